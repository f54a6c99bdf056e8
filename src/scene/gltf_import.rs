//! glTF 2.0 import (`.gltf` + `.bin` + images, or `.glb`) into a [`Scene`].
//!
//! The pipeline, and what it does with imperfect files:
//!
//! 1. The JSON is parsed with `serde_json` first. Required extensions that only
//!    change appearance (`AMD_split_roughnessMetallic`, `MSFT_texture_dds`, any
//!    `KHR_materials_*`, …) are removed from `extensionsRequired` with a warning,
//!    because the `gltf` crate refuses documents whose required extensions it
//!    does not know. A required extension that changes geometry
//!    (`KHR_draco_mesh_compression`, `EXT_meshopt_compression`, …) or that we do
//!    not recognise is an error.
//!    On the same raw JSON, before the typed parse (which would refuse the
//!    whole document): a primitive without POSITION is removed with a
//!    warning (glTF 2.0 §3.7.2.1: clients SHOULD skip it), and animation
//!    channels an extension defines (`KHR_animation_pointer`) or that target
//!    no node are removed with one warning per animation (`gltf_animation`).
//! 2. The document is validated by the `gltf` crate's rules (dangling
//!    indices are errors), except that an accessor with neither `bufferView`
//!    nor `sparse` is accepted and reads as zeros (glTF 2.0 §5.1.1).
//! 3. Buffers and accessors are read by `gltf_buffers` with checked ranges.
//! 4. The default scene's node tree is flattened into [`Instance`]s; a glTF mesh
//!    used by several nodes maps to the same [`Mesh`]es (instancing). Cycles and
//!    absurd depths are errors. A node with `EXT_mesh_gpu_instancing` (read from
//!    the raw JSON, `gltf_instancing`) yields one [`Instance`] per element of its
//!    TRANSLATION/ROTATION/SCALE accessors, transform node_world × T·R·S, all
//!    sharing the node's meshes; its children are not instanced.
//! 5. Every triangle primitive becomes one [`Mesh`]: TRIANGLES as is,
//!    TRIANGLE_STRIP and TRIANGLE_FAN converted to lists with the winding the
//!    glTF topology rules define; points and lines are skipped with a warning.
//!    Missing indices are generated, missing normals are generated
//!    (area-weighted). The mesh's uvs are the uv set its material's textures
//!    read (`texCoord`, or the `KHR_texture_transform` override) with that
//!    extension's offset, rotation and scale applied (`gltf_uv`: one uv set
//!    and one transform per material; slots that disagree are warned); a
//!    missing uv set is zeros (warned where the material has textures).
//!    Missing tangents are generated with MikkTSpace
//!    (`mesh_ops::generate_tangents`, which may split vertices, on the
//!    transformed uvs) when the material has a normal map; supplied tangents
//!    are kept, turned in the tangent plane to follow a transform's rotation
//!    (and flipped by a mirroring scale).
//!    **Morph targets**: the default weights (`node.weights`, else
//!    `mesh.weights`) are applied to POSITION, NORMAL and TANGENT (sparse
//!    accessors too) at import, normals and tangents renormalised; a glTF mesh
//!    used with different weights becomes different [`Mesh`]es. Animated
//!    weights are not supported (one warning per animation, `gltf_animation`).
//!    **Vertices with a NaN/Inf attribute**: every triangle using such a vertex
//!    is dropped and one warning per primitive names the mesh and the count.
//! 6. Images are decoded once each; a missing/undecodable image is a warning and
//!    the material falls back to its factor (an image naming neither `uri`
//!    nor `bufferView`, or a `bufferView` without `mimeType`, is an error:
//!    the gltf crate would panic on it). Each texture reference carries its
//!    glTF sampler (wrap modes, filters); a sampler field with a value glTF does
//!    not define is a warning and that field's default is used.
//!
//! The whole import runs under `catch_unwind` as defence in depth: should a
//! dependency panic on a malformed file, the caller gets an error naming it.

use super::gltf_animation::{import_animations, prepare_animation_json};
use super::gltf_buffers::{load_buffers, split_container, AccessorReader};
use super::gltf_instancing::{instancing_json, NodeInstancing, INSTANCING_EXTENSION};
use super::gltf_textures::{decode_images, patch_invalid_samplers, texture_sampler, ImageUses};
use super::gltf_uv::{
    choose, texture_transforms_json, SlotUv, UvAffine, UvChannels, UvChoice, UvTransform,
    BASE_COLOR_SLOT, CLEARCOAT_NORMAL_SLOT, EMISSIVE_SLOT, NORMAL_SLOT, ORDER, SLOTS, SLOT_COUNT,
    TEXTURE_TRANSFORM,
};
use super::mesh_ops::{
    drop_non_finite_triangles, fan_to_triangles, flat_normals, generate_normals,
    generate_tangents_for, generate_tangents_from, strip_to_triangles,
};
use super::{
    AlphaMode, Clearcoat, Instance, Light, LightKind, Material, Mesh, Scene, SceneCamera,
    SceneError, TextureEncoding, TextureRef, Volume,
};
use glam::{Mat4, Vec2, Vec3, Vec4};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;

/// Required extensions that only affect appearance; ignoring them degrades
/// shading, never geometry. (`KHR_materials_*` are accepted by prefix.)
const APPEARANCE_ONLY_EXTENSIONS: &[&str] = &[
    "AMD_split_roughnessMetallic",
    "MSFT_texture_dds",
    "KHR_materials_variants",
    "EXT_texture_webp",
    "KHR_texture_basisu",
    "MSFT_packing_normalRoughnessMetallic",
    "MSFT_packing_occlusionRoughnessMetallic",
];

/// Node hierarchies deeper than this are rejected (real files stay below ~30).
const MAX_NODE_DEPTH: usize = 256;
/// Upper bound on instances a node tree may expand to (guards DAG blow-ups).
const MAX_INSTANCES: usize = 4_000_000;

/// Loads a `.gltf` or `.glb` file. See the module documentation for how
/// imperfect files are handled; non-fatal problems end up in `Scene::warnings`.
pub fn load_gltf(path: &Path) -> Result<Scene, SceneError> {
    match std::panic::catch_unwind(|| load_gltf_unguarded(path)) {
        Ok(result) => result,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(SceneError::invalid(
                path,
                format!("malformed glTF: the importer failed internally ({what})"),
            ))
        }
    }
}

fn load_gltf_unguarded(path: &Path) -> Result<Scene, SceneError> {
    let bytes = crate::input::read(path).map_err(|e| SceneError::io(path, e))?;
    let container = split_container(path, bytes)?;
    let mut warnings = Vec::new();
    let prepared = parse_document(path, &container.json, &mut warnings)?;
    let doc = prepared.doc;
    let buffers = load_buffers(&doc, path, container.bin)?;
    let mut importer = Importer {
        path,
        doc: &doc,
        reader: AccessorReader {
            path,
            buffers: &buffers,
        },
        scene: Scene {
            source: path.to_path_buf(),
            warnings,
            ..Default::default()
        },
        mesh_map: HashMap::new(),
        instancing: prepared.instancing,
        instance_offsets: Vec::new(),
        morph_warnings: HashSet::new(),
        default_material: None,
        instances_budget: MAX_INSTANCES,
        split_rm_materials: prepared.split_rm,
        unlit_materials: prepared.unlit,
        sourceless_textures: prepared.sourceless,
        slot_uvs: prepared.slot_uvs,
        primitive_indices: prepared.primitive_indices,
        material_uvs: Vec::new(),
        missing_uvs: BTreeMap::new(),
        record_paths: doc.animations().len() > 0,
        node_path: Vec::new(),
        instance_paths: Vec::new(),
        too_bright: None,
    };
    importer.import_materials(&buffers);
    if let Some(m) = importer.too_bright.take() {
        return Err(SceneError::invalid(path, m));
    }
    // Material graphs (KHR_texture_procedurals, or a .mtlx in a material's
    // extras): read from the raw JSON, the gltf crate knows neither.
    if has_material_graphs(&container.json) {
        let root: serde_json::Value = serde_json::from_slice(&container.json)
            .map_err(|e| SceneError::invalid(path, format!("invalid JSON: {e}")))?;
        check_materialx_files(path, &root)?;
        importer.scene.graphs =
            crate::materials::binding::from_gltf_json(path, &root, &mut importer.scene.materials)
                .map_err(|e| SceneError::invalid(path, e))?;
        let w: Vec<String> = importer.scene.graphs.warnings().cloned().collect();
        importer.scene.warnings.extend(w);
        importer.graph_uv_channels()?;
    }
    importer.import_nodes()?;
    importer.warn_missing_uvs();
    let instance_paths = std::mem::take(&mut importer.instance_paths);
    let instance_offsets = std::mem::take(&mut importer.instance_offsets);
    let mut scene = importer.scene;
    super::mesh_ops::generate_graph_normal_tangents(&mut scene);
    scene.animation = import_animations(
        &doc,
        &importer.reader,
        path,
        instance_paths,
        instance_offsets,
        &mut scene.warnings,
    )?;
    scene
        .validate()
        .map_err(|e| with_load_warnings(e, &scene.warnings))?;
    Ok(scene)
}

/// A scene that fails validation after the importer warned (every triangle
/// dropped for NaN vertices, every primitive points or lines: "the scene has
/// no triangles") keeps the warnings that explain it in its one error line,
/// without the file name each repeats; they were dropped with the scene
/// until session 47.
fn with_load_warnings(e: SceneError, warnings: &[String]) -> SceneError {
    match e {
        SceneError::Invalid { path, message } if !warnings.is_empty() => {
            let prefix = format!("{}: ", path.display());
            let why: Vec<&str> = warnings
                .iter()
                .map(|w| w.strip_prefix(&prefix).unwrap_or(w))
                .collect();
            SceneError::Invalid {
                path,
                message: format!("{message} (while loading: {})", why.join("; ")),
            }
        }
        e => e,
    }
}

