//! The two-level software BVH (src/rt/two_level.rs): on scenes with several
//! instances (rotated, non-uniformly scaled copies) it agrees with the
//! flattened BVH and with ray queries on primary hits, its CPU traversal
//! agrees with its GPU traversal, and after the instances move
//! (`SceneGpu::set_instance_transforms`, the TLAS rebuilt and re-uploaded)
//! it agrees with ray queries on a scene uploaded at the moved pose.
//!
//! Agreement as in tests/backends.rs (issue 16's bar): instance and primitive
//! on ≥ 99.9 % of pixels, depth within 1e-4 relative. The two structures
//! differ in f32 rounding only (triangles pre-transformed in f64 vs the ray
//! taken to object space in f32: ~1e-7 relative), so ties at triangle edges
//! are the only expected id differences and 1e-4 is ~1000 ulps of depth.

mod common;
use common::*;
use glam::{Mat4, Quat, UVec2, Vec2, Vec3};
use std::sync::Arc;
use stereocache::camera::{Eye, StereoCamera};
use stereocache::methods::{RenderSettings, StereoFrame};
use stereocache::rt::{BvhLayout, CpuHit, RtChoice, SoftwareBvh, TwoLevelBvh};
use stereocache::scene::Scene;
use stereocache::session::{CameraSelect, Session};

const W: u32 = 64;
const H: u32 = 64;

/// The Cornell box plus rotated, non-uniformly scaled and translated copies
/// of its spheres and of a wall panel, inside the box where the default
/// camera sees them.
fn cornell_instanced() -> Scene {
    let mut s = shipped("cornell");
    let sphere = s
        .instances
        .iter()
        .find(|i| i.name.to_lowercase().contains("sphere"))
        .expect("cornell has spheres")
        .clone();
    let wall = s.instances[0].clone();
    let copies = [
        (
            &sphere,
            Mat4::from_scale_rotation_translation(
                Vec3::new(0.4, 0.7, 0.5),
                Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.7),
                Vec3::new(-0.25, 0.75, 0.1),
            ),
        ),
        (
            &sphere,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(0.3),
                Quat::from_rotation_y(1.1),
                Vec3::new(0.3, 0.7, 0.2),
            ),
        ),
        (
            &wall,
            Mat4::from_scale_rotation_translation(
                Vec3::new(0.3, 1.0, 0.3),
                Quat::from_rotation_x(-1.0) * Quat::from_rotation_z(0.4),
                Vec3::new(0.05, 0.45, 0.25),
            ),
        ),
    ];
    for (k, (base, m)) in copies.iter().enumerate() {
        let mut i = (*base).clone();
        i.name = format!("copy{k}");
        i.transform = *m * base.transform;
        s.instances.push(i);
    }
    s
}

fn camera_of(scene: &Scene) -> StereoCamera {
    let c = scene
        .camera("default")
        .or(scene.cameras.first())
        .expect("a scene camera");
    StereoCamera::from_scene_camera(c.transform, c.yfov, W as f32 / H as f32)
}

/// Instance/primitive and depth of every pixel's primary hit along the
/// camera model's CPU rays (camera.glsl's twin), by `trace`.
fn cpu_hits(cam: &StereoCamera, trace: impl Fn(Vec3, Vec3) -> Option<CpuHit>) -> Vec<[f32; 3]> {
    let mut out = Vec::new();
    for eye in Eye::BOTH {
        let v = cam.eye(eye);
        for y in 0..H {
            for x in 0..W {
                let d =
                    v.ray_direction(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), UVec2::new(W, H));
                out.push(match trace(v.position, d) {
                    Some(h) => [
                        h.instance as f32,
                        h.prim as f32,
                        h.t * d.dot(v.orientation * Vec3::NEG_Z),
                    ],
                    None => [-1.0, -1.0, 0.0],
                });
            }
        }
    }
    out
}

fn gpu_hits(f: &StereoFrame) -> Vec<[f32; 3]> {
    let mut out = Vec::new();
    for e in &f.eyes {
        for (h, d) in e.first_hit.iter().zip(&e.depth) {
            out.push(if h[3] == u32::MAX {
                [-1.0, -1.0, 0.0]
            } else {
                [h[3] as f32, h[2] as f32, *d]
            });
        }
    }
    out
}

/// Pixels whose ids differ or whose depths differ by more than 1e-4 relative.
fn disagreements(a: &[[f32; 3]], b: &[[f32; 3]]) -> usize {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .filter(|(x, y)| {
            x[0] != y[0] || x[1] != y[1] || (x[2] - y[2]).abs() > 1e-4 * x[2].abs().max(y[2].abs())
        })
        .count()
}

