//! Numerical stability under stress (issue 7): scenes far from the origin
//! and at extreme scales, grazing views, degenerate triangles, long runs, and
//! the precision of the packed barycentrics. Figures: `docs/ROBUSTNESS.md`.

mod common;
use common::*;
use glam::{Mat4, Quat, Vec2, Vec3};
use stereocache::camera::{Eye, StereoCamera};
use stereocache::methods::sample_cache::{
    CacheSnapshot, Retrace, SampleCache, SampleCacheSettings,
};
use stereocache::methods::{RenderSettings, StereoFrame};
use stereocache::rt::{RtChoice, SoftwareBvh};
use stereocache::scene::{Environment, Material, Mesh, Scene};
use stereocache::session::{CameraSelect, Session};

/// `world' = scale · world + offset` applied to every instance, light and camera.
fn transformed(mut s: Scene, scale: f32, offset: Vec3) -> Scene {
    let m = Mat4::from_translation(offset) * Mat4::from_scale(Vec3::splat(scale));
    for i in &mut s.instances {
        i.transform = m * i.transform;
    }
    for l in &mut s.lights {
        l.position = m.transform_point3(l.position);
        l.range = l.range.map(|r| r * scale);
    }
    for c in &mut s.cameras {
        let (_, r, t) = c.transform.to_scale_rotation_translation();
        c.transform = Mat4::from_rotation_translation(r, m.transform_point3(t));
        c.znear *= scale;
    }
    s
}

fn camera_transformed(c: &StereoCamera, scale: f32, offset: Vec3) -> StereoCamera {
    let mut c = *c;
    c.anchor = c.anchor * scale as f64 + offset.as_dvec3();
    c.head.position *= scale;
    c.ipd *= scale;
    c.znear *= scale;
    c
}

fn settings(w: u32, h: u32, cache: SampleCacheSettings) -> CacheSetup {
    cache_settings(w, h, cache, 5)
}

fn moving(start: &StereoCamera, frame: u32, deg_per_frame: f32, drift: f32) -> StereoCamera {
    turning_head(start, frame, deg_per_frame, drift)
}

fn all_finite(f: &StereoFrame) -> bool {
    f.eyes.iter().all(|e| {
        e.radiance.iter().all(|p| p.iter().all(|c| c.is_finite()))
            && e.depth.iter().all(|d| d.is_finite())
            && e.albedo.iter().all(|p| p.iter().all(|c| c.is_finite()))
    })
}

fn snapshot_finite(s: &CacheSnapshot) -> bool {
    s.radiance.iter().all(|r| r.iter().all(|c| c.is_finite()))
}

