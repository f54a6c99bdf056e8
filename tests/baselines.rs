//! The methods the sample cache is compared against: `naive` (1 spp),
//! `supersample` (N spp), `taa` (1 spp + temporal antialiasing) and `isrt`
//! (interactive stable ray tracing). Known answers where there are any:
//! Monte Carlo error ratios, exact zeros in a colour channel no disoccluded
//! pixel may inherit, and the isrt grid's structural invariants read back
//! from the GPU.

mod common;
use common::*;
use glam::{Mat4, UVec2, Vec2, Vec3};
use std::collections::{HashMap, HashSet};
use stereocache::camera::{Eye, StereoCamera};
use stereocache::methods::isrt::IsrtSnapshot;
use stereocache::methods::{
    Isrt, IsrtSettings, Method, MethodConfig, RenderSettings, StereoFrame, TaaSettings, TaaWeights,
};
use stereocache::rt::{RtChoice, SoftwareBvh};
use stereocache::scene::{generate::*, Environment, Material, Scene};
use stereocache::session::{Session, METHODS};

fn settings(w: u32, h: u32, spp: u32, seed: u32) -> RenderSettings {
    RenderSettings {
        width: w,
        height: h,
        spp,
        max_bounces: 2,
        seed,
        ..Default::default()
    }
}

fn diff_stats(a: &StereoFrame, b: &StereoFrame) -> (f64, f64) {
    mean_and_standard_error(&squared_errors(a, b))
}

/// Like `common::assert_finite_non_negative` over the colour channels only.
fn assert_rgb_finite_non_negative(f: &StereoFrame, what: &str) {
    for (e, eye) in f.eyes.iter().enumerate() {
        for (p, c) in eye.radiance.iter().enumerate() {
            assert!(
                c[..3].iter().all(|v| v.is_finite() && *v >= 0.0),
                "{what}: eye {e} pixel {p} radiance {c:?}"
            );
        }
    }
}

fn moving(start: &StereoCamera, frame: u32, deg: f32) -> StereoCamera {
    turning_head(start, frame, deg, 0.004)
}

/// Renders `frames` frames of `cams` with one method instance; returns every frame.
fn run(m: &mut dyn Method, cams: &[StereoCamera]) -> Vec<StereoFrame> {
    let mut prev = None;
    cams.iter()
        .enumerate()
        .map(|(i, c)| {
            let f = render_at(m, i as u32, *c, prev);
            prev = Some(*c);
            f
        })
        .collect()
}

