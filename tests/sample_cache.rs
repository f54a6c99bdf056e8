//! The sample cache's invariants, read back from the GPU after every frame of
//! moving traces, and its convergence, dispatch and reprojection variants.

mod common;
use common::*;
use glam::{Quat, UVec2, Vec2, Vec3};
use stereocache::camera::{Eye, StereoCamera};
use stereocache::methods::sample_cache::{
    CacheSnapshot, Reproject, Retrace, SampleCache, SampleCacheSettings, Shading,
};
use stereocache::methods::{FrameInput, Method, RenderSettings};
use stereocache::rt::{RtChoice, SoftwareBvh};
use stereocache::scene::{apply_default_lighting, load_scene, DefaultLighting, Scene};
use stereocache::session::{CameraSelect, Session};

fn shipped(name: &str) -> Scene {
    let mut s = load_scene(name).unwrap();
    apply_default_lighting(&mut s, &DefaultLighting::default()).unwrap();
    s
}

fn settings(w: u32, h: u32, cache: SampleCacheSettings) -> RenderSettings {
    RenderSettings {
        width: w,
        height: h,
        spp: 1,
        max_bounces: 2,
        seed: 5,
        all_features: false,
        cache,
    }
}

fn cache_method(s: &Session, st: &RenderSettings) -> SampleCache {
    SampleCache::new(&s.ctx, &s.scene_gpu, &s.scene.environment, st).expect("sample cache")
}

/// A head turning about +Y by `deg_per_frame` and drifting sideways.
fn moving(start: &StereoCamera, frame: u32, deg_per_frame: f32) -> StereoCamera {
    let mut c = *start;
    let yaw = Quat::from_rotation_y((deg_per_frame * frame as f32).to_radians());
    c.head.orientation = (start.head.orientation * yaw).normalize();
    c.head.position =
        start.head.position + start.head.orientation * Vec3::new(0.004 * frame as f32, 0.0, 0.0);
    c
}

/// Checks the structural invariants and returns the fraction of visible
/// samples whose stored hit differs from a fresh primary ray's hit.
fn check_invariants(snap: &CacheSnapshot, cam: &StereoCamera, bvh: &SoftwareBvh) -> (usize, usize) {
    let (w, h) = (snap.width, snap.height);
    let (mut visible, mut mismatched) = (0usize, 0usize);
    for (e, eye) in Eye::BOTH.iter().enumerate() {
        let v = cam.eye(*eye);
        for pixel in 0..snap.npix() {
            let m = snap.mask(e, pixel);
            let (occ, vis) = (snap.occupied(m), snap.visible(m));
            assert_eq!(
                vis & !occ,
                0,
                "eye {e} pixel {pixel}: visible bit without occupancy (mask {m:#x})"
            );
            assert_eq!(m >> (2 * snap.slots), 0, "mask bits above 2N set");
            if vis == 0 && fully_covered(bvh, &v, pixel, w, h) {
                panic!("eye {e} pixel {pixel}: no visible sample although geometry covers the whole pixel");
            }
            let mut bits = vis;
            while bits != 0 {
                let s = bits.trailing_zeros();
                bits &= bits - 1;
                let fh = snap.first_hits[snap.slot(e, s, pixel)];
                assert_ne!(fh[3], u32::MAX, "visible sample without a first hit");
                // Where does the stored sample lie, and what does a fresh ray towards it hit?
                let p = stored_position(bvh, fh);
                let d = (p - v.position).normalize();
                visible += 1;
                match bvh.closest_hit(v.position, d, 0.0, 1e30) {
                    Some(hit) if hit.instance == fh[3] && hit.prim == fh[2] => {}
                    Some(hit) if (hit.t - (p - v.position).length()).abs() <= 1e-3 * hit.t => {}
                    _ => mismatched += 1,
                }
                // The sample projects into its own pixel.
                if let Some((q, _)) = v.project(p, UVec2::new(w, h)) {
                    let qp = (q.y.floor() as i64) * w as i64 + q.x.floor() as i64;
                    assert!(
                        qp == pixel as i64
                            || (q - pixel_centre(pixel, w)).abs().max_element() < 1.0 + 1e-3,
                        "sample outside its pixel"
                    );
                }
            }
        }
    }
    (visible, mismatched)
}

