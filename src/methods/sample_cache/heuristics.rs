//! CPU twins of the sample cache's per-pixel heuristics, written to evaluate
//! exactly what `shaders/sample_cache/common.glsl` and
//! `shaders/common/accumulation.glsl` evaluate, so they can be
//! unit-tested at the edges (θ → 90°, t → 0, huge t).

/// Number of importance buckets of the shading histogram (§3.5, M = 13).
pub const HIST_M: u32 = 13;

/// Eq. 1: the expected depth extent within a pixel footprint,
/// Δn = t_s |1 − cos θ / cos(θ − φ)| with θ clamped to [0, π/2] (appendix A):
/// the denominator is then ≥ sin φ > 0, so Δn ≤ t_s stays finite up to
/// grazing incidence, and Δn → 0 as t → 0. Evaluated without trigonometry
/// as cos(θ − φ) = cos θ cos φ + sin θ sin φ, sin θ = √((1 − cos θ)(1 + cos θ)),
/// from `cs_phi` = (cos φ, sin φ) ([`pixel_diagonal_cos_sin`]).
pub fn normal_slope(t: f32, cos_theta: f32, cs_phi: [f32; 2]) -> f32 {
    let c = cos_theta.clamp(0.0, 1.0);
    let sin_theta = ((1.0 - c) * (1.0 + c)).sqrt();
    t * (1.0 - c / (c * cs_phi[0] + sin_theta * cs_phi[1])).abs()
}

/// Eq. 1 for an orthographic eye, whose rays are parallel: the limit of
/// [`normal_slope`] as `t → ∞` with `t · tan φ` held at `diag`, the pixel
/// diagonal's length on the image plane (metres): Δn = diag · tan θ, with
/// no cap (Eq. 1's cap, Δn = t at θ = π/2, grows without bound in that
/// limit; until session 57 it was kept at t, which for an orthographic eye
/// is the distance from the camera's arbitrary place along its axis, so a
/// steep surface's pixels were edges seen from near and flat from far —
/// a review's finding). Edge-on (cos θ ≤ 0): ∞, every finite depth
/// consistent.
pub fn normal_slope_parallel(cos_theta: f32, diag: f32) -> f32 {
    let c = cos_theta.clamp(0.0, 1.0);
    let sin_theta = ((1.0 - c) * (1.0 + c)).sqrt();
    if c > 0.0 {
        diag * sin_theta / c
    } else {
        f32::INFINITY
    }
}

/// Eq. 2: `t_max < t_min + 2Δn + tol` — the depths in a 3×3 neighbourhood
/// are consistent with one locally flat surface (no retrace of every
/// sample). `tol` = ε1 · [`tolerance_scale`]`(t_min + 2Δn)`: for a
/// perspective eye the paper's `(1 + ε1)(t_min + 2Δn)`.
pub fn depths_consistent(t_min: f32, slope: f32, t_max: f32, tol: f32) -> bool {
    t_max < t_min + 2.0 * slope + tol
}

/// What the relative tolerances ε0, ε1 multiply for a depth `t` (CPU twin
/// of camera.glsl `eye_tolerance_scale`): `t` for a perspective eye
/// (`ortho_ymag` None); for an orthographic one, whose depths run from the
/// camera's arbitrary place along its axis, the view's half height ymag,
/// or t/1024 beyond 1024·ymag (keeping it above f32's resolution of t).
pub fn tolerance_scale(t: f32, ortho_ymag: Option<f32>) -> f32 {
    match ortho_ymag {
        Some(ymag) => ymag.max(t / 1024.0),
        None => t,
    }
}

/// φ of Eq. 1: the angle subtended by a pixel's diagonal, for a symmetric
/// frustum with half-angle tangents `tan_half` and an image of `size` pixels.
pub fn pixel_diagonal_angle(tan_half: [f32; 2], size: [u32; 2]) -> f32 {
    let px = 2.0 * tan_half[0] / size[0] as f32;
    let py = 2.0 * tan_half[1] / size[1] as f32;
    (px * px + py * py).sqrt().atan()
}

