//! What of glTF 2.0 the importer implements, and one warning for whatever a
//! file uses that it does not.
//!
//! [`FEATURES`] is the one table of glTF features and extensions: each is
//! implemented ([`Support::Full`]), implemented in part ([`Support::Partly`],
//! saying how), not applicable to a path tracer ([`Support::NotApplicable`]),
//! or not implemented ([`Support::Ignored`], saying what is done instead).
//! README's "glTF support" table is this table (tests/gltf_features.rs checks
//! that they agree).
//!
//! [`warn_unsupported`] walks a document's JSON before import and emits one
//! warning per feature used that is not fully implemented, naming the file,
//! the items that use it (materials, meshes, nodes) and what is done instead.
//! Features whose importer code already warns at the point where it drops
//! them (`warned_elsewhere`) are left to that code, so nothing is said twice.

use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// How far the importer implements a feature.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// Implemented as the specification says (the note says how, if needed).
    Full,
    /// Implemented in part; the note says which part.
    Partly,
    /// Nothing to do for a path tracer (metadata, or a raster approximation of
    /// what the path tracer computes); the note says why.
    NotApplicable,
    /// Not implemented; the note says what is done instead.
    Ignored,
}

impl Support {
    /// The word README's table uses.
    pub fn word(self) -> &'static str {
        match self {
            Support::Full => "supported",
            Support::Partly => "partly",
            Support::NotApplicable => "not applicable",
            Support::Ignored => "warned",
        }
    }
}

/// One glTF feature or extension.
#[derive(Clone, Copy, Debug)]
pub struct Feature {
    /// The extension's name, or a core feature's name as README writes it.
    pub name: &'static str,
    pub support: Support,
    /// How it is implemented, or what is done instead.
    pub note: &'static str,
    /// The importer warns at the place where it drops this feature (so the
    /// walk here stays silent about it).
    pub warned_elsewhere: bool,
}

const fn f(name: &'static str, support: Support, note: &'static str) -> Feature {
    Feature {
        name,
        support,
        note,
        warned_elsewhere: false,
    }
}

const fn elsewhere(name: &'static str, support: Support, note: &'static str) -> Feature {
    Feature {
        name,
        support,
        note,
        warned_elsewhere: true,
    }
}

use Support::{Full, Ignored, NotApplicable, Partly};

