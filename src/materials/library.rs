//! The shipped graph library: `scenes/materials/*.mtlx`, one material per
//! file (a nodegraph whose outputs are named after the material inputs they
//! feed, see `binding.rs`).

use super::document::Document;
use super::error::GraphError;
use super::graph::Graph;
use std::path::PathBuf;

/// The shipped files' names and texts, embedded (the generated scenes use
/// them wherever the binary runs).
pub const EMBEDDED: &[(&str, &str)] = &[
    (
        "bricks.mtlx",
        include_str!("../../scenes/materials/bricks.mtlx"),
    ),
    (
        "cardboard.mtlx",
        include_str!("../../scenes/materials/cardboard.mtlx"),
    ),
    (
        "concrete.mtlx",
        include_str!("../../scenes/materials/concrete.mtlx"),
    ),
    (
        "fabric.mtlx",
        include_str!("../../scenes/materials/fabric.mtlx"),
    ),
    (
        "granite.mtlx",
        include_str!("../../scenes/materials/granite.mtlx"),
    ),
    (
        "lava.mtlx",
        include_str!("../../scenes/materials/lava.mtlx"),
    ),
    (
        "leather.mtlx",
        include_str!("../../scenes/materials/leather.mtlx"),
    ),
    (
        "marble.mtlx",
        include_str!("../../scenes/materials/marble.mtlx"),
    ),
    (
        "rust.mtlx",
        include_str!("../../scenes/materials/rust.mtlx"),
    ),
    (
        "terrazzo.mtlx",
        include_str!("../../scenes/materials/terrazzo.mtlx"),
    ),
    (
        "tiles.mtlx",
        include_str!("../../scenes/materials/tiles.mtlx"),
    ),
    (
        "wood.mtlx",
        include_str!("../../scenes/materials/wood.mtlx"),
    ),
];

/// The compute-heavy variants (`scenes/materials/heavy/`, written by
/// `scripts/material_library.py … --heavy`): the same materials with every
/// position or texcoord domain-warped by two 8-octave vector3 fractal
/// layers and every fractal six octaves more (at most 16): graphs whose
/// evaluation dominates a frame, as the thesis's Classroom graphs do (the
/// `procedural-heavy-uv:` scenes; the memoization benchmark's heavy case).
pub const HEAVY: &[(&str, &str)] = &[
    (
        "bricks.mtlx",
        include_str!("../../scenes/materials/heavy/bricks_heavy.mtlx"),
    ),
    (
        "cardboard.mtlx",
        include_str!("../../scenes/materials/heavy/cardboard_heavy.mtlx"),
    ),
    (
        "concrete.mtlx",
        include_str!("../../scenes/materials/heavy/concrete_heavy.mtlx"),
    ),
    (
        "fabric.mtlx",
        include_str!("../../scenes/materials/heavy/fabric_heavy.mtlx"),
    ),
    (
        "granite.mtlx",
        include_str!("../../scenes/materials/heavy/granite_heavy.mtlx"),
    ),
    (
        "lava.mtlx",
        include_str!("../../scenes/materials/heavy/lava_heavy.mtlx"),
    ),
    (
        "leather.mtlx",
        include_str!("../../scenes/materials/heavy/leather_heavy.mtlx"),
    ),
    (
        "marble.mtlx",
        include_str!("../../scenes/materials/heavy/marble_heavy.mtlx"),
    ),
    (
        "rust.mtlx",
        include_str!("../../scenes/materials/heavy/rust_heavy.mtlx"),
    ),
    (
        "terrazzo.mtlx",
        include_str!("../../scenes/materials/heavy/terrazzo_heavy.mtlx"),
    ),
    (
        "tiles.mtlx",
        include_str!("../../scenes/materials/heavy/tiles_heavy.mtlx"),
    ),
    (
        "wood.mtlx",
        include_str!("../../scenes/materials/heavy/wood_heavy.mtlx"),
    ),
];

/// The graph of an embedded file (its one nodegraph), named `materials/<file>` in errors.
pub fn embedded(file: &str) -> Result<Graph, GraphError> {
    let text = EMBEDDED
        .iter()
        .find(|(n, _)| *n == file)
        .map(|(_, t)| *t)
        .ok_or_else(|| GraphError::file(file, "not a shipped library file"))?;
    let doc = Document::parse(&format!("materials/{file}"), text)?;
    let name = doc
        .graphs
        .first()
        .map(|g| g.name.clone())
        .ok_or_else(|| GraphError::file(file, "has no nodegraph"))?;
    Graph::build(&doc, &name, &[])
}

/// The library's folder.
pub fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/materials")
}

/// Every shipped .mtlx file, sorted by name: the library's, then the
/// heavy variants'.
pub fn files() -> Vec<PathBuf> {
    let mut v = mtlx_in(&dir());
    v.extend(mtlx_in(&dir().join("heavy")));
    v
}