fn assert_agree(what: &str, a: &[[f32; 3]], b: &[[f32; 3]]) {
    let hits = a.iter().filter(|h| h[0] >= 0.0).count();
    assert!(
        hits > a.len() / 4,
        "{what}: only {hits} of {} pixels hit",
        a.len()
    );
    let bad = disagreements(a, b);
    assert!(
        bad <= a.len() / 1000,
        "{what}: {bad} of {} pixels disagree (limit 0.1 %)",
        a.len()
    );
}

#[test]
fn cpu_two_level_matches_flattened() {
    for (name, scene) in [
        ("cornell+copies", cornell_instanced()),
        ("cornell", shipped("cornell")),
        ("plane", shipped("plane")),
        ("hairball", shipped("hairball")),
        ("cornell, zero-area triangles first", degenerate_first()),
    ] {
        let cam = camera_of(&scene);
        let flat = SoftwareBvh::build(&scene);
        let two = TwoLevelBvh::build_at(&scene, flat.origin);
        assert!(
            two.max_depth < stereocache::rt::TRAVERSAL_STACK_SIZE,
            "{name}"
        );
        let a = cpu_hits(&cam, |o, d| {
            flat.closest_hit(flat.to_local(o.as_dvec3()), d, 0.0, 1e30)
        });
        let b = cpu_hits(&cam, |o, d| {
            two.closest_hit(two.to_local(o.as_dvec3()), d, 0.0, 1e30)
        });
        assert_agree(&format!("{name}: CPU flattened vs two-level"), &a, &b);
        if name.contains("zero-area") {
            // Both BVHs leave those out and report the mesh's own
            // primitive numbers: a hit is never one of the first 7, and
            // the two layouts name the same primitive on every pixel.
            let hits: Vec<_> = a.iter().filter(|h| h[0] >= 0.0).collect();
            assert!(hits.len() > 100, "{} hits", hits.len());
            assert!(
                hits.iter().all(|h| h[1] >= 7.0),
                "a zero-area triangle was hit"
            );
            assert!(
                a.iter().zip(&b).all(|(x, y)| x[0] == y[0] && x[1] == y[1]),
                "the layouts disagree on a primitive"
            );
        }
    }
}

/// The Cornell box with 7 zero-area triangles (a repeated vertex) before
/// each mesh's own: primitive numbers 7.. are the real triangles.
fn degenerate_first() -> Scene {
    let mut s = shipped("cornell");
    for m in &mut s.meshes {
        let mut idx = vec![0u32; 21];
        idx.extend_from_slice(&m.indices);
        m.indices = idx;
    }
    s.validate().unwrap();
    s
}