/// Every glTF feature and extension the importer knows of. Core features
/// first, then extensions in alphabetical order.
pub const FEATURES: &[Feature] = &[
    f("triangles", Full, "indexed and non-indexed triangle lists"),
    f(
        "triangle strips and fans",
        Full,
        "converted to triangle lists with the glTF topology rules' winding",
    ),
    elsewhere(
        "points and lines",
        Ignored,
        "the primitive is skipped (a path tracer has no width for them)",
    ),
    f(
        "POSITION, NORMAL",
        Full,
        "missing normals are flat (each triangle's own, as glTF requires; supplied tangents are then ignored and regenerated); NaN/Inf vertices drop their triangles",
    ),
    f(
        "TANGENT",
        Full,
        "missing tangents are generated with MikkTSpace (the `mikktspace` crate, on the \
         transformed uvs) where a material has a normal map; supplied tangents are kept, turned \
         in the tangent plane to follow a KHR_texture_transform rotation or mirror",
    ),
    f(
        "TEXCOORD_0",
        Full,
        "missing uvs are zeros (warned where the material has textures)",
    ),
    elsewhere(
        "TEXCOORD_1 and texCoord",
        Partly,
        "two uv channels per material: each texture reads the set it names (texCoord, or the \
         KHR_texture_transform override) under its transform. Channel 1 holds the base colour \
         texture's (set, transform), channel 2 the first other uv set's (else the first other \
         transform, the normal texture's first); further transforms of those sets are read \
         through a map (KHR_texture_transform below), the normal texture's with tangents of \
         its own uvs; a texture naming a third uv set reads the base colour texture's uvs, and \
         a warning names it",
    ),
    f(
        "COLOR_0",
        Full,
        "vertex colours (RGB or RGBA; float, normalized byte or short) multiply the base colour and its alpha",
    ),
    f(
        "COLOR_1 and further colour sets",
        Ignored,
        "only COLOR_0 multiplies the base colour (as the glTF specification says)",
    ),
    f(
        "application-specific attributes (_NAME)",
        Ignored,
        "attributes named with a leading underscore (glTF: application-specific semantics) \
         mean nothing to a renderer; ignored",
    ),
    f(
        "skins (JOINTS_0, WEIGHTS_0)",
        Ignored,
        "skinned meshes render in their bind pose",
    ),
    f(
        "morph targets",
        Full,
        "the default weights (node.weights, else mesh.weights) applied to POSITION, NORMAL and \
         TANGENT at import (sparse accessors too); animated weights are warned",
    ),
    f(
        "animation (translation, rotation, scale)",
        Full,
        "STEP, LINEAR and CUBICSPLINE samplers; several animations, picked by --animation",
    ),
    elsewhere(
        "animation of morph weights",
        Ignored,
        "those channels are ignored",
    ),
    f(
        "sparse accessors",
        Full,
        "substituted into the base data (or zeros)",
    ),
    f(
        "normalized integer attributes",
        Full,
        "mapped to floats as glTF §3.11 says",
    ),
    f(
        "node hierarchy (matrix or TRS)",
        Full,
        "flattened into instances; a mesh used by several nodes is stored once",
    ),
    f(
        "several scenes",
        Partly,
        "the default scene (or the first) is imported; the others are not",
    ),
    f(
        "perspective cameras",
        Full,
        "yfov; aspectRatio is read, the image's own aspect (`--size`) is used, as the Khronos sample viewer does; zfar is not needed by a ray tracer; znear: the next row",
    ),
    f(
        "orthographic cameras",
        Full,
        "parallel rays from the image plane, ymag with the image's aspect (as aspectRatio); zfar is not needed by a ray tracer; znear: the next row",
    ),
    f(
        "camera znear beyond 1 cm",
        Ignored,
        "read and checked, but no renderer clips at it: primary rays start at the eye (on the image plane for orthographic cameras), so geometry nearer than znear is drawn; warned where a camera's znear exceeds 1 cm",
    ),
    f(
        "metallic-roughness materials",
        Full,
        "factors and textures (base colour, metallic-roughness, normal with scale, emissive)",
    ),
    f(
        "occlusionTexture",
        NotApplicable,
        "a path tracer computes occlusion; the texture would count it twice",
    ),
    f(
        "alphaMode BLEND",
        Full,
        "stochastic coverage: a screen door of 2^16 × 2^16 barycentric cells per triangle, each \
         solid with probability alpha, fixed on the surface for every ray (camera, shadow, \
         light sampling, the sample cache's retrace), so paths average to the alpha blend",
    ),
    f("alphaMode MASK", Full, "alphaCutoff against base colour alpha"),
    f(
        "single-sided materials (doubleSided false)",
        Full,
        "back faces are culled for every ray (camera, path, shadow, the caches' retraces): a ray \
         meeting one from behind passes through; the front is counter-clockwise in object space, \
         so mirrored nodes keep theirs; emission is front-only; volume boundaries never cull",
    ),
    f(
        "texture samplers (wrap modes, filters)",
        Full,
        "REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT; NEAREST/LINEAR magnification; the six \
         minification filters (without mipmaps: level 0 only); an invalid value is warned and \
         replaced by that field's default",
    ),
    f(
        "extras",
        NotApplicable,
        "application data; stereocache reads only its own material-graph bindings",
    ),
    elsewhere(
        "AMD_split_roughnessMetallic",
        Ignored,
        "the separate roughness/metallic textures are ignored; factors are used",
    ),
    f(
        "EXT_lights_image_based",
        Ignored,
        "the image-based light is not read; default lighting applies",
    ),
    f(
        "EXT_mesh_gpu_instancing",
        Full,
        "one instance per element of TRANSLATION/ROTATION/SCALE, sharing the node's meshes",
    ),
    f(
        "EXT_meshopt_compression",
        Partly,
        "not decoded: the uncompressed fallback buffers are read; a file that requires it is refused",
    ),
    elsewhere(
        "EXT_texture_webp",
        Partly,
        "the PNG/JPEG fallback source is used; a texture without one falls back to its factor",
    ),
    elsewhere(
        "KHR_animation_pointer",
        Ignored,
        "those animation channels are ignored (one warning per animation); its other channels play",
    ),
    f(
        "KHR_draco_mesh_compression",
        Partly,
        "not decoded: the uncompressed fallback is read; a file that requires it is refused",
    ),
    f(
        "KHR_lights_punctual",
        Full,
        "point, spot and directional lights; intensities as linear radiometric units; range and spot-cone falloffs as the extension recommends",
    ),
    f(
        "KHR_materials_anisotropy",
        Ignored,
        "rendered isotropic",
    ),
    f(
        "KHR_materials_clearcoat",
        Full,
        "a GGX coat of ior 1.5 over the base (factor, roughness and their textures; its own \
         normal texture, in the tangent frame of the uvs it reads (the triangle's, from the \
         gradients of its channel's uvs through its uv map if any, where those are not the \
         uvs the vertex tangents belong to), else the interpolated normal), layered as the extension's fresnel_coat: \
         f_coat + (1 − clearcoat·Fc(n_c·v))·f_base, emission under it dimmed by the same \
         1 − clearcoat·Fc; over transmission it reflects on the outside",
    ),
    f(
        "KHR_materials_diffuse_transmission",
        Ignored,
        "rendered without diffuse transmission",
    ),
    f(
        "KHR_materials_dispersion",
        Ignored,
        "rendered without dispersion",
    ),
    f("KHR_materials_emissive_strength", Full, ""),
    f("KHR_materials_ior", Full, ""),
    f(
        "KHR_materials_iridescence",
        Ignored,
        "rendered without iridescence",
    ),
    f("KHR_materials_sheen", Ignored, "rendered without sheen"),
    f(
        "KHR_materials_specular",
        Full,
        "specularFactor × specularTexture (A) weighs the dielectric Fresnel layer and \
         specularColorFactor × specularColorTexture tints its F0 (min(F0(ior)·colour, 1)); on \
         transmissive surfaces the transmitted part keeps 1 − specular·max(Fr) (the extension's \
         fresnel_mix, with the exact Fresnel's shape between F0 and 1)",
    ),
    f(
        "KHR_materials_transmission",
        Full,
        "transmissionFactor and transmissionTexture; without KHR_materials_volume the surface is \
         thin-walled (light passes straight through or reflects, split by the Fresnel of the ior), \
         with it a boundary that refracts with the ior; nested, as glTF's BRDF nests it, inside \
         the dielectric of mix(dielectric, metal, metallic), so a surface transmits t·(1 − \
         metallic)",
    ),
    f(
        "KHR_materials_unlit",
        Full,
        "an emitter of the base colour (factor × texture × COLOR_0) with a black BSDF: the \
         surface shows exactly its base colour and reflects nothing; as any emitter it also \
         lights its surroundings; the glTF writer gives it back as unlit",
    ),
    f(
        "KHR_materials_variants",
        Ignored,
        "the primitives' default materials are used",
    ),
    f(
        "KHR_materials_volume",
        Full,
        "thicknessFactor > 0 on a transmissive material: a volume boundary that refracts and whose inside absorbs by \
         Beer–Lambert (attenuationColor, attenuationDistance) along the traced path (the \
         thickness value and its texture are for rasterizers); thicknessFactor 0 is thin-walled; \
         without KHR_materials_transmission the extension has no effect (as it says); \
         volumes nest and overlap as the extension's implementation notes suggest (Schmidt & \
         Budge's nested dielectrics, without priorities: the volume entered last fills an \
         overlap; each interface refracts with the ratio of the indices on its sides; touching \
         or overlapping objects of one material are one medium; up to 4 deep)",
    ),
    f(
        "KHR_mesh_quantization",
        Full,
        "integer and normalized attributes are read as glTF §3.11 says",
    ),
    elsewhere(
        "KHR_texture_basisu",
        Partly,
        "KTX2 images are not decoded: the PNG/JPEG fallback source is used, or the factor",
    ),
    f(
        "KHR_texture_procedurals",
        Full,
        "MaterialX graphs bound to materials (docs/MATERIALS.md); `texcoord` index 0 and 1 \
         read TEXCOORD_0 and TEXCOORD_1 untransformed",
    ),
    elsewhere(
        "KHR_texture_transform",
        Partly,
        "per texture: offset, rotation and scale (rotation as the spec's example and sample \
         model, glTF issue 1563). The (set, transform) pairs of a material's two uv channels \
         are applied at import; a texture with a further transform of a set a channel holds \
         reads that channel through the affine map between the two transforms at shading \
         time (spec constant SC_UV_AFFINE; a normal texture with MikkTSpace tangents of its \
         own uvs, supplied ones turned by its transform; a clearcoat normal texture on \
         other uvs than the normal texture's in the triangle's frame of its own uvs). Not \
         done: where a channel's own transform is singular (a zero scale), a further \
         transform of its set reads the first channel's uvs (the first bound slot's, named \
         in the warning). The glTF writer refuses a map that shears (one error) and stores \
         tangents turned back by the transform of the texture they serve",
    ),
    f(
        "KHR_xmp_json_ld",
        NotApplicable,
        "metadata; nothing to render",
    ),
    elsewhere(
        "MSFT_texture_dds",
        Partly,
        "DDS images are not decoded: the PNG/JPEG fallback source is used, or the factor",
    ),
];