/// True when rays through the centre and the four corners of the pixel all hit geometry.
fn fully_covered(
    bvh: &SoftwareBvh,
    v: &stereocache::camera::EyeView,
    pixel: usize,
    w: u32,
    h: u32,
) -> bool {
    let c = pixel_centre(pixel, w);
    [
        Vec2::ZERO,
        Vec2::new(-0.49, -0.49),
        Vec2::new(0.49, -0.49),
        Vec2::new(-0.49, 0.49),
        Vec2::new(0.49, 0.49),
    ]
    .iter()
    .all(|o| {
        bvh.closest_hit(
            v.position,
            v.ray_direction(c + *o, UVec2::new(w, h)),
            0.0,
            1e30,
        )
        .is_some()
    })
}

fn pixel_centre(pixel: usize, w: u32) -> Vec2 {
    Vec2::new(
        (pixel as u32 % w) as f32 + 0.5,
        (pixel as u32 / w) as f32 + 0.5,
    )
}

/// World position of a stored first hit, from the software BVH's triangle data.
fn stored_position(bvh: &SoftwareBvh, fh: [u32; 4]) -> Vec3 {
    let k = bvh
        .tri_ref
        .iter()
        .position(|r| r[0] == fh[3] && r[1] == fh[2])
        .expect("stored triangle exists");
    let v = &bvh.tri_verts[3 * k..3 * k + 3];
    let (v0, e1, e2) = (
        Vec3::from_slice(&v[0][..3]),
        Vec3::from_slice(&v[1][..3]),
        Vec3::from_slice(&v[2][..3]),
    );
    let b = Vec2::new((fh[0] & 0xFF_FFFF) as f32, (fh[1] & 0xFF_FFFF) as f32) / 16_777_215.0;
    v0 + b.x * e1 + b.y * e2
}

#[test]
fn smoke_frames_run_clean() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let st = settings(32, 24, SampleCacheSettings::default());
    let mut m = cache_method(&s, &st);
    let cam0 = s
        .camera(&CameraSelect::Default, 32, 24, None, None)
        .unwrap();
    let bvh = SoftwareBvh::build(&s.scene);
    let mut prev = None;
    for f in 0..6 {
        let cam = moving(&cam0, f, 1.0);
        let frame = m
            .render_frame(&FrameInput {
                index: f,
                camera: cam,
                prev_camera: prev,
            })
            .unwrap();
        prev = Some(cam);
        eprintln!(
            "frame {f}: {:?} rays {:?}",
            frame.stats.counters, frame.stats.rays
        );
        let snap = m.snapshot().unwrap();
        let (vis, bad) = check_invariants(&snap, &cam, &bvh);
        eprintln!("  visible {vis}, mismatched {bad}");
        assert!(frame
            .eyes
            .iter()
            .flat_map(|e| &e.radiance)
            .all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
    }
    assert_no_validation_messages(&ctx);
}

#[test]
#[ignore]
fn dump_debug_views() {
    let ctx = context();
    for name in ["cornell", "plane"] {
        let s = session(&ctx, shipped(name), RtChoice::Software);
        let mut cs = SampleCacheSettings::default();
        cs.debug_views = true;
        let st = settings(128, 96, cs);
        let mut m = cache_method(&s, &st);
        let cam = s
            .camera(&CameraSelect::Default, 128, 96, None, None)
            .unwrap();
        let mut last = None;
        for f in 0..4 {
            last = Some(
                m.render_frame(&FrameInput {
                    index: f,
                    camera: cam,
                    prev_camera: Some(cam),
                })
                .unwrap(),
            );
        }
        let fr = last.unwrap();
        eprintln!("{name}: {:?}", fr.stats.counters);
        for (v, img) in &fr.eyes[0].debug {
            stereocache::output::write_png(
                std::path::Path::new(&format!("/tmp/dbg_{name}_{v}.png")),
                128,
                96,
                img,
                1.0,
            )
            .unwrap();
        }
        stereocache::output::write_png(
            std::path::Path::new(&format!("/tmp/dbg_{name}_color.png")),
            128,
            96,
            &fr.eyes[0].radiance,
            1.0,
        )
        .unwrap();
    }
}
