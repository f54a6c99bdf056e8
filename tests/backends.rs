//! The two ray backends (ray query, software CWBVH) and a CPU traversal of
//! the same obvhs BVH agree on primary hits: instance and primitive on
//! ≥ 99.9 % of pixels, hit distance within 1e-4 relative.

mod common;
use common::*;
use glam::{UVec2, Vec2};
use std::path::Path;
use stereocache::camera::{Eye, StereoCamera};
use stereocache::methods::{RenderSettings, StereoFrame};
use stereocache::rt::{RtChoice, SoftwareBvh};
use stereocache::scene::Scene;
use stereocache::session::{CameraSelect, Session};

const W: u32 = 64;
const H: u32 = 64;

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

struct Agreement {
    pixels: usize,
    id_mismatch: usize,
    depth_mismatch: usize,
}

fn compare(a: &StereoFrame, b: &StereoFrame) -> Agreement {
    let mut r = Agreement {
        pixels: 0,
        id_mismatch: 0,
        depth_mismatch: 0,
    };
    for e in 0..2 {
        for i in 0..(W * H) as usize {
            let (ha, hb) = (a.eyes[e].first_hit[i], b.eyes[e].first_hit[i]);
            r.pixels += 1;
            if ha[2] != hb[2] || ha[3] != hb[3] {
                r.id_mismatch += 1;
            } else if ha[3] != u32::MAX {
                let (da, db) = (a.eyes[e].depth[i], b.eyes[e].depth[i]);
                if (da - db).abs() > 1e-4 * da.abs().max(db.abs()) {
                    r.depth_mismatch += 1;
                }
            }
        }
    }
    r
}

fn check_scene(name: &str, scene: Scene, cpu: bool) {
    let ctx = context();
    if !require(
        ctx.ray_query_enabled(),
        "ray queries (the backend compared against)",
    ) {
        return;
    }
    let sw = session(&ctx, scene.clone(), RtChoice::Software);
    let rq = session(&ctx, scene.clone(), RtChoice::Query);
    let cam = sw.camera(&CameraSelect::Default, W, H, None, None).unwrap();
    let fs = primary(&sw, &cam);
    let fq = primary(&rq, &cam);
    let hits = fs
        .eyes
        .iter()
        .flat_map(|e| &e.first_hit)
        .filter(|h| h[3] != u32::MAX)
        .count();
    assert!(
        hits > 100,
        "{name}: only {hits} pixels hit geometry; the camera sees nothing"
    );
    let agree = compare(&fs, &fq);
    let limit = agree.pixels / 1000; // 99.9 %
    assert!(
        agree.id_mismatch <= limit && agree.depth_mismatch <= limit,
        "{name}: software vs query: {} id and {} depth mismatches of {} pixels",
        agree.id_mismatch,
        agree.depth_mismatch,
        agree.pixels
    );
    if cpu {
        // The CPU walks the same CWBVH with the same triangle test; rays come
        // from the camera model's CPU twin of eye_ray_dir (camera.glsl).
        let bvh = SoftwareBvh::build(&scene);
        let (mut mismatch, mut n) = (0usize, 0usize);
        for (e, eye) in Eye::BOTH.iter().enumerate() {
            let v = cam.eye(*eye);
            for y in 0..H {
                for x in 0..W {
                    let i = (y * W + x) as usize;
                    let d = v
                        .ray_direction(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), UVec2::new(W, H));
                    let hit = bvh.closest_hit(v.position, d, 0.0, 1e30);
                    let g = fs.eyes[e].first_hit[i];
                    n += 1;
                    match hit {
                        Some(h) => {
                            if h.instance != g[3] || h.prim != g[2] {
                                mismatch += 1;
                            } else {
                                let depth = h.t * d.dot(v.orientation * glam::Vec3::NEG_Z);
                                let gd = fs.eyes[e].depth[i];
                                if (depth - gd).abs() > 1e-4 * depth.abs() {
                                    mismatch += 1;
                                }
                            }
                        }
                        None => mismatch += (g[3] != u32::MAX) as usize,
                    }
                }
            }
        }
        assert!(
            mismatch <= n / 1000,
            "{name}: CPU vs GPU software traversal: {mismatch} of {n} pixels differ"
        );
    }
    assert_no_validation_messages(&ctx);
}

#[test]
fn cornell_backends_agree() {
    check_scene("cornell", shipped("cornell"), true);
}

#[test]
fn hairball_backends_agree() {
    check_scene("hairball", shipped("hairball"), true);
}

#[test]
fn plane_backends_agree() {
    check_scene("plane", shipped("plane"), true);
}

#[test]
fn shipped_gltf_files_agree_with_generated() {
    // The files in scenes/ load and trace the same as the generators.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell/cornell.gltf");
    check_scene(
        "scenes/cornell/cornell.gltf",
        shipped(dir.to_str().unwrap()),
        true,
    );
}

/// Sponza has alpha-masked foliage: the two GPU backends alpha-test the same
/// way; the CPU traversal has no alpha test, so it is not compared here.
#[test]
fn sponza_backends_agree() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/sponza/Sponza.gltf");
    if !require_file(&path) {
        return;
    }
    check_scene("sponza", shipped(path.to_str().unwrap()), false);
}

/// Triangles of zero area (here: 5,000 instances of the plane scaled to a
/// point) are never hit, so the software BVHs leave them out: the render
/// is bit for bit the plain scene's, where kept in they chained the
/// flattened BVH past the traversal stack (an error: "8190 levels deep"),
/// and the two-level TLAS keeps no box of them either.
#[test]
fn zero_area_triangles_change_no_pixel() {
    let plain = shipped("plane");
    let mut crowded = plain.clone();
    let first = crowded.instances[0].clone();
    for k in 0..5000 {
        crowded.instances.push(stereocache::scene::Instance {
            transform: glam::Mat4::from_translation(glam::Vec3::new(0.1, 0.2, 0.3))
                * glam::Mat4::from_scale(glam::Vec3::ZERO),
            name: format!("point {k}"),
            ..first.clone()
        });
    }
    crowded.validate().expect("other triangles are hittable");
    let ctx = context();
    let frame = |scene: Scene| {
        let s = session(&ctx, scene, RtChoice::Software);
        let cam = default_camera(&s, W, H);
        primary(&s, &cam)
    };
    let (a, b) = (frame(plain), frame(crowded.clone()));
    for e in 0..2 {
        assert!(
            a.eyes[e].first_hit == b.eyes[e].first_hit,
            "eye {e}: first hits differ"
        );
        let bits = |f: &StereoFrame| -> Vec<[u32; 4]> {
            f.eyes[e]
                .radiance
                .iter()
                .map(|p| p.map(f32::to_bits))
                .collect()
        };
        assert!(bits(&a) == bits(&b), "eye {e}: radiance differs");
    }
    let two = stereocache::rt::TwoLevelBvh::build_at(&crowded, glam::DVec3::ZERO);
    assert!(
        two.max_depth < stereocache::rt::TRAVERSAL_STACK_SIZE,
        "two-level depth {}",
        two.max_depth
    );
    assert_no_validation_messages(&ctx);
}