/// (cos φ, sin φ) of [`pixel_diagonal_angle`] without trigonometry:
/// φ = atan(L), so cos φ = 1/√(1 + L²) and sin φ = L/√(1 + L²).
pub fn pixel_diagonal_cos_sin(tan_half: [f32; 2], size: [u32; 2]) -> [f32; 2] {
    let px = 2.0 * tan_half[0] / size[0] as f32;
    let py = 2.0 * tan_half[1] / size[1] as f32;
    let l = (px * px + py * py).sqrt();
    let inv = 1.0 / (1.0 + l * l).sqrt();
    [inv, l * inv]
}

/// Shading importance w = (1 + c_s)^−1 (§3.5).
pub fn importance(c: f32) -> f32 {
    1.0 / (1.0 + c)
}

/// Logarithmic bucket of importance `w` between the previous frame's
/// extremes: floor(M · log(w / w_min) / log(w_max / w_min)), clamped to
/// [0, M − 1]; degenerate bounds put everything in the top bucket.
pub fn importance_bucket(w: f32, w_min: f32, w_max: f32) -> u32 {
    let valid = w_max > w_min && w_min > 0.0;
    if !valid {
        return HIST_M - 1;
    }
    let x = (w / w_min).ln() / (w_max / w_min).ln();
    (x * HIST_M as f32).floor().clamp(0.0, (HIST_M - 1) as f32) as u32
}

/// Appendix C: the smallest temporal blend factor for a view-dependent
/// material of GGX roughness α: α_min = (1 − α)·0.5 + α·0.1.
pub fn alpha_min(alpha_ggx: f32) -> f32 {
    (1.0 - alpha_ggx) * 0.5 + alpha_ggx * 0.1
}

/// Effective sample count after one exponential-average step
/// x' = (1 − α)x + αL with independent L (Yang et al. 2009): from
/// Var(x') = (1 − α)² Var(x) + α² σ², c' = 1 / ((1 − α)²/c + α²); an empty
/// record (c = 0, or not a number: the shader's `!(c > 0)`) or α = 1 gives
/// 1. common/accumulation.glsl `accumulated_count`.
pub fn accumulated_count(c: f32, alpha: f32) -> f32 {
    if c.is_nan() || c <= 0.0 || alpha >= 1.0 {
        return 1.0;
    }
    let k = 1.0 - alpha;
    (1.0 / (k * k / c + alpha * alpha)).min(C_MAX)
}

/// Effective counts saturate here (common/accumulation.glsl `C_MAX`).
pub const C_MAX: f32 = 65535.0;

/// accumulation.glsl `accumulate_record` (sample_cache/shade.comp, isrt/shade.comp): the update of a record with effective count `c`: the blend
/// factor (the running mean's 1/(c + 1), floored at `alpha_floor` — appendix
/// C's α_min, `--accumulation fixed:A`'s A, or 0) and the new count.
pub fn accumulate(c: f32, alpha_floor: f32) -> (f32, f32) {
    let alpha = 1.0 / (c + 1.0);
    if alpha < alpha_floor {
        (alpha_floor, accumulated_count(c, alpha_floor))
    } else {
        (alpha, (c + 1.0).min(C_MAX))
    }
}

/// Ranks of a 4×4 Bayer matrix (row-major): the order in which a full
/// block's pixels become its base pixel.
const BAYER4: [u32; 16] = [0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5];

/// The block-sparse base pixel of §3.4/§3.5 (`is_sparse_base_pixel` in
/// shaders/sample_cache/common.glsl): one pixel per 4×4 block and frame,
/// each pixel of a block once in every 16 consecutive frames (Bayer order
/// from a per-block, per-eye hashed start); a block cut by the image's
/// right or bottom border rotates over its n pixels in row order.
pub fn is_sparse_base_pixel(px: [u32; 2], size: [u32; 2], frame_index: u32, eye: u32) -> bool {
    sparse_base_visit(px, size, frame_index, eye).is_some()
}