fn primary(s: &Session, cam: &StereoCamera) -> StereoFrame {
    let settings = RenderSettings {
        width: W,
        height: H,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    render(s, "reference", *cam, &settings)
}

fn layout_session(
    ctx: &Arc<stereocache::gpu::GpuContext>,
    scene: &Scene,
    rt: RtChoice,
    layout: BvhLayout,
) -> Session {
    Session::with_layout(ctx.clone(), scene.clone(), rt, Some(layout)).expect("scene upload")
}

#[test]
fn two_level_agrees_with_flattened_query_and_cpu() {
    let ctx = context();
    let has_query = require(
        ctx.ray_query_enabled(),
        "ray queries (the backend compared against)",
    );
    // (hairball: flattened vs query in tests/backends.rs, two-level vs
    // flattened on the CPU above; its GPU sessions here cost minutes.)
    {
        let (name, scene) = ("cornell+copies", cornell_instanced());
        let two = layout_session(&ctx, &scene, RtChoice::Software, BvhLayout::TwoLevel);
        assert_eq!(two.scene_gpu.bvh_layout, BvhLayout::TwoLevel);
        let flat = layout_session(&ctx, &scene, RtChoice::Software, BvhLayout::Flattened);
        let cam = two
            .camera(&CameraSelect::Default, W, H, None, None)
            .unwrap();
        let g2 = gpu_hits(&primary(&two, &cam));
        let gf = gpu_hits(&primary(&flat, &cam));
        assert_agree(&format!("{name}: GPU two-level vs flattened"), &g2, &gf);
        let cpu = TwoLevelBvh::build_at(&scene, two.scene_gpu.origin);
        let c2 = cpu_hits(&cam, |o, d| {
            cpu.closest_hit(cpu.to_local(o.as_dvec3()), d, 0.0, 1e30)
        });
        assert_agree(&format!("{name}: GPU vs CPU two-level"), &g2, &c2);
        if has_query {
            let rq = layout_session(&ctx, &scene, RtChoice::Query, BvhLayout::TwoLevel);
            let gq = gpu_hits(&primary(&rq, &cam));
            assert_agree(&format!("{name}: two-level vs ray query"), &g2, &gq);
        }
    }
    assert_no_validation_messages(&ctx);
}

/// The copies and a sphere move (translate, rotate, scale) at two
/// times; after each `set_instance_transforms` the software two-level
/// traversal agrees with its CPU twin at the moved pose, with the flattened
/// BVH of the scene uploaded at that pose, and with ray queries whose TLAS
/// was rebuilt in place by the same call.
#[test]
fn moved_instances_agree_across_backends() {
    let ctx = context();
    let has_query = require(
        ctx.ray_query_enabled(),
        "ray queries (the backend compared against)",
    );
    let scene = cornell_instanced();
    let n = scene.instances.len();
    let two = layout_session(&ctx, &scene, RtChoice::Software, BvhLayout::TwoLevel);
    let rq = has_query.then(|| layout_session(&ctx, &scene, RtChoice::Query, BvhLayout::TwoLevel));
    let cam = two
        .camera(&CameraSelect::Default, W, H, None, None)
        .unwrap();
    for t in [0.5f32, 1.0] {
        let moved: Vec<Mat4> = scene
            .instances
            .iter()
            .enumerate()
            .map(|(i, inst)| {
                if i + 4 > n {
                    // The last three copies and the instance before them.
                    Mat4::from_translation(Vec3::new(0.1 * t, -0.15 * t, 0.05 * t))
                        * Mat4::from_rotation_y(0.8 * t)
                        * inst.transform
                        * Mat4::from_scale(Vec3::splat(1.0 + 0.2 * t))
                } else {
                    inst.transform
                }
            })
            .collect();
        two.scene_gpu
            .set_instance_transforms(&moved)
            .expect("software two-level instances move");
        let g2 = gpu_hits(&primary(&two, &cam));
        let cpu = TwoLevelBvh::build_with(&scene, two.scene_gpu.origin, &moved);
        let c2 = cpu_hits(&cam, |o, d| {
            cpu.closest_hit(cpu.to_local(o.as_dvec3()), d, 0.0, 1e30)
        });
        assert_agree(&format!("t = {t}: GPU vs CPU two-level"), &g2, &c2);
        let mut at_pose = scene.clone();
        for (inst, m) in at_pose.instances.iter_mut().zip(&moved) {
            inst.transform = *m;
        }
        let flat = layout_session(&ctx, &at_pose, RtChoice::Software, BvhLayout::Flattened);
        let gf = gpu_hits(&primary(&flat, &cam));
        assert_agree(
            &format!("t = {t}: moved two-level vs flattened at the pose"),
            &g2,
            &gf,
        );
        if let Some(rq) = rq.as_ref() {
            rq.scene_gpu
                .set_instance_transforms(&moved)
                .expect("the ray-query TLAS is rebuilt");
            let gq = gpu_hits(&primary(rq, &cam));
            assert_agree(
                &format!("t = {t}: moved two-level vs moved ray query"),
                &g2,
                &gq,
            );
        }
    }
    assert_no_validation_messages(&ctx);
}

/// The rotating hairball (`hairball-rotating`, one turn in 8 s), posed by
/// the replay's own call (`Session::pose_instances`) at several times: the
/// software two-level traversal agrees with its CPU twin at that pose and
/// with ray queries whose TLAS the same call rebuilt (issue 16's bar: ids on
/// ≥ 99.9 % of pixels, depth 1e-4 relative).
#[test]
fn rotating_hairball_agrees_across_backends_at_several_times() {
    let ctx = context();
    let has_query = require(
        ctx.ray_query_enabled(),
        "ray queries (the backend compared against)",
    );
    let scene = shipped("hairball-rotating");
    assert!(scene.is_animated());
    let two = layout_session(&ctx, &scene, RtChoice::Software, BvhLayout::TwoLevel);
    let rq = has_query.then(|| layout_session(&ctx, &scene, RtChoice::Query, BvhLayout::TwoLevel));
    let cam = camera_of(&scene);
    let mut seen = Vec::new();
    for t in [0.0f64, 1.3, 2.9, 6.1] {
        two.pose_instances(t, None).unwrap();
        let g2 = gpu_hits(&primary(&two, &cam));
        let moved = scene.instance_transforms_at(t as f32);
        let cpu = TwoLevelBvh::build_with(&scene, two.scene_gpu.origin, &moved);
        let c2 = cpu_hits(&cam, |o, d| {
            cpu.closest_hit(cpu.to_local(o.as_dvec3()), d, 0.0, 1e30)
        });
        assert_agree(&format!("t = {t}: GPU vs CPU two-level"), &g2, &c2);
        if let Some(rq) = rq.as_ref() {
            rq.pose_instances(t, None).unwrap();
            let gq = gpu_hits(&primary(rq, &cam));
            assert_agree(&format!("t = {t}: two-level vs ray query"), &g2, &gq);
        }
        seen.push(g2);
    }
    // The poses differ: the hairball turned between the times.
    assert!(disagreements(&seen[0], &seen[1]) > seen[0].len() / 10);
    assert_no_validation_messages(&ctx);
}

/// A frame where every instance is scaled to a point leaves no box in the
/// TLAS; its root must then be a node without children in the uploaded
/// bytes (the previous frame's root stayed there, and the GPU drew the
/// instances at their old pose), and the CPU twin hits nothing.
#[test]
fn a_tlas_of_no_boxes_uploads_an_empty_root() {
    let scene = shipped("cornell");
    let mut two = TwoLevelBvh::build_at(&scene, glam::DVec3::ZERO);
    assert_ne!(&two.tlas_bytes().0[..80], &[0u8; 80][..], "a root at rest");
    let points = vec![glam::Mat4::from_scale(Vec3::ZERO); scene.instances.len()];
    two.rebuild_tlas(&points);
    assert_eq!(
        &two.tlas_bytes().0[..80],
        &[0u8; 80][..],
        "the root of no boxes"
    );
    let cam = camera_of(&scene);
    let hits = cpu_hits(&cam, |o, d| {
        two.closest_hit(two.to_local(o.as_dvec3()), d, 0.0, 1e30)
    });
    assert!(
        hits.iter().all(|h| h[0] < 0.0),
        "a point-sized instance was hit"
    );
}

/// Watertightness on the GPU: a plane of 48 × 48 quads, each split along
/// its diagonal (x − y constant), fills the view of a camera looking
/// straight at it from points off the grid's binary fractions, x = y (so
/// x − y of a hit is the pixel's offset): its pixels 1/32 apart on the
/// plane and the cells 1/16, so every other pixel centre is aimed at a
/// shared diagonal. The vertices lie on a 2^-4 grid (exact in any storage
/// of a triangle). Möller–Trumbore let such rays fall
/// through both triangles; the watertight test (rt_software.glsl
/// `intersect_triangle`) hits every pixel, on both software layouts, as
/// does its CPU twin, which finds the same depth.
#[test]
fn rays_at_shared_diagonals_hit_on_both_software_layouts() {
    use stereocache::scene::generate::{add_material, add_mesh, grid};
    use stereocache::scene::Material;
    let mut scene = Scene {
        source: "test:diagonals".into(),
        ..Default::default()
    };
    let m = add_material(&mut scene, Material::diffuse("plane", Vec3::ONE));
    let plane = grid(
        "plane",
        Vec3::new(-1.5, -1.5, 0.0),
        Vec3::X * 3.0,
        Vec3::Y * 3.0,
        48,
        48,
        Vec2::ONE,
    );
    add_mesh(&mut scene, plane, m, Mat4::IDENTITY);
    scene.validate().unwrap();
    let ctx = context();
    let mut report = Vec::new();
    for layout in [BvhLayout::Flattened, BvhLayout::TwoLevel] {
        let s = layout_session(&ctx, &scene, RtChoice::Software, layout);
        let origin = s.scene_gpu.origin;
        let flat = SoftwareBvh::build_at(&scene, origin);
        let two = TwoLevelBvh::build_at(&scene, origin);
        for e in [0.3f32, 0.1234, -0.271, 0.0071] {
            let mut cam = look_at_camera(Vec3::new(e, e, 1.0), Vec3::new(e, e, 0.0), 90.0, 1.0);
            cam.ipd = 0.0;
            let g = gpu_hits(&primary(&s, &cam));
            let c = cpu_hits(&cam, |o, d| match layout {
                BvhLayout::Flattened => flat.closest_hit(flat.to_local(o.as_dvec3()), d, 0.0, 1e30),
                _ => two.closest_hit(two.to_local(o.as_dvec3()), d, 0.0, 1e30),
            });
            let gpu_miss = g.iter().filter(|h| h[0] < 0.0).count();
            let cpu_miss = c.iter().filter(|h| h[0] < 0.0).count();
            // Ties on a diagonal may name either triangle (the CPU's camera
            // rays are the GPU's up to rounding); the depth is the plane's.
            let far = g
                .iter()
                .zip(&c)
                .filter(|(a, b)| (a[2] - b[2]).abs() > 1e-4 * a[2].abs().max(b[2].abs()))
                .count();
            if gpu_miss + cpu_miss + far > 0 {
                report.push(format!(
                    "{layout:?}, eye at x = y = {e}: {gpu_miss} GPU and {cpu_miss} CPU misses, {far} depths differ of {}",
                    g.len()
                ));
            }
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
    assert_no_validation_messages(&ctx);
}

/// A node scaled to zero along one axis (a static file's flat node, an
/// animated flip through 0): its linear part is singular, but its world
/// triangles are a flattened sphere, a disc of non-zero area, which the
/// flattened layout hits as they are. The two-level layout traced rays in
/// object space through the inverse (NaN: the disc was missed) and the
/// TLAS was handed the singular matrix, which Vulkan forbids
/// (VUID-VkTransformMatrixKHR-matrix-03799). Both now take the placement
/// made invertible (`scene::regularized_placement`: the linear part +
/// 2^-22·max|entry|·I, the same world triangles to a few ulps), so every
/// layout sees the disc on the same pixels and the same primitives (the
/// file's bar: ≤ 0.1 % of pixels differ), the CPU twins included, and the
/// disc covers far more than that bar. The sphere's material culls back
/// faces, so the two sheets of the disc (its upper and lower hemisphere)
/// are told apart by the placement's mirror sign; in the second pose
/// (turned 180° about z: diag(−1.5, 0, 1.5) before the tilt) the
/// regularized determinant is negative, and every layout must take the
/// same sheet.
#[test]
fn a_node_flattened_to_a_disc_is_hit_by_every_layout() {
    let ctx = context();
    let base = shipped("cornell");
    let sphere = base
        .instances
        .iter()
        .find(|i| i.name.to_lowercase().contains("sphere"))
        .expect("cornell has spheres")
        .clone();
    let c = sphere.transform.w_axis.truncate();
    for (pose, turn) in [
        ("tilted", 0.0f32),
        ("tilted, turned 180° about z", std::f32::consts::PI),
    ] {
        let mut scene = base.clone();
        let flat = Mat4::from_translation(Vec3::new(0.0, 0.35, 0.1))
            * Mat4::from_rotation_x(0.7)
            * Mat4::from_rotation_z(turn)
            * Mat4::from_scale(Vec3::new(1.5, 0.0, 1.5))
            * Mat4::from_translation(-c);
        let mut disc = sphere.clone();
        disc.name = "disc".into();
        disc.transform = flat * sphere.transform;
        assert_eq!(
            disc.transform.determinant(),
            0.0,
            "{pose}: a singular placement"
        );
        scene.instances.push(disc);
        scene.validate().unwrap();
        let disc_id = (scene.instances.len() - 1) as f32;
        let cam = camera_of(&scene);
        let flat_cpu = SoftwareBvh::build(&scene);
        let two_cpu = TwoLevelBvh::build_at(&scene, flat_cpu.origin);
        let a = cpu_hits(&cam, |o, d| {
            flat_cpu.closest_hit(flat_cpu.to_local(o.as_dvec3()), d, 0.0, 1e30)
        });
        let on_disc = a.iter().filter(|h| h[0] == disc_id).count();
        assert!(
            on_disc > a.len() / 50,
            "{pose}: the disc covers {on_disc} of {} pixels",
            a.len()
        );
        let b = cpu_hits(&cam, |o, d| {
            two_cpu.closest_hit(two_cpu.to_local(o.as_dvec3()), d, 0.0, 1e30)
        });
        assert_agree(&format!("{pose}: CPU flattened vs two-level"), &a, &b);
        let flat_gpu = layout_session(&ctx, &scene, RtChoice::Software, BvhLayout::Flattened);
        let gf = gpu_hits(&primary(&flat_gpu, &cam));
        assert_agree(&format!("{pose}: GPU flattened vs CPU"), &gf, &a);
        let two_gpu = layout_session(&ctx, &scene, RtChoice::Software, BvhLayout::TwoLevel);
        let g2 = gpu_hits(&primary(&two_gpu, &cam));
        assert_agree(&format!("{pose}: GPU two-level vs flattened"), &g2, &gf);
        if require(ctx.ray_query_enabled(), "ray queries (the TLAS's matrix)") {
            let rq = layout_session(&ctx, &scene, RtChoice::Query, BvhLayout::TwoLevel);
            let gq = gpu_hits(&primary(&rq, &cam));
            assert_agree(&format!("{pose}: ray query vs flattened"), &gq, &gf);
        }
    }
    assert_no_validation_messages(&ctx);
}
