//! Temporal instability: the frame-to-frame reprojected difference that
//! Philippi et al. 2025 (Fig. 10) use as a proxy for temporal stability.
//!
//! Frame `t − 1` is reprojected into frame `t` ([`reproject`]); the metric is
//! the **mean absolute difference** ([`pixel_difference`]: mean over RGB of
//! `|Δ|`, linear values) over the co-visible pixels. Disocclusions, sky and
//! off-screen pixels are excluded; `covisible_fraction` says how many pixels
//! the mean rests on. No co-visible pixel: no value — `mean` is NaN (JSON
//! `null`), `covisible_fraction` 0 — never a 0 that reads as perfectly
//! stable; `evaluate` leaves such a frame out.

use serde::Serialize;

use super::check::MetricsError;
use super::covisibility::Covisibility;
use super::image::LinearImage;
use super::reproject::{pixel_difference, ViewBuffers};

/// Temporal instability of one frame pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TemporalInstability {
    /// Mean absolute RGB difference over co-visible pixels (NaN: none).
    pub mean: f32,
    /// Co-visible pixels / all pixels of frame `t`.
    pub covisible_fraction: f32,
    /// Per-pixel difference map of frame `t` (0 where not co-visible).
    #[serde(skip)]
    pub map: LinearImage,
}

/// Temporal instability between `prev` (frame `t − 1`) and `cur` (frame `t`),
/// with relative depth tolerance `depth_tolerance_rel` (e.g. 0.01), on the
/// co-visibility of the two frames' **own** geometry. First-hit ids are
/// compared when both frames carry them. `compare` uses
/// [`temporal_instability_masked`] with the reference's geometry instead.
pub fn temporal_instability(
    prev: &ViewBuffers,
    cur: &ViewBuffers,
    depth_tolerance_rel: f32,
) -> Result<TemporalInstability, MetricsError> {
    prev.image
        .check_same_size(cur.image, "temporal: current frame")?;
    let cov = Covisibility::new(
        prev.geometry(),
        cur.geometry(),
        cur.image.width,
        cur.image.height,
        depth_tolerance_rel,
    )?;
    temporal_instability_masked(prev.image, cur.image, &cov)
}

/// Temporal instability of `prev` reprojected into `cur` through a given
/// co-visibility (frame `t − 1` into frame `t`): the same mask for every
/// method when it comes from the reference's geometry.
pub fn temporal_instability_masked(
    prev: &LinearImage,
    cur: &LinearImage,
    cov: &Covisibility,
) -> Result<TemporalInstability, MetricsError> {
    prev.check_same_size(cur, "temporal: current frame")?;
    let warped = cov.warp(prev)?;
    let (mut sum, mut n) = (0.0f64, 0usize);
    let map = LinearImage::from_fn(cur.width, cur.height, |x, y| {
        let i = y * cur.width + x;
        if cov.is_covisible(i) {
            let d = pixel_difference(warped.rgb[i], cur.rgb[i]);
            sum += d as f64;
            n += 1;
            [d; 3]
        } else {
            [0.0; 3]
        }
    });
    Ok(TemporalInstability {
        mean: if n > 0 {
            (sum / n as f64) as f32
        } else {
            f32::NAN
        },
        covisible_fraction: n as f32 / cur.len() as f32,
        map,
    })
}

#[cfg(test)]
mod tests {
    use super::super::reproject::tests::{rig, texture};
    use super::*;
    use crate::camera::Eye;

    #[test]
    fn identical_frames_are_stable() {
        let v = rig().eye(Eye::Left);
        let img = LinearImage::from_fn(64, 64, texture);
        let depth: Vec<f32> = (0..64 * 64).map(|i| 1.0 + (i % 64) as f32 * 0.01).collect();
        let b = ViewBuffers {
            image: &img,
            depth: &depth,
            view: &v,
            first_hits: None,
        };
        let t = temporal_instability(&b, &b, 0.01).unwrap();
        assert!(t.mean < 1e-5, "{}", t.mean);
        assert!(t.covisible_fraction > 0.99);
    }

    #[test]
    fn no_covisible_pixel_has_no_value() {
        let v = rig().eye(Eye::Left);
        let img = LinearImage::filled(8, 8, [0.5; 3]);
        let sky = vec![0.0f32; 8 * 8];
        let b = ViewBuffers {
            image: &img,
            depth: &sky,
            view: &v,
            first_hits: None,
        };
        let t = temporal_instability(&b, &b, 0.01).unwrap();
        assert!(t.mean.is_nan() && t.covisible_fraction == 0.0, "{t:?}");
    }

    /// The head moves between the frames (the rig's left eye at t − 1, its
    /// right eye at t): a texture on a plane at depth 1 shifts 4 pixels, so
    /// frame t − 1 reprojected through the two frames' own geometry matches
    /// frame t on its 60 of 64 co-visible columns; the same image at both
    /// poses (no shift) does not.
    #[test]
    fn a_moving_head_is_reprojected_before_differencing() {
        let c = rig();
        let [l, r] = [c.eye(Eye::Left), c.eye(Eye::Right)];
        let prev = LinearImage::from_fn(64, 64, texture);
        let cur = LinearImage::from_fn(64, 64, |x, y| texture(x + 4, y));
        let depth = vec![1.0f32; 64 * 64];
        let vb = |image, view| ViewBuffers {
            image,
            depth: &depth,
            view,
            first_hits: None,
        };
        let t = temporal_instability(&vb(&prev, &l), &vb(&cur, &r), 0.01).unwrap();
        assert!(t.mean < 1e-3, "{t:?}");
        assert!(
            (t.covisible_fraction - 60.0 / 64.0).abs() < 1e-6,
            "{}",
            t.covisible_fraction
        );
        let t = temporal_instability(&vb(&prev, &l), &vb(&prev, &r), 0.01).unwrap();
        assert!(t.mean > 0.05, "{}", t.mean);
    }

    #[test]
    fn flicker_is_measured() {
        let v = rig().eye(Eye::Right);
        let a = LinearImage::filled(32, 32, [0.5; 3]);
        let b = LinearImage::filled(32, 32, [0.7, 0.5, 0.5]);
        let depth = vec![2.0f32; 32 * 32];
        let vb = |image| ViewBuffers {
            image,
            depth: &depth,
            view: &v,
            first_hits: None,
        };
        let t = temporal_instability(&vb(&a), &vb(&b), 0.01).unwrap();
        assert!((t.mean - 0.2 / 3.0).abs() < 1e-4, "{}", t.mean);
    }
}
