//! Issue 18: orthographic cameras (glTF `orthographic`), in every method and
//! on both ray backends, against the answers parallel projection gives.
//!
//! - **Coverage and depth** (analytic): a 1 m square facing the camera, seen
//!   by 40 × 40 eyes with ymag = 1 (20 pixels per metre) and an IPD of 0.1 m,
//!   covers exactly the 20 × 20 pixels its edges bound: columns 11..31 in
//!   the left eye, 9..29 in the right (the eyes at ∓0.05 m shift it by ±1
//!   pixel), rows 10..30, at every distance. Its edges lie on pixel
//!   boundaries, so every pixel is fully covered or fully empty and every
//!   method must agree with the count, edges included. Its view depth is the
//!   distance, exactly (to f32 precision).
//! - **Radiance** (furnace): the square is a pure Lambertian of albedo ρ in a
//!   constant white environment with nothing above it, so it reflects
//!   exactly ρ; the background is the environment, 1.
//! - **Moving**: after three still frames the camera moves two pixels'
//!   width sideways; every method's cached samples follow, so coverage,
//!   depth and radiance are again exact.
//! - **Turning** (the background rule): background samples of an
//!   orthographic eye hold for one view direction only. After three still
//!   frames and a 2° turn in an environment map that varies with azimuth,
//!   every method's background pixels equal the reference's (the map in the
//!   new direction), not the one the cached samples saw.
//! - **glTF**: an orthographic camera survives export and import, and the
//!   session's default camera is orthographic with its ymag.

mod common;
use common::*;
use glam::{Mat4, Quat, UVec2, Vec2, Vec3};
use stereocache::camera::{Eye, HeadPose, Projection, StereoCamera};
use stereocache::methods::sample_cache::{Retrace, SampleCacheSettings};
use stereocache::methods::{MethodKind, RenderSettings, StereoFrame};
use stereocache::rt::RtChoice;
use stereocache::scene::generate::{add_material, add_mesh, grid};
use stereocache::scene::{Environment, Material, Scene, SceneCamera};
use stereocache::session::CameraSelect;

const W: u32 = 40;
const YMAG: f32 = 1.0;
const IPD: f32 = 0.1;
const RHO: f32 = 0.5;

/// A 1 m square in the z = 0 plane facing +Z, pure Lambert (no specular lobe).
fn square(env: Environment) -> Scene {
    let mut m = Material::diffuse("grey", Vec3::splat(RHO));
    m.specular = 0.0;
    square_in_environment("test:orthographic-square", m, env)
}

/// The orthographic stereo camera at distance `d` in front of the square,
/// turned by `yaw_deg` about +Y.
fn ortho_camera(d: f32, yaw_deg: f32) -> StereoCamera {
    let mut c = StereoCamera::new(
        HeadPose::new(
            Vec3::new(0.0, 0.0, d),
            Quat::from_rotation_y(yaw_deg.to_radians()),
        ),
        1.0,
        1.0,
    );
    c.ipd = IPD;
    c.projection = Projection::Orthographic { ymag: YMAG };
    c
}

/// Whether pixel (i, j) of `eye` is covered by the square (head-on camera,
/// moved `shift` pixels along +X: the square moves `shift` pixels left).
fn covered(eye: Eye, i: u32, j: u32, shift: u32) -> bool {
    let (lo, hi) = match eye {
        Eye::Left => (11, 31),
        Eye::Right => (9, 29),
    };
    (lo..hi).contains(&(i + shift)) && (10..30).contains(&j)
}

fn settings(spp: u32) -> RenderSettings {
    RenderSettings {
        width: W,
        height: W,
        spp,
        max_bounces: 2,
        seed: 7,
        ..Default::default()
    }
}

/// Mean and standard error of the mean of the covered pixels' channel
/// means (`inner`: only those off the outline).
fn covered_mean(fr: &StereoFrame, eye: Eye, shift: u32, inner: bool) -> (f64, f64, usize) {
    let img = fr.eye(eye);
    let mut v = Vec::new();
    for j in 0..W {
        for i in 0..W {
            if covered(eye, i, j, shift) && !(inner && at_outline(eye, i, j, shift)) {
                let p = img.radiance[(j * W + i) as usize];
                v.push((p[0] + p[1] + p[2]) as f64 / 3.0);
            }
        }
    }
    let (m, se) = mean_and_standard_error(&v);
    (m, se, v.len())
}

