//! The reference's own error, estimated from two independent half-sample
//! renders (the "half-buffer" or split-sample variance estimate).
//!
//! Every error figure is measured against a Monte Carlo reference `R`, which
//! is itself noisy. `compare` renders it as two independent halves `A` and `B`
//! (different seeds, `spp/2` samples each) and uses their mean `R = (A + B)/2`
//! (the same `spp` samples a single render would take, so no extra cost).
//!
//! **Derivation.** Per pixel and channel let `T` be the converged value and
//! `A`, `B` unbiased and independent with `Var A = Var B = s²` (same sample
//! count, same integrand). Then `E R = T`, `Var R = s²/2`, and
//!
//! `E (A − B)² = Var A + Var B = 2 s² = 4 Var R`,
//!
//! so `d² = ((A − B)/2)²` is an unbiased estimate of `Var R = E (R − T)²`
//! whatever the noise distribution (only independence and equal variance are
//! used). Hence:
//!
//! - **MSE** of `R` against `T`: `MSE_ref ≈ 1/(3N) Σ_p Σ_c d²` — unbiased.
//! - **RSE** with the project's `ε` ([`super::error::rse`]: squared error over
//!   `r² + ε`, `ε = RSE_EPSILON = 0.01`, averaged over pixels and RGB):
//!   `RSE_ref ≈ 1/(3N) Σ_p Σ_c d² / (R² + ε)`. `T` is unknown, so the
//!   denominator is `R`'s — as in every method's RSE, where `R` is the `r` of
//!   [`super::error::rse`]. What this estimates is `rse(T; R) = 1/(3N) Σ
//!   (T − R)²/(R² + ε)`: the RSE at which the *converged image itself* would
//!   be measured against this reference, i.e. the floor the reference puts
//!   under every method's RSE. To first order in the noise, `E d² f(R)` and
//!   `E (R − T)² f(R)` (`f(R) = 1/(R² + ε)`) agree: both are
//!   `Var R f(T) + f'(T) E (R − T)³` because `E d² (R − T) = E (R − T)³ =
//!   μ₃/4` (`μ₃` the halves' third central moment). The remaining difference
//!   is of relative order `ρ = Var R/(T² + ε)`, the pixel's own RSE (≈ −6ρ
//!   for Gaussian noise on bright pixels) — negligible exactly when the
//!   reference is good enough to use. (Against
//!   `rse(R; T)`, with the truth's denominator, the estimate differs by the
//!   skewness term `f'(T) μ₃/4`, relative `≈ −skew · 2T s/(T² + ε)` for halves
//!   of standard deviation `s`: zero for symmetric noise, a few per cent low
//!   for skewed path-tracing noise at the noise levels where it matters.)
//!
//! **What it means for the methods' figures.** For a method image `X`
//! independent of `R`, `E (X − R)² = E (X − T)² + Var R` (the cross term
//! vanishes), so every measured MSE is the true one plus `MSE_ref`, and the
//! measured RSE likewise plus `RSE_ref` to first order. A reference whose RSE
//! is a tenth of the best method's inflates that method's figure by 10 %
//! (and the others' by less).
//!
//! **Standard error.** Pixels are independent (their random numbers are),
//! the three channels of one pixel are not (same paths), so the standard
//! error is that of the mean of the per-pixel terms (mean over RGB):
//! `sd(u_p)/√N`.

use super::check::MetricsError;
use super::image::{sanitize, LinearImage};

/// The estimated error of the mean of two independent half references
/// against the converged image, with standard errors (module documentation:
/// the RSE is `rse(T; R)`, the floor under every method's RSE).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ReferenceNoise {
    /// Estimated RSE of `(A + B)/2` against the converged image (`ε` as given).
    pub rse: f64,
    pub rse_stderr: f64,
    /// Estimated MSE (linear) of `(A + B)/2` against the converged image.
    pub mse: f64,
    pub mse_stderr: f64,
    /// Pixels the estimate averages over.
    pub pixels: usize,
}

