//! The co-visibility of one view in another, computed once from a pair of
//! geometry buffers (depth and, optionally, first-hit ids) and then applied
//! to any image: the step [`super::reproject`] performs, split so that every
//! method's images can be compared on **one mask** (issue 15, "Fair
//! metrics").
//!
//! `compare` builds the masks of its temporal and stereo metrics from the
//! *reference's* pixel-centre geometry, never from a method's own hits: two
//! methods that render identical images then score identically, whatever
//! depth and ids they report (a method whose hits disagree with the scene
//! would otherwise be scored on fewer, easier pixels — on the hairball 4.9 %
//! of pixels for sample-cache against 1.1 % for hash-cache).
//!
//! The construction is the one [`super::reproject`] documents (steps 1–4):
//! per destination pixel with a valid depth, the four bilinear taps around
//! its projection into the source view, each kept when its stored source
//! depth agrees within the relative tolerance and (with ids) its instance
//! and primitive match; the pixel is co-visible when one tap is kept.
//! [`Covisibility::warp`] then fetches any source image through the kept
//! taps with their weights renormalized.

use glam::{UVec2, Vec2, Vec3};

use super::check::{check_len, MetricsError};
use super::image::{sanitize, LinearImage};
use super::reproject::{FirstHits, MISS_INSTANCE};
use crate::camera::EyeView;

/// One view's geometry: what co-visibility is computed from.
#[derive(Clone, Copy, Debug)]
pub struct Geometry<'a> {
    /// Per-pixel view depth along the eye's −Z (0 = no hit).
    pub depth: &'a [f32],
    /// The eye that saw it.
    pub view: &'a EyeView,
    /// Optional first hits `[x, y, primitive, instance]`.
    pub first_hits: Option<FirstHits<'a>>,
}

/// Where the centre of pixel `(i, j)` of `dst_view`, seen at view depth
/// `depth` (`None`: a miss, the point at infinity along the pixel's ray), lies
/// in `src_view`: its pixel position and source view depth (`None`: behind
/// either eye). `forward` is `dst_view`'s −Z in world space. The step shared
/// by [`Covisibility::new`] and [`super::ghosting`].
pub(super) fn project_into(
    src_view: &EyeView,
    dst_view: &EyeView,
    forward: Vec3,
    i: usize,
    j: usize,
    depth: Option<f32>,
    size: UVec2,
) -> Option<(Vec2, f32)> {
    let centre = Vec2::new(i as f32 + 0.5, j as f32 + 0.5);
    let dir = dst_view.ray_direction(centre, size);
    // Where the ray starts relative to the destination eye (non-zero for an
    // orthographic eye: its point on the image plane).
    let origin = dst_view.ray_origin_offset(centre, size);
    let cos = dir.dot(forward);
    if cos <= 0.0 {
        return None;
    }
    // The eyes' offset, taken in f64 so views far from the origin keep
    // their precision.
    let eyes = (dst_view.world - src_view.world).as_vec3();
    let Some(d) = depth else {
        if src_view.is_orthographic() {
            // An orthographic eye sees infinity along its own axis only
            // (camera.glsl background_offset): while the axes agree, the
            // miss is the line from the pixel's place on the image plane,
            // moved like any point by the eyes' offset.
            let src_fwd = src_view.orientation * Vec3::NEG_Z;
            if dir.dot(src_fwd) < 1.0 - 1e-6 {
                return None;
            }
            return src_view.project_offset(eyes + origin + dir, size);
        }
        // A point at infinity: only the source eye's orientation matters.
        return src_view.project_offset(dir, size);
    };
    // The point relative to the source eye.
    src_view.project_offset(eyes + origin + dir * (d / cos), size)
}

/// The kept bilinear taps of every destination pixel (empty: not co-visible).
#[derive(Clone, Debug, PartialEq)]
pub struct Covisibility {
    pub width: usize,
    pub height: usize,
    /// Up to four `(source pixel index, bilinear weight)` per destination
    /// pixel, in the order `(0,0), (1,0), (0,1), (1,1)`; `count[i]` are used.
    taps: Vec<[(u32, f32); 4]>,
    count: Vec<u8>,
}