/// The visit number of `px` when it is its block's base pixel this frame:
/// (frame + offset) / n, one more at each of its visits, from which the
/// shaders pick the slot round robin over visits (common.glsl
/// `sparse_base_pixel`); `None` otherwise.
pub fn sparse_base_visit(px: [u32; 2], size: [u32; 2], frame_index: u32, eye: u32) -> Option<u32> {
    use crate::methods::hash_table::hash::pcg_hash;
    let block = [px[0] / 4, px[1] / 4];
    let extent = [
        (size[0] - block[0] * 4).min(4),
        (size[1] - block[1] * 4).min(4),
    ];
    let n = extent[0] * extent[1];
    let offset = pcg_hash(
        block[0].wrapping_mul(73856093)
            ^ block[1].wrapping_mul(19349663)
            ^ eye.wrapping_mul(83492791),
    );
    let local = (px[0] & 3) + extent[0] * (px[1] & 3);
    let rank = if n == 16 {
        BAYER4[local as usize]
    } else {
        local
    };
    let at = frame_index.wrapping_add(offset);
    (rank == at % n).then_some(at / n)
}

#[cfg(test)]
mod tests {
    use super::*;

    const PHI: f32 = 0.0025; // ~1080p, 90° vertical field of view
    const CS_PHI: [f32; 2] = [0.999_996_9, 0.002_499_997_4]; // (cos PHI, sin PHI)

    #[test]
    fn slope_is_zero_head_on_and_bounded_at_grazing_angles() {
        assert!(normal_slope(10.0, 1.0, CS_PHI) < 10.0 * 4e-6);
        for deg in [60.0f32, 80.0, 89.0, 89.9, 89.99, 90.0] {
            let s = normal_slope(10.0, deg.to_radians().cos(), CS_PHI);
            assert!(
                s.is_finite() && (0.0..=10.0 + 1e-4).contains(&s),
                "θ = {deg}°: Δ = {s}"
            );
        }
        // Exactly tangential and backfacing inputs clamp to θ = 90°: Δ = t.
        assert!((normal_slope(10.0, 0.0, CS_PHI) - 10.0).abs() < 1e-4);
        assert!((normal_slope(10.0, -0.5, CS_PHI) - 10.0).abs() < 1e-4);
        // Grows monotonically with θ.
        let mut prev = 0.0;
        for i in 0..=90 {
            let s = normal_slope(1.0, (i as f32).to_radians().cos(), CS_PHI);
            assert!(s + 1e-6 >= prev, "not monotone at {i}°");
            prev = s;
        }
    }

    #[test]
    fn slope_scales_with_distance_and_vanishes_at_zero() {
        let c = 60f32.to_radians().cos();
        assert_eq!(normal_slope(0.0, c, CS_PHI), 0.0);
        let a = normal_slope(1.0, c, CS_PHI);
        let b = normal_slope(1.0e6, c, CS_PHI);
        assert!(((b / a) - 1.0e6).abs() / 1.0e6 < 1e-4);
        assert!(normal_slope(3.0e38, c, CS_PHI).is_finite());
    }

    #[test]
    fn small_angle_slope_matches_the_derivative() {
        // For small φ, Δ ≈ t φ tan θ (first-order expansion of Eq. 1).
        let theta = 45f32.to_radians();
        let s = normal_slope(2.0, theta.cos(), CS_PHI);
        let approx = 2.0 * PHI * theta.tan();
        assert!((s - approx).abs() / approx < 0.01, "{s} vs {approx}");
    }

    #[test]
    fn flat_surfaces_pass_eq2_and_steps_fail() {
        let t = 5.0;
        let theta = 70f32.to_radians();
        let slope = normal_slope(t, theta.cos(), CS_PHI);
        // A tilted plane's depth range across a 3×3 block stays inside the bound.
        let tol = |t_min: f32, slope: f32| 0.005 * tolerance_scale(t_min + 2.0 * slope, None);
        assert!(depths_consistent(t, slope, t + 1.5 * slope, tol(t, slope)));
        // A depth step (an edge) does not.
        assert!(!depths_consistent(t, slope, t * 1.2, tol(t, slope)));
        // Numerical noise at a head-on plane is absorbed by ε1.
        assert!(depths_consistent(t, 0.0, t * (1.0 + 1e-4), tol(t, 0.0)));
    }

