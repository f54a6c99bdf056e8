//! Uncertainty of the per-frame means a comparison reports: the standard
//! error of a mean over frames, and of the ratio of two methods' means over
//! the same frames (issue 15: "every error figure comes with its
//! uncertainty"; "ratios to a chosen baseline with their standard errors").
//!
//! **Mean.** `x̄ = Σ x_t / n`, `se = s / √n` with `s² = Σ (x_t − x̄)² / (n − 1)`.
//! This treats the frames as independent samples of the method's error. For
//! a method that accumulates over time (sample-cache, taa, hash-cache)
//! consecutive frames are correlated and the true uncertainty of the mean is
//! larger; the figure then says how much the frames scatter, not how
//! repeatable the whole run is. `n < 2`: `se = ∞` (unknown, JSON `null`).
//!
//! **Ratio to a baseline** (the **delta method** on paired frames). Both
//! methods render the same frames, so their per-frame errors are paired and
//! positively correlated (a hard frame is hard for both). For `R = x̄ / ȳ`,
//! to first order
//!
//! `Var R ≈ (s_xx − 2 R s_xy + R² s_yy) / (n ȳ²)`,
//!
//! with the sample (co)variances `s_xy = Σ (x_t − x̄)(y_t − ȳ)/(n − 1)`. The
//! ratio of the means is what the table's columns divide (a per-frame mean
//! of `x_t / y_t` would weight easy frames with tiny `y_t` heavily and need
//! not equal the ratio of the reported means); the covariance term removes
//! the frames' shared difficulty from the ratio's error. The baseline
//! against itself: `R = 1`, `se = 0`. `ȳ = 0` or `n < 2`: `se = ∞`.

use serde::Serialize;

/// A mean over frames and its standard error.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MeanStderr {
    pub mean: f64,
    /// `∞` (JSON `null`) when fewer than two values.
    pub stderr: f64,
    pub n: usize,
}

/// Mean and standard error of `v` (module documentation); `None` when empty.
pub fn mean_stderr(v: &[f64]) -> Option<MeanStderr> {
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let stderr = if v.len() < 2 {
        f64::INFINITY
    } else {
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt()
    };
    Some(MeanStderr {
        mean,
        stderr,
        n: v.len(),
    })
}

/// `x̄ / ȳ` of paired per-frame values and its delta-method standard error
/// (module documentation); `None` when the lengths differ or are 0.
pub fn ratio_of_means(x: &[f64], y: &[f64]) -> Option<MeanStderr> {
    if x.len() != y.len() || x.is_empty() {
        return None;
    }
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let r = mx / my;
    let stderr = if x.len() < 2 || my == 0.0 || !r.is_finite() {
        f64::INFINITY
    } else {
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for (a, b) in x.iter().zip(y) {
            let (dx, dy) = (a - mx, b - my);
            sxx += dx * dx;
            sxy += dx * dy;
            syy += dy * dy;
        }
        let (sxx, sxy, syy) = (sxx / (n - 1.0), sxy / (n - 1.0), syy / (n - 1.0));
        ((sxx - 2.0 * r * sxy + r * r * syy).max(0.0) / (n * my * my)).sqrt()
    };
    Some(MeanStderr {
        mean: r,
        stderr,
        n: x.len(),
    })
}
