//! Backward reprojection of one view's image into another view, with a
//! co-visibility mask: the common step of the temporal and stereo metrics
//! (Philippi et al. 2025, Figs. 10 and 15: "frame-to-frame reprojected
//! difference", "the left eye was reprojected onto the right view").
//!
//! For each destination pixel `(i, j)` with view depth `d > 0`:
//! 1. the ray through its centre `(i + ½, j + ½)` is
//!    [`EyeView::ray_direction`] from [`EyeView::ray_origin_offset`] (the
//!    eye, or for an orthographic eye the pixel's point on its image plane);
//!    the world point is `p = origin + dir · d / cos θ`, `cos θ = dir ·
//!    forward` (depth is measured along the eye's −Z, not along the ray);
//! 2. `p` is projected into the source view ([`EyeView::project`]), giving a
//!    continuous pixel position and the view depth `d_s` the source *should*
//!    see there;
//! 3. the colour is fetched **bilinearly** from the four source pixel centres
//!    around that position; a tap counts only when its stored source depth
//!    agrees, `|depth_src − z| ≤ tol · z`, with `z` either `d_s` or the depth
//!    at which the tap's own ray (through its pixel centre) meets the
//!    destination surface's tangent plane at `p` — the plane through the
//!    destination pixel's point and its neighbours' on each axis (the
//!    neighbour of closer depth, of the same instance when ids are given).
//!    On a slanted surface the taps' depths differ from `d_s` by the slope
//!    times their offset from `p` (at 60° already more than 1 % per pixel),
//!    so the plane keeps them; before, oblique walls and floors were largely
//!    not co-visible. And — when first-hit buffers are given — the tap's
//!    instance must equal the destination pixel's (its primitive need not:
//!    until session 55 it had to, which left a mesh of sub-pixel triangles,
//!    the hairball, almost without co-visible pixels).
//!    Failing taps are dropped and the weights of the rest renormalized;
//! 4. the pixel is **co-visible** when at least one tap passed. Otherwise it
//!    is black in the reprojected image.
//!
//! Depth `0` (or negative / non-finite) means "no hit" (sky): such pixels are
//! never co-visible, in either view. Projections outside `[0, w] × [0, h]` of
//! the source are not co-visible. Source colours are sanitized (non-finite →
//! 0).

use super::check::{check_len, MetricsError};
use super::covisibility::{Covisibility, Geometry};
use super::image::{sanitize, LinearImage};
use crate::camera::EyeView;

/// Instance index of a first hit that missed all geometry.
pub const MISS_INSTANCE: u32 = u32::MAX;

/// A per-pixel first-hit buffer, `[x, y, primitive, instance]` per pixel.
pub type FirstHits<'a> = &'a [[u32; 4]];

/// One view's buffers: what a metric needs from a rendered eye image.
#[derive(Clone, Copy, Debug)]
pub struct ViewBuffers<'a> {
    /// Linear radiance.
    pub image: &'a LinearImage,
    /// Per-pixel view depth along the eye's −Z (0 = no hit).
    pub depth: &'a [f32],
    /// The eye that rendered the image.
    pub view: &'a EyeView,
    /// Optional first hits `[x, y, primitive, instance]` (DESIGN.md, 128-bit
    /// first hits; instance [`MISS_INSTANCE`] = miss).
    pub first_hits: Option<FirstHits<'a>>,
}

impl<'a> ViewBuffers<'a> {
    /// The geometry part (depth, view, ids) co-visibility is computed from.
    pub fn geometry(&self) -> Geometry<'a> {
        Geometry {
            depth: self.depth,
            view: self.view,
            first_hits: self.first_hits,
        }
    }
}

/// Reproject `src` into the destination view (see the module docs): the
/// [`Covisibility`] of the two geometries applied to `src`.
///
/// Returns the reprojected image (destination size) and the co-visibility
/// mask. `first_hits = Some((src_hits, dst_hits))` additionally requires the
/// same instance. The destination size is `dst_depth`'s grid,
/// taken to have `src`'s dimensions (both eyes and consecutive frames render
/// at one resolution); every buffer must hold `width · height` entries.
pub fn reproject(
    src: &LinearImage,
    src_depth: &[f32],
    src_view: &EyeView,
    dst_depth: &[f32],
    dst_view: &EyeView,
    depth_tolerance_rel: f32,
    first_hits: Option<(FirstHits, FirstHits)>,
) -> Result<(LinearImage, Vec<bool>), MetricsError> {
    let (w, h) = (src.width, src.height);
    check_len("reproject: source rgb", src.rgb.len(), w, h)?;
    check_len("reproject: source depth", src_depth.len(), w, h)?;
    check_len("reproject: destination depth", dst_depth.len(), w, h)?;
    if let Some((s, d)) = first_hits {
        check_len("reproject: source first hits", s.len(), w, h)?;
        check_len("reproject: destination first hits", d.len(), w, h)?;
    }
    let cov = Covisibility::new(
        Geometry {
            depth: src_depth,
            view: src_view,
            first_hits: first_hits.map(|(s, _)| s),
        },
        Geometry {
            depth: dst_depth,
            view: dst_view,
            first_hits: first_hits.map(|(_, d)| d),
        },
        w,
        h,
        depth_tolerance_rel,
    )?;
    Ok((cov.warp(src)?, cov.mask()))
}

