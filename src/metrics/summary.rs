//! [`ImageMetrics`]: every full-reference and no-reference metric of one image
//! against its reference, in one serializable record for reports.

use serde::Serialize;

use super::check::MetricsError;
use super::cpbd::cpbd;
use super::error::{mse, psnr, rse, RSE_EPSILON};
use super::flip::{flip_hdr, DEFAULT_PPD};
use super::image::LinearImage;
use super::ssim::ssim;

/// Metrics of one rendered image against its reference.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ImageMetrics {
    /// Relative squared error, `ε =` [`RSE_EPSILON`], linear values.
    pub rse: f32,
    /// Mean squared error, linear values.
    pub mse: f32,
    /// PSNR (dB) on the display image (clamped to `[0, 1]`); `+∞` (JSON
    /// `null`) for identical display images.
    pub psnr: f32,
    /// Mean SSIM on display luma.
    pub ssim: f32,
    /// Mean **HDR-FLIP** (the inputs are scene-referred radiance) at
    /// [`DEFAULT_PPD`] ([`Self::compute`]) or the given pixels per degree
    /// ([`Self::compute_at`]).
    pub flip: f32,
    /// CPBD sharpness of the test image; `None` (JSON `null`) when the
    /// image has no edge to measure (a flat image: CPBD's definition has
    /// no value there, and the authors' code returns NaN).
    pub cpbd: Option<f32>,
    /// CPBD sharpness of the reference (the paper compares the two), as `cpbd`.
    pub cpbd_reference: Option<f32>,
    /// Pixels of the test image with a non-finite channel value (each
    /// such channel replaced by 0).
    pub non_finite: usize,
}

impl ImageMetrics {
    /// All metrics of `x` against `reference`; errors when the sizes differ
    /// or the images are empty.
    pub fn compute(x: &LinearImage, reference: &LinearImage) -> Result<Self, MetricsError> {
        Self::compute_at(x, reference, DEFAULT_PPD)
    }

    /// [`Self::compute`] with FLIP at `flip_ppd` pixels per degree
    /// ([`super::ppd`]).
    pub fn compute_at(
        x: &LinearImage,
        reference: &LinearImage,
        flip_ppd: f32,
    ) -> Result<Self, MetricsError> {
        reference.check_same_size(x, "metrics: test image")?;
        Ok(Self {
            rse: rse(x, reference, RSE_EPSILON)?,
            mse: mse(x, reference)?,
            psnr: psnr(x, reference)?,
            ssim: ssim(x, reference)?.mean,
            flip: flip_hdr(x, reference, flip_ppd)?.flip.mean,
            cpbd: cpbd_with_edges(x)?,
            cpbd_reference: cpbd_with_edges(reference)?,
            non_finite: x.non_finite_count(),
        })
    }
}

/// CPBD of `x`, `None` without edges.
fn cpbd_with_edges(x: &LinearImage) -> Result<Option<f32>, MetricsError> {
    let c = cpbd(x)?;
    Ok((c.edges > 0).then_some(c.cpbd))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_image_has_no_cpbd() {
        let flat = LinearImage::from_fn(64, 64, |_, _| [0.5; 3]);
        let edges = LinearImage::from_fn(64, 64, |x, _| [if x < 32 { 0.0 } else { 1.0 }; 3]);
        let m = ImageMetrics::compute(&flat, &edges).unwrap();
        assert_eq!(m.cpbd, None);
        assert_eq!(m.cpbd_reference, Some(1.0)); // one sharp step: every edge pixel sharp
        let json = serde_json::to_value(m).unwrap();
        assert!(json["cpbd"].is_null(), "{json}");
    }

    #[test]
    fn identical_and_different_images() {
        let r = LinearImage::from_fn(64, 64, |x, y| [((x / 8 + y / 8) % 2) as f32 * 2.0; 3]);
        let m = ImageMetrics::compute(&r, &r).unwrap();
        assert_eq!((m.rse, m.mse, m.flip), (0.0, 0.0, 0.0));
        assert!(m.psnr.is_infinite() && (m.ssim - 1.0).abs() < 1e-5);
        assert_eq!(m.cpbd, m.cpbd_reference);
        let x = LinearImage::from_fn(64, 64, |x, y| r.get(x, y).unwrap().map(|c| 0.5 * c + 0.1));
        let n = ImageMetrics::compute(&x, &r).unwrap();
        assert!(n.rse > 0.0 && n.mse > 0.0 && n.psnr.is_finite() && n.ssim < 1.0);
        assert!(n.flip > 0.0 && n.flip <= 1.0);
        let json = serde_json::to_string(&n).unwrap();
        assert!(json.contains("\"flip\""));
        assert!(ImageMetrics::compute(&x, &LinearImage::filled(2, 2, [0.0; 3])).is_err());
    }
}
