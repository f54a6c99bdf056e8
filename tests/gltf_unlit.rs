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
    quad_coloured(unlit, None)
}

/// [`quad`] with COLOR_0 (RGBA per corner) where given.
fn quad_coloured(unlit: bool, colours: Option<[[f32; 4]; 4]>) -> Scene {
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
    // Padding to 4 bytes, then the colours (at 112).
    bytes.extend_from_slice(&[0, 0, 0, 0]);
    for c in colours.iter().flatten() {
        c.iter()
            .for_each(|v| bytes.extend_from_slice(&v.to_le_bytes()));
    }
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
    let mut attributes = json!({"POSITION": 0, "NORMAL": 1});
    let mut views = vec![
        json!({"buffer": 0, "byteOffset": 0, "byteLength": 48}),
        json!({"buffer": 0, "byteOffset": 48, "byteLength": 48}),
        json!({"buffer": 0, "byteOffset": 96, "byteLength": 12}),
    ];
    let mut accessors = vec![
        json!({"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
               "min": [-1.0, -1.0, 0.0], "max": [1.0, 1.0, 0.0]}),
        json!({"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}),
        json!({"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}),
    ];
    if colours.is_some() {
        views.push(json!({"buffer": 0, "byteOffset": 112, "byteLength": 64}));
        accessors.push(json!({"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC4"}));
        attributes["COLOR_0"] = json!(3);
    }
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": used,
        "buffers": [{"byteLength": bytes.len(), "uri": uri}],
        "bufferViews": views,
        "accessors": accessors,
        "materials": [material],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 2, "material": 0}]}],
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

/// COLOR_0 per corner of the coloured quad (RGBA): red, green, blue, white.
const CORNERS: [[f32; 4]; 4] = [
    [1.0, 0.0, 0.0, 1.0],
    [0.0, 1.0, 0.0, 1.0],
    [0.0, 0.0, 1.0, 1.0],
    [1.0, 1.0, 1.0, 1.0],
];

/// KHR_materials_unlit with COLOR_0: the extension's output is the base
/// colour, which COLOR_0 multiplies as always (glTF §3.9.2): every pixel of
/// the quad shows BASE × the vertex colour interpolated at its hit. Before,
/// the colour was dropped without a word (the emission ignored it: off by
/// up to BASE, e.g. 0.6 in blue at the red corner).
///
/// The pixel's one sample is jittered within the pixel while its stored
/// first hit is the pixel centre's: the colour may differ by its gradient
/// (≤ √2/2 per metre: corners differ by ≤ 1 over 2 m) times half the
/// pixel's diagonal at the quad (≤ 3.2 m away, 30° over 24 px: 4.8 cm), so
/// BASE × 0.034 per channel, plus f32 rounding.
#[test]
fn an_unlit_surface_shows_its_base_colour_times_the_vertex_colour() {
    let scene = quad_coloured(true, Some(CORNERS));
    assert!(scene.materials[0].unlit);
    let ctx = context();
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
        spp: 1,
        max_bounces: 1,
        seed: 7,
        ..Default::default()
    };
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        let fr = render(&s, "reference", cam, &settings);
        let mesh = &scene.meshes[0];
        let mut checked = 0;
        for eye in &fr.eyes {
            for (r, fh) in eye.radiance.iter().zip(&eye.first_hit) {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (idx, wt) = first_hit_weights(&scene, *fh);
                let c: glam::Vec4 = (0..3).map(|k| mesh.colors[idx[k]] * wt[k]).sum();
                let want = Vec3::from(BASE) * c.truncate();
                let got = Vec3::new(r[0], r[1], r[2]);
                let pixel = 2.0 * 3.2 * (15f32.to_radians()).tan() / h as f32;
                let tol = Vec3::from(BASE) * (0.5f32.sqrt() * pixel * 0.5f32.sqrt()) + 1e-5;
                assert!(
                    (got - want).abs().cmple(tol).all(),
                    "{rt:?}: {got}, expected BASE × COLOR_0 = {want} ± {tol}"
                );
                checked += 1;
            }
        }
        assert!(checked > 2 * w * h / 4, "{rt:?}: {checked} pixels");
    }
    assert_no_validation_messages(&ctx);
}

/// The coloured unlit quad as a light: a diffuse floor below it, lit by it
/// alone (black environment), must come out the same whether the light is
/// found by next-event estimation (lights.glsl `emitted_radiance`) or by
/// BSDF-sampled hits (material_at): both must apply COLOR_0. Means over the
/// floor's pixels within 5 combined standard errors, per channel.
#[test]
fn a_coloured_unlit_light_gives_the_same_light_to_both_samplers() {
    use stereocache::scene::generate::{add_material, add_mesh, grid};
    let mut scene = quad_coloured(true, Some(CORNERS));
    scene.environment = None;
    let floor = add_material(
        &mut scene,
        stereocache::scene::Material::diffuse("floor", Vec3::splat(0.8)),
    );
    add_mesh(
        &mut scene,
        grid(
            "floor",
            Vec3::new(-4.0, -1.5, 4.0),
            Vec3::X * 8.0,
            Vec3::NEG_Z * 8.0,
            1,
            1,
            glam::Vec2::ONE,
        ),
        floor,
        glam::Mat4::IDENTITY,
    );
    scene.validate().unwrap();
    let ctx = context();
    let (w, h) = (48, 32);
    let cam = look_at_camera(
        Vec3::new(0.0, 1.5, 5.0),
        Vec3::new(0.0, -1.5, 1.0),
        50.0,
        w as f32 / h as f32,
    );
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        let (nee, _) = assert_light_samplers_agree(&s, floor, cam, w, h, &format!("{rt:?}"));
        assert!(
            nee.iter().all(|c| c.0 > 1e-3),
            "{rt:?}: the floor is dark: {nee:?}"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// The writer gives an unlit material back as KHR_materials_unlit (base
/// colour, no emission), so COLOR_0 keeps multiplying it when read again.
#[test]
fn an_unlit_material_survives_the_writer_as_unlit() {
    let scene = quad_coloured(true, Some(CORNERS));
    let dir = std::env::temp_dir().join(format!("stereocache-unlit-write-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("written.gltf");
    stereocache::scene::write_gltf(&scene, &path).unwrap();
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let m = &doc["materials"][0];
    assert!(m["extensions"]["KHR_materials_unlit"].is_object(), "{m}");
    assert!(m.get("emissiveFactor").is_none(), "{m}");
    let back = load_gltf(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let (a, b) = (&scene.materials[0], &back.materials[0]);
    assert!(b.unlit);
    assert_eq!(a.emissive, b.emissive);
    assert_eq!(a.base_color, b.base_color);
    assert_eq!(back.meshes[0].colors, scene.meshes[0].colors);
}
