//! Pixel-wise error against a reference: relative squared error (RSE), mean
//! squared error (MSE) and PSNR.
//!
//! All three average over **pixels and the three RGB channels** (each channel
//! of each pixel is one term), accumulate in `f64`, and replace non-finite
//! values by `0` first (see [`super::image`]).

use super::check::MetricsError;
use super::image::{sanitize, LinearImage};

/// ε of the relative squared error: keeps near-black reference values from
/// dominating. `1e-2` is the value commonly used for relMSE in rendering
/// papers (e.g. Rousselle et al. 2011; Vogels et al. 2018).
pub const RSE_EPSILON: f32 = 1e-2;

/// Relative squared error (the paper's "RSE", Philippi et al. 2025, Fig. 12):
///
/// `RSE = 1/(3N) · Σ_pixels Σ_c (x_c − r_c)² / (r_c² + ε)`
///
/// on linear values (no clamping), `ε` as given (use [`RSE_EPSILON`]).
/// `eps ≤ 0` or non-finite is replaced by [`RSE_EPSILON`] so the result stays
/// finite.
pub fn rse(x: &LinearImage, r: &LinearImage, eps: f32) -> Result<f32, MetricsError> {
    r.check_same_size(x, "rse: test image")?;
    let eps = if eps > 0.0 && eps.is_finite() {
        eps
    } else {
        RSE_EPSILON
    } as f64;
    let sum: f64 = x
        .rgb
        .iter()
        .zip(&r.rgb)
        .map(|(&a, &b)| {
            let (a, b) = (sanitize(a), sanitize(b));
            (0..3)
                .map(|c| {
                    let d = a[c] as f64 - b[c] as f64;
                    d * d / ((b[c] as f64).powi(2) + eps)
                })
                .sum::<f64>()
        })
        .sum();
    Ok((sum / (3 * x.len()) as f64) as f32)
}

/// Mean squared error on linear values (no clamping):
/// `MSE = 1/(3N) · Σ_pixels Σ_c (x_c − r_c)²`.
pub fn mse(x: &LinearImage, r: &LinearImage) -> Result<f32, MetricsError> {
    r.check_same_size(x, "mse: test image")?;
    Ok(mse_f64(
        x.rgb
            .iter()
            .zip(&r.rgb)
            .map(|(&a, &b)| (sanitize(a), sanitize(b))),
    ) as f32)
}

/// Peak signal-to-noise ratio in dB on the **display image** (linear values
/// clamped to `[0, 1]`, no sRGB encoding), peak 1:
/// `PSNR = 10 · log10(1 / MSE_clamped)`.
///
/// Identical display images give `f32::INFINITY` (serialized as JSON `null`
/// by serde_json).
pub fn psnr(x: &LinearImage, r: &LinearImage) -> Result<f32, MetricsError> {
    r.check_same_size(x, "psnr: test image")?;
    let clamp = |p: [f32; 3]| sanitize(p).map(|c| c.clamp(0.0, 1.0));
    let m = mse_f64(
        x.rgb
            .iter()
            .zip(&r.rgb)
            .map(|(&a, &b)| (clamp(a), clamp(b))),
    );
    Ok(if m > 0.0 {
        (-10.0 * m.log10()) as f32
    } else {
        f32::INFINITY
    })
}

fn mse_f64(pairs: impl Iterator<Item = ([f32; 3], [f32; 3])>) -> f64 {
    let mut n = 0usize;
    let mut sum = 0.0f64;
    for (a, b) in pairs {
        for c in 0..3 {
            let d = a[c] as f64 - b[c] as f64;
            sum += d * d;
        }
        n += 3;
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_have_zero_error() {
        let a = LinearImage::from_fn(8, 8, |x, y| [x as f32, y as f32 * 0.1, 3.0]);
        assert_eq!(rse(&a, &a, RSE_EPSILON).unwrap(), 0.0);
        assert_eq!(mse(&a, &a).unwrap(), 0.0);
        assert_eq!(psnr(&a, &a).unwrap(), f32::INFINITY);
    }

    #[test]
    fn known_values() {
        let r = LinearImage::filled(4, 2, [1.0, 0.0, 0.5]);
        let x = LinearImage::filled(4, 2, [1.1, 0.1, 0.5]);
        let expected_rse = (0.01 / 1.01 + 0.01 / 0.01) / 3.0;
        assert!((rse(&x, &r, 1e-2).unwrap() - expected_rse).abs() < 1e-5);
        assert!((mse(&x, &r).unwrap() - 0.02 / 3.0).abs() < 1e-6);
        // Clamped: red 1.1 → 1.0, so only green differs.
        let p = psnr(&x, &r).unwrap();
        assert!((p - (-10.0 * (0.01f32 / 3.0).log10())).abs() < 1e-3, "{p}");
    }

    #[test]
    fn nan_counts_as_black_and_mismatch_errors() {
        let r = LinearImage::filled(2, 1, [0.5; 3]);
        let x = LinearImage::new(2, 1, vec![[f32::NAN; 3], [0.5; 3]]).unwrap();
        assert!((mse(&x, &r).unwrap() - 0.125).abs() < 1e-6);
        assert!(rse(&x, &r, f32::NAN).unwrap().is_finite());
        let bad = LinearImage::filled(1, 2, [0.5; 3]);
        assert!(mse(&bad, &r).is_err());
    }
}
