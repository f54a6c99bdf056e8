//! Nothing of a glTF file is dropped without a word: every feature a file
//! uses is implemented or warned, and README's table is the importer's
//! (src/scene/gltf_features.rs). CPU only, fast.
//!
//! The walk here is written apart from the importer's own: it lists what a
//! document uses straight from the glTF 2.0 schema (extensionsUsed, primitive
//! modes and attributes, morph targets, skins, animation paths, camera types,
//! material flags, samplers, scenes), so a feature the importer's walk forgets
//! fails here.

use base64::Engine as _;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use stereocache::scene::gltf_features::{feature, Support, FEATURES};
use stereocache::scene::load_gltf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README's "glTF support" table as (feature, support word, note) rows.
fn readme_rows() -> Vec<(String, String, String)> {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let section = text
        .split("\n## glTF support")
        .nth(1)
        .expect("README has a '## glTF support' section");
    let section = section.split("\n## ").next().unwrap();
    section
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| feature") && !l.starts_with("|--"))
        .map(|l| {
            let cells: Vec<String> = l
                .trim_matches('|')
                .split(" | ")
                .map(|c| c.trim().trim_matches('`').to_owned())
                .collect();
            assert_eq!(cells.len(), 3, "README row with other than 3 cells: {l}");
            (cells[0].clone(), cells[1].clone(), cells[2].clone())
        })
        .collect()
}

fn expected_table() -> String {
    let mut s = String::from("| feature | support | what stereocache does |\n|---|---|---|\n");
    for f in FEATURES {
        s.push_str(&format!(
            "| `{}` | {} | {} |\n",
            f.name,
            f.support.word(),
            f.note
        ));
    }
    s
}

#[test]
fn readme_table_is_the_importers_feature_table() {
    let rows = readme_rows();
    let want: Vec<(String, String, String)> = FEATURES
        .iter()
        .map(|f| {
            (
                f.name.to_owned(),
                f.support.word().to_owned(),
                f.note.to_owned(),
            )
        })
        .collect();
    assert_eq!(
        rows,
        want,
        "README's glTF support table differs from src/scene/gltf_features.rs; it should read:\n{}",
        expected_table()
    );
}

