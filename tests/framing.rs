//! Issue 18: the lighting rule on the shipped scenes, and the automatic
//! framing of a scene without a camera (src/camera/framing.rs).
//!
//! Framing, known answers: the fit puts the 8 corners of a box inside both
//! eyes' images with exactly the margin [`FRAMING_MARGIN`] at the binding
//! corner; a flat model on the XZ plane is looked at from above with −Z up;
//! rendered (lavapipe, validation on, `debug-normals`: one pixel-centre
//! primary ray per pixel), a 5 mm cube and a flat 2 m × 1 m quad cover the
//! projected area of their silhouettes (the convex hull of the projected
//! corners) within the pixels the silhouette's edges cross.

mod common;
use common::*;
use glam::{Mat4, UVec2, Vec2, Vec3};
use stereocache::camera::{
    frame_bounds, Eye, Framing, StereoCamera, DEFAULT_ZNEAR, FRAMING_MARGIN,
};
use stereocache::methods::RenderSettings;
use stereocache::rt::RtChoice;
use stereocache::scene::generate::{add_material, add_mesh, grid};
use stereocache::scene::{DefaultLighting, Environment, Material, Scene};
use stereocache::session::{CameraSelect, Session};

/// The 8 corners of the box `lo`..`hi`.
fn corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Projected pixel coordinates of `points` in `eye` of `cam` (`size` pixels);
/// every point must be in front of the eye.
fn project(cam: &StereoCamera, eye: Eye, points: &[Vec3], size: UVec2) -> Vec<Vec2> {
    let v = cam.eye(eye);
    points
        .iter()
        .map(|p| v.project(*p, size).expect("in front of the eye").0)
        .collect()
}

/// Checks that every corner of `lo`..`hi` projects inside both eyes' images
/// of `w`×`h` pixels, at least the margin away from the borders, and that
/// some corner lies on the margin (the fit is the tightest). Float
/// tolerance: the projection is a few f32 operations on coordinates of at
/// most the image size: 1e-4 of the image size.
fn check_fit(f: &Framing, lo: Vec3, hi: Vec3, w: u32, h: u32, what: &str) {
    let size = UVec2::new(w, h);
    let margin = Vec2::new(w as f32, h as f32) * 0.5 * (1.0 - 1.0 / FRAMING_MARGIN);
    let tol = 1e-4 * w.max(h) as f32;
    let mut slack = f32::INFINITY;
    for eye in Eye::BOTH {
        for p in project(&f.camera, eye, &corners(lo, hi), size) {
            let lo_gap = p - margin;
            let hi_gap = Vec2::new(w as f32, h as f32) - margin - p;
            let gap = lo_gap.min(hi_gap).min_element();
            assert!(
                gap >= -tol,
                "{what}: {eye:?} corner at {p} crosses the margin {margin}"
            );
            slack = slack.min(gap);
        }
    }
    assert!(
        slack <= tol,
        "{what}: no corner on the margin (closest {slack} px away)"
    );
}

#[test]
fn fit_puts_every_corner_inside_both_eyes_with_the_margin() {
    let yfov = 60f32.to_radians();
    let cases = [
        // (lo, hi, width, height, ipd, axis looked along)
        (
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(3.0, 3.0, 3.5),
            64,
            48,
            0.063,
            2,
        ),
        // Wide image: the height binds.
        (
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(3.0, 3.0, 3.5),
            128,
            32,
            0.063,
            2,
        ),
        // Flat on XZ: from above.
        (
            Vec3::new(-1.0, 0.0, -0.5),
            Vec3::new(1.0, 0.0, 0.5),
            64,
            48,
            0.063,
            1,
        ),
        // Thin along X: from +X.
        (
            Vec3::new(0.0, -1.0, -2.0),
            Vec3::new(0.1, 1.0, 2.0),
            48,
            64,
            0.063,
            0,
        ),
        // 5 mm cube, the IPD 13 times its size.
        (Vec3::splat(0.2), Vec3::splat(0.205), 64, 48, 0.063, 2),
        (Vec3::splat(0.2), Vec3::splat(0.205), 64, 48, 0.0, 2),
    ];
    for (lo, hi, w, h, ipd, axis) in cases {
        let what = format!("box {lo}..{hi}, {w}x{h}, ipd {ipd}");
        let f = frame_bounds(lo, hi, yfov, w as f32 / h as f32, ipd);
        assert_eq!(f.view_axis, axis, "{what}");
        assert_eq!(f.camera.ipd, ipd, "{what}");
        assert!(f.camera.znear <= DEFAULT_ZNEAR && f.camera.znear <= 0.5 * f.near_face);
        check_fit(&f, lo, hi, w, h, &what);
        // The near face really is `near_face` from the eyes (view depth of
        // its nearest corner), so znear ≤ near_face/2 clips nothing.
        let v = f.camera.eye(Eye::Left);
        let nearest = corners(lo, hi)
            .iter()
            .map(|p| v.project(*p, UVec2::new(w, h)).unwrap().1)
            .fold(f32::INFINITY, f32::min);
        assert!(
            (nearest - f.near_face).abs() <= 1e-5 * f.near_face.max(1.0),
            "{what}: nearest depth {nearest} vs {}",
            f.near_face
        );
        assert_eq!(f.warning.is_some(), ipd > (hi - lo).max_element(), "{what}");
    }
}