    /// The orthographic form answers the same wherever the camera sits
    /// along its axis (all depths shifted alike), unlike the relative one.
    #[test]
    fn orthographic_eq2_does_not_depend_on_the_camera_distance() {
        let (ymag, eps1, slope) = (1.0, 0.005, 0.0);
        for shift in [0.0f32, 8.0, 998.0] {
            let t = 2.0 + shift;
            // A 0.5 m step is an edge, a 1 mm wobble is not, at every shift.
            let tol = eps1 * tolerance_scale(t + 2.0 * slope, Some(ymag));
            assert!(!depths_consistent(t, slope, t + 0.5, tol));
            assert!(depths_consistent(t, slope, t + 0.001, tol));
        }
        // The perspective form, read with the orthographic depths, passes
        // the step 1 km back (the session-57 bug the form replaces).
        assert!(depths_consistent(
            1000.0,
            0.0,
            1000.5,
            eps1 * tolerance_scale(1000.0, None)
        ));
    }

    #[test]
    fn pixel_diagonal_angle_of_a_square_pixel() {
        let phi = pixel_diagonal_angle([1.0, 1.0], [1000, 1000]);
        assert!((phi - (0.002f32 * 2f32.sqrt()).atan()).abs() < 1e-7);
        let [c, s] = pixel_diagonal_cos_sin([1.0, 1.0], [1000, 1000]);
        assert!((c - phi.cos()).abs() < 1e-7 && (s - phi.sin()).abs() < 1e-7);
        assert!((CS_PHI[0] - PHI.cos()).abs() < 1e-7 && (CS_PHI[1] - PHI.sin()).abs() < 1e-9);
    }

    #[test]
    fn trig_free_slope_equals_the_angle_form() {
        // Eq. 1 as written, in f64: t |1 − cos θ / cos(θ − φ)|.
        for phi in [PHI, 0.01, 0.05] {
            let cs = [phi.cos(), phi.sin()];
            for i in 0..=900 {
                let theta = (i as f64 / 10.0).to_radians();
                let exact = (1.0 - theta.cos() / (theta - phi as f64).cos()).abs();
                let s = normal_slope(1.0, theta.cos() as f32, cs) as f64;
                // f32 rounding of cos θ is amplified by 1/cos(θ − φ) near grazing angles.
                let tol = 1e-6 / (theta - phi as f64).cos() + 1e-4 * exact;
                assert!(
                    (s - exact).abs() <= tol,
                    "φ = {phi}, θ = {}°: {s} vs {exact}",
                    i as f64 / 10.0
                );
            }
        }
    }

    /// The parallel-ray slope is Eq. 1's limit for a distant eye whose
    /// pixel diagonal spans the same length at the surface: evaluated in
    /// f64 as written, t |1 − cos θ / cos(θ − φ)| with tan φ = diag / t,
    /// for t = 10⁴ · diag.
    #[test]
    fn parallel_slope_is_the_far_limit_of_eq1() {
        let diag = 0.01f32;
        let t = 1.0e4 * diag as f64;
        let phi = (diag as f64 / t).atan();
        for deg in [0.0f64, 10.0, 45.0, 70.0, 85.0, 89.0] {
            let theta = deg.to_radians();
            let far = t * (1.0 - theta.cos() / (theta - phi).cos()).abs();
            let s = normal_slope_parallel(theta.cos() as f32, diag) as f64;
            // Neglected: the relative O(φ tan θ) term, and t·φ²/2 = diag·φ/2
            // (the perspective cone's own growth, non-zero head on).
            let tol = far * (2.0 * phi * theta.tan() + 1e-5) + diag as f64 * phi;
            assert!((s - far).abs() <= tol, "θ = {deg}°: {s} vs {far}");
        }
        // Head on: 0; edge-on and back-facing: unbounded, so Eq. 2 holds.
        assert_eq!(normal_slope_parallel(1.0, diag), 0.0);
        assert_eq!(normal_slope_parallel(0.0, diag), f32::INFINITY);
        assert_eq!(normal_slope_parallel(-0.5, diag), f32::INFINITY);
        let edge_on = normal_slope_parallel(0.0, diag);
        let tol = 0.005 * tolerance_scale(2.0 + 2.0 * edge_on, Some(1.0));
        assert!(depths_consistent(2.0, edge_on, 1e6, tol));
        // A steep surface (tan θ = 100) at any depth: a spread within a 3×3
        // block of up to 2·diag·tan θ (1.5× here) passes Eq. 2, 3× does not.
        let c = (1.0f32 / (1.0 + 100.0 * 100.0)).sqrt();
        let s = normal_slope_parallel(c, diag);
        for t in [2.0f32, 1000.0] {
            let tol = 0.005 * tolerance_scale(t + 2.0 * s, Some(1.0));
            assert!(depths_consistent(t, s, t + 1.5 * s, tol));
            assert!(!depths_consistent(t, s, t + 3.0 * s, tol));
        }
    }

