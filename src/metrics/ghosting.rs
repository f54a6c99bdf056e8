//! Ghosting: the error on the pixels a moving object has just **left**
//! (issue 16; appendix D of the paper, Fig. 19). A method that keeps history
//! — TAA's blend, the sample cache's reprojected samples, HashCache's
//! world-space cells — may show the object there for a while after it has
//! gone; a method without history (1 spp) has only its noise there.
//!
//! A pixel of frame t is a **ghost pixel** when
//! 1. frame t's reference does not see a moving instance there (it sees a
//!    static one, or nothing), and
//! 2. the point it sees, projected into frame t−1's view, lands on a pixel
//!    where frame t−1's reference saw a moving instance.
//!
//! That is, the surface was covered by the moving object a frame ago and is
//! uncovered now. Both tests read only the **reference's** pixel-centre
//! geometry (depth and first-hit ids), as the co-visibility masks of the
//! temporal and stereo metrics do ([`super::covisibility`], whose projection
//! step this reuses): every method is scored on the same pixels. The point
//! is projected by the camera motion alone (it is static), into the source
//! pixel containing it (no bilinear taps: a pixel is either covered or not).
//! A pixel whose reference is a miss is projected as the point at infinity
//! along its ray, so an object moving in front of the sky is counted too.
//!
//! The error on the ghost pixels is the RSE of [`super::error::rse`]
//! restricted to them: `Σ_ghost Σ_c (x_c − r_c)² / (r_c² + ε)` over
//! `3 · count`, returned as its sum and count so that both eyes (or several
//! frames) pool their pixels.
//!
//! Tested in tests/fair_metrics.rs (constructed frames with known ghost
//! pixels and error) and tests/motion.rs (TAA on `cornell-moving`).

use glam::{UVec2, Vec3};

use super::check::{check_len, MetricsError};
use super::covisibility::{project_into, Geometry};
use super::image::{sanitize, LinearImage};
use super::reproject::MISS_INSTANCE;

/// The ghost pixels of `now` given `prev` (both need first-hit ids: without
/// them this is a [`MetricsError::BufferLength`]),
/// `moving[k]` true for every instance `k` that moves (instances past its
/// end count as static). One entry per pixel of `now`, row-major.
pub fn ghost_mask(
    prev: Geometry,
    now: Geometry,
    moving: &[bool],
    width: usize,
    height: usize,
) -> Result<Vec<bool>, MetricsError> {
    let (w, h) = (width, height);
    check_len("ghosting: previous depth", prev.depth.len(), w, h)?;
    check_len("ghosting: current depth", now.depth.len(), w, h)?;
    // Both frames need ids: a missing buffer is one of length 0.
    let (prev_ids, now_ids) = (
        prev.first_hits.unwrap_or(&[]),
        now.first_hits.unwrap_or(&[]),
    );
    check_len("ghosting: previous first hits", prev_ids.len(), w, h)?;
    check_len("ghosting: current first hits", now_ids.len(), w, h)?;
    let moves = |inst: u32| inst != MISS_INSTANCE && moving.get(inst as usize) == Some(&true);
    let size = UVec2::new(w as u32, h as u32);
    let forward = now.view.orientation * Vec3::NEG_Z;
    let mut mask = vec![false; w * h];
    for j in 0..h {
        for i in 0..w {
            let di = j * w + i;
            if moves(now_ids[di][3]) {
                continue;
            }
            let d = now.depth[di];
            let hit = now_ids[di][3] != MISS_INSTANCE && d > 0.0 && d.is_finite();
            let Some((p, _)) =
                project_into(prev.view, now.view, forward, i, j, hit.then_some(d), size)
            else {
                continue;
            };
            if !(p.x >= 0.0 && p.y >= 0.0 && p.x < w as f32 && p.y < h as f32) {
                continue;
            }
            let si = p.y as usize * w + p.x as usize;
            mask[di] = moves(prev_ids[si][3]);
        }
    }
    Ok(mask)
}

/// The RSE terms of `x` against `r` on the pixels of `mask`: their sum
/// (over pixels and channels) and the number of pixels; the restricted RSE
/// is `sum / (3 · count)`.
pub fn rse_on_mask(
    x: &LinearImage,
    r: &LinearImage,
    mask: &[bool],
    eps: f32,
) -> Result<(f64, usize), MetricsError> {
    r.check_same_size(x, "ghosting: test image")?;
    check_len("ghosting: mask", mask.len(), r.width, r.height)?;
    let eps = if eps > 0.0 && eps.is_finite() {
        eps
    } else {
        super::RSE_EPSILON
    } as f64;
    let mut sum = 0.0;
    let mut count = 0;
    for ((a, b), _) in x.rgb.iter().zip(&r.rgb).zip(mask).filter(|(_, m)| **m) {
        let (a, b) = (sanitize(*a), sanitize(*b));
        for c in 0..3 {
            let d = a[c] as f64 - b[c] as f64;
            sum += d * d / ((b[c] as f64).powi(2) + eps);
        }
        count += 1;
    }
    Ok((sum, count))
}