/// The table's row for `name`.
pub fn feature(name: &str) -> Option<&'static Feature> {
    FEATURES.iter().find(|f| f.name == name)
}

/// One warning per feature `json` uses that the importer does not implement
/// fully and does not already warn about elsewhere: "FILE: FEATURE (used by
/// ITEMS): WHAT IS DONE INSTEAD". Extensions the table does not know get a
/// warning of their own.
pub fn warn_unsupported(path: &Path, json: &Value) -> Vec<String> {
    let mut out = Vec::new();
    for (name, items) in features_used(json) {
        let (support, note) = match feature(&name) {
            Some(f) if f.warned_elsewhere => continue,
            Some(f) => (f.support, f.note),
            None => (
                Ignored,
                "stereocache does not know this extension; it is ignored",
            ),
        };
        if matches!(support, Full | NotApplicable) {
            continue;
        }
        let what = if support == Partly {
            "is supported in part"
        } else {
            "is not supported"
        };
        out.push(format!(
            "{}: {name} {what} (used by {}): {note}",
            path.display(),
            summarize(&items)
        ));
    }
    out
}

/// Lists up to four items and counts the rest.
fn summarize(items: &[String]) -> String {
    const SHOWN: usize = 4;
    let mut s = items
        .iter()
        .take(SHOWN)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if items.len() > SHOWN {
        s.push_str(&format!(" and {} more", items.len() - SHOWN));
    }
    s
}