/// For independent unbiased estimates with N and M samples per pixel against
/// a reference with R, the mean squared difference is Σσ²_p (1/N + 1/R):
/// naive (N = 1) against supersample (N = 16) predicts
/// (1 + 1/R) / (1/16 + 1/R). Tolerance: 4σ of the measured ratio.
/// Then TAA on a static view: its error against the reference falls over the
/// frames, and the count weights (a running mean while the history is short)
/// lower it faster than a fixed α.
#[test]
fn supersample_naive_and_taa_against_the_reference() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Auto);
    let (w, h) = (32, 32);
    let cam = default_camera(&s, w, h);
    let r = 512.0;
    let reference = render(&s, "reference", cam, &settings(w, h, r as u32, 11));
    // naive's expected squared error from 16 independent 1 spp images (seeds
    // 100..116), per pixel the mean of their squared errors, so it rests on
    // as many paths as the 16 spp supersample image. With next-event
    // estimation the 1 spp error is concentrated (97 % of it in 1 % of the
    // pixels) in the pixels the ceiling emitter's edge crosses, where a
    // jittered sample hits the light or not: one image's squared error (and
    // its standard error from the pixel spread) then depends on a few
    // Bernoulli draws and varies by ±30 % from image to image.
    let naives: Vec<StereoFrame> = (0..16)
        .map(|k| render(&s, "naive", cam, &settings(w, h, 64, 100 + k)))
        .collect();
    let naive = &naives[0];
    let ss = render(&s, "supersample", cam, &settings(w, h, 16, 13));
    for (f, name) in [(naive, "naive"), (&ss, "supersample")] {
        assert_rgb_finite_non_negative(f, name);
    }
    // naive ignores --spp: one sample per pixel, whose jittered ray is the
    // path's first hit (the paper's 1 spp: one stage). The pixel-centre ray
    // that fills the depth / first-hit outputs is diagnostic (until session
    // 43 it was a second primary ray per pixel in naive's rays and frame
    // time): counted as centre_rays, its pass outside the frame time.
    let pixels = 2 * (w * h) as u64;
    assert_eq!(naive.stats.rays.primary, pixels);
    assert_eq!(naive.stats.counters["centre_rays"], pixels as f64);
    let names: Vec<&str> = naive.stats.passes.iter().map(|p| p.name.as_str()).collect();
    assert!(names.contains(&"diag.naive.primary"), "{names:?}");
    for n in names.iter().filter(|n| !n.starts_with("diag.")) {
        assert!(
            ["naive.params", "naive.clear", "naive.trace"].contains(n),
            "{names:?}"
        );
    }
    let per_pixel: Vec<Vec<f64>> = naives
        .iter()
        .map(|n| squared_errors(n, &reference))
        .collect();
    let naive_sq: Vec<f64> = (0..per_pixel[0].len())
        .map(|i| per_pixel.iter().map(|v| v[i]).sum::<f64>() / per_pixel.len() as f64)
        .collect();
    let (m1, s1) = mean_and_standard_error(&naive_sq);
    // The spread of one 1 spp image's MSE (frame 0 of TAA below is one).
    let singles: Vec<f64> = per_pixel
        .iter()
        .map(|v| v.iter().sum::<f64>() / v.len() as f64)
        .collect();
    let single_sd =
        (singles.iter().map(|x| (x - m1).powi(2)).sum::<f64>() / (singles.len() - 1) as f64).sqrt();
    eprintln!("MSE of single 1 spp images: {singles:.3?} (sd {single_sd:.3e})");
    let (m16, s16) = diff_stats(&ss, &reference);
    let ratio = m1 / m16;
    let sigma = ratio * ((s1 / m1).powi(2) + (s16 / m16).powi(2)).sqrt();
    let predicted = (1.0 + 1.0 / r) / (1.0 / 16.0 + 1.0 / r);
    eprintln!("MSE naive {m1:.3e}, supersample(16) {m16:.3e}: ratio {ratio:.2} ± {sigma:.2} (predicted {predicted:.2})");
    assert!(
        (ratio - predicted).abs() < 4.0 * sigma,
        "ratio {ratio:.2} ± {sigma:.2}, predicted {predicted:.2}"
    );

    // TAA on a static view, with clipping (γ = 1) and without it (to see the
    // temporal weights alone).
    let cams = vec![cam; 16];
    let mut mse = HashMap::new();
    for (weights, clip) in [
        (TaaWeights::Fixed, true),
        (TaaWeights::Fixed, false),
        (TaaWeights::Count, false),
        (TaaWeights::Pfj23, true),
    ] {
        // RUNS independent runs (seeds 21..) averaged frame by frame: one
        // run's per-frame MSE rests on the few emitter-edge pixels (above),
        // too noisy for the orderings below.
        const RUNS: u32 = 8;
        let mut e = vec![0.0; cams.len()];
        for run_k in 0..RUNS {
            let st = settings(w, h, 1, 21 + run_k);
            let taa = MethodConfig::Taa(TaaSettings {
                weights,
                clip,
                ..Default::default()
            });
            let mut m = s.create(taa, &st).unwrap();
            let frames = run(m.as_mut(), &cams);
            for (i, f) in frames.iter().enumerate() {
                assert_rgb_finite_non_negative(f, "taa");
                let mse_i = diff_stats(f, &reference).0;
                // Frame 0 is plain 1 spp (no history): its error is one
                // 1 spp image's, within 4 standard deviations of that MSE.
                if i == 0 {
                    assert!(
                        (mse_i - m1).abs() < 4.0 * single_sd,
                        "run {run_k} frame 0 {mse_i} vs naive {m1} ± {single_sd}"
                    );
                }
                e[i] += mse_i / RUNS as f64;
            }
            let last = frames.last().unwrap();
            // TAA reads the pixel centres: their rays are part of taa's cost.
            assert_eq!(last.stats.rays.primary, 2 * 2 * (w * h) as u64);
            assert_eq!(last.stats.counters["taa_history_used"], (2 * w * h) as f64);
            assert_eq!(last.stats.counters["taa_rejected_disocclusion"], 0.0);
        }
        eprintln!("taa {weights:?} clip {clip}: MSE per frame (mean of {RUNS} runs) {e:.4?}");
        mse.insert(format!("{weights:?} {clip}"), e);
    }
    let (clip, fixed, count) = (&mse["Fixed true"], &mse["Fixed false"], &mse["Count false"]);
    let pfj = &mse["Pfj23 true"];
    // Clipping against a 1 spp neighbourhood acts as a spatial filter at once
    // and adds bias; a halving is all that is asserted (figures in the docs).
    // The reductions are against the expected 1 spp error m1 (16 images),
    // not frame 0's single image: the box's emitter edges make one image's
    // MSE vary by ±30 % (single_sd above).
    assert!(clip[15] < 0.5 * m1, "γ = 1: {clip:?} vs 1 spp {m1}");
    // By frame 4 the clipped EMA sits at its bias floor, where the per-frame
    // MSE moves with the Halton phase (0.053–0.061 from frame 4 on with the
    // centred jitter of session 55): frames 4 and 15 are not ordered, both
    // are below frame 0's.
    assert!(clip[4] < clip[0] && clip[15] < clip[0], "γ = 1: {clip:?}");
    // Without clipping an EMA with α = 0.1 keeps ≈ α/(2 − α) ≈ 5 % of the
    // 1 spp variance in steady state (plus the Halton-vs-random jitter
    // difference to the reference at edges).
    assert!(fixed[15] < 0.25 * m1, "fixed: {fixed:?} vs 1 spp {m1}");
    assert!(count[15] < 0.25 * m1, "count: {count:?} vs 1 spp {m1}");
    // Our reading of the paper's TAA weights (pfj23: Eq. 4 from 3×3
    // neighbourhoods, clipping) also halves the error by frame 15; its
    // per-frame MSE jumps where the fixed Halton jitter moves the emitter's
    // edges (frames 4, 7 and 13: 0.16, 0.15, 0.16 against 0.05–0.06 for the
    // fixed weights), where the neighbourhoods see a bias and take the
    // current frame (docs/ARCHITECTURE.md `taa`). Recorded, not asserted.
    assert!(pfj[15] < 0.5 * m1, "pfj23: {pfj:?} vs 1 spp {m1}");
    // While the history is short, a running mean (count: variance σ²/n) beats
    // an EMA from a reset (variance 0.81ⁿ⁻¹ + …, e.g. 0.56 σ² vs 0.25 σ² at
    // n = 4). The jitter pattern's bias against the reference adds to both, so
    // the order is asserted, not the ratio (measured: 0.70 at frame 3).
    for k in 1..=6 {
        assert!(
            count[k] < fixed[k],
            "frame {k}: count {count:?} vs fixed {fixed:?}"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// A red quad in front of a green wall under a white sky, direct light only
/// (B = 1) and pure Lambert materials: a path that hits the wall carries no
/// red at all, so the red channel of a pixel that sees only the wall is
/// exactly 0 at any sample count, and any red there was carried over from
/// the quad. The camera slides sideways, uncovering wall behind the quad's
/// edge: a pixel whose reprojected history position has all four bilinear
/// taps on the quad must show no red. Without rejection (and without
/// clipping, which would hide it) the same pixels do turn red, which shows the
/// test can see the failure.
#[test]
fn taa_keeps_no_history_across_a_disocclusion() {
    let ctx = context();
    let mut scene = Scene {
        source: "test:quad-before-wall".into(),
        ..Default::default()
    };
    let lambert = |name: &str, c: Vec3| {
        let mut m = Material::diffuse(name, c);
        m.specular = 0.0;
        m
    };
    let green = add_material(&mut scene, lambert("green", Vec3::new(0.0, 0.8, 0.0)));
    let red = add_material(&mut scene, lambert("red", Vec3::new(0.8, 0.0, 0.0)));
    let quad = |name: &str, half: f32, z: f32| {
        grid(
            name,
            Vec3::new(-half, -half, z),
            Vec3::X * 2.0 * half,
            Vec3::Y * 2.0 * half,
            2,
            2,
            Vec2::ONE,
        )
    };
    add_mesh(&mut scene, quad("wall", 6.0, -1.0), green, Mat4::IDENTITY); // instance 0
    add_mesh(&mut scene, quad("quad", 0.5, 1.0), red, Mat4::IDENTITY); // instance 1
    scene.environment = Some(Environment::Constant(Vec3::ONE));
    scene.validate().unwrap();
    let s = session(&ctx, scene, RtChoice::Auto);
    let (w, h) = (40, 40);
    let cam0 = look_at_camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 45.0, 1.0);
    // 6 still frames build a history, then 3 frames slide 0.3 m each.
    let cams: Vec<StereoCamera> = (0u32..9)
        .map(|i| {
            let mut c = cam0;
            c.head.position.x += 0.3 * i.saturating_sub(5) as f32;
            c
        })
        .collect();
    let run_taa = |taa: TaaSettings| {
        let st = RenderSettings {
            max_bounces: 1,
            ..settings(w, h, 1, 3)
        };
        let mut m = s.create(MethodConfig::Taa(taa), &st).unwrap();
        run(m.as_mut(), &cams)
    };
    let size = UVec2::new(w, h);
    // (max red, pixels checked, rejected by the counters) over the moving frames.
    let disoccluded_red = |frames: &[StereoFrame]| {
        let (mut max_red, mut checked, mut rejected) = (0.0f32, 0, 0.0);
        for f in 6..frames.len() {
            let (cur, prev) = (&frames[f], &frames[f - 1]);
            rejected += cur.stats.counters["taa_rejected_disocclusion"];
            for (e, eye) in Eye::BOTH.iter().enumerate() {
                let (v, pv) = (cams[f].eye(*eye), cams[f - 1].eye(*eye));
                let img = &cur.eyes[e];
                for y in 1..h - 1 {
                    for x in 1..w - 1 {
                        // The pixel and its 3×3 neighbourhood see only the wall now...
                        let wall = (-1..=1).all(|dy: i32| {
                            (-1..=1).all(|dx: i32| {
                                let q = ((y as i32 + dy) * w as i32 + x as i32 + dx) as usize;
                                img.first_hit[q][3] == 0
                            })
                        });
                        if !wall {
                            continue;
                        }
                        // ...and its point lay behind the quad: all 4 bilinear taps saw it.
                        let p = (y * w + x) as usize;
                        let d = v.ray_direction(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), size);
                        let fwd = v.orientation * Vec3::NEG_Z;
                        let world = v.position + d * (img.depth[p] / d.dot(fwd));
                        let Some((q, _)) = pv.project(world, size) else {
                            continue;
                        };
                        let b = (q - Vec2::splat(0.5)).floor();
                        let taps_on_quad = (0..4).all(|k| {
                            let t = b + Vec2::new((k & 1) as f32, (k >> 1) as f32);
                            t.x >= 0.0
                                && t.y >= 0.0
                                && t.x < w as f32
                                && t.y < h as f32
                                && prev.eyes[e].first_hit[(t.y as u32 * w + t.x as u32) as usize][3]
                                    == 1
                        });
                        if taps_on_quad {
                            checked += 1;
                            max_red = max_red.max(img.radiance[p][0]);
                        }
                    }
                }
            }
        }
        (max_red, checked, rejected)
    };
    for (clip, label) in [(true, "γ = 1"), (false, "no clipping")] {
        for weights in [TaaWeights::Fixed, TaaWeights::Count, TaaWeights::Pfj23] {
            let frames = run_taa(TaaSettings {
                clip,
                weights,
                ..Default::default()
            });
            let (max_red, checked, rejected) = disoccluded_red(&frames);
            eprintln!("{label}, {weights:?}: {checked} disoccluded pixels, max red {max_red:.2e}, {rejected} rejected");
            assert!(checked >= 40, "only {checked} disoccluded pixels to check");
            assert!(rejected >= checked as f64);
            assert!(
                max_red <= 1e-6,
                "{label}: red {max_red} carried into a disocclusion"
            );
        }
    }
    let frames = run_taa(TaaSettings {
        clip: false,
        reject_disocclusions: false,
        weights: TaaWeights::Fixed,
        ..Default::default()
    });
    let (max_red, checked, _) = disoccluded_red(&frames);
    eprintln!("without rejection: {checked} pixels, max red {max_red:.3}");
    assert!(
        max_red > 0.05,
        "without rejection the quad's red should ghost ({max_red})"
    );
    assert_no_validation_messages(&ctx);
}

