//! The blending math of §3.6, evaluated identically by
//! `shaders/sample_cache/stereo_blend.comp`, and the per-pixel moments
//! (Eq. 5–6) `shaders/sample_cache/reconstruct.comp` hands it.

use std::str::FromStr;

/// `--stereo-blend`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BlendMode {
    None,
    /// β′ from the cache's per-pixel raw moments (Eq. 5–8).
    Moments,
    /// β′ from 3×3 neighbourhood estimates of the same moments (Philippi et al. 2023).
    Neighbourhood,
}

impl FromStr for BlendMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "none" => Ok(BlendMode::None),
            "moments" => Ok(BlendMode::Moments),
            "neighbourhood" | "neighborhood" => Ok(BlendMode::Neighbourhood),
            _ => Err(format!(
                "bad --stereo-blend '{s}': expected none, moments or neighbourhood"
            )),
        }
    }
}

/// Eq. 8: β′ = 1 − (μ2(Y) − μ1(Y)²) / (μ2(X) + μ2(Y) − 2 μ1(X) μ1(Y)), the
/// estimate of Eq. 4's optimal weight of Y in lerp(X, Y, β′) (Eq. 3).
///
/// Numerically safe, always finite and in [0, 1]:
/// - the variance μ2 − μ1² is clamped to ≥ 0 (it can come out negative from
///   rounding or from running means);
/// - the denominator is E[(X − Y)²] ≥ Var(Y); when it is not positive and
///   finite (X and Y identical, or non-finite inputs) there is nothing to gain
///   and Y is kept (β′ = 1);
/// - the result is clamped to [0, 1].
pub fn beta_prime(m1x: f32, m2x: f32, m1y: f32, m2y: f32) -> f32 {
    let var_y = (m2y - m1y * m1y).max(0.0);
    // Var(X) + Var(Y) + Bias², each variance clamped at 0: X's resampled
    // moments can give a negative variance under Dodgson's negative lobes
    // (R > ½), which used to drive β′ to 0.
    let var_x = (m2x - m1x * m1x).max(0.0);
    let denom = var_x + var_y + (m1x - m1y) * (m1x - m1y);
    if !(denom.is_finite() && denom > 1e-12 && var_y.is_finite()) {
        return 1.0;
    }
    (1.0 - var_y / denom).clamp(0.0, 1.0)
}

/// Eq. 5–6 as `reconstruct.comp` evaluates them for one pixel (one colour
/// channel): the raw moments μ1 = Σ c_s L_s / c_X and μ2 = Σ c_s L_s² / c_X
/// over the pixel's visible samples. `surface` = (L_s, c_s) of its visible
/// surface samples, L_s the sample's accumulated mean (an exponential
/// average) and c_s its effective sample count (0: not shaded yet, left
/// out of the sums but counted in n_surf); `background` = the radiance of
/// its visible background samples (§3.3), each weighing c_bg = c_total /
/// n_surf (1 without a surface sample), so that surface and background
/// weigh n_surf : n_bg as in the pixel's colour. c_X = c_total + c_bg·n_bg.
/// So σ² = μ2 − μ1² (Eq. 7) is the c-weighted spread of the per-sample
/// means — the variance of one sample's mean, not of the pixel's average of
/// them (which would be about σ²/n). None where nothing estimates it: no
/// visible sample, or surface samples none of which is shaded (the shader
/// then writes μ1 = colour, μ2 = colour²: no spread).
pub fn pixel_moments(surface: &[(f32, f32)], background: &[f32]) -> Option<(f32, f32)> {
    let (mut m1, mut m2, mut c_total, mut shaded) = (0.0f32, 0.0f32, 0.0f32, 0usize);
    for &(l, cs) in surface.iter().filter(|(_, cs)| *cs > 0.0) {
        m1 += cs * l;
        m2 += cs * l * l;
        c_total += cs;
        shaded += 1;
    }
    if !surface.is_empty() && shaded == 0 {
        return None;
    }
    let n_surf = surface.len() as f32;
    let c_bg = if shaded > 0 { c_total / n_surf } else { 1.0 };
    let (bg1, bg2) = background
        .iter()
        .fold((0.0f32, 0.0f32), |(a, b), &l| (a + l, b + l * l));
    let c = c_total + c_bg * background.len() as f32;
    (c > 0.0).then(|| ((m1 + c_bg * bg1) / c, (m2 + c_bg * bg2) / c))
}

/// Dodgson's quadratic resampling kernel (Dodgson 1997) with parameter r:
/// −2r s² + (r + 1)/2 for |s| ≤ ½, r s² − (2r + ½)|s| + ¾(r + 1) for
/// ½ < |s| ≤ 3/2, else 0. r = 1 interpolates (weight 1 at 0, 0 at ±1);
/// smaller r blurs. The sharpness R is used as r.
pub fn dodgson(s: f32, r: f32) -> f32 {
    let a = s.abs();
    if a <= 0.5 {
        -2.0 * r * a * a + 0.5 * (r + 1.0)
    } else if a <= 1.5 {
        r * a * a - (2.0 * r + 0.5) * a + 0.75 * (r + 1.0)
    } else {
        0.0
    }
}

