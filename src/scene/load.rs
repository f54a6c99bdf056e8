//! One entry point for "give me a scene": a built-in generator name, a glTF
//! file, or a directory holding exactly one glTF file.

use super::generate::{generate, NAMES};
use super::{load_gltf, Scene, SceneError};
use std::path::{Path, PathBuf};

fn is_gltf(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// Resolves `spec`: `cornell`, `hairball`, `plane` generate in memory (a file or
/// directory of that name in the working directory does not shadow them; write
/// `./cornell` for that); a `.gltf`/`.glb` path loads it; a directory loads the
/// single `.gltf`/`.glb` inside it.
///
/// `cornell:alpha=A` is the Cornell box with both spheres at GGX roughness
/// α_GGX = A ∈ [0, 1] (appendix C's sweep; generate::cornell).
///
/// `procedural:[SEED:]SPEC` loads SPEC and replaces every material by a
/// library material graph picked at random with SEED (default 1), e.g.
/// `procedural:../shared/scenes/sponza` (issue 17's procedural Sponza;
/// `materials::library::assign_random`). `procedural-uv:[SEED:]SPEC`
/// picks the same graphs in texture space (`library::texture_space`: the
/// uv drives them, so the memoization cache can key them by texel).
/// `procedural-heavy-uv:[SEED:]SPEC` makes the same picks from the
/// compute-heavy variants (`library::HEAVY`) in texture space.
///
/// `spin:NODE:SPEC` loads the static scene SPEC and makes the instances of
/// its glTF node NODE turn about the vertical through their node origin
/// (one turn in 4 s; `generate::animated::spin_named_instances`), e.g.
/// `spin:VaseRound.006:../shared/scenes/sponza`, Sponza with one animated instance.
pub fn load_scene(spec: &str) -> Result<Scene, SceneError> {
    let mut scene = load_scene_as_specified(spec)?;
    // Graphs attached after import (procedural:, the material balls) need
    // their tangents too (glTF files have theirs from load_gltf).
    super::mesh_ops::generate_graph_normal_tangents(&mut scene);
    Ok(scene)
}

fn load_scene_as_specified(spec: &str) -> Result<Scene, SceneError> {
    if let Some(rest) = spec.strip_prefix("spin:") {
        let (node, inner) = rest.split_once(':').ok_or_else(|| {
            SceneError::invalid(
                Path::new(spec),
                "expected spin:NODE:SCENE (a glTF node name, then a scene)",
            )
        })?;
        let mut scene = load_scene(inner)?;
        super::generate::animated::spin_named_instances(&mut scene, node)
            .map_err(|why| SceneError::invalid(Path::new(spec), why))?;
        scene.validate()?;
        return Ok(scene);
    }
    let procedural = spec
        .strip_prefix("procedural:")
        .map(|r| (r, false, false))
        .or_else(|| {
            spec.strip_prefix("procedural-uv:")
                .map(|r| (r, true, false))
        })
        .or_else(|| {
            spec.strip_prefix("procedural-heavy-uv:")
                .map(|r| (r, true, true))
        });
    if let Some((rest, texture_space, heavy)) = procedural {
        let (seed, inner) = match rest.split_once(':') {
            Some((n, inner)) if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) => (
                n.parse::<u64>().map_err(|e| {
                    SceneError::invalid(Path::new(spec), format!("bad seed `{n}` ({e})"))
                })?,
                inner,
            ),
            _ => (1, rest),
        };
        let mut scene = load_scene(inner)?;
        crate::materials::library::assign_random_from(&mut scene, seed, texture_space, heavy);
        scene.validate()?;
        return Ok(scene);
    }
    if let Some(opts) = spec.strip_prefix("cornell:") {
        let bad = |why: &str| {
            SceneError::invalid(
                Path::new(spec),
                format!("{why}; expected cornell:alpha=A with the spheres' GGX alpha A in [0, 1]"),
            )
        };
        let a = opts
            .strip_prefix("alpha=")
            .ok_or_else(|| bad("unknown Cornell box option"))?;
        let alpha: f32 = a.parse().map_err(|_| bad("alpha is not a number"))?;
        if !(0.0..=1.0).contains(&alpha) {
            return Err(bad("alpha out of range"));
        }
        let scene = super::generate::cornell::cornell_with_sphere_alpha(alpha);
        scene.validate()?;
        return Ok(scene);
    }
    if let Some(scene) = generate(spec) {
        return Ok(scene);
    }
    let path = Path::new(spec);
    if path.is_dir() {
        let entries = std::fs::read_dir(path).map_err(|e| SceneError::io(path, e))?;
        let mut found: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file() && is_gltf(p))
            .collect();
        found.sort();
        return match found.as_slice() {
            [one] => load_gltf(one),
            [] => Err(SceneError::invalid(
                path,
                "directory contains no .gltf or .glb file",
            )),
            many => Err(SceneError::invalid(
                path,
                format!(
                    "directory contains {} glTF files ({}); name one of them",
                    many.len(),
                    many.iter()
                        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )),
        };
    }
    if is_gltf(path) {
        return load_gltf(path);
    }
    if path.exists() {
        return Err(SceneError::invalid(path, "not a .gltf or .glb file"));
    }
    Err(SceneError::invalid(
        path,
        format!(
            "no such file or directory, and not a built-in scene ({})",
            NAMES.join(", ")
        ),
    ))
}