#[test]
fn flat_model_on_xz_is_seen_from_above_with_minus_z_up() {
    let f = frame_bounds(
        Vec3::new(-1.0, 0.0, -0.5),
        Vec3::new(1.0, 0.0, 0.5),
        1.0,
        1.5,
        0.063,
    );
    let q = f.camera.head.orientation;
    assert!((q * Vec3::NEG_Z - Vec3::NEG_Y).length() < 1e-6);
    assert!((q * Vec3::Y - Vec3::NEG_Z).length() < 1e-6);
    assert!((q * Vec3::X - Vec3::X).length() < 1e-6);
    assert!(f.camera.head.position.y > 0.0);
    assert!(
        f.line().contains("looking along −Y with −Z up"),
        "{}",
        f.line()
    );
}

/// The shipped Cornell box is lit by its ceiling light alone (an HDR
/// emitter: strength 17): no sun, no sky, from the file and from the
/// generator; `--lighting` adds the sun and sky and the light stays.
#[test]
fn shipped_cornell_keeps_its_own_lighting_and_lighting_wins() {
    for spec in ["scenes/cornell", "cornell"] {
        let (s, d) = Session::load_scene_lit(spec, None).unwrap();
        assert!(s.environment.is_none(), "{spec}");
        assert!(s.lights.is_empty(), "{spec}");
        assert!(
            d.added.is_none() && d.own.hdr_emitters == 1,
            "{spec}: {d:?}"
        );
        let (s, d) = Session::load_scene_lit(spec, Some(&DefaultLighting::default())).unwrap();
        assert!(
            matches!(s.environment, Some(Environment::Sky { .. })),
            "{spec}"
        );
        assert_eq!(s.lights.len(), 1, "{spec}");
        assert!(s.materials.iter().any(|m| m.emissive.max_element() > 1.0));
        assert!(
            d.line().contains("added to the scene's own (1 HDR emitter"),
            "{}",
            d.line()
        );
    }
    // The shipped hairball's file has no light: the default sun and sky.
    let (s, d) = Session::load_scene_lit("scenes/hairball", None).unwrap();
    assert!(matches!(s.environment, Some(Environment::Sky { .. })));
    assert_eq!(d.added, Some(DefaultLighting::default()));
}

fn lambert_scene(name: &str) -> (Scene, u32) {
    let mut s = Scene {
        source: name.into(),
        ..Default::default()
    };
    let m = add_material(&mut s, Material::diffuse("grey", Vec3::splat(0.5)));
    (s, m)
}

/// A cube of side `side` with its low corner at `o`.
fn cube(o: Vec3, side: f32) -> Scene {
    let (mut s, m) = lambert_scene("test:cube");
    let (x, y, z) = (Vec3::X * side, Vec3::Y * side, Vec3::Z * side);
    for (origin, eu, ev) in [
        (z, x, y),
        (x, -x, y),
        (x + z, -z, y),
        (Vec3::ZERO, z, y),
        (y + z, x, -z),
        (Vec3::ZERO, x, z),
    ] {
        let g = grid("face", o + origin, eu, ev, 1, 1, Vec2::ONE);
        add_mesh(&mut s, g, m, Mat4::IDENTITY);
    }
    s
}

/// Convex hull (counter-clockwise, monotone chain) of `p`.
fn hull(mut p: Vec<Vec2>) -> Vec<Vec2> {
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    let mut h: Vec<Vec2> = Vec::new();
    for pass in 0..2 {
        let start = h.len();
        let pts: Vec<Vec2> = if pass == 0 {
            p.clone()
        } else {
            p.iter().rev().copied().collect()
        };
        for q in pts {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], q) <= 0.0 {
                h.pop();
            }
            h.push(q);
        }
        h.pop();
    }
    h
}

