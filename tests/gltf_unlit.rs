//! KHR_materials_unlit in a path tracer: the surface shows exactly its base
//! colour and reflects nothing (src/scene/gltf_import.rs `unlit`). On
//! lavapipe with validation, both ray backends.

mod common;
use base64::Engine as _;
use common::*;
use glam::Vec3;
use serde_json::json;
use stereocache::methods::RenderSettings;
use stereocache::rt::RtChoice;
use stereocache::scene::{load_gltf, Environment, Scene};

const BASE: [f32; 3] = [0.2, 0.4, 0.6];
/// The constant environment: a reflecting surface would show a multiple of it.
const ENV: f32 = 5.0;

/// A 2 m square at z = 0 facing +z, base colour `BASE`, metallic 0,
/// double-sided, with or without KHR_materials_unlit.
fn quad(unlit: bool) -> Scene {
    let p: [f32; 12] = [
        -1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0,
    ];
    let n: [f32; 12] = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
    let idx: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut bytes: Vec<u8> = Vec::new();
    p.iter()
        .for_each(|v| bytes.extend_from_slice(&v.to_le_bytes()));
    n.iter()
        .for_each(|v| bytes.extend_from_slice(&v.to_le_bytes()));
    idx.iter()
        .for_each(|v| bytes.extend_from_slice(&v.to_le_bytes()));
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    );
    let mut material = json!({
        "name": "poster", "doubleSided": true,
        "pbrMetallicRoughness": {"baseColorFactor": [BASE[0], BASE[1], BASE[2], 1.0],
                                 "metallicFactor": 0.0, "roughnessFactor": 1.0}
    });
    let mut used = vec![];
    if unlit {
        material["extensions"] = json!({"KHR_materials_unlit": {}});
        used.push("KHR_materials_unlit");
    }
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": used,
        "buffers": [{"byteLength": bytes.len(), "uri": uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-1.0, -1.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "materials": [material],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1},
                                    "indices": 2, "material": 0}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    // One folder per call: the tests run in parallel and each removes its own.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("stereocache-unlit-{}-{call}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("unlit-{unlit}.gltf"));
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let mut s = load_gltf(&path).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).ok();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    s.environment = Some(Environment::Constant(Vec3::splat(ENV)));
    s
}

/// The radiance of every pixel the quad covers, both eyes.
fn covered_radiance(scene: Scene, rt: RtChoice) -> Vec<Vec3> {
    let ctx = context();
    let s = session(&ctx, scene, rt);
    let (w, h) = (32, 24);
    let cam = look_at_camera(
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::ZERO,
        30.0,
        w as f32 / h as f32,
    );
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 4,
        max_bounces: 3,
        seed: 7,
        ..Default::default()
    };
    let fr = render(&s, "reference", cam, &settings);
    assert_no_validation_messages(&ctx);
    let mut out = Vec::new();
    for eye in &fr.eyes {
        for (r, fh) in eye.radiance.iter().zip(&eye.first_hit) {
            if fh[3] != u32::MAX {
                out.push(Vec3::new(r[0], r[1], r[2]));
            }
        }
    }
    out
}

#[test]
fn unlit_material_becomes_an_emitter_of_its_base_colour_with_a_black_bsdf() {
    let m = &quad(true).materials[0];
    assert_eq!(m.emissive, Vec3::from(BASE));
    assert_eq!(m.base_color.truncate(), Vec3::ZERO);
    assert_eq!(m.base_color.w, 1.0);
    assert_eq!((m.metallic, m.specular, m.transmission), (0.0, 0.0, 0.0));
}

#[test]
fn an_unlit_surface_shows_exactly_its_base_colour_in_a_bright_environment() {
    for rt in rt_backends(&context()) {
        let px = covered_radiance(quad(true), rt);
        // The quad fills the middle of the view (2 m at 3 m, 30° fov).
        assert!(px.len() > 2 * 32 * 24 / 4, "{rt:?}: {} pixels", px.len());
        for r in &px {
            // Emission alone: no sample reaches the environment, so the
            // answer is exact up to f32 rounding of the stored factor.
            assert!(
                (*r - Vec3::from(BASE)).abs().max_element() < 1e-5,
                "{rt:?}: {r} is not the base colour {BASE:?}"
            );
        }
        // The same material lit: a diffuse surface in a constant environment
        // of 5 reflects about 5 × albedo, far from the base colour.
        let lit = covered_radiance(quad(false), rt);
        let mean = lit.iter().sum::<Vec3>() / lit.len() as f32;
        assert!(
            mean.x > 2.0 * BASE[0] && mean.z > 2.0 * BASE[2],
            "{rt:?}: lit mean {mean}: the control does not reflect"
        );
    }
}
