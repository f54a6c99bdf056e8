//! Material graphs bound to glTF materials and evaluated at every hit
//! (issue 17; src/materials/binding.rs, scene_shaders.rs). Known answers:
//! two coplanar emissive quads seen from above, black environment, no
//! lights — every camera sample that hits a quad returns exactly its
//! emission (the quads cannot see each other and every bounce escapes to
//! black), and the albedo output is the base colour at the pixel-centre hit.
//! Both are compared with the CPU evaluator (the test oracle).

mod common;
use common::*;
use glam::{Mat4, Vec2, Vec3};
use std::path::{Path, PathBuf};
use stereocache::camera::StereoCamera;
use stereocache::materials::{eval, Geom, Slot};
use stereocache::methods::{MethodKind, RenderSettings};
use stereocache::rt::RtChoice;
use stereocache::scene::generate::{add_material, add_mesh, grid, look_at};
use stereocache::scene::{Material, Scene, Texture, TextureEncoding, TextureRef};

/// KHR_texture_procedurals graph 0: `base` = mix of two colours by
/// sin(6u, 4v)·(¼, ¼) + ½ (|∂/∂uv| ≤ 0.8·(1.5 + 1) = 2), `emission` =
/// |noise3d(2.5·N) + 0.5| (constant over a flat quad, but evaluated per hit).
const PROCEDURAL: &str = r#"{
  "name": "khr_test", "nodetype": "nodegraph", "type": "multioutput",
  "inputs": [ { "name": "fg", "nodetype": "input", "type": "color3", "value": [0.9, 0.2, 0.1] } ],
  "nodes": [
    { "name": "uv", "nodetype": "texcoord", "type": "vector2", "outputs": [ { "nodetype": "output", "name": "out", "type": "vector2" } ] },
    { "name": "uvs", "nodetype": "multiply", "type": "vector2", "inputs": [
        { "name": "in1", "nodetype": "input", "type": "vector2", "node": 0 },
        { "name": "in2", "nodetype": "input", "type": "vector2", "value": [6.0, 4.0] } ] },
    { "name": "s", "nodetype": "sin", "type": "vector2", "inputs": [ { "name": "in", "nodetype": "input", "type": "vector2", "node": 1 } ] },
    { "name": "d", "nodetype": "dotproduct", "type": "float", "inputs": [
        { "name": "in1", "nodetype": "input", "type": "vector2", "node": 2 },
        { "name": "in2", "nodetype": "input", "type": "vector2", "value": [0.25, 0.25] } ] },
    { "name": "w", "nodetype": "add", "type": "float", "inputs": [
        { "name": "in1", "nodetype": "input", "type": "float", "node": 3 },
        { "name": "in2", "nodetype": "input", "type": "float", "value": 0.5 } ] },
    { "name": "base", "nodetype": "mix", "type": "color3", "inputs": [
        { "name": "fg", "nodetype": "input", "type": "color3", "input": 0 },
        { "name": "bg", "nodetype": "input", "type": "color3", "value": [0.1, 0.3, 0.8] },
        { "name": "mix", "nodetype": "input", "type": "float", "node": 4 } ] },
    { "name": "n", "nodetype": "normal", "type": "vector3" },
    { "name": "ns", "nodetype": "multiply", "type": "vector3", "inputs": [
        { "name": "in1", "nodetype": "input", "type": "vector3", "node": 6 },
        { "name": "in2", "nodetype": "input", "type": "float", "value": 2.5 } ] },
    { "name": "noise", "nodetype": "noise3d", "type": "color3", "inputs": [
        { "name": "position", "nodetype": "input", "type": "vector3", "node": 7 } ] },
    { "name": "lift", "nodetype": "add", "type": "color3", "inputs": [
        { "name": "in1", "nodetype": "input", "type": "color3", "node": 8 },
        { "name": "in2", "nodetype": "input", "type": "float", "value": 0.5 } ] },
    { "name": "emit", "nodetype": "absval", "type": "color3", "inputs": [
        { "name": "in", "nodetype": "input", "type": "color3", "node": 9 } ] }
  ],
  "outputs": [
    { "name": "base", "nodetype": "output", "type": "color3", "node": 5 },
    { "name": "emission", "nodetype": "output", "type": "color3", "node": 10 }
  ]
}"#;

/// The `.mtlx` attached through extras: base colour 0.3·sin(3.1·P) +
/// 0.1·sin(2.3·P_world) + 0.5 (|∂/∂P| ≤ 0.93, |∂/∂P_world| ≤ 0.23),
/// emission 0.2·N + 0.1·T + 0.45 (in [0.15, 0.75], constant over a flat
/// quad), P, N and T in object space (MaterialX's default space), P_world
/// by `space="world"`.
const MTLX: &str = r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="ball">
    <position name="p" type="vector3" />
    <multiply name="pm" type="vector3"><input name="in1" type="vector3" nodename="p" /><input name="in2" type="float" value="3.1" /></multiply>
    <sin name="ps" type="vector3"><input name="in" type="vector3" nodename="pm" /></sin>
    <multiply name="pk" type="vector3"><input name="in1" type="vector3" nodename="ps" /><input name="in2" type="float" value="0.3" /></multiply>
    <position name="pw" type="vector3"><input name="space" type="string" value="world" /></position>
    <multiply name="pwm" type="vector3"><input name="in1" type="vector3" nodename="pw" /><input name="in2" type="float" value="2.3" /></multiply>
    <sin name="pws" type="vector3"><input name="in" type="vector3" nodename="pwm" /></sin>
    <multiply name="pwk" type="vector3"><input name="in1" type="vector3" nodename="pws" /><input name="in2" type="float" value="0.1" /></multiply>
    <add name="pb" type="vector3"><input name="in1" type="vector3" nodename="pk" /><input name="in2" type="vector3" nodename="pwk" /></add>
    <add name="pa" type="vector3"><input name="in1" type="vector3" nodename="pb" /><input name="in2" type="float" value="0.5" /></add>
    <normal name="n" type="vector3" />
    <multiply name="nm" type="vector3"><input name="in1" type="vector3" nodename="n" /><input name="in2" type="float" value="0.2" /></multiply>
    <tangent name="t" type="vector3" />
    <multiply name="tm" type="vector3"><input name="in1" type="vector3" nodename="t" /><input name="in2" type="float" value="0.1" /></multiply>
    <add name="e1" type="vector3"><input name="in1" type="vector3" nodename="nm" /><input name="in2" type="vector3" nodename="tm" /></add>
    <add name="na" type="vector3"><input name="in1" type="vector3" nodename="e1" /><input name="in2" type="float" value="0.45" /></add>
    <output name="base_color" type="vector3" nodename="pa" />
    <output name="emission" type="vector3" nodename="na" />
  </nodegraph>
</materialx>
"#;

/// KHR factors (powers of two, so the products are exact).
const KHR_BASE_FACTOR: [f32; 3] = [1.0, 0.5, 1.0];
const KHR_EMISSIVE_FACTOR: [f32; 3] = [0.5, 1.0, 0.25];

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("material_binding-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Two 1 m quads in the XZ plane facing +Y (x ∈ [−1.05, −0.05] and
/// [0.05, 1.05]), written as glTF; material 0 has a 1×1 texture so the file
/// has the fallback texture KHR_texture_procedurals requires.
fn write_quads(d: &Path) -> PathBuf {
    write_quads_uv(d, Vec2::ONE)
}

/// `write_quads` with uvs spanning `uv_scale` over each 1 m quad (u along
/// +x, v along −z).
fn write_quads_uv(d: &Path, uv_scale: Vec2) -> PathBuf {
    write_quads_placed(d, uv_scale, Mat4::IDENTITY)
}

/// `write_quads_uv` with each quad's mesh in an object space of its own:
/// instance transform `place` takes it to the same world place (vertices
/// by place⁻¹, normals by placeᵀ, tangents by place⁻¹, winding and
/// handedness turned over where `place` mirrors, as an exporter writes a
/// mirrored node), so the world image is the same while graphs reading
/// object space see other values. The quads carry tangents along +u (+x
/// in world), w = +1.
fn write_quads_placed(d: &Path, uv_scale: Vec2, place: Mat4) -> PathBuf {
    write_quads_edited(d, uv_scale, place, |_| {})
}

/// `write_quads_placed` with each quad's mesh changed by `edit` first.
fn write_quads_edited(
    d: &Path,
    uv_scale: Vec2,
    place: Mat4,
    edit: impl Fn(&mut stereocache::scene::Mesh),
) -> PathBuf {
    let mut s = Scene {
        source: "test:quads".into(),
        ..Default::default()
    };
    s.textures.push(Texture::with_mips(
        "fallback".into(),
        TextureEncoding::Srgb,
        1,
        1,
        vec![255, 255, 255, 255],
    ));
    let m0 = add_material(
        &mut s,
        Material {
            base_color_texture: Some(TextureRef::new(0)),
            ..Material::diffuse("khr", Vec3::ONE)
        },
    );
    let m1 = add_material(&mut s, Material::diffuse("extras", Vec3::ONE));
    for (m, x0) in [(m0, -1.05), (m1, 0.05)] {
        let mut g = grid(
            "quad",
            Vec3::new(x0, 0.0, 0.5),
            Vec3::X,
            Vec3::NEG_Z,
            1,
            1,
            uv_scale,
        );
        edit(&mut g);
        add_mesh(&mut s, into_object_space(g, place), m, place);
    }
    s.validate().unwrap();
    let path = d.join("quads.gltf");
    stereocache::scene::write_gltf(&s, &path).unwrap();
    path
}

/// `m` (world space) moved into the object space of an instance placed by
/// `place` (see `write_quads_placed`), with tangents along +x (w = +1) in
/// world space where it has none.
fn into_object_space(mut m: stereocache::scene::Mesh, place: Mat4) -> stereocache::scene::Mesh {
    if place == Mat4::IDENTITY {
        return m;
    }
    if m.tangents.is_empty() {
        m.tangents = vec![glam::Vec4::new(1.0, 0.0, 0.0, 1.0); m.positions.len()];
    }
    let inv = place.inverse();
    let lin = glam::Mat3::from_mat4(place);
    let mirror = lin.determinant() < 0.0;
    for p in &mut m.positions {
        *p = inv.transform_point3(*p);
    }
    for n in &mut m.normals {
        *n = (lin.transpose() * *n).normalize();
    }
    for t in &mut m.tangents {
        let v = inv.transform_vector3(t.truncate()).normalize();
        *t = v.extend(if mirror { -t.w } else { t.w });
    }
    if mirror {
        for tri in m.indices.chunks_mut(3) {
            tri.swap(1, 2);
        }
    }
    m
}

/// Adds both binding forms to the written file: material 0 by
/// KHR_texture_procedurals (base colour and emission textures), material 1
/// by `ball.mtlx` in its extras. `edit` may break the JSON afterwards.
fn bind(path: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let khr = |out: u32| serde_json::json!({ "index": 0, "extensions": { "KHR_texture_procedurals": { "index": 0, "output": out } } });
    j["extensionsUsed"] = serde_json::json!(["KHR_texture_procedurals"]);
    j["extensions"] = serde_json::json!({ "KHR_texture_procedurals": { "procedurals": [
        serde_json::from_str::<serde_json::Value>(PROCEDURAL).unwrap()
    ] } });
    let m0 = &mut j["materials"][0];
    m0["pbrMetallicRoughness"]["baseColorFactor"] = serde_json::json!([
        KHR_BASE_FACTOR[0],
        KHR_BASE_FACTOR[1],
        KHR_BASE_FACTOR[2],
        1.0
    ]);
    m0["pbrMetallicRoughness"]["baseColorTexture"] = khr(0);
    m0["emissiveTexture"] = khr(1);
    m0["emissiveFactor"] = serde_json::json!(KHR_EMISSIVE_FACTOR);
    j["materials"][1]["extras"] =
        serde_json::json!({ "materialx": { "file": "ball.mtlx", "graph": "ball" } });
    std::fs::write(path.with_file_name("ball.mtlx"), MTLX).unwrap();
    edit(&mut j);
    std::fs::write(path, serde_json::to_string_pretty(&j).unwrap()).unwrap();
}

/// The graph outputs bound to `slot` of `material` at `geom` (CPU evaluator;
/// `geom.uv` and `uv1` the mesh's uv sets, which the graph sees flipped;
/// `uv1_per_uv` already in the graph's space), times the material's factor.
fn cpu_slot(scene: &Scene, material: u32, slot: Slot, geom: &Geom) -> Vec3 {
    let b = scene
        .graphs
        .of_material(material)
        .iter()
        .find(|b| b.slot == slot)
        .unwrap_or_else(|| panic!("material {material} has no {slot:?} graph"));
    let g = &scene.graphs.graphs[b.graph];
    // Graphs see the mesh's uv with v up (eval::graph_uv), as the GPU's.
    let geom = &Geom {
        uv: eval::graph_uv(geom.uv),
        uv1: eval::graph_uv(geom.uv1),
        ..*geom
    };
    let floats: Vec<f32> = eval::evaluate(g, geom)
        .iter()
        .flat_map(|v| v.channels().to_vec())
        .collect();
    let v = Vec3::new(floats[b.float], floats[b.float + 1], floats[b.float + 2]);
    let m = &scene.materials[material as usize];
    v * match slot {
        Slot::Emission => m.emissive,
        _ => m.base_color.truncate(),
    }
}

/// The surface point of a stored first hit (Listing 1: bary in 24 bits,
/// primitive, instance), rebuilt on the CPU from the scene: object space
/// from the mesh's own vertices, world space through the instance's
/// transform (the quads face +y in world).
fn hit_geom(scene: &Scene, fh: [u32; 4]) -> (u32, Geom) {
    let inst = &scene.instances[fh[3] as usize];
    let mesh = &scene.meshes[inst.mesh as usize];
    let (idx, w) = first_hit_weights(scene, fh);
    let p: Vec3 = (0..3).map(|k| mesh.positions[idx[k]] * w[k]).sum();
    let n: Vec3 = (0..3).map(|k| mesh.normals[idx[k]] * w[k]).sum();
    let uv: Vec2 = (0..3).map(|k| mesh.uvs[idx[k]] * w[k]).sum();
    let (t, ts) = match mesh.tangents.is_empty() {
        true => (Vec3::ZERO, 1.0),
        false => (
            (0..3)
                .map(|k| mesh.tangents[idx[k]].truncate() * w[k])
                .sum::<Vec3>()
                .normalize(),
            mesh.tangents[idx[0]].w,
        ),
    };
    let mirror = if inst.transform.determinant() < 0.0 {
        -1.0
    } else {
        1.0
    };
    (
        mesh.material,
        Geom {
            uv: uv.to_array(),
            // Set 1: only graphs_read_the_raw_uv_sets reads it, and sets it.
            uv1: [0.0; 2],
            uv1_per_uv: [[0.0; 2]; 2],
            position: inst.transform.transform_point3(p).to_array(),
            normal: [0.0, 1.0, 0.0],
            tangent: inst
                .transform
                .transform_vector3(t)
                .normalize_or_zero()
                .to_array(),
            tangent_sign: ts * mirror,
            footprint: 0.0,
            object: stereocache::materials::ObjectFrame {
                position: p.to_array(),
                normal: n.normalize().to_array(),
                tangent: t.to_array(),
                tangent_sign: ts,
            },
        },
    )
}

/// Whether pixel `i` of a `w`×`h` image lies inside one instance: not on
/// the border, and its four neighbours' centres hit the instance its own
/// centre hits (so every sample of the pixel does, on the quads).
fn inner_pixel(first_hit: &[[u32; 4]], i: usize, w: usize, h: usize) -> bool {
    let (x, y) = (i % w, i / w);
    x > 0
        && y > 0
        && x + 1 < w
        && y + 1 < h
        && [i - 1, i + 1, i - w, i + w]
            .iter()
            .all(|&j| first_hit[j][3] == first_hit[i][3])
}

/// The centre ray of pixel `i` of a 40-pixel-wide image of `size`
/// (normalised) and its distance to the y = 0 plane of the quads.
fn pixel_ray_to_ground(
    view: &stereocache::camera::EyeView,
    i: usize,
    size: glam::UVec2,
) -> (Vec3, f32) {
    let px = Vec2::new((i % 40) as f32 + 0.5, (i / 40) as f32 + 0.5);
    let dir = view.ray_direction(px, size);
    (dir, -view.position.y / dir.y)
}

/// Texels whose centre the GPU may have snapped a hit at `uv` to at level
/// `m`: the CPU's uv is rebuilt from 24-bit barycentrics, so a hit within
/// `eps` (that rounding, in uv) of a texel edge may go either way.
fn snap_candidates(uv: [f32; 2], m: i32, eps: f32) -> Vec<[i32; 2]> {
    use stereocache::materials::memo::lod;
    let mut candidates = Vec::new();
    for du in [-eps, 0.0, eps] {
        for dv in [-eps, 0.0, eps] {
            let q = lod::quantise([uv[0] + du, uv[1] + dv], m);
            if !candidates.contains(&q) {
                candidates.push(q);
            }
        }
    }
    candidates
}

fn top_camera() -> StereoCamera {
    let c = look_at(
        "top",
        Vec3::new(0.0, 2.2, 0.0),
        Vec3::ZERO,
        Vec3::NEG_Z,
        60.0,
    );
    StereoCamera::from_scene_camera(c.transform, c.yfov, 40.0 / 24.0)
}

/// 40×24 per eye (the top camera's aspect), 2 spp, 2 bounces, seed 3.
fn probe_settings() -> RenderSettings {
    RenderSettings {
        width: 40,
        height: 24,
        spp: 2,
        max_bounces: 2,
        seed: 3,
        all_features: false,
        ..Default::default()
    }
}

/// Tolerance: the GPU and CPU agree to 64 ulp relative to max(1, |v|) at
/// the same point (tests/material_graphs.rs: built-ins that are not
/// correctly rounded), 64·2⁻²³ = 7.6·10⁻⁶; the CPU rebuilds the point from
/// barycentrics rounded to 24 bits (≤ 2⁻²⁴ of the 1 m quad / unit uv), and
/// the base colours change by at most 2 per unit uv or metre: 1.2·10⁻⁷.
/// Radiance is the mean of identical samples (2 spp, exact).
const TOL: f32 = 7.6e-6 + 1.2e-7;

/// The placement of `graphs_read_object_space_through_the_instance`:
/// translated, turned 0.7 rad about (1, 2, 3), scaled (1.25, 0.8) and
/// mirrored in z (condition number 1.5625).
fn mirrored_placement() -> Mat4 {
    Mat4::from_scale_rotation_translation(
        Vec3::new(1.25, 0.8, -1.0),
        glam::Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7),
        Vec3::new(0.5, -0.25, 0.75),
    )
}

/// TOL plus the error of taking the hit back to object space on the GPU
/// (scene_shaders.rs sc_graph_object_space: p_o = L⁻¹(p − t) in f32):
/// relative error of a few ulps in p, t and L⁻¹ magnified by L's
/// condition number κ, bounded by 16·κ·(|p| + |t|)·2⁻²⁴ with |p| ≤ 1.6 m,
/// |t| = 0.94 m: 3.8·10⁻⁶ m; the base colour changes by at most 0.93 per
/// metre of the object position (N and T move the constant emission by
/// far less).
const TOL_OBJECT: f32 = TOL + 0.93 * 16.0 * 1.5625 * (1.6 + 0.94) * 5.96e-8;

#[test]
fn graph_bound_materials_render_the_cpu_evaluators_values() {
    probe_graph_bound_quads("probe", Mat4::IDENTITY, TOL);
}

/// Object space (MaterialX's default for position, normal and tangent):
/// the quads' meshes in a translated, turned, non-uniformly scaled and
/// mirrored object space, placed back by their instance; every hit's
/// object-space point, normal and tangent are the mesh's own
/// (interpolated on the CPU from the vertices, not taken back through the
/// transform as the GPU does), and the world-space input still reads world
/// space.
#[test]
fn graphs_read_object_space_through_the_instance_transform() {
    probe_graph_bound_quads("object", mirrored_placement(), TOL_OBJECT);
}