fn mtlx_in(d: &std::path::Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(d)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e == "mtlx"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Every graph of every shipped file.
pub fn load_all() -> Result<Vec<Graph>, GraphError> {
    let mut out = Vec::new();
    for f in files() {
        let doc = Document::load(&f)?;
        out.extend(Graph::build_all(&doc, &[])?);
    }
    Ok(out)
}

/// The library files a random assignment picks from: all but `lava.mtlx`
/// (emissive; left out when any emissive material switched the default
/// lighting off; bound with emissive factor 1 it is now a glow, see
/// `scene::default_lighting`).
pub fn pickable() -> impl Iterator<Item = &'static (&'static str, &'static str)> {
    pickable_in(EMBEDDED)
}

fn pickable_in(
    set: &'static [(&'static str, &'static str)],
) -> impl Iterator<Item = &'static (&'static str, &'static str)> {
    set.iter().filter(|(n, _)| *n != "lava.mtlx")
}

/// Replaces every material of `scene` by a library graph picked at random
/// with `seed` (SplitMix64 of seed and material index), as the papers'
/// PARTYTUG/Classroom setups do. The textures the graphs replace are no
/// longer sampled (alpha-masked materials become opaque); alpha mode,
/// double-sidedness, transmission and ior stay.
pub fn assign_random(scene: &mut crate::scene::Scene, seed: u64) {
    assign_random_in(scene, seed, false)
}

/// A library graph in texture space (the thesis's materials are
/// procedural textures over the uv; the library's are object-space solids):
/// every `position` node reads the uv as (u, v, 0) instead, and a `normal`
/// output made by a final `normalmap` node (with the surface's own N, T, B
/// and unit scale) becomes a `normal_tangent` output of the node's input,
/// which material_at maps with the surface's frame as it does a normal
/// texture. The result reads only the uv unless other nodes read the
/// geometry (`Graph::reads_only_uv`), so the memoization cache can key it
/// by texel. A text rewrite, so a scene using it writes and reloads as is.
pub fn texture_space(file: &str, text: &str) -> Result<String, GraphError> {
    let doc = Document::parse(file, text)?;
    let mut out = text.replace("<position ", "<texcoord ");
    for g in &doc.graphs {
        let Some(o) = g.outputs.iter().find(|o| o.name == "normal") else {
            continue;
        };
        let Some(nm) = &o.nodename else { continue };
        let Some(node) = g
            .nodes
            .iter()
            .find(|n| &n.name == nm && n.category == "normalmap")
        else {
            continue;
        };
        let plain = node.inputs.iter().all(|i| match i.name.as_str() {
            "in" => i.nodename.is_some(),
            "scale" => matches!(i.value.as_deref(), Some("1" | "1.0" | "1.0, 1.0")),
            _ => false,
        });
        let input = node
            .inputs
            .iter()
            .find(|i| i.name == "in")
            .and_then(|i| i.nodename.as_ref());
        let (true, Some(input)) = (plain, input) else {
            continue;
        };
        let ty = o.ty.as_deref().unwrap_or("vector3");
        let from = format!(r#"<output name="normal" type="{ty}" nodename="{nm}" />"#);
        let to = format!(r#"<output name="normal_tangent" type="{ty}" nodename="{input}" />"#);
        if out.matches(&from).count() == 1 {
            out = out.replace(&from, &to);
        }
    }
    Ok(out)
}

/// [`assign_random`], with the graphs in texture space when `texture_space`
/// ([`texture_space`]; the `procedural-uv:` scenes).
pub fn assign_random_in(scene: &mut crate::scene::Scene, seed: u64, texture_space: bool) {
    assign_random_from(scene, seed, texture_space, false)
}

/// [`assign_random_in`] from the library (`heavy` false) or its
/// compute-heavy variants ([`HEAVY`]; the same picks, material for
/// material, so the two scenes differ only in the graphs' cost).
pub fn assign_random_from(
    scene: &mut crate::scene::Scene,
    seed: u64,
    texture_space: bool,
    heavy: bool,
) {
    let files: Vec<_> = pickable_in(if heavy { HEAVY } else { EMBEDDED }).collect();
    let sub = if heavy { "heavy/" } else { "" };
    for mi in 0..scene.materials.len() {
        let mut z = seed.wrapping_add((mi as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        let (file, text) = files[(z % files.len() as u64) as usize];
        let (path, text) = if texture_space {
            let t = self::texture_space(file, text)
                .unwrap_or_else(|e| panic!("library graph {file}: {e}"));
            (format!("materials/{sub}uv/{file}"), t)
        } else {
            (format!("materials/{sub}{file}"), text.to_string())
        };
        let mut m = scene.materials[mi].clone();
        m.base_color_texture = None;
        m.metallic_roughness_texture = None;
        m.normal_texture = None;
        m.emissive_texture = None;
        scene
            .graphs
            .attach_mtlx(mi as u32, &mut m, &path, &text)
            .unwrap_or_else(|e| panic!("library graph {file}: {e}"));
        scene.materials[mi] = m;
    }
}
