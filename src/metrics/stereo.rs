//! Stereo discrepancy: the left eye reprojected into the right view
//! (Philippi et al. 2025, Sec. 5.2 and Fig. 15, bottom row).
//!
//! Per co-visible right-eye pixel, the difference is the mean absolute RGB
//! difference ([`pixel_difference`], linear values) between the right image
//! and the reprojected left image. Reported: the mean, the 95th percentile
//! (nearest rank) and the co-visible fraction. No co-visible pixel: no
//! value — `mean` and `p95` are NaN (JSON `null`), `covisible_fraction` 0 —
//! never a 0 that reads as no discrepancy; `evaluate` leaves such a pair out.

use serde::Serialize;

use super::check::MetricsError;
use super::covisibility::Covisibility;
use super::image::LinearImage;
use super::reproject::{pixel_difference, ViewBuffers};

/// Stereo discrepancy of one stereo pair.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StereoDiscrepancy {
    /// Mean per-pixel difference over co-visible pixels (NaN: none).
    pub mean: f32,
    /// 95th percentile (nearest rank) of the per-pixel difference (NaN: none).
    pub p95: f32,
    /// Co-visible pixels / all right-eye pixels.
    pub covisible_fraction: f32,
}

/// Stereo discrepancy of a stereo pair (left reprojected into right), with
/// relative depth tolerance `depth_tolerance_rel`, on the co-visibility of
/// the pair's **own** geometry; first-hit ids are compared when both eyes
/// carry them. `compare` uses [`stereo_discrepancy_masked`] with the
/// reference's geometry instead.
pub fn stereo_discrepancy(
    left: &ViewBuffers,
    right: &ViewBuffers,
    depth_tolerance_rel: f32,
) -> Result<StereoDiscrepancy, MetricsError> {
    left.image
        .check_same_size(right.image, "stereo: right image")?;
    let cov = Covisibility::new(
        left.geometry(),
        right.geometry(),
        right.image.width,
        right.image.height,
        depth_tolerance_rel,
    )?;
    stereo_discrepancy_masked(left.image, right.image, &cov)
}

/// Stereo discrepancy of `left` reprojected into `right` through a given
/// co-visibility (left view into right view): the same mask for every method
/// when it comes from the reference's geometry.
pub fn stereo_discrepancy_masked(
    left: &LinearImage,
    right: &LinearImage,
    cov: &Covisibility,
) -> Result<StereoDiscrepancy, MetricsError> {
    left.check_same_size(right, "stereo: right image")?;
    let warped = cov.warp(left)?;
    let n = right.len();
    let mut diffs: Vec<f32> = (0..n)
        .filter(|&i| cov.is_covisible(i))
        .map(|i| pixel_difference(warped.rgb[i], right.rgb[i]))
        .collect();
    if diffs.is_empty() {
        return Ok(StereoDiscrepancy {
            mean: f32::NAN,
            p95: f32::NAN,
            covisible_fraction: 0.0,
        });
    }
    let mean = (diffs.iter().map(|&d| d as f64).sum::<f64>() / diffs.len() as f64) as f32;
    diffs.sort_by(|a, b| a.total_cmp(b));
    let rank = ((0.95 * diffs.len() as f64).ceil() as usize).clamp(1, diffs.len());
    Ok(StereoDiscrepancy {
        mean,
        p95: diffs[rank - 1],
        covisible_fraction: diffs.len() as f32 / n as f32,
    })
}

#[cfg(test)]
mod tests {
    use super::super::reproject::tests::{rig, texture};
    use super::*;
    use crate::camera::Eye;

    #[test]
    fn constant_plane_has_no_discrepancy_and_full_overlap() {
        let c = rig();
        let [l, r] = [c.eye(Eye::Left), c.eye(Eye::Right)];
        let img = LinearImage::filled(64, 64, [0.3, 0.6, 0.9]);
        // At depth 8 the disparity is 0.5 px: nearly everything is co-visible.
        let depth = vec![8.0f32; 64 * 64];
        let vb = |view| ViewBuffers {
            image: &img,
            depth: &depth,
            view,
            first_hits: None,
        };
        let s = stereo_discrepancy(&vb(&l), &vb(&r), 0.01).unwrap();
        assert!(s.covisible_fraction > 0.99, "{s:?}");
        assert!(s.mean < 1e-5 && s.p95 < 1e-5, "{s:?}");
    }

    #[test]
    fn no_covisible_pixel_has_no_value() {
        let c = rig();
        let [l, r] = [c.eye(Eye::Left), c.eye(Eye::Right)];
        let img = LinearImage::filled(8, 8, [0.5; 3]);
        let sky = vec![0.0f32; 8 * 8];
        let vb = |view| ViewBuffers {
            image: &img,
            depth: &sky,
            view,
            first_hits: None,
        };
        let s = stereo_discrepancy(&vb(&l), &vb(&r), 0.01).unwrap();
        assert!(s.mean.is_nan() && s.p95.is_nan(), "{s:?}");
        assert_eq!(s.covisible_fraction, 0.0);
    }

    #[test]
    fn consistent_texture_matches_and_inconsistent_does_not() {
        let c = rig();
        let [l, r] = [c.eye(Eye::Left), c.eye(Eye::Right)];
        let left = LinearImage::from_fn(64, 64, texture);
        let right = LinearImage::from_fn(64, 64, |x, y| texture(x + 4, y));
        let depth = vec![1.0f32; 64 * 64];
        let vb = |image, view| ViewBuffers {
            image,
            depth: &depth,
            view,
            first_hits: None,
        };
        let s = stereo_discrepancy(&vb(&left, &l), &vb(&right, &r), 0.01).unwrap();
        assert!(s.mean < 1e-3 && s.p95 < 1e-3, "{s:?}");
        assert!((s.covisible_fraction - 60.0 / 64.0).abs() < 1e-6);
        // Same texture without the disparity: a clear discrepancy.
        let s = stereo_discrepancy(&vb(&left, &l), &vb(&left, &r), 0.01).unwrap();
        assert!(s.mean > 0.05 && s.p95 >= s.mean, "{s:?}");
    }
}