/// Renders the quads of `write_quads_placed(place)` with both bindings and
/// holds every hit pixel's albedo and inner radiance to the CPU evaluator
/// at the hit (`tol`). A placed scene also checks the probe would fail if
/// object space read world space.
fn probe_graph_bound_quads(name: &str, place: Mat4, tol: f32) {
    let ctx = context();
    let d = dir(name);
    let path = write_quads_placed(&d, Vec2::ONE, place);
    bind(&path, |_| {});
    let scene = stereocache::scene::load_gltf(&path).expect("bound scene loads");
    assert_eq!(
        scene.graphs.graphs.len(),
        2,
        "one KHR graph, one .mtlx graph"
    );
    // The bound slots' textures are off (the graph stands in for them).
    assert!(scene.materials[0].base_color_texture.is_none());
    assert_eq!(
        scene.materials[1].emissive,
        Vec3::ONE,
        "extras form: factors 1"
    );
    let settings = probe_settings();
    for rt in [RtChoice::Software, RtChoice::Query] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let s = session(&ctx, scene.clone(), rt);
        assert!(
            s.scene_gpu.shaders.is_some(),
            "{rt:?}: graph scene has run-time shaders"
        );
        let f = render(&s, "reference", top_camera(), &settings);
        let (w, h) = (f.width as usize, f.height as usize);
        let mut checked = [0usize; 2];
        let mut albedos = Vec::new();
        // The largest difference the CPU finds where object space is world
        // space: what reading world space would have missed by.
        let mut world_miss = 0.0f32;
        for eye in &f.eyes {
            for (i, fh) in eye.first_hit.iter().enumerate() {
                let rad = Vec3::from_slice(&eye.radiance[i][..3]);
                if fh[3] == u32::MAX {
                    // Black environment, nothing else lit: a pixel whose centre
                    // misses may only pick up a quad's emission at its edge.
                    assert!(rad.max_element() <= 1.0, "{rt:?}: pixel {i} radiance {rad}");
                    continue;
                }
                let (mat, geom) = hit_geom(&s.scene, *fh);
                let albedo = Vec3::from_slice(&eye.albedo[i][..3]);
                let want = cpu_slot(&s.scene, mat, Slot::BaseColor, &geom);
                assert!(
                    (albedo - want).abs().max_element() <= tol,
                    "{rt:?}: material {mat} pixel {i}: albedo {albedo} vs CPU {want}"
                );
                albedos.push(albedo);
                // Radiance: exact where every sample of the pixel hits the same
                // quad (the 4 neighbours' centres do); edge pixels mix with black.
                let emit = cpu_slot(&s.scene, mat, Slot::Emission, &geom);
                let world = geom.untransformed();
                for slot in [Slot::BaseColor, Slot::Emission] {
                    let v = cpu_slot(&s.scene, mat, slot, &geom);
                    let v_world = cpu_slot(&s.scene, mat, slot, &world);
                    world_miss = world_miss.max((v - v_world).abs().max_element());
                }
                if inner_pixel(&eye.first_hit, i, w, h) {
                    assert!(
                        (rad - emit).abs().max_element() <= tol,
                        "{rt:?}: material {mat} pixel {i}: radiance {rad} vs CPU emission {emit}"
                    );
                    checked[mat as usize] += 1;
                } else {
                    assert!(
                        rad.cmple(emit + tol).all(),
                        "{rt:?}: edge pixel {i}: {rad} above the emission {emit}"
                    );
                }
            }
        }
        assert!(
            checked.iter().all(|&c| c > 100),
            "{rt:?}: inner pixels per quad {checked:?}"
        );
        // The base colours vary across the quads (the probe is not vacuous).
        let (lo, hi) = albedos
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), a| {
                (l.min(*a), h.max(*a))
            });
        assert!(
            (hi - lo).max_element() > 0.2,
            "{rt:?}: albedo range {lo}..{hi}"
        );
        if place != Mat4::IDENTITY {
            assert!(
                world_miss > 100.0 * tol,
                "{rt:?}: object and world space give the same values here ({world_miss})"
            );
        }
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// A KHR_texture_procedurals graph for the packed metallicRoughnessTexture:
/// (0.9, 0.25, 1.0) + 0·u (varying, so compiled, not folded at load), i.e.
/// roughness g = 0.25, metallic b = 1.
const MR_PROCEDURAL: &str = r#"{
  "name": "mr", "nodetype": "nodegraph", "type": "color3",
  "nodes": [
    { "name": "uv", "nodetype": "texcoord", "type": "vector2" },
    { "name": "z", "nodetype": "dotproduct", "type": "float", "inputs": [
        { "name": "in1", "nodetype": "input", "type": "vector2", "node": 0 },
        { "name": "in2", "nodetype": "input", "type": "vector2", "value": [0.0, 0.0] } ] },
    { "name": "mr", "nodetype": "add", "type": "color3", "inputs": [
        { "name": "in1", "nodetype": "input", "type": "color3", "value": [0.9, 0.25, 1.0] },
        { "name": "in2", "nodetype": "input", "type": "float", "node": 1 } ] }
  ],
  "outputs": [ { "name": "mr", "nodetype": "output", "type": "color3", "node": 2 } ]
}"#;

/// The `.mtlx` of the extras form: metallic 0 + 0·u, roughness 0.4 + 0·u.
const MR_MTLX: &str = r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="mr">
    <texcoord name="uv" type="vector2" />
    <dotproduct name="z" type="float"><input name="in1" type="vector2" nodename="uv" /><input name="in2" type="vector2" value="0, 0" /></dotproduct>
    <add name="m" type="float"><input name="in1" type="float" nodename="z" /><input name="in2" type="float" value="0" /></add>
    <add name="r" type="float"><input name="in1" type="float" nodename="z" /><input name="in2" type="float" value="0.4" /></add>
    <output name="metallic" type="float" nodename="m" />
    <output name="roughness" type="float" nodename="r" />
  </nodegraph>
</materialx>
"#;