/// Every feature of [`FEATURES`] (by name) or unknown extension that `json`
/// uses, with the items that use it. Only the uses that change what is
/// rendered count: an extension listed in `extensionsUsed` but found on no
/// item is listed against "extensionsUsed".
pub fn features_used(json: &Value) -> BTreeMap<String, Vec<String>> {
    let mut used: BTreeMap<String, Vec<String>> = BTreeMap::new();
    fn add_to(used: &mut BTreeMap<String, Vec<String>>, name: &str, item: String) {
        let v = used.entry(name.to_owned()).or_default();
        if !v.contains(&item) {
            v.push(item);
        }
    }
    macro_rules! add {
        ($name:expr, $item:expr $(,)?) => {
            add_to(&mut used, $name, $item)
        };
    }
    let array = |key: &str| {
        json.get(key)
            .and_then(Value::as_array)
            .cloned()
            .unwrap_or_default()
    };
    let label = |kind: &str, i: usize, v: &Value| match v.get("name").and_then(Value::as_str) {
        Some(n) => format!("{kind} {i} '{n}'"),
        None => format!("{kind} {i}"),
    };

    // Extensions wherever they are attached, by the item that carries them.
    let mut extension_items: BTreeMap<String, Vec<String>> = BTreeMap::new();
    collect_extensions(json, "the document", &mut extension_items, &label);
    for name in array("extensionsUsed")
        .iter()
        .chain(array("extensionsRequired").iter())
        .filter_map(Value::as_str)
    {
        if !extension_items.contains_key(name) {
            add!(name, "extensionsUsed".into());
        }
    }
    for (name, items) in &extension_items {
        items.iter().for_each(|i| add!(name, i.clone()));
    }

    for (mi, mesh) in array("meshes").iter().enumerate() {
        let mesh_label = label("mesh", mi, mesh);
        let prims = mesh.get("primitives").and_then(Value::as_array);
        for p in prims.into_iter().flatten() {
            if let Some(attrs) = p.get("attributes").and_then(Value::as_object) {
                for key in attrs.keys() {
                    if key.starts_with("COLOR_") && key != "COLOR_0" {
                        add!("COLOR_1 and further colour sets", mesh_label.clone());
                    } else if key.starts_with('_') {
                        add!(
                            "application-specific attributes (_NAME)",
                            mesh_label.clone()
                        );
                    } else if key.starts_with("JOINTS_") || key.starts_with("WEIGHTS_") {
                        add!("skins (JOINTS_0, WEIGHTS_0)", mesh_label.clone());
                    }
                }
            }
            if p.get("targets")
                .and_then(Value::as_array)
                .is_some_and(|t| !t.is_empty())
            {
                add!("morph targets", mesh_label.clone());
            }
        }
    }
    for (si, skin) in array("skins").iter().enumerate() {
        add!("skins (JOINTS_0, WEIGHTS_0)", label("skin", si, skin));
    }
    // znear is not applied (no near clipping); at most 1 cm (the default
    // near distance, camera/stereo.rs DEFAULT_ZNEAR) it clips next to
    // nothing, so only larger values are named.
    for (ci, c) in array("cameras").iter().enumerate() {
        let znear = ["perspective", "orthographic"]
            .iter()
            .filter_map(|k| c.get(*k)?.get("znear")?.as_f64())
            .next();
        if znear.is_some_and(|z| z > crate::camera::DEFAULT_ZNEAR as f64 * (1.0 + 1e-6)) {
            add!("camera znear beyond 1 cm", label("camera", ci, c));
        }
    }
    let scenes = array("scenes");
    if scenes.len() > 1 {
        add!("several scenes", format!("{} scenes", scenes.len()));
    }
    for (mi, m) in array("materials").iter().enumerate() {
        if !m
            .get("doubleSided")
            .and_then(Value::as_bool)
            .unwrap_or(false)
        {
            add!(
                "single-sided materials (doubleSided false)",
                label("material", mi, m),
            );
        }
    }
    for (si, s) in array("samplers").iter().enumerate() {
        const REPEAT: u64 = 10497;
        const LINEAR: u64 = 9729;
        const LINEAR_MIPMAP_LINEAR: u64 = 9987;
        let is = |key: &str, default: u64| {
            s.get(key)
                .and_then(Value::as_u64)
                .is_none_or(|v| v == default)
        };
        // The one sampler every texture gets: repeat, linear magnification,
        // trilinear minification (a missing filter lets the viewer choose).
        let default = is("wrapS", REPEAT)
            && is("wrapT", REPEAT)
            && is("magFilter", LINEAR)
            && is("minFilter", LINEAR_MIPMAP_LINEAR);
        if !default {
            add!(
                "texture samplers (wrap modes, filters)",
                label("sampler", si, s),
            );
        }
    }
    used
}