/// The features `doc` uses, by the table's names (unknown extensions by their
/// own name), walked from the glTF schema.
fn used_by(doc: &Value) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut add = |s: &str| {
        if !out.iter().any(|o| o == s) {
            out.push(s.to_owned());
        }
    };
    let list = |key: &str| doc[key].as_array().cloned().unwrap_or_default();
    for e in list("extensionsUsed") {
        let name = e.as_str().unwrap();
        // A texture transform:
        // only where a material's textures have different ones (one
        // transform per material is implemented).
        if name != "KHR_texture_transform" {
            add(name);
        }
    }
    for m in list("meshes") {
        for p in m["primitives"].as_array().unwrap() {
            match p["mode"].as_u64().unwrap_or(4) {
                0..=3 => add("points and lines"),
                5 | 6 => add("triangle strips and fans"),
                _ => add("triangles"),
            }
            for (k, _) in p["attributes"].as_object().unwrap() {
                match k.as_str() {
                    "POSITION" | "NORMAL" => add("POSITION, NORMAL"),
                    "TANGENT" => add("TANGENT"),
                    "TEXCOORD_0" => add("TEXCOORD_0"),
                    "COLOR_0" => add("COLOR_0"),
                    k if k.starts_with("COLOR_") => add("COLOR_1 and further colour sets"),
                    k if k.starts_with('_') => add("application-specific attributes (_NAME)"),
                    k if k.starts_with("JOINTS_") || k.starts_with("WEIGHTS_") => {
                        add("skins (JOINTS_0, WEIGHTS_0)")
                    }
                    _ => {}
                }
            }
            if p["targets"].as_array().is_some_and(|t| !t.is_empty()) {
                add("morph targets");
            }
        }
    }
    if !list("skins").is_empty() {
        add("skins (JOINTS_0, WEIGHTS_0)");
    }
    for a in list("animations") {
        for c in a["channels"].as_array().unwrap() {
            if c["target"]["path"] == "weights" {
                add("animation of morph weights");
            } else {
                add("animation (translation, rotation, scale)");
            }
        }
    }
    for c in list("cameras") {
        let kind = if c["type"] == "orthographic" {
            "orthographic"
        } else {
            "perspective"
        };
        add(&format!("{kind} cameras"));
        // Near clipping is not implemented: a znear above the 1 cm default.
        if c[kind]["znear"].as_f64().is_some_and(|z| z > 0.010_000_1) {
            add("camera znear beyond 1 cm");
        }
    }
    if list("scenes").len() > 1 {
        add("several scenes");
    }
    for m in list("materials") {
        add("metallic-roughness materials");
        match m["alphaMode"].as_str() {
            Some("BLEND") => add("alphaMode BLEND"),
            Some("MASK") => add("alphaMode MASK"),
            _ => {}
        }
        if m["doubleSided"] != true {
            add("single-sided materials (doubleSided false)");
        }
        if m.get("occlusionTexture").is_some() {
            add("occlusionTexture");
        }
        // The textureInfos the renderer samples, in the order they claim the
        // two uv channels (base colour, normal, then the rest): two (uv set,
        // transform) choices per material get channels, a further transform
        // of a set a channel holds is read through a map, so the slots that
        // name a further set count.
        let mut infos = vec![
            &m["pbrMetallicRoughness"]["baseColorTexture"],
            &m["normalTexture"],
            &m["pbrMetallicRoughness"]["metallicRoughnessTexture"],
            &m["emissiveTexture"],
            &m["extensions"]["KHR_materials_transmission"]["transmissionTexture"],
            &m["extensions"]["KHR_materials_specular"]["specularTexture"],
            &m["extensions"]["KHR_materials_specular"]["specularColorTexture"],
            &m["extensions"]["KHR_materials_clearcoat"]["clearcoatTexture"],
            &m["extensions"]["KHR_materials_clearcoat"]["clearcoatRoughnessTexture"],
            &m["extensions"]["KHR_materials_clearcoat"]["clearcoatNormalTexture"],
        ];
        infos.retain(|t| t.is_object());
        let uv_set = |t: &Value| {
            let ext = &t["extensions"]["KHR_texture_transform"];
            ext["texCoord"]
                .as_u64()
                .or(t["texCoord"].as_u64())
                .unwrap_or(0)
        };
        let transform = |t: &Value| {
            let ext = &t["extensions"]["KHR_texture_transform"];
            let pair = |k: &str, d: f64| {
                let v = &ext[k];
                [v[0].as_f64().unwrap_or(d), v[1].as_f64().unwrap_or(d)]
            };
            let r = ext["rotation"].as_f64().unwrap_or(0.0);
            (pair("offset", 0.0), r, pair("scale", 1.0))
        };
        let choice = |t: &Value| (uv_set(t), transform(t));
        let mut channels = Vec::new();
        let mut third = Vec::new();
        for t in &infos {
            let c = choice(t);
            if channels.contains(&c) {
                continue;
            }
            if channels.len() < 2 {
                channels.push(c);
            } else if !channels.iter().any(|h| h.0 == c.0) {
                third.push(c);
            }
        }
        if third.iter().any(|c| c.0 != channels[0].0) {
            add("TEXCOORD_1 and texCoord");
        }
        if third.iter().any(|c| c.1 != channels[0].1) {
            add("KHR_texture_transform");
        }
    }
    for s in list("samplers") {
        let is = |k: &str, d: u64| s[k].as_u64().is_none_or(|v| v == d);
        if !(is("wrapS", 10497)
            && is("wrapT", 10497)
            && is("magFilter", 9729)
            && is("minFilter", 9987))
        {
            add("texture samplers (wrap modes, filters)");
        }
    }
    out
}

/// A word of the warning that says a feature warned by the importer's own
/// code (not by the feature table's walk) is dropped.
fn elsewhere_keyword(name: &str) -> &'static str {
    match name {
        "points and lines" => "triangle strips and triangle fans only",
        "TEXCOORD_1 and texCoord" => "different uv sets (texCoord)",
        "KHR_texture_transform" => "texture transforms (KHR_texture_transform)",
        "animation of morph weights" => "morph-target weights",
        "AMD_split_roughnessMetallic" => "AMD_split_roughnessMetallic",
        "KHR_animation_pointer" => "KHR_animation_pointer",
        _ => panic!("no keyword for the feature warned elsewhere '{name}'"),
    }
}

