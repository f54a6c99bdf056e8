//! The one TAA on any method's output (`--taa-output`, `RenderSettings::taa_output`;
//! the paper's Fig. 12 applies TAA on top of all methods): it runs on every
//! registry method exactly once per frame inside the frame's one submit, and
//! on a still view with the running-mean weights (count, no clipping) its
//! output is the running mean of the method's own frames, and with the
//! pfj23 weights (our reading of the paper's) it follows their CPU twin.

mod common;
use common::*;
use stereocache::camera::StereoCamera;
use stereocache::methods::{
    MethodConfig, MethodKind, RenderSettings, StereoFrame, TaaSettings, TaaWeights,
};
use stereocache::rt::RtChoice;

fn settings(w: u32, h: u32, taa_output: Option<TaaSettings>) -> RenderSettings {
    RenderSettings {
        width: w,
        height: h,
        spp: 2,
        max_bounces: 1,
        seed: 7,
        taa_output,
        ..Default::default()
    }
}

/// `kind` with its default options, a small table for the hash-table
/// methods, and their own TAA on or off.
fn config(kind: MethodKind, hash_taa: bool) -> MethodConfig {
    match kind {
        MethodKind::HashCache => MethodConfig::hash_cache(|c| {
            c.capacity = 1 << 14;
            c.taa = hash_taa;
        }),
        MethodKind::Hybrid => MethodConfig::hybrid(|c| {
            c.hash.capacity = 1 << 14;
            c.hash.taa = hash_taa;
        }),
        other => other.into(),
    }
}

/// Passes named `taa.resolve` in the frame (the one TAA's resolve).
fn resolves(fr: &StereoFrame) -> usize {
    fr.stats
        .passes
        .iter()
        .filter(|p| p.name == "taa.resolve")
        .count()
}