/// Every `extensions` object below `v`, by the name of the nearest item
/// (material, mesh, node, texture, …) that holds it.
fn collect_extensions(
    v: &Value,
    item: &str,
    out: &mut BTreeMap<String, Vec<String>>,
    label: &dyn Fn(&str, usize, &Value) -> String,
) {
    const ITEMS: &[(&str, &str)] = &[
        ("materials", "material"),
        ("meshes", "mesh"),
        ("nodes", "node"),
        ("textures", "texture"),
        ("images", "image"),
        ("cameras", "camera"),
        ("animations", "animation"),
        ("scenes", "scene"),
        ("samplers", "sampler"),
        ("accessors", "accessor"),
        ("bufferViews", "bufferView"),
        ("buffers", "buffer"),
        ("skins", "skin"),
    ];
    match v {
        Value::Object(map) => {
            for (key, child) in map {
                if key == "extensions" {
                    if let Some(exts) = child.as_object() {
                        for name in exts.keys() {
                            let items = out.entry(name.clone()).or_default();
                            if !items.iter().any(|i| i == item) {
                                items.push(item.to_owned());
                            }
                        }
                    }
                    // Extensions nest (an extension's own textureInfo may
                    // carry KHR_texture_transform).
                    collect_extensions(child, item, out, label);
                } else if key == "extras" {
                    continue;
                } else if let (Some((_, kind)), Some(list)) =
                    (ITEMS.iter().find(|(k, _)| k == key), child.as_array())
                {
                    for (i, elem) in list.iter().enumerate() {
                        collect_extensions(elem, &label(kind, i, elem), out, label);
                    }
                } else {
                    collect_extensions(child, item, out, label);
                }
            }
        }
        Value::Array(list) => {
            for elem in list {
                collect_extensions(elem, item, out, label);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn names_are_unique_and_notes_say_what_is_done_instead() {
        for (i, a) in FEATURES.iter().enumerate() {
            assert!(
                FEATURES[i + 1..].iter().all(|b| b.name != a.name),
                "{} twice",
                a.name
            );
            if matches!(a.support, Partly | Ignored | NotApplicable) {
                assert!(!a.note.is_empty(), "{} needs a note", a.name);
            }
        }
    }

    #[test]
    fn a_texture_transform_is_left_to_the_importer() {
        let doc = json!({
            "extensionsUsed": ["KHR_texture_transform", "KHR_materials_emissive_strength"],
            "materials": [
                {"name": "label", "doubleSided": true,
                 "pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
                    "extensions": {"KHR_texture_transform": {"scale": [2, 2]}}}}},
                {"doubleSided": true,
                 "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}}
            ]
        });
        // The walk finds the extension, but the importer applies it and
        // warns only where a material's slots disagree (gltf_uv).
        assert_eq!(
            features_used(&doc)["KHR_texture_transform"],
            ["material 0 'label'"]
        );
        let w = warn_unsupported(Path::new("a.gltf"), &doc);
        assert!(w.is_empty(), "{w:?}");
    }

    #[test]
    fn unknown_extensions_and_silent_core_features_are_warned() {
        let doc = json!({
            "extensionsUsed": ["VENDOR_magic"],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 1, "COLOR_1": 3},
                                        "targets": [{"POSITION": 2}]}]}],
            "materials": [{}],
            "skins": [{"joints": [0]}],
            "samplers": [{"wrapS": 33071}, {"magFilter": 9729}]
        });
        let w = warn_unsupported(Path::new("b.glb"), &doc);
        let has = |s: &str| w.iter().any(|x| x.contains(s));
        assert!(
            has("VENDOR_magic is not supported (used by extensionsUsed)"),
            "{w:?}"
        );
        assert!(!has("COLOR_0 is not supported"), "{w:?}");
        assert!(
            has("COLOR_1 and further colour sets is not supported (used by mesh 0)"),
            "{w:?}"
        );
        assert!(!has("morph targets"), "{w:?}");
        assert!(
            has("skins (JOINTS_0, WEIGHTS_0) is not supported (used by skin 0)"),
            "{w:?}"
        );
        // Samplers and single-sided materials (back-face culling) are
        // implemented: no word about them.
        assert!(!has("single-sided"), "{w:?}");
        assert!(!has("sampler"), "{w:?}");
        assert_eq!(w.len(), 3, "{w:?}");
    }
}
