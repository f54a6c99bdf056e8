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
fn check_invariants(
    snap: &CacheSnapshot,
    cam: &StereoCamera,
    bvh: &SoftwareBvh,
) -> (usize, usize, usize) {
    let (w, h) = (snap.width, snap.height);
    let (mut visible, mut mismatched, mut uncovered) = (0usize, 0usize, 0usize);
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
                uncovered += 1;
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
    (visible, mismatched, uncovered)
}

/// True when a 5×5 grid of rays over the pixel all hit geometry (a CPU
/// stand-in for "geometry covers the whole pixel").
fn fully_covered(
    bvh: &SoftwareBvh,
    v: &stereocache::camera::EyeView,
    pixel: usize,
    w: u32,
    h: u32,
) -> bool {
    let c = pixel_centre(pixel, w) - Vec2::splat(0.5);
    (0..25).all(|k| {
        let o = Vec2::new((k % 5) as f32 * 0.245 + 0.01, (k / 5) as f32 * 0.245 + 0.01);
        bvh.closest_hit(
            v.position,
            v.ray_direction(c + o, UVec2::new(w, h)),
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

/// Runs `frames` frames of a turning, drifting head and checks the invariants
/// after every frame; returns (visible samples, stale ones, retrace rays).
fn run_moving(
    scene: &str,
    retrace: Retrace,
    frames: u32,
    deg_per_frame: f32,
) -> (usize, usize, u64) {
    let ctx = context();
    let s = session(&ctx, shipped(scene), RtChoice::Software);
    let cs = SampleCacheSettings {
        retrace,
        ..Default::default()
    };
    let (w, h) = (48, 36);
    let mut m = cache_method(&s, &settings(w, h, cs));
    let cam0 = s.camera(&CameraSelect::Default, w, h, None, None).unwrap();
    let bvh = SoftwareBvh::build(&s.scene);
    let (mut visible, mut stale, mut rays) = (0, 0, 0u64);
    let mut prev = None;
    for f in 0..frames {
        let cam = moving(&cam0, f, deg_per_frame);
        let frame = m
            .render_frame(&FrameInput {
                index: f,
                camera: cam,
                prev_camera: prev,
            })
            .unwrap();
        prev = Some(cam);
        assert!(
            frame
                .eyes
                .iter()
                .flat_map(|e| &e.radiance)
                .all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)),
            "non-finite output"
        );
        let snap = m.snapshot().unwrap();
        let (v, bad, uncovered) = check_invariants(&snap, &cam, &bvh);
        // A pixel that geometry covers keeps a visible sample. On solid
        // surfaces this is exact; between thin hairball tubes a fresh sample
        // can still fall through a gap the 25 probes missed (≤ 1 % of pixels).
        let limit = if scene == "hairball" {
            snap.npix() * 2 / 100
        } else {
            0
        };
        assert!(
            uncovered <= limit,
            "frame {f}: {uncovered} covered pixels without a visible sample"
        );
        let (checked, outside) = check_density(&snap, m.settings());
        // Thin hairball tubes cover pixels only partly (new samples miss), so
        // the density band is asserted where surfaces cover whole neighbourhoods.
        assert!(
            scene == "hairball" || outside * 20 <= checked,
            "frame {f}: 3×3 density outside n_target ± δ at {outside} of {checked} pixels"
        );
        if f > 0 {
            visible += v;
            stale += bad;
            rays += frame.stats.counters["retrace_rays"] as u64;
        }
    }
    assert_no_validation_messages(&ctx);
    (visible, stale, rays)
}

/// Density control acts on the 3×3 average of visible samples per pixel:
/// where a pixel's whole neighbourhood is covered by geometry, that average
/// ends the frame inside n_target ± δ (adds reach n_target at once; purges
/// remove one sample per frame, so a strong convergence of samples may take
/// a few frames). Returns (pixels checked, pixels outside the band).
fn check_density(snap: &CacheSnapshot, cs: &SampleCacheSettings) -> (usize, usize) {
    let (w, h) = (snap.width as i64, snap.height as i64);
    let (mut checked, mut outside) = (0, 0);
    for e in 0..2 {
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let mut sum = 0;
                let mut covered = true;
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let n = snap
                            .visible(snap.mask(e, ((y + dy) * w + x + dx) as usize))
                            .count_ones();
                        assert!(n <= cs.slots);
                        covered &= n > 0;
                        sum += n;
                    }
                }
                if !covered {
                    continue;
                }
                checked += 1;
                let avg = sum as f32 / 9.0;
                if avg < (cs.n_target - cs.delta) as f32 || avg > (cs.n_target + cs.delta) as f32 {
                    outside += 1;
                }
            }
        }
    }
    (checked, outside)
}

#[test]
fn invariants_hold_on_a_moving_trace_cornell() {
    let mut rays = std::collections::BTreeMap::new();
    for retrace in [Retrace::Single, Retrace::Multi, Retrace::Adaptive] {
        let (visible, stale, r) = run_moving("cornell", retrace, 8, 1.5);
        eprintln!("cornell {retrace:?}: {stale} stale of {visible} visible, {r} retrace rays");
        assert!(visible > 10_000);
        assert!(stale as f64 <= 0.01 * visible as f64);
        rays.insert(format!("{retrace:?}"), r);
    }
    // On surfaces with few edges adaptive retracing is a small fraction of multi (measured 0.12×).
    assert!(rays["Adaptive"] * 4 < rays["Multi"], "{rays:?}");
}

/// Stale visibility (visible samples that a fresh ray does not reach) per
/// retrace mode on the hairball, the hard case for edges: multi retraces
/// everything, adaptive stays within 1.5× of multi's mismatch rate while
/// tracing far fewer rays, single lags clearly behind.
#[test]
fn retrace_modes_on_the_hairball() {
    let mut rate = std::collections::BTreeMap::new();
    let mut rays = std::collections::BTreeMap::new();
    for retrace in [Retrace::Multi, Retrace::Adaptive, Retrace::Single] {
        let (visible, stale, r) = run_moving("hairball", retrace, 8, 2.0);
        let k = format!("{retrace:?}");
        rate.insert(k.clone(), stale as f64 / visible as f64);
        rays.insert(k, r);
    }
    eprintln!("stale rates {rate:?}, retrace rays {rays:?}");
    let (multi, adaptive, single) = (rate["Multi"], rate["Adaptive"], rate["Single"]);
    // Multi retraces every sample every frame, so its stale rate is the float
    // floor between GPU and CPU traversal (measured 0). Adaptive may miss a
    // visibility change outside the flagged neighbourhoods for a frame:
    // its budget is 1 % of samples (measured 0.14 %), i.e. within 1.5× of
    // multi plus that budget; single round robin lags an order of magnitude
    // behind (measured 3.7 %).
    assert!(multi <= 1e-3, "multi {multi:.5}");
    assert!(
        adaptive <= 1.5 * multi + 0.01,
        "adaptive {adaptive:.5} vs multi {multi:.5}"
    );
    assert!(
        single > 10.0 * adaptive.max(1e-4),
        "single {single:.5} should lag adaptive {adaptive:.5}"
    );
    // Nearly every hairball pixel at 48×36 is an edge, so adaptive may trace
    // almost as much as multi here, never more.
    assert!(
        rays["Adaptive"] <= rays["Multi"],
        "adaptive traced {} vs multi's {} rays",
        rays["Adaptive"],
        rays["Multi"]
    );
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