/// A graph's metallic and roughness reach the BSDF, in both binding forms:
/// material 0 (gold base colour factor) by KHR's packed
/// metallicRoughnessTexture (g = roughness 0.25, b = metallic 1, times
/// factors 1), material 1 (blue) by an attached `.mtlx`'s `metallic` (0)
/// and `roughness` (0.4) outputs. The same quads with those values as the
/// materials' factors and no graphs, lit alike (sun and sky) and rendered
/// with the same seed, give the same image: every pixel within 10⁻⁵ of
/// max(1, v) (the graph's values are exact in f32 and the factors 1, so
/// the BSDF sees the same numbers; the run-time shader may order other
/// arithmetic differently, a few ulp). Not vacuous: the factor scenes with
/// each likely mistake — g and b swapped, the metallic output lost (the
/// extras form leaves the factor 1), the roughness output lost — differ
/// from the graph image on that quad by far more (mean over its pixels
/// above 10⁻² of the mean radiance).
#[test]
fn graph_metallic_and_roughness_reach_the_bsdf() {
    use stereocache::scene::default_lighting::{apply_default_lighting, DefaultLighting};
    let ctx = context();
    let d = dir("metallic-roughness");
    let path = write_quads(&d);
    let plain = stereocache::scene::load_gltf(&path).expect("quads load");
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    j["extensionsUsed"] = serde_json::json!(["KHR_texture_procedurals"]);
    j["extensions"] = serde_json::json!({ "KHR_texture_procedurals": { "procedurals": [
        serde_json::from_str::<serde_json::Value>(MR_PROCEDURAL).unwrap()
    ] } });
    let gold = [0.9f32, 0.6, 0.2];
    let blue = [0.2f32, 0.5, 0.8];
    let m0 = &mut j["materials"][0]["pbrMetallicRoughness"];
    m0["baseColorFactor"] = serde_json::json!([gold[0], gold[1], gold[2], 1.0]);
    m0["metallicFactor"] = serde_json::json!(1.0);
    m0["roughnessFactor"] = serde_json::json!(1.0);
    m0["metallicRoughnessTexture"] = serde_json::json!({ "index": 0, "extensions": { "KHR_texture_procedurals": { "index": 0, "output": 0 } } });
    j["materials"][1]["pbrMetallicRoughness"]["baseColorFactor"] =
        serde_json::json!([blue[0], blue[1], blue[2], 1.0]);
    j["materials"][1]["extras"] =
        serde_json::json!({ "materialx": { "file": "mr.mtlx", "graph": "mr" } });
    std::fs::write(path.with_file_name("mr.mtlx"), MR_MTLX).unwrap();
    std::fs::write(&path, serde_json::to_string_pretty(&j).unwrap()).unwrap();
    let mut graphs = stereocache::scene::load_gltf(&path).expect("bound quads load");
    assert_eq!(
        graphs.graphs.graphs.len(),
        2,
        "one KHR graph, one .mtlx graph"
    );
    let lighting = DefaultLighting::default();
    apply_default_lighting(&mut graphs, &lighting).unwrap();
    let settings = probe_settings();
    let rt = RtChoice::Software;
    let s = session(&ctx, graphs, rt);
    assert!(
        s.scene_gpu.shaders.is_some(),
        "graph scene has run-time shaders"
    );
    let want = render(&s, "reference", top_camera(), &settings);
    // The factor scene: (metallic, roughness) of material 0 and 1.
    let factors = |mr0: (f32, f32), mr1: (f32, f32)| {
        let mut p = plain.clone();
        for (m, c, (metallic, roughness)) in [(0usize, gold, mr0), (1, blue, mr1)] {
            let mat = &mut p.materials[m];
            mat.base_color = Vec3::from(c).extend(1.0);
            mat.metallic = metallic;
            mat.roughness = roughness;
            mat.metallic_roughness_texture = None;
        }
        apply_default_lighting(&mut p, &lighting).unwrap();
        let s = session(&ctx, p, rt);
        render(&s, "reference", top_camera(), &settings)
    };
    // Per quad: the mean |difference| and the mean radiance over its pixels.
    let quad_diff = |a: &stereocache::methods::StereoFrame,
                     b: &stereocache::methods::StereoFrame| {
        let mut sums = [(0.0f64, 0.0f64, 0usize); 2];
        for (ea, eb) in a.eyes.iter().zip(&b.eyes) {
            for (i, fh) in ea.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX || *fh != eb.first_hit[i] {
                    continue;
                }
                let mat = hit_geom(&s.scene, *fh).0 as usize;
                for c in 0..3 {
                    sums[mat].0 += (ea.radiance[i][c] - eb.radiance[i][c]).abs() as f64;
                    sums[mat].1 += ea.radiance[i][c] as f64;
                }
                sums[mat].2 += 1;
            }
        }
        sums.map(|(d, v, n)| {
            assert!(n > 100, "quad pixels: {n}");
            (d / n as f64, v / n as f64)
        })
    };
    let same = factors((1.0, 0.25), (0.0, 0.4));
    for (ea, eb) in want.eyes.iter().zip(&same.eyes) {
        assert_eq!(ea.first_hit, eb.first_hit, "the same hits");
        for (i, (a, b)) in ea.radiance.iter().zip(&eb.radiance).enumerate() {
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() <= 1e-5 * a[c].abs().max(1.0),
                    "pixel {i}, channel {c}: graphs {} vs factors {}",
                    a[c],
                    b[c]
                );
            }
        }
    }
    for (what, quad, mr0, mr1) in [
        ("g and b swapped", 0usize, (0.25, 1.0), (0.0, 0.4)),
        ("metallic output lost", 1, (1.0, 0.25), (1.0, 0.4)),
        ("roughness output lost", 1, (1.0, 0.25), (0.0, 1.0)),
    ] {
        let (diff, mean) = quad_diff(&want, &factors(mr0, mr1))[quad];
        eprintln!("{what}: quad {quad} mean |difference| {diff:.5} of mean {mean:.5}");
        assert!(
            diff > 1e-2 * mean,
            "{what}: {diff} of {mean}: the test would not see it"
        );
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// Graph outputs that are not finite or out of range: the `.mtlx` of
/// material 1 makes x = 100 + 0·P.x (varying, so not folded at load),
/// e = exp(x) (overflows to +∞ in f32) and e − e (NaN): base colour
/// (2, NaN, −1), metallic NaN, roughness −3, emission (+∞, −5, 3).
const WILD_MTLX: &str = r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="ball">
    <position name="p" type="vector3" />
    <extract name="px" type="float"><input name="in" type="vector3" nodename="p" /><input name="index" type="integer" value="0" /></extract>
    <multiply name="z" type="float"><input name="in1" type="float" nodename="px" /><input name="in2" type="float" value="0" /></multiply>
    <add name="x" type="float"><input name="in1" type="float" nodename="z" /><input name="in2" type="float" value="100" /></add>
    <exp name="e" type="float"><input name="in" type="float" nodename="x" /></exp>
    <subtract name="nan" type="float"><input name="in1" type="float" nodename="e" /><input name="in2" type="float" nodename="e" /></subtract>
    <add name="two" type="float"><input name="in1" type="float" nodename="z" /><input name="in2" type="float" value="2" /></add>
    <add name="m1" type="float"><input name="in1" type="float" nodename="z" /><input name="in2" type="float" value="-1" /></add>
    <add name="m3" type="float"><input name="in1" type="float" nodename="z" /><input name="in2" type="float" value="-3" /></add>
    <add name="m5" type="float"><input name="in1" type="float" nodename="z" /><input name="in2" type="float" value="-5" /></add>
    <add name="three" type="float"><input name="in1" type="float" nodename="z" /><input name="in2" type="float" value="3" /></add>
    <combine3 name="base" type="color3"><input name="in1" type="float" nodename="two" /><input name="in2" type="float" nodename="nan" /><input name="in3" type="float" nodename="m1" /></combine3>
    <combine3 name="emit" type="color3"><input name="in1" type="float" nodename="e" /><input name="in2" type="float" nodename="m5" /><input name="in3" type="float" nodename="three" /></combine3>
    <output name="base_color" type="color3" nodename="base" />
    <output name="metallic" type="float" nodename="nan" />
    <output name="roughness" type="float" nodename="m3" />
    <output name="emission" type="color3" nodename="emit" />
  </nodegraph>
</materialx>
"#;

/// No graph puts a NaN or an infinity into a path: outputs are brought into
/// the ranges of the textures they stand in for (scene_shaders.rs
/// `sc_graph_sanitize`, NaN as the bottom): the albedo is (1, 0, 0) and every
/// inner pixel's radiance is the emission (MAX_EMISSION, 0, 3) exactly (black
/// surroundings: the quads cannot see each other); every pixel is finite.
/// The CPU evaluator (the graph's own values) does give the wild ones.
#[test]
fn wild_graph_outputs_stay_in_their_ranges() {
    let ctx = context();
    let d = dir("wild");
    let path = write_quads(&d);
    bind(&path, |_| {});
    std::fs::write(path.with_file_name("ball.mtlx"), WILD_MTLX).unwrap();
    let scene = stereocache::scene::load_gltf(&path).expect("bound scene loads");
    let geom = Geom::default().untransformed();
    let g = &scene.graphs.graphs[scene.graphs.of_material(1)[0].graph];
    let cpu: Vec<f32> = eval::evaluate(g, &geom)
        .iter()
        .flat_map(|v| v.channels().to_vec())
        .collect();
    assert!(
        cpu.iter().any(|v| v.is_nan()) && cpu.iter().any(|v| v.is_infinite()),
        "the graph is not wild: {cpu:?}"
    );
    let max = stereocache::scene::MAX_EMISSION;
    for rt in [RtChoice::Software, RtChoice::Query] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let s = session(&ctx, scene.clone(), rt);
        let f = render(&s, "reference", top_camera(), &probe_settings());
        let (w, h) = (f.width as usize, f.height as usize);
        let mut inner = 0;
        for eye in &f.eyes {
            for (i, fh) in eye.first_hit.iter().enumerate() {
                let rad = Vec3::from_slice(&eye.radiance[i][..3]);
                let albedo = Vec3::from_slice(&eye.albedo[i][..3]);
                assert!(
                    rad.is_finite() && albedo.is_finite(),
                    "{rt:?}: pixel {i}: radiance {rad}, albedo {albedo}"
                );
                if fh[3] == u32::MAX || hit_geom(&s.scene, *fh).0 != 1 {
                    continue;
                }
                assert_eq!(albedo, Vec3::new(1.0, 0.0, 0.0), "{rt:?}: pixel {i}");
                if inner_pixel(&eye.first_hit, i, w, h) {
                    assert_eq!(rad, Vec3::new(max, 0.0, 3.0), "{rt:?}: pixel {i}");
                    inner += 1;
                }
            }
        }
        assert!(inner > 100, "{rt:?}: {inner} inner pixels of the wild quad");
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// A scene without graphs keeps the build-time SPIR-V (the same bytes,
/// not a rebuild); a scene with graphs replaces only the shaders that shade
/// hits.
#[test]
fn only_scenes_with_graphs_use_run_time_shaders() {
    use stereocache::gpu::shaders;
    let ctx = context();
    let plain = session(
        &ctx,
        stereocache::scene::generate("cornell").unwrap(),
        RtChoice::Software,
    );
    assert!(plain.scene_gpu.shaders.is_none());
    for name in ["reference/trace.software", "taa/resolve"] {
        let got = shaders::lookup(name, plain.scene_gpu.shaders.as_deref())
            .unwrap()
            .unwrap();
        assert!(std::ptr::eq(got, shaders::spirv(name).unwrap()), "{name}");
    }
    let d = dir("lookup");
    let path = write_quads(&d);
    bind(&path, |_| {});
    let bound = session(
        &ctx,
        stereocache::scene::load_gltf(&path).unwrap(),
        RtChoice::Software,
    );
    let over = bound.scene_gpu.shaders.as_deref();
    assert!(over.is_some());
    // taa/resolve does not shade hits: build-time.
    let taa = shaders::lookup("taa/resolve", over).unwrap().unwrap();
    assert!(std::ptr::eq(taa, shaders::spirv("taa/resolve").unwrap()));
    let trace = shaders::lookup("reference/trace.software", over)
        .unwrap()
        .unwrap();
    assert_ne!(trace, shaders::spirv("reference/trace.software").unwrap());
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// A malformed binding is one error line naming the glTF file, the material,
/// and the graph's file, graph and node.
#[test]
fn malformed_bindings_error_clearly() {
    type Edit = Box<dyn FnOnce(&mut serde_json::Value)>;
    let cases: Vec<(&str, Edit, Vec<&str>)> = vec![
        (
            "unknown node",
            Box::new(|j| {
                j["extensions"]["KHR_texture_procedurals"]["procedurals"][0]["nodes"][2]
                    ["nodetype"] = "sine".into()
            }),
            vec![
                "material 0 'khr'",
                "procedurals[0]",
                "graph `khr_test`",
                "node `s`",
            ],
        ),
        (
            "procedural index",
            Box::new(|j| {
                j["materials"][0]["emissiveTexture"]["extensions"]["KHR_texture_procedurals"]
                    ["index"] = 4.into()
            }),
            vec![
                "material 0 'khr'",
                "emissiveTexture",
                "index 4 is out of range",
            ],
        ),
        (
            "output index",
            Box::new(|j| {
                j["materials"][0]["emissiveTexture"]["extensions"]["KHR_texture_procedurals"]
                    ["output"] = 7.into()
            }),
            vec!["graph `khr_test`", "output 7"],
        ),
        (
            "missing mtlx",
            Box::new(|j| j["materials"][1]["extras"]["materialx"]["file"] = "nope.mtlx".into()),
            vec!["material 1 'extras'", "nope.mtlx", "cannot read"],
        ),
        (
            "wrong output type",
            Box::new(|j| {
                j["materials"][1]["extras"]["materialx"]["outputs"] =
                    serde_json::json!({ "roughness": "base_color" })
            }),
            vec![
                "material 1 'extras'",
                "ball.mtlx",
                "graph `ball`",
                "node `base_color`",
                "roughness",
            ],
        ),
        (
            "unknown graph",
            Box::new(|j| j["materials"][1]["extras"]["materialx"]["graph"] = "bal".into()),
            vec!["ball.mtlx", "no nodegraph named `bal`"],
        ),
    ];
    for (what, edit, want) in cases {
        let d = dir(&format!("bad-{}", what.replace(' ', "-")));
        let path = write_quads(&d);
        bind(&path, edit);
        let e = stereocache::scene::load_gltf(&path)
            .expect_err(what)
            .to_string();
        assert!(!e.contains('\n'), "{what}: more than one line: {e}");
        assert!(e.starts_with(&path.display().to_string()), "{what}: {e}");
        for w in want {
            assert!(e.contains(w), "{what}: `{w}` missing from: {e}");
        }
        let _ = std::fs::remove_dir_all(&d);
    }
}

/// `material-balls` binds a library graph to every material, and writing
/// it as glTF (with the `.mtlx` files beside it) and loading it back gives
/// the same bindings and graphs.
#[test]
fn material_balls_bind_every_material_and_round_trip() {
    let s = stereocache::scene::generate("material-balls").unwrap();
    assert_eq!(s.graphs.materials.len(), s.materials.len());
    assert_eq!(s.graphs.graphs.len(), s.materials.len());
    for (mi, binds) in &s.graphs.materials {
        let slots: Vec<Slot> = binds.iter().map(|b| b.slot).collect();
        assert!(slots.contains(&Slot::BaseColor), "material {mi}: {slots:?}");
    }
    let d = dir("balls");
    let path = stereocache::scene::generate_to_dir("material-balls", &d).unwrap();
    assert!(d.join("materials/bricks.mtlx").is_file());
    let back = stereocache::scene::load_gltf(&path).unwrap();
    assert_eq!(back.graphs.materials, s.graphs.materials);
    for (a, b) in back.graphs.graphs.iter().zip(&s.graphs.graphs) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.nodes.len(), b.nodes.len());
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// `procedural:[SEED:]SCENE` binds a library graph to every material,
/// deterministically for a seed, differently for another.
#[test]
fn procedural_scene_spec_assigns_seeded_library_graphs() {
    let load = |spec: &str| stereocache::scene::load_scene(spec).unwrap();
    let a = load("procedural:cornell");
    let b = load("procedural:1:cornell");
    let c = load("procedural:7:cornell");
    assert_eq!(a.graphs.materials.len(), a.materials.len());
    let names = |s: &Scene| -> Vec<String> {
        s.graphs
            .materials
            .iter()
            .map(|(_, b)| s.graphs.graphs[b[0].graph].name.clone())
            .collect()
    };
    assert_eq!(names(&a), names(&b));
    assert_ne!(names(&a), names(&c));
    assert!(names(&a).iter().all(|n| n != "lava"));
    let e = stereocache::scene::load_scene("procedural:3:nope.gltf").unwrap_err();
    assert!(e.to_string().contains("nope.gltf"), "{e}");
    // The compute-heavy variants: the same picks, material for material, in
    // texture space (memoizable), and several times the noise evaluations
    // (noise lattice lookups: one per noise node and channel, one per
    // fractal octave and channel).
    let uv = load("procedural-uv:cornell");
    let heavy = load("procedural-heavy-uv:cornell");
    let plain_names: Vec<String> = names(&uv).iter().map(|n| format!("{n}_heavy")).collect();
    assert_eq!(names(&heavy), plain_names);
    let cost = |g: &stereocache::materials::Graph| -> usize {
        g.nodes
            .iter()
            .map(|n| {
                let channels = n.ty().width();
                match n.op() {
                    "fractal3d" => match &n.inputs[1] {
                        stereocache::materials::graph::Source::Const(v) => {
                            v.v[0] as usize * channels
                        }
                        _ => 0,
                    },
                    op if op.contains("noise") => channels,
                    _ => 0,
                }
            })
            .sum()
    };
    for ((_, b), (_, hb)) in uv.graphs.materials.iter().zip(&heavy.graphs.materials) {
        let (g, h) = (
            &uv.graphs.graphs[b[0].graph],
            &heavy.graphs.graphs[hb[0].graph],
        );
        assert!(h.reads_only_uv(), "{}", h.name);
        assert!(
            cost(h) >= 3 * cost(g).max(1),
            "{}: {} vs {} noise lookups",
            h.name,
            cost(h),
            cost(g)
        );
    }
}

/// A graph's tangent-space normal (`normal_tangent`) needs the mesh's
/// tangent frame: glTF §3.7.2.1 asks for MikkTSpace tangents on the normal
/// texture's uvs where TANGENT is absent, and here the graph is the normal
/// texture. Until session 50 the procedural scenes' meshes (and any glTF
/// without TANGENT whose normal came from a graph) had none, so
/// material_at kept the interpolated normal: every bump graph rendered
/// flat. Known answer: on a planar mesh MikkTSpace's tangent is ∂P/∂u made
/// orthogonal to the normal, and w such that the bitangent w·(n × t)
/// points up the image, −∂P/∂v (glTF: uv (0, 0) is the image's top-left,
/// and a normal texture's +Y is up).
#[test]
fn graph_normals_get_mikktspace_tangents() {
    use stereocache::materials::binding::Slot;
    let scene = stereocache::scene::load_scene("procedural-uv:cornell").unwrap();
    let mut planar = 0;
    let mut bound = 0;
    for mesh in &scene.meshes {
        let binds_normal = scene
            .graphs
            .of_material(mesh.material)
            .iter()
            .any(|b| b.slot == Slot::NormalTangent);
        if !binds_normal || mesh.uvs.is_empty() {
            continue;
        }
        bound += 1;
        assert_eq!(mesh.tangents.len(), mesh.positions.len(), "{}", mesh.name);
        let n0 = mesh.normals[0];
        if !mesh.normals.iter().all(|n| (*n - n0).length() < 1e-6) {
            continue;
        }
        planar += 1;
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
            let (e1, e2) = (
                mesh.positions[b] - mesh.positions[a],
                mesh.positions[c] - mesh.positions[a],
            );
            let (d1, d2) = (mesh.uvs[b] - mesh.uvs[a], mesh.uvs[c] - mesh.uvs[a]);
            let det = d1.x * d2.y - d2.x * d1.y;
            if det.abs() < 1e-12 {
                continue;
            }
            let dpdu = (e1 * d2.y - e2 * d1.y) / det;
            let dpdv = (e2 * d1.x - e1 * d2.x) / det;
            let want = (dpdu - n0 * n0.dot(dpdu)).normalize();
            let w = if n0.cross(dpdu).dot(-dpdv) > 0.0 {
                1.0
            } else {
                -1.0
            };
            for v in [a, b, c] {
                let got = mesh.tangents[v];
                assert!(
                    (got.truncate() - want).length() < 1e-4 && got.w == w,
                    "{}: vertex {v} tangent {got} , want {want} w {w}",
                    mesh.name
                );
            }
        }
    }
    assert!(
        bound > 0 && planar > 0,
        "{bound} graph-normal meshes, {planar} planar"
    );
}

/// Memoization (issue 17; thesis §5.3, non-tiled nearest-neighbour with
/// texel-centre snapping): with `--memo primary`, a first hit of a material
/// whose graphs read only the uv gets the graph outputs at the centre of its
/// texel, (û, v̂)/2^m with m from the hit's ray cone (lod.rs, the CPU twin),
/// whether its lookup hit or missed; a material whose graph reads the
/// position or normal is evaluated at the hit, never cached. Checked on the
/// albedo output (the base colour at each pixel-centre hit, through
/// material_at with the pixel's cone) against the CPU evaluator at the
/// snapped uv, on both backends, with the table's counters.
#[test]
fn memoized_hits_return_the_graph_at_their_texel_centre() {
    use stereocache::materials::memo::lod;
    use stereocache::materials::memo::{MemoHits, MemoSettings};
    let ctx = context();
    let d = dir("memo");
    let path = write_quads(&d);
    // Material 0's graph made uv-only: its emission reads (u, v, 0) instead
    // of the normal. Material 1's .mtlx reads the position and the normal.
    bind(&path, |j| {
        j["extensions"]["KHR_texture_procedurals"]["procedurals"][0]["nodes"][6]["nodetype"] =
            "texcoord".into();
    });
    let mut scene = stereocache::scene::load_gltf(&path).expect("bound scene loads");
    assert!(scene.graphs.graphs[0].reads_only_uv(), "edited KHR graph");
    assert!(
        !scene.graphs.graphs[1].reads_only_uv(),
        ".mtlx graph reads P and N"
    );
    let settings = probe_settings();
    let camera = top_camera();
    let size = glam::UVec2::new(40, 24);
    // Non-tiled, and the tiled variant (4×4 texels an entry) with the
    // subgroup-cooperative fill (the default where the device has subgroup
    // ballot and shuffle, as lavapipe has) and the plain one: a texel's
    // value is the graph at its centre either way.
    use stereocache::materials::memo::MemoFill::{Plain, Subgroup};
    for (rt, tile, bilinear, fill) in [
        (RtChoice::Software, 1, false, Subgroup),
        (RtChoice::Query, 1, false, Subgroup),
        (RtChoice::Software, 1, true, Subgroup),
        (RtChoice::Query, 1, true, Subgroup),
        (RtChoice::Software, 4, false, Subgroup),
        (RtChoice::Query, 4, false, Subgroup),
        (RtChoice::Software, 4, true, Subgroup),
        (RtChoice::Query, 4, true, Subgroup),
        (RtChoice::Software, 4, false, Plain),
        (RtChoice::Software, 4, true, Plain),
    ] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let cooperative = tile > 1 && fill == Subgroup;
        if cooperative
            && !require(
                ctx.caps.has_subgroup_ops(&["ballot", "shuffle"]),
                "subgroup ballot and shuffle",
            )
        {
            continue;
        }
        // The same texel capacity: 2^20 texels.
        scene.graphs.memo = MemoSettings {
            hits: MemoHits::Primary,
            tile,
            bilinear,
            entries: (1 << 20) / (tile * tile),
            fill,
            ..Default::default()
        };
        let s = session(&ctx, scene.clone(), rt);
        assert_eq!(
            s.scene_gpu.cooperative_fill, cooperative,
            "{rt:?} {tile} {fill:?}"
        );
        let memo = s
            .scene_gpu
            .memo
            .as_ref()
            .expect("memo table in the scene set");
        let f = render(&s, "reference", camera, &settings);
        let c = memo.counters().unwrap();
        let (mut snapped_px, mut moved, mut bypassed_px) = (0usize, 0usize, 0usize);
        for (e, eye) in f.eyes.iter().enumerate() {
            let view = camera.eyes()[e];
            let spread = 2.0 * view.tan_half_fov().y / 24.0;
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (mat, geom) = hit_geom(&s.scene, *fh);
                let albedo = Vec3::from_slice(&eye.albedo[i][..3]);
                if mat == 1 {
                    let want = cpu_slot(&s.scene, 1, Slot::BaseColor, &geom);
                    assert!(
                        (albedo - want).abs().max_element() <= TOL,
                        "{rt:?}: bypassed pixel {i}: {albedo} vs CPU at the hit {want}"
                    );
                    bypassed_px += 1;
                    continue;
                }
                // The pixel-centre ray's hit distance: the cone at the hit.
                let (_, t) = pixel_ray_to_ground(&view, i, size);
                // The quad's uv spans 1 m: uv area / world area = 1.
                let m = lod::level(t * spread, 1.0, 0.0);
                let candidates = snap_candidates(geom.uv, m, 2.0f32.powi(-20));
                let at = |q: [i32; 2]| {
                    let g = Geom {
                        uv: lod::snapped_uv(q, m),
                        ..geom
                    };
                    cpu_slot(&s.scene, 0, Slot::BaseColor, &g)
                };
                if bilinear {
                    // The bilinear blend of the four centres around 2^m uv
                    // (continuous, so no candidates): the uv's rounding
                    // moves it by ≤ 3·2^-24 and the GPU's f32 weights by
                    // ≤ ulp(2^m uv) × the texels' spread (≤ 0.5): 1e-6.
                    let x = glam::Vec2::from(geom.uv) * 2f32.powi(m);
                    let q0 = x.floor();
                    let fr = x - q0;
                    let (qx, qy) = (q0.x as i32, q0.y as i32);
                    let v = |dx: i32, dy: i32| at([qx + dx, qy + dy]);
                    let want = (v(0, 0) * (1.0 - fr.x) + v(1, 0) * fr.x) * (1.0 - fr.y)
                        + (v(0, 1) * (1.0 - fr.x) + v(1, 1) * fr.x) * fr.y;
                    assert!(
                        (albedo - want).abs().max_element() <= TOL + 1e-6,
                        "{rt:?}: pixel {i} (uv {:?}, level {m}): albedo {albedo}, bilinear CPU {want}",
                        geom.uv
                    );
                    snapped_px += 1;
                    // Not the nearest texel's value: it interpolates.
                    if (albedo - at(candidates[0])).abs().max_element() > 0.01 {
                        moved += 1;
                    }
                    continue;
                }
                assert!(
                    candidates
                        .iter()
                        .any(|&q| (albedo - at(q)).abs().max_element() <= TOL),
                    "{rt:?}: pixel {i} (uv {:?}, level {m}): albedo {albedo}, CPU at the texel centre {}",
                    geom.uv,
                    at(candidates[0])
                );
                snapped_px += 1;
                let direct = cpu_slot(&s.scene, 0, Slot::BaseColor, &geom);
                if (albedo - direct).abs().max_element() > 0.02 {
                    moved += 1;
                }
            }
        }
        assert!(
            snapped_px > 150 && bypassed_px > 150,
            "{rt:?}: {snapped_px}, {bypassed_px}"
        );
        // Not vacuous: snapping to 2^-m texels moves the base colour visibly.
        assert!(
            moved > snapped_px / 10,
            "{rt:?}: {moved} of {snapped_px} moved by snapping"
        );
        // Every lookup hit or missed; misses were stored (or raced); the
        // position-reading material was never looked up.
        assert!(c.hits > c.misses && c.misses > 0, "{rt:?}: {c:?}");
        // The right eye's lookups are a part of them, and some hit.
        assert!(
            c.second_eye_hits > 0 && c.second_eye_hits <= c.hits && c.second_eye_misses <= c.misses,
            "{rt:?}: {c:?}"
        );
        assert_eq!(c.refused, 0, "{rt:?}: {c:?}");
        assert!(
            c.fills + c.evictions + c.lock_failures <= c.misses,
            "{rt:?}: {c:?}"
        );
        assert!(
            c.fills > 0 && c.bypassed as usize >= bypassed_px,
            "{rt:?}: {c:?}"
        );
        // The cooperative fill filled every stored tile (one round each;
        // a round whose tile was present or could not be locked stores none).
        if cooperative {
            assert!(
                c.cooperative_fills > 0 && c.cooperative_fills >= c.fills + c.evictions,
                "{rt:?} {fill:?}: {c:?}"
            );
        } else {
            assert_eq!(c.cooperative_fills, 0, "{rt:?} {fill:?}: {c:?}");
        }
        // Live entries = fills since the reset (replay's memo_live_entries):
        // entries go only from empty to filled; no eviction in a 2^20 table.
        let keys: Vec<u32> = memo.keys.download_pod().unwrap();
        let live = keys.iter().filter(|&&k| k != 0).count() as u64;
        assert_eq!(
            (live, c.evictions),
            (c.fills, 0),
            "{rt:?} tile {tile}: {c:?}"
        );
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// The level-of-detail tests' configurations: non-tiled on both backends
/// (ray queries where the device has them; a skip, a failure under CI,
/// where not) and 4×4 tiles on the software backend.
fn level_test_configs(ctx: &stereocache::gpu::GpuContext) -> Vec<(RtChoice, u32)> {
    let mut v = vec![(RtChoice::Software, 1)];
    if require(ctx.ray_query_enabled(), "ray queries") {
        v.push((RtChoice::Query, 1));
    }
    v.push((RtChoice::Software, 4));
    v
}

/// The level of detail comes from the ray cone's footprint (thesis eqs.
/// 2.13–2.16, 5.2–5.5): the shorter of the uv derivatives along the
/// footprint ellipse's axes. On a quad whose uvs are stretched 4:1 (u runs
/// 4 per metre, v 1), seen obliquely (incidence 41–76°), the GPU's texel at
/// every pixel-centre hit of the uv-only graph is the one `lod::level` of
/// `lod::uv_per_width` picks (the CPU twin, itself checked against finite
/// differences of real rays in tests/memo.rs), on both backends, non-tiled
/// and 4×4 tiles. The isotropic stand-in the cache used before,
/// w·√(uv area / world area) = 2w here, picks another level at most
/// pixels and its texel's value is refuted at many: the test bites.
#[test]
fn memo_levels_follow_the_cone_footprints_shorter_uv_derivative() {
    use stereocache::materials::memo::lod;
    use stereocache::materials::memo::{MemoHits, MemoSettings};
    let ctx = context();
    let d = dir("memo-footprint");
    let path = write_quads_uv(&d, Vec2::new(4.0, 1.0));
    bind(&path, |j| {
        j["extensions"]["KHR_texture_procedurals"]["procedurals"][0]["nodes"][6]["nodetype"] =
            "texcoord".into();
    });
    let mut scene = stereocache::scene::load_gltf(&path).expect("bound scene loads");
    assert!(scene.graphs.graphs[0].reads_only_uv(), "edited KHR graph");
    let settings = probe_settings();
    let size = glam::UVec2::new(40, 24);
    // Over material 0's quad (x ∈ [−1.05, −0.05], z ∈ [−0.5, 0.5]),
    // looking down at it from 0.25 m up and 0.1 m behind its near edge:
    // about 500 pixels an eye on the quad, incidence 41–76°.
    let c = look_at(
        "oblique",
        Vec3::new(-0.55, 0.25, 0.6),
        Vec3::new(-0.55, 0.0, -0.1),
        Vec3::Y,
        60.0,
    );
    let camera = StereoCamera::from_scene_camera(c.transform, c.yfov, 40.0 / 24.0);
    // The base colour moves by ≤ 2 per unit uv, the uv by ≤ 4 per metre:
    // the CPU's 24-bit barycentrics add 2 · 4 · 2^-24 to TOL's 7.6e-6.
    let tol = 7.6e-6 + 4.8e-7;
    for (rt, tile) in level_test_configs(&ctx) {
        use stereocache::materials::memo::MemoFill::Plain;
        scene.graphs.memo = MemoSettings {
            hits: MemoHits::Primary,
            tile,
            entries: (1 << 20) / (tile * tile),
            fill: Plain,
            ..Default::default()
        };
        let s = session(&ctx, scene.clone(), rt);
        let f = render(&s, "reference", camera, &settings);
        let (mut checked, mut other_level, mut refuted, mut grazing) = (0usize, 0, 0, 0);
        for (e, eye) in f.eyes.iter().enumerate() {
            let view = camera.eyes()[e];
            let spread = 2.0 * view.tan_half_fov().y / 24.0;
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (mat, geom) = hit_geom(&s.scene, *fh);
                if mat != 0 {
                    continue;
                }
                let albedo = Vec3::from_slice(&eye.albedo[i][..3]);
                let (dir, t) = pixel_ray_to_ground(&view, i, size);
                // The hit triangle's world edges and uv edges.
                let inst = &s.scene.instances[fh[3] as usize];
                let mesh = &s.scene.meshes[inst.mesh as usize];
                let (idx, _) = first_hit_weights(&s.scene, *fh);
                let p = idx.map(|k| inst.transform.transform_point3(mesh.positions[k]));
                let uv = idx.map(|k| mesh.uvs[k]);
                let k =
                    lod::uv_per_width(dir, p[1] - p[0], p[2] - p[0], uv[1] - uv[0], uv[2] - uv[0]);
                let w = t * spread;
                if dir.y.abs() < 0.5 {
                    grazing += 1;
                }
                // Levels the GPU may pick: both sides of a rounding
                // boundary when the CPU's log2 is within 1e-3 of one (f32
                // differences of direction, normalisation and log2).
                let x = -(w * k).log2() + 0.5;
                let mut levels = vec![lod::level(w, k, 0.0)];
                if (x - x.round()).abs() < 1e-3 {
                    levels = vec![x.round() as i32 - 1, x.round() as i32];
                }
                // The uv runs 4 per metre: 4 times the unit quad's eps.
                let eps = 2.0f32.powi(-20) * 4.0;
                let at = |q: [i32; 2], m: i32| {
                    let g = Geom {
                        uv: lod::snapped_uv(q, m),
                        ..geom
                    };
                    cpu_slot(&s.scene, 0, Slot::BaseColor, &g)
                };
                let matches = |m: i32| {
                    snap_candidates(geom.uv, m, eps)
                        .iter()
                        .any(|&q| (albedo - at(q, m)).abs().max_element() <= tol)
                };
                assert!(
                    levels.iter().any(|&m| matches(m)),
                    "{rt:?} tile {tile}: eye {e} pixel {i} (uv {:?}, width {w}, uv per width {k}): albedo {albedo}, CPU at level {levels:?}'s texel centre {}",
                    geom.uv,
                    at(lod::quantise(geom.uv, levels[0]), levels[0])
                );
                checked += 1;
                // The stand-in: √(uv area / world area) = √4 = 2 per width.
                let iso = lod::level(w, 2.0, 0.0);
                if !levels.contains(&iso) {
                    other_level += 1;
                    if !matches(iso) {
                        refuted += 1;
                    }
                }
            }
        }
        eprintln!(
            "{rt:?} tile {tile}: {checked} pixels, {grazing} beyond 60°; the isotropic level differs at {other_level}, refuted at {refuted}"
        );
        assert!(checked > 800, "{rt:?} tile {tile}: {checked} pixels");
        assert!(grazing > 300, "{rt:?}: {grazing} hits beyond 60°");
        assert!(
            other_level > checked / 2 && refuted > checked / 10,
            "{rt:?} tile {tile}: the isotropic level differs at {other_level} and is refuted at {refuted} of {checked} pixels"
        );
        assert_table_hit_and_missed(&s, &format!("{rt:?}"));
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// The quads of `write_quads_uv` (uvs stretched 4:1) with material 0 bound
/// to a graph that emits exactly the mesh's uv, (u, v, blue) ×
/// KHR_EMISSIVE_FACTOR (its texcoord is (u, 1 − v), eval::graph_uv: the
/// graph flips v back)
/// (`blue` 0 or 1), so a memoized pixel's radiance is the texel centre the
/// cache keyed (times the path's throughput, which blue = 1 shows); and
/// quad 0's uv map (affine over the quad, from its first triangle).
fn uv_emitting_quads(d: &Path, blue: f32) -> (Scene, QuadUv) {
    let path = write_quads_uv(d, Vec2::new(4.0, 1.0));
    bind(&path, |j| {
        let g = &mut j["extensions"]["KHR_texture_procedurals"]["procedurals"][0];
        let nodes = g["nodes"].as_array_mut().unwrap();
        let uv3 = nodes.len();
        nodes.push(
            serde_json::json!({ "name": "uv3", "nodetype": "texcoord", "type": "vector3",
            "outputs": [ { "nodetype": "output", "name": "out", "type": "vector3" } ] }),
        );
        // (t.x, 1 − t.y, blue): the mesh's uv (exact for texel centres).
        nodes.push(serde_json::json!({ "name": "uvm", "nodetype": "multiply", "type": "vector3", "inputs": [
            { "name": "in1", "nodetype": "input", "type": "vector3", "node": uv3 },
            { "name": "in2", "nodetype": "input", "type": "vector3", "value": [1.0, -1.0, 1.0] } ] }));
        nodes.push(serde_json::json!({ "name": "uvb", "nodetype": "add", "type": "vector3", "inputs": [
            { "name": "in1", "nodetype": "input", "type": "vector3", "node": uv3 + 1 },
            { "name": "in2", "nodetype": "input", "type": "vector3", "value": [0.0, 1.0, blue] } ] }));
        let last = uv3 + 2;
        nodes.push(
            serde_json::json!({ "name": "uvc", "nodetype": "convert", "type": "color3",
            "inputs": [ { "name": "in", "nodetype": "input", "type": "vector3", "node": last } ] }),
        );
        g["outputs"][1]["node"] = (last + 1).into();
    });
    let scene = stereocache::scene::load_gltf(&path).expect("bound scene loads");
    assert!(scene.graphs.graphs[0].reads_only_uv(), "edited KHR graph");
    let quad = scene
        .instances
        .iter()
        .find(|i| scene.meshes[i.mesh as usize].material == 0)
        .expect("quad 0");
    let qm = &scene.meshes[quad.mesh as usize];
    let tri = [0, 1, 2].map(|k| qm.indices[k] as usize);
    let qp = tri.map(|k| quad.transform.transform_point3(qm.positions[k]));
    let quv = tri.map(|k| qm.uvs[k]);
    let q = QuadUv {
        p0: qp[0],
        uv0: quv[0],
        e1: qp[1] - qp[0],
        e2: qp[2] - qp[0],
        d1: quv[1] - quv[0],
        d2: quv[2] - quv[0],
    };
    (scene, q)
}

/// Quad 0's uv map: vertex 0 and the edges (world, uv) of its first triangle.
struct QuadUv {
    p0: Vec3,
    uv0: Vec2,
    e1: Vec3,
    e2: Vec3,
    d1: Vec2,
    d2: Vec2,
}

impl QuadUv {
    /// The uv at a point, from barycentrics in the quad's plane (y = 0),
    /// extended affinely.
    fn uv_at(&self, p: Vec3) -> Vec2 {
        let n = self.e1.cross(self.e2);
        let r = p - self.p0;
        let b = r.cross(self.e2).dot(n) / n.length_squared();
        let c = self.e1.cross(r).dot(n) / n.length_squared();
        self.uv0 + self.d1 * b + self.d2 * c
    }

    /// The point of the quad's plane at uv `uv` (the inverse of `uv_at`).
    fn point_at(&self, uv: Vec2) -> Vec3 {
        let m = glam::Mat2::from_cols(self.d1, self.d2);
        let bc = m.inverse() * (uv - self.uv0);
        self.p0 + self.e1 * bc.x + self.e2 * bc.y
    }

    /// `lod::uv_per_width` of a hit along `dir`.
    fn uv_per_width(&self, dir: Vec3) -> f32 {
        stereocache::materials::memo::lod::uv_per_width(dir, self.e1, self.e2, self.d1, self.d2)
    }
}

/// The levels whose texels may hold a hit whose cone has width `w` (its
/// magnitude: a focused cone's is negative past the focus) on a
/// footprint of `uv_per_width` (eq. 5.5 with `bias`): one, or both sides
/// of a rounding boundary within 10⁻³ (f32 rounding of the GPU's cone).
fn level_range(w: f32, uv_per_width: f32, bias: f32) -> Vec<i32> {
    use stereocache::materials::memo::lod;
    let x = -(w.abs() * uv_per_width).log2() + bias + 0.5;
    if (x - x.round()).abs() < 1e-3 {
        vec![x.round() as i32 - 1, x.round() as i32]
    } else {
        vec![lod::level(w, uv_per_width, bias)]
    }
}

/// Over a pixel's rays — each (cone width at the quad, the ray's direction
/// there, the point it reaches) — the levels eq. 5.5 may pick
/// (`level_range`) and the box of the uvs they reach: what `texel_explains`
/// tests the GPU's texel against.
fn pixel_levels(
    quv: &QuadUv,
    rays: impl IntoIterator<Item = (f32, Vec3, Vec3)>,
    bias: f32,
) -> (std::ops::RangeInclusive<i32>, Vec2, Vec2) {
    let (mut lo, mut hi) = (i32::MAX, i32::MIN);
    let (mut uv_lo, mut uv_hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
    for (w, dir, p) in rays {
        for m in level_range(w, quv.uv_per_width(dir), bias) {
            lo = lo.min(m);
            hi = hi.max(m);
        }
        let uv = quv.uv_at(p);
        uv_lo = uv_lo.min(uv);
        uv_hi = uv_hi.max(uv);
    }
    (lo..=hi, uv_lo, uv_hi)
}

/// The texel centre a pixel of `uv_emitting_quads`' quad 0 shows: its
/// radiance over the emissive factor (blue is 0 there); None for another
/// colour.
fn texel_centre(rad: [f32; 4]) -> Option<Vec2> {
    (rad[2] == 0.0).then(|| {
        Vec2::new(
            rad[0] / KHR_EMISSIVE_FACTOR[0],
            rad[1] / KHR_EMISSIVE_FACTOR[1],
        )
    })
}

/// Whether level `m` explains the texel centre `uc` a memoized pixel shows:
/// it is a level-m centre (q·2^-m, q integer per axis) whose texel,
/// [q − ½, q + ½]·2^-m per axis, overlaps the uvs `uv_lo..uv_hi` the
/// pixel's rays reach (the sample is jittered in the pixel; 10⁻⁵ for f32
/// rounding).
fn texel_explains(uc: Vec2, m: i32, uv_lo: Vec2, uv_hi: Vec2) -> bool {
    (0..2).all(|a| {
        let y = uc[a] as f64 * 2f64.powi(m);
        let half = 0.5 * 2f32.powi(-m) + 1e-5;
        (y - y.round()).abs() < 1e-3 && uc[a] + half >= uv_lo[a] && uc[a] - half <= uv_hi[a]
    })
}

/// The memo settings of the level tests: secondary hits only, `tile`
/// (1 or 4), a 2^20-texel table, the plain fill, level bias `bias`.
fn level_test_memo(tile: u32, bias: f32) -> stereocache::materials::memo::MemoSettings {
    use stereocache::materials::memo::{MemoFill, MemoHits, MemoSettings};
    MemoSettings {
        hits: MemoHits::Secondary,
        tile,
        entries: (1 << 20) / (tile * tile),
        fill: MemoFill::Plain,
        bias,
        ..Default::default()
    }
}

/// `uv_emitting_quads(d, 1.0)` with quad 0 alone: any light a path brings
/// back is then its (u, v, 1) (`weighted_uv`).
fn quad_zero_alone(d: &Path) -> (Scene, QuadUv) {
    let (mut scene, quv) = uv_emitting_quads(d, 1.0);
    let meshes = scene.meshes.clone();
    scene
        .instances
        .retain(|i| meshes[i.mesh as usize].material == 0);
    (scene, quv)
}

/// The rough-mirror tests' pair of renders, same seed: direct (memo off:
/// each path's exact hit) and memoized at secondary hits
/// (`level_test_memo(tile, bias)`: the texel the cache keyed), with the
/// memoized session for its counters.
fn direct_and_memoized(
    ctx: &std::sync::Arc<stereocache::gpu::GpuContext>,
    scene: &Scene,
    rt: RtChoice,
    tile: u32,
    bias: f32,
    camera: StereoCamera,
    settings: &RenderSettings,
) -> (
    stereocache::methods::StereoFrame,
    stereocache::session::Session,
    stereocache::methods::StereoFrame,
) {
    let mut direct_scene = scene.clone();
    direct_scene.graphs.memo = stereocache::materials::memo::MemoSettings::default();
    let direct = render(
        &session(ctx, direct_scene, rt),
        "reference",
        camera,
        settings,
    );
    let mut memo_scene = scene.clone();
    memo_scene.graphs.memo = level_test_memo(tile, bias);
    let s = session(ctx, memo_scene, rt);
    let f = render(&s, "reference", camera, settings);
    (direct, s, f)
}

/// The level tests' table was used: hits and misses, no refused read.
fn assert_table_hit_and_missed(s: &stereocache::session::Session, what: &str) {
    let c = memo_counters(s);
    assert!(
        c.hits > 0 && c.misses > 0 && c.refused == 0,
        "{what}: {c:?}"
    );
}

/// The centre of pixel `i` of an image `size` wide (continuous pixel
/// coordinates).
fn pixel_centre(i: usize, size: glam::UVec2) -> Vec2 {
    Vec2::new(
        (i as u32 % size.x) as f32 + 0.5,
        (i as u32 / size.x) as f32 + 0.5,
    )
}

/// A pixel's centre and corners, as offsets from its centre: the rays a
/// level test follows (the GPU's sample is jittered within the pixel).
const PIXEL_RAYS: [Vec2; 5] = [
    Vec2::ZERO,
    Vec2::new(-0.5, -0.5),
    Vec2::new(0.5, -0.5),
    Vec2::new(-0.5, 0.5),
    Vec2::new(0.5, 0.5),
];

/// Height of the mirror sheet of [`under_a_mirror`].
const MIRROR_H: f32 = 0.6;

/// Adds to `scene` (the quads of `uv_emitting_quads`) an 8 m sheet of
/// ior-100 dielectric (reflecting ~96 %, a Fresnel-chosen event; GGX
/// `roughness`), double-sided, `MIRROR_H` above the quads, and returns its
/// instance and the view of the mirror tests: eyes 5 cm up, 0.5 m in front
/// of the quad's near edge, looking up at the mirror, so the paths' two legs
/// are about equally long (t₁ ≈ t₂) and a cone that did not grow, or
/// restarted at the mirror, is half as wide; 64×40 pixels, one sample, one
/// bounce.
fn under_a_mirror(
    scene: &mut Scene,
    roughness: f32,
) -> (u32, StereoCamera, glam::UVec2, RenderSettings) {
    let mut sheet = Material::diffuse("mirror", Vec3::ONE);
    sheet.transmission = 1.0;
    sheet.ior = 100.0;
    sheet.roughness = roughness;
    sheet.double_sided = true;
    let m_sheet = add_material(scene, sheet);
    add_mesh(
        scene,
        grid(
            "mirror",
            Vec3::new(-4.0, MIRROR_H, -4.0),
            Vec3::X * 8.0,
            Vec3::Z * 8.0,
            1,
            1,
            Vec2::ONE,
        ),
        m_sheet,
        Mat4::IDENTITY,
    );
    scene.validate().unwrap();
    let size = glam::UVec2::new(64, 40);
    let settings = RenderSettings {
        width: size.x,
        height: size.y,
        spp: 1,
        max_bounces: 1,
        seed: 11,
        all_features: false,
        ..Default::default()
    };
    let c = look_at(
        "under the mirror",
        Vec3::new(-0.55, 0.05, 1.0),
        Vec3::new(-0.55, MIRROR_H, -0.2),
        Vec3::Y,
        60.0,
    );
    let camera = StereoCamera::from_scene_camera(c.transform, c.yfov, 64.0 / 40.0);
    ((scene.instances.len() - 1) as u32, camera, size, settings)
}

/// The cone past the first hit (thesis eq. 2.10: w ← w + α·t, the spread α
/// carried over and grown by eq. 2.11's β_r of each surface), checked at a
/// mirror. A smooth thin dielectric sheet of ior 100 hangs 0.6 m above the
/// quads (reflecting ~96 % by a Fresnel-chosen delta event, refracting the
/// rest away into the black); the eyes, 5 cm above the floor in front of
/// the quads, look up at it, so every reflected path's second hit is a
/// quad, after two legs of about equal length. Material 0 emits exactly its
/// uv, (u, v, 0) × its emissive factor (0.5, 1, 0.25), memoized at
/// secondary hits only, with texels 8× the footprint (bias −3): a reflected
/// pixel's radiance is the texel centre q·2^-m (q integer per axis) the
/// cache keyed the hit to. The uvs are stretched 4:1 and the view is
/// oblique, so the footprint's shorter derivative is in play in the
/// reflected frame.
///
/// For each pixel whose rays (centre and corners) all reflect onto quad 0,
/// the CPU follows them through the mirror and builds the twin's level
/// from eq. 2.10 (w = spread·t₁ + spread·t₂: the eye's spread, plus β_r = 0
/// of the smooth sheet) and `lod::uv_per_width` in the reflected
/// direction, over the pixel's centre and corners (the sample is jittered
/// in the pixel; rounding boundaries within 10⁻³ admit both sides). Some
/// level in that range must explain the GPU's texel: a level-m centre whose
/// texel overlaps the uvs the pixel's rays reach. The finite-difference
/// part: the width eq. 2.10 gives is compared with the true width of the
/// pixel's cone at the second hit: two rays ± spread/2 either side of the
/// centre ray, each reflected at its own mirror hit, measured across the
/// reflected centre ray at the hit, within tan(a)/a − 1 ≈ a²/3 relative,
/// a = spread/2 (the small-angle error of 2a for the edge rays' true
/// 2 tan a), plus f64 rounding. Non-tiled and 4×4 tiles, software backend
/// and ray queries. A cone that did not grow past the mirror
/// (w = spread·t₁), or restarted there (w = spread·t₂), is half as wide, a
/// level finer; its texel would be refuted wherever the GPU's texel centre
/// lies over a quarter texel from the pixel's uvs on an axis (about two
/// pixels in three): measured 273 and 254 of 453.
#[test]
fn memo_levels_past_a_mirror_follow_the_grown_cone() {
    let ctx = context();
    let d = dir("memo-mirror");
    let (mut scene, quv) = uv_emitting_quads(&d, 0.0);
    const H: f32 = MIRROR_H;
    // Texels 8× the footprint (bias −3), so a pixel's uvs lie well inside
    // one and its texel tells the level apart from its neighbours'.
    const BIAS: f32 = -3.0;
    let (mirror_inst, camera, size, settings) = under_a_mirror(&mut scene, 0.0);
    for (rt, tile) in level_test_configs(&ctx) {
        scene.graphs.memo = level_test_memo(tile, BIAS);
        let s = session(&ctx, scene.clone(), rt);
        let f = render(&s, "reference", camera, &settings);
        let (mut checked, mut refracted, mut no_growth, mut restarted) = (0usize, 0usize, 0, 0);
        let mut worst_fd = 0.0f64;
        let mut levels_seen = std::collections::BTreeSet::new();
        for (e, eye) in f.eyes.iter().enumerate() {
            let view = camera.eyes()[e];
            let spread = 2.0 * view.tan_half_fov().y / size.y as f32;
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] != mirror_inst {
                    continue;
                }
                let px = pixel_centre(i, size);
                // A ray through the mirror: (t1, t2, reflected direction,
                // the quad's point) in f64 where it matters.
                let follow = |dir: glam::DVec3| {
                    let dir = dir.normalize();
                    let o = view.position.as_dvec3();
                    let t1 = (H as f64 - o.y) / dir.y;
                    let p1 = o + dir * t1;
                    let r = glam::DVec3::new(dir.x, -dir.y, dir.z);
                    let t2 = p1.y / dir.y;
                    (t1, t2, r, p1 + r * t2)
                };
                let corners = [
                    Vec2::new(-0.5, -0.5),
                    Vec2::new(0.5, -0.5),
                    Vec2::new(-0.5, 0.5),
                    Vec2::new(0.5, 0.5),
                ];
                let inside =
                    |p: glam::DVec3| p.x > -1.04 && p.x < -0.06 && p.z > -0.49 && p.z < 0.49;
                let at = |off: Vec2| follow(view.ray_direction(px + off, size).as_dvec3());
                if !corners.iter().chain([Vec2::ZERO].iter()).all(|&o| {
                    let (t1, _, _, p) = at(o);
                    t1 > 0.0 && inside(p)
                }) {
                    continue;
                }
                let rad = eye.radiance[i];
                if rad[0] == 0.0 && rad[1] == 0.0 {
                    refracted += 1;
                    continue;
                }
                // Eq. 2.10 at the centre, and the cone's true width there.
                let dc = view.ray_direction(px, size).as_dvec3().normalize();
                let (t1, t2, r, p2) = follow(dc);
                let w_eq = spread as f64 * (t1 + t2);
                let axis = dc.cross(glam::DVec3::Y).normalize();
                let half = 0.5 * spread as f64;
                for ax in [axis, dc.cross(axis).normalize()] {
                    let edge = |s: f64| {
                        let de = glam::DQuat::from_axis_angle(ax, s * half) * dc;
                        let (_, _, re, pe) = follow(de);
                        // Where the edge ray crosses the plane through p2
                        // normal to the reflected centre ray.
                        let k = (p2 - pe).dot(r) / re.dot(r);
                        pe + re * k
                    };
                    let w_fd = (edge(1.0) - edge(-1.0)).length();
                    let rel = (w_fd / w_eq - 1.0).abs();
                    worst_fd = worst_fd.max(rel);
                    assert!(
                        rel <= half.tan() / half - 1.0 + 1e-9,
                        "{rt:?} eye {e} pixel {i}: the cone's width at the second hit is {w_fd}, eq. 2.10 gives {w_eq}"
                    );
                }
                // The twin's level range over the pixel (centre, corners).
                let level_of = |w: f32, k: f32| level_range(w, k, BIAS);
                let (levels, uv_lo, uv_hi) = pixel_levels(
                    &quv,
                    corners.iter().chain([Vec2::ZERO].iter()).map(|&o| {
                        let (t1, t2, r, p) = at(o);
                        (spread * (t1 + t2) as f32, r.as_vec3(), p.as_vec3())
                    }),
                    BIAS,
                );
                let (lo, hi) = (*levels.start(), *levels.end());
                // The GPU's texel centre, read off the radiance
                // (texel_explains).
                let uc = texel_centre(rad)
                    .unwrap_or_else(|| panic!("{rt:?} eye {e} pixel {i}: {rad:?}"));
                let explains = |m: i32| texel_explains(uc, m, uv_lo, uv_hi);
                assert!(
                    (lo..=hi).any(explains),
                    "{rt:?} tile {tile}: eye {e} pixel {i}: texel centre {uc} is no texel of eq. 2.10's \
                     levels {lo}..={hi} over the pixel's uvs {uv_lo}..{uv_hi}"
                );
                levels_seen.extend((lo..=hi).filter(|&m| explains(m)));
                checked += 1;
                // Refuted alternatives, from the centre ray.
                let k = quv.uv_per_width(r.as_vec3());
                if !level_of(spread * t1 as f32, k).into_iter().any(explains) {
                    no_growth += 1;
                }
                if !level_of(spread * t2 as f32, k).into_iter().any(explains) {
                    restarted += 1;
                }
            }
        }
        eprintln!(
            "{rt:?} tile {tile}: {checked} reflected pixels (levels {levels_seen:?}), {refracted} refracted; \
             eq. 2.10 against the cone's true width: worst {worst_fd:.1e} relative; a cone that did not grow \
             is refuted at {no_growth}, one restarted at the mirror at {restarted}"
        );
        assert!(
            checked > 400 && refracted > 0,
            "{rt:?}: {checked} checked, {refracted} refracted"
        );
        assert!(levels_seen.len() >= 2, "{rt:?}: levels {levels_seen:?}");
        assert!(
            no_growth > checked / 3 && restarted > checked / 3,
            "{rt:?}: the alternatives are refuted at only {no_growth} and {restarted} of {checked}"
        );
        assert_table_hit_and_missed(&s, &format!("{rt:?}"));
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// Eq. 2.11 (β_r = 2·√(α²/(2 − 2α²)), α the GGX roughness) on the GPU: the
/// spread a rough reflection adds to the cone. The plane mirror of
/// `memo_levels_past_a_mirror_follow_the_grown_cone` becomes rough (glTF
/// roughness 0.5, α = 0.25, β_r = 0.365 rad against the eyes' 0.029 rad a
/// pixel), so each path leaves the sheet in a random direction of the GGX
/// lobe and hits quad 0 (alone in the scene, emitting (u, v, 1)) somewhere.
/// To know where, the same view is rendered twice with the same seed and
/// one sample a pixel: memoized (secondary hits, bias −3), where a pixel
/// shows the texel centre the cache keyed, and direct, where it shows the
/// exact uv of the hit (the paths' random numbers do not depend on the
/// cache; blue gives the rough reflection's weight, which both share). For
/// each pixel whose path reflected onto the quad, the CPU takes the hit
/// point p₂ from that uv, the mirror point p₁ from the pixel's rays (centre
/// and corners: the sample is jittered) and builds the level of eq. 2.10
/// with eq. 2.11, w = spread·t₁ + (spread + β_r)·t₂, footprint in the
/// direction p₂ − p₁; some level in that range must explain the memoized
/// texel (a level-m centre whose texel holds the hit's uv). What eq. 2.11's
/// spread means statistically (2σ of a Gaussian fit to the GGX lobe) is the
/// thesis's approximation and is not tested; that the cache grows the cone
/// by it is. Cones with other spreads are refuted wherever none of their
/// levels explains the texel: without β_r (a smooth mirror's cone), with
/// β_r/2 (σ for 2σ) and with 2β_r, measured 509, 219 and 150 of 543 pixels;
/// required a half, a fifth and a fifth. Both backends where ray queries
/// exist, non-tiled and 4×4 tiles.
#[test]
fn memo_levels_past_a_rough_mirror_follow_the_roughness_spread() {
    use stereocache::materials::memo::lod;
    let ctx = context();
    let d = dir("memo-rough-mirror");
    let (mut scene, quv) = quad_zero_alone(&d);
    const H: f32 = MIRROR_H;
    const BIAS: f32 = -3.0;
    const ROUGHNESS: f32 = 0.5;
    let alpha = ROUGHNESS * ROUGHNESS;
    let beta_r = 2.0 * (alpha * alpha / (2.0 - 2.0 * alpha * alpha)).sqrt();
    assert!((beta_r - lod::roughness_spread(alpha)).abs() <= 1e-6 * beta_r);
    let (mirror_inst, camera, size, settings) = under_a_mirror(&mut scene, ROUGHNESS);
    // BSDF sampling alone: since session 43 the rough sheet also samples
    // the quad by next-event estimation, whose light sample would add a
    // second memoized texel to the pixel (light samples go through the
    // table too: `light_sampled_emission_goes_through_the_table`); here one
    // path, one texel.
    let settings = RenderSettings {
        light_sampling: stereocache::methods::LightSampling::Bsdf,
        ..settings
    };
    for (rt, tile) in level_test_configs(&ctx) {
        let (direct, s, f) = direct_and_memoized(&ctx, &scene, rt, tile, BIAS, camera, &settings);
        let (mut checked, mut no_roughness, mut halved, mut doubled) =
            (0usize, 0usize, 0usize, 0usize);
        let mut levels_seen = std::collections::BTreeSet::new();
        for (e, eye) in f.eyes.iter().enumerate() {
            let view = camera.eyes()[e];
            let spread = 2.0 * view.tan_half_fov().y / size.y as f32;
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] != mirror_inst {
                    continue;
                }
                // The memoized texel and the exact hit, when the path
                // reflected onto quad 0: (u, v, 1) × the factor × the
                // rough reflection's weight (the same in both renders),
                // which blue gives (`weighted_uv`). Else
                // black (refracted away, or reflected past the quad).
                let (Some(uc), Some(uv)) = (
                    weighted_uv(eye.radiance[i]),
                    weighted_uv(direct.eyes[e].radiance[i]),
                ) else {
                    continue;
                };
                let p2 = quv.point_at(uv);
                let px = pixel_centre(i, size);
                // Levels over the pixel's rays for a spread gain `gain` at
                // the sheet.
                let levels = |gain: f32| {
                    let rays = PIXEL_RAYS.map(|off| {
                        let dir = view.ray_direction(px + off, size).normalize();
                        let t1 = (H - view.position.y) / dir.y;
                        let p1 = view.position + dir * t1;
                        let t2 = (p2 - p1).length();
                        (spread * t1 + (spread + gain) * t2, (p2 - p1) / t2, p2)
                    });
                    pixel_levels(&quv, rays, BIAS).0
                };
                let explains = |m: i32| texel_explains(uc, m, uv, uv);
                let with_beta = levels(beta_r);
                assert!(
                    with_beta.clone().any(explains),
                    "{rt:?} tile {tile}: eye {e} pixel {i}: texel centre {uc} (hit at uv {uv}) is no texel \
                     of eqs. 2.10–2.11's levels {with_beta:?}"
                );
                levels_seen.extend(with_beta.filter(|&m| explains(m)));
                checked += 1;
                if !levels(0.0).any(explains) {
                    no_roughness += 1;
                }
                if !levels(0.5 * beta_r).any(explains) {
                    halved += 1;
                }
                if !levels(2.0 * beta_r).any(explains) {
                    doubled += 1;
                }
            }
        }
        eprintln!(
            "{rt:?} tile {tile}: {checked} pixels reflected onto quad 0 (levels {levels_seen:?}); \
             a cone without β_r is refuted at {no_roughness}, one with β_r/2 at {halved}, 2β_r at {doubled}"
        );
        assert!(checked > 200, "{rt:?} tile {tile}: {checked} pixels");
        assert!(levels_seen.len() >= 2, "{rt:?}: levels {levels_seen:?}");
        assert!(
            no_roughness > checked / 2 && halved > checked / 5 && doubled > checked / 5,
            "{rt:?} tile {tile}: the alternatives are refuted at only {no_roughness}, {halved} and {doubled} of {checked}"
        );
        assert_table_hit_and_missed(&s, &format!("{rt:?}"));
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// Radius, bias and tessellation of the spherical mirror of the curved-mirror
/// tests ([`SphereMirror`]).
const SPHERE_R: f32 = 2.0;
const SPHERE_SEGMENTS: usize = 256;
const SPHERE_RINGS: usize = 128;

/// A sphere of radius `SPHERE_R` (a 256 × 128 UV sphere with smooth normals,
/// poles turned to ±z so rays near its equator meet near-square facets) of
/// the ior-100 sheet material with GGX `roughness`, double-sided, added to a
/// scene, and its facets in world space (f32 as uploaded), bucketed by the
/// (ring, segment) cell of their centroid, so the CPU can follow a ray to
/// the facet the GPU hits.
struct SphereMirror {
    centre: Vec3,
    instance: u32,
    mesh: usize,
    tris: Vec<([Vec3; 3], [Vec3; 3])>,
    to_object: glam::DMat4,
    buckets: Vec<Vec<usize>>,
}

/// Where a ray meets a [`SphereMirror`], as the shader sees it.
struct SphereHit {
    /// Distance along the (unit) ray.
    t: f64,
    /// The ray mirrored about the interpolated shading normal.
    reflected: glam::DVec3,
    /// The hit facet's k (`lod::triangle_curvature`) towards the shading
    /// normal, as `surface_at` signs it.
    k: f32,
    /// |n_g·d| of the facet's plane.
    cos: f64,
    /// The f32 rounding bound of k: 32·2^-23·(1 + |p| / R) / (shortest edge
    /// / R), as in tests/memo.rs.
    tol_k: f64,
}

impl SphereMirror {
    fn add(scene: &mut Scene, centre: Vec3, roughness: f32) -> Self {
        let mut sheet = Material::diffuse("mirror", Vec3::ONE);
        sheet.transmission = 1.0;
        sheet.ior = 100.0;
        sheet.roughness = roughness;
        sheet.double_sided = true;
        let m_sheet = add_material(scene, sheet);
        add_mesh(
            scene,
            stereocache::scene::generate::uv_sphere(
                "mirror",
                SPHERE_SEGMENTS as u32,
                SPHERE_RINGS as u32,
            ),
            m_sheet,
            Mat4::from_translation(centre)
                * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2)
                * Mat4::from_scale(Vec3::splat(SPHERE_R)),
        );
        scene.validate().unwrap();
        let instance = (scene.instances.len() - 1) as u32;
        let inst = &scene.instances[instance as usize];
        let mesh = inst.mesh as usize;
        let m = &scene.meshes[mesh];
        let tris: Vec<([Vec3; 3], [Vec3; 3])> = (0..m.indices.len() / 3)
            .map(|t| {
                let idx = [0, 1, 2].map(|k| m.indices[3 * t + k] as usize);
                (
                    idx.map(|k| inst.transform.transform_point3(m.positions[k])),
                    idx.map(|k| inst.transform.transform_vector3(m.normals[k]).normalize()),
                )
            })
            .collect();
        let mut s = SphereMirror {
            centre,
            instance,
            mesh,
            tris,
            to_object: inst.transform.as_dmat4().inverse(),
            buckets: vec![Vec::new(); SPHERE_RINGS * SPHERE_SEGMENTS],
        };
        for t in 0..s.tris.len() {
            let p = s.tris[t].0;
            let (r, c) = s.cell((p[0] + p[1] + p[2]).as_dvec3() / 3.0);
            s.buckets[r * SPHERE_SEGMENTS + c].push(t);
        }
        s
    }

    /// The (ring, segment) cell of a point near the sphere.
    fn cell(&self, p: glam::DVec3) -> (usize, usize) {
        use std::f64::consts::{PI, TAU};
        let o = self.to_object.transform_point3(p).normalize();
        let theta = o.y.clamp(-1.0, 1.0).acos();
        let phi = o.x.atan2(o.z).rem_euclid(TAU);
        (
            ((theta / PI * SPHERE_RINGS as f64) as usize).min(SPHERE_RINGS - 1),
            ((phi / TAU * SPHERE_SEGMENTS as f64) as usize).min(SPHERE_SEGMENTS - 1),
        )
    }

    /// A ray's hit on the mesh, as the shader computes it: the nearest facet
    /// ahead (f64 Möller–Trumbore among the facets around the exact
    /// sphere's hit, both sides), its interpolated and normalised normal
    /// turned to the ray's side, k signed with it. `sign` −1: the mesh's
    /// normals turned inwards.
    fn hit(&self, o: glam::DVec3, dir: glam::DVec3, sign: f32) -> Option<SphereHit> {
        use stereocache::materials::memo::lod;
        let r2 = (SPHERE_R * SPHERE_R) as f64;
        let oc = o - self.centre.as_dvec3();
        let bq = oc.dot(dir);
        let disc = bq * bq - (oc.length_squared() - r2);
        if disc <= 0.0 {
            return None;
        }
        // From outside the near root, from inside the far one.
        let inside = oc.length_squared() < r2;
        let root = -bq + if inside { disc.sqrt() } else { -disc.sqrt() };
        let (r0, s0) = self.cell(o + dir * root);
        let mut best: Option<(f64, usize, f64, f64)> = None;
        for r in r0.saturating_sub(1)..=(r0 + 1).min(SPHERE_RINGS - 1) {
            for ds in [SPHERE_SEGMENTS - 1, 0, 1] {
                for &t in &self.buckets[r * SPHERE_SEGMENTS + (s0 + ds) % SPHERE_SEGMENTS] {
                    let p = self.tris[t].0.map(|v| v.as_dvec3());
                    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
                    let pv = dir.cross(e2);
                    let det = e1.dot(pv);
                    if det.abs() < 1e-18 {
                        continue;
                    }
                    let tv = o - p[0];
                    let u = tv.dot(pv) / det;
                    let qv = tv.cross(e1);
                    let v = dir.dot(qv) / det;
                    let th = e2.dot(qv) / det;
                    if u >= 0.0
                        && v >= 0.0
                        && u + v <= 1.0
                        && th > 0.0
                        && best.is_none_or(|b| th < b.0)
                    {
                        best = Some((th, t, u, v));
                    }
                }
            }
        }
        let (t, tri, u, v) = best?;
        let (p, nv) = self.tris[tri];
        let nv = nv.map(|n| n * sign);
        let ng = (p[1] - p[0]).cross(p[2] - p[0]).as_dvec3().normalize();
        let ng = if ng.dot(dir) > 0.0 { -ng } else { ng };
        let n = (nv[0].as_dvec3() * (1.0 - u - v) + nv[1].as_dvec3() * u + nv[2].as_dvec3() * v)
            .normalize();
        let flipped = n.dot(ng) < 0.0;
        let n = if flipped { -n } else { n };
        let k = lod::triangle_curvature(p, nv) * if flipped { -1.0 } else { 1.0 };
        let edge = (0..3)
            .map(|j| (p[(j + 1) % 3] - p[j]).length())
            .fold(f32::MAX, f32::min) as f64;
        let far = p.iter().map(|v| v.length()).fold(0.0, f32::max) as f64;
        let tol_k =
            32.0 * f32::EPSILON as f64 * (1.0 + far / SPHERE_R as f64) * SPHERE_R as f64 / edge;
        Some(SphereHit {
            t,
            reflected: dir - n * (2.0 * dir.dot(n)),
            k,
            cos: ng.dot(dir).abs(),
            tol_k,
        })
    }
}

/// Eq. 2.12 (β_c = −2 k w / (n·d)) on the GPU: the cone a curved mirror
/// reflects. The plane mirror of `memo_levels_past_a_mirror_follow_the_grown_cone`
/// becomes a sphere of radius R = 2 m (a 256 × 128 UV sphere with smooth
/// normals, poles turned to ±z so the rays meet near-square facets, the
/// same smooth ior-100 sheet material) over the uv-emitting quad 0,
/// memoized at secondary hits only, bias −2, 96 × 60 pixels:
/// * convex: the sphere's lowest point hangs 0.6 m above the quads and the
///   eyes look up at it from outside; k = +1/R, and eq. 2.12 makes the
///   reflected cone 2–3× wider than the eye's spread alone would (a level
///   or two coarser at the quad);
/// * concave: eyes and quads inside the sphere, looking up at its inner
///   wall; k = −1/R towards the normal facing the ray, the cone focuses
///   (focal length R/2) and every checked pixel's cone is past its focus
///   at the quad, with a negative width whose magnitude sets the level.
///
/// On the sphere's facets |k| is 1/R (the twin, `lod::triangle_curvature`,
/// on the hit triangle: its vertices lie on the sphere with radial
/// normals). For each pixel whose rays (centre and corners) all reflect
/// onto quad 0, the CPU follows them through the mesh as the shader does —
/// the triangle hit (f64, among the facets around the sphere's hit), its
/// interpolated and normalised normal turned to the ray's side, the
/// reflection about it — and builds the twin's level from
/// w = spread·t₁ + (spread + β_c)·t₂ with β_c =
/// `lod::curvature_spread(k, spread·t₁, n_g·d)` (k of the hit facet signed
/// as `surface_at` signs it, n_g its plane's normal), over the pixel's
/// centre and corners; some level in that range must explain the GPU's
/// texel (`texel_explains`). That eq. 2.12 is the true spread of rays
/// reflected at a sphere (in the plane of incidence, convex and concave)
/// is checked apart, by finite differences in tests/memo.rs
/// (`curvature_spread_matches_reflection_at_a_sphere`). The cone without
/// the curvature term (w = spread·(t₁ + t₂), the plane mirror's) is refuted
/// wherever the GPU's texel centre lies over half a texel of that level
/// from the pixel's uvs (measured: 278 of 805 convex and 1,084 of 1,239
/// concave pixels; required: a quarter). Shaders without the term, without
/// the flip of k, or without the width's magnitude at the lookup each fail
/// the main check at once (tried: with the term left out, eye 0's pixel
/// 326 shows the level-3 centre [0.375, 1] where eq. 2.12 gives level 2).
/// Both backends where ray queries exist, non-tiled and 4×4 tiles, and with
/// the file's normals turned inwards.
#[test]
fn memo_levels_past_a_curved_mirror_follow_the_curvature_spread() {
    use glam::DVec3;
    use stereocache::materials::memo::lod;
    let ctx = context();
    let d = dir("memo-curved-mirror");
    let (base, quv) = uv_emitting_quads(&d, 0.0);
    const R: f32 = SPHERE_R;
    const BIAS: f32 = -2.0;
    // (name, the sphere's centre, the eyes' midpoint, where they look).
    let geometries = [
        // Convex: the sphere's lowest point 0.6 above the quads.
        (
            "convex",
            Vec3::new(-0.55, 0.6 + R, -0.2),
            Vec3::new(-0.55, 0.05, 1.0),
            Vec3::new(-0.55, 0.6, -0.2),
        ),
        // Concave: eyes and quads inside the sphere, looking up at its
        // inner wall; the cone focuses (k = −1/R, focal length R/2) and
        // is past its focus at the quads, its width negative there.
        (
            "concave",
            Vec3::new(-0.55, 0.5, 0.0),
            Vec3::new(-0.55, 0.2, 1.0),
            Vec3::new(-0.55, 2.4, -0.3),
        ),
    ];
    for (geometry, centre, eye, look) in geometries {
        let mut scene = base.clone();
        let mirror = SphereMirror::add(&mut scene, centre, 0.0);
        let (mirror_inst, mesh_index) = (mirror.instance, mirror.mesh);
        // A ray's reflection at the mesh, as the shader computes it: (t₁,
        // reflected direction, hit facet's k towards the shading normal,
        // |n_g·d|, the f32 rounding bound of k).
        let reflect_at_mesh = |o: DVec3, dir: DVec3, sign: f32| {
            mirror
                .hit(o, dir, sign)
                .map(|h| (h.t, h.reflected, h.k, h.cos, h.tol_k))
        };
        let size = glam::UVec2::new(96, 60);
        let settings = RenderSettings {
            width: size.x,
            height: size.y,
            spp: 1,
            max_bounces: 1,
            seed: 11,
            all_features: false,
            ..Default::default()
        };
        let c = look_at(geometry, eye, look, Vec3::Y, 60.0);
        let camera = StereoCamera::from_scene_camera(c.transform, c.yfov, 96.0 / 60.0);
        let on_quad = |p: DVec3| p.x > -1.04 && p.x < -0.06 && p.z > -0.49 && p.z < 0.49;
        // k towards the shading normal, which faces the ray: +1/R seen from
        // outside, −1/R from inside (whichever way the file's normals point).
        let k_want = if geometry == "convex" { 1.0 } else { -1.0 };
        // Also with the sphere's normals turned inwards (as a file may have
        // them): the shading normal is flipped to the ray's side and k with it
        // (`surface_at`), so the same convex k and the same levels.
        let configs = level_test_configs(&ctx)
            .into_iter()
            .map(|(rt, tile)| (rt, tile, 1.0f32))
            .chain([(RtChoice::Software, 1, -1.0)]);
        for (rt, tile, sign) in configs {
            let mut scene = scene.clone();
            for n in &mut scene.meshes[mesh_index].normals {
                *n *= sign;
            }
            scene.graphs.memo = level_test_memo(tile, BIAS);
            let s = session(&ctx, scene, rt);
            let f = render(&s, "reference", camera, &settings);
            let (mut checked, mut refracted, mut refuted, mut focused) =
                (0usize, 0usize, 0usize, 0usize);
            let mut levels_seen = std::collections::BTreeSet::new();
            let mut worst_k = 0.0f64;
            for (e, eye) in f.eyes.iter().enumerate() {
                let view = camera.eyes()[e];
                let spread = 2.0 * view.tan_half_fov().y / size.y as f32;
                for (i, fh) in eye.first_hit.iter().enumerate() {
                    if fh[3] != mirror_inst {
                        continue;
                    }
                    let px = pixel_centre(i, size);
                    // Centre and corners: (t₁, t₂, reflected direction, the
                    // quad's point, k, |n_g·d|).
                    let follow = |off: Vec2| {
                        let dir = view.ray_direction(px + off, size).as_dvec3().normalize();
                        let o = view.position.as_dvec3();
                        let (t1, r, k, cos, tol_k) = reflect_at_mesh(o, dir, sign)?;
                        let p1 = o + dir * t1;
                        if r.y >= 0.0 {
                            return None;
                        }
                        let t2 = -p1.y / r.y;
                        Some((t1, t2, r, p1 + r * t2, k, cos, tol_k))
                    };
                    let rays: Vec<_> = PIXEL_RAYS.iter().map(|&o| follow(o)).collect();
                    if !rays.iter().all(|r| r.is_some_and(|r| on_quad(r.3))) {
                        continue;
                    }
                    let rad = eye.radiance[i];
                    if rad[0] == 0.0 && rad[1] == 0.0 {
                        refracted += 1;
                        continue;
                    }
                    let (levels, uv_lo, uv_hi) = pixel_levels(
                        &quv,
                        rays.iter().flatten().map(|&(t1, t2, r, p, k, cos, tol_k)| {
                            // The hit facet's k is ±1/R (its vertices lie on
                            // the sphere with radial normals) to f32 rounding.
                            let err = (k as f64 * R as f64 - k_want).abs();
                            assert!(
                                err <= tol_k,
                                "{geometry} {rt:?}: a facet's k·R is {}",
                                k * R
                            );
                            worst_k = worst_k.max(err);
                            let w1 = spread * t1 as f32;
                            let w = w1
                                + (spread + lod::curvature_spread(k, w1, cos as f32)) * t2 as f32;
                            (w, r.as_vec3(), p.as_vec3())
                        }),
                        BIAS,
                    );
                    let (lo, hi) = (*levels.start(), *levels.end());
                    let uc = texel_centre(rad)
                        .unwrap_or_else(|| panic!("{geometry} {rt:?} eye {e} pixel {i}: {rad:?}"));
                    let explains = |m: i32| texel_explains(uc, m, uv_lo, uv_hi);
                    assert!(
                    (lo..=hi).any(explains),
                    "{geometry} {rt:?} tile {tile} normals {sign}: eye {e} pixel {i}: texel centre {uc} is no texel of eq. 2.12's \
                     levels {lo}..={hi} over the pixel's uvs {uv_lo}..{uv_hi}"
                );
                    levels_seen.extend((lo..=hi).filter(|&m| explains(m)));
                    checked += 1;
                    // The plane mirror's cone, from the centre ray.
                    let (t1, t2, r, _, k, cos, _) = rays[0].unwrap();
                    let w1 = spread * t1 as f32;
                    if w1 + (spread + lod::curvature_spread(k, w1, cos as f32)) * (t2 as f32) < 0.0
                    {
                        focused += 1;
                    }
                    if !level_range(
                        spread * (t1 + t2) as f32,
                        quv.uv_per_width(r.as_vec3()),
                        BIAS,
                    )
                    .into_iter()
                    .any(explains)
                    {
                        refuted += 1;
                    }
                }
            }
            eprintln!(
            "{geometry} {rt:?} tile {tile} normals {sign}: {checked} reflected pixels (levels {levels_seen:?}), {refracted} refracted; \
             {focused} past the focus (negative width); facet |k·R| − 1 at most {worst_k:.1e}; \
             the cone without eq. 2.12 is refuted at {refuted}"
        );
            assert!(
                checked > 500 && refracted > 0 && (geometry == "convex" || focused > checked / 2),
                "{geometry} {rt:?}: {checked} checked, {refracted} refracted, {focused} past the focus"
            );
            assert!(
            refuted > checked / 4,
            "{geometry} {rt:?}: the cone without the curvature term is refuted at only {refuted} of {checked}"
        );
            assert_table_hit_and_missed(&s, &format!("{geometry} {rt:?}"));
        }
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// The uv a pixel of `uv_emitting_quads(_, 1.0)`'s quad 0 shows, when its
/// path reached the quad: (u, v, 1) × the emissive factor × the path's
/// weight, which blue gives; None for black (the path went elsewhere).
fn weighted_uv(rad: [f32; 4]) -> Option<Vec2> {
    let w = rad[2] / KHR_EMISSIVE_FACTOR[2];
    (w > 0.0).then(|| {
        Vec2::new(
            rad[0] / (KHR_EMISSIVE_FACTOR[0] * w),
            rad[1] / (KHR_EMISSIVE_FACTOR[1] * w),
        )
    })
}

/// Eqs. 2.11 and 2.12 at one surface: the cone past a *rough concave*
/// mirror keeps its roughness blur (shaders/memo/lod.glsl
/// `memo_cone_at`, twin `lod::cone_at`). The thesis sums the spreads
/// (α + β_r + β_c), so a concave surface's negative β_c would cancel the
/// blur β_r adds and focus the whole cone; ours keeps the geometric pencil
/// (the eye's spread turned by β_c) apart from the blur, and the width at
/// the next hit is |w₁ + (α + β_c)·t₂| + β_r·t₂. The concave view of
/// `memo_levels_past_a_curved_mirror_follow_the_curvature_spread` (eyes
/// and quad 0 inside the sphere of radius 2 m, k = −1/R) with the sphere
/// made slightly rough (roughness 0.1, α_GGX = 0.01, β_r = 0.0141 rad, of
/// the order of the eyes' 0.019 rad a pixel and of β_c), quad 0 alone and
/// emitting (u, v, 1), memoized at secondary hits only (bias −2), BSDF
/// sampling alone, rendered memoized and direct with the same seed as in
/// `memo_levels_past_a_rough_mirror_follow_the_roughness_spread` (the
/// direct render gives each path's exact hit on the quad, the memoized one
/// the texel the cache keyed). For every pixel whose path reflected onto the
/// quad, the CPU follows the pixel's centre and corner rays to the sphere's
/// facets (t₁, k of the hit facet, |n_g·d|) and takes the second leg to the
/// exact hit; the levels of the two-part cone over those rays must explain
/// the texel at every pixel. The summed cone, |w₁ + (α + β_r + β_c)·t₂|,
/// which focuses at this mirror (width through 0 before the quad at most
/// pixels), is refuted wherever none of its levels explains the texel
/// (required: a quarter of the pixels; measured in the eprintln), and so is
/// the cone without the curvature term (w₁ + (α + β_r)·t₂; required: a
/// tenth): the two-part cone still carries eq. 2.12. Both backends where
/// ray queries exist, non-tiled and 4×4 tiles.
#[test]
fn memo_levels_past_a_rough_concave_mirror_keep_the_roughness_blur() {
    use stereocache::materials::memo::lod;
    let ctx = context();
    let d = dir("memo-rough-concave");
    let (mut scene, quv) = quad_zero_alone(&d);
    const BIAS: f32 = -2.0;
    const ROUGHNESS: f32 = 0.1;
    let beta_r = lod::roughness_spread(ROUGHNESS * ROUGHNESS);
    let mirror = SphereMirror::add(&mut scene, Vec3::new(-0.55, 0.5, 0.0), ROUGHNESS);
    let size = glam::UVec2::new(96, 60);
    let settings = RenderSettings {
        width: size.x,
        height: size.y,
        spp: 1,
        max_bounces: 1,
        seed: 11,
        all_features: false,
        light_sampling: stereocache::methods::LightSampling::Bsdf,
        ..Default::default()
    };
    let c = look_at(
        "rough concave",
        Vec3::new(-0.55, 0.2, 1.0),
        Vec3::new(-0.55, 2.4, -0.3),
        Vec3::Y,
        60.0,
    );
    let camera = StereoCamera::from_scene_camera(c.transform, c.yfov, 96.0 / 60.0);
    for (rt, tile) in level_test_configs(&ctx) {
        let (direct, s, f) = direct_and_memoized(&ctx, &scene, rt, tile, BIAS, camera, &settings);
        let (mut checked, mut focused, mut summed_refuted, mut flat_refuted) =
            (0usize, 0usize, 0usize, 0usize);
        let mut levels_seen = std::collections::BTreeSet::new();
        for (e, eye) in f.eyes.iter().enumerate() {
            let view = camera.eyes()[e];
            let spread = 2.0 * view.tan_half_fov().y / size.y as f32;
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] != mirror.instance {
                    continue;
                }
                let (Some(uc), Some(uv)) = (
                    weighted_uv(eye.radiance[i]),
                    weighted_uv(direct.eyes[e].radiance[i]),
                ) else {
                    continue;
                };
                let p2 = quv.point_at(uv).as_dvec3();
                let px = pixel_centre(i, size);
                // Per ray of the pixel: (w₁, α + β_c, t₂, second leg's
                // direction).
                let legs: Vec<_> = PIXEL_RAYS
                    .iter()
                    .map(|&off| {
                        let dir = view.ray_direction(px + off, size).as_dvec3().normalize();
                        let o = view.position.as_dvec3();
                        let h = mirror
                            .hit(o, dir, 1.0)
                            .expect("rays from inside meet the sphere");
                        assert!(
                            (h.k as f64 * SPHERE_R as f64 + 1.0).abs() <= h.tol_k,
                            "{rt:?}: a facet's k·R is {}",
                            h.k * SPHERE_R
                        );
                        let second = p2 - (o + dir * h.t);
                        let t2 = second.length();
                        let w1 = spread * h.t as f32;
                        let pencil = spread + lod::curvature_spread(h.k, w1, h.cos as f32);
                        (w1, pencil, t2 as f32, (second / t2).as_vec3())
                    })
                    .collect();
                let levels = |width: &dyn Fn(f32, f32, f32) -> f32| {
                    pixel_levels(
                        &quv,
                        legs.iter()
                            .map(|&(w1, pencil, t2, r)| (width(w1, pencil, t2), r, p2.as_vec3())),
                        BIAS,
                    )
                    .0
                };
                let explains = |m: i32| texel_explains(uc, m, uv, uv);
                let two_part = levels(&|w1, pencil, t2| lod::cone_at(w1, pencil, 0.0, beta_r, t2));
                assert!(
                    two_part.clone().any(explains),
                    "{rt:?} tile {tile}: eye {e} pixel {i}: texel centre {uc} (hit at uv {uv}) is no texel \
                     of the two-part cone's levels {two_part:?}"
                );
                levels_seen.extend(two_part.filter(|&m| explains(m)));
                checked += 1;
                let (w1, pencil, t2, _) = legs[0];
                if w1 + (pencil + beta_r) * t2 < 0.0 {
                    focused += 1;
                }
                if !levels(&|w1, pencil, t2| w1 + (pencil + beta_r) * t2).any(explains) {
                    summed_refuted += 1;
                }
                if !levels(&|w1, _, t2| w1 + (spread + beta_r) * t2).any(explains) {
                    flat_refuted += 1;
                }
            }
        }
        eprintln!(
            "{rt:?} tile {tile}: {checked} pixels reflected onto quad 0 (levels {levels_seen:?}); \
             the summed cone focuses at {focused} and is refuted at {summed_refuted}, \
             the cone without eq. 2.12 at {flat_refuted}"
        );
        assert!(
            checked > 200 && focused > checked / 2,
            "{rt:?} tile {tile}: {checked} pixels, {focused} focused"
        );
        assert!(
            summed_refuted > checked / 4 && flat_refuted > checked / 10,
            "{rt:?} tile {tile}: the alternatives are refuted at only {summed_refuted} and {flat_refuted} of {checked}"
        );
        assert_table_hit_and_missed(&s, &format!("{rt:?}"));
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// Memoized against direct rendering, same seed, where the answer is known
/// (issue 17, the snapping bound of docs/MATERIALS.md): material 0 emits its
/// uv-only base-colour function (|fg − bg| ≤ 0.8, mix weight
/// ¼ sin 6u + ¼ sin 4v + ½, so |Δ| ≤ 0.8 (1.5 δu + δv) per channel) on a
/// black background with no bounce, so a pixel is the mean over its samples
/// of the emission at each sample's hit (direct) or of the cached texels
/// (memoized, `--memo both`). Nearest with texel-centre snapping moves each
/// sample's uv by at most half a texel per axis: per pixel the two differ by
/// at most 0.8 · 2.5 · 2^-(m+1) = 2^-m times the emissive factor, m the
/// coarsest level over the quad (from its nearest and farthest points,
/// lod.rs), plus float rounding. Bilinear interpolation of texel centres
/// 2^-m apart errs by at most (h²/8)(max |f_uu| + max |f_vv|) with
/// h = 2^-m (tensor-product linear interpolation); f_uu = 0.8 · ¼ · 36,
/// f_vv = 0.8 · ¼ · 16 at most, so 1.3 · 4^-m times the factor. The bound
/// holds for each variant — nearest + snap, 4×4 tiles, bilinear, 4×4
/// bilinear tiles — and gives the relative squared error's bound
/// 1/(3N) Σ bound² / (r_c² + ε) over the quad's pixels and channels (RSE's
/// own formula with the bound in place of the difference; every other
/// pixel is identical), asserted too. With
/// `--memo secondary` and no bounce nothing is looked up: the image equals
/// the direct one bit for bit.
#[test]
fn memoized_images_stay_within_the_snapping_bound_of_direct_ones() {
    use stereocache::materials::memo::lod;
    use stereocache::materials::memo::{MemoHits, MemoSettings};
    use stereocache::metrics::error::{rse, RSE_EPSILON};
    use stereocache::metrics::image::LinearImage;
    let ctx = context();
    let d = dir("memo-image");
    let path = write_quads(&d);
    bind(&path, |j| {
        // Emission := the uv-only base-colour node (5).
        j["extensions"]["KHR_texture_procedurals"]["procedurals"][0]["outputs"][1]["node"] =
            5.into();
    });
    let scene = stereocache::scene::load_gltf(&path).expect("bound scene loads");
    assert!(scene.graphs.graphs[0].reads_only_uv());
    let settings = RenderSettings {
        max_bounces: 0,
        spp: 4,
        ..probe_settings()
    };
    let camera = top_camera();
    // The quad of material 0 spans x ∈ [−1.05, −0.05], z ∈ [−0.5, 0.5] at
    // y = 0; the eyes sit 2.2 m above the origin, ± half the IPD in x.
    let view = camera.eyes()[0];
    let spread = 2.0 * view.tan_half_fov().y / 24.0;
    let far = Vec3::new(-1.05, 0.0, 0.5).distance(view.position) + camera.ipd;
    let m = lod::level(far * spread, 1.0, 0.0);
    let near = lod::level(2.2 * spread, 1.0, 0.0);
    assert!(m <= near, "{m} {near}");
    let factor = KHR_EMISSIVE_FACTOR.iter().copied().fold(0.0f32, f32::max);
    for rt in [RtChoice::Software, RtChoice::Query] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let image_of = |memo: MemoSettings, method: &str| {
            let mut s = scene.clone();
            s.graphs.memo = memo;
            let session = session(&ctx, s, rt);
            let f = render(&session, method, camera, &settings);
            let lookups = session.scene_gpu.memo.as_ref().map_or(0, |t| {
                let c = t.counters().unwrap();
                c.hits + c.misses
            });
            (f, lookups)
        };
        let image = |memo: MemoSettings| image_of(memo, "reference");
        let hits = |hits: MemoHits| MemoSettings {
            hits,
            ..Default::default()
        };
        let (direct, _) = image(hits(MemoHits::Off));
        let (secondary, none) = image(hits(MemoHits::Secondary));
        assert_eq!(none, 0, "{rt:?}: secondary-only looked up a first hit");
        for e in 0..2 {
            assert_eq!(
                direct.eyes[e].radiance, secondary.eyes[e].radiance,
                "{rt:?}: secondary-only with no bounce"
            );
        }
        for (name, tile, bilinear) in [
            ("nearest + snap", 1, false),
            ("4×4 tiles", 4, false),
            ("bilinear", 1, true),
            ("4×4 bilinear tiles", 4, true),
        ] {
            let (memo, lookups) = image(MemoSettings {
                tile,
                bilinear,
                entries: (1 << 20) / (tile * tile),
                ..hits(MemoHits::Both)
            });
            assert!(lookups > 0, "{rt:?} {name}: nothing was looked up");
            let bound = if bilinear {
                factor * 1.3 * 4f32.powi(-m)
            } else {
                factor * 2f32.powi(-m)
            } + TOL;
            let mut worst = 0.0f32;
            let mut checked = 0;
            for e in 0..2 {
                let (a, b) = (&direct.eyes[e], &memo.eyes[e]);
                let mut bound_sq = 0.0f64;
                for i in 0..a.radiance.len() {
                    // Pixels of material 1 (not memoizable) or the
                    // background: identical; material 0's: within the bound.
                    let diff = (Vec3::from_slice(&a.radiance[i][..3])
                        - Vec3::from_slice(&b.radiance[i][..3]))
                    .abs()
                    .max_element();
                    assert!(
                        diff <= bound,
                        "{rt:?} {name}: eye {e} pixel {i}: |memo − direct| = {diff} > {bound}"
                    );
                    if a.first_hit[i][3] != u32::MAX && hit_geom(&scene, a.first_hit[i]).0 == 0 {
                        worst = worst.max(diff);
                        checked += 1;
                        for c in 0..3 {
                            let r = a.radiance[i][c] as f64;
                            bound_sq += (bound as f64).powi(2) / (r * r + RSE_EPSILON as f64);
                        }
                    }
                }
                let (w, h) = (settings.width as usize, settings.height as usize);
                let err = rse(
                    &LinearImage::from_rgba(&b.radiance, w, h).unwrap(),
                    &LinearImage::from_rgba(&a.radiance, w, h).unwrap(),
                    RSE_EPSILON,
                )
                .unwrap() as f64;
                let rse_bound = bound_sq / (3 * a.radiance.len()) as f64;
                eprintln!("{rt:?} {name}: eye {e}: RSE {err:.3e}, bound {rse_bound:.3e}");
                assert!(
                    err > 0.0 && err <= rse_bound,
                    "{rt:?} {name}: eye {e}: RSE {err} against direct, bound {rse_bound}"
                );
            }
            assert!(
                checked > 150,
                "{rt:?} {name}: {checked} pixels of the memoized quad"
            );
            // Not vacuous: snapping shows, at a sizeable share of the bound.
            eprintln!("{rt:?} {name}: worst {worst}, bound {bound} (level {m}), {checked} pixels");
            assert!(
                worst > 0.1 * bound,
                "{rt:?} {name}: worst {worst} of bound {bound}"
            );
        }
        // Every other method, one frame, nearest + snap (software backend;
        // the backends' hits agree above): each forms its pixels from
        // emission at its own samples' hits (kept, reprojected, blended,
        // averaged: convex combinations of per-sample values), at the same
        // sample points with and without the cache (same seed; no bounce,
        // so nothing random reads the material), so the per-pixel bound
        // holds for each.
        if rt != RtChoice::Software {
            continue;
        }
        let bound = factor * 2f32.powi(-m) + TOL;
        for &kind in MethodKind::ALL {
            if matches!(kind, MethodKind::Reference | MethodKind::DebugNormals) {
                continue;
            }
            let (direct, _) = image_of(hits(MemoHits::Off), kind.name());
            let (memo, lookups) = image_of(hits(MemoHits::Both), kind.name());
            assert!(lookups > 0, "{}: nothing was looked up", kind.name());
            let (mut worst, mut moved) = (0.0f32, 0usize);
            for e in 0..2 {
                let (a, b) = (&direct.eyes[e], &memo.eyes[e]);
                for i in 0..a.radiance.len() {
                    let diff = (Vec3::from_slice(&a.radiance[i][..3])
                        - Vec3::from_slice(&b.radiance[i][..3]))
                    .abs()
                    .max_element();
                    assert!(
                        diff <= bound,
                        "{}: eye {e} pixel {i}: |memo − direct| = {diff} > {bound}",
                        kind.name()
                    );
                    worst = worst.max(diff);
                    moved += (diff > 0.0) as usize;
                }
            }
            eprintln!(
                "{}: worst {worst}, bound {bound}, {moved} pixels moved",
                kind.name()
            );
            assert!(
                worst > 0.1 * bound && moved > 100,
                "{}: worst {worst} of bound {bound}, {moved} pixels moved: the cache was not used",
                kind.name()
            );
        }
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// The memoization table's counters of a session rendered with one.
fn memo_counters(
    s: &stereocache::session::Session,
) -> stereocache::materials::memo::state::MemoCounters {
    s.scene_gpu
        .memo
        .as_ref()
        .expect("a memo table")
        .counters()
        .unwrap()
}

/// (HDR-FLIP, RSE) of each eye of `test` against the same eye of
/// `reference`, both `w`×`h`.
fn flip_rse_per_eye(
    test: &stereocache::methods::StereoFrame,
    reference: &stereocache::methods::StereoFrame,
    w: usize,
    h: usize,
) -> [(f32, f32); 2] {
    use stereocache::metrics::error::{rse, RSE_EPSILON};
    use stereocache::metrics::flip::{flip_hdr, DEFAULT_PPD};
    use stereocache::metrics::image::LinearImage;
    [0, 1].map(|e| {
        let t = LinearImage::from_rgba(&test.eyes[e].radiance, w, h).unwrap();
        let r = LinearImage::from_rgba(&reference.eyes[e].radiance, w, h).unwrap();
        (
            flip_hdr(&t, &r, DEFAULT_PPD).unwrap().flip.mean,
            rse(&t, &r, RSE_EPSILON).unwrap(),
        )
    })
}

/// The noise bound of the memoized-image tests: the smaller of the two
/// eyes' (HDR-FLIP, RSE) of a second seed's render. Both eyes estimate the
/// same quantity; a bright outlier pixel only raises one eye's RSE.
fn noise_bound(noise: [(f32, f32); 2]) -> (f32, f32) {
    (noise[0].0.min(noise[1].0), noise[0].1.min(noise[1].1))
}

/// `procedural-uv:cornell` without its graphs' tangent-space normal
/// bindings, for the tests that compare memoized with direct images of the
/// same seed: they rely on same-seed paths staying the same paths where a
/// material does not choose among them, and a memoized normal turns the
/// BSDF-sampled directions, so which of them hit the light (MIS) changes
/// and the difference gains path noise that no texel size removes (the
/// graphs' normals rendered flat until session 50, when these tests'
/// "halved per level" and "within a second seed's noise" began to fail by
/// that floor: 0.52 instead of ≤ 0.5 from bias 1 to 2, HDR-FLIP 0.084
/// against TAA's 0.067). The normal outputs are still evaluated and
/// memoized with the others; only their use in shading is dropped.
fn procedural_cornell_without_graph_normals() -> Scene {
    use stereocache::materials::binding::Slot;
    let mut s =
        stereocache::scene::load_scene("procedural-uv:cornell").expect("procedural-uv:cornell");
    for (_, binds) in &mut s.graphs.materials {
        binds.retain(|b| b.slot != Slot::NormalTangent);
    }
    s
}

/// Memoized against direct evaluation on a scene of the library's graphs
/// (`procedural-uv:cornell`: twelve texture-space graphs on the box), same
/// seed:
///
/// - secondary-only memoization (3 bounces, 8 spp) is identical within
///   noise: it moves pixels by less than the per-pixel noise σ measured
///   from two direct images of different seeds (their difference has √2 σ)
///   and the mean by less than 3 standard errors of that noise;
/// - with every hit memoized (1 bounce, so that same-seed paths stay the
///   same paths, 32 spp), each variant (nearest with texel-centre snapping,
///   4×4 tiles, bilinear, 4×4 bilinear tiles) differs from the direct image
///   (HDR-FLIP at FLIP's default 67 pixels per degree, and relative squared
///   error, both printed beside a second seed's), and the thesis's ordering
///   holds (§6.1): nearest with snapping scores a lower FLIP than bilinear;
/// - tiled and non-tiled variants of one lookup give the same image bit for
///   bit: the same texel centres at the same levels, blended alike;
/// - the documented bound (docs/MATERIALS.md): memoization converges to
///   direct evaluation as texels shrink. For nearest + snap and bilinear,
///   each level of `--memo-bias` (texel edge halved) at least halves the
///   mean absolute difference from the direct image (first order in the
///   snapping displacement) and lowers HDR-FLIP, from bias 0 to 1 to 2.
///
/// The per-pixel bound on memoization's error is asserted where it can be
/// derived from the graphs' gradients, on the known-answer scene of
/// `memoized_images_stay_within_the_snapping_bound_of_direct_ones`. The
/// table must have been used (lookups counted). Software backend only: the
/// graphs' run-time pipelines take minutes to build on lavapipe, and the
/// backends agree on memoized hits in
/// `memoized_hits_return_the_graph_at_their_texel_centre`.
#[test]
fn memoized_images_differ_from_direct_ones_as_the_thesis_orders_them() {
    use stereocache::materials::memo::{MemoHits, MemoSettings};
    let ctx = context();
    let base = procedural_cornell_without_graph_normals();
    assert!(!base.graphs.is_empty());
    let rt = RtChoice::Software;
    let settings_at = |seed: u32, spp: u32, max_bounces: u32| RenderSettings {
        width: 40,
        height: 30,
        spp,
        max_bounces,
        seed,
        all_features: false,
        ..Default::default()
    };
    let direct = session(&ctx, base.clone(), rt);
    let camera = default_camera(&direct, 40, 30);
    let settings = |seed: u32| settings_at(seed, 8, 3);
    let direct1 = render(&direct, "reference", camera, &settings(1));
    let direct2 = render(&direct, "reference", camera, &settings(2));
    // One bounce, so that same-seed paths stay the same paths (with more
    // bounces, Russian roulette and lobe selection read the material and
    // part of the difference would be decorrelated noise, not bias).
    let one = |seed: u32| settings_at(seed, 32, 1);
    let direct1b = render(&direct, "reference", camera, &one(1));
    let direct2b = render(&direct, "reference", camera, &one(2));
    drop(direct);
    let memoized = |memo: MemoSettings, settings: &RenderSettings| {
        let mut s = base.clone();
        s.graphs.memo = memo;
        let session = session(&ctx, s, rt);
        let f = render(&session, "reference", camera, settings);
        let c = memo_counters(&session);
        (f, c)
    };
    let (memo1, c) = memoized(
        MemoSettings {
            hits: MemoHits::Secondary,
            ..Default::default()
        },
        &settings(1),
    );
    assert!(c.hits + c.misses > 1000, "secondary lookups {c:?}");
    let values = |f: &stereocache::methods::StereoFrame| -> Vec<f64> {
        f.eyes
            .iter()
            .flat_map(|e| {
                e.radiance
                    .iter()
                    .flat_map(|p| p[..3].iter().map(|&x| x as f64))
            })
            .collect()
    };
    let (d1, d2, m1) = (values(&direct1), values(&direct2), values(&memo1));
    let noise: Vec<f64> = d1.iter().zip(&d2).map(|(a, b)| a - b).collect();
    let diff: Vec<f64> = m1.iter().zip(&d1).map(|(a, b)| a - b).collect();
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    let sigma = rms(&noise) / 2f64.sqrt();
    let (mean_diff, _) = mean_and_standard_error(&diff);
    let se_mean = sigma / (diff.len() as f64).sqrt();
    eprintln!(
        "secondary: per-pixel noise σ {sigma:.4}, |memo − direct| rms {:.4}, mean {mean_diff:.5} (3 SE {:.5}); {c:?}",
        rms(&diff),
        3.0 * se_mean
    );
    assert!(
        sigma > 0.0 && rms(&diff) > 0.0,
        "memoization changed nothing"
    );
    assert!(
        rms(&diff) < sigma,
        "memoized secondary hits move pixels by {:.4} rms, more than the noise {sigma:.4}",
        rms(&diff)
    );
    assert!(
        mean_diff.abs() <= 3.0 * se_mean,
        "mean shift {mean_diff} beyond 3 SE {}",
        3.0 * se_mean
    );

    // Every hit memoized: FLIP and RSE per eye against the second seed's.
    let scores = |f: &stereocache::methods::StereoFrame| flip_rse_per_eye(f, &direct1b, 40, 30);
    let noise_scores = scores(&direct2b);
    eprintln!("second seed: (HDR-FLIP, RSE) per eye {noise_scores:?}");
    let mut frames = Vec::new();
    let mut scored = Vec::new();
    for (name, tile, bilinear) in [
        ("nearest + snap", 1, false),
        ("4×4 tiles", 4, false),
        ("bilinear", 1, true),
        ("4×4 bilinear tiles", 4, true),
    ] {
        let (f, c) = memoized(
            MemoSettings {
                hits: MemoHits::Both,
                tile,
                bilinear,
                entries: (1 << 20) / (tile * tile),
                ..Default::default()
            },
            &one(1),
        );
        assert!(c.hits > c.misses && c.misses > 0, "{name}: {c:?}");
        let s = scores(&f);
        eprintln!("{name}: (HDR-FLIP, RSE) per eye {s:?}; {c:?}");
        for (e, &(flip, err)) in s.iter().enumerate() {
            assert!(
                flip > 0.0 && err > 0.0,
                "{name}, eye {e}: memoization changed nothing"
            );
        }
        scored.push(s);
        frames.push(f);
    }
    // The thesis's ordering (§6.1): nearest with snapping scores best,
    // bilinear's blur a little worse.
    for (e, (nearest, bilinear)) in scored[0].iter().zip(&scored[2]).enumerate() {
        assert!(
            nearest.0 < bilinear.0,
            "eye {e}: HDR-FLIP nearest + snap {} not below bilinear {}",
            nearest.0,
            bilinear.0
        );
    }
    // The documented bound: convergence in texel size. Each level of
    // `--memo-bias` halves the texel edge h at every hit (eq. 5.5: the level
    // moves by exactly one), so snapping moves each lookup by at most half as
    // far. To first order the error is the graph's gradient times that
    // displacement, so a pixel's error is O(h); across a discontinuity of a
    // graph (checker and cell edges) the share of a pixel that reads the
    // wrong side is O(h) too; and where a pixel's paths average several
    // texels the errors also cancel, which makes it smaller. So the mean
    // absolute difference from the direct image at least halves per level.
    // FLIP (not linear in the difference) must fall with every level.
    let mad = |f: &stereocache::methods::StereoFrame, e: usize| -> f64 {
        let (t, r) = (&f.eyes[e].radiance, &direct1b.eyes[e].radiance);
        let sum: f64 = t
            .iter()
            .zip(r)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] as f64 - b[c] as f64).abs()))
            .sum();
        sum / (3 * t.len()) as f64
    };
    for (name, bilinear, at_bias_0) in [
        ("nearest + snap", false, &frames[0]),
        ("bilinear", true, &frames[2]),
    ] {
        let mut levels = vec![([0, 1].map(|e| mad(at_bias_0, e)), scores(at_bias_0))];
        for bias in [1.0, 2.0] {
            let (f, _) = memoized(
                MemoSettings {
                    hits: MemoHits::Both,
                    bilinear,
                    bias,
                    ..Default::default()
                },
                &one(1),
            );
            levels.push(([0, 1].map(|e| mad(&f, e)), scores(&f)));
        }
        eprintln!(
            "{name}: (mean |memo − direct| per eye, (HDR-FLIP, RSE) per eye) at bias 0, 1, 2: {levels:?}"
        );
        // The asserted bound (issue 17: "FLIP (and RSE) below a documented
        // bound"): from bias 2 on — texels a quarter of the pixel cone's
        // width — memoizing every hit changes the image less than rendering
        // it again with another seed at the same 32 spp does, in HDR-FLIP
        // and in RSE, each eye. The bound is the renderer's own Monte Carlo
        // noise at this sample count (measured above, not chosen): a
        // difference below it cannot be told from resampling. At bias 0 the
        // memoized image is more than the noise away (docs/MATERIALS.md),
        // so the bound bites there.
        let (noise_flip, noise_rse) = noise_bound(noise_scores);
        for (e, &(flip2, rse2)) in levels[2].1.iter().enumerate() {
            assert!(
                flip2 < noise_flip && rse2 < noise_rse,
                "{name}, eye {e}: at bias 2 HDR-FLIP {flip2} / RSE {rse2} against direct, \
                 not below the second seed's {noise_flip} / {noise_rse}"
            );
        }
        for b in 0..2 {
            for e in 0..2 {
                let ((m0, f0), (m1, f1)) = (
                    (levels[b].0[e], levels[b].1[e].0),
                    (levels[b + 1].0[e], levels[b + 1].1[e].0),
                );
                assert!(
                    m1 > 0.0 && m1 <= 0.5 * m0,
                    "{name}, eye {e}: bias {b} → {}: mean |memo − direct| {m0} → {m1}, not halved",
                    b + 1
                );
                assert!(
                    f1 < f0,
                    "{name}, eye {e}: bias {b} → {}: HDR-FLIP {f0} → {f1} did not fall",
                    b + 1
                );
            }
        }
    }
    for (e, eye) in frames[0].eyes.iter().enumerate() {
        assert!(
            eye.radiance == frames[1].eyes[e].radiance,
            "eye {e}: 4×4 tiles differ from nearest + snap"
        );
        assert!(
            frames[2].eyes[e].radiance == frames[3].eyes[e].radiance,
            "eye {e}: 4×4 bilinear tiles differ from non-tiled bilinear"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// The asserted bound of `memoized_images_differ_from_direct_ones_as_the_thesis_orders_them`
/// for the methods that accumulate over frames — the sample cache (the
/// method this project is about), TAA, the hash cache, the hybrid and
/// stable ray tracing (isrt): each still view rendered for 32 frames
/// (uniform shading for the sample cache: every cached sample shaded about
/// every n_target-th frame) stands for the reference's 32 spp. From
/// `--memo-bias 2` on, memoizing every hit moves that image less than
/// rendering it again with another seed does, in HDR-FLIP and in RSE, each
/// eye (the bound is the method's own noise, measured here); the image at
/// bias 0 must differ more than at bias 2, so the table is used.
#[test]
fn accumulating_methods_memoized_images_stay_within_their_own_noise() {
    use stereocache::materials::memo::{MemoHits, MemoSettings};
    const FRAMES: u32 = 32;
    let ctx = context();
    let base = procedural_cornell_without_graph_normals();
    let rt = RtChoice::Software;
    // One bounce, as in the reference's test: same-seed paths stay the
    // same paths where the material does not choose among them.
    let settings = |seed: u32| RenderSettings {
        width: 40,
        height: 30,
        spp: 1,
        max_bounces: 1,
        seed,
        all_features: false,
        ..Default::default()
    };
    for method in ["sample-cache", "taa", "hash-cache", "hybrid", "isrt"] {
        let run = |memo: Option<f32>, seed: u32| {
            let mut s = base.clone();
            if let Some(bias) = memo {
                s.graphs.memo = MemoSettings {
                    hits: MemoHits::Both,
                    bias,
                    ..Default::default()
                };
            }
            let session = session(&ctx, s, rt);
            let camera = default_camera(&session, 40, 30);
            let mut m = session.method(method, &settings(seed)).expect("method");
            let f = render_still(m.as_mut(), camera, FRAMES);
            if memo.is_some() {
                let c = memo_counters(&session);
                assert!(
                    c.hits > c.misses && c.misses > 0,
                    "{method}, bias {memo:?}: {c:?}"
                );
            }
            f
        };
        let direct1 = run(None, 1);
        let direct2 = run(None, 2);
        let scores = |f: &stereocache::methods::StereoFrame| flip_rse_per_eye(f, &direct1, 40, 30);
        let noise = scores(&direct2);
        let at0 = scores(&run(Some(0.0), 1));
        let at2 = scores(&run(Some(2.0), 1));
        eprintln!(
            "{method}, {FRAMES} still frames: (HDR-FLIP, RSE) per eye against direct: second seed {noise:?}, bias 0 {at0:?}, bias 2 {at2:?}"
        );
        let (nf, nr) = noise_bound(noise);
        for (e, (&(f0, _), &(f2, r2))) in at0.iter().zip(&at2).enumerate() {
            assert!(
                f2 > 0.0 && f2 < f0,
                "{method}, eye {e}: HDR-FLIP at bias 2 {f2} not between 0 and bias 0's {f0}"
            );
            assert!(
                f2 < nf && r2 < nr,
                "{method}, eye {e}: at bias 2 HDR-FLIP {f2} / RSE {r2} against direct, not below the second seed's {nf} / {nr}"
            );
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Eviction by either clock (`--memo-clock frame|counter`, thesis §5.3.3
/// and Table 6.2) changes which lookups hit, never a value: a texel's
/// record is the graph at its centre whoever stored it. Tables far smaller
/// than a frame's texels (256 single texels, 16 tiles of 4×4), where
/// nearly every lookup evicts, render procedural-uv:cornell bit for bit as
/// the default 2^20-texel table does, for LRU by the frame and by the
/// access counter and LRW by the counter. The access counter advanced once
/// per stamp write: per stored entry, and with LRU per hit (read back from
/// the head of the stamps buffer).
#[test]
fn small_tables_evict_by_either_clock_without_changing_the_image() {
    use stereocache::materials::memo::table::Eviction;
    use stereocache::materials::memo::{MemoClock, MemoHits, MemoSettings};
    let ctx = context();
    let base =
        stereocache::scene::load_scene("procedural-uv:cornell").expect("procedural-uv:cornell");
    let rt = RtChoice::Software;
    let settings = RenderSettings {
        width: 40,
        height: 30,
        spp: 4,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    let camera = default_camera(&session(&ctx, base.clone(), rt), 40, 30);
    let run = |memo: MemoSettings| {
        let mut s = base.clone();
        s.graphs.memo = memo;
        let session = session(&ctx, s, rt);
        let f = render(&session, "reference", camera, &settings);
        let m = session.scene_gpu.memo.as_ref().expect("a memo table");
        let c = m.counters().unwrap();
        let words: Vec<u32> = m.stamps.download_pod().unwrap();
        (f, c, words[0] as u64 | (words[1] as u64) << 32)
    };
    for tile in [1u32, 4] {
        let big = MemoSettings {
            hits: MemoHits::Both,
            tile,
            entries: MemoSettings::default_entries(tile),
            ..Default::default()
        };
        let (want, c, _) = run(big);
        assert_eq!(c.evictions, 0, "tile {tile}: the big table evicts: {c:?}");
        let small = if tile == 1 { 256 } else { 16 };
        for (eviction, clock) in [
            (Eviction::Lru, MemoClock::Frame),
            (Eviction::Lru, MemoClock::Counter),
            (Eviction::Lrw, MemoClock::Counter),
        ] {
            let what = format!("tile {tile}, {small} entries, {eviction:?} by {clock:?}");
            let (f, c, counter) = run(MemoSettings {
                entries: small,
                eviction,
                clock,
                ..big
            });
            eprintln!(
                "{what}: hit rate {:?}, {c:?}, counter {counter}",
                c.hit_rate()
            );
            assert!(c.evictions > 100 && c.hits > 0, "{what}: {c:?}");
            for (e, eye) in f.eyes.iter().enumerate() {
                assert!(
                    eye.radiance == want.eyes[e].radiance && eye.albedo == want.eyes[e].albedo,
                    "{what}: eye {e} differs from the big table's image"
                );
            }
            if clock == MemoClock::Counter {
                let touched = if eviction == Eviction::Lru { c.hits } else { 0 };
                assert_eq!(
                    counter,
                    c.fills + c.evictions + touched,
                    "{what}: the access counter against the stamp writes: {c:?}"
                );
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// The reuse between the eyes (`other_eye_hits`: hits on a record the
/// other eye filled in this frame, tagged in the record). Both eyes at one
/// point (IPD 0) see nearly the same tiles (4×4 texels, primary hits only;
/// their jitter differs), so each tile is filled by one eye and read by the
/// other: whichever eye fills a tile, the other's later lookups of it are
/// the other eye's hits. Those are at most the non-filling eye's lookups,
/// about half of all lookups whatever order the device runs the eyes in
/// (≤ 0.5 + the 1 % by which the eyes' lookup counts may differ), and at
/// least the hits that are not on the own eye's fills: here well above a
/// third. A tag without the eye counts the filler's own later lookups too
/// (≈ the frame's hit rate, 0.86); one never matching counts 0. In the
/// next frame, same view, the tiles were filled in frame 0, so hardly any
/// hit is on this frame's fills: under 1 % of the lookups (a tag without
/// the frame gives about half again).
#[test]
fn other_eye_hits_count_the_other_eyes_fills_of_this_frame() {
    use stereocache::materials::memo::{MemoHits, MemoSettings};
    let ctx = context();
    let mut s =
        stereocache::scene::load_scene("procedural-uv:cornell").expect("procedural-uv:cornell");
    s.graphs.memo = MemoSettings {
        hits: MemoHits::Primary,
        tile: 4,
        entries: MemoSettings::default_entries(4),
        ..Default::default()
    };
    let rt = RtChoice::Software;
    let session = session(&ctx, s, rt);
    let settings = RenderSettings {
        width: 40,
        height: 30,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    let mut camera = default_camera(&session, 40, 30);
    camera.ipd = 0.0;
    let table = session.scene_gpu.memo.as_ref().expect("a memo table");
    let mut m = session.method("reference", &settings).expect("reference");
    let mut prev = None;
    for frame in 0..2u32 {
        table.begin_frame(frame).unwrap();
        render_at(m.as_mut(), frame, camera, prev);
        prev = Some(camera);
        let c = table.counters().unwrap();
        let lookups = c.hits + c.misses;
        let share = c.other_eye_share().unwrap_or(0.0);
        eprintln!("frame {frame}: {c:?}, other-eye share {share:.4}");
        assert!(lookups > 1000, "frame {frame}: {c:?}");
        let second = c.second_eye_hits + c.second_eye_misses;
        assert!(
            second.abs_diff(lookups / 2) * 100 <= lookups,
            "frame {frame}: the eyes look up alike: {second} of {lookups}"
        );
        if frame == 0 {
            assert!(
                c.fills > 0 && (0.35..=0.51).contains(&share),
                "frame 0: other-eye share {share} (hit rate {:?})",
                c.hit_rate()
            );
        } else {
            assert!(
                c.hits * 10 > lookups * 9 && c.other_eye_hits * 100 < lookups,
                "frame 1: {c:?}"
            );
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Emission seen by light sampling goes through the table like emission a
/// BSDF-sampled ray hits, so both MIS strategies estimate the same light.
/// A white floor under a 1 m emissive square 0.5 m above it (black
/// environment, 1 bounce): the square's emission graph is 2 for u ≤ ½ and
/// 0 beyond (mean 1). With `--memo secondary` every light point is a
/// secondary hit whose cone (grown by the floor's roughness-1 spread, thesis
/// eq. 2.11: ≥ 22 m at 0.5 m) gives level round(−log2 22) = −4: one texel
/// of 16 uv units, centre uv (0, 0), where the graph is 2. So the memoized
/// light is a uniform Le = 2 and the floor's radiance is exactly
/// ρ·Le·F(x), F the form factor to the square (Howell B-3). Were light
/// samples evaluated directly (mean 1), the floor would sit well below.
#[test]
fn light_sampled_emission_goes_through_the_table() {
    use stereocache::materials::memo::{MemoHits, MemoSettings};
    let ctx = context();
    let half = r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="half">
    <texcoord name="uv" type="vector2" />
    <extract name="u" type="float"><input name="in" type="vector2" nodename="uv" /><input name="index" type="integer" value="0" /></extract>
    <ifgreater name="e" type="color3"><input name="value1" type="float" nodename="u" /><input name="value2" type="float" value="0.5" /><input name="in1" type="color3" value="0, 0, 0" /><input name="in2" type="color3" value="2, 2, 2" /></ifgreater>
    <output name="emission" type="color3" nodename="e" />
  </nodegraph>
</materialx>
"#;
    let mut s = Scene {
        source: "test:light-through-the-table".into(),
        ..Default::default()
    };
    let albedo = 0.5f32;
    // specular 0: a pure Lambertian floor (no dielectric layer).
    let floor = add_material(
        &mut s,
        Material {
            specular: 0.0,
            ..Material::diffuse("floor", Vec3::splat(albedo))
        },
    );
    let mut lm = Material {
        emissive: Vec3::ONE,
        ..Material::diffuse("light", Vec3::ZERO)
    };
    s.graphs
        .attach_mtlx(1, &mut lm, "half.mtlx", half)
        .expect("graph binds");
    let light = add_material(&mut s, lm);
    assert_eq!(light, 1);
    let g = grid(
        "floor",
        Vec3::new(-0.5, 0.0, 0.5),
        Vec3::X,
        Vec3::NEG_Z,
        1,
        1,
        Vec2::ONE,
    );
    add_mesh(&mut s, g, floor, Mat4::IDENTITY);
    let g = grid(
        "light",
        Vec3::new(-0.5, 0.5, -0.5),
        Vec3::X,
        Vec3::Z,
        1,
        1,
        Vec2::ONE,
    );
    add_mesh(&mut s, g, light, Mat4::IDENTITY);
    s.validate().unwrap();
    s.graphs.memo = MemoSettings {
        hits: MemoHits::Secondary,
        ..Default::default()
    };
    let (w, h) = (24u32, 16u32);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 64,
        max_bounces: 1,
        seed: 5,
        all_features: false,
        ..Default::default()
    };
    let c = look_at("down", Vec3::new(0.0, 0.3, 0.0), Vec3::ZERO, Vec3::Z, 60.0);
    let camera = StereoCamera::from_scene_camera(c.transform, c.yfov, w as f32 / h as f32);
    let sess = session(&ctx, s, RtChoice::Software);
    let f = render(&sess, "reference", camera, &settings);
    let counters = memo_counters(&sess);
    let mut diffs = Vec::new();
    let mut direct_gap = Vec::new();
    for eye in &f.eyes {
        for (i, fh) in eye.first_hit.iter().enumerate() {
            assert_ne!(fh[3], u32::MAX, "pixel {i} sees the floor");
            let inst = &sess.scene.instances[fh[3] as usize];
            assert_eq!(sess.scene.meshes[inst.mesh as usize].material, floor);
            let (mat, geom) = hit_geom(&sess.scene, *fh);
            assert_eq!(mat, floor);
            let (x, z) = (geom.position[0] as f64, geom.position[2] as f64);
            let ff = form_factor_to_parallel_rect(-0.5 - x, 0.5 - x, -0.5 - z, 0.5 - z, 0.5);
            // ρ/π · E with E = π·Le·F.
            let want = albedo as f64 * 2.0 * ff;
            let got = eye.radiance[i][0] as f64;
            diffs.push(got - want);
            // What light samples of the direct graph (mean 1) would pull towards.
            direct_gap.push(want * 0.5);
        }
    }
    let (mean, se) = mean_and_standard_error(&diffs);
    let gap = direct_gap.iter().sum::<f64>() / direct_gap.len() as f64;
    eprintln!("floor − ρ·2·F: mean {mean:.5} ± {se:.5} (direct light samples would be ≈ {gap:.3} lower); {counters:?}");
    assert!(counters.hits > 0, "the light was looked up: {counters:?}");
    assert!(
        mean.abs() <= 4.0 * se,
        "floor radiance off the uniform-2 light by {mean} (SE {se})"
    );
    assert!(
        gap > 20.0 * se,
        "the test separates the two answers: gap {gap}, SE {se}"
    );
    assert_no_validation_messages(&ctx);
}

/// Memoization serves every method's path tracing, not only the
/// reference's (issue 17: "used by every method's path tracing (reference,
/// naive, TAA, hash-cache, sample-cache shading)"): on procedural-uv:cornell
/// with `--memo both`, each method's first frame (a fresh table each) looks
/// its hits' graphs up in the table — thousands of lookups, of which most
/// hit (neighbouring paths share texels) — and its image has every covered
/// pixel finite. A method that evaluated the graphs directly would leave
/// the counters at zero.
#[test]
fn every_method_shades_through_the_memoization_table() {
    use stereocache::materials::memo::{MemoHits, MemoSettings};
    use stereocache::methods::MethodKind;
    let ctx = context();
    let mut scene =
        stereocache::scene::load_scene("procedural-uv:cornell").expect("procedural-uv:cornell");
    scene.graphs.memo = MemoSettings {
        hits: MemoHits::Both,
        ..Default::default()
    };
    let settings = RenderSettings {
        width: 40,
        height: 30,
        spp: 4,
        max_bounces: 2,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    for &kind in MethodKind::ALL {
        if kind.name() == "debug-normals" {
            continue;
        }
        let s = session(&ctx, scene.clone(), RtChoice::Software);
        let camera = default_camera(&s, 40, 30);
        let f = render(&s, kind.name(), camera, &settings);
        let c = memo_counters(&s);
        eprintln!("{}: {c:?}", kind.name());
        // 2 eyes × 1,200 pixels, each shading at least one first hit.
        assert!(c.hits + c.misses >= 2400, "{}: lookups {c:?}", kind.name());
        assert!(c.hits > c.misses, "{}: {c:?}", kind.name());
        assert_finite_non_negative(&f, kind.name());
    }
    assert_no_validation_messages(&ctx);
}

/// A Lambert quad (albedo `rho`, no specular lobe) under one delta
/// directional light of irradiance `e` towards `to_light`, written as glTF
/// at `path` with its material bound to the MaterialX file `mtlx` (beside
/// it) through `extras.materialx`, and loaded back.
fn lit_quad_bound_to(
    path: &Path,
    mtlx: &str,
    quad: stereocache::scene::Mesh,
    rho: f32,
    double_sided: bool,
    to_light: Vec3,
    e: f32,
) -> Scene {
    let mut s = Scene {
        source: "test:lit-quad".into(),
        ..Default::default()
    };
    let mut m = Material::diffuse("white", Vec3::splat(rho));
    m.specular = 0.0;
    m.double_sided = double_sided;
    let mat = add_material(&mut s, m);
    add_mesh(&mut s, quad, mat, Mat4::IDENTITY);
    s.lights.push(directional_light(to_light, e, 0.0));
    s.validate().unwrap();
    stereocache::scene::write_gltf(&s, path).unwrap();
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    j["materials"][0]["extras"] = serde_json::json!({ "materialx": { "file": mtlx } });
    std::fs::write(path, serde_json::to_string_pretty(&j).unwrap()).unwrap();
    stereocache::scene::load_gltf(path).expect("bound scene loads")
}

/// 8×8 per eye, 2 spp, one scattering event, seed 3.
fn one_event_settings() -> RenderSettings {
    RenderSettings {
        width: 8,
        height: 8,
        spp: 2,
        max_bounces: 1,
        seed: 3,
        all_features: false,
        ..Default::default()
    }
}

/// A graph's `normalmap` uses the mesh's own bitangent, glTF's
/// cross(N, T)·w, as a normal texture does (material.glsl
/// tangent_space_normal): on a mirrored uv island (w = −1) and seen from
/// behind (normal, tangent and w all turned over, scene.glsl surface_at)
/// the mapped normal is the one the texture's author drew, not its mirror
/// image along the bitangent. A white Lambert quad in y = 0, double-sided,
/// tangents from its uvs (MikkTSpace), plain and with u mirrored; a `.mtlx`
/// graph's world-space `normal` output is `normalmap` of a constant
/// tangent-space normal tilted along T and B. One delta directional light,
/// one scattering event: every pixel is ρ/π·E·max(0, n·l) with n the
/// front's mapped normal (negated from behind, the light mirrored there),
/// to 10⁻⁴ relative (f32 shading). The unsigned bitangent cross(N, T) gave
/// a different value where exactly one of mirroring and seeing from behind
/// applies (checked below, so the test bites; the two turnings cancel in
/// the fourth case); the CPU evaluator's bitangent is checked at grid
/// points against the GPU in tests/material_graphs.rs.
#[test]
fn graph_normal_maps_follow_the_meshs_handedness_and_sides() {
    let ctx = context();
    let d = dir("handedness");
    std::fs::write(
        d.join("tilt.mtlx"),
        r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="tilt">
    <normalmap name="nm" type="vector3"><input name="in" type="vector3" value="0.35, 0.75, 0.9" /></normalmap>
    <output name="normal" type="vector3" nodename="nm" />
  </nodegraph>
</materialx>
"#,
    )
    .unwrap();
    // The tangent-space normal the graph decodes: 2·in − 1.
    let tn = Vec3::new(-0.3, 0.5, 0.8);
    let (rho, e) = (0.8f32, 2.0f32);
    let to_light_above = Vec3::new(0.2, 1.0, 0.7).normalize();
    let settings = one_event_settings();
    let mut handedness = Vec::new();
    for mirrored in [false, true] {
        let quad = tangent_quad(mirrored);
        let t = quad.tangents[0];
        handedness.push(t.w);
        for below in [false, true] {
            let to_light = if below {
                to_light_above * Vec3::new(1.0, -1.0, 1.0)
            } else {
                to_light_above
            };
            let path = d.join(format!("quad-{mirrored}-{below}.gltf"));
            let scene = lit_quad_bound_to(&path, "tilt.mtlx", quad.clone(), rho, true, to_light, e);
            let read = &scene.meshes[0].tangents;
            assert!(
                read.len() == 4 && read.iter().all(|x| x.abs_diff_eq(t, 1e-6)),
                "the written quad keeps its tangents: {read:?} against {t}"
            );
            // The frame the surface is seen in: the front's, or all of it
            // turned over from behind.
            let side = if below { -1.0 } else { 1.0 };
            let (n, tg) = (Vec3::Y * side, t.truncate() * side);
            let mapped = |b: Vec3| (tn.x * tg + tn.y * b + tn.z * n).normalize();
            let want_n = mapped(n.cross(tg) * t.w * side);
            let wrong_n = mapped(n.cross(tg));
            let shade = |n: Vec3| rho / std::f32::consts::PI * e * n.dot(to_light).max(0.0);
            let (want, wrong) = (shade(want_n), shade(wrong_n));
            assert!(want > 0.1, "the light reaches the mapped normal: {want}");
            if mirrored != below {
                assert!(
                    (want - wrong).abs() > 0.05 * want,
                    "mirrored {mirrored}, below {below}: the unsigned bitangent gives {wrong}, close to {want}"
                );
            }
            let y = 10.0 * side;
            let cam = look_at_camera(Vec3::new(0.0, y, 1e-3), Vec3::ZERO, 5.0, 1.0);
            for rt in rt_backends(&ctx) {
                let f = render(
                    &session(&ctx, scene.clone(), rt),
                    "reference",
                    cam,
                    &settings,
                );
                for eye in &f.eyes {
                    for p in &eye.radiance {
                        assert!(
                            (p[0] - want).abs() <= 1e-4 * want,
                            "{rt:?}, uv mirrored {mirrored}, seen from below {below}: {} where \
                             ρ/π·E·(n·l) = {want} (the unsigned bitangent's: {wrong})",
                            p[0]
                        );
                    }
                }
            }
        }
    }
    assert_eq!(
        handedness,
        [1.0, -1.0],
        "the mirrored quad is the left-handed one"
    );
    assert_no_validation_messages(&ctx);
}

/// Graphs of `uvs.mtlx`. `both`: base colour (t₀.x, t₀.y, ¼·t₁.x + ¾·t₁.y)
/// and emission heighttonormal(0.8·u₁ − 1.7·v₁, scale 4), differentiated
/// in set 0 (so the normal is Jᵀ(0.8, −1.7) scaled: it reads ∂uv1/∂uv, J;
/// constant over a quad, as the inner radiance check needs); `zero`:
/// base colour (t₀.x, t₀.y, ½), emission (0.3, 0.5, 0.7).
const UVS_MTLX: &str = r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="both">
    <texcoord name="t0" type="vector2" />
    <texcoord name="t1" type="vector2"><input name="index" type="integer" value="1" /></texcoord>
    <extract name="t0x" type="float"><input name="in" type="vector2" nodename="t0" /><input name="index" type="integer" value="0" /></extract>
    <extract name="t0y" type="float"><input name="in" type="vector2" nodename="t0" /><input name="index" type="integer" value="1" /></extract>
    <dotproduct name="t1s" type="float"><input name="in1" type="vector2" nodename="t1" /><input name="in2" type="vector2" value="0.25, 0.75" /></dotproduct>
    <combine3 name="base" type="vector3"><input name="in1" type="float" nodename="t0x" /><input name="in2" type="float" nodename="t0y" /><input name="in3" type="float" nodename="t1s" /></combine3>
    <dotproduct name="h" type="float"><input name="in1" type="vector2" nodename="t1" /><input name="in2" type="vector2" value="0.8, -1.7" /></dotproduct>
    <heighttonormal name="n" type="vector3"><input name="in" type="float" nodename="h" /><input name="scale" type="float" value="4.0" /></heighttonormal>
    <output name="base_color" type="vector3" nodename="base" />
    <output name="emission" type="vector3" nodename="n" />
  </nodegraph>
  <nodegraph name="zero">
    <texcoord name="t0" type="vector2" />
    <extract name="t0x" type="float"><input name="in" type="vector2" nodename="t0" /><input name="index" type="integer" value="0" /></extract>
    <extract name="t0y" type="float"><input name="in" type="vector2" nodename="t0" /><input name="index" type="integer" value="1" /></extract>
    <combine3 name="base" type="vector3"><input name="in1" type="float" nodename="t0x" /><input name="in2" type="float" nodename="t0y" /><input name="in3" type="float" value="0.5" /></combine3>
    <constant name="emit" type="vector3"><input name="value" type="vector3" value="0.3, 0.5, 0.7" /></constant>
    <output name="base_color" type="vector3" nodename="base" />
    <output name="emission" type="vector3" nodename="emit" />
  </nodegraph>
</materialx>
"#;

/// Left edges of the three quads of `graphs_read_the_raw_uv_sets`.
const UV_QUADS_X0: [f32; 3] = [-1.6, -0.5, 0.6];

/// Three 1 m quads (y = 0, facing +y) with TEXCOORD_0 (u along +x, v along
/// −z, the unit square) and TEXCOORD_1 = (0.2 + 0.6·v₀, 0.9 − 0.7·u₀), a
/// turn and a mirror of it. Material 0's base colour texture reads
/// TEXCOORD_1, material 1 has no texture, material 2's base colour texture
/// reads TEXCOORD_0 under a KHR_texture_transform; materials 0 and 1 take
/// graph `both`, material 2 graph `zero` (or `both`: `third_set`), by
/// extras.
fn write_uv_quads(d: &Path, third_set: bool) -> PathBuf {
    let mut s = Scene {
        source: "test:uv-quads".into(),
        ..Default::default()
    };
    s.textures.push(Texture::with_mips(
        "fallback".into(),
        TextureEncoding::Srgb,
        1,
        1,
        vec![255, 255, 255, 255],
    ));
    let textured = |name: &str, second: bool| Material {
        base_color_texture: Some(TextureRef::new(0)),
        second_uv_slots: if second { 1 } else { 0 },
        ..Material::diffuse(name, Vec3::ONE)
    };
    let ms = [
        add_material(&mut s, textured("on set 1", true)),
        add_material(&mut s, Material::diffuse("untextured", Vec3::ONE)),
        add_material(&mut s, textured("transformed", false)),
    ];
    for (m, x0) in ms.into_iter().zip(UV_QUADS_X0) {
        let mut g = grid(
            "quad",
            Vec3::new(x0, 0.0, 0.5),
            Vec3::X,
            Vec3::NEG_Z,
            1,
            1,
            Vec2::ONE,
        );
        g.uvs2 = g.uvs.iter().map(|uv| raw_uv1(*uv)).collect();
        add_mesh(&mut s, g, m, Mat4::IDENTITY);
    }
    s.validate().unwrap();
    let path = d.join("uv_quads.gltf");
    stereocache::scene::write_gltf(&s, &path).unwrap();
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    j["extensionsUsed"] = serde_json::json!(["KHR_texture_transform"]);
    j["materials"][2]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = serde_json::json!(
        { "KHR_texture_transform": { "offset": [0.5, 0.0], "scale": [2.0, 2.0] } }
    );
    for (k, graph) in [
        (0, "both"),
        (1, "both"),
        (2, if third_set { "both" } else { "zero" }),
    ] {
        j["materials"][k]["extras"] =
            serde_json::json!({ "materialx": { "file": "uvs.mtlx", "graph": graph } });
    }
    std::fs::write(path.with_file_name("uvs.mtlx"), UVS_MTLX).unwrap();
    std::fs::write(&path, serde_json::to_string_pretty(&j).unwrap()).unwrap();
    path
}

/// TEXCOORD_1 of `write_uv_quads` at TEXCOORD_0 `uv` (glTF's v down).
fn raw_uv1(uv: Vec2) -> Vec2 {
    Vec2::new(0.2 + 0.6 * uv.y, 0.9 - 0.7 * uv.x)
}

/// `texcoord` index k reads glTF's TEXCOORD_k as stored, whatever uv
/// channels the material's textures take: material 0's texture takes
/// TEXCOORD_1 as the first channel (so set 0 is the second channel,
/// swapped back), material 1 none (set 1 gets the second channel),
/// material 2's texture a transformed TEXCOORD_0 (set 0 gets the second
/// channel untransformed). Every hit's albedo and inner radiance equal the
/// CPU evaluator at the raw sets, computed here from the hit's position
/// (not from the loaded mesh's channels), with ∂uv1/∂uv written down from
/// the map: in MaterialX's v-up space g₁ = (0.8 − 0.6·g₀.y, 0.1 + 0.7·g₀.x),
/// so J's columns are (0, 0.7) and (−0.6, 0); on material 0 the GPU
/// inverts the channels' derivative. The emission's tolerance adds the
/// rounding of heighttonormal's differences (|h| ≤ 2.5: two roundings of
/// h over the 2·step difference, times the scale 4 and Sobel ¼ … ⅟16).
/// Export and re-import keep the sets; a material whose textures take both
/// channels while its graphs read a third choice is one load error.
#[test]
fn graphs_read_the_raw_uv_sets() {
    let ctx = context();
    let d = dir("uv-sets");
    let path = write_uv_quads(&d, false);
    let scene = stereocache::scene::load_gltf(&path).expect("uv quads load");
    assert_eq!(
        scene.graphs.uv_swapped,
        vec![0, 2],
        "set 0 on the second channel"
    );
    assert!(scene.meshes.iter().all(|m| !m.uvs2.is_empty()));
    let sigma = eval::HEIGHT_SOBEL_SCALE;
    let tol_emit = TOL + 2.0 * 2.5 * f32::EPSILON / (2.0 * eval::HEIGHT_STEP) * 4.0 * sigma;
    let j_graph = [[0.0, 0.7], [-0.6, 0.0]];
    for rt in [RtChoice::Software, RtChoice::Query] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let s = session(&ctx, scene.clone(), rt);
        let f = render(&s, "reference", top_camera(), &probe_settings());
        let (w, h) = (f.width as usize, f.height as usize);
        let mut checked = [0usize; 3];
        for eye in &f.eyes {
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (mat, geom) = hit_geom(&s.scene, *fh);
                let p = Vec3::from(geom.position);
                let raw0 = Vec2::new(p.x - UV_QUADS_X0[mat as usize], 0.5 + p.z);
                let at = Geom {
                    uv: raw0.to_array(),
                    uv1: raw_uv1(raw0).to_array(),
                    uv1_per_uv: j_graph,
                    ..geom
                };
                let albedo = Vec3::from_slice(&eye.albedo[i][..3]);
                let want = cpu_slot(&s.scene, mat, Slot::BaseColor, &at);
                assert!(
                    (albedo - want).abs().max_element() <= TOL,
                    "{rt:?}: material {mat} pixel {i}: albedo {albedo} vs CPU {want}"
                );
                if inner_pixel(&eye.first_hit, i, w, h) {
                    let rad = Vec3::from_slice(&eye.radiance[i][..3]);
                    let emit = cpu_slot(&s.scene, mat, Slot::Emission, &at);
                    assert!(
                        (rad - emit).abs().max_element() <= tol_emit,
                        "{rt:?}: material {mat} pixel {i}: radiance {rad} vs CPU emission {emit}"
                    );
                    checked[mat as usize] += 1;
                }
            }
        }
        assert!(
            checked.iter().all(|&c| c > 50),
            "{rt:?}: inner pixels per quad {checked:?}"
        );
    }
    // Export writes material 0's and 2's channels the other way round, so
    // TEXCOORD_0 is set 0 again and a reload's graphs read the same sets
    // (from whichever channels the reload gives them).
    let out = d.join("exported").join("uv_quads.gltf");
    std::fs::create_dir_all(out.parent().unwrap()).unwrap();
    stereocache::scene::write_gltf(&scene, &out).unwrap();
    let again = stereocache::scene::load_gltf(&out).expect("exported scene loads");
    let sets = |sc: &Scene, m: &stereocache::scene::Mesh| {
        let read = sc.graphs.uv_sets_of(m.material);
        let (s0, s1) = match sc.graphs.uv_swapped.contains(&m.material) {
            true => (m.uvs2.clone(), m.uvs.clone()),
            false => (m.uvs.clone(), m.uvs2.clone()),
        };
        ((read & 1 != 0).then_some(s0), (read & 2 != 0).then_some(s1))
    };
    for (a, b) in again.meshes.iter().zip(&scene.meshes) {
        assert_eq!(sets(&again, a), sets(&scene, b), "material {}", a.material);
    }
    // Material 2 reading TEXCOORD_1 as well: its texture's transformed
    // TEXCOORD_0 and the raw TEXCOORD_0 take both channels.
    let third = d.join("third");
    std::fs::create_dir_all(&third).unwrap();
    let e = stereocache::scene::load_gltf(&write_uv_quads(&third, true))
        .expect_err("a third uv choice is refused")
        .to_string();
    for want in [
        "uv_quads.gltf",
        "material 2",
        "TEXCOORD_1 untransformed",
        "both uv channels",
    ] {
        assert!(e.contains(want), "{want:?} not in: {e}");
    }
    assert_eq!(e.lines().count(), 1, "one line: {e}");
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// A uv the finest level's texel grid cannot hold is evaluated directly
/// (memo/lod.glsl `memo_fits`, session 46's memo audit). The quads carry
/// one uv on all their vertices, (3000.3, 0.7): no uv derivative, so the
/// cone's level is the finest, 22, where 2^22·3000.3 is past 2^23 (and
/// past 2^30, where quantising clamped every uv to u ≈ 256). Every hit of
/// the uv-only material must have the graph's value at that uv (the CPU
/// evaluator; nothing to snap; to the f32 rounding of interpolating so
/// large a uv), in every variant, and the lookups count as bypassed.
/// Before, the graph was evaluated at u = 2^30/2^22 = 256.
#[test]
fn far_out_uvs_are_evaluated_directly() {
    use stereocache::materials::memo::{MemoFill, MemoHits, MemoSettings};
    let ctx = context();
    let d = dir("memo-far");
    let uv = Vec2::new(3000.3, 0.7);
    let path = write_quads_edited(&d, Vec2::ONE, Mat4::IDENTITY, |m| {
        m.uvs.iter_mut().for_each(|u| *u = uv)
    });
    bind(&path, |j| {
        j["extensions"]["KHR_texture_procedurals"]["procedurals"][0]["nodes"][6]["nodetype"] =
            "texcoord".into();
    });
    let mut scene = stereocache::scene::load_gltf(&path).expect("bound scene loads");
    assert!(scene.graphs.graphs[0].reads_only_uv(), "edited KHR graph");
    assert!(!stereocache::materials::memo::lod::fits(
        eval::graph_uv(uv.to_array()),
        stereocache::materials::memo::lod::MAX_LEVEL
    ));
    let at = Geom {
        uv: uv.to_array(),
        ..Default::default()
    };
    let want = cpu_slot(&scene, 0, Slot::BaseColor, &at);
    // The hit's uv is the three equal vertex uvs interpolated in f32: a few
    // roundings of terms up to |u| (weights from 24-bit barycentrics, three
    // products, two sums), within 4 ulps of 3000.3 (2^-12 each), and the
    // base colour changes by at most 2 per unit uv (PROCEDURAL).
    let tol = TOL + 2.0 * 4.0 * (-12f32).exp2();
    // What the clamp gave: the graph at u = 2^30 / 2^22, far beyond the
    // tolerance (the test's bite).
    let clamped = cpu_slot(
        &scene,
        0,
        Slot::BaseColor,
        &Geom {
            uv: [256.0, uv.y],
            ..at
        },
    );
    assert!(
        (want - clamped).abs().max_element() > 10.0 * tol,
        "{want} vs {clamped}"
    );
    for (tile, bilinear) in [(1, false), (1, true), (4, false), (4, true)] {
        scene.graphs.memo = MemoSettings {
            hits: MemoHits::Primary,
            tile,
            bilinear,
            entries: (1 << 16) / (tile * tile),
            fill: MemoFill::Plain,
            ..Default::default()
        };
        let s = session(&ctx, scene.clone(), RtChoice::Software);
        let memo = s.scene_gpu.memo.as_ref().expect("memo table");
        let f = render(&s, "reference", top_camera(), &probe_settings());
        let mut hits = 0usize;
        for eye in &f.eyes {
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX || hit_geom(&s.scene, *fh).0 != 0 {
                    continue;
                }
                let albedo = Vec3::from_slice(&eye.albedo[i][..3]);
                assert!(
                    (albedo - want).abs().max_element() <= tol,
                    "tile {tile} bilinear {bilinear}: pixel {i}: {albedo} vs the graph at the uv {want}"
                );
                hits += 1;
            }
        }
        let c = memo.counters().unwrap();
        assert!(hits > 100, "{hits} hits of material 0");
        assert_eq!((c.hits, c.fills), (0, 0), "nothing cached: {c:?}");
        assert!(c.bypassed as usize >= hits, "{c:?}");
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// Memoized normals (issue 17): a graph's tangent-space normal
/// (`normal_tangent`, the output the procedural-uv scenes' bumps bind and
/// the memo record stores) comes out of the table as it went in. A white
/// Lambert quad in y = 0 with tangents along +u (`tangent_quad`), one delta
/// directional light, one scattering event; the graph's constant encoded
/// normal (0.35, 0.75, 0.9) decodes to t = (−0.3, 0.5, 0.8), so every pixel
/// is ρ/π·E·max(0, n·l) with n = normalize(t.x·T + t.y·B + t.z·N), to 10⁻⁴
/// relative (f32 shading), without memoization and with it at primary and
/// at all hits, non-tiled and tiled, both backends; the table is used (its
/// lookups counted). A record that lost the normal shades with the quad's
/// own normal, ≥ 5 % off (checked, so the test bites).
#[test]
fn memoized_graph_normals_shade_as_evaluated_ones() {
    use stereocache::materials::memo::{MemoHits, MemoSettings};
    let ctx = context();
    let d = dir("memo-normal");
    std::fs::write(
        d.join("tilt.mtlx"),
        r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="tilt">
    <constant name="nt" type="vector3"><input name="value" type="vector3" value="0.35, 0.75, 0.9" /></constant>
    <output name="normal_tangent" type="vector3" nodename="nt" />
  </nodegraph>
</materialx>
"#,
    )
    .unwrap();
    let tn = Vec3::new(-0.3, 0.5, 0.8);
    let (rho, e) = (0.8f32, 2.0f32);
    let to_light = Vec3::new(0.2, 1.0, 0.7).normalize();
    let quad = tangent_quad(false);
    let t = quad.tangents[0];
    let mut scene = lit_quad_bound_to(
        &d.join("quad.gltf"),
        "tilt.mtlx",
        quad,
        rho,
        false,
        to_light,
        e,
    );
    assert!(scene.graphs.graphs[0].reads_only_uv(), "a memoizable graph");
    let (n, tg) = (Vec3::Y, t.truncate());
    let mapped = (tn.x * tg + tn.y * n.cross(tg) * t.w + tn.z * n).normalize();
    let shade = |n: Vec3| rho / std::f32::consts::PI * e * n.dot(to_light).max(0.0);
    let want = shade(mapped);
    assert!(
        (want - shade(n)).abs() > 0.05 * want,
        "the mapped normal shades apart from the quad's: {want} vs {}",
        shade(n)
    );
    let settings = one_event_settings();
    let cam = look_at_camera(Vec3::new(0.0, 10.0, 1e-3), Vec3::ZERO, 5.0, 1.0);
    for (hits, tile) in [
        (MemoHits::Off, 1),
        (MemoHits::Primary, 1),
        (MemoHits::Both, 1),
        (MemoHits::Primary, 4),
        (MemoHits::Both, 4),
    ] {
        scene.graphs.memo = MemoSettings {
            hits,
            tile,
            entries: 1 << 16,
            ..Default::default()
        };
        for rt in rt_backends(&ctx) {
            let ses = session(&ctx, scene.clone(), rt);
            let f = render(&ses, "reference", cam, &settings);
            if hits != MemoHits::Off {
                let c = memo_counters(&ses);
                assert!(c.hits + c.misses > 0, "{hits:?} {tile} {rt:?}: no lookup");
            }
            for eye in &f.eyes {
                for p in &eye.radiance {
                    assert!(
                        (p[0] - want).abs() <= 1e-4 * want,
                        "{hits:?}, tile {tile}, {rt:?}: {} where ρ/π·E·(n·l) = {want}",
                        p[0]
                    );
                }
            }
        }
    }
    assert_no_validation_messages(&ctx);
}