#[test]
fn the_cpu_model_projects_parallel_rays_and_inverts_them() {
    let c = ortho_camera(3.0, 25.0);
    let size = UVec2::new(W, W);
    for eye in Eye::BOTH {
        let v = c.eye(eye);
        let fwd = c.head.forward();
        for &(px, py) in &[(0.5, 0.5), (10.25, 30.75), (39.9, 0.1), (20.0, 20.0)] {
            let p = Vec2::new(px, py);
            // Every ray points along the view axis.
            assert!(v.ray_direction(p, size).abs_diff_eq(fwd, 1e-6));
            let o = v.ray_origin_offset(p, size);
            assert!(
                o.dot(fwd).abs() < 1e-6,
                "the origin lies on the image plane"
            );
            for &dist in &[0.05f32, 1.0, 37.0] {
                let (q, depth) = v.project_offset(o + fwd * dist, size).unwrap();
                assert!((q - p).length() < 1e-3, "{eye:?} {p} -> {q} at {dist}");
                assert!((depth - dist).abs() < 1e-5 * dist.max(1.0));
            }
        }
        assert!(
            v.project_offset(-fwd, size).is_none(),
            "behind the image plane"
        );
    }
    // The eyes' disparity is the same at every depth: IPD / (2 xmag) · W.
    let (l, r) = (c.eye(Eye::Left), c.eye(Eye::Right));
    for dist in [0.5f32, 4.0, 100.0] {
        let p = l.world.as_vec3() + 0.5 * (r.world - l.world).as_vec3() + c.head.forward() * dist;
        let ql = l.project(p, size).unwrap().0;
        let qr = r.project(p, size).unwrap().0;
        assert!(((ql.x - qr.x) - IPD / (2.0 * YMAG) * W as f32).abs() < 1e-3);
        assert!((ql.y - qr.y).abs() < 1e-4);
    }
}

/// Whether pixel (i, j) has a neighbour (3×3) on the other side of the
/// square's outline.
fn at_outline(eye: Eye, i: u32, j: u32, shift: u32) -> bool {
    let c = covered(eye, i, j, shift);
    (-1i32..=1).any(|dj| {
        (-1i32..=1).any(|di| {
            let (x, y) = (i as i32 + di, j as i32 + dj);
            (0..W as i32).contains(&x)
                && (0..W as i32).contains(&y)
                && covered(eye, x as u32, y as u32, shift) != c
        })
    })
}

/// The furnace square's image in a frame of `kind` (camera `shift` pixels
/// along +X, the square at distance `d`): exact coverage and depth, the
/// background exactly 1, the square's mean ρ within four standard errors.
/// `history`: the frame resolves with TAA after a move, whose
/// neighbourhood clipping lets a pixel on the outline keep part of what its
/// history held (the trailing edge's background blends with the square it
/// showed a frame ago, as in any TAA): those pixels' radiance is not exact,
/// their coverage and depth still are.
fn check_square(fr: &StereoFrame, kind: MethodKind, what: &str, d: f32, shift: u32, history: bool) {
    assert_finite_non_negative(fr, what);
    for eye in Eye::BOTH {
        let img = fr.eye(eye);
        for j in 0..W {
            for i in 0..W {
                let k = (j * W + i) as usize;
                let depth = img.depth[k];
                if covered(eye, i, j, shift) {
                    assert!(
                        (depth - d).abs() <= 4.0 * f32::EPSILON * d,
                        "{what} {eye:?} ({i}, {j}): depth {depth}, expected {d}"
                    );
                } else {
                    assert_eq!(depth, 0.0, "{what} {eye:?} ({i}, {j}): not covered");
                    if kind != MethodKind::DebugNormals
                        && !(history && at_outline(eye, i, j, shift))
                    {
                        let p = img.radiance[k];
                        for c in &p[..3] {
                            assert!(
                                (c - 1.0).abs() <= 1e-6,
                                "{what} {eye:?} ({i}, {j}): background {p:?}"
                            );
                        }
                    }
                }
            }
        }
        if kind == MethodKind::DebugNormals {
            // The shading normal +Z as colour (0.5, 0.5, 1).
            let p = img.radiance[(20 * W + 20) as usize];
            assert!((p[2] - 1.0).abs() < 1e-6 && (p[0] - 0.5).abs() < 1e-6);
            continue;
        }
        // The furnace answer ρ: a mean over 400 pixels within four standard
        // errors (plus f32 rounding).
        let (m, se, n) = covered_mean(fr, eye, shift, history);
        assert_eq!(n, if history { 18 * 18 } else { 400 });
        assert!(
            (m - RHO as f64).abs() <= 4.0 * se + 1e-5,
            "{what} {eye:?}: square {m} ± {se}, expected {RHO}"
        );
    }
}