/// Every registry method (and hash-cache / hybrid with their own TAA off)
/// along 3 moving frames of the Cornell box: with `taa_output` each frame
/// runs the TAA resolve exactly once, in one submit-and-wait; frame 0 has no
/// history for any pixel, later frames use it for some; the radiance is
/// finite and non-negative and the method keeps its registry name. Without
/// `taa_output` a method that has no TAA of its own runs none.
#[test]
fn taa_output_runs_once_per_frame_on_every_registry_method() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let (w, h) = (20, 16);
    let npix = (2 * w * h) as f64;
    let cam0 = default_camera(&s, w, h);
    let path = |f: u32| turning_head(&cam0, f, 1.0, 0.01);
    let mut runs: Vec<(MethodKind, bool, bool)> =
        MethodKind::ALL.iter().map(|m| (*m, true, true)).collect();
    runs.push((MethodKind::HashCache, true, false));
    runs.push((MethodKind::Hybrid, true, false));
    for m in MethodKind::ALL {
        runs.push((*m, false, true));
    }
    for (kind, taa_output, hash_taa) in runs {
        let what = format!("{kind} (taa_output {taa_output}, hash taa {hash_taa})");
        let taa = taa_output.then(TaaSettings::default);
        let mut m = s
            .create(config(kind, hash_taa), &settings(w, h, taa))
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(m.name(), kind.name(), "{what}");
        let own_taa = matches!(kind, MethodKind::Taa)
            || (hash_taa && matches!(kind, MethodKind::HashCache | MethodKind::Hybrid));
        let mut prev: Option<StereoCamera> = None;
        for f in 0..3 {
            let before = ctx.submit_count();
            let fr = render_at(m.as_mut(), f, path(f), prev);
            prev = Some(path(f));
            assert_eq!(ctx.submit_count() - before, 1, "{what} frame {f}: submits");
            assert_finite_non_negative(&fr, &what);
            let expect = usize::from(taa_output || own_taa);
            assert_eq!(resolves(&fr), expect, "{what} frame {f}: TAA resolves");
            if expect == 0 {
                assert!(
                    !fr.stats.counters.contains_key("taa_history_used"),
                    "{what}"
                );
                continue;
            }
            let c = &fr.stats.counters;
            if f == 0 {
                assert_eq!(c["taa_no_history"], npix, "{what} frame 0");
                assert_eq!(c["taa_history_used"], 0.0, "{what} frame 0");
            } else {
                assert_eq!(c["taa_no_history"], 0.0, "{what} frame {f}");
                assert!(c["taa_history_used"] > 0.0, "{what} frame {f}: {c:?}");
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Still view (Cornell box, 12 frames): with count weights, α_min = 1/32
/// (so the weights stay 1/(n + 1) for all 12 frames) and no clipping, the
/// TAA over a method's output at frame k is the running mean of that
/// method's frames 0..=k, per pixel and channel. Checked against a second,
/// plain run of the same method (same seed, so the same frames) for every
/// deterministic registry method. Not here: `taa` (it is this TAA; its own
/// tests are tests/baselines.rs) and `hash-cache`/`hybrid` (atomic update
/// order makes two runs differ; their TAA is the same pass, checked above).
///
/// Tolerance: on a still view the history position is the pixel centre up
/// to f32 rounding of the reprojection (~1e-6 px at these sizes), so the
/// bilinear fetch leaks ≤ ~1e-5 of a neighbour's history; the running mean
/// itself rounds ~k · 2^-24 relatively. 1e-4 · (1 + the largest mean in the
/// 3×3 neighbourhood) is above both by an order of magnitude.
#[test]
fn still_view_taa_output_is_the_running_mean_of_the_method() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let (w, h) = (20, 16);
    let cam = default_camera(&s, w, h);
    let frames = 12u32;
    let taa = TaaSettings {
        weights: TaaWeights::Count,
        alpha: 1.0 / 32.0,
        clip: false,
        ..Default::default()
    };
    let deterministic = [
        MethodKind::Reference,
        MethodKind::SampleCache,
        MethodKind::Naive,
        MethodKind::Supersample,
        MethodKind::Isrt,
        MethodKind::DebugNormals,
    ];
    for kind in deterministic {
        let mut plain = s.create(kind, &settings(w, h, None)).unwrap();
        let mut resolved = s.create(kind, &settings(w, h, Some(taa.clone()))).unwrap();
        let n = (w * h) as usize;
        let mut sum = vec![[0.0f64; 3]; 2 * n];
        let mut worst = 0.0f64;
        for f in 0..frames {
            let prev = (f > 0).then_some(cam);
            let a = render_at(plain.as_mut(), f, cam, prev);
            let b = render_at(resolved.as_mut(), f, cam, prev);
            for e in 0..2 {
                for (i, p) in a.eyes[e].radiance.iter().enumerate() {
                    for (s, v) in sum[e * n + i].iter_mut().zip(p) {
                        *s += *v as f64;
                    }
                }
            }
            let mean = |e: usize, i: usize, c: usize| sum[e * n + i][c] / (f + 1) as f64;
            for e in 0..2 {
                for y in 0..h as i32 {
                    for x in 0..w as i32 {
                        let i = (y * w as i32 + x) as usize;
                        let mut local = 0.0f64;
                        for dy in -1..=1 {
                            for dx in -1..=1 {
                                let (qx, qy) = (x + dx, y + dy);
                                if qx >= 0 && qy >= 0 && qx < w as i32 && qy < h as i32 {
                                    let q = (qy * w as i32 + qx) as usize;
                                    for c in 0..3 {
                                        local = local.max(mean(e, q, c));
                                    }
                                }
                            }
                        }
                        for c in 0..3 {
                            let d = (b.eyes[e].radiance[i][c] as f64 - mean(e, i, c)).abs();
                            let tol = 1e-4 * (1.0 + local);
                            worst = worst.max(d / tol);
                            assert!(
                                d <= tol,
                                "{kind} frame {f} eye {e} pixel ({x}, {y}) channel {c}: TAA {} vs running mean {} (tolerance {tol:.1e})",
                                b.eyes[e].radiance[i][c],
                                mean(e, i, c)
                            );
                        }
                    }
                }
            }
            if f == frames - 1 {
                assert_eq!(
                    b.stats.counters["taa_history_used"],
                    (2 * n) as f64,
                    "{kind}"
                );
            }
        }
        eprintln!("{kind}: largest |TAA − running mean| / tolerance {worst:.3}");
    }
    assert_no_validation_messages(&ctx);
}

/// The pfj23 weights (Eq. 4 per channel from 3×3 neighbourhood moments of
/// the history X and the current frame Y) on a still view, no clipping:
/// the history position is the pixel centre (to ~1e-6 px), so the resolve
/// is out_t = lerp(out_{t−1}, in_t, β′) with β′ = 1 − σ_Y²/(Bias² + σ_X² +
/// σ_Y²) from the boxes of out_{t−1} and in_t around the pixel (clamped at
/// the border), computed here on the CPU in f32 in the shader's order from
/// the plain method's frames (the CPU twin of Eq. 4 is the stereo blend's,
/// src/stereo/blend.rs `beta_prime`). The noisy 1 spp `naive` frames make
/// β′ vary between 0 and 1 from pixel to pixel; `debug-normals` is the same
/// image every frame (Bias = 0, σ_X = σ_Y: β′ = ½ or, where the box is
/// flat, 1 — the output is the input either way). Tolerance as the running
/// mean's above, the recurrence's f32 rounding (FMA on the GPU) included.
///
/// Known answer of the weight itself (the case of an audit): a flat history
/// c (σ_X = 0) against a current box of c with c + δ at its centre has Bias
/// = −δ/9 and σ_Y² = 8δ²/81, so β′ = 1/9: the output moves δ/9 towards the
/// outlier, where the count weights after 255 frames move it α_min·δ.
#[test]
fn still_view_pfj23_taa_follows_its_cpu_twin() {
    use stereocache::stereo::blend::beta_prime;
    let (c, d) = (0.5f32, 0.9f32);
    let m1y = (8.0 * c + (c + d)) / 9.0;
    let m2y = (8.0 * c * c + (c + d) * (c + d)) / 9.0;
    let b = beta_prime(c, c * c, m1y, m2y);
    assert!((b - 1.0 / 9.0).abs() < 1e-6, "β′ {b}");

    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let (w, h) = (20usize, 16usize);
    let cam = default_camera(&s, w as u32, h as u32);
    let taa = TaaSettings {
        weights: TaaWeights::Pfj23,
        clip: false,
        ..Default::default()
    };
    // 3×3 box moments (sum / 9 in the shader's order), clamped at the border.
    let boxed = |img: &[[f32; 3]], x: usize, y: usize, k: usize| -> (f32, f32) {
        let (mut m1, mut m2) = (0.0f32, 0.0f32);
        for dy in -1i32..=1 {
            for dx in -1i32..=1 {
                let qx = (x as i32 + dx).clamp(0, w as i32 - 1) as usize;
                let qy = (y as i32 + dy).clamp(0, h as i32 - 1) as usize;
                let v = img[qy * w + qx][k];
                m1 += v;
                m2 += v * v;
            }
        }
        (m1 / 9.0, m2 / 9.0)
    };
    for kind in [MethodKind::Naive, MethodKind::DebugNormals] {
        let mut plain = s.create(kind, &settings(w as u32, h as u32, None)).unwrap();
        let mut resolved = s
            .create(kind, &settings(w as u32, h as u32, Some(taa.clone())))
            .unwrap();
        let mut twin: Vec<Vec<[f32; 3]>> = Vec::new();
        let mut worst = 0.0f64;
        let mut betas = Vec::new();
        for f in 0..10u32 {
            let prev = (f > 0).then_some(cam);
            let a = render_at(plain.as_mut(), f, cam, prev);
            let b = render_at(resolved.as_mut(), f, cam, prev);
            for e in 0..2 {
                let input: Vec<[f32; 3]> = a.eyes[e]
                    .radiance
                    .iter()
                    .map(|p| [p[0], p[1], p[2]])
                    .collect();
                let out: Vec<[f32; 3]> = if f == 0 {
                    input.clone()
                } else {
                    let hist = &twin[e];
                    (0..w * h)
                        .map(|i| {
                            let (x, y) = (i % w, i / w);
                            std::array::from_fn(|k| {
                                let (m1x, m2x) = boxed(hist, x, y, k);
                                let (m1y, m2y) = boxed(&input, x, y, k);
                                let beta = beta_prime(m1x, m2x, m1y, m2y);
                                betas.push(beta);
                                let hv = hist[i][k].max(0.0);
                                hv + (input[i][k] - hv) * beta
                            })
                        })
                        .collect()
                };
                for (i, o) in out.iter().enumerate() {
                    let local = o.iter().chain(&input[i]).fold(0.0f32, |m, v| m.max(*v));
                    for (k, want) in o.iter().enumerate() {
                        let got = b.eyes[e].radiance[i][k];
                        let dlt = (got - want).abs() as f64;
                        let tol = 1e-4 * (1.0 + local as f64);
                        worst = worst.max(dlt / tol);
                        assert!(
                            dlt <= tol,
                            "{kind} frame {f} eye {e} pixel {i} channel {k}: TAA {got} vs twin {want} (tolerance {tol:.1e})"
                        );
                    }
                }
                if twin.len() < 2 {
                    twin.push(out);
                } else {
                    twin[e] = out;
                }
            }
        }
        let spread = betas.iter().filter(|b| **b > 0.05 && **b < 0.95).count();
        eprintln!(
            "{kind}: largest |TAA − twin| / tolerance {worst:.3}; β′ strictly inside (0.05, 0.95) in {spread} of {}",
            betas.len()
        );
        if kind == MethodKind::Naive {
            assert!(
                spread > betas.len() / 4,
                "the noisy frames exercise the weight ({spread} of {})",
                betas.len()
            );
        }
    }
    assert_no_validation_messages(&ctx);
}

/// A pixel whose reprojection leaves the previous image (or falls behind
/// the previous eye) has no history (Yang et al. 2020 §4.2): the resolve
/// shows the current input unchanged and counts it in
/// `taa_rejected_offscreen`. Before this test the "history used" state of
/// `taa/resolve.comp` was the value 0, which is also `C_TAA_OFFSCREEN`'s
/// slot, so such pixels took the history branch with an all-zero history:
/// with fixed weights they showed (1 − α) × (black clipped into the
/// neighbourhood box) + α × input, and the counter stayed 0.
///
/// Setup: the deterministic `naive` method on the hairball under the sun
/// and sky (the Cornell box would bring only its black surroundings into
/// view, where the old blend of black also gave black), rendered twice with
/// the same seed, once plain and once with `--taa-output` (fixed α = 0.1,
/// clipping on), along a head turning 6° per frame. Which
/// pixels reproject off-screen is computed here on the CPU from the
/// method's own depth (the depth TAA reads) with `EyeView::project_offset`;
/// pixels within 0.01 px of the image border (f32 rounding of two different
/// formulas is ~1e-5 px) are left undecided and only bound the counter.
/// Every clearly off-screen pixel must equal the plain frame's pixel to f32
/// rounding (the resolve copies it: 1e-6 relative is generous).
#[test]
fn off_screen_reprojection_drops_the_history() {
    use glam::{UVec2, Vec2, Vec3};
    let ctx = context();
    let s = session(&ctx, shipped("hairball"), RtChoice::Software);
    let (w, h) = (32u32, 24u32);
    let size = UVec2::new(w, h);
    let cam0 = default_camera(&s, w, h);
    let taa = TaaSettings {
        weights: TaaWeights::Fixed,
        alpha: 0.1,
        ..Default::default()
    };
    let mut plain = s.create(MethodKind::Naive, &settings(w, h, None)).unwrap();
    let mut resolved = s
        .create(MethodKind::Naive, &settings(w, h, Some(taa)))
        .unwrap();
    let margin = 0.01f32;
    let mut checked = 0usize;
    let mut prev: Option<StereoCamera> = None;
    for f in 0..4u32 {
        let cam = turning_head(&cam0, f, 6.0, 0.0);
        let a = render_at(plain.as_mut(), f, cam, prev);
        let b = render_at(resolved.as_mut(), f, cam, prev);
        if let Some(pc) = prev {
            let (mut clear, mut undecided) = (0usize, 0usize);
            for e in 0..2 {
                let (ev, pe) = (cam.eyes()[e], pc.eyes()[e]);
                let fwd = ev.orientation * Vec3::NEG_Z;
                let shift = (ev.world - pe.world).as_vec3();
                for y in 0..h {
                    for x in 0..w {
                        let i = (y * w + x) as usize;
                        let d = ev.ray_direction(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), size);
                        let depth = a.eyes[e].depth[i];
                        // A miss reprojects its direction (rotation only).
                        let offset = if a.eyes[e].first_hit[i][3] == u32::MAX {
                            d
                        } else {
                            shift + d * (depth / d.dot(fwd))
                        };
                        let (off, near_border) = match pe.project_offset(offset, size) {
                            None => (true, false),
                            Some((q, _)) => {
                                let lo = q.min_element();
                                let out =
                                    q.x < 0.0 || q.y < 0.0 || q.x >= w as f32 || q.y >= h as f32;
                                let near = lo.abs() < margin
                                    || (q.x - w as f32).abs() < margin
                                    || (q.y - h as f32).abs() < margin;
                                (out, near)
                            }
                        };
                        if near_border {
                            undecided += 1;
                            continue;
                        }
                        if !off {
                            continue;
                        }
                        clear += 1;
                        for c in 0..3 {
                            let (want, got) = (a.eyes[e].radiance[i][c], b.eyes[e].radiance[i][c]);
                            assert!(
                                (got - want).abs() <= 1e-6 * (1.0 + want.abs()),
                                "frame {f} eye {e} pixel ({x}, {y}) channel {c}: reprojected off-screen, TAA shows {got}, the input is {want}"
                            );
                        }
                    }
                }
            }
            let counted = b.stats.counters["taa_rejected_offscreen"] as usize;
            eprintln!(
                "frame {f}: {clear} pixels off-screen, {undecided} undecided, counter {counted}"
            );
            assert!(
                clear >= 2 * h as usize,
                "frame {f}: the turn moved only {clear} pixels off-screen"
            );
            assert!(
                counted >= clear && counted <= clear + undecided,
                "frame {f}: taa_rejected_offscreen {counted}, expected {clear}..={}",
                clear + undecided
            );
            checked += clear;
        }
        prev = Some(cam);
    }
    assert!(checked > 0);
    assert_no_validation_messages(&ctx);
}

/// The references the metrics score against are path-traced truth, never
/// resolved through `--taa-output` (until session 50 a compare with
/// `--taa-output`, fig12-13's setting, built them from the shared settings,
/// so the reference's frame k was TAA's blend of frames 0..k reprojected at
/// frame k's pose, and it was cached under the plain reference's key).
/// Three frames of a head turn through two caches, one given `taa_output`:
/// each frame's halves are bit-identical (the reference is deterministic
/// for a seed), frame 0 included.
#[test]
fn references_never_pass_through_the_output_taa() {
    use stereocache::evaluate::ReferenceCache;
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let (w, h) = (16, 12);
    let cam0 = default_camera(&s, w, h);
    let dir = |tag: &str| {
        let d =
            std::env::temp_dir().join(format!("stereocache-taa-ref-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    };
    let (plain_dir, taa_dir) = (dir("plain"), dir("taa"));
    let mut plain = ReferenceCache::new(plain_dir.clone(), settings(w, h, None)).unwrap();
    let mut with_taa = ReferenceCache::new(
        taa_dir.clone(),
        settings(w, h, Some(TaaSettings::default())),
    )
    .unwrap();
    for f in 0..3u32 {
        let cam = turning_head(&cam0, f, 1.0, 0.02);
        let a = plain.get(&s, &cam, f).unwrap();
        let b = with_taa.get(&s, &cam, f).unwrap();
        for e in 0..2 {
            let differ = a.frame.eyes[e]
                .radiance
                .iter()
                .zip(&b.frame.eyes[e].radiance)
                .filter(|(x, y)| x != y)
                .count();
            assert_eq!(
                differ, 0,
                "frame {f}, eye {e}: {differ} pixels of the reference differ under --taa-output"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&plain_dir);
    let _ = std::fs::remove_dir_all(&taa_dir);
    assert_no_validation_messages(&ctx);
}