/// Asserts every feature `doc` (loaded from `path`) uses is implemented or
/// warned; returns the warnings.
fn check_implemented_or_warned(path: &Path, doc: &Value) -> Vec<String> {
    let scene = load_gltf(path).unwrap_or_else(|e| panic!("{e}"));
    let warnings = scene.warnings;
    let said = |s: &str| warnings.iter().any(|w| w.contains(s));
    for name in used_by(doc) {
        let Some(f) = feature(&name) else {
            assert!(
                said(&format!("{name} is not supported")),
                "{}: unknown extension {name} not warned: {warnings:#?}",
                path.display()
            );
            continue;
        };
        match f.support {
            Support::Full | Support::NotApplicable => {}
            Support::Partly | Support::Ignored if f.warned_elsewhere => assert!(
                said(elsewhere_keyword(&name)),
                "{}: {name} is used and not implemented, but no warning says so: {warnings:#?}",
                path.display()
            ),
            Support::Partly | Support::Ignored => assert!(
                warnings
                    .iter()
                    .any(|w| w.contains(&name) && w.contains(&path.display().to_string())),
                "{}: {name} is used and not implemented, but no warning names it and the file: \
                 {warnings:#?}",
                path.display()
            ),
        }
    }
    warnings
}

fn gltf_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            gltf_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "gltf") {
            out.push(p);
        }
    }
}

#[test]
fn every_feature_the_shipped_and_test_files_use_is_implemented_or_warned() {
    let mut files = Vec::new();
    gltf_files(&root().join("scenes"), &mut files);
    gltf_files(&root().join("tests/data"), &mut files);
    let mut checked = 0;
    for path in files {
        let Ok(doc) = serde_json::from_slice::<Value>(&std::fs::read(&path).unwrap()) else {
            continue; // the malformed corpus: tests/scene_import.rs checks its errors
        };
        if let Err(e) = load_gltf(&path) {
            // The vendored Khronos models must load: one that regressed to
            // an error would otherwise drop out of this walk unnoticed.
            assert!(
                !path.starts_with(root().join("tests/data/khronos")),
                "{}: {e}",
                path.display()
            );
            continue; // ditto
        }
        check_implemented_or_warned(&path, &doc);
        checked += 1;
    }
    // cornell, hairball, plane, the material balls, animated.gltf, the valid
    // members of the bad-scene and fuzz corpora.
    assert!(checked >= 6, "only {checked} glTF files checked");
}

/// A little-endian buffer of f32s, u8s etc. with accessors over it.
struct Buffer {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Buffer {
    fn f32s(&mut self, data: &[f32], ty: &str) -> usize {
        let offset = self.bytes.len();
        for v in data {
            self.bytes.extend_from_slice(&v.to_le_bytes());
        }
        let per = match ty {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            _ => unreachable!(),
        };
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4}));
        let mut acc = json!({"bufferView": self.views.len() - 1, "componentType": 5126,
                             "count": data.len() / per, "type": ty});
        if ty == "VEC3" && per == 3 {
            let mut lo = [f32::MAX; 3];
            let mut hi = [f32::MIN; 3];
            for v in data.chunks(3) {
                for k in 0..3 {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        if ty == "SCALAR" {
            let lo = data.iter().cloned().fold(f32::MAX, f32::min);
            let hi = data.iter().cloned().fold(f32::MIN, f32::max);
            acc["min"] = json!([lo]);
            acc["max"] = json!([hi]);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    fn u8x4(&mut self, data: &[u8]) -> usize {
        let offset = self.bytes.len();
        self.bytes.extend_from_slice(data);
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len()}));
        self.accessors.push(
            json!({"bufferView": self.views.len() - 1, "componentType": 5121,
                                   "count": data.len() / 4, "type": "VEC4"}),
        );
        self.accessors.len() - 1
    }
}