/// (area, Σ over edges of |dx| + |dy| + 2) of a convex polygon: the second
/// bounds the pixels its boundary crosses (a segment crosses at most
/// ⌈|dx|⌉ + ⌈|dy|⌉ + 1 pixels), the only ones whose pixel centre can be
/// on the other side of the boundary than most of the pixel.
fn area_and_edge_pixels(poly: &[Vec2]) -> (f32, f32) {
    let (mut area, mut edge) = (0.0, 0.0);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        area += 0.5 * a.perp_dot(b);
        edge += (b - a).abs().element_sum() + 2.0;
    }
    (area.abs(), edge)
}

/// Renders `scene` from its automatic framing with `debug-normals` and
/// checks both eyes' coverage against the silhouette of the box `lo`..`hi`
/// (the model's convex hull: a box). Returns (covered pixels, silhouette
/// area, edge-pixel bound) per eye.
fn check_coverage(
    ctx: &std::sync::Arc<stereocache::gpu::GpuContext>,
    scene: Scene,
    w: u32,
    h: u32,
    what: &str,
) -> [(usize, f32, f32); 2] {
    let (lo, hi) = scene.world_bounds();
    let s = session(ctx, scene, RtChoice::Software);
    let cam = s
        .camera(&CameraSelect::Default, w, h, None, None)
        .expect("camera");
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        ..Default::default()
    };
    let fr = render(&s, "debug-normals", cam, &settings);
    let mut out = [(0, 0.0, 0.0); 2];
    for eye in Eye::BOTH {
        let img = &fr.eye(eye).first_hit;
        let covered: Vec<(u32, u32)> = (0..w * h)
            .filter(|&i| img[i as usize][3] != u32::MAX)
            .map(|i| (i % w, i / w))
            .collect();
        let poly = hull(project(&cam, eye, &corners(lo, hi), UVec2::new(w, h)));
        let (area, edge) = area_and_edge_pixels(&poly);
        let n = covered.len();
        assert!(n > 0, "{what}: {eye:?} eye sees nothing");
        assert!(
            (n as f32 - area).abs() <= edge,
            "{what}: {eye:?} eye covers {n} pixels, silhouette {area} ± {edge}"
        );
        // The covered pixels' extent is the silhouette's: the first and
        // last covered pixel centres lie within a pixel of its edges.
        let (min, max) = poly
            .iter()
            .fold((Vec2::INFINITY, Vec2::NEG_INFINITY), |(a, b), p| {
                (a.min(*p), b.max(*p))
            });
        let cx = covered.iter().map(|c| c.0 as f32 + 0.5);
        let cy = covered.iter().map(|c| c.1 as f32 + 0.5);
        let got_min = Vec2::new(
            cx.clone().fold(f32::INFINITY, f32::min),
            cy.clone().fold(f32::INFINITY, f32::min),
        );
        let got_max = Vec2::new(
            cx.fold(f32::NEG_INFINITY, f32::max),
            cy.fold(f32::NEG_INFINITY, f32::max),
        );
        assert!(
            (got_min - min).abs().max_element() <= 1.0
                && (got_max - max).abs().max_element() <= 1.0,
            "{what}: {eye:?} eye covers {got_min}..{got_max}, silhouette {min}..{max}"
        );
        out[eye.index()] = (n, area, edge);
    }
    out
}

#[test]
fn tiny_and_flat_models_fill_the_view_where_computed() {
    let ctx = context();
    let (w, h) = (256, 192);
    // 5 mm cube: the old framing (fitted without the IPD) showed it to
    // neither eye; now each eye sees it with the IPD in the fit.
    let tiny = check_coverage(
        &ctx,
        cube(Vec3::new(0.1, 0.02, -0.3), 0.005),
        w,
        h,
        "5 mm cube",
    );
    // A 2 m × 1 m quad on the XZ plane (y = 1), facing up: seen face-on from
    // above it fills most of the image (edge-on from +Z it would cover 0).
    let (mut flat, m) = lambert_scene("test:flat");
    let g = grid(
        "quad",
        Vec3::new(2.0, 1.0, -1.5),
        Vec3::X * 2.0,
        Vec3::NEG_Z,
        1,
        1,
        Vec2::ONE,
    );
    add_mesh(&mut flat, g, m, Mat4::IDENTITY);
    let quad = check_coverage(&ctx, flat, w, h, "flat quad");
    eprintln!("(covered pixels, silhouette area, edge bound) per eye: 5 mm cube {tiny:?}, flat quad {quad:?}");
    assert_no_validation_messages(&ctx);
}