/// Fraction of pixels (both eyes) where software and query backends agree
/// on the primary hit's instance and primitive, and the number of hits.
fn backend_agreement(
    sw: &Session,
    rq: Option<&Session>,
    cam: &StereoCamera,
) -> Option<(f64, usize)> {
    let rq = rq?;
    let st = RenderSettings {
        width: 48,
        height: 36,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    let (a, b) = (
        render(sw, "reference", *cam, &st),
        render(rq, "reference", *cam, &st),
    );
    let (mut same, mut n, mut hits) = (0, 0, 0);
    for e in 0..2 {
        for (ha, hb) in a.eyes[e].first_hit.iter().zip(&b.eyes[e].first_hit) {
            n += 1;
            hits += (ha[3] != u32::MAX) as usize;
            same += (ha[2] == hb[2] && ha[3] == hb[3]) as usize;
        }
    }
    Some((same as f64 / n as f64, hits))
}

/// Stale visible samples (a fresh CPU ray does not reach the stored hit) and
/// visible samples, accumulated over frames 1.. of a moving run; plus the
/// number of covered pixels left without a visible sample (of `pixels`).
struct CacheRun {
    visible: usize,
    stale: usize,
    uncovered: usize,
    pixels: usize,
    finite: bool,
}

fn cache_run(s: &Session, cam0: &StereoCamera, frames: u32, drift: f32, rel_eps: f32) -> CacheRun {
    let (w, h) = (32, 24);
    let st = settings(w, h, SampleCacheSettings::default());
    let mut m =
        SampleCache::new(&s.ctx, &s.scene_gpu, &s.scene.environment, &st, &st.cache).unwrap();
    let bvh = SoftwareBvh::build(&s.scene);
    let mut r = CacheRun {
        visible: 0,
        stale: 0,
        uncovered: 0,
        pixels: 0,
        finite: true,
    };
    let mut prev = None;
    for f in 0..frames {
        let cam = moving(cam0, f, 1.5, drift);
        let frame = render_at(&mut m, f, cam, prev);
        prev = Some(cam);
        let snap = m.snapshot().unwrap();
        r.finite &= all_finite(&frame) && snapshot_finite(&snap);
        if f == 0 {
            continue;
        }
        for (e, eye) in Eye::BOTH.iter().enumerate() {
            let v = cam.eye(*eye);
            // Rays in the BVH's frame: the eye relative to the render origin.
            let eye_pos = bvh.to_local(v.world);
            for pixel in 0..snap.npix() {
                r.pixels += 1;
                let vis = snap.visible(snap.mask(e, pixel));
                // Covered: a visible surface sample (background samples,
                // rays that missed the scene, issue 12, do not count).
                if snap.surface(e, pixel, vis) == 0 && fully_covered(&bvh, &v, pixel, w, h) {
                    r.uncovered += 1;
                }
                let mut bits = vis;
                while bits != 0 {
                    let slot = bits.trailing_zeros();
                    bits &= bits - 1;
                    let fh = snap.first_hits[snap.slot(e, slot, pixel)];
                    // A visible background sample is stale when a fresh ray
                    // in its direction hits the scene.
                    if let Some(d) =
                        stereocache::methods::sample_cache::background::background_direction(fh)
                    {
                        r.visible += 1;
                        if bvh.closest_hit(eye_pos, d, 0.0, 1e30).is_some() {
                            r.stale += 1;
                        }
                        continue;
                    }
                    let p = stored_position(&bvh, fh);
                    let d = (p - eye_pos).normalize();
                    r.visible += 1;
                    match bvh.closest_hit(eye_pos, d, 0.0, 1e30) {
                        Some(hit) if hit.instance == fh[3] && hit.prim == fh[2] => {}
                        Some(hit) if (hit.t - (p - eye_pos).length()).abs() <= rel_eps * hit.t => {}
                        _ => r.stale += 1,
                    }
                }
            }
        }
    }
    r
}

/// Mean per-pixel squared error (and its standard error) of the sample
/// cache after 8 frames of a still view against the scene's own 128 spp
/// reference.
fn error_against_reference(s: &Session, cam: &StereoCamera) -> (f64, f64) {
    let (w, h) = (32, 24);
    let reference = reference_frame(s, *cam, w, h, 128);
    let mut st = settings(w, h, SampleCacheSettings::default());
    st.max_bounces = 2;
    let mut m = s.create(st.config(), &st).unwrap();
    let mut last = None;
    for f in 0..8 {
        last = Some(render_at(m.as_mut(), f, *cam, Some(*cam)));
    }
    mean_and_standard_error(&squared_errors(&last.unwrap(), &reference))
}

/// Everything measured for one scene under `scale · x + offset`.
struct Stress {
    agree: Option<f64>,
    stale: f64,
    /// Stale and visible samples counted (stale = their ratio).
    stale_counts: (usize, usize),
    uncovered: f64,
    finite: bool,
    mse: (f64, f64),
}

fn measure(base: &Scene, cam0: &StereoCamera, scale: f32, offset: Vec3) -> Stress {
    let ctx = context();
    let scene = transformed(base.clone(), scale, offset);
    let cam = camera_transformed(cam0, scale, offset);
    let sw = session(&ctx, scene.clone(), RtChoice::Software);
    let rq = require(ctx.ray_query_enabled(), "ray queries (backend agreement)")
        .then(|| session(&ctx, scene, RtChoice::Query));
    let agree = backend_agreement(&sw, rq.as_ref(), &cam).map(|(a, hits)| {
        assert!(hits > 500, "camera sees nothing ({hits} hits)");
        a
    });
    let r = cache_run(&sw, &cam, 5, 0.004 * scale, 1e-3);
    let mse = error_against_reference(&sw, &cam);
    assert_no_validation_messages(&ctx);
    let m = Stress {
        agree,
        stale: r.stale as f64 / r.visible.max(1) as f64,
        stale_counts: (r.stale, r.visible),
        uncovered: r.uncovered as f64 / r.pixels.max(1) as f64,
        finite: r.finite,
        mse,
    };
    eprintln!(
        "{} scale {scale:e} offset {:e} (origin {}): backends agree {:?}, stale {}/{} = {:.4}, uncovered {:.4}, finite {}, MSE {:.4e} ± {:.1e}",
        base.source.display(),
        offset.x,
        sw.scene_gpu.origin,
        m.agree,
        r.stale,
        r.visible,
        m.stale,
        m.uncovered,
        m.finite,
        m.mse.0,
        m.mse.1
    );
    m
}

/// The bounds of tests/backends.rs and tests/sample_cache.rs, and the same
/// error against the scene's own reference as at the origin: the two means
/// may differ by 4 standard errors of their difference (each from its
/// pixel count), no more.
fn assert_like_origin(what: &str, m: &Stress, at_origin: &Stress, uncovered_budget: f64) {
    assert!(m.finite, "{what}: non-finite output or cache radiance");
    if let Some(a) = m.agree {
        assert!(
            a >= 0.99,
            "{what}: backends agree on {:.2} % of pixels",
            100.0 * a
        );
    }
    assert!(m.stale <= 0.01, "{what}: stale fraction {:.4}", m.stale);
    // And as many stale samples as at the origin (measured 9 of 25 368 on
    // the Cornell box, 46 of 24 042 on the hairball there): the counts are
    // Poisson-like, so they may differ by 4 standard deviations of the
    // difference of two independent counts, √(k + k0) (conservative: the
    // runs share their samples), plus one where both are 0.
    let ((k, n), (k0, n0)) = (m.stale_counts, at_origin.stale_counts);
    let expected = k0 as f64 * n as f64 / n0.max(1) as f64;
    assert!(
        (k as f64 - expected).abs() <= 4.0 * ((k + k0) as f64).sqrt() + 1.0,
        "{what}: {k} stale of {n} samples, {k0} of {n0} at the origin"
    );
    assert!(
        m.uncovered <= uncovered_budget,
        "{what}: {:.4} of pixels covered but without a visible sample",
        m.uncovered
    );
    let (e, se) = m.mse;
    let (e0, se0) = at_origin.mse;
    let bound = 4.0 * (se * se + se0 * se0).sqrt();
    assert!(
        (e - e0).abs() <= bound,
        "{what}: MSE {e:.4e} against its reference, {e0:.4e} at the origin (bound {bound:.1e})"
    );
}

/// The scene translated by (o, o, −o) for o = 1e3, 1e5, 1e6 m and scaled by
/// 1e-3 and 1e4, against the same scene at the origin.
fn stress_scene(name: &str, uncovered_budget: f64) {
    let base = shipped(name);
    let cam0 = {
        let ctx = context();
        let s0 = session(&ctx, base.clone(), RtChoice::Software);
        s0.camera(&CameraSelect::Default, 32, 24, None, None)
            .unwrap()
    };
    let at_origin = measure(&base, &cam0, 1.0, Vec3::ZERO);
    assert_like_origin(
        &format!("{name} at the origin"),
        &at_origin,
        &at_origin,
        uncovered_budget,
    );
    for o in [1e3f32, 1e5, 1e6] {
        let m = measure(&base, &cam0, 1.0, Vec3::new(o, o, -o));
        assert_like_origin(
            &format!("{name} offset {o:e}"),
            &m,
            &at_origin,
            uncovered_budget,
        );
    }
    for k in [1e-3f32, 1e4] {
        let m = measure(&base, &cam0, k, Vec3::ZERO);
        assert_like_origin(
            &format!("{name} scale {k:e}"),
            &m,
            &at_origin,
            uncovered_budget,
        );
    }
}

#[test]
fn cornell_far_from_origin_and_scaled() {
    stress_scene("cornell", 0.0);
}

/// Hairball: 25 probe rays cannot prove every pixel between strands covered,
/// so up to 1 % of pixels may lack a visible sample (tests/sample_cache.rs).
#[test]
fn hairball_far_from_origin_and_scaled() {
    stress_scene("hairball", 0.01);
}

/// A large plane seen from 1 m above with the view level: rows near the
/// horizon see the plane at up to ≈ 89.95° from its normal. Eq. 1's slope
/// term must stay bounded and adaptive retracing must not flag the plane.
#[test]
fn grazing_plane_adaptive_retrace() {
    let ctx = context();
    let scene = plane_in_environment(
        Material {
            base_color: glam::Vec4::new(0.6, 0.6, 0.6, 1.0),
            ..Default::default()
        },
        4000.0,
        Vec3::splat(0.5),
    );
    let s = session(&ctx, scene, RtChoice::Software);
    let (w, h) = (64, 48);
    let cs = SampleCacheSettings {
        retrace: Retrace::Adaptive,
        ..Default::default()
    };
    let st = settings(w, h, cs);
    let mut m =
        SampleCache::new(&s.ctx, &s.scene_gpu, &s.scene.environment, &st, &st.cache).unwrap();
    // Eye 1 m above the plane, looking level along −Z: the horizon is the
    // middle row; the farthest plane point (2000 m) is at atan(2000) = 89.97°.
    let cam0 = look_at_camera(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, -10.0),
        60.0,
        w as f32 / h as f32,
    );
    let (mut edge, mut retrace, mut plane_px) = (0.0, 0.0, 0usize);
    let mut prev = None;
    let frames = 6;
    for f in 0..frames {
        let cam = moving(&cam0, f, 0.5, 0.004);
        let fr = render_at(&mut m, f, cam, prev);
        prev = Some(cam);
        assert!(all_finite(&fr), "frame {f}: non-finite output");
        let snap = m.snapshot().unwrap();
        assert!(snapshot_finite(&snap));
        if f > 0 {
            edge += fr.stats.counters["edge_pixels"];
            retrace += fr.stats.counters["retrace_rays"];
            plane_px += fr
                .eyes
                .iter()
                .flat_map(|e| &e.first_hit)
                .filter(|h| h[3] != u32::MAX)
                .count();
        }
    }
    let edge_frac = edge / plane_px as f64;
    let retrace_frac = retrace / plane_px as f64;
    eprintln!(
        "grazing plane: {plane_px} plane pixels over {} frames, edge pixels {edge} ({:.3} of plane pixels), retrace rays {retrace} ({:.3} per plane pixel)",
        frames - 1,
        edge_frac,
        retrace_frac
    );
    assert!(plane_px > 1000);
    // Measured 0.22 (and 0.98 retrace rays per plane pixel): far from the
    // whole plane, but not small either; see docs/ROBUSTNESS.md. This bound
    // guards against a regression to "every grazing pixel is an edge".
    assert!(edge_frac < 0.3, "edge fraction {edge_frac:.3}");
    assert_no_validation_messages(&ctx);
}