/// One document using every feature the importer does not implement in full
/// (and some it does), valid glTF 2.0 otherwise.
fn kitchen_sink() -> Value {
    let mut b = Buffer {
        bytes: Vec::new(),
        views: Vec::new(),
        accessors: Vec::new(),
    };
    let tri = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let pos = b.f32s(&tri, "VEC3");
    let strip_pos = b.f32s(
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0],
        "VEC3",
    );
    let color = b.f32s(
        &[1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0],
        "VEC4",
    );
    let uv = b.f32s(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC2");
    let target = b.f32s(&[0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], "VEC3");
    let times = b.f32s(&[0.0, 1.0], "SCALAR");
    let weights = b.f32s(&[0.0, 1.0], "SCALAR");
    let inst = b.f32s(&[0.0, 0.0, 0.0, 2.0, 0.0, 0.0], "VEC3");
    let joint_weights = b.f32s(&[1.0, 0.0, 0.0, 0.0].repeat(3), "VEC4");
    let joints = b.u8x4(&[0; 12]);
    let ibm = b.f32s(&glam::Mat4::IDENTITY.to_cols_array(), "MAT4");
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&b.bytes)
    );
    json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_texture_transform", "KHR_materials_clearcoat",
                           "KHR_materials_volume", "KHR_materials_unlit",
                           "KHR_materials_specular", "KHR_materials_transmission",
                           "EXT_mesh_gpu_instancing", "VENDOR_unknown_thing"],
        "buffers": [{"byteLength": b.bytes.len(), "uri": uri}],
        "bufferViews": b.views,
        "accessors": b.accessors,
        "samplers": [{"wrapS": 33071, "wrapT": 33648, "magFilter": 9728}],
        "images": [{"uri": "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8DwHwAFBQIAX8jx0gAAAABJRU5ErkJggg=="}],
        "textures": [{"source": 0, "sampler": 0}],
        "materials": [
            {"name": "transformed", "alphaMode": "BLEND",
             "pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 1,
                "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0]}}}},
             "normalTexture": {"index": 0},
             "emissiveTexture": {"index": 0, "texCoord": 2,
                "extensions": {"KHR_texture_transform": {"scale": [2.0, 2.0]}}}},
            {"name": "coated", "doubleSided": true,
             "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1.0},
                            "KHR_materials_specular": {"specularColorFactor": [1.0, 0.5, 0.5]}}},
            {"name": "glass", "doubleSided": true,
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                            "KHR_materials_volume": {"thicknessFactor": 0.1,
                                                      "attenuationColor": [0.5, 0.5, 1.0],
                                                      "attenuationDistance": 0.2}}},
            {"name": "flat", "doubleSided": true,
             "extensions": {"KHR_materials_unlit": {}}},
            {"name": "thin", "doubleSided": true,
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                            "KHR_materials_volume": {"attenuationColor": [0.5, 0.5, 1.0]}}}
        ],
        "meshes": [
            {"name": "coloured", "primitives": [{"attributes": {"POSITION": pos, "COLOR_0": color,
                                                                 "TEXCOORD_1": uv, "TEXCOORD_2": uv},
                                                  "material": 0}]},
            {"name": "morphing", "weights": [0.5],
             "primitives": [{"attributes": {"POSITION": pos}, "targets": [{"POSITION": target}],
                             "material": 1}]},
            {"name": "strip", "primitives": [{"attributes": {"POSITION": strip_pos, "_TEMPERATURE": strip_pos}, "mode": 5,
                                               "material": 2}]},
            {"name": "points", "primitives": [{"attributes": {"POSITION": pos}, "mode": 0,
                                                "material": 3}]},
            {"name": "skinned", "primitives": [{"attributes": {"POSITION": pos,
                "JOINTS_0": joints, "WEIGHTS_0": joint_weights}, "material": 3}]}
        ],
        "skins": [{"joints": [6], "inverseBindMatrices": ibm}],
        "cameras": [{"type": "orthographic",
                     "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0}}],
        "nodes": [
            {"mesh": 0, "extensions": {"VENDOR_unknown_thing": {}}},
            {"mesh": 1},
            {"mesh": 2},
            {"mesh": 3, "extensions": {"EXT_mesh_gpu_instancing":
                {"attributes": {"TRANSLATION": inst}}}},
            {"mesh": 4, "skin": 0},
            {"camera": 0, "translation": [0.0, 0.0, 5.0]},
            {"name": "joint"}
        ],
        "animations": [{"name": "breathe",
                        "channels": [{"sampler": 0, "target": {"node": 1, "path": "weights"}}],
                        "samplers": [{"input": times, "output": weights}]}],
        "scenes": [{"nodes": [0, 1, 2, 3, 4, 5, 6]}, {"nodes": [0]}],
        "scene": 0
    })
}