impl ReferenceNoise {
    /// The mean of several estimates of equal pixel counts (frames, eyes):
    /// means of the values, standard errors combined as independent
    /// (`√(Σ se²)/k`).
    pub fn mean(parts: &[ReferenceNoise]) -> ReferenceNoise {
        let k = parts.len().max(1) as f64;
        let sum = |f: fn(&ReferenceNoise) -> f64| parts.iter().map(f).sum::<f64>() / k;
        let se = |f: fn(&ReferenceNoise) -> f64| {
            parts.iter().map(|p| f(p).powi(2)).sum::<f64>().sqrt() / k
        };
        ReferenceNoise {
            rse: sum(|p| p.rse),
            rse_stderr: se(|p| p.rse_stderr),
            mse: sum(|p| p.mse),
            mse_stderr: se(|p| p.mse_stderr),
            pixels: parts.iter().map(|p| p.pixels).sum(),
        }
    }
}

/// The mean `(A + B)/2` of two half references (sanitized: non-finite → 0).
pub fn mean_of_halves(a: &LinearImage, b: &LinearImage) -> Result<LinearImage, MetricsError> {
    a.check_same_size(b, "reference half B")?;
    let rgb = a
        .rgb
        .iter()
        .zip(&b.rgb)
        .map(|(&p, &q)| {
            let (p, q) = (sanitize(p), sanitize(q));
            [0, 1, 2].map(|c| 0.5 * (p[c] + q[c]))
        })
        .collect();
    LinearImage::new(a.width, a.height, rgb)
}