/// A material's `extras.materialx.file` (read by `materials::binding`,
/// relative to the glTF's folder) must be a regular file when it exists:
/// `/dev/zero` was read until memory ran out. A missing file is left to
/// the binding, which reports it.
fn check_materialx_files(path: &Path, root: &serde_json::Value) -> Result<(), SceneError> {
    let Some(ms) = root.get("materials").and_then(|m| m.as_array()) else {
        return Ok(());
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    for (i, m) in ms.iter().enumerate() {
        let Some(file) = m.pointer("/extras/materialx/file").and_then(|f| f.as_str()) else {
            continue;
        };
        let mtlx = dir.join(file);
        if std::fs::metadata(&mtlx).is_ok() {
            crate::input::check_regular(&mtlx).map_err(|e| {
                SceneError::invalid(
                    path,
                    format!(
                        "materials[{i}]: extras.materialx.file '{}': cannot read: {e}",
                        mtlx.display()
                    ),
                )
            })?;
        }
    }
    Ok(())
}

/// `[1.000e38, 2.000e0, inf]`: a colour in messages, readable at any magnitude.
fn exp3(v: Vec3) -> String {
    format!("[{:.3e}, {:.3e}, {:.3e}]", v.x, v.y, v.z)
}

/// Whether the JSON may bind material graphs (a cheap test before parsing it again).
fn has_material_graphs(json: &[u8]) -> bool {
    let has = |pat: &[u8]| json.windows(pat.len()).any(|w| w == pat);
    has(b"\"materialx\"") || has(b"KHR_texture_procedurals")
}

/// JSON → validated `gltf::Document`, after filtering `extensionsRequired`.
fn parse_document(
    path: &Path,
    json: &[u8],
    warnings: &mut Vec<String>,
) -> Result<Prepared, SceneError> {
    // glTF's JSON must not start with a UTF-8 byte-order mark, which
    // loaders may ignore (glTF 2.0, "JSON encoding"): ignored with a
    // warning (until session 49 "invalid JSON … line 1 column 1", which did
    // not name it).
    let json = match json.strip_prefix(b"\xEF\xBB\xBF") {
        Some(rest) => {
            warnings.push(format!(
                "{}: the JSON starts with a UTF-8 byte-order mark, which glTF does not allow; ignored",
                path.display()
            ));
            rest
        }
        None => json,
    };
    let mut value: serde_json::Value = serde_json::from_slice(json)
        .map_err(|e| SceneError::invalid(path, format!("invalid JSON: {e}")))?;
    // One warning per feature used that is not implemented (gltf_features.rs).
    warnings.extend(super::gltf_features::warn_unsupported(path, &value));
    let Some(obj) = value.as_object_mut() else {
        return Err(SceneError::invalid(
            path,
            "invalid glTF: the top-level JSON value is not an object",
        ));
    };
    if let Some(required) = obj.get_mut("extensionsRequired") {
        let list = required.as_array_mut().ok_or_else(|| {
            SceneError::invalid(path, "invalid glTF: extensionsRequired is not an array")
        })?;
        let mut kept = Vec::new();
        for ext in list.drain(..) {
            let name = ext.as_str().ok_or_else(|| {
                SceneError::invalid(
                    path,
                    "invalid glTF: extensionsRequired has a non-string entry",
                )
            })?;
            if gltf::json::extensions::ENABLED_EXTENSIONS.contains(&name) {
                kept.push(ext);
            } else if name == INSTANCING_EXTENSION {
                // Read from the JSON (gltf_instancing; the crate does not know it).
            } else if name == TEXTURE_TRANSFORM {
                // Applied to the mesh uvs at import (gltf_uv; read from the JSON).
            } else if name == "KHR_texture_procedurals" {
                // Read from the JSON by materials::binding (the crate does not know it).
            } else if name == "KHR_mesh_quantization" {
                // Decoded by gltf_buffers (read_component: every integer and
                // normalized component type); the crate's list lacks it, so
                // a file that requires it (gltfpack's quantized output does)
                // was refused until session 48.
            } else if name == "KHR_xmp_json_ld" {
                // Metadata only.
            } else if APPEARANCE_ONLY_EXTENSIONS.contains(&name)
                || name.starts_with("KHR_materials_")
            {
                // A feature the table knows is warned by its walk (above) or
                // by the import code where it drops it, naming the items and
                // what is done instead: one warning, not two.
                if super::gltf_features::feature(name).is_some() {
                    continue;
                }
                warnings.push(format!(
                    "{}: required extension {name} is not supported; it only affects appearance, \
                     so it is ignored",
                    path.display()
                ));
            } else {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "requires extension {name}, which stereocache does not support \
                         (it may change geometry); convert the file without it, e.g. with \
                         `gltf-transform` or Blender"
                    ),
                ));
            }
        }
        *list = kept;
    }
    let split_rm = obj
        .get("materials")
        .and_then(|m| m.as_array())
        .map_or(0, |ms| {
            ms.iter()
                .filter(|m| {
                    m.pointer("/extensions/AMD_split_roughnessMetallic")
                        .is_some()
                })
                .count()
        });
    // KHR_materials_unlit, per material (read on the raw JSON like the above).
    let unlit = obj
        .get("materials")
        .and_then(|m| m.as_array())
        .map_or_else(Vec::new, |ms| {
            ms.iter()
                .map(|m| m.pointer("/extensions/KHR_materials_unlit").is_some())
                .collect()
        });
    let sourceless = patch_sourceless_textures(obj);
    warnings.extend(patch_invalid_samplers(path, obj));
    check_position_accessors(path, obj)?;
    check_structure(path, obj, warnings)?;
    super::gltf_textures::check_image_sources(path, obj)?;
    let primitive_indices = drop_positionless_primitives(path, obj, warnings);
    let instancing = instancing_json(path, obj, warnings)?;
    let slot_uvs = texture_transforms_json(path, obj, warnings);
    prepare_animation_json(path, obj, warnings)?;
    let root: gltf::json::Root = serde_json::from_value(value)
        .map_err(|e| SceneError::invalid(path, format!("invalid glTF structure: {e}")))?;
    let errors = validation_errors(&root);
    if !errors.is_empty() {
        let shown: Vec<String> = errors
            .iter()
            .take(4)
            .map(|(p, err)| format!("{p}: {err}"))
            .collect();
        let more = errors.len().saturating_sub(4);
        let more = if more > 0 {
            format!(" (and {more} more)")
        } else {
            String::new()
        };
        return Err(SceneError::invalid(
            path,
            format!("invalid glTF: {}{more}", shown.join("; ")),
        ));
    }
    let doc = gltf::Document::from_json_without_validation(root);
    Ok(Prepared {
        doc,
        split_rm,
        unlit,
        sourceless,
        instancing,
        slot_uvs,
        primitive_indices,
    })
}

/// The `gltf` crate's validation of `root` (what `Document::from_json`
/// runs), less its one departure from the specification: it requires an
/// accessor without `sparse` to have a `bufferView`, but glTF 2.0 §5.1.1
/// (`accessor.bufferView`): "When undefined, the accessor MUST be
/// initialized with zeros; `sparse` property or extensions MAY override
/// zeros with actual values." `gltf_buffers` reads such an accessor as
/// zeros.
fn validation_errors(
    root: &gltf::json::Root,
) -> Vec<(gltf::json::Path, gltf::json::validation::Error)> {
    use gltf::json::validation::{Error, Validate};
    let zeros: HashSet<String> = root
        .accessors
        .iter()
        .enumerate()
        .filter(|(_, a)| a.buffer_view.is_none() && a.sparse.is_none())
        .map(|(i, _)| format!("accessors[{i}].bufferView"))
        .collect();
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |p, e| {
        let p = p();
        if !(matches!(e, Error::Missing) && zeros.contains(p.as_str())) {
            errors.push((p, e));
        }
    });
    errors
}

/// Removes the primitives that have no POSITION attribute, one warning
/// each: glTF 2.0 §3.7.2.1, "When positions are not specified, client
/// implementations SHOULD skip primitive's rendering" (the `gltf` crate
/// would refuse the whole document). Returns, for each mesh that lost any,
/// the file's index of each primitive kept (for messages).
fn drop_positionless_primitives(
    path: &Path,
    obj: &mut serde_json::Map<String, serde_json::Value>,
    warnings: &mut Vec<String>,
) -> HashMap<usize, Vec<usize>> {
    let mut kept_indices = HashMap::new();
    let Some(meshes) = obj.get_mut("meshes").and_then(|m| m.as_array_mut()) else {
        return kept_indices;
    };
    for (mi, mesh) in meshes.iter_mut().enumerate() {
        let name = mesh.get("name").and_then(|n| n.as_str()).map(str::to_owned);
        let Some(prims) = mesh.get_mut("primitives").and_then(|p| p.as_array_mut()) else {
            continue;
        };
        // Only objects: anything else is left to the typed parse's error.
        let has_position =
            |p: &serde_json::Value| !p.is_object() || p.pointer("/attributes/POSITION").is_some();
        if prims.iter().all(has_position) {
            continue;
        }
        let mut kept = Vec::new();
        for (pi, p) in std::mem::take(prims).into_iter().enumerate() {
            if has_position(&p) {
                prims.push(p);
                kept.push(pi);
            } else {
                warnings.push(format!(
                    "{}: {} primitive {pi} has no POSITION attribute; skipped (glTF §3.7.2.1)",
                    path.display(),
                    named("mesh", mi, name.as_deref())
                ));
            }
        }
        kept_indices.insert(mi, kept);
    }
    kept_indices
}