impl Covisibility {
    /// Co-visibility of `src` in `dst` for images of `width × height`, with
    /// relative depth tolerance `depth_tolerance_rel`; ids are compared when
    /// both views carry them.
    pub fn new(
        src: Geometry,
        dst: Geometry,
        width: usize,
        height: usize,
        depth_tolerance_rel: f32,
    ) -> Result<Self, MetricsError> {
        let (w, h) = (width, height);
        check_len("co-visibility: source depth", src.depth.len(), w, h)?;
        check_len("co-visibility: destination depth", dst.depth.len(), w, h)?;
        let first_hits = src.first_hits.zip(dst.first_hits);
        if let Some((s, d)) = first_hits {
            check_len("co-visibility: source first hits", s.len(), w, h)?;
            check_len("co-visibility: destination first hits", d.len(), w, h)?;
        }
        let tol = if depth_tolerance_rel.is_finite() {
            depth_tolerance_rel.max(0.0)
        } else {
            0.0
        };
        let (src_depth, dst_depth) = (src.depth, dst.depth);
        let (src_view, dst_view) = (src.view, dst.view);
        let size = UVec2::new(w as u32, h as u32);
        let forward = dst_view.orientation * Vec3::NEG_Z;
        let valid = |d: f32| d > 0.0 && d.is_finite();
        let mut taps = vec![[(0u32, 0.0f32); 4]; w * h];
        let mut count = vec![0u8; w * h];
        for j in 0..h {
            for i in 0..w {
                let di = j * w + i;
                let d = dst_depth[di];
                if !valid(d) {
                    continue;
                }
                let dst_id = first_hits.map(|(_, dh)| dh[di]);
                if dst_id.is_some_and(|id| id[3] == MISS_INSTANCE) {
                    continue;
                }
                let Some((p, d_s)) = project_into(src_view, dst_view, forward, i, j, Some(d), size)
                else {
                    continue;
                };
                if !(p.x >= 0.0 && p.y >= 0.0 && p.x <= w as f32 && p.y <= h as f32) {
                    continue;
                }
                let (u, v) = (p.x - 0.5, p.y - 0.5);
                let (x0, y0) = (u.floor(), v.floor());
                let (fx, fy) = (u - x0, v - y0);
                for (dx, dy, wt) in [
                    (0, 0, (1.0 - fx) * (1.0 - fy)),
                    (1, 0, fx * (1.0 - fy)),
                    (0, 1, (1.0 - fx) * fy),
                    (1, 1, fx * fy),
                ] {
                    let (sx, sy) = (x0 as i64 + dx, y0 as i64 + dy);
                    if wt <= 0.0 || sx < 0 || sy < 0 || sx >= w as i64 || sy >= h as i64 {
                        continue;
                    }
                    let si = sy as usize * w + sx as usize;
                    let ds = src_depth[si];
                    if !valid(ds) || (ds - d_s).abs() > tol * d_s {
                        continue;
                    }
                    if let (Some((sh, _)), Some(id)) = (first_hits, dst_id) {
                        if sh[si][2] != id[2] || sh[si][3] != id[3] {
                            continue;
                        }
                    }
                    taps[di][count[di] as usize] = (si as u32, wt);
                    count[di] += 1;
                }
            }
        }
        Ok(Covisibility {
            width: w,
            height: h,
            taps,
            count,
        })
    }

    /// Whether destination pixel `i` (row-major) is co-visible.
    #[inline]
    pub fn is_covisible(&self, i: usize) -> bool {
        self.count[i] > 0
    }

    /// The mask, one entry per destination pixel.
    pub fn mask(&self) -> Vec<bool> {
        self.count.iter().map(|&c| c > 0).collect()
    }

    /// Co-visible pixels / all destination pixels.
    pub fn fraction(&self) -> f32 {
        self.count.iter().filter(|&&c| c > 0).count() as f32 / self.count.len().max(1) as f32
    }

    /// `src` fetched through the kept taps (weights renormalized), black
    /// where not co-visible; `src` must be `width × height`.
    pub fn warp(&self, src: &LinearImage) -> Result<LinearImage, MetricsError> {
        if (src.width, src.height) != (self.width, self.height) {
            return Err(MetricsError::SizeMismatch {
                what: "co-visibility: warped image",
                expected_width: self.width,
                expected_height: self.height,
                found_width: src.width,
                found_height: src.height,
            });
        }
        check_len(
            "co-visibility: source rgb",
            src.rgb.len(),
            src.width,
            src.height,
        )?;
        let mut out = LinearImage::filled(self.width, self.height, [0.0; 3]);
        for (di, (taps, &n)) in self.taps.iter().zip(&self.count).enumerate() {
            let mut acc = [0.0f32; 3];
            let mut wsum = 0.0f32;
            for &(si, wt) in &taps[..n as usize] {
                let c = sanitize(src.rgb[si as usize]);
                for k in 0..3 {
                    acc[k] += wt * c[k];
                }
                wsum += wt;
            }
            if wsum > 0.0 {
                out.rgb[di] = acc.map(|a| a / wsum);
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Eye, HeadPose, Projection, StereoCamera};
    use glam::Quat;

    /// A miss seen by an orthographic eye (ymag 1, 64 px: 32 px per metre)
    /// lands where the same line along the view axis is in the other view:
    /// shifted by the eyes' offset (IPD 0.125 m: 4 px), and nowhere once
    /// that view has turned.
    #[test]
    fn an_orthographic_miss_follows_the_eye_and_not_a_turn() {
        let size = UVec2::new(64, 64);
        let mut c = StereoCamera::new(
            HeadPose::new(Vec3::new(0.2, 1.5, -0.3), Quat::IDENTITY),
            1.0,
            1.0,
        );
        c.ipd = 0.125;
        c.projection = Projection::Orthographic { ymag: 1.0 };
        let (l, r) = (c.eye(Eye::Left), c.eye(Eye::Right));
        let fwd = r.orientation * Vec3::NEG_Z;
        let (q, _) = project_into(&l, &r, fwd, 10, 20, None, size).unwrap();
        assert!((q - Vec2::new(14.5, 20.5)).length() < 1e-3, "{q}");
        let hit = project_into(&l, &r, fwd, 10, 20, Some(3.0), size)
            .unwrap()
            .0;
        assert!(
            (hit - q).length() < 1e-3,
            "a hit and a miss share the disparity"
        );
        let mut turned = c;
        turned.head.orientation = Quat::from_rotation_y(0.01);
        let lt = turned.eye(Eye::Left);
        assert!(project_into(&lt, &r, fwd, 10, 20, None, size).is_none());
        assert!(project_into(&lt, &r, fwd, 10, 20, Some(3.0), size).is_some());
    }
}