/// Per-pixel difference used by the temporal and stereo metrics: the mean
/// absolute RGB difference `(|ΔR| + |ΔG| + |ΔB|) / 3` on linear values
/// (sanitized, not clamped).
#[inline]
pub fn pixel_difference(a: [f32; 3], b: [f32; 3]) -> f32 {
    let (a, b) = (sanitize(a), sanitize(b));
    ((a[0] - b[0]).abs() + (a[1] - b[1]).abs() + (a[2] - b[2]).abs()) / 3.0
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::camera::{Eye, HeadPose, StereoCamera};
    use glam::{Quat, Vec3};

    /// 64 × 64 eyes, 90° fov, IPD 0.125 m: a fronto-parallel plane at depth
    /// `d` has a disparity of `32 · 0.125 / d` pixels (4 px at `d = 1`).
    pub(crate) fn rig() -> StereoCamera {
        let mut c = StereoCamera::new(
            HeadPose::new(Vec3::new(0.2, 1.5, -0.3), Quat::IDENTITY),
            90f32.to_radians(),
            1.0,
        );
        c.ipd = 0.125;
        c
    }

    pub(crate) fn texture(x: usize, y: usize) -> [f32; 3] {
        [
            x as f32 / 64.0,
            y as f32 / 64.0,
            ((x * 7 + y * 3) % 11) as f32 / 10.0,
        ]
    }

    #[test]
    fn plane_disparity_reprojects_textured_left_into_right() {
        let c = rig();
        let [l, r] = [c.eye(Eye::Left), c.eye(Eye::Right)];
        let left = LinearImage::from_fn(64, 64, texture);
        let depth = vec![1.0f32; 64 * 64];
        let (img, cov) = reproject(&left, &depth, &l, &depth, &r, 0.01, None).unwrap();
        assert_shifted_by_4(&img, &cov, "perspective");
        // The rightmost 4 columns look at what the left eye cannot see.
        assert!(!cov[10 * 64 + 60] && !cov[10 * 64 + 63]);
    }

    /// Right pixel (i, j) of `img` sees what left pixel (i + 4, j) of
    /// [`texture`] sees, and all but the rightmost 4 columns are co-visible.
    fn assert_shifted_by_4(img: &LinearImage, cov: &[bool], what: &str) {
        for &(i, j) in &[(0usize, 0usize), (10, 20), (31, 63), (59, 5)] {
            assert!(cov[j * 64 + i]);
            let got = img.get(i, j).unwrap();
            let want = texture(i + 4, j);
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-3,
                    "{what}: ({i},{j}) {got:?} {want:?}"
                );
            }
        }
        assert_eq!(cov.iter().filter(|&&v| v).count(), 60 * 64, "{what}");
    }

    /// Orthographic eyes (ymag = 1, 64 px: 32 px per metre, IPD 0.125 m):
    /// every depth has the same disparity, 0.125 · 32 = 4 pixels.
    #[test]
    fn orthographic_disparity_is_the_same_at_every_depth() {
        let mut c = rig();
        c.projection = crate::camera::Projection::Orthographic { ymag: 1.0 };
        let [l, r] = [c.eye(Eye::Left), c.eye(Eye::Right)];
        let left = LinearImage::from_fn(64, 64, texture);
        for d in [0.25f32, 1.0, 40.0] {
            let depth = vec![d; 64 * 64];
            let (img, cov) = reproject(&left, &depth, &l, &depth, &r, 0.01, None).unwrap();
            assert_shifted_by_4(&img, &cov, &format!("orthographic at depth {d}"));
        }
    }

    #[test]
    fn depth_and_id_mismatch_break_covisibility() {
        let c = rig();
        let [l, r] = [c.eye(Eye::Left), c.eye(Eye::Right)];
        let img = LinearImage::filled(64, 64, [1.0; 3]);
        let near = vec![1.0f32; 64 * 64];
        let far = vec![1.5f32; 64 * 64];
        let (_, cov) = reproject(&img, &far, &l, &near, &r, 0.05, None).unwrap();
        assert!(cov.iter().all(|&v| !v));
        // Another instance at the same depth: not the same surface.
        let ids_a = vec![[0, 0, 3, 1]; 64 * 64];
        let ids_b = vec![[0, 0, 3, 2]; 64 * 64];
        let (_, cov) = reproject(&img, &near, &l, &near, &r, 0.05, Some((&ids_a, &ids_b))).unwrap();
        assert!(cov.iter().all(|&v| !v));
        let (_, cov) = reproject(&img, &near, &l, &near, &r, 0.05, Some((&ids_a, &ids_a))).unwrap();
        assert_eq!(cov.iter().filter(|&&v| v).count(), 60 * 64);
        // One instance of sub-pixel triangles (every pixel its own
        // primitive, none shared between the eyes): the surface is still
        // co-visible wherever the depths agree.
        let tiny = |k: u32| -> Vec<[u32; 4]> {
            (0..64 * 64u32).map(|i| [0, 0, k * 4096 + i, 1]).collect()
        };
        let (ids_l, ids_r) = (tiny(0), tiny(1));
        let (_, cov) = reproject(&img, &near, &l, &near, &r, 0.05, Some((&ids_l, &ids_r))).unwrap();
        assert_eq!(cov.iter().filter(|&&v| v).count(), 60 * 64);
        let sky = vec![0.0f32; 64 * 64];
        let (_, cov) = reproject(&img, &sky, &l, &sky, &r, 0.05, None).unwrap();
        assert!(cov.iter().all(|&v| !v));
        assert!(reproject(&img, &near[1..], &l, &near, &r, 0.05, None).is_err());
    }
}