/// `gltf-json` 1.4's primitive validation indexes `accessors[POSITION]`
/// before checking that the index exists (it panics on a dangling POSITION),
/// so that one reference is checked here on the raw JSON first. Found by
/// `tests/fuzz_inputs.rs`; regression file `tests/data/fuzz/dangling_position.gltf`.
fn check_position_accessors(
    path: &Path,
    obj: &serde_json::Map<String, serde_json::Value>,
) -> Result<(), SceneError> {
    let accessors = obj
        .get("accessors")
        .and_then(|a| a.as_array())
        .map_or(0, Vec::len);
    let quantized = obj
        .get("extensionsUsed")
        .and_then(|u| u.as_array())
        .is_some_and(|u| u.iter().any(|e| e == "KHR_mesh_quantization"));
    let Some(meshes) = obj.get("meshes").and_then(|m| m.as_array()) else {
        return Ok(());
    };
    for (mi, mesh) in meshes.iter().enumerate() {
        let Some(prims) = mesh.get("primitives").and_then(|p| p.as_array()) else {
            continue;
        };
        for (pi, prim) in prims.iter().enumerate() {
            let Some(pos) = prim.pointer("/attributes/POSITION") else {
                continue;
            };
            // Non-integers are reported by the typed parse that follows.
            if let Some(k) = pos.as_u64() {
                if k >= accessors as u64 {
                    return Err(SceneError::invalid(
                        path,
                        format!(
                            "invalid glTF: meshes[{mi}].primitives[{pi}].attributes.POSITION \
                             refers to accessor {k}, but the file has {accessors} accessors"
                        ),
                    ));
                }
                // Core glTF positions are FLOAT (5126); integer ones need
                // KHR_mesh_quantization, declared (they were read as bytes
                // without it: a scene 191 m across; an audit's finding).
                let ty = obj
                    .get("accessors")
                    .and_then(|a| a.get(k as usize))
                    .and_then(|a| a.get("componentType"))
                    .and_then(|t| t.as_u64());
                if ty.is_some_and(|t| t != 5126) && !quantized {
                    return Err(SceneError::invalid(
                        path,
                        format!(
                            "invalid glTF: meshes[{mi}].primitives[{pi}].attributes.POSITION \
                             (accessor {k}) has componentType {}, not FLOAT (5126); integer \
                             positions need KHR_mesh_quantization in extensionsUsed",
                            ty.unwrap_or(0)
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// What the `gltf` crate does not check of glTF 2.0's structure (an
/// audit's findings: each was accepted without a word): `asset.version`
/// must be 2.x; a node has at most one parent (the hierarchy is a set of
/// disjoint trees; a node under two parents was instanced twice); a node's
/// `rotation` is a unit quaternion (a zero one is refused; another length
/// is normalised with a warning: the crate's matrix of `[0, 0, 0, 5]`
/// scaled the node 25×).
fn check_structure(
    path: &Path,
    obj: &mut serde_json::Map<String, serde_json::Value>,
    warnings: &mut Vec<String>,
) -> Result<(), SceneError> {
    use serde_json::Value;
    let bad = |m: String| SceneError::invalid(path, format!("invalid glTF: {m}"));
    if let Some(v) = obj
        .get("asset")
        .and_then(|a| a.get("version"))
        .and_then(Value::as_str)
    {
        if v.split('.').next() != Some("2") {
            return Err(bad(format!(
                "asset.version is '{v}': stereocache reads glTF 2.x"
            )));
        }
    }
    let Some(Value::Array(nodes)) = obj.get_mut("nodes") else {
        return Ok(());
    };
    let mut parent: Vec<Option<usize>> = vec![None; nodes.len()];
    for (i, n) in nodes.iter().enumerate() {
        let Some(children) = n.get("children").and_then(Value::as_array) else {
            continue;
        };
        for c in children.iter().filter_map(Value::as_u64) {
            let Some(slot) = parent.get_mut(c as usize) else {
                continue; // out of range: the typed validation names it
            };
            match *slot {
                Some(p) if p != i => {
                    return Err(bad(format!(
                        "node {c} is a child of nodes {p} and {i}; a node has at most one parent"
                    )))
                }
                _ => *slot = Some(i),
            }
        }
    }
    for (i, n) in nodes.iter_mut().enumerate() {
        let Some(Value::Array(q)) = n.get_mut("rotation") else {
            continue;
        };
        let v: Vec<f64> = q.iter().filter_map(Value::as_f64).collect();
        if v.len() != 4 || !v.iter().all(|x| x.is_finite()) {
            continue; // the typed parse and the transform checks name it
        }
        let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if len == 0.0 {
            return Err(bad(format!(
                "node {i}: rotation [0, 0, 0, 0] is no rotation (a unit quaternion is required)"
            )));
        }
        // (A rounding-sized deviation is left as written.)
        if (len - 1.0).abs() > 1e-3 {
            warnings.push(format!(
                "{}: node {i}: rotation {v:?} is not a unit quaternion (length {len:.4}); normalised",
                path.display()
            ));
            *q = v.iter().map(|x| Value::from(x / len)).collect();
        }
    }
    // A cycle (each node one parent, so walking up from a node either ends
    // at a root or comes back round): named as the traversal names it.
    let mut state = vec![0u8; parent.len()]; // 0 new, 1 on the walk, 2 ends at a root
    for start in 0..parent.len() {
        let mut walk = Vec::new();
        let mut n = Some(start);
        while let Some(k) = n {
            match state[k] {
                2 => break,
                1 => {
                    return Err(bad(format!(
                        "node {k} is its own ancestor: the node hierarchy has a cycle"
                    )))
                }
                _ => {
                    state[k] = 1;
                    walk.push(k);
                    n = parent[k];
                }
            }
        }
        for k in walk {
            state[k] = 2;
        }
    }
    // A scene's root nodes have no parent (else they are instanced twice).
    if let Some(Value::Array(scenes)) = obj.get("scenes") {
        for (si, sc) in scenes.iter().enumerate() {
            for n in sc
                .get("nodes")
                .and_then(Value::as_array)
                .into_iter()
                .flatten()
            {
                let Some(n) = n.as_u64() else { continue };
                if let Some(Some(p)) = parent.get(n as usize) {
                    return Err(bad(format!(
                        "scene {si} lists node {n} as a root, but it is a child of node {p}"
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Textures with no core `source` (e.g. only `MSFT_texture_dds.source` or
/// `KHR_texture_basisu.source`) are legal under those extensions but the `gltf`
/// crate requires `source`. Points them at image 0 (adding a placeholder image
/// when there is none) and returns their indices so they are never sampled.
fn patch_sourceless_textures(obj: &mut serde_json::Map<String, serde_json::Value>) -> Vec<usize> {
    use serde_json::{json, Value};
    let mut sourceless = Vec::new();
    if let Some(Value::Array(textures)) = obj.get_mut("textures") {
        for (i, t) in textures.iter_mut().enumerate() {
            if let Value::Object(t) = t {
                if !t.contains_key("source") {
                    t.insert("source".into(), json!(0));
                    sourceless.push(i);
                }
            }
        }
    }
    if !sourceless.is_empty() {
        let images = obj.entry("images").or_insert_with(|| json!([]));
        if let Value::Array(images) = images {
            if images.is_empty() {
                images.push(
                    json!({"name": "placeholder for source-less textures", "uri": "data:;base64,"}),
                );
            }
        }
    }
    sourceless
}

struct Prepared {
    doc: gltf::Document,
    /// Materials carrying AMD_split_roughnessMetallic.
    split_rm: usize,
    /// Per material: whether it carries KHR_materials_unlit.
    unlit: Vec<bool>,
    /// Textures that had no core `source` (see `patch_sourceless_textures`).
    sourceless: Vec<usize>,
    /// Nodes with EXT_mesh_gpu_instancing, by node index.
    instancing: HashMap<usize, NodeInstancing>,
    /// Per material, per texture slot (`gltf_uv::SLOTS`): its KHR_texture_transform.
    slot_uvs: Vec<[Option<SlotUv>; SLOT_COUNT]>,
    /// Meshes that lost primitives without POSITION
    /// (`drop_positionless_primitives`): the file's index of each kept one.
    primitive_indices: HashMap<usize, Vec<usize>>,
}

/// The uvs a material's textures read, as decided at import (`gltf_uv`).
struct MaterialUv {
    channels: UvChannels,
    /// Whether any texture slot is bound (so missing uvs matter).
    textured: bool,
    label: String,
}

struct Importer<'a> {
    path: &'a Path,
    doc: &'a gltf::Document,
    reader: AccessorReader<'a>,
    scene: Scene,
    /// (glTF mesh index, default morph weights as bits; empty when they are
    /// all zero) → our mesh indices (one per triangle primitive).
    mesh_map: HashMap<(usize, Vec<u32>), Vec<u32>>,
    /// Nodes with EXT_mesh_gpu_instancing, by node index.
    instancing: HashMap<usize, NodeInstancing>,
    /// Per instance, its EXT_mesh_gpu_instancing T·R·S (identity otherwise),
    /// for `SceneAnimation`; filled only when `record_paths`.
    instance_offsets: Vec<Mat4>,
    /// Morph-weight warnings already given (a mesh's weights are seen once
    /// per node that uses it).
    morph_warnings: HashSet<String>,
    /// Index of the glTF default material, appended on first use.
    default_material: Option<u32>,
    instances_budget: usize,
    /// Materials carrying AMD_split_roughnessMetallic (counted on the raw JSON:
    /// the `gltf` crate is built without its generic `extensions` accessors).
    split_rm_materials: usize,
    /// Per material: KHR_materials_unlit ([`unlit`]).
    unlit_materials: Vec<bool>,
    sourceless_textures: Vec<usize>,
    /// Per material, its KHR_texture_transform per slot (raw JSON).
    slot_uvs: Vec<[Option<SlotUv>; SLOT_COUNT]>,
    /// The file's index of each primitive of the meshes that lost some (`Prepared`).
    primitive_indices: HashMap<usize, Vec<usize>>,
    /// Per material (by index), the uv set and transform its meshes get.
    material_uvs: Vec<MaterialUv>,
    /// Materials whose uv set some primitive lacks → those primitives.
    missing_uvs: BTreeMap<u32, Vec<String>>,
    /// Whether to record each instance's node path (files with animations).
    record_paths: bool,
    /// Nodes from the root to the one being visited.
    node_path: Vec<u32>,
    /// Per instance, its node path (for `SceneAnimation`).
    instance_paths: Vec<Vec<u32>>,
    /// The first material whose emission exceeds `MAX_EMISSION` (an error
    /// once the materials are read).
    too_bright: Option<String>,
}

/// KHR_materials_clearcoat of one material, read from its raw JSON (the
/// `gltf` crate does not know the extension): factors, and each texture with
/// its `texCoord`. A field of the wrong type, out of range, or a texture
/// index past the file's textures is listed in `bad` and takes its default.
struct CoatJson<'a> {
    factor: f32,
    roughness: f32,
    normal_scale: f32,
    texture: Option<(gltf::texture::Texture<'a>, u32)>,
    roughness_texture: Option<(gltf::texture::Texture<'a>, u32)>,
    normal_texture: Option<(gltf::texture::Texture<'a>, u32)>,
    bad: Vec<String>,
}

fn coat_json<'a>(doc: &'a gltf::Document, m: &gltf::Material<'a>) -> CoatJson<'a> {
    let mut c = CoatJson {
        factor: 0.0,
        roughness: 0.0,
        normal_scale: 1.0,
        texture: None,
        roughness_texture: None,
        normal_texture: None,
        bad: Vec::new(),
    };
    let Some(ext) = m.extension_value("KHR_materials_clearcoat") else {
        return c;
    };
    let number = |key: &str, default: f32, unit: bool, bad: &mut Vec<String>| -> f32 {
        let Some(v) = ext.get(key) else {
            return default;
        };
        match v.as_f64().map(|x| x as f32).filter(|x| x.is_finite()) {
            Some(x) if !unit || (0.0..=1.0).contains(&x) => x,
            _ => {
                bad.push(format!("{key} {v}"));
                default
            }
        }
    };
    let mut bad = Vec::new();
    c.factor = number("clearcoatFactor", 0.0, true, &mut bad);
    c.roughness = number("clearcoatRoughnessFactor", 0.0, true, &mut bad);
    let texture = |key: &str, bad: &mut Vec<String>| {
        let info = ext.get(key)?;
        let found = info
            .get("index")
            .and_then(serde_json::Value::as_u64)
            .and_then(|i| doc.textures().nth(i as usize));
        let tex_coord = info.get("texCoord").map_or(Some(0), |t| {
            t.as_u64()
                .filter(|&n| n <= u32::MAX as u64)
                .map(|n| n as u32)
        });
        match (found, tex_coord) {
            (Some(t), Some(set)) => Some((t, set)),
            _ => {
                bad.push(format!("{key} {info} (no such texture or texCoord)"));
                None
            }
        }
    };
    c.texture = texture("clearcoatTexture", &mut bad);
    c.roughness_texture = texture("clearcoatRoughnessTexture", &mut bad);
    c.normal_texture = texture("clearcoatNormalTexture", &mut bad);
    if let Some(info) = ext.get("clearcoatNormalTexture") {
        c.normal_scale = match info.get("scale") {
            None => 1.0,
            Some(v) => v
                .as_f64()
                .map(|x| x as f32)
                .filter(|x| x.is_finite())
                .unwrap_or_else(|| {
                    bad.push(format!("clearcoatNormalTexture.scale {v}"));
                    1.0
                }),
        };
    }
    c.bad = bad;
    c
}

fn named(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) if !n.is_empty() => format!("{kind} {index} '{n}'"),
        _ => format!("{kind} {index}"),
    }
}

fn encoding_slot(uses: &mut ImageUses, image: usize, enc: TextureEncoding) {
    let v = uses.entry(image).or_default();
    if !v.contains(&enc) {
        v.push(enc);
    }
}

impl Importer<'_> {
    fn warn(&mut self, msg: String) {
        self.scene
            .warnings
            .push(format!("{}: {msg}", self.path.display()));
    }

    fn err(&self, msg: String) -> SceneError {
        SceneError::invalid(self.path, msg)
    }

    /// Textures first (decoded once per image and encoding), then materials.
    fn import_materials(&mut self, buffers: &[Vec<u8>]) {
        let sourceless = self.sourceless_textures.clone();
        let src = |t: gltf::texture::Texture| {
            (!sourceless.contains(&t.index())).then(|| t.source().index())
        };
        let mut uses = ImageUses::new();
        for m in self.doc.materials() {
            let pbr = m.pbr_metallic_roughness();
            let coat = coat_json(self.doc, &m);
            let srgb = [
                pbr.base_color_texture().and_then(|t| src(t.texture())),
                m.emissive_texture().and_then(|t| src(t.texture())),
                m.specular()
                    .and_then(|t| t.specular_color_texture())
                    .and_then(|t| src(t.texture())),
            ];
            let linear = [
                pbr.metallic_roughness_texture()
                    .and_then(|t| src(t.texture())),
                m.normal_texture().and_then(|t| src(t.texture())),
                m.transmission()
                    .and_then(|t| t.transmission_texture())
                    .and_then(|t| src(t.texture())),
                m.specular()
                    .and_then(|t| t.specular_texture())
                    .and_then(|t| src(t.texture())),
                coat.texture.as_ref().and_then(|(t, _)| src(t.clone())),
                coat.roughness_texture
                    .as_ref()
                    .and_then(|(t, _)| src(t.clone())),
                coat.normal_texture
                    .as_ref()
                    .and_then(|(t, _)| src(t.clone())),
            ];
            for i in srgb.into_iter().flatten() {
                encoding_slot(&mut uses, i, TextureEncoding::Srgb);
            }
            for i in linear.into_iter().flatten() {
                encoding_slot(&mut uses, i, TextureEncoding::Linear);
            }
        }
        let decoded = decode_images(self.doc, &uses, self.path, buffers);
        self.scene.warnings.extend(decoded.warnings);
        let mut lookup: HashMap<(usize, TextureEncoding), u32> = HashMap::new();
        for (key, tex) in decoded.textures {
            lookup.insert(key, self.scene.textures.len() as u32);
            self.scene.textures.push(tex);
        }
        let tex_ref = |t: gltf::texture::Texture, enc| {
            src(t.clone()).and_then(|image| {
                lookup.get(&(image, enc)).map(|&texture| TextureRef {
                    texture,
                    sampler: texture_sampler(&t),
                })
            })
        };

        let split_rm = self.split_rm_materials;

        let mut no_source = Vec::new();
        let doc = self.doc;
        for m in doc.materials() {
            let pbr = m.pbr_metallic_roughness();
            let label = named("material", m.index().unwrap_or(0), m.name());
            let coat = coat_json(doc, &m);
            let mut tex_coords = [
                pbr.base_color_texture().map(|t| t.tex_coord()),
                pbr.metallic_roughness_texture().map(|t| t.tex_coord()),
                m.normal_texture().map(|t| t.tex_coord()),
                m.emissive_texture().map(|t| t.tex_coord()),
                m.transmission()
                    .and_then(|t| t.transmission_texture())
                    .map(|t| t.tex_coord()),
                m.specular()
                    .and_then(|t| t.specular_texture())
                    .map(|t| t.tex_coord()),
                m.specular()
                    .and_then(|t| t.specular_color_texture())
                    .map(|t| t.tex_coord()),
                coat.texture.as_ref().map(|(_, c)| *c),
                coat.roughness_texture.as_ref().map(|(_, c)| *c),
                coat.normal_texture.as_ref().map(|(_, c)| *c),
            ];
            let core_textures = [
                pbr.base_color_texture().map(|t| t.texture().index()),
                pbr.metallic_roughness_texture()
                    .map(|t| t.texture().index()),
                m.normal_texture().map(|t| t.texture().index()),
                m.emissive_texture().map(|t| t.texture().index()),
            ];
            if core_textures
                .into_iter()
                .flatten()
                .any(|t| self.sourceless_textures.contains(&t))
            {
                no_source.push(label.clone());
            }
            let alpha_mode = match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask,
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            };
            let alpha_cutoff = m.alpha_cutoff().unwrap_or(0.5);
            let transmission = m.transmission();
            let emissive = Vec3::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0);
            if self.too_bright.is_none()
                && (emissive.is_nan() || emissive.max_element() > super::MAX_EMISSION)
            {
                self.too_bright = Some(format!(
                    "{label}: emissiveFactor {:?} × emissive_strength {:e} = {} is beyond the brightest emission accepted ({:e} per channel)",
                    m.emissive_factor(),
                    m.emissive_strength().unwrap_or(1.0),
                    exp3(emissive),
                    super::MAX_EMISSION
                ));
            }
            let normal = m.normal_texture();
            let specular = m.specular();
            // KHR_materials_volume: "The volume extension needs to be
            // combined with an extension which allows light to transmit
            // through the surface, e.g. KHR_materials_transmission": without
            // transmission it has no effect (and must not stop back faces
            // being culled, `Material::culls_back_faces`).
            let transmits = transmission.as_ref().is_some_and(|t| {
                t.transmission_factor() > 0.0 || t.transmission_texture().is_some()
            });
            let volume = m
                .volume()
                .filter(|v| transmits && v.thickness_factor() > 0.0)
                .map(|v| Volume {
                    attenuation_color: Vec3::from(v.attenuation_color()),
                    attenuation_distance: v.attenuation_distance(),
                });
            let material = Material {
                name: m.name().map(str::to_owned).unwrap_or_else(|| label.clone()),
                base_color: Vec4::from(pbr.base_color_factor()),
                base_color_texture: pbr
                    .base_color_texture()
                    .and_then(|t| tex_ref(t.texture(), TextureEncoding::Srgb)),
                metallic: pbr.metallic_factor(),
                roughness: pbr.roughness_factor(),
                metallic_roughness_texture: pbr
                    .metallic_roughness_texture()
                    .and_then(|t| tex_ref(t.texture(), TextureEncoding::Linear)),
                normal_texture: normal
                    .as_ref()
                    .and_then(|t| tex_ref(t.texture(), TextureEncoding::Linear)),
                normal_scale: normal.as_ref().map_or(1.0, |t| t.scale()),
                emissive,
                emissive_texture: m
                    .emissive_texture()
                    .and_then(|t| tex_ref(t.texture(), TextureEncoding::Srgb)),
                alpha_mode,
                alpha_cutoff,
                double_sided: m.double_sided(),
                transmission: transmission
                    .as_ref()
                    .map_or(0.0, |t| t.transmission_factor()),
                transmission_texture: transmission
                    .as_ref()
                    .and_then(|t| t.transmission_texture())
                    .and_then(|t| tex_ref(t.texture(), TextureEncoding::Linear)),
                ior: m.ior().unwrap_or(1.5),
                specular: specular.as_ref().map_or(1.0, |s| s.specular_factor()),
                specular_texture: specular
                    .as_ref()
                    .and_then(|s| s.specular_texture())
                    .and_then(|t| tex_ref(t.texture(), TextureEncoding::Linear)),
                specular_color: specular
                    .as_ref()
                    .map_or(Vec3::ONE, |s| Vec3::from(s.specular_color_factor())),
                specular_color_texture: specular
                    .as_ref()
                    .and_then(|s| s.specular_color_texture())
                    .and_then(|t| tex_ref(t.texture(), TextureEncoding::Srgb)),
                clearcoat: Clearcoat {
                    factor: coat.factor,
                    texture: coat
                        .texture
                        .and_then(|(t, _)| tex_ref(t, TextureEncoding::Linear)),
                    roughness: coat.roughness,
                    roughness_texture: coat
                        .roughness_texture
                        .and_then(|(t, _)| tex_ref(t, TextureEncoding::Linear)),
                    normal_texture: coat
                        .normal_texture
                        .and_then(|(t, _)| tex_ref(t, TextureEncoding::Linear)),
                    normal_scale: coat.normal_scale,
                },
                volume,
                second_uv_slots: 0,
                uv_affine: [None; SLOT_COUNT],
                unlit: false,
            };
            if !coat.bad.is_empty() {
                self.warn(format!(
                    "{label}: KHR_materials_clearcoat has {}; the default is used",
                    coat.bad.join(", ")
                ));
            }
            // Unlit before the uv choice: its emissive slot holds the base
            // colour texture, which reads the base colour's uv set and
            // KHR_texture_transform (not the dropped emissive texture's).
            let is_unlit = self.unlit_materials.get(m.index().unwrap_or(usize::MAX)) == Some(&true);
            let material = if is_unlit {
                tex_coords[EMISSIVE_SLOT] = tex_coords[BASE_COLOR_SLOT];
                if let Some(ext) = self.slot_uvs.get_mut(self.material_uvs.len()) {
                    ext[EMISSIVE_SLOT] = ext[BASE_COLOR_SLOT];
                }
                unlit(material)
            } else {
                material
            };
            let bound = [
                material.base_color_texture.is_some(),
                material.metallic_roughness_texture.is_some(),
                material.normal_texture.is_some(),
                material.emissive_texture.is_some(),
                material.transmission_texture.is_some(),
                material.specular_texture.is_some(),
                material.specular_color_texture.is_some(),
                material.clearcoat.texture.is_some(),
                material.clearcoat.roughness_texture.is_some(),
                material.clearcoat.normal_texture.is_some(),
            ];
            let (second_uv_slots, uv_affine) = self.choose_uvs(label.clone(), bound, tex_coords);
            let material = Material {
                second_uv_slots,
                uv_affine,
                ..material
            };
            let (material, changed) = sanitize_material(material);
            if !changed.is_empty() {
                self.warn(format!(
                    "{label}: {} out of range or not finite; clamped into range",
                    changed.join(", ")
                ));
            }
            self.scene.materials.push(material);
        }
        if split_rm > 0 {
            self.warn(format!(
                "{split_rm} materials use AMD_split_roughnessMetallic; their separate roughness/metallic \
                 textures are ignored and the roughness/metallic factors are used"
            ));
        }
        if !no_source.is_empty() {
            self.warn(format!(
                "textures without a PNG/JPEG source (e.g. DDS only) fall back to factors in {}",
                no_source.join(", ")
            ));
        }
    }

    /// Decides the uv channels of the material being imported (the next
    /// index of `material_uvs`) from its bound slots and returns the slots
    /// that read the second (`Material::second_uv_slots`) and the maps of
    /// the slots that read a channel through one (`Material::uv_affine`);
    /// warns when a slot's (uv set, transform) choice can be neither.
    fn choose_uvs(
        &mut self,
        label: String,
        bound: [bool; SLOT_COUNT],
        tex_coords: [Option<u32>; SLOT_COUNT],
    ) -> (u32, [Option<UvAffine>; SLOT_COUNT]) {
        let index = self.material_uvs.len();
        let ext = self.slot_uvs.get(index).copied().unwrap_or_default();
        let slots: [Option<(u32, Option<SlotUv>)>; SLOT_COUNT] =
            std::array::from_fn(|k| bound[k].then(|| (tex_coords[k].unwrap_or(0), ext[k])));
        let channels = choose(&slots);
        let (choice, wrong) = (channels.first, &channels.wrong);
        if !wrong.is_empty() {
            let winner = ORDER.into_iter().find(|&k| slots[k].is_some()).unwrap_or(0);
            let sets = wrong.iter().any(|(_, c)| c.set != choice.set);
            let transforms = wrong
                .iter()
                .any(|(_, c)| !c.transform.same_as(&choice.transform));
            let what = match (sets, transforms) {
                (true, true) => "uv sets (texCoord) and texture transforms (KHR_texture_transform)",
                (true, false) => "uv sets (texCoord)",
                _ => "texture transforms (KHR_texture_transform)",
            };
            let losers: Vec<String> = wrong
                .iter()
                .map(|(k, c)| format!("the {} ({})", SLOTS[*k].0, c.describe()))
                .collect();
            let second = channels
                .second
                .map_or(String::new(), |c| format!(" and {}", c.describe()));
            self.warn(format!(
                "{label}: its textures use more than two different {what}, but a material gets \
                 two uv channels ({}{second}), and only further transforms of their uv sets are \
                 read through a map: the others read the \
                 {}'s uvs, so {} {} the wrong uvs",
                choice.describe(),
                SLOTS[winner].0,
                losers.join(" and "),
                if losers.len() == 1 { "reads" } else { "read" }
            ));
        }
        let second_slots = channels.second_slots;
        let mut affine = [None; SLOT_COUNT];
        for &(k, a) in &channels.relative {
            affine[k] = Some(a);
        }
        self.material_uvs.push(MaterialUv {
            channels,
            textured: bound.iter().any(|&b| b),
            label,
        });
        (second_slots, affine)
    }

    /// Channels for the uv sets the material graphs read. A `texcoord`
    /// node's index k is glTF's TEXCOORD_k as the mesh stores it (MaterialX
    /// knows no KHR_texture_transform; the graph places its own uvs), so
    /// each set a material's graphs read must be a channel holding it
    /// untransformed: one its textures take already, else the second
    /// channel where the textures leave it free. A material whose textures
    /// take both channels with other choices is an error naming it. Where
    /// set 0 ends on the second channel, the material is one of
    /// `SceneGraphs::uv_swapped` (scene_shaders.rs swaps the sets back).
    fn graph_uv_channels(&mut self) -> Result<(), SceneError> {
        let mut swapped = Vec::new();
        let bound: Vec<u32> = self
            .scene
            .graphs
            .materials
            .iter()
            .map(|(m, _)| *m)
            .collect();
        for m in bound {
            let sets = self.scene.graphs.uv_sets_of(m);
            let Some(mu) = self.material_uvs.get_mut(m as usize) else {
                continue;
            };
            if sets == 0 {
                continue;
            }
            let holds = |c: &UvChoice, set: u32| c.set == set && c.transform.is_identity();
            // Which channel (0: Mesh::uvs, 1: Mesh::uvs2) holds set k.
            let mut channel = [None; 2];
            for set in 0..2u32 {
                if sets & (1 << set) == 0 {
                    continue;
                }
                channel[set as usize] = Some(if holds(&mu.channels.first, set) {
                    0
                } else if mu.channels.second.is_some_and(|c| holds(&c, set)) {
                    1
                } else if mu.channels.second.is_none() {
                    mu.channels.second = Some(UvChoice {
                        set,
                        transform: UvTransform::default(),
                    });
                    1
                } else {
                    let second = mu.channels.second.map_or(String::new(), |c| c.describe());
                    return Err(SceneError::invalid(
                        self.path,
                        format!(
                            "{}: its material graphs read TEXCOORD_{set} untransformed (texcoord index {set}), \
                             but its textures take both uv channels ({} and {second}); a material gets two",
                            mu.label,
                            mu.channels.first.describe()
                        ),
                    ));
                });
            }
            mu.textured = true;
            if matches!(channel, [Some(1), _] | [None, Some(0)]) {
                swapped.push(m);
            }
        }
        self.scene.graphs.uv_swapped = swapped;
        Ok(())
    }

    /// One warning per textured material used by primitives that lack the
    /// uv set it reads (their uvs are zeros: the texture shows one texel).
    fn warn_missing_uvs(&mut self) {
        for (material, prims) in std::mem::take(&mut self.missing_uvs) {
            let Some(m) = self.material_uvs.get(material as usize) else {
                continue;
            };
            const SHOWN: usize = 4;
            let mut list = prims[..prims.len().min(SHOWN)].join(", ");
            if prims.len() > SHOWN {
                list.push_str(&format!(" and {} more", prims.len() - SHOWN));
            }
            let sets = match m.channels.second {
                Some(s) if s.set != m.channels.first.set => {
                    format!("TEXCOORD_{} and TEXCOORD_{}", m.channels.first.set, s.set)
                }
                _ => format!("TEXCOORD_{}", m.channels.first.set),
            };
            let msg = format!(
                "{}: its textures read {sets}, which {list} {}; those uvs are zeros",
                m.label,
                if prims.len() == 1 { "lacks" } else { "lack" }
            );
            self.warn(msg);
        }
    }

    fn default_material(&mut self) -> u32 {
        *self.default_material.get_or_insert_with(|| {
            self.scene.materials.push(Material::default());
            (self.scene.materials.len() - 1) as u32
        })
    }

    /// Flattens the default scene (or the first, or every root node when the
    /// file declares no scene) into instances, lights and cameras.
    fn import_nodes(&mut self) -> Result<(), SceneError> {
        let roots: Vec<gltf::Node> = match self
            .doc
            .default_scene()
            .or_else(|| self.doc.scenes().next())
        {
            Some(s) => s.nodes().collect(),
            None => {
                let mut is_child = vec![false; self.doc.nodes().len()];
                for n in self.doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                self.doc.nodes().filter(|n| !is_child[n.index()]).collect()
            }
        };
        let mut on_path = vec![false; self.doc.nodes().len()];
        for root in roots {
            self.visit(root, Mat4::IDENTITY, &mut on_path, 0)?;
        }
        Ok(())
    }

    fn visit(
        &mut self,
        node: gltf::Node,
        parent: Mat4,
        on_path: &mut [bool],
        depth: usize,
    ) -> Result<(), SceneError> {
        let label = named("node", node.index(), node.name());
        if on_path[node.index()] {
            return Err(self.err(format!(
                "{label} is its own ancestor: the node hierarchy has a cycle"
            )));
        }
        if depth > MAX_NODE_DEPTH {
            return Err(self.err(format!(
                "{label}: node hierarchy deeper than {MAX_NODE_DEPTH} levels"
            )));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            self.warn(format!(
                "{label} has a non-finite transform; it and its children are skipped"
            ));
            return Ok(());
        }
        self.node_path.push(node.index() as u32);
        if let Some(mesh) = node.mesh() {
            let weights = self.morph_weights(&node, &mesh, &label);
            let ids = self.mesh(mesh, weights)?;
            // EXT_mesh_gpu_instancing: one instance per element, node_world × T·R·S.
            let offsets = match self.instancing.get(&node.index()) {
                Some(inst) => inst.transforms(&self.reader, self.doc, &label)?,
                None => vec![Mat4::IDENTITY],
            };
            let total = ids.len().saturating_mul(offsets.len());
            if self.instances_budget < total {
                return Err(self.err(format!(
                    "the node hierarchy expands to more than {MAX_INSTANCES} instances"
                )));
            }
            self.instances_budget -= total;
            let name = node
                .name()
                .map(str::to_owned)
                .unwrap_or_else(|| label.clone());
            for offset in offsets {
                let transform = world * offset;
                for &id in &ids {
                    if self.record_paths {
                        self.instance_paths.push(self.node_path.clone());
                        self.instance_offsets.push(offset);
                    }
                    self.scene.instances.push(Instance {
                        mesh: id,
                        transform,
                        name: name.clone(),
                    });
                }
            }
        } else if self.instancing.contains_key(&node.index()) {
            self.warn(format!(
                "{label} has {INSTANCING_EXTENSION} but no mesh; the extension is ignored"
            ));
        }
        if let Some(camera) = node.camera() {
            self.camera(&node, camera, world)?;
        }
        if let Some(light) = node.light() {
            self.light(&node, light, world)?;
        }
        on_path[node.index()] = true;
        for child in node.children() {
            self.visit(child, world, on_path, depth + 1)?;
        }
        on_path[node.index()] = false;
        self.node_path.pop();
        Ok(())
    }

    fn camera(
        &mut self,
        node: &gltf::Node,
        camera: gltf::Camera,
        world: Mat4,
    ) -> Result<(), SceneError> {
        let name = camera
            .name()
            .or(node.name())
            .map(str::to_owned)
            .unwrap_or_else(|| format!("camera {}", camera.index()));
        // Camera-to-world without scale: cameras are rigid.
        let (_, rot, pos) = world.to_scale_rotation_translation();
        let transform = Mat4::from_rotation_translation(rot.normalize(), pos);
        // A zero scale (or a zero rotation quaternion) leaves no
        // orientation to take: NaNs. Found by `tests/fuzz_inputs.rs`.
        if !transform.is_finite() {
            self.warn(format!(
                "camera '{name}': its node transform is degenerate (zero scale?); skipped"
            ));
            return Ok(());
        }
        // The bound instances have (`Scene::check_placement`): a camera at
        // 3e38 m rendered black images without a word.
        if pos.abs().max_element() > super::MAX_WORLD_COORDINATE {
            return Err(SceneError::invalid(
                self.path,
                format!(
                    "camera '{name}' (node {}): its position reaches {:.3e} from the origin; world coordinates must stay within ±1e15 (a broken translation?)",
                    node.index(),
                    pos.abs().max_element()
                ),
            ));
        }
        let znear = |this: &mut Self, znear: f32, min: f32| {
            if znear.is_finite() && znear >= min {
                znear
            } else {
                this.warn(format!(
                    "camera '{name}': znear {znear} is not {} and finite; using {}",
                    if min > 0.0 {
                        "positive"
                    } else {
                        "non-negative"
                    },
                    crate::camera::DEFAULT_ZNEAR
                ));
                crate::camera::DEFAULT_ZNEAR
            }
        };
        match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let yfov = p.yfov();
                if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                    self.warn(format!(
                        "camera '{name}': yfov {yfov} is not in (0, π) radians; skipped"
                    ));
                    return Ok(());
                }
                let aspect = p.aspect_ratio().filter(|a| a.is_finite() && *a > 0.0);
                if aspect.is_none() && p.aspect_ratio().is_some() {
                    self.warn(format!(
                        "camera '{name}': aspectRatio {:?} is not positive and finite; ignored",
                        p.aspect_ratio().unwrap_or_default()
                    ));
                }
                let znear = znear(self, p.znear(), f32::MIN_POSITIVE);
                self.scene.cameras.push(SceneCamera {
                    name,
                    transform,
                    yfov,
                    aspect,
                    znear,
                    orthographic: None,
                });
            }
            gltf::camera::Projection::Orthographic(o) => {
                // glTF: xmag and ymag are non-zero (a negative one would
                // mirror the image; the sample viewer's matrix divides by
                // them). The view's height is 2·|ymag|; its width follows
                // the image's aspect, as a perspective camera's does.
                let (xmag, ymag) = (o.xmag(), o.ymag());
                if !(xmag.is_finite() && ymag.is_finite() && xmag != 0.0 && ymag != 0.0) {
                    self.warn(format!(
                        "camera '{name}': orthographic xmag {xmag}, ymag {ymag} must be non-zero and finite; skipped"
                    ));
                    return Ok(());
                }
                if xmag < 0.0 || ymag < 0.0 {
                    self.warn(format!(
                        "camera '{name}': negative orthographic xmag {xmag} or ymag {ymag} (a mirrored view) is not supported; their magnitudes are used"
                    ));
                }
                let znear = znear(self, o.znear(), 0.0);
                self.scene.cameras.push(SceneCamera {
                    name,
                    transform,
                    yfov: 0.0,
                    aspect: Some(xmag.abs() / ymag.abs()),
                    znear,
                    orthographic: Some(glam::Vec2::new(xmag.abs(), ymag.abs())),
                });
            }
        }
        Ok(())
    }

    fn light(
        &mut self,
        node: &gltf::Node,
        light: gltf::khr_lights_punctual::Light,
        world: Mat4,
    ) -> Result<(), SceneError> {
        use gltf::khr_lights_punctual::Kind;
        let mut cone_warning = None;
        let kind = match light.kind() {
            Kind::Point => LightKind::Point,
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                // KHR_lights_punctual: 0 ≤ inner < outer ≤ π/2. Outside it
                // the falloff's smoothstep has its edges reversed (undefined
                // in GLSL): clamped into range, with a warning.
                let outer = if outer_cone_angle.is_finite() {
                    outer_cone_angle.clamp(1e-4, std::f32::consts::FRAC_PI_2)
                } else {
                    std::f32::consts::FRAC_PI_4
                };
                let inner = if !inner_cone_angle.is_finite() || inner_cone_angle < 0.0 {
                    0.0
                } else if inner_cone_angle >= outer {
                    outer * 0.999
                } else {
                    inner_cone_angle
                };
                if (inner, outer) != (inner_cone_angle, outer_cone_angle) {
                    cone_warning = Some(format!(
                        "inner and outer cone angles {inner_cone_angle}, {outer_cone_angle} are not 0 ≤ inner < outer ≤ π/2; using {inner}, {outer}"
                    ));
                }
                LightKind::Spot {
                    inner_cone: inner,
                    outer_cone: outer,
                }
            }
            Kind::Directional => LightKind::Directional {
                angular_radius: 0.0,
            },
        };
        let direction = world
            .transform_vector3(Vec3::NEG_Z)
            .try_normalize()
            .unwrap_or(Vec3::NEG_Y);
        let name = light
            .name()
            .or(node.name())
            .map(str::to_owned)
            .unwrap_or_else(|| format!("light {}", light.index()));
        // The name marks the project's own default lighting
        // (default_lighting.rs), which `--lighting` replaces and export
        // leaves out (export never writes it): a file's light of that name
        // is renamed, so it stays the scene's.
        let name = if name == super::default_lighting::DEFAULT_SUN_NAME {
            let renamed = format!("{name} (glTF light {})", light.index());
            self.warn(format!(
                "light '{name}': the name marks the default lighting; imported as '{renamed}'"
            ));
            renamed
        } else {
            name
        };
        if let Some(w) = cone_warning {
            self.warn(format!("light '{name}': {w}"));
        }
        let radiant = Vec3::from(light.color()) * light.intensity();
        // Too bright (the product overflowing f32 included): an error, as
        // for emissive materials; `Scene::MAX_EMISSION`.
        if radiant.max_element() > super::MAX_EMISSION {
            return Err(SceneError::invalid(
                self.path,
                format!(
                    "light '{name}': colour {:?} × intensity {:e} = {} is beyond the brightest emission accepted ({:e} per channel)",
                    light.color(),
                    light.intensity(),
                    exp3(radiant),
                    super::MAX_EMISSION
                ),
            ));
        }
        if !radiant.is_finite() || radiant.min_element() < 0.0 {
            self.warn(format!(
                "light '{name}': colour × intensity {radiant} is negative or not finite; skipped"
            ));
            return Ok(());
        }
        self.scene.lights.push(Light {
            name,
            kind,
            radiant,
            position: world.transform_point3(Vec3::ZERO),
            direction,
            range: light.range(),
        });
        Ok(())
    }

    /// The default morph weights a node's mesh is shown with: `node.weights`
    /// when present, else `mesh.weights` (glTF 2.0, "Morph Targets"); `None`
    /// when the mesh has no targets or every weight is zero. A weight list
    /// whose length differs from the target count, or a non-finite weight, is
    /// a warning; missing and non-finite weights count as 0.
    fn morph_weights(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        label: &str,
    ) -> Option<Vec<f32>> {
        let targets = mesh
            .primitives()
            .map(|p| p.morph_targets().len())
            .max()
            .unwrap_or(0);
        if targets == 0 {
            return None;
        }
        let (given, source) = match (node.weights(), mesh.weights()) {
            (Some(w), _) => (w, label.to_owned()),
            (None, Some(w)) => (w, named("mesh", mesh.index(), mesh.name())),
            (None, None) => return None,
        };
        let mut problems = Vec::new();
        if given.len() != targets {
            problems.push(format!(
                "{source}: {} morph weights for {targets} morph targets; missing weights \
                 count as 0, extra ones are ignored",
                given.len()
            ));
        }
        if given.iter().any(|w| !w.is_finite()) {
            problems.push(format!("{source}: non-finite morph weights count as 0"));
        }
        for p in problems {
            if self.morph_warnings.insert(p.clone()) {
                self.warn(p);
            }
        }
        let weights: Vec<f32> = (0..targets)
            .map(|k| {
                given
                    .get(k)
                    .copied()
                    .filter(|w| w.is_finite())
                    .unwrap_or(0.0)
            })
            .collect();
        weights.iter().any(|&w| w != 0.0).then_some(weights)
    }

    /// Our meshes for one glTF mesh shown with `weights`, converted on first use.
    fn mesh(
        &mut self,
        mesh: gltf::Mesh,
        weights: Option<Vec<f32>>,
    ) -> Result<Vec<u32>, SceneError> {
        let key = (
            mesh.index(),
            weights
                .as_deref()
                .unwrap_or(&[])
                .iter()
                .map(|w| w.to_bits())
                .collect::<Vec<u32>>(),
        );
        if let Some(ids) = self.mesh_map.get(&key) {
            return Ok(ids.clone());
        }
        let mut ids = Vec::new();
        for prim in mesh.primitives() {
            // The file's index, where primitives without POSITION were removed.
            let index = self
                .primitive_indices
                .get(&mesh.index())
                .and_then(|k| k.get(prim.index()).copied())
                .unwrap_or(prim.index());
            let label = format!(
                "{} primitive {index}",
                named("mesh", mesh.index(), mesh.name())
            );
            if let Some(m) = self.primitive(&prim, &label, mesh.name(), weights.as_deref())? {
                ids.push(self.scene.meshes.len() as u32);
                self.scene.meshes.push(m);
            }
        }
        self.mesh_map.insert(key, ids.clone());
        Ok(ids)
    }

    fn primitive(
        &mut self,
        prim: &gltf::Primitive,
        label: &str,
        mesh_name: Option<&str>,
        morph_weights: Option<&[f32]>,
    ) -> Result<Option<Mesh>, SceneError> {
        use gltf::mesh::Mode;
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.warn(format!(
                "{label}: mode {mode:?} is not supported (triangles, triangle strips and \
                 triangle fans only); skipped"
            ));
            return Ok(None);
        }
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            // Removed, with a warning, before the typed parse
            // (`drop_positionless_primitives`): not reached.
            return Ok(None);
        };
        let material = match prim.material().index() {
            Some(i) => i as u32,
            None => self.default_material(),
        };
        let (channels, textured) = self
            .material_uvs
            .get(material as usize)
            .map_or((UvChannels::default(), false), |m| {
                (m.channels.clone(), m.textured)
            });
        let choice = channels.first;
        let r = &self.reader;
        let mut positions: Vec<Vec3> = r
            .read_vec::<3>(&pos_acc, &format!("POSITION of {label}"))?
            .into_iter()
            .map(Vec3::from)
            .collect();
        let n = positions.len();
        if n > u32::MAX as usize {
            return Err(self.err(format!("{label}: more than 2^32 vertices")));
        }
        let same_len = |what: &str, len: usize| -> Result<(), SceneError> {
            if len != n {
                Err(SceneError::invalid(
                    self.path,
                    format!("{label}: {what} has {len} elements but POSITION has {n}"),
                ))
            } else {
                Ok(())
            }
        };
        let mut normals: Vec<Vec3> = match prim.get(&gltf::Semantic::Normals) {
            Some(a) => {
                let v = r.read_vec::<3>(&a, &format!("NORMAL of {label}"))?;
                same_len("NORMAL", v.len())?;
                v.into_iter().map(Vec3::from).collect()
            }
            None => Vec::new(),
        };
        // The uv sets the material's textures read, each transformed as its
        // KHR_texture_transform says (gltf_uv): channel 1, and channel 2
        // where some slots read another set or transform.
        let mut read_uvs = |c: UvChoice| -> Result<Vec<Vec2>, SceneError> {
            Ok(match prim.get(&gltf::Semantic::TexCoords(c.set)) {
                Some(a) => {
                    let name = format!("TEXCOORD_{}", c.set);
                    let v = r.read_vec::<2>(&a, &format!("{name} of {label}"))?;
                    same_len(&name, v.len())?;
                    let t = c.transform;
                    if t.is_identity() {
                        v.into_iter().map(Vec2::from).collect()
                    } else {
                        v.into_iter().map(|uv| t.apply(Vec2::from(uv))).collect()
                    }
                }
                None => {
                    if textured {
                        let prims = self.missing_uvs.entry(material).or_default();
                        if !prims.iter().any(|p| p == label) {
                            prims.push(label.to_owned());
                        }
                    }
                    vec![Vec2::ZERO; n]
                }
            })
        };
        let uvs = read_uvs(choice)?;
        let uvs2 = match channels.second {
            Some(c) => read_uvs(c)?,
            None => Vec::new(),
        };
        // COLOR_0: linear RGB or RGBA (float, or normalized unsigned byte /
        // short: read_vec normalizes), alpha 1 for VEC3 (glTF §3.7.2.1).
        let colors: Vec<Vec4> = match prim.get(&gltf::Semantic::Colors(0)) {
            Some(a) => {
                let what = format!("COLOR_0 of {label}");
                let v: Vec<Vec4> = match a.dimensions() {
                    gltf::accessor::Dimensions::Vec3 => r
                        .read_vec::<3>(&a, &what)?
                        .into_iter()
                        .map(|c| Vec3::from(c).extend(1.0))
                        .collect(),
                    _ => r
                        .read_vec::<4>(&a, &what)?
                        .into_iter()
                        .map(Vec4::from)
                        .collect(),
                };
                same_len("COLOR_0", v.len())?;
                v
            }
            None => Vec::new(),
        };
        let mut tangents: Vec<Vec4> = match prim.get(&gltf::Semantic::Tangents) {
            Some(a) => {
                let v = r.read_vec::<4>(&a, &format!("TANGENT of {label}"))?;
                same_len("TANGENT", v.len())?;
                v.into_iter().map(Vec4::from).collect()
            }
            None => Vec::new(),
        };
        // Default morph weights: attribute += Σ weight × target delta. Deltas
        // of attributes the primitive lacks are ignored (normals are then
        // generated from the morphed positions, tangents from both).
        let mut morphed = false;
        let (has_normals, has_tangents) = (!normals.is_empty(), !tangents.is_empty());
        for (k, target) in prim.morph_targets().enumerate() {
            let w = morph_weights.and_then(|w| w.get(k)).copied().unwrap_or(0.0);
            if w == 0.0 {
                continue;
            }
            morphed = true;
            let read = |a: gltf::Accessor, what: &str| -> Result<Vec<Vec3>, SceneError> {
                let v = r.read_vec::<3>(&a, &format!("morph target {k} {what} of {label}"))?;
                same_len(&format!("morph target {k} {what}"), v.len())?;
                Ok(v.into_iter().map(Vec3::from).collect())
            };
            if let Some(a) = target.positions() {
                for (p, d) in positions.iter_mut().zip(read(a, "POSITION")?) {
                    *p += w * d;
                }
            }
            if let Some(a) = target.normals().filter(|_| has_normals) {
                for (v, d) in normals.iter_mut().zip(read(a, "NORMAL")?) {
                    *v += w * d;
                }
            }
            if let Some(a) = target.tangents().filter(|_| has_tangents) {
                for (t, d) in tangents.iter_mut().zip(read(a, "TANGENT")?) {
                    *t += (w * d).extend(0.0);
                }
            }
        }
        if morphed {
            // Normals are renormalised below with the file's own.
            for t in &mut tangents {
                if let Some(xyz) = t.truncate().try_normalize() {
                    *t = xyz.extend(t.w);
                }
            }
        }
        let mut indices = match prim.indices() {
            Some(a) => r.read_indices(&a, &format!("indices of {label}"))?,
            None => (0..n as u32).collect(),
        };
        if let Some((k, &bad)) = indices.iter().enumerate().find(|(_, &i)| i as usize >= n) {
            return Err(self.err(format!(
                "{label}: index {k} has value {bad}, out of range for {n} vertices"
            )));
        }
        match mode {
            Mode::TriangleStrip => indices = strip_to_triangles(&indices),
            Mode::TriangleFan => indices = fan_to_triangles(&indices),
            _ => {}
        }
        if indices.len() % 3 != 0 {
            self.warn(format!(
                "{label}: {} indices is not a multiple of 3; the last incomplete triangle is ignored",
                indices.len()
            ));
            indices.truncate(indices.len() / 3 * 3);
        }
        let mut mesh = Mesh {
            name: mesh_name
                .map(str::to_owned)
                .unwrap_or_else(|| label.to_owned()),
            positions,
            normals,
            uvs,
            uvs2,
            tangents,
            colors,
            indices,
            material,
        };
        let dropped = drop_non_finite_triangles(&mut mesh);
        if dropped > 0 {
            self.warn(format!(
                "{label}: {dropped} triangles dropped because they use vertices with NaN/Inf attributes"
            ));
        }
        if mesh.normals.is_empty() {
            // glTF: flat normals, and supplied tangents ignored.
            flat_normals(&mut mesh);
        } else if mesh.normals.iter().any(|v| v.length_squared() < 1e-20) {
            let generated = generate_normals(&mesh.positions, &mesh.indices);
            for (v, g) in mesh.normals.iter_mut().zip(generated) {
                *v = v.try_normalize().unwrap_or(g);
            }
        } else {
            for v in &mut mesh.normals {
                *v = v.normalize();
            }
        }
        // The tangent frame belongs to the normal texture's own uvs (its
        // set and transform, whether it reads a channel or a map of one;
        // else the clearcoat normal texture's: both share the one tangent
        // per vertex). Supplied tangents belong to the untransformed uvs:
        // turn them to the direction of increasing transformed u (generated
        // ones below come from the transformed uvs already).
        let normal_slot = if self
            .scene
            .materials
            .get(material as usize)
            .is_some_and(|m| m.normal_texture.is_none())
        {
            CLEARCOAT_NORMAL_SLOT
        } else {
            NORMAL_SLOT
        };
        let tangent_second = channels.second_slots & (1 << normal_slot) != 0;
        let tangent_choice = channels.tangent.unwrap_or(choice);
        let needs_tangents = self
            .scene
            .materials
            .get(material as usize)
            .is_some_and(|m| m.normal_texture.is_some() || m.clearcoat.normal_texture.is_some());
        // Turned only for a normal texture: without one the tangents serve
        // a graph's tangent-space normal, which reads its uvs untransformed
        // (until session 50 turned by an unrelated texture's transform).
        if needs_tangents && !mesh.tangents.is_empty() && !tangent_choice.transform.is_identity() {
            for (t, nrm) in mesh.tangents.iter_mut().zip(&mesh.normals) {
                *t = tangent_choice.transform.tangent(*nrm, *t);
            }
        }
        if mesh.tangents.is_empty() && needs_tangents {
            match channels.relative.iter().find(|&&(k, _)| k == normal_slot) {
                // Read through a map: MikkTSpace on the channel's uvs mapped
                // to the normal texture's own.
                Some(&(_, map)) => {
                    let channel = if tangent_second {
                        &mesh.uvs2
                    } else {
                        &mesh.uvs
                    };
                    let uvs: Vec<Vec2> = channel.iter().map(|&uv| map.apply(uv)).collect();
                    generate_tangents_from(&mut mesh, &uvs);
                }
                None => generate_tangents_for(&mut mesh, tangent_second),
            }
        }
        Ok(Some(mesh))
    }
}

/// KHR_materials_unlit translated to a path tracer: the surface shows its
/// base colour (factor × texture, as the extension's `color = baseColor`) and
/// reflects nothing — an emitter of radiance base colour with a black BSDF
/// (no diffuse, no specular, no transmission). The alpha (factor and texture)
/// still drives MASK cutoffs. Like any emitter it is also sampled as a light,
/// so it lights its surroundings as a surface of that radiance would (a
/// rasterizer's unlit surface lights nothing: a path tracer's choice, README).
/// Applied before the uv channels are chosen, the emissive slot given the
/// base colour texture's uv set and transform (`import_materials`), so the
/// moved texture reads the uvs the base colour texture would.
fn unlit(mut m: Material) -> Material {
    m.unlit = true;
    m.emissive = m.base_color.truncate();
    m.emissive_texture = m.base_color_texture;
    m.base_color = Vec4::new(0.0, 0.0, 0.0, m.base_color.w);
    m.metallic = 0.0;
    m.metallic_roughness_texture = None;
    m.roughness = 1.0;
    m.specular = 0.0;
    m.transmission = 0.0;
    m.transmission_texture = None;
    m.normal_texture = None;
    m.specular_texture = None;
    m.specular_color_texture = None;
    m.clearcoat = Clearcoat::default();
    m.volume = None;
    m
}

/// Clamps material parameters to their glTF ranges (files in the wild carry
/// e.g. roughness 1.0000001 or ior 0 meaning "unset").
/// `m` with every factor finite and in its range (glTF's and the
/// extensions'), and the names of the factors that had to change.
fn sanitize_material(m: Material) -> (Material, Vec<&'static str>) {
    let before = m.clone();
    let m = sanitize_factors(m);
    let mut changed = Vec::new();
    let mut check = |name: &'static str, a: &[f32], b: &[f32]| {
        if a.iter().zip(b).any(|(x, y)| x.to_bits() != y.to_bits()) {
            changed.push(name);
        }
    };
    check(
        "baseColorFactor",
        &before.base_color.to_array(),
        &m.base_color.to_array(),
    );
    check("metallicFactor", &[before.metallic], &[m.metallic]);
    check("roughnessFactor", &[before.roughness], &[m.roughness]);
    check(
        "emissive",
        &before.emissive.to_array(),
        &m.emissive.to_array(),
    );
    check(
        "transmissionFactor",
        &[before.transmission],
        &[m.transmission],
    );
    check("alphaCutoff", &[before.alpha_cutoff], &[m.alpha_cutoff]);
    check("normal scale", &[before.normal_scale], &[m.normal_scale]);
    check("ior", &[before.ior], &[m.ior]);
    check("specularFactor", &[before.specular], &[m.specular]);
    check(
        "specularColorFactor",
        &before.specular_color.to_array(),
        &m.specular_color.to_array(),
    );
    check(
        "clearcoatFactor",
        &[before.clearcoat.factor],
        &[m.clearcoat.factor],
    );
    check(
        "clearcoatRoughnessFactor",
        &[before.clearcoat.roughness],
        &[m.clearcoat.roughness],
    );
    check(
        "clearcoat normal scale",
        &[before.clearcoat.normal_scale],
        &[m.clearcoat.normal_scale],
    );
    if let (Some(a), Some(b)) = (&before.volume, &m.volume) {
        check(
            "attenuationColor",
            &a.attenuation_color.to_array(),
            &b.attenuation_color.to_array(),
        );
        // A missing or non-positive distance means "no attenuation" (∞).
        let (x, y) = (a.attenuation_distance, b.attenuation_distance);
        if x.is_nan() || (x < 0.0 && y.is_infinite()) {
            changed.push("attenuationDistance");
        }
    }
    (m, changed)
}

fn sanitize_factors(mut m: Material) -> Material {
    let finite_or = |v: f32, d: f32| if v.is_finite() { v } else { d };
    m.base_color = Vec4::from_array(
        m.base_color
            .to_array()
            .map(|c| finite_or(c, 1.0).clamp(0.0, 1.0)),
    );
    m.metallic = finite_or(m.metallic, 1.0).clamp(0.0, 1.0);
    m.roughness = finite_or(m.roughness, 1.0).clamp(0.0, 1.0);
    m.emissive = Vec3::from_array(m.emissive.to_array().map(|c| finite_or(c, 0.0).max(0.0)));
    m.transmission = finite_or(m.transmission, 0.0).clamp(0.0, 1.0);
    // glTF schema: alphaCutoff minimum 0, no maximum. MASK keeps alpha ≥
    // cutoff, so a cutoff above 1 cuts everything (not clamped to 1).
    m.alpha_cutoff = finite_or(m.alpha_cutoff, 0.5).max(0.0);
    m.normal_scale = finite_or(m.normal_scale, 1.0);
    // KHR_materials_ior: ior = 0 is a legal "no refraction" marker; keep ≥ 1 otherwise.
    m.ior = finite_or(m.ior, 1.5);
    m.specular = finite_or(m.specular, 1.0).clamp(0.0, 1.0);
    m.specular_color = Vec3::from_array(
        m.specular_color
            .to_array()
            .map(|c| finite_or(c, 1.0).max(0.0)),
    );
    m.clearcoat.factor = finite_or(m.clearcoat.factor, 0.0).clamp(0.0, 1.0);
    m.clearcoat.roughness = finite_or(m.clearcoat.roughness, 0.0).clamp(0.0, 1.0);
    m.clearcoat.normal_scale = finite_or(m.clearcoat.normal_scale, 1.0);
    if let Some(v) = &mut m.volume {
        v.attenuation_color = Vec3::from_array(
            v.attenuation_color
                .to_array()
                .map(|c| finite_or(c, 1.0).clamp(0.0, 1.0)),
        );
        if v.attenuation_distance.is_nan() || v.attenuation_distance <= 0.0 {
            v.attenuation_distance = f32::INFINITY;
        }
    }
    if m.ior != 0.0 {
        m.ior = m.ior.max(1.0);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use base64::Engine as _;
    use serde_json::{json, Value};

    /// A 1×1 PNG.
    const PNG: &str = "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8DwHwAFBQIAX8jx0gAAAABJRU5ErkJggg==";

    /// One little-endian f32 buffer: a bufferView and an accessor per array.
    #[derive(Default)]
    struct Bin {
        bytes: Vec<u8>,
        views: Vec<Value>,
        accessors: Vec<Value>,
    }

    impl Bin {
        /// An accessor of `n`-component floats; min/max for VEC3 (POSITION needs them).
        fn floats(&mut self, data: &[f32], ty: &str, n: usize) -> usize {
            let offset = self.bytes.len();
            self.bytes.extend(data.iter().flat_map(|f| f.to_le_bytes()));
            self.views
                .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4}));
            let mut acc = json!({"bufferView": self.views.len() - 1, "componentType": 5126,
                                 "count": data.len() / n, "type": ty});
            if n == 3 {
                let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
                for v in data.chunks_exact(3) {
                    for k in 0..3 {
                        lo[k] = lo[k].min(v[k]);
                        hi[k] = hi[k].max(v[k]);
                    }
                }
                acc["min"] = json!(lo);
                acc["max"] = json!(hi);
            }
            self.accessors.push(acc);
            self.accessors.len() - 1
        }
    }

    const TRIANGLE: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

    /// Writes `doc` with `bin` as its one buffer and loads it.
    fn load(tag: &str, mut doc: Value, bin: Bin) -> Result<Scene, SceneError> {
        let dir = std::env::temp_dir().join(format!(
            "stereocache-gltf-import-{tag}-{}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin.bytes)
        );
        doc["asset"] = json!({"version": "2.0"});
        doc["buffers"] = json!([{"byteLength": bin.bytes.len(), "uri": uri}]);
        doc["bufferViews"] = json!(bin.views);
        doc["accessors"] = json!(bin.accessors);
        let path = dir.join(format!("{tag}.gltf"));
        std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
        let scene = load_gltf(&path);
        std::fs::remove_dir_all(&dir).ok();
        scene
    }

    /// glTF 2.0's structure that the `gltf` crate does not check (an
    /// audit's findings, each accepted without a word until session 52):
    /// a node with two parents, a scene root that is someone's child, a
    /// zero rotation and integer positions without KHR_mesh_quantization are
    /// refused naming the item; a rotation of another length is normalised
    /// with a warning (the node was scaled by its squared length); a version
    /// other than 2.x is refused.
    #[test]
    fn structure_the_crate_does_not_check_is_refused_or_repaired() {
        let tri = || {
            let mut b = Bin::default();
            let pos = b.floats(&TRIANGLE, "VEC3", 3);
            (
                b,
                json!([{"primitives": [{"attributes": {"POSITION": pos}}]}]),
            )
        };
        let err = |tag: &str, doc: Value, b: Bin| load(tag, doc, b).unwrap_err().to_string();
        let (b, meshes) = tri();
        let e = err(
            "two-parents",
            json!({"meshes": meshes, "scene": 0, "scenes": [{"nodes": [0, 1]}],
                   "nodes": [{"children": [2]}, {"children": [2]}, {"mesh": 0}]}),
            b,
        );
        assert!(e.contains("node 2 is a child of nodes 0 and 1"), "{e}");
        let (b, meshes) = tri();
        let e = err(
            "root-child",
            json!({"meshes": meshes, "scene": 0, "scenes": [{"nodes": [0, 1]}],
                   "nodes": [{"children": [1]}, {"mesh": 0}]}),
            b,
        );
        assert!(e.contains("scene 0 lists node 1 as a root"), "{e}");
        let (b, meshes) = tri();
        let e = err(
            "zero-rotation",
            json!({"meshes": meshes, "nodes": [{"mesh": 0, "rotation": [0.0, 0.0, 0.0, 0.0]}]}),
            b,
        );
        assert!(e.contains("node 0: rotation [0, 0, 0, 0]"), "{e}");
        let (b, meshes) = tri();
        let s = load(
            "long-rotation",
            json!({"meshes": meshes, "nodes": [{"mesh": 0, "rotation": [0.0, 0.0, 0.0, 5.0]}]}),
            b,
        )
        .unwrap();
        assert!(
            s.warnings
                .iter()
                .any(|w| w.contains("not a unit quaternion")),
            "{:?}",
            s.warnings
        );
        assert!(
            s.instances[0].transform.abs_diff_eq(Mat4::IDENTITY, 1e-6),
            "{:?}",
            s.instances[0].transform
        );
        // Integer positions without the extension.
        let mut b = Bin::default();
        let off = b.bytes.len();
        b.bytes.extend([0u8, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0]);
        b.views
            .push(json!({"buffer": 0, "byteOffset": off, "byteLength": 12}));
        b.accessors
            .push(json!({"bufferView": 0, "componentType": 5121, "count": 3,
                                "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}));
        let e = err(
            "byte-positions",
            json!({"meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
                   "nodes": [{"mesh": 0}]}),
            b,
        );
        assert!(e.contains("KHR_mesh_quantization"), "{e}");
        // A version other than 2.x (written past `load`, which sets 2.0).
        let dir = std::env::temp_dir().join(format!("stereocache-gltf-v3-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("v3.gltf");
        std::fs::write(&path, r#"{"asset": {"version": "3.0"}}"#).unwrap();
        let e = load_gltf(&path).unwrap_err().to_string();
        std::fs::remove_dir_all(&dir).ok();
        assert!(e.contains("asset.version is '3.0'"), "{e}");
    }

    /// A KHR_animation_pointer channel (path "pointer", no node) used to
    /// make the whole file fail (the gltf crate requires a node and a core
    /// path); it is dropped with one warning per animation naming the
    /// extension, the animation's other channels play, and an animation
    /// left with none loads.
    #[test]
    fn animation_pointer_channels_are_dropped_with_one_warning_per_animation() {
        let doc_with = |channels: Value| {
            let mut b = Bin::default();
            let pos = b.floats(&TRIANGLE, "VEC3", 3);
            let times = b.floats(&[0.0, 1.0], "SCALAR", 1);
            let moved = b.floats(&[0.0, 0.0, 0.0, 2.0, 0.0, 0.0], "VEC3", 3);
            let roughness = b.floats(&[0.0, 1.0], "SCALAR", 1);
            let doc = json!({
                "extensionsUsed": ["KHR_animation_pointer"],
                "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
                "nodes": [{"mesh": 0}],
                "scenes": [{"nodes": [0]}],
                "animations": [{"name": "glow", "channels": channels, "samplers": [
                    {"input": times, "output": roughness},
                    {"input": times, "output": moved}]}]
            });
            (doc, b)
        };
        let pointer = json!({"sampler": 0, "target": {"path": "pointer", "extensions":
            {"KHR_animation_pointer": {"pointer": "/materials/0/pbrMetallicRoughness/roughnessFactor"}}}});
        // Alone: the animation loads with no channel.
        let (doc, b) = doc_with(json!([pointer.clone()]));
        let s = load("pointer", doc, b).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.warnings.len(), 1, "{:#?}", s.warnings);
        let w = &s.warnings[0];
        for part in [
            "pointer.gltf: animation 'glow': channel 0 animates through KHR_animation_pointer",
            "ignored",
        ] {
            assert!(w.contains(part), "'{part}' missing in: {w}");
        }
        let a = s.animation.as_ref().expect("the animation is kept");
        assert!(a.animations[0].channels.is_empty());
        // Before a translation channel using sampler 1: that one plays.
        let translation = json!({"sampler": 1, "target": {"node": 0, "path": "translation"}});
        let (doc, b) = doc_with(json!([pointer, translation]));
        let s = load("pointer-and-trs", doc, b).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.warnings.len(), 1, "{:#?}", s.warnings);
        let x = s.instance_transforms_at(0.5)[0].w_axis.x;
        assert!((x - 1.0).abs() < 1e-5, "{x}");
        // No node and no extension: nothing to animate, dropped too.
        let nodeless = json!({"sampler": 1, "target": {"path": "translation"}});
        let (doc, b) = doc_with(json!([nodeless]));
        let s = load("nodeless", doc, b).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            s.warnings.iter().any(|w| w.contains(
                "animation 'glow': channel 0 targets no node and no extension defines one"
            )),
            "{:#?}",
            s.warnings
        );
        // A path that is neither glTF's nor an extension's stays an error.
        let typo = json!({"sampler": 1, "target": {"node": 0, "path": "colour"}});
        let (doc, b) = doc_with(json!([typo]));
        let e = load("typo", doc, b).unwrap_err().to_string();
        assert!(
            e.contains("animation 'glow' channel 0: unknown target path 'colour'"),
            "{e}"
        );
    }

    /// glTF 2.0 §3.7.2.1: a primitive without POSITION is skipped (the gltf
    /// crate would refuse the document), with a warning; the rest renders.
    #[test]
    fn a_primitive_without_position_is_skipped_with_a_warning() {
        let mut b = Bin::default();
        let normal = b.floats(&[0.0, 0.0, 1.0].repeat(3), "VEC3", 3);
        let pos = b.floats(&TRIANGLE, "VEC3", 3);
        let doc = json!({
            "meshes": [
                {"name": "ghost", "primitives": [{"attributes": {"NORMAL": normal}}]},
                {"primitives": [{"attributes": {"POSITION": pos}}]}
            ],
            "nodes": [{"mesh": 0}, {"mesh": 1}],
            "scenes": [{"nodes": [0, 1]}]
        });
        let s = load("no-position", doc, b).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.meshes.len(), 1);
        assert_eq!(s.meshes[0].positions.len(), 3);
        assert_eq!(s.instances.len(), 1);
        assert!(
            s.warnings.iter().any(|w| w.contains(
                "no-position.gltf: mesh 0 'ghost' primitive 0 has no POSITION attribute; skipped"
            )),
            "{:#?}",
            s.warnings
        );
    }

    /// glTF 2.0 §5.1.1: an accessor without bufferView (and without sparse)
    /// reads as zeros; the gltf crate refused it. A morph target of zeros
    /// with weight 1 leaves the base positions.
    #[test]
    fn an_accessor_without_buffer_view_reads_as_zeros() {
        let mut b = Bin::default();
        let pos = b.floats(&TRIANGLE, "VEC3", 3);
        b.accessors
            .push(json!({"componentType": 5126, "count": 3, "type": "VEC3"}));
        let zeros = b.accessors.len() - 1;
        let doc = json!({
            "meshes": [{"weights": [1.0], "primitives": [{"attributes": {"POSITION": pos},
                                                            "targets": [{"POSITION": zeros}]}]}],
            "nodes": [{"mesh": 0}],
            "scenes": [{"nodes": [0]}]
        });
        let s = load("zeros", doc, b).unwrap_or_else(|e| panic!("{e}"));
        let base: Vec<Vec3> = TRIANGLE
            .chunks_exact(3)
            .map(|p| Vec3::from_slice(p))
            .collect();
        assert_eq!(s.meshes[0].positions, base);
    }

    /// A material with a base colour texture and an emissive texture of
    /// another transform: lit, the emissive texture takes the second uv
    /// channel; unlit, the base colour texture moved to the emissive slot
    /// reads the base colour's uvs (one channel, no map).
    #[test]
    fn unlit_moves_the_base_colour_texture_with_its_uvs() {
        let material = |unlit: bool| {
            let mut m = json!({
                "doubleSided": true,
                "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
                "emissiveTexture": {"index": 0, "extensions":
                    {"KHR_texture_transform": {"offset": [0.5, 0.0]}}}
            });
            if unlit {
                m["extensions"] = json!({"KHR_materials_unlit": {}});
            }
            m
        };
        let mut b = Bin::default();
        let pos = b.floats(&TRIANGLE, "VEC3", 3);
        let uv = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC2", 2);
        let doc = json!({
            "extensionsUsed": ["KHR_texture_transform", "KHR_materials_unlit"],
            "images": [{"uri": PNG}],
            "textures": [{"source": 0}],
            "materials": [material(false), material(true)],
            "meshes": [
                {"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "material": 0}]},
                {"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "material": 1}]}
            ],
            "nodes": [{"mesh": 0}, {"mesh": 1}],
            "scenes": [{"nodes": [0, 1]}]
        });
        let s = load("unlit-uvs", doc, b).unwrap_or_else(|e| panic!("{e}"));
        const EMISSIVE: u32 = 1 << EMISSIVE_SLOT;
        let lit = &s.materials[0];
        assert_eq!(lit.second_uv_slots & EMISSIVE, EMISSIVE, "{lit:?}");
        let m = &s.materials[1];
        assert!(m.unlit);
        assert_eq!(m.emissive_texture, m.base_color_texture);
        assert_eq!(
            m.second_uv_slots & EMISSIVE,
            (m.second_uv_slots & (1 << BASE_COLOR_SLOT)) << EMISSIVE_SLOT,
            "{m:?}"
        );
        assert_eq!(m.uv_affine[EMISSIVE_SLOT], m.uv_affine[BASE_COLOR_SLOT]);
        let unlit_mesh = s.meshes.iter().find(|x| x.material == 1).unwrap();
        assert!(unlit_mesh.uvs2.is_empty(), "one uv channel");
    }

    /// alphaCutoff has minimum 0 and no maximum (glTF schema); MASK keeps
    /// alpha ≥ cutoff, so 1.5 cuts everything and is kept, not clamped.
    #[test]
    fn an_alpha_cutoff_above_one_is_kept() {
        let mut b = Bin::default();
        let pos = b.floats(&TRIANGLE, "VEC3", 3);
        let doc = json!({
            "materials": [{"doubleSided": true, "alphaMode": "MASK", "alphaCutoff": 1.5}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "material": 0}]}],
            "nodes": [{"mesh": 0}],
            "scenes": [{"nodes": [0]}]
        });
        let s = load("cutoff", doc, b).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.materials[0].alpha_cutoff, 1.5);
        assert!(
            !s.warnings.iter().any(|w| w.contains("alphaCutoff")),
            "{:#?}",
            s.warnings
        );
    }

    /// KHR_materials_volume needs transmission: on an opaque single-sided
    /// material it is no volume, and back faces stay culled.
    #[test]
    fn a_volume_without_transmission_keeps_back_face_culling() {
        let mut b = Bin::default();
        let pos = b.floats(&TRIANGLE, "VEC3", 3);
        let volume = json!({"KHR_materials_volume": {"thicknessFactor": 0.5}});
        let mut glass = volume.clone();
        glass["KHR_materials_transmission"] = json!({"transmissionFactor": 1.0});
        let doc = json!({
            "extensionsUsed": ["KHR_materials_volume", "KHR_materials_transmission"],
            "materials": [{"extensions": volume}, {"extensions": glass}],
            "meshes": [
                {"primitives": [{"attributes": {"POSITION": pos}, "material": 0}]},
                {"primitives": [{"attributes": {"POSITION": pos}, "material": 1}]}
            ],
            "nodes": [{"mesh": 0}, {"mesh": 1}],
            "scenes": [{"nodes": [0, 1]}]
        });
        let s = load("volume", doc, b).unwrap_or_else(|e| panic!("{e}"));
        let opaque = &s.materials[0];
        assert!(!opaque.double_sided);
        assert!(opaque.volume.is_none());
        assert!(opaque.culls_back_faces());
        let glass = &s.materials[1];
        assert!(glass.volume.is_some());
        assert!(!glass.culls_back_faces());
    }
}