    #[test]
    fn buckets_cover_the_range_monotonically() {
        let (lo, hi) = (importance(1000.0), importance(0.0));
        assert_eq!(importance_bucket(hi, lo, hi), HIST_M - 1);
        assert_eq!(importance_bucket(lo, lo, hi), 0);
        let mut prev = 0;
        for c in (0..=1000).rev() {
            let b = importance_bucket(importance(c as f32), lo, hi);
            assert!(b >= prev, "bucket not monotone in importance");
            prev = b;
        }
        // Outside the bounds clamps; degenerate bounds go to the top bucket.
        assert_eq!(importance_bucket(2.0, lo, hi), HIST_M - 1);
        assert_eq!(importance_bucket(1e-9, lo, hi), 0);
        assert_eq!(importance_bucket(0.5, 0.5, 0.5), HIST_M - 1);
        assert_eq!(importance_bucket(0.5, 0.0, 1.0), HIST_M - 1);
        // Logarithmic: equal ratios of w land in equally spaced buckets.
        let b1 = importance_bucket(lo * 2.0, lo, lo * 2f32.powi(13));
        let b2 = importance_bucket(lo * 4.0, lo, lo * 2f32.powi(13));
        assert_eq!((b1, b2), (1, 2));
    }

    #[test]
    fn empty_or_broken_counts_restart_at_one() {
        // As the shader's !(c > 0): 0, negative and NaN counts are empty records.
        for c in [0.0, -1.0, f32::NAN] {
            assert_eq!(accumulated_count(c, 0.1), 1.0, "{c}");
        }
        assert_eq!(accumulated_count(5.0, 1.0), 1.0);
    }