#[test]
fn a_document_using_every_unimplemented_feature_warns_each_once() {
    let doc = kitchen_sink();
    let dir = std::env::temp_dir().join(format!("stereocache-features-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("kitchen_sink.gltf");
    std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    let warnings = check_implemented_or_warned(&path, &doc);
    // The walk must have found the features the document was written to use.
    let used = used_by(&doc);
    for name in [
        "KHR_texture_transform",
        "TEXCOORD_1 and texCoord",
        "KHR_materials_clearcoat",
        "KHR_materials_volume",
        "KHR_materials_unlit",
        "COLOR_0",
        "morph targets",
        "skins (JOINTS_0, WEIGHTS_0)",
        "application-specific attributes (_NAME)",
        "orthographic cameras",
        "camera znear beyond 1 cm",
        "several scenes",
        "texture samplers (wrap modes, filters)",
        "VENDOR_unknown_thing",
    ] {
        assert!(
            used.iter().any(|u| u == name),
            "walk missed {name}: {used:?}"
        );
    }
    // One line each, each naming the file.
    for w in &warnings {
        assert!(!w.contains('\n'), "multi-line warning: {w}");
        assert!(
            w.contains("kitchen_sink.gltf"),
            "warning without the file: {w}"
        );
    }
    let mut sorted = warnings.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(
        sorted.len(),
        warnings.len(),
        "a warning twice: {warnings:#?}"
    );
    // The items are named: the transformed texture's material, the coated one.
    let said = |s: &str| warnings.iter().any(|w| w.contains(s));
    // Two uv channels per material: the base colour's (TEXCOORD_1, offset)
    // and the normal texture's (TEXCOORD_0, untransformed); the emissive
    // texture's third uv set reads the base colour texture's uvs.
    assert!(said(
        "material 0 'transformed': its textures use more than two different uv sets (texCoord) \
         and texture transforms (KHR_texture_transform), but a material gets two uv channels \
         (TEXCOORD_1, offset (0.5, 0) and TEXCOORD_0, no transform)"
    ));
    assert!(said(
        "the others read the base colour texture's uvs, so the emissive texture (TEXCOORD_2, \
         scale (2, 2)) reads the wrong uvs"
    ));
    // Clearcoat, the specular colour on an opaque material and a volume with
    // a thickness are implemented: not a word about them.
    for ext in [
        "KHR_materials_clearcoat",
        "KHR_materials_specular",
        "KHR_materials_volume",
    ] {
        assert!(!said(ext), "{ext} warned: {:?}", warnings);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_required_appearance_extension_is_warned_once() {
    let mut doc = kitchen_sink();
    doc["extensionsRequired"] = json!([
        "KHR_texture_transform",
        "KHR_materials_sheen",
        "KHR_materials_clearcoat",
        "AMD_split_roughnessMetallic"
    ]);
    doc["extensionsUsed"]
        .as_array_mut()
        .unwrap()
        .push(json!("KHR_materials_sheen"));
    doc["materials"][1]["extensions"]["KHR_materials_sheen"] =
        json!({"sheenColorFactor": [1.0, 1.0, 1.0]});
    doc["materials"][3]["extensions"]["AMD_split_roughnessMetallic"] = json!({});
    let dir = std::env::temp_dir().join(format!("stereocache-features-req-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("required.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let warnings = check_implemented_or_warned(&path, &doc);
    for name in [
        "KHR_texture_transform",
        "KHR_materials_sheen",
        "AMD_split_roughnessMetallic",
    ] {
        let n = warnings.iter().filter(|w| w.contains(name)).count();
        assert_eq!(n, 1, "{name} warned {n} times: {warnings:#?}");
    }
    // Required and implemented: nothing to say.
    let n = warnings
        .iter()
        .filter(|w| w.contains("KHR_materials_clearcoat"))
        .count();
    assert_eq!(n, 0, "clearcoat warned: {warnings:#?}");
    std::fs::remove_dir_all(&dir).ok();
}