/// Zero-area triangles (collinear and coincident vertices), needles and
/// duplicated vertices next to a normal quad: no NaN/Inf anywhere.
#[test]
fn degenerate_triangles_stay_finite() {
    let mut s = Scene {
        source: "test:degenerate".into(),
        ..Default::default()
    };
    let mat = stereocache::scene::generate::add_material(&mut s, Material::default());
    let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let positions = vec![
        // A proper quad (two triangles) facing +Z.
        p(-1.0, -1.0, 0.0),
        p(1.0, -1.0, 0.0),
        p(1.0, 1.0, 0.0),
        p(-1.0, 1.0, 0.0),
        // Coincident vertices (zero area, zero edges).
        p(0.2, 0.2, 0.1),
        p(0.2, 0.2, 0.1),
        p(0.2, 0.2, 0.1),
        // Collinear vertices (zero area, non-zero edges).
        p(-0.5, 0.0, 0.2),
        p(0.0, 0.0, 0.2),
        p(0.5, 0.0, 0.2),
        // Needles: 2 m long, 1e-7 m wide, one facing the camera.
        p(-1.0, 0.5, 0.3),
        p(1.0, 0.5, 0.3),
        p(1.0, 0.5 + 1e-7, 0.3),
        p(0.0, -0.9, 0.3),
        p(0.0, 0.9, 0.3),
        p(1e-7, 0.9, 0.3),
        // Duplicated quad vertices (same positions as 0..4).
        p(-1.0, -1.0, 0.0),
        p(1.0, -1.0, 0.0),
        p(1.0, 1.0, 0.0),
    ];
    let indices = vec![
        0, 1, 2, 0, 2, 3, 4, 5, 6, 7, 8, 9, 9, 8, 7, 10, 11, 12, 13, 14, 15, 16, 17, 18, 0, 0, 0,
        1, 1, 2,
    ];
    let n = positions.len();
    let mesh = Mesh {
        name: "degenerate".into(),
        normals: stereocache::scene::mesh_ops::generate_normals(&positions, &indices),
        positions,
        uvs: vec![Vec2::ZERO; n],
        tangents: Vec::new(),
        colors: Vec::new(),
        indices,
        material: 0,
        ..Default::default()
    };
    stereocache::scene::generate::add_mesh(&mut s, mesh, mat, Mat4::IDENTITY);
    s.environment = Some(Environment::Constant(Vec3::splat(0.8)));
    s.validate().unwrap();
    for n in &s.meshes[0].normals {
        assert!(n.is_finite(), "generated normal {n}");
    }
    let ctx = context();
    let (w, h) = (32, 24);
    let cam = look_at_camera(
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::ZERO,
        50.0,
        w as f32 / h as f32,
    );
    for rt in [RtChoice::Software, RtChoice::Query] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let sess = session(&ctx, s.clone(), rt);
        let mut st = settings(w, h, SampleCacheSettings::default());
        st.spp = 4;
        st.max_bounces = 3;
        let fr = render(&sess, "reference", cam, &st);
        assert!(all_finite(&fr), "{rt:?}: reference output not finite");
        let mut m = SampleCache::new(
            &sess.ctx,
            &sess.scene_gpu,
            &sess.scene.environment,
            &st,
            &st.cache,
        )
        .unwrap();
        let mut prev = None;
        for f in 0..4 {
            let c = moving(&cam, f, 1.0, 0.01);
            let fr = render_at(&mut m, f, c, prev);
            prev = Some(c);
            assert!(
                all_finite(&fr),
                "{rt:?} frame {f}: sample-cache output not finite"
            );
            let snap = m.snapshot().unwrap();
            assert!(
                snapshot_finite(&snap),
                "{rt:?} frame {f}: cache radiance not finite"
            );
            let mo = m.moments().unwrap();
            assert!(
                mo.m1
                    .iter()
                    .chain(&mo.m2)
                    .all(|v| v.iter().all(|c| c.is_finite())),
                "{rt:?} frame {f}: moments not finite"
            );
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Replays `frames` frames at 8×6; returns (max sample count, finite,
/// allocated bytes after frame 10, at the end).
fn long_run(frames: u32, moving_head: bool) -> (f32, bool, u64, u64) {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let (w, h) = (8, 6);
    let st = settings(w, h, SampleCacheSettings::default());
    let mut m =
        SampleCache::new(&s.ctx, &s.scene_gpu, &s.scene.environment, &st, &st.cache).unwrap();
    let cam0 = default_camera(&s, w, h);
    let (mut finite, mut at10) = (true, 0);
    let mut prev = None;
    for f in 0..frames {
        // Moving: a slow back-and-forth turn, so samples keep being reused.
        let cam = if moving_head {
            let k = (f % 200) as f32;
            moving(&cam0, 0, 0.0, 0.0).tap_yaw(if k < 100.0 { k } else { 200.0 - k } * 0.05)
        } else {
            cam0
        };
        let fr = render_at(&mut m, f, cam, prev.or(Some(cam)));
        prev = Some(cam);
        if f % 64 == 0 || f + 1 == frames {
            finite &= all_finite(&fr);
        }
        if f == 10 {
            at10 = ctx.allocated_bytes();
        }
    }
    let snap = m.snapshot().unwrap();
    finite &= snapshot_finite(&snap);
    let mut max_count = 0.0f32;
    for e in 0..2 {
        for px in 0..snap.npix() {
            let mut bits = snap.occupied(snap.mask(e, px));
            while bits != 0 {
                let slot = bits.trailing_zeros();
                bits &= bits - 1;
                max_count = max_count.max(snap.radiance[snap.slot(e, slot, px)][3]);
            }
        }
    }
    let end = ctx.allocated_bytes();
    assert_no_validation_messages(&ctx);
    (max_count, finite, at10, end)
}

trait TapYaw {
    fn tap_yaw(self, deg: f32) -> Self;
}

impl TapYaw for StereoCamera {
    fn tap_yaw(mut self, deg: f32) -> Self {
        self.head.orientation =
            (self.head.orientation * Quat::from_rotation_y(deg.to_radians())).normalize();
        self
    }
}

fn check_long_run(frames: u32, moving_head: bool) {
    let (max_count, finite, at10, end) = long_run(frames, moving_head);
    eprintln!(
        "long run, {frames} frames at 8×6, moving {moving_head}: max sample count {max_count}, finite {finite}, allocated {at10} B at frame 10, {end} B at the end"
    );
    assert!(finite);
    assert!(max_count <= 65_535.0, "count {max_count} beyond saturation");
    assert_eq!(at10, end, "GPU memory grew during the run");
}

#[test]
fn long_run_static() {
    check_long_run(1_200, false);
}

#[test]
fn long_run_moving() {
    check_long_run(600, true);
}

/// The 10 000 frames (minutes on lavapipe); result in docs/ROBUSTNESS.md.
#[test]
#[ignore]
fn long_run_10000_frames() {
    check_long_run(10_000, false);
    check_long_run(10_000, true);
}

// ------------------------------------------------ barycentric packing (GPU)

/// `shaders/common/packing.glsl` run on the device (`packing_test.comp`):
/// b ↦ round(clamp(b, 0, 1) · (2²⁴ − 1)) in the low 24 bits of x and y,
/// the material's 16 bits above them, primitive and instance whole;
/// decoding divides by 2²⁴ − 1. Known bounds: the stored integer is the
/// rounding of the f32 product b·(2²⁴ − 1), itself rounded (by up to a
/// quarter step where it lies in [2²², 2²³)), so within 0.75 step of the
/// exact product (ties either way: GLSL leaves them to the
/// implementation); the decoded barycentric is within 2.5 ulp of
/// q/(2²⁴ − 1) (GLSL's precision for a / b), so within
/// B = 0.75 step + 3·2⁻²⁴ of the input, and a point rebuilt from both is within 2B of the original,
/// relative to the triangle's longest edge (triangle inequality). Ends,
/// out-of-range values and material bits exact; a NaN input is not tested
/// (GLSL's clamp of NaN is undefined).
#[test]
fn barycentric_packing_round_trip() {
    use stereocache::interface::packing_test;
    let ctx = context();
    let mut rng = stereocache::camera::pcg::Pcg32::new(7, 1);
    let mut bary: Vec<[f32; 2]> = (0..20_000)
        .map(|_| {
            let (b1, b2) = (rng.next_f64() as f32, rng.next_f64() as f32);
            if b1 + b2 > 1.0 {
                [1.0 - b1, 1.0 - b2]
            } else {
                [b1, b2]
            }
        })
        .collect();
    bary.extend([[0.0, 1.0], [1.0, 0.0], [2.0, -1.0], [1e-9, 0.5], [0.5, 0.5]]);
    let keys: Vec<[u32; 4]> = bary
        .iter()
        .enumerate()
        .map(|(i, b)| {
            [
                b[0].to_bits(),
                b[1].to_bits(),
                (i as u32).wrapping_mul(2_654_435_761) & 0xFFFF,
                i as u32 ^ 0x8000_0001,
            ]
        })
        .collect();
    let n = keys.len() as u32;
    let out = run_key_kernel(
        &ctx,
        "common/packing_test",
        &packing_test::INTERFACE,
        &packing_test::PUSH,
        &keys,
        8,
        &[[n, 0u32, 0, 0]],
    )
    .remove(0);
    let step = 1.0 / 16_777_215.0f64;
    let bound = 0.75 * step + 3.0 * 2f64.powi(-24);
    let (mut worst_b, mut worst_rel) = (0.0f64, 0.0f64);
    for (i, (k, b)) in keys.iter().zip(&bary).enumerate() {
        let o = &out[8 * i..8 * i + 8];
        assert_eq!(
            (o[2], o[3]),
            (k[3], i as u32),
            "input {i}: primitive, instance"
        );
        assert_eq!(o[6], k[2], "input {i}: material bits");
        assert_eq!(o[7], 1, "input {i}: a hit");
        let mut d = [0.0f64; 2];
        for c in 0..2 {
            let x = b[c].clamp(0.0, 1.0) * 16_777_215.0f32;
            let q = o[c] & 0xFF_FFFF;
            let tie = x.fract() == 0.5;
            assert!(
                q as f32 == x.round() || (tie && (q as f32 - x).abs() == 0.5),
                "input {i}: {} stored as {q}, product {x}",
                b[c]
            );
            let got = f32::from_bits(o[4 + c]) as f64;
            let exact = q as f64 * step;
            assert!(
                (got - exact).abs()
                    <= 2.5 * f32::EPSILON as f64 * exact.max(f32::MIN_POSITIVE as f64),
                "input {i}: decoded {got}, {q}/(2^24 - 1) = {exact}"
            );
            let want = b[c].clamp(0.0, 1.0) as f64;
            assert!((got - want).abs() <= bound, "input {i}: {got} for {want}");
            worst_b = worst_b.max((got - want).abs());
            d[c] = got;
        }
        // A point rebuilt from the decoded barycentrics, at any scale.
        let size = 10f64.powi(i as i32 % 13 - 6);
        let v0 = glam::DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * size;
        let e1 = glam::DVec3::new(
            rng.next_f64() - 0.5,
            rng.next_f64() - 0.5,
            rng.next_f64() - 0.5,
        ) * size;
        let e2 = glam::DVec3::new(
            rng.next_f64() - 0.5,
            rng.next_f64() - 0.5,
            rng.next_f64() - 0.5,
        ) * size;
        if b[0] >= 0.0 && b[1] >= 0.0 && b[0] + b[1] <= 1.0 {
            let p = v0 + e1 * b[0] as f64 + e2 * b[1] as f64;
            let q = v0 + e1 * d[0] + e2 * d[1];
            let rel = (p - q).length() / e1.length().max(e2.length());
            assert!(rel <= 2.0 * bound, "input {i}: relative error {rel:e}");
            worst_rel = worst_rel.max(rel);
        }
    }
    eprintln!("barycentric packing: worst |Δb| = {worst_b:e} (2^-24 = {:e}), worst |Δp| / edge = {worst_rel:e}", 2f64.powi(-24));
    // Exact at the ends.
    let at = |j: usize| &out[8 * (bary.len() - 5 + j)..8 * (bary.len() - 4 + j)];
    assert_eq!((at(0)[0] & 0xFF_FFFF, at(0)[1] & 0xFF_FFFF), (0, 0xFF_FFFF));
    assert_eq!(
        (f32::from_bits(at(0)[4]), f32::from_bits(at(0)[5])),
        (0.0, 1.0)
    );
    assert_eq!(
        (at(2)[0] & 0xFF_FFFF, at(2)[1] & 0xFF_FFFF),
        (0xFF_FFFF, 0),
        "clamped"
    );
    assert_no_validation_messages(&ctx);
}

/// A path tracer that produces ∞ or NaN radiance says so. The reference
/// drops such a sample (counted as black, so one bad path cannot poison a
/// pixel's mean) and counts it: `non_finite_samples` in its frame, and
/// through the reference cache (rendered, then read back from disk) the
/// `non_finite_reference_samples` every method's metrics carry. An
/// environment of infinite radiance (the Rust API takes it as given; no
/// importer makes one), seen by every pixel (the scene's sphere is behind
/// the camera): every sample is ∞ and dropped, so the count is exact,
/// spp · pixels · 2 eyes, and the image is black.
#[test]
fn non_finite_reference_samples_are_counted() {
    use stereocache::evaluate::ReferenceCache;
    let ctx = context();
    let scene = sphere_in_environment(
        Material::default(),
        Vec3::ZERO,
        1.0,
        Vec3::splat(f32::INFINITY),
    );
    let s = session(&ctx, scene, RtChoice::Software);
    let cam = look_at_camera(
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::new(0.0, 0.0, 6.0),
        10.0,
        1.0,
    );
    let (w, h, spp) = (16u32, 16u32, 4u32);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp,
        ..Default::default()
    };
    let f = render(&s, "reference", cam, &settings);
    let expected = (spp * w * h * 2) as f64;
    assert_eq!(f.stats.counters.get("non_finite_samples"), Some(&expected));
    assert!(f
        .eyes
        .iter()
        .all(|e| e.radiance.iter().all(|p| p[..3] == [0.0; 3])));
    // A finite sky drops nothing.
    let healthy = sphere_in_environment(Material::default(), Vec3::ZERO, 1.0, Vec3::splat(0.5));
    let s2 = session(&ctx, healthy, RtChoice::Software);
    let g = render(&s2, "reference", cam, &settings);
    assert_eq!(g.stats.counters.get("non_finite_samples"), Some(&0.0));

    // The two halves of a reference of 2·spp, rendered and then cached.
    let dir = std::env::temp_dir().join(format!("stereocache-nonfinite-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let reference_settings = RenderSettings {
        spp: 2 * spp,
        ..settings.clone()
    };
    for pass in ["rendered", "read from the cache"] {
        let mut cache = ReferenceCache::new(dir.clone(), reference_settings.clone()).unwrap();
        let r = cache.get(&s, &cam, 0).unwrap();
        assert_eq!(r.non_finite_samples, 2.0 * expected, "{pass}");
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert_no_validation_messages(&ctx);
}

/// The caching methods drop a shading path whose radiance is ∞ or NaN as
/// the reference does, and count it (`non_finite_samples` in their frame
/// counters) instead of hiding it in a cached record. A white Lambertian
/// sphere filling the view under an environment of infinite radiance,
/// faceted so that shading normals are the geometric ones: every path's
/// first bounce is cosine-sampled about the face's own normal, so it leaves
/// the convex sphere into ∞ (with smooth normals a sample can fall below
/// the geometric surface and end the path finite, ~10⁻⁴ of them), and
/// every shading path is dropped —
/// the count equals the paths the method traced (sample-cache and isrt:
/// `shaded_samples`; the hash cache: `cell_updates` + `fallback_paths`) —
/// and under a finite sky none is.
#[test]
fn caching_methods_count_the_paths_they_drop() {
    let ctx = context();
    let lambert = Material {
        metallic: 0.0,
        specular: 0.0,
        ..Default::default()
    };
    let cam = look_at_camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 10.0, 1.0);
    let settings = RenderSettings {
        width: 16,
        height: 16,
        spp: 1,
        ..Default::default()
    };
    for (sky, bad) in [(f32::INFINITY, true), (0.5, false)] {
        let scene = faceted_sphere_in_environment(lambert.clone(), Vec3::splat(sky));
        let s = session(&ctx, scene, RtChoice::Software);
        for method in ["sample-cache", "isrt", "hash-cache", "hybrid"] {
            let f = render(&s, method, cam, &settings);
            let c = |k: &str| f.stats.counters.get(k).copied().unwrap_or(0.0);
            let paths = match method {
                "sample-cache" | "isrt" => c("shaded_samples"),
                _ => c("cell_updates") + c("fallback_paths"),
            };
            let dropped = c("non_finite_samples");
            assert!(
                f.stats.counters.contains_key("non_finite_samples"),
                "{method}: no non_finite_samples counter"
            );
            if bad {
                assert!(paths > 0.0, "{method}: no paths traced");
                assert_eq!(
                    dropped, paths,
                    "{method}: dropped against paths under an infinite sky"
                );
            } else {
                assert_eq!(dropped, 0.0, "{method}: dropped paths under a finite sky");
            }
        }
    }
    assert_no_validation_messages(&ctx);
}