    /// The effective count is what the variance says: many independent
    /// records accumulate N(0, 1) samples with α floored at appendix C's
    /// α_min(0.2) = 0.42 (and at 0.1, §5.2's fixed α); after every step the
    /// records' empirical variance equals 1/c within 4 standard errors
    /// (relative standard error √(2/(records − 1)) of a variance estimate).
    #[test]
    fn effective_count_predicts_the_variance_of_the_average() {
        let mut state = 0x1234_5678_9abc_def0u64;
        let mut normal = move || {
            let mut u = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 40) as f64 + 0.5) / (1u64 << 24) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let records = 20_000usize;
        for floor in [alpha_min(0.2), 0.1] {
            let mut x = vec![0.0f64; records];
            let mut c = 0.0f32;
            for step in 0..40 {
                let (alpha, c_next) = accumulate(c, floor);
                for v in x.iter_mut() {
                    *v += alpha as f64 * (normal() - *v);
                }
                c = c_next;
                if ![0, 4, 9, 19, 39].contains(&step) {
                    continue;
                }
                let mean = x.iter().sum::<f64>() / records as f64;
                let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (records - 1) as f64;
                let predicted = 1.0 / c as f64;
                let tol = 4.0 * predicted * (2.0 / (records - 1) as f64).sqrt();
                assert!(
                    (var - predicted).abs() < tol,
                    "floor {floor}, step {step}: variance {var} vs 1/c = {predicted} ± {tol}"
                );
            }
            // The running mean counts exactly until 1/(c + 1) falls below the
            // floor; then c tends to (2 − α)/α.
            assert!(
                (c - (2.0 - floor) / floor).abs() < 0.01 * c,
                "floor {floor}: c = {c}"
            );
        }
        for k in 0..50 {
            assert_eq!(
                accumulate(k as f32, 0.0),
                (1.0 / (k as f32 + 1.0), k as f32 + 1.0)
            );
        }
        assert_eq!(accumulate(0.0, 0.1), (1.0, 1.0));
    }

    #[test]
    fn appendix_c_alpha_min() {
        assert_eq!(alpha_min(0.0), 0.5);
        assert!((alpha_min(1.0) - 0.1).abs() < 1e-7);
        assert!((alpha_min(0.2) - 0.42).abs() < 1e-6);
    }

    /// Every block of a 10×7 image (full blocks, and blocks cut by both
    /// borders) has exactly one base pixel per frame, and every pixel is
    /// its block's base pixel exactly once in every window of n
    /// consecutive frames (n = the block's pixels in the image: 16 for a
    /// full block), in both eyes, across the u32 frame counter's wrap
    /// where n divides 2^32 (a full block) — so no pixel waits longer than
    /// n frames for its retrace. The order of a full block spreads
    /// consecutive base pixels: never 4-neighbours.
    #[test]
    fn a_base_pixel_walks_its_slots_over_its_visits() {
        // At 4 occupied slots the slot of each visit, visit mod 4, takes all
        // four values over four consecutive visits (frame mod 4 at visits 16
        // frames apart took one), for every pixel of full and cut blocks.
        let size = [10u32, 7];
        for eye in 0..2 {
            for y in 0..size[1] {
                for x in 0..size[0] {
                    let visits: Vec<u32> = (0..64u32)
                        .filter_map(|f| sparse_base_visit([x, y], size, 1000 + f, eye))
                        .collect();
                    assert!(visits.len() >= 4, "({x}, {y}): {visits:?}");
                    let slots: std::collections::BTreeSet<u32> =
                        visits[..4].iter().map(|v| v % 4).collect();
                    assert_eq!(slots.len(), 4, "({x}, {y}) eye {eye}: visits {visits:?}");
                }
            }
        }
    }

    #[test]
    fn base_pixels_rotate_through_every_pixel_of_a_block() {
        let size = [10u32, 7];
        for eye in 0..2 {
            for start in [0u32, 1000, u32::MAX - 40] {
                let frames: Vec<u32> = (0..48).map(|k| start.wrapping_add(k)).collect();
                for by in 0..2 {
                    for bx in 0..3 {
                        let pixels: Vec<[u32; 2]> = (0..4)
                            .flat_map(|y| (0..4).map(move |x| [4 * bx + x, 4 * by + y]))
                            .filter(|p| p[0] < size[0] && p[1] < size[1])
                            .collect();
                        let n = pixels.len();
                        let base: Vec<usize> = frames
                            .iter()
                            .map(|&f| {
                                let hits: Vec<usize> = (0..n)
                                    .filter(|&i| is_sparse_base_pixel(pixels[i], size, f, eye))
                                    .collect();
                                assert_eq!(
                                    hits.len(),
                                    1,
                                    "block ({bx}, {by}), frame {f}: {hits:?}"
                                );
                                hits[0]
                            })
                            .collect();
                        // The wrap of a cut block's n (not a divisor of
                        // 2^32) may repeat a pixel once there.
                        if n != 16 && start > u32::MAX - 48 {
                            continue;
                        }
                        for w in base.windows(n) {
                            let mut seen = vec![false; n];
                            for &i in w {
                                assert!(
                                    !seen[i],
                                    "block ({bx}, {by}): pixel {i} twice in {n} frames"
                                );
                                seen[i] = true;
                            }
                        }
                        if n == 16 {
                            for p in base.windows(2) {
                                let (a, b) = (pixels[p[0]], pixels[p[1]]);
                                let d = a[0].abs_diff(b[0]) + a[1].abs_diff(b[1]);
                                assert!(d > 1, "consecutive base pixels {a:?}, {b:?} adjacent");
                            }
                        }
                    }
                }
            }
        }
    }
}
