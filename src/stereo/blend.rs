//! The blending math of §3.6, evaluated identically by
//! `shaders/sample_cache/stereo_blend.comp`.

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
    let denom = m2x + m2y - 2.0 * m1x * m1y;
    if !(denom.is_finite() && denom > 1e-12 && var_y.is_finite()) {
        return 1.0;
    }
    (1.0 - var_y / denom).clamp(0.0, 1.0)
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

    /// Two noisy views of the same value: blending with β′ estimated from n
    /// samples per pixel lowers the squared error of Y, towards the
    /// error of the optimal weight (½ for equal variance, no bias).
    #[test]
    fn moments_blending_lowers_the_error_of_a_noisy_stereo_pair() {
        let mut rng = Lcg(7);
        let (truth, sigma, n, pixels) = (1.0f32, 0.5f32, 8usize, 20_000usize);
        let (mut err_y, mut err_blend) = (0.0f64, 0.0f64);
        let mut betas = 0.0f64;
        let mut gains = Vec::with_capacity(pixels);
        for _ in 0..pixels {
            let sample = |rng: &mut Lcg| -> (f32, f32) {
                let v: Vec<f32> = (0..n).map(|_| truth + sigma * rng.normal()).collect();
                let m1 = v.iter().sum::<f32>() / n as f32;
                // Moments of the pixel estimate (the mean of n samples): Var = σ²/n.
                let var =
                    v.iter().map(|x| (x - m1).powi(2)).sum::<f32>() / (n as f32 - 1.0) / n as f32;
                (m1, var + m1 * m1)
            };
            let (x1, x2) = sample(&mut rng);
            let (y1, y2) = sample(&mut rng);
            let b = beta_prime(x1, x2, y1, y2);
            betas += b as f64;
            let blended = (1.0 - b) * x1 + b * y1;
            let (ey, eb) = (
                ((y1 - truth) as f64).powi(2),
                ((blended - truth) as f64).powi(2),
            );
            err_y += ey;
            err_blend += eb;
            gains.push(ey - eb);
        }
        let (err_y, err_blend) = (err_y / pixels as f64, err_blend / pixels as f64);
        let mean_beta = betas / pixels as f64;
        // Expected: Var(Y) = σ²/n; the optimum (β = ½) halves it.
        let var_y = (sigma * sigma) as f64 / n as f64;
        assert!(
            (err_y - var_y).abs() < 4.0 * var_y * (2.0 / pixels as f64).sqrt(),
            "{err_y} vs {var_y}"
        );
        // The paired per-pixel reduction exceeds 4 standard errors of its mean.
        let mean_gain = gains.iter().sum::<f64>() / pixels as f64;
        let se = (gains.iter().map(|g| (g - mean_gain).powi(2)).sum::<f64>()
            / (pixels as f64 - 1.0)
            / pixels as f64)
            .sqrt();
        assert!(
            mean_gain > 4.0 * se,
            "blending {err_blend} vs unblended {err_y} (gain {mean_gain} ± {se})"
        );
        // It cannot beat the optimal weight's error, Var(Y)/2.
        assert!(err_blend > 0.5 * var_y * (1.0 - 4.0 * (2.0 / pixels as f64).sqrt()));
        // With estimated moments the denominator also carries (x̄ − ȳ)², whose
        // expectation is 2σ²/n: E[denominator] ≈ 4σ²/n against Var(Y) = σ²/n,
        // so β′ centres near 1 − 1/4 = 0.75 (between the optimum ½ and no
        // blending); the ratio's nonlinearity pulls the mean a little lower.
        assert!(mean_beta > 0.5 && mean_beta < 0.8, "mean β′ {mean_beta}");
    }

    #[test]
    fn dodgson_kernel_properties() {
        // r = 1: interpolating (1 at 0, 0 at ±1), so no neighbour contributes.
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