/// Frames 0–2 of `m` at `still`, then frame 3 at `then` (its previous
/// camera `still`): the frame returned.
fn after_three_still_frames(
    m: &mut dyn stereocache::methods::Method,
    still: StereoCamera,
    then: StereoCamera,
) -> StereoFrame {
    render_still(m, still, 3);
    render_at(m, 3, then, Some(still))
}

/// Every method on both backends: the square's coverage, depth and
/// radiance, at two distances (an orthographic image does not shrink).
#[test]
fn every_method_sees_the_square_at_its_parallel_projection() {
    let ctx = context();
    let scene = square(Environment::Constant(Vec3::ONE));
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        for &kind in MethodKind::ALL {
            for d in [2.0f32, 5.0] {
                let fr = render(&s, kind.name(), ortho_camera(d, 0.0), &settings(4));
                check_square(
                    &fr,
                    kind,
                    &format!("{} {rt:?} at {d} m", kind.name()),
                    d,
                    0,
                    false,
                );
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Three still frames, then the camera moves 0.1 m (2 pixels) along +X:
/// every method's cached samples, background samples included, move with
/// the eye, so the square is where parallel projection puts it, exactly.
#[test]
fn cached_samples_move_with_the_orthographic_eye() {
    let ctx = context();
    let scene = square(Environment::Constant(Vec3::ONE));
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        let still = ortho_camera(2.0, 0.0);
        let mut moved = still;
        moved.head.position.x += 2.0 / (W as f32 / (2.0 * YMAG));
        for &kind in MethodKind::ALL {
            let mut m = s.method(kind.name(), &settings(1)).expect("method");
            let fr = after_three_still_frames(m.as_mut(), still, moved);
            let history = m.resolves_with_taa();
            check_square(
                &fr,
                kind,
                &format!("{} {rt:?} moved", kind.name()),
                2.0,
                2,
                history,
            );
        }
        // The sample cache retracing one slot per pixel and frame: a
        // background sample left behind on a pixel the square moved onto
        // would stay visible there for frames, not be retraced at once.
        let st = cache_settings(
            W,
            W,
            SampleCacheSettings {
                retrace: Retrace::Single,
                ..Default::default()
            },
            7,
        );
        let mut m = s.create(st.config(), &st.settings).expect("sample cache");
        let fr = after_three_still_frames(m.as_mut(), still, moved);
        check_square(
            &fr,
            MethodKind::SampleCache,
            &format!("sample-cache single retrace {rt:?} moved"),
            2.0,
            2,
            false,
        );
    }
    assert_no_validation_messages(&ctx);
}

/// An environment map whose radiance grows with azimuth, the same in every
/// row, with its seam behind the camera (u = 0.5, +Z): 2° of yaw changes
/// what the view axis (−Z, u = 0) sees.
fn azimuth_ramp() -> Environment {
    let (w, h) = (360u32, 4u32);
    let texels = (0..h)
        .flat_map(|_| (0..w).map(|i| [0.2 + ((i + w / 2) % w) as f32 / w as f32, 0.5, 1.0]))
        .collect();
    Environment::Map {
        name: "azimuth ramp".into(),
        width: w,
        height: h,
        texels,
        scale: 1.0,
    }
}

/// Three still frames, then a 2° turn: each method's background pixels are
/// the reference's, the map in the new view direction. (Pixels next to the
/// turned square's silhouette are partly covered, and their 1-spp reference
/// is a sample of the square or the map: the static test above checks the
/// edges where they are exact.)
#[test]
fn background_samples_do_not_outlive_the_view_direction() {
    let ctx = context();
    let scene = square(azimuth_ramp());
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        let still = ortho_camera(2.0, 0.0);
        let turned = ortho_camera(2.0, 2.0);
        let reference = render(&s, "reference", turned, &settings(1));
        let before = render(&s, "reference", still, &settings(1));
        let centre = (20 * W + 2) as usize; // a background pixel
        assert!(
            (reference.eye(Eye::Left).radiance[centre][0]
                - before.eye(Eye::Left).radiance[centre][0])
                .abs()
                > 1e-3,
            "the turn must change the background"
        );
        for &kind in MethodKind::ALL {
            if matches!(kind, MethodKind::Reference | MethodKind::DebugNormals) {
                continue;
            }
            let mut m = s.method(kind.name(), &settings(1)).expect("method");
            let fr = after_three_still_frames(m.as_mut(), still, turned);
            let what = format!("{} {rt:?}", kind.name());
            let mut checked = 0;
            for eye in Eye::BOTH {
                let (img, want) = (fr.eye(eye), reference.eye(eye));
                for k in 0..(W * W) as usize {
                    let (i, j) = ((k as u32 % W) as i32, (k as u32 / W) as i32);
                    let near_square = (-1..=1).any(|dj| {
                        (-1..=1).any(|di| {
                            let (x, y) = (i + di, j + dj);
                            (0..W as i32).contains(&x)
                                && (0..W as i32).contains(&y)
                                && want.depth[(y as u32 * W + x as u32) as usize] != 0.0
                        })
                    });
                    if near_square || img.depth[k] != 0.0 {
                        continue;
                    }
                    for c in 0..3 {
                        assert!(
                            (img.radiance[k][c] - want.radiance[k][c]).abs() <= 1e-6,
                            "{what} {eye:?} pixel {k}: background {:?}, the reference's {:?}",
                            img.radiance[k],
                            want.radiance[k]
                        );
                    }
                    checked += 1;
                }
            }
            // The square and its neighbours cover about 22 × 22 of 40 × 40
            // pixels per eye.
            assert!(
                checked > 2 * 1050,
                "{what}: only {checked} background pixels"
            );
        }
    }
    assert_no_validation_messages(&ctx);
}

#[test]
fn an_orthographic_gltf_camera_round_trips_and_becomes_the_default() {
    let mut scene = square(Environment::Constant(Vec3::ONE));
    let m = Mat4::from_rotation_translation(Quat::from_rotation_y(0.3), Vec3::new(0.5, 0.2, 3.0));
    scene.cameras.push(SceneCamera {
        name: "plan".into(),
        transform: m,
        yfov: 0.0,
        aspect: Some(2.0),
        znear: 0.25,
        orthographic: Some(Vec2::new(3.0, 1.5)),
    });
    let dir = std::env::temp_dir().join(format!("stereocache-ortho-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("ortho.gltf");
    stereocache::scene::write_gltf(&scene, &path).unwrap();
    let back = stereocache::scene::load_scene(path.to_str().unwrap()).unwrap();
    let c = &back.cameras[0];
    assert_eq!(c.name, "plan");
    assert_eq!(c.orthographic, Some(Vec2::new(3.0, 1.5)));
    assert_eq!(c.znear, 0.25);
    assert!(c.transform.abs_diff_eq(m, 1e-6));
    let ctx = context();
    let s = session(&ctx, back, RtChoice::Software);
    let cam = s
        .camera(&CameraSelect::Default, 60, 30, None, None)
        .unwrap();
    assert_eq!(cam.projection, Projection::Orthographic { ymag: 1.5 });
    let e = s
        .camera(&CameraSelect::Default, 60, 30, None, Some(1.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("orthographic") && e.contains("--fov"), "{e}");
    let v = cam.eye(Eye::Left);
    assert_eq!(v.half_extents(), Vec2::new(3.0, 1.5));
    // The CLI names the camera it renders with.
    let o = cli(120)
        .args([
            "render",
            "--method",
            "debug-normals",
            "--size",
            "60x30",
            "--rt",
            "software",
        ])
        .arg("--scene")
        .arg(&path)
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("camera: the scene's 'plan': orthographic, a 6 × 3 m view (ymag 1.5, the image's aspect 2)"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A partly covered pixel converges to its coverage in the sample cache:
/// with the camera 0.25 pixel along +X the square's right edge crosses the
/// left eye's column 30 (the right eye's 28) three quarters of the way, so
/// those pixels' mean is ¾·ρ + ¼·1 after the cache has filled them. Their
/// background samples are retraced from their own rays' origins; retraced
/// from the pixel centre, which the square covers, they would all be
/// found occluded and the pixels would converge to ρ.
#[test]
fn an_orthographic_edge_pixel_converges_to_its_coverage() {
    let ctx = context();
    let scene = square(Environment::Constant(Vec3::ONE));
    let mut cam = ortho_camera(2.0, 0.0);
    cam.head.position.x += 0.25 / (W as f32 / (2.0 * YMAG));
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        let mut m = s.method("sample-cache", &settings(1)).expect("method");
        let fr = render_still(m.as_mut(), cam, 16);
        let mut v = Vec::new();
        for (eye, col) in [(Eye::Left, 30u32), (Eye::Right, 28)] {
            for j in 11..29u32 {
                let p = fr.eye(eye).radiance[(j * W + col) as usize];
                v.push((p[0] + p[1] + p[2]) as f64 / 3.0);
            }
        }
        let (mean, se) = mean_and_standard_error(&v);
        let want = 0.75 * RHO as f64 + 0.25;
        assert!(
            (mean - want).abs() <= 4.0 * se + 1e-3,
            "{rt:?}: edge pixels {mean} ± {se}, coverage ¾ gives {want}"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// Pixel (i, j) of `eye` lies at least two pixels from the square (as it
/// stands at shift 0 and after the eye slid up to one pixel along +X) and
/// from the image's border: sky that only background samples reach.
fn open_sky(eye: Eye, i: u32, j: u32) -> bool {
    let (lo, hi) = match eye {
        Eye::Left => (11, 31),
        Eye::Right => (9, 29),
    };
    let near_square = (lo - 3..hi + 2).contains(&i) && (8..32).contains(&j);
    (2..W - 2).contains(&i) && (2..W - 2).contains(&j) && !near_square
}

/// An orthographic eye's background sample moves with the eye's
/// translation by its place in the pixel (camera.glsl background_offset),
/// so a sample reprojected into a pixel must carry its place there
/// (first_hit.glsl background_at), in the one- and two-pass reprojection of
/// the sample cache and in isrt's gather. Until session 49 it kept the
/// place it was traced at: sliding 0.3 pixels a frame, a sample at place
/// 0.1 of pixel p went to pixel p − 1 at place 0.1 (not 0.8), then to p − 2
/// (not p − 1 at 0.5): samples stood still or ran a pixel ahead, and along
/// a 24-frame slide the square's trailing edge pixels read 0.156 ± 0.014
/// below their coverage in the sample cache (isrt 0.038 ± 0.003).
///
/// Known answer: every open-sky pixel (`open_sky`) is given one background
/// sample along the view axis at place (0.1, 0.5) (isrt: each cell one at
/// its centre); the eye slides 0.3 pixels along +X twice, and after each
/// frame every sample of those pixels is the one from 0.3 pixels to the
/// right, at place x − 0.3 (within 1/256 a frame, the stored place's
/// resolution), its y place unchanged.
#[test]
fn background_samples_carry_their_place_into_the_new_pixel() {
    use stereocache::methods::sample_cache::background::{
        background_subpixel, encode_background, is_background,
    };
    use stereocache::methods::sample_cache::{CacheSnapshot, Reproject, SampleCache};
    let ctx = context();
    let scene = square(Environment::Constant(Vec3::ONE));
    let px = 1.0 / (W as f32 / (2.0 * YMAG));
    let cam = |k: u32| {
        let mut c = ortho_camera(2.0, 0.0);
        c.head.position.x += 0.3 * k as f32 * px;
        c
    };
    let n = (W * W) as usize;
    let sky = [1.0f32, 1.0, 1.0, 0.0];
    let tol = |k: u32| k as f32 / 256.0 + 1e-5;
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        for reproject in [Reproject::OnePass, Reproject::TwoPass] {
            let cs = SampleCacheSettings {
                slots: 1,
                n_target: 1,
                delta: 0,
                reproject,
                retrace: Retrace::Multi,
                ..Default::default()
            };
            let mut m = SampleCache::new(
                &s.ctx,
                &s.scene_gpu,
                &s.scene.environment,
                &settings(1),
                &cs,
            )
            .unwrap();
            let mut snap = CacheSnapshot::empty(1, W, W);
            for (e, eye) in Eye::BOTH.into_iter().enumerate() {
                for j in 0..W {
                    for i in 0..W {
                        // The sky the samples come from: open sky and the
                        // pixel to its right.
                        if open_sky(eye, i, j) || (i > 0 && open_sky(eye, i - 1, j)) {
                            let p = e * n + (j * W + i) as usize;
                            snap.masks[p] = 0b11;
                            snap.first_hits[p] =
                                encode_background(Vec3::NEG_Z, Vec2::new(0.1, 0.5));
                            snap.radiance[p] = sky;
                        }
                    }
                }
            }
            m.load(&snap).unwrap();
            for k in 1..=2u32 {
                render_at(&mut m, k, cam(k), Some(cam(k - 1)));
                let out = m.snapshot().unwrap();
                // 0.1 − 0.3k: place 0.8 in the pixel to the left, then 0.5 there.
                let want_x = (0.1 - 0.3 * k as f32).rem_euclid(1.0);
                for (e, eye) in Eye::BOTH.into_iter().enumerate() {
                    for j in 0..W {
                        for i in 0..W {
                            if !open_sky(eye, i, j) {
                                continue;
                            }
                            let p = e * n + (j * W + i) as usize;
                            let fh = out.first_hits[out.slot(e, 0, (j * W + i) as usize)];
                            let what = format!("{reproject:?} {rt:?} frame {k} {eye:?} ({i}, {j})");
                            assert_eq!(out.masks[p], 0b11, "{what}: one visible sample");
                            assert!(is_background(fh), "{what}: a background sample");
                            let at = background_subpixel(fh).unwrap();
                            assert!(
                                (at.x - want_x).abs() <= tol(k) && (at.y - 0.5).abs() <= tol(k),
                                "{what}: place {at}, expected ({want_x}, 0.5)"
                            );
                        }
                    }
                }
            }
        }
        // isrt: M = 3 cells a pixel, each given a background sample at its
        // centre; 0.3 px < a cell (1/3 px), so each lands in the cell to its
        // left, at place (centre − 0.3) in that cell's pixel, then − 0.6.
        let (mut m, mut snap) = isrt_with_empty_cells(&s);
        let mm = snap.m;
        let gw = W * mm;
        let centre = |g: u32| (g as f32 + 0.5) / mm as f32; // in pixels
        for (e, eye) in Eye::BOTH.into_iter().enumerate() {
            for gy in 0..gw {
                for gx in 0..gw {
                    let (i, j) = (gx / mm, gy / mm);
                    if open_sky(eye, i, j) || (i > 0 && open_sky(eye, i - 1, j)) {
                        let c = snap.cell(e, gx, gy);
                        let sub = Vec2::new(centre(gx).fract(), centre(gy).fract());
                        snap.first_hits[c] = encode_background(Vec3::NEG_Z, sub);
                        snap.radiance[c] = sky;
                    }
                }
            }
        }
        m.load(&snap).unwrap();
        for k in 1..=2u32 {
            render_at(&mut m, k, cam(k), Some(cam(k - 1)));
            let out = m.snapshot().unwrap();
            for (e, eye) in Eye::BOTH.into_iter().enumerate() {
                for gy in 0..gw {
                    for gx in 0..gw {
                        let (i, j) = (gx / mm, gy / mm);
                        if !open_sky(eye, i, j) {
                            continue;
                        }
                        // The sample from k cells to the right, 0.3k px
                        // to the left of that cell's centre.
                        let x = centre(gx + k) - 0.3 * k as f32;
                        let (want_x, want_y) = (x - i as f32, centre(gy).fract());
                        let fh = out.first_hits[out.cell(e, gx, gy)];
                        let what = format!("isrt {rt:?} frame {k} {eye:?} cell ({gx}, {gy})");
                        assert!(is_background(fh), "{what}: a background sample");
                        let at = background_subpixel(fh).unwrap();
                        assert!(
                            (at.x - want_x).abs() <= tol(k) + 0.5 / 256.0
                                && (at.y - want_y).abs() <= tol(k) + 0.5 / 256.0,
                            "{what}: place {at}, expected ({want_x}, {want_y})"
                        );
                    }
                }
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// isrt with the default settings (M = 3) at the tests' size, and a
/// snapshot of its grid with every cell empty, to fill and load.
fn isrt_with_empty_cells(
    s: &stereocache::session::Session,
) -> (
    stereocache::methods::isrt::Isrt,
    stereocache::methods::isrt::IsrtSnapshot,
) {
    use stereocache::methods::isrt::{Isrt, IsrtSettings, IsrtSnapshot};
    let is = IsrtSettings::default();
    let m = Isrt::new(
        &s.ctx,
        &s.scene_gpu,
        &s.scene.environment,
        &settings(1),
        &is,
    )
    .unwrap();
    let cells = (W * is.m * W * is.m) as usize;
    let snap = IsrtSnapshot {
        m: is.m,
        width: W,
        height: W,
        first_hits: vec![[0, 0, 0, u32::MAX]; 2 * cells],
        radiance: vec![[0.0; 4]; 2 * cells],
    };
    (m, snap)
}

/// isrt fixes a sample's cell by its place in the pixel, and a background
/// sample's place is stored in steps of 1/256 of a pixel (first_hit.glsl).
/// At M = 3 the cell edges 1/3 and 2/3 fall inside a step: a place of
/// 0.3325 (cell 0) is stored as its step's centre 0.33398 (cell 1). Until
/// session 56 an orthographic eye's sample so placed moved to cell 1 in a
/// still view (a tie with cell 1's own sample, one of them dropped), and
/// cell 0 took a new sample at a random place: a ray a frame for nothing
/// (an audit's finding; 0.5 % of uniformly placed background samples).
///
/// Known answer: every cell of both eyes holds a background sample, those
/// of column 0 at x = 0.3325 and the others at their cell's centre; after a
/// still frame (`--isrt-retrace every`) every cell keeps its own sample at
/// its place (within a step) and no new sample is traced — the samples
/// over the square are retraced and replaced by its hits, at no new ray.
#[test]
fn isrt_background_samples_keep_their_cell() {
    use stereocache::methods::isrt::IsrtSettings;
    use stereocache::methods::sample_cache::background::{
        background_subpixel, encode_background, is_background,
    };
    let ctx = context();
    let scene = square(Environment::Constant(Vec3::ONE));
    let cam = ortho_camera(2.0, 0.0);
    let mm = IsrtSettings::default().m;
    assert_eq!(mm, 3, "the test's places are for M = 3");
    let gw = W * mm;
    let cells = (gw * gw) as usize;
    // Place (pixel-relative) of grid column / row g's sample: the cell's
    // centre, but 0.3325 in column 0 (its step's centre lies in cell 1).
    let centre = |g: u32| ((g % mm) as f32 + 0.5) / mm as f32;
    let place_x = |gx: u32| if gx % mm == 0 { 0.3325f32 } else { centre(gx) };
    let place_y = centre;
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        let (mut m, mut snap) = isrt_with_empty_cells(&s);
        for e in 0..2 {
            for gy in 0..gw {
                for gx in 0..gw {
                    let c = snap.cell(e, gx, gy);
                    snap.first_hits[c] =
                        encode_background(Vec3::NEG_Z, Vec2::new(place_x(gx), place_y(gy)));
                    snap.radiance[c] = [1.0, 1.0, 1.0, 0.0];
                }
            }
        }
        m.load(&snap).unwrap();
        let fr = render_at(&mut m, 1, cam, Some(cam));
        assert_eq!(
            fr.stats.counters["new_sample_rays"], 0.0,
            "{rt:?}: a still view with every cell filled traced new samples"
        );
        let out = m.snapshot().unwrap();
        let (mut checked, step) = (0usize, 1.0 / 256.0 + 1e-5);
        for (e, eye) in Eye::BOTH.into_iter().enumerate() {
            for gy in 0..gw {
                for gx in 0..gw {
                    let fh = out.first_hits[out.cell(e, gx, gy)];
                    if !is_background(fh) {
                        // Over the square: retraced and replaced by its hit.
                        assert!(
                            covered(eye, gx / mm, gy / mm, 0),
                            "{rt:?} {eye:?} cell ({gx}, {gy}): a surface sample in open sky"
                        );
                        continue;
                    }
                    let at = background_subpixel(fh).unwrap();
                    let want = Vec2::new(place_x(gx), place_y(gy));
                    assert!(
                        (at - want).abs().max_element() <= step,
                        "{rt:?} {eye:?} cell ({gx}, {gy}): place {at}, its own sample's is {want}"
                    );
                    checked += 1;
                }
            }
        }
        // Every cell but the square's 20 × 20 pixels' in each eye.
        assert_eq!(checked, 2 * (cells - 400 * 9), "{rt:?}: background cells");
    }
    assert_no_validation_messages(&ctx);
}

/// The square 0.5 m in front of a darker backdrop that fills the view.
fn square_before_backdrop() -> Scene {
    let mut s = square(Environment::Constant(Vec3::ONE));
    let mut m = Material::diffuse("dark", Vec3::splat(0.1));
    m.specular = 0.0;
    let mat = add_material(&mut s, m);
    add_mesh(
        &mut s,
        grid(
            "backdrop",
            Vec3::new(-2.0, -2.0, -0.5),
            4.0 * Vec3::X,
            4.0 * Vec3::Y,
            2,
            2,
            Vec2::ONE,
        ),
        mat,
        Mat4::IDENTITY,
    );
    s.validate().unwrap();
    s
}

/// Eq. 2's ε1 and the retrace's ε0 are relative tolerances: for a
/// perspective eye they scale with the hit distance t; for an orthographic
/// eye, whose t runs from the camera's arbitrary place along its axis and
/// whose pixels do not grow with distance, with the view's half height
/// (`eye_tolerance_scale`). Until session 57 they scaled with that t too
/// (an audit): 1 km back, ε1·t = 5 m passed the square's 0.5 m step as one
/// flat surface, and ε0·t = 1 m hid it as an occluder from the retrace.
/// The same view from 2 m and from 1 km, three still frames and three
/// after a 2-pixel slide: every frame's Eq. 2 edge flags and visible-sample
/// counts agree pixel for pixel, and from frame 1 at least as many pixels
/// are edges as the square's outline has.
#[test]
fn orthographic_tolerances_do_not_depend_on_the_camera_distance() {
    use stereocache::methods::sample_cache::SampleCache;
    let ctx = context();
    let s = session(&ctx, square_before_backdrop(), RtChoice::Software);
    let st = settings(1);
    let run = |d: f32| -> Vec<Vec<[u32; 2]>> {
        let cs = SampleCacheSettings::default();
        let mut m = SampleCache::new(&s.ctx, &s.scene_gpu, &s.scene.environment, &st, &cs).unwrap();
        let still = ortho_camera(d, 0.0);
        let mut moved = still;
        moved.head.position.x += 2.0 / (W as f32 / (2.0 * YMAG));
        (0..6u32)
            .map(|f| {
                let (cam, prev) = if f < 3 {
                    (still, still)
                } else {
                    (moved, if f == 3 { still } else { moved })
                };
                render_at(&mut m, f, cam, Some(prev));
                let snap = m.snapshot().unwrap();
                (0..2 * snap.npix())
                    .map(|k| {
                        let (e, p) = (k / snap.npix(), k % snap.npix());
                        let vis = snap.visible(snap.mask(e, p)).count_ones();
                        [snap.pixel_stats[k][3], vis]
                    })
                    .collect()
            })
            .collect()
    };
    let near = run(2.0);
    let far = run(1000.0);
    for f in 0..near.len() {
        let edges = near[f].iter().filter(|v| v[0] != 0).count();
        // The square's 20 × 20 pixels in each eye: its outline, the 76
        // pixels inside it whose 3×3 neighbourhood reaches the backdrop,
        // from frame 1 on (frame 0 decides on an empty cache).
        assert!(
            f == 0 || edges >= 2 * 76,
            "frame {f}: {edges} edge pixels at 2 m"
        );
        for (k, (a, b)) in near[f].iter().zip(&far[f]).enumerate() {
            assert_eq!(
                a,
                b,
                "frame {f}, eye {}, pixel {}: [edge, visible samples] at 2 m vs 1 km",
                k / (W * W) as usize,
                k % (W * W) as usize
            );
        }
    }
    assert_no_validation_messages(&ctx);
}
