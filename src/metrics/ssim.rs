//! Structural similarity (SSIM), Wang, Bovik, Sheikh, Simoncelli: "Image
//! Quality Assessment: From Error Visibility to Structural Similarity",
//! IEEE TIP 13(4), 2004.
//!
//! Input: the **display luma** of both images
//! ([`LinearImage::display_luma`]: channels clamped to `[0, 1]`, Rec. 709
//! luminance, sRGB OETF), so `L = 1`.
//!
//! Parameters as in the paper (Sec. III-C): 11 × 11 circular-symmetric
//! Gaussian window, σ = 1.5, normalized to unit sum; `K1 = 0.01`,
//! `K2 = 0.03`, `C1 = (K1 L)²`, `C2 = (K2 L)²`. Local statistics are the
//! window-weighted mean, variance and covariance (Eqs. 14–16), and the local
//! index is Eq. 13:
//!
//! `SSIM = (2 μx μy + C1)(2 σxy + C2) / ((μx² + μy² + C1)(σx² + σy² + C2))`.
//!
//! Differences from Wang's MATLAB `ssim_index.m`, stated honestly: no
//! automatic down-sampling of large images; the map is computed at every
//! pixel with clamp-to-edge borders, and the **mean SSIM** (Eq. 17)
//! averages only pixels whose window lies fully inside the image (Wang's
//! `'valid'` region) when the image is at least 11 × 11, and all pixels
//! otherwise.

use super::check::MetricsError;
use super::filter::{gaussian_kernel, separable};
use super::image::LinearImage;

/// `K1` of Wang et al. 2004, Eq. 7.
pub const SSIM_K1: f32 = 0.01;
/// `K2` of Wang et al. 2004, Eq. 9.
pub const SSIM_K2: f32 = 0.03;
/// Gaussian window σ (pixels).
pub const SSIM_SIGMA: f32 = 1.5;
/// Gaussian window radius: 11 × 11 window.
pub const SSIM_RADIUS: usize = 5;

/// Mean SSIM and the per-pixel SSIM map.
#[derive(Clone, Debug, PartialEq)]
pub struct SsimResult {
    /// Mean SSIM (Eq. 17), in `[−1, 1]`, 1 for identical images.
    pub mean: f32,
    /// Map width (the image width).
    pub width: usize,
    /// Map height.
    pub height: usize,
    /// Row-major local SSIM values.
    pub map: Vec<f32>,
}

/// SSIM of `x` against `reference` (symmetric in its arguments).
pub fn ssim(x: &LinearImage, reference: &LinearImage) -> Result<SsimResult, MetricsError> {
    reference.check_same_size(x, "ssim: test image")?;
    let (w, h) = (x.width, x.height);
    let a = x.display_luma();
    let b = reference.display_luma();
    let map = ssim_map(&a, &b, w, h);
    let r = SSIM_RADIUS;
    let interior = w > 2 * r && h > 2 * r;
    let (mut sum, mut n) = (0.0f64, 0usize);
    for y in 0..h {
        for xx in 0..w {
            if !interior || (xx >= r && xx < w - r && y >= r && y < h - r) {
                sum += map[y * w + xx] as f64;
                n += 1;
            }
        }
    }
    Ok(SsimResult {
        mean: (sum / n.max(1) as f64) as f32,
        width: w,
        height: h,
        map,
    })
}

/// Local SSIM (Eq. 13) at every pixel of two `[0, 1]` grey planes.
pub(crate) fn ssim_map(a: &[f32], b: &[f32], w: usize, h: usize) -> Vec<f32> {
    let k = gaussian_kernel(SSIM_SIGMA, SSIM_RADIUS);
    let blur = |p: &[f32]| separable(p, w, h, &k, &k);
    let mu_a = blur(a);
    let mu_b = blur(b);
    let aa: Vec<f32> = a.iter().map(|v| v * v).collect();
    let bb: Vec<f32> = b.iter().map(|v| v * v).collect();
    let ab: Vec<f32> = a.iter().zip(b).map(|(u, v)| u * v).collect();
    let (e_aa, e_bb, e_ab) = (blur(&aa), blur(&bb), blur(&ab));
    let c1 = SSIM_K1 * SSIM_K1;
    let c2 = SSIM_K2 * SSIM_K2;
    (0..w * h)
        .map(|i| {
            let (ma, mb) = (mu_a[i], mu_b[i]);
            let va = (e_aa[i] - ma * ma).max(0.0);
            let vb = (e_bb[i] - mb * mb).max(0.0);
            let cov = e_ab[i] - ma * mb;
            ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(w: usize, h: usize) -> LinearImage {
        LinearImage::from_fn(w, h, |x, y| {
            let v = ((x * 7 + y * 13) % 17) as f32 / 16.0;
            [v, v * 0.5, 1.0 - v]
        })
    }

    #[test]
    fn identical_is_one() {
        let a = pattern(32, 24);
        let s = ssim(&a, &a).unwrap();
        assert!((s.mean - 1.0).abs() < 1e-5);
        assert_eq!(s.map.len(), 32 * 24);
    }

    #[test]
    fn decreases_with_noise_and_is_symmetric() {
        let a = pattern(48, 48);
        let mut state = 1u32;
        let mut noisy = |amp: f32| {
            LinearImage::from_fn(48, 48, |x, y| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let n = (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
                a.get(x, y).unwrap().map(|c| c + amp * n)
            })
        };
        let n1 = noisy(0.05);
        let n2 = noisy(0.3);
        let s1 = ssim(&n1, &a).unwrap().mean;
        let s2 = ssim(&n2, &a).unwrap().mean;
        assert!(1.0 > s1 && s1 > s2, "{s1} {s2}");
        assert!((ssim(&a, &n1).unwrap().mean - s1).abs() < 1e-5);
    }

    /// Against scikit-image 0.26 `structural_similarity(gaussian_weights=True,
    /// sigma=1.5, use_sample_covariance=False, data_range=1)` on the same
    /// display luma (clamped, Rec. 709, sRGB OETF; computed in f64 with
    /// numpy): 0.883 012 58. The pattern exceeds 1 in red, so the clamp is
    /// exercised; the noise is the LCG of `decreases_with_noise_and_is_symmetric`.
    /// Tolerance: f32 window sums (about 1e-7 absolute on a variance, over
    /// `C2 = 9e-4`).
    #[test]
    fn matches_scikit_image() {
        let a = LinearImage::from_fn(48, 40, |x, y| {
            let v = ((x * 7 + y * 13) % 17) as f32 / 16.0;
            [v * 1.2, v * 0.5, 1.0 - v]
        });
        let mut state = 1u32;
        let b = LinearImage::from_fn(48, 40, |x, y| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let n = (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
            a.get(x, y).unwrap().map(|c| c + 0.3 * n)
        });
        let s = ssim(&a, &b).unwrap().mean;
        assert!((s - 0.883_012_6).abs() < 1e-4, "{s}");
    }

    #[test]
    fn tiny_images_do_not_panic() {
        let a = pattern(3, 2);
        assert!(ssim(&a, &a).unwrap().mean > 0.999);
    }
}