/// The error of `(A + B)/2` against the converged image, estimated from the
/// two independent halves `a` and `b` (module documentation), RSE with `eps`
/// (use [`super::RSE_EPSILON`]; `eps ≤ 0` or non-finite is replaced by it,
/// as in [`super::error::rse`]).
pub fn half_split_error(
    a: &LinearImage,
    b: &LinearImage,
    eps: f32,
) -> Result<ReferenceNoise, MetricsError> {
    a.check_same_size(b, "reference half B")?;
    let eps = if eps > 0.0 && eps.is_finite() {
        eps
    } else {
        super::RSE_EPSILON
    } as f64;
    let n = a.len();
    let (mut s_rse, mut s2_rse, mut s_mse, mut s2_mse) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (&p, &q) in a.rgb.iter().zip(&b.rgb) {
        let (p, q) = (sanitize(p), sanitize(q));
        let (mut u_rse, mut u_mse) = (0.0, 0.0);
        for c in 0..3 {
            let (x, y) = (p[c] as f64, q[c] as f64);
            let d2 = (0.5 * (x - y)).powi(2);
            let r = 0.5 * (x + y);
            u_mse += d2 / 3.0;
            u_rse += d2 / (r * r + eps) / 3.0;
        }
        s_rse += u_rse;
        s2_rse += u_rse * u_rse;
        s_mse += u_mse;
        s2_mse += u_mse * u_mse;
    }
    let nf = n as f64;
    let stderr = |s: f64, s2: f64| {
        if n < 2 {
            return f64::INFINITY;
        }
        let mean = s / nf;
        let var = ((s2 - nf * mean * mean) / (nf - 1.0)).max(0.0);
        (var / nf).sqrt()
    };
    Ok(ReferenceNoise {
        rse: s_rse / nf,
        rse_stderr: stderr(s_rse, s2_rse),
        mse: s_mse / nf,
        mse_stderr: stderr(s_mse, s2_mse),
        pixels: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::RSE_EPSILON;

    /// SplitMix64: a small deterministic generator for the synthetic noise.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        /// Standard normal (Box–Muller).
        fn normal(&mut self) -> f64 {
            let (u, v) = (self.next(), self.next());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        }
    }

    /// A converged image with dark, mid and bright pixels, and a noise level
    /// per pixel and channel (the half references' standard deviation).
    fn truth(w: usize, h: usize, k: f64) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let mut t = Vec::new();
        let mut s = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let base = 0.02 + 2.0 * (x as f64 / w as f64).powi(2) + 0.3 * (y % 3) as f64;
                let px = [base, 0.5 * base, 0.05 + 0.1 * ((x + y) % 5) as f64];
                t.push(px);
                // Noise that grows with the signal, as Monte Carlo noise does.
                s.push(px.map(|v| k * (v + 0.05).sqrt()));
            }
        }
        (t, s)
    }

    fn image(v: &[[f64; 3]], w: usize, h: usize) -> LinearImage {
        LinearImage::new(w, h, v.iter().map(|p| p.map(|c| c as f32)).collect()).unwrap()
    }

    /// What the estimator estimates, from the known truth and noise:
    /// E RSE(R; T) = mean Var R/(T² + ε), E MSE(R; T) = mean Var R, Var R = s²/2.
    fn expected(t: &[[f64; 3]], s: &[[f64; 3]]) -> (f64, f64) {
        let eps = RSE_EPSILON as f64;
        let n = (3 * t.len()) as f64;
        let mut rse = 0.0;
        let mut mse = 0.0;
        for (tp, sp) in t.iter().zip(s) {
            for c in 0..3 {
                let var_r = 0.5 * sp[c] * sp[c];
                rse += var_r / (tp[c] * tp[c] + eps);
                mse += var_r;
            }
        }
        (rse / n, mse / n)
    }

    /// Independent half images: truth plus noise of the given kind with the
    /// per-pixel standard deviations `s`.
    fn halves(
        t: &[[f64; 3]],
        s: &[[f64; 3]],
        kind: &str,
        rng: &mut Rng,
        w: usize,
        h: usize,
    ) -> (LinearImage, LinearImage) {
        let mut half = || -> Vec<[f64; 3]> {
            t.iter()
                .zip(s)
                .map(|(tp, sp)| {
                    [0, 1, 2].map(|c| {
                        let z = match kind {
                            "gaussian" => rng.normal(),
                            // Exp(1) − 1: mean 0, variance 1, skewness 2 (like
                            // path tracing's occasional bright samples).
                            _ => -rng.next().ln() - 1.0,
                        };
                        tp[c] + sp[c] * z
                    })
                })
                .collect()
        };
        let a = half();
        let b = half();
        (image(&a, w, h), image(&b, w, h))
    }

    /// Synthetic halves with known noise variance: the estimate lies within
    /// 4 of its own standard errors of the known answer (a 4σ bound fails
    /// with probability 6e-5 for an unbiased, normally distributed estimate;
    /// the seed is fixed, so the test is deterministic). MSE: exact for any
    /// noise (only independence and equal variance are used), checked for
    /// Gaussian and skewed noise. RSE: against the analytic `mean Var R/(T² +
    /// ε)` for symmetric (Gaussian) noise, where the estimate's bias is of
    /// relative order 6ρ ≈ 1e-3 here (ρ = the RSE ≈ 1.7e-4), below its
    /// standard error (≈ 1.7 % relative at 64×64).
    #[test]
    fn the_estimate_is_within_its_standard_error_of_the_known_answer() {
        let (w, h) = (64, 64);
        let (t, s) = truth(w, h, 0.01);
        let (rse_true, mse_true) = expected(&t, &s);
        for (kind, seed) in [("gaussian", 1u64), ("exponential", 2)] {
            let (a, b) = halves(&t, &s, kind, &mut Rng(seed), w, h);
            let est = half_split_error(&a, &b, RSE_EPSILON).unwrap();
            let z_rse = (est.rse - rse_true) / est.rse_stderr;
            let z_mse = (est.mse - mse_true) / est.mse_stderr;
            eprintln!(
                "{kind}: RSE {:.4e} ± {:.1e} (analytic {rse_true:.4e}, z {z_rse:.2}); MSE {:.4e} ± {:.1e} (truth {mse_true:.4e}, z {z_mse:.2})",
                est.rse, est.rse_stderr, est.mse, est.mse_stderr
            );
            assert!(z_mse.abs() < 4.0, "{kind}: MSE z = {z_mse}");
            if kind == "gaussian" {
                assert!(z_rse.abs() < 4.0, "{kind}: RSE z = {z_rse}");
            }
            // The standard error is an honest ~1/√N fraction, not vacuous.
            assert!(
                est.rse_stderr < 0.05 * rse_true,
                "{kind}: stderr {}",
                est.rse_stderr
            );
            assert_eq!(est.pixels, w * h);
        }
    }

    /// What the RSE estimate stands for, for skewed noise too: the RSE at
    /// which the truth itself is measured against the reference, `rse(T; R)`,
    /// computable here because the truth is known. Over many independent
    /// reference pairs the mean of (estimate − rse(T; R)) is 0 within 4 of
    /// its standard errors (the module's first-order argument; the
    /// second-order remainder, ≈ −6ρ relative for Gaussian noise, is 1e-3
    /// here (ρ ≈ 1.7e-4), below the standard error of ≈ 0.4 % relative; the
    /// skewness term that separates rse(T; R) from rse(R; T) is ≈ 3 %).
    #[test]
    fn the_estimate_tracks_the_rse_of_the_truth_against_the_reference() {
        let (w, h) = (32, 32);
        let (t, s) = truth(w, h, 0.01);
        let tr = image(&t, w, h);
        for (kind, seed) in [("gaussian", 3u64), ("exponential", 4)] {
            let mut rng = Rng(seed);
            let mut diffs = Vec::new();
            for _ in 0..200 {
                let (a, b) = halves(&t, &s, kind, &mut rng, w, h);
                let est = half_split_error(&a, &b, RSE_EPSILON).unwrap();
                let r = mean_of_halves(&a, &b).unwrap();
                let floor = crate::metrics::rse(&tr, &r, RSE_EPSILON).unwrap() as f64;
                diffs.push(est.rse - floor);
            }
            let n = diffs.len() as f64;
            let mean = diffs.iter().sum::<f64>() / n;
            let se = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
                / n.sqrt();
            let (rse_true, _) = expected(&t, &s);
            eprintln!(
                "{kind}: estimate − rse(T; R) = {mean:.3e} ± {se:.1e} (RSE ≈ {rse_true:.3e})"
            );
            assert!(mean.abs() < 4.0 * se, "{kind}: bias {mean} (se {se})");
        }
    }

    #[test]
    fn identical_halves_have_no_error_and_sizes_must_match() {
        let a = LinearImage::filled(4, 4, [0.5, 1.0, 0.0]);
        let e = half_split_error(&a, &a, RSE_EPSILON).unwrap();
        assert_eq!((e.rse, e.mse), (0.0, 0.0));
        assert_eq!(mean_of_halves(&a, &a).unwrap(), a);
        let b = LinearImage::filled(4, 3, [0.5, 1.0, 0.0]);
        assert!(half_split_error(&a, &b, RSE_EPSILON).is_err());
        // Combining equal-size parts: means of values, independent errors.
        let p = ReferenceNoise {
            rse: 1.0,
            rse_stderr: 0.3,
            mse: 2.0,
            mse_stderr: 0.4,
            pixels: 10,
        };
        let q = ReferenceNoise {
            rse: 3.0,
            rse_stderr: 0.4,
            mse: 4.0,
            mse_stderr: 0.3,
            pixels: 10,
        };
        let m = ReferenceNoise::mean(&[p, q]);
        assert_eq!((m.rse, m.mse, m.pixels), (2.0, 3.0, 20));
        assert!((m.rse_stderr - 0.25).abs() < 1e-12 && (m.mse_stderr - 0.25).abs() < 1e-12);
    }
}