/// Weight of a 3×3 neighbour in the blur of the moments: 1 − R (the centre
/// has weight 1), so R = 1 uses the pixel alone.
pub fn neighbour_weight(sharpness: f32) -> f32 {
    1.0 - sharpness.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator for the Monte Carlo tests.
    struct Lcg(u64);
    impl Lcg {
        fn uniform(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        }
        /// Standard normal by Box–Muller.
        fn normal(&mut self) -> f32 {
            let (u, v) = (self.uniform(), self.uniform());
            (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * v).cos()
        }
    }

    #[test]
    fn exact_moments_give_the_analytic_optimum_of_eq4() {
        // X ~ (μx, σx²), Y ~ (μy, σy²): raw moments μ2 = σ² + μ².
        for &(mx, sx, my, sy) in &[
            (1.0f32, 0.5f32, 1.0f32, 0.5f32),
            (1.0, 0.2, 1.3, 0.6),
            (0.5, 1.0, 0.4, 0.1),
            (2.0, 0.0, 2.0, 0.7),
        ] {
            let bias2 = (mx - my) * (mx - my);
            let optimum = 1.0 - sy * sy / (bias2 + sx * sx + sy * sy);
            let b = beta_prime(mx, sx * sx + mx * mx, my, sy * sy + my * my);
            assert!(
                (b - optimum).abs() < 1e-5,
                "({mx},{sx},{my},{sy}): {b} vs {optimum}"
            );
        }
    }

    #[test]
    fn adversarial_moments_stay_finite_and_in_range() {
        for (m1x, m2x, m1y, m2y) in [
            (1.0, 1.0, 1.0, 1.0),      // identical, zero variance: denominator 0
            (0.0, 0.0, 0.0, 0.0),      // all zero
            (1.0, 0.5, 1.0, 0.9),      // negative variance of X (μ2 < μ1²)
            (2.0, 1.0, 2.0, 1.0),      // both negative variances
            (f32::NAN, 1.0, 1.0, 2.0), // NaN
            (f32::INFINITY, f32::INFINITY, 1.0, 2.0),
            (1e30, 1e38, 1e30, 1e38),     // overflow
            (1e-30, 1e-40, 1e-30, 1e-40), // underflow
        ] {
            let b = beta_prime(m1x, m2x, m1y, m2y);
            assert!(
                b.is_finite() && (0.0..=1.0).contains(&b),
                "({m1x},{m2x},{m1y},{m2y}) → {b}"
            );
        }
        assert_eq!(beta_prime(1.0, 1.0, 1.0, 1.0), 1.0);
    }

    /// X's moments resampled with Dodgson's negative lobes (R > ½) can give
    /// μ2X < μ1X²: Var(X) counts as 0, so β′ = 1 − Var(Y)/(Var(Y) + Bias²)
    /// = 1 − 2/2.0625. Before session 43 the raw μ2X entered the
    /// denominator (1.0 here) and β′ clamped to 0: all X, whatever Y's
    /// variance.
    #[test]
    fn negative_resampled_variance_of_x_counts_as_zero() {
        let b = beta_prime(0.75, -0.5, 1.0, 3.0);
        assert!((b - (1.0 - 2.0 / 2.0625)).abs() < 1e-6, "{b}");
    }

    /// One pixel as the cache holds it: n visible samples, each the mean of
    /// `c` radiance samples ~ N(μ, σ²); returns (pixel colour = the plain
    /// mean of the per-sample means, as reconstruct.comp averages them, and
    /// the Eq. 5–6 moments the shader computes from them).
    fn cached_pixel(rng: &mut Lcg, mu: f32, sigma: f32, n: usize, c: usize) -> (f32, (f32, f32)) {
        let means: Vec<(f32, f32)> = (0..n)
            .map(|_| {
                let l = (0..c).map(|_| mu + sigma * rng.normal()).sum::<f32>() / c as f32;
                (l, c as f32)
            })
            .collect();
        let colour = means.iter().map(|m| m.0).sum::<f32>() / n as f32;
        (colour, pixel_moments(&means, &[]).unwrap())
    }

    #[test]
    fn pixel_moments_are_eq5_and_eq6() {
        // Weighted by c_s: two samples 1.0 (c = 3) and 2.0 (c = 1).
        let (m1, m2) = pixel_moments(&[(1.0, 3.0), (2.0, 1.0), (9.0, 0.0)], &[]).unwrap();
        assert!((m1 - 1.25).abs() < 1e-6 && (m2 - 1.75).abs() < 1e-6);
        // A single sample has no spread: σ² = μ2 − μ1² = 0.
        let (a, b) = pixel_moments(&[(0.7, 5.0)], &[]).unwrap();
        assert!((b - a * a).abs() < 1e-6);
        assert!(beta_prime(0.3, 0.3 * 0.3 + 0.1, a, b) > 1.0 - 1e-6);
        // Only unshaded surface samples: no estimate (the shader's colour²).
        assert!(pixel_moments(&[(1.0, 0.0)], &[]).is_none());
        assert!(pixel_moments(&[(1.0, 0.0)], &[3.0]).is_none());
        assert!(pixel_moments(&[], &[]).is_none());
        // One shaded surface sample (L = 1, c = 4) and one background sample
        // (L = 3) weighing c_total / n_surf = 4: μ1 = (4 + 12) / 8 = 2,
        // μ2 = (4 + 36) / 8 = 5.
        let (m1, m2) = pixel_moments(&[(1.0, 4.0)], &[3.0]).unwrap();
        assert!(
            (m1 - 2.0).abs() < 1e-6 && (m2 - 5.0).abs() < 1e-6,
            "{m1} {m2}"
        );
        // An unshaded surface sample beside them counts in n_surf: c_bg = 4 / 2,
        // μ1 = (4 + 6) / 6, μ2 = (4 + 18) / 6.
        let (m1, m2) = pixel_moments(&[(1.0, 4.0), (7.0, 0.0)], &[3.0]).unwrap();
        assert!((m1 - 10.0 / 6.0).abs() < 1e-6 && (m2 - 22.0 / 6.0).abs() < 1e-6);
        // Background alone: weight 1 each.
        let (m1, m2) = pixel_moments(&[], &[1.0, 3.0]).unwrap();
        assert!((m1 - 2.0).abs() < 1e-6 && (m2 - 5.0).abs() < 1e-6);
    }

    /// Eq. 4's optimum from the shader's estimator. Per pixel the moments
    /// are Eq. 5–6 over n per-sample means, each the mean of c radiance
    /// samples of variance σ²: E[μ1] = μ and E[μ2] = μ² + σ²/c, so the
    /// variance Eq. 8 works with is that of one per-sample mean, σ²/c (not
    /// the pixel average's σ²/(nc)). Eq. 8 on the moments averaged over many
    /// pixels is then exactly Eq. 4 with σ_X² = σ_Y² = σ²/c and Bias² =
    /// (μ_X − μ_Y)². (Per pixel, μ2 − μ1² is the spread of n means, whose
    /// expectation is (n − 1)/n · σ²/c.) Tolerance: 4 standard errors of β′
    /// from the averaged moments (delta method).
    #[test]
    fn eq8_on_the_shaders_moments_gives_eq4s_optimum() {
        let mut rng = Lcg(11);
        let (sigma, n, c, pixels) = (0.5f32, 4usize, 3usize, 40_000usize);
        for &(mx, my) in &[(1.0f32, 1.0f32), (1.0, 1.2), (0.6, 1.0)] {
            let v: Vec<[f64; 4]> = (0..pixels)
                .map(|_| {
                    let (_, (x1, x2)) = cached_pixel(&mut rng, mx, sigma, n, c);
                    let (_, (y1, y2)) = cached_pixel(&mut rng, my, sigma, n, c);
                    [x1 as f64, x2 as f64, y1 as f64, y2 as f64]
                })
                .collect();
            let mean: Vec<f64> = (0..4)
                .map(|k| v.iter().map(|p| p[k]).sum::<f64>() / pixels as f64)
                .collect();
            let b = beta_prime(
                mean[0] as f32,
                mean[1] as f32,
                mean[2] as f32,
                mean[3] as f32,
            ) as f64;
            let var = (sigma * sigma) as f64 / c as f64;
            let bias2 = ((mx - my) as f64).powi(2);
            let optimum = 1.0 - var / (bias2 + 2.0 * var);
            // Standard error of β′ by the delta method: β′ = 1 − num/den with
            // num = m2y − m1y², den = m2x + m2y − 2 m1x m1y; each pixel's
            // linearized contribution carries the moments' covariances.
            let (num, den) = (
                mean[3] - mean[2].powi(2),
                mean[1] + mean[3] - 2.0 * mean[0] * mean[2],
            );
            let grad = [
                -num / den.powi(2) * 2.0 * mean[2],
                num / den.powi(2),
                2.0 * mean[2] / den - num / den.powi(2) * 2.0 * mean[0],
                -1.0 / den + num / den.powi(2),
            ];
            let g: Vec<f64> = v
                .iter()
                .map(|p| (0..4).map(|k| grad[k] * (p[k] - mean[k])).sum())
                .collect();
            let se = (g.iter().map(|x| x * x).sum::<f64>() / (pixels as f64 - 1.0) / pixels as f64)
                .sqrt();
            let tol = 4.0 * se + 1e-5;
            assert!(
                (b - optimum).abs() < tol,
                "μx {mx} μy {my}: β′ {b} vs Eq. 4 {optimum} ± {tol}"
            );
        }
    }

    /// A noisy stereo pair as the cache renders it (the pixel colour is the
    /// mean of n per-sample means; β′ from the shader's Eq. 5–6 moments):
    /// blending lowers the squared error of Y, and cannot beat the optimal
    /// weight's error.
    #[test]
    fn moments_blending_lowers_the_error_of_a_noisy_stereo_pair() {
        let mut rng = Lcg(7);
        let (truth, sigma, n, c, pixels) = (1.0f32, 0.5f32, 4usize, 2usize, 20_000usize);
        let (mut err_y, mut err_blend) = (0.0f64, 0.0f64);
        let mut betas = 0.0f64;
        let mut gains = Vec::with_capacity(pixels);
        for _ in 0..pixels {
            let (x, (x1, x2)) = cached_pixel(&mut rng, truth, sigma, n, c);
            let (y, (y1, y2)) = cached_pixel(&mut rng, truth, sigma, n, c);
            let b = beta_prime(x1, x2, y1, y2);
            betas += b as f64;
            let blended = (1.0 - b) * x + b * y;
            let (ey, eb) = (
                ((y - truth) as f64).powi(2),
                ((blended - truth) as f64).powi(2),
            );
            err_y += ey;
            err_blend += eb;
            gains.push(ey - eb);
        }
        let (err_y, err_blend) = (err_y / pixels as f64, err_blend / pixels as f64);
        // Var(Y) = σ²/(nc); its estimate from `pixels` squared errors has a
        // relative standard error √(2/pixels).
        let var_y = (sigma * sigma) as f64 / (n * c) as f64;
        assert!(
            (err_y - var_y).abs() < 4.0 * var_y * (2.0 / pixels as f64).sqrt(),
            "{err_y} vs {var_y}"
        );
        let mean_gain = gains.iter().sum::<f64>() / pixels as f64;
        let se = (gains.iter().map(|g| (g - mean_gain).powi(2)).sum::<f64>()
            / (pixels as f64 - 1.0)
            / pixels as f64)
            .sqrt();
        assert!(
            mean_gain > 4.0 * se,
            "blending {err_blend} vs unblended {err_y} (gain {mean_gain} ± {se})"
        );
        // The optimal weight (½ for equal variances, no bias) halves Var(Y).
        assert!(err_blend > 0.5 * var_y * (1.0 - 4.0 * (2.0 / pixels as f64).sqrt()));
        // Per pixel, the numerator μ2 − μ1² of Y has expectation (n − 1)/n · σ²/c
        // and the denominator 2σ²/c (two spreads plus (μ1X − μ1Y)², 2σ²/(nc)),
        // so β′ centres near 1 − (n − 1)/(2n) = 0.625 for n = 4 (the σ²/n
        // estimate the old test assumed centred near 0.75); the ratio's
        // nonlinearity moves the mean a little.
        let mean_beta = betas / pixels as f64;
        assert!(mean_beta > 0.5 && mean_beta < 0.75, "mean β′ {mean_beta}");
    }

    #[test]
    fn dodgson_kernel_properties() {
        // r = 1: interpolating (1 at 0, 0 at ±1): at a pixel centre no
        // neighbour contributes (between centres they do: at offset ¼ the
        // taps are 0.875, 0.1875 and −0.0625).
        assert!((dodgson(0.0, 1.0) - 1.0).abs() < 1e-6);
        assert!(dodgson(1.0, 1.0).abs() < 1e-6 && dodgson(-1.0, 1.0).abs() < 1e-6);
        // Partition of unity for any r and offset: Σ_k h(s − k) = 1.
        for r in [0.0f32, 0.25, 0.5, 0.75, 1.0] {
            for i in 0..=10 {
                let s = i as f32 / 10.0 - 0.5;
                let sum: f32 = (-2..=2).map(|k| dodgson(s - k as f32, r)).sum();
                assert!((sum - 1.0).abs() < 1e-5, "r={r} s={s}: Σ = {sum}");
            }
            // Continuous at ½ and 3/2, zero beyond.
            assert!((dodgson(0.5 - 1e-6, r) - dodgson(0.5 + 1e-6, r)).abs() < 1e-4);
            assert!(dodgson(1.5, r).abs() < 1e-5 && dodgson(2.0, r) == 0.0);
        }
        assert_eq!(neighbour_weight(1.0), 0.0);
        assert_eq!(neighbour_weight(0.0), 1.0);
    }
}