/// TAA's history resampling against its closed form. A view pans 0.5 px a
/// frame across an emissive sinusoid of f = 0.2 cycles per pixel (black
/// base colour: every path is exactly its emission, no Monte Carlo noise),
/// with fixed weights α = 0.1 and no clipping, so in the frame that moves
/// with the image the output obeys y_n = α·x_n + (1 − α)·H·y_{n−1}: x_n
/// the frame's sample of the sinusoid at its Halton jitter (a phase
/// e^{2πif(j_n − ½)} of the pixel centre's), H the history filter's
/// response at a half-pixel offset, cos πf for bilinear and
/// 9/8·cos πf − 1/8·cos 3πf for Catmull-Rom (taps −1/16, 9/16, 9/16, −1/16).
/// The reference box-filters the pixel: sinc f. So the amplitude of the
/// TAA image over the reference's is |y_K| / sinc f, computed here from the
/// same jitters (0.37 bilinear, 0.68 Catmull-Rom at steady state: the
/// blur Karis 2014 resamples the history bicubically to avoid). The
/// texture's own filtering and 8-bit steps apply to both images alike, and
/// the reference's Monte Carlo error on the fitted amplitude is about 0.1 %
/// (256 spp, 24 rows × 80 columns × 2 eyes); the tolerance, 2 % of the
/// prediction, leaves room for another device's texture filtering and still
/// tells the filters apart (their predictions differ by 86 %). Measured on
/// llvmpipe: 0.3561 against 0.3560 and 0.6747 against 0.6741. (Catmull-Rom
/// first skipped the image's border rows, whose outer taps lie outside it:
/// 0.634 here, until taps were clamped to the edge.)
#[test]
fn taa_history_resampling_keeps_the_contrast_its_filter_predicts() {
    use stereocache::methods::{halton_jitter, TaaHistory};
    use stereocache::scene::texture::{Texture, TextureEncoding};
    use stereocache::scene::TextureRef;
    let ctx = context();
    let (w, h) = (96u32, 24u32);
    let (d, yfov) = (3.0f32, 45.0f32);
    let m_per_px = 2.0 * d * (0.5 * yfov).to_radians().tan() / h as f32;
    const F: f32 = 0.2; // cycles per pixel
    let period = m_per_px / F;
    // A plane 30 m wide (the pan moves 0.5 px a frame for 48 frames) whose
    // emission is 0.5 + 0.4 sin(2πX/period) along X, as a 1024-texel sRGB
    // texture.
    let (x0, width) = (-10.0f32, 30.0f32);
    let tw = 1024u32;
    let mut px = Vec::new();
    for _ in 0..4 {
        for i in 0..tw {
            let x = x0 + width * (i as f32 + 0.5) / tw as f32;
            let lin = 0.5 + 0.4 * (std::f32::consts::TAU * x / period).sin();
            let srgb = if lin <= 0.0031308 {
                12.92 * lin
            } else {
                1.055 * lin.powf(1.0 / 2.4) - 0.055
            };
            let b = (srgb * 255.0 + 0.5) as u8;
            px.extend([b, b, b, 255]);
        }
    }
    let mut scene = Scene {
        source: "test:panned-sinusoid".into(),
        ..Default::default()
    };
    scene.textures.push(Texture::with_mips(
        "sinusoid".into(),
        TextureEncoding::Srgb,
        tw,
        4,
        px,
    ));
    let mut m = Material::diffuse("emitter", Vec3::ZERO);
    m.base_color = glam::Vec4::new(0.0, 0.0, 0.0, 1.0);
    m.emissive = Vec3::ONE;
    m.emissive_texture = Some(TextureRef::new(0));
    m.specular = 0.0;
    let mat = add_material(&mut scene, m);
    add_mesh(
        &mut scene,
        grid(
            "plane",
            Vec3::new(x0, -5.0, 0.0),
            Vec3::X * width,
            Vec3::Y * 10.0,
            2,
            2,
            Vec2::ONE,
        ),
        mat,
        Mat4::IDENTITY,
    );
    scene.environment = Some(Environment::Constant(Vec3::ZERO));
    scene.validate().unwrap();
    let s = session(&ctx, scene, RtChoice::Software);
    const K: u32 = 48;
    let cam0 = look_at_camera(
        Vec3::new(0.0, 0.0, d),
        Vec3::ZERO,
        yfov,
        w as f32 / h as f32,
    );
    let cams: Vec<StereoCamera> = (0..K)
        .map(|i| {
            let mut c = cam0;
            c.head.position.x += 0.5 * m_per_px * i as f32;
            c
        })
        .collect();
    // Amplitude of the sinusoid at F in columns 8..w−8 (away from the
    // column the pan brings in each frame, with no history), both eyes,
    // every row (the border rows read clamped taps).
    let amplitude = |f: &StereoFrame| {
        let (mut a, mut b) = (0.0f64, 0.0f64);
        let mut n = 0.0;
        for e in &f.eyes {
            let cols: Vec<f64> = (8..w - 8)
                .map(|x| {
                    (0..h)
                        .map(|y| e.radiance[(y * w + x) as usize][1] as f64)
                        .sum::<f64>()
                        / h as f64
                })
                .collect();
            let mean = cols.iter().sum::<f64>() / cols.len() as f64;
            // Least squares on sin/cos over whole periods (80 columns = 16).
            for (i, v) in cols.iter().enumerate() {
                let ph = std::f64::consts::TAU * F as f64 * (i as f64 + 8.5);
                a += (v - mean) * ph.sin();
                b += (v - mean) * ph.cos();
            }
            n += cols.len() as f64;
        }
        2.0 * (a * a + b * b).sqrt() / n
    };
    let st = |spp| RenderSettings {
        max_bounces: 1,
        ..settings(w, h, spp, 5)
    };
    let mut reference = s.method("reference", &st(256)).unwrap();
    let a_ref = amplitude(&render_at(
        reference.as_mut(),
        K - 1,
        cams[(K - 1) as usize],
        None,
    ));
    let f = F as f64;
    let pi = std::f64::consts::PI;
    let sinc = (pi * f).sin() / (pi * f);
    for (history, hf) in [
        (TaaHistory::Bilinear, (pi * f).cos()),
        (
            TaaHistory::CatmullRom,
            9.0 / 8.0 * (pi * f).cos() - (3.0 * pi * f).cos() / 8.0,
        ),
    ] {
        let taa = TaaSettings {
            weights: TaaWeights::Fixed,
            alpha: 0.1,
            clip: false,
            history,
            ..Default::default()
        };
        let mut m = s.create(MethodConfig::Taa(taa), &st(1)).unwrap();
        let frames = run(m.as_mut(), &cams);
        // The recursion over this run's jitters (complex amplitude).
        let (mut yr, mut yi) = (0.0f64, 0.0f64);
        for n in 0..K {
            let j = halton_jitter(n)[0] as f64 - 0.5;
            let (xr, xi) = ((2.0 * pi * f * j).cos(), (2.0 * pi * f * j).sin());
            if n == 0 {
                (yr, yi) = (xr, xi);
            } else {
                (yr, yi) = (0.1 * xr + 0.9 * hf * yr, 0.1 * xi + 0.9 * hf * yi);
            }
        }
        let want = (yr * yr + yi * yi).sqrt() / sinc;
        let got = amplitude(frames.last().unwrap()) / a_ref;
        eprintln!("{history:?}: contrast {got:.4} of the reference's, predicted {want:.4}");
        assert!(
            (got - want).abs() <= 0.02 * want,
            "{history:?}: contrast {got:.4} of the reference's, predicted {want:.4}"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// World position of a stored first hit, with a (instance, prim) → leaf index
/// map so the lookups stay cheap for the many isrt samples.
struct HitPositions<'a> {
    bvh: &'a SoftwareBvh,
    index: HashMap<(u32, u32), usize>,
}

impl<'a> HitPositions<'a> {
    fn new(bvh: &'a SoftwareBvh) -> Self {
        let index = bvh
            .tri_ref
            .iter()
            .enumerate()
            .map(|(k, r)| ((r[0], r[1]), k))
            .collect();
        HitPositions { bvh, index }
    }
    fn position(&self, fh: [u32; 4]) -> Vec3 {
        let k = self.index[&(fh[3], fh[2])];
        let [v0, v1, v2] = self.bvh.triangle(k);
        let b = Vec2::new((fh[0] & 0xFF_FFFF) as f32, (fh[1] & 0xFF_FFFF) as f32) / 16_777_215.0;
        v0 + b.x * (v1 - v0) + b.y * (v2 - v0)
    }
}

/// Checks the isrt grid after a frame; returns (samples, stale samples).
fn check_isrt(
    snap: &IsrtSnapshot,
    frame: &StereoFrame,
    cam: &StereoCamera,
    bvh: &SoftwareBvh,
    hits: &HitPositions,
) -> (usize, usize) {
    let (w, h, m) = (snap.width, snap.height, snap.m);
    let size = UVec2::new(w, h);
    let (mut samples, mut stale) = (0, 0);
    for (e, eye) in Eye::BOTH.iter().enumerate() {
        let v = cam.eye(*eye);
        let mut seen = HashSet::new();
        for gy in 0..h * m {
            for gx in 0..w * m {
                let c = snap.cell(e, gx, gy);
                if !snap.occupied(c) {
                    continue;
                }
                let fh = snap.first_hits[c];
                samples += 1;
                // No sample is held twice (one cell per sample).
                assert!(seen.insert(fh), "eye {e}: first hit {fh:?} in two cells");
                // The cell is the one the sample's sub-pixel position falls into
                // (up to 1e-3 of a cell for float differences at cell borders).
                let p = hits.position(fh);
                let (q, _) = v.project(p, size).expect("sample in front of the eye");
                let g = q * m as f32;
                let cell = Vec2::new(gx as f32, gy as f32);
                let tol = 1e-3;
                assert!(
                    g.x >= cell.x - tol
                        && g.x <= cell.x + 1.0 + tol
                        && g.y >= cell.y - tol
                        && g.y <= cell.y + 1.0 + tol,
                    "eye {e}: sample of cell ({gx}, {gy}) projects to {g:?}"
                );
                let r = snap.radiance[c];
                assert!(r.iter().all(|x| x.is_finite() && *x >= 0.0), "{r:?}");
                // Visible: a fresh ray towards it reaches it.
                let d = (p - v.position).normalize();
                match bvh.closest_hit(v.position, d, 0.0, 1e30) {
                    Some(hit) if hit.instance == fh[3] && hit.prim == fh[2] => {}
                    Some(hit) if (hit.t - (p - v.position).length()).abs() <= 1e-3 * hit.t => {}
                    _ => stale += 1,
                }
            }
        }
        // Every pixel that geometry covers has a sample and a valid first hit.
        for pixel in 0..(w * h) as usize {
            if !fully_covered(bvh, &v, pixel, w, h) {
                continue;
            }
            let (px, py) = (pixel as u32 % w, pixel as u32 / w);
            let any =
                (0..m * m).any(|k| snap.occupied(snap.cell(e, px * m + k % m, py * m + k / m)));
            assert!(any, "eye {e}: covered pixel {pixel} has no sample");
            assert_ne!(frame.eyes[e].first_hit[pixel][3], u32::MAX);
        }
    }
    (samples, stale)
}

#[test]
fn isrt_grid_invariants_on_a_moving_trace() {
    let ctx = context();
    for (scene, m) in [("cornell", 3), ("hairball", 2)] {
        let s = session(&ctx, shipped(scene), RtChoice::Software);
        let (w, h) = (32, 24);
        let st = settings(w, h, 1, 5);
        let isrt = IsrtSettings {
            m,
            ..Default::default()
        };
        let mut method = Isrt::new(&s.ctx, &s.scene_gpu, &s.scene.environment, &st, &isrt).unwrap();
        let bvh = SoftwareBvh::build(&s.scene);
        let hits = HitPositions::new(&bvh);
        let cam0 = default_camera(&s, w, h);
        let (mut samples, mut stale, mut kept) = (0, 0, 0.0);
        let mut prev = None;
        for f in 0..6 {
            let cam = moving(&cam0, f, 1.5);
            let frame = render_at(&mut method, f, cam, prev);
            prev = Some(cam);
            assert_rgb_finite_non_negative(&frame, "isrt");
            let snap = method.snapshot().unwrap();
            let (n, bad) = check_isrt(&snap, &frame, &cam, &bvh, &hits);
            let c = &frame.stats.counters;
            assert_eq!(c["samples"] as usize, n, "counted vs read-back samples");
            // One shading per pixel that holds a surface sample (shade.comp),
            // in both eyes.
            let with_surface = (0..2usize)
                .flat_map(|e| (0..w * h).map(move |p| (e, p)))
                .filter(|&(e, p)| {
                    (0..m * m).any(|k| {
                        snap.occupied(snap.cell(e, (p % w) * m + k % m, (p / w) * m + k / m))
                    })
                })
                .count();
            assert_eq!(
                c["shaded_samples"] as usize, with_surface,
                "frame {f}: shadings"
            );
            if f > 0 {
                // Survivors of the reservation are at most the reprojected ones;
                // retraces are exactly the survivors, and a retrace that finds
                // a closer hit keeps it (isrt_retrace), so new-sample rays are
                // exactly the cells the reservation left empty.
                assert!(c["kept_samples"] <= c["reprojected_samples"]);
                assert_eq!(c["retrace_rays"], c["kept_samples"]);
                assert_eq!(
                    c["new_sample_rays"],
                    (2 * w * h * m * m) as f64 - c["kept_samples"],
                    "frame {f}: new-sample rays"
                );
                samples += n;
                stale += bad;
                kept += c["kept_samples"] - c["retrace_replaced"];
            }
        }
        eprintln!("isrt {scene} M={m}: {stale} stale of {samples} samples, {kept} carried over");
        assert!(stale as f64 <= 0.01 * samples as f64);
        assert!(
            kept > 0.5 * samples as f64,
            "few samples survive reprojection"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// isrt in the paper's Fig. 10 configuration (`IsrtSettings::fig10`: one
/// sample per pixel retraced, empty cells filled up to n_target = 4) on the
/// Cornell box, M = 3: frame 0 starts from an empty grid, so nothing is
/// retraced and every pixel gets exactly 4 new sample rays; on the still
/// frame 1 every pixel holds samples, so exactly one retrace ray per pixel;
/// then along a moving head no more than one per pixel. After every frame
/// each pixel holds at least 4 samples (surface or background), the grid
/// invariants of `check_isrt` hold (one cell per sample, in the cell its
/// projection falls into, covered pixels have a sample) and the `samples`
/// counter equals the read-back surface samples.
#[test]
fn isrt_fig10_configuration_retraces_one_sample_per_pixel() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let (w, h) = (32, 24);
    let npix = (2 * w * h) as f64;
    let st = settings(w, h, 1, 5);
    let isrt = IsrtSettings::fig10(3);
    let mut method = Isrt::new(&s.ctx, &s.scene_gpu, &s.scene.environment, &st, &isrt).unwrap();
    let bvh = SoftwareBvh::build(&s.scene);
    let hits = HitPositions::new(&bvh);
    let cam0 = default_camera(&s, w, h);
    let mut prev = None;
    for f in 0..6u32 {
        // Frames 0 and 1 still, then turning.
        let cam = moving(&cam0, f.saturating_sub(1), 1.5);
        let frame = render_at(&mut method, f, cam, prev);
        prev = Some(cam);
        assert_rgb_finite_non_negative(&frame, "isrt fig10");
        let c = &frame.stats.counters;
        match f {
            0 => {
                assert_eq!(c["retrace_rays"], 0.0);
                assert_eq!(c["new_sample_rays"], 4.0 * npix);
            }
            1 => assert_eq!(c["retrace_rays"], npix),
            _ => assert!(c["retrace_rays"] <= npix, "frame {f}: {c:?}"),
        }
        let snap = method.snapshot().unwrap();
        let (n, _) = check_isrt(&snap, &frame, &cam, &bvh, &hits);
        assert_eq!(c["samples"] as usize, n, "counted vs read-back samples");
        for e in 0..2 {
            for py in 0..h {
                for px in 0..w {
                    let held = (0..9)
                        .filter(|k| {
                            let cell = snap.cell(e, px * 3 + k % 3, py * 3 + k / 3);
                            snap.occupied(cell) || snap.background(cell)
                        })
                        .count();
                    assert!(
                        held >= 4,
                        "frame {f} eye {e} pixel ({px}, {py}): {held} samples"
                    );
                }
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Every method, every shipped scene, a few frames of a moving head:
/// radiance is finite and non-negative everywhere.
#[test]
fn every_method_is_finite_and_non_negative_on_every_shipped_scene() {
    let ctx = context();
    for scene in ["cornell", "hairball", "plane"] {
        let s: Session = session(&ctx, shipped(scene), RtChoice::Auto);
        let (w, h) = (24, 16);
        let cam0 = default_camera(&s, w, h);
        let cams: Vec<StereoCamera> = (0..3).map(|f| moving(&cam0, f, 2.0)).collect();
        for method in METHODS {
            let mut m = s.method(method, &settings(w, h, 2, 9)).unwrap();
            assert_eq!(m.name(), *method);
            assert!(m.memory_bytes() > 0);
            for f in run(m.as_mut(), &cams) {
                assert_rgb_finite_non_negative(&f, &format!("{method} on {scene}"));
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Every method's `memory_bytes` (compare's `method_memory_bytes`) is what
/// its buffers take on the device: the allocator's count grows by exactly
/// that much while the method is created, and shrinks back when it drops
/// (tests/sample_cache.rs checks the cache's variants).
#[test]
fn every_method_reports_the_memory_it_allocates() {
    let ctx = context();
    let s: Session = session(&ctx, shipped("cornell"), RtChoice::Auto);
    let mut wrong = Vec::new();
    for method in METHODS {
        let before = ctx.allocated_bytes();
        let m = s.method(method, &settings(24, 16, 2, 9)).unwrap();
        let allocated = ctx.allocated_bytes() - before;
        if m.memory_bytes() != allocated {
            wrong.push(format!(
                "{method}: reports {} B, allocated {allocated} B",
                m.memory_bytes()
            ));
        }
        drop(m);
        assert_eq!(ctx.allocated_bytes(), before, "{method}: freed");
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    assert_no_validation_messages(&ctx);
}
