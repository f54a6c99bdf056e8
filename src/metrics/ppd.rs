//! Pixels per degree of a rendered eye image: the viewing condition FLIP's
//! filters are built for (Andersson et al. 2020, Sec. 4: the contrast
//! sensitivity and edge filters are sized in degrees of visual angle, so a
//! pixel's angular size decides what is visible).
//!
//! [`super::flip::DEFAULT_PPD`] (67) is a desktop monitor at 0.7 m; a headset
//! eye image of `w` pixels across a horizontal field of view `hfov` is far
//! coarser (960 pixels across 100° are 7.0 PPD at the centre, 160 across 90°
//! are 1.4), and FLIP at 67 PPD would judge its errors as if seen from much
//! further away.
//!
//! **Which value.** The exact angle of one pixel at the image centre, on the
//! optical axis of the (symmetric) pinhole: with the focal length in pixels
//! `f = (w/2) / tan(hfov/2)`, one pixel there subtends `2 atan(1/(2f))`, so
//!
//! `PPD = 1 / degrees(2 · atan(1 / (2f)))`  (≈ `f · π/180`).
//!
//! The alternative, `w / hfov_deg`, is the mean over the whole width; a
//! pinhole image's pixels shrink in angle towards the border (by `cos²θ`),
//! so the mean is larger than the centre's value (1.78 against 1.40 at 90°).
//! The centre is where the eye looks most of the time in a headset and the
//! coarsest part of the image, so FLIP there sees errors at their most
//! visible: the conservative choice. `compare --flip-ppd` overrides it.

use crate::camera::EyeView;

/// Pixels per degree at the centre of an image `width` pixels wide with
/// half-extent `tan_half_hfov` (`tan(hfov/2)`) of its image plane (module
/// documentation). `None` for an empty width or a non-finite / non-positive
/// extent.
pub fn centre_pixels_per_degree(width: u32, tan_half_hfov: f32) -> Option<f32> {
    let t = tan_half_hfov as f64;
    if width == 0 || !(t.is_finite() && t > 0.0) {
        return None;
    }
    let f = 0.5 * width as f64 / t;
    let deg = (2.0 * (0.5 / f).atan()).to_degrees();
    Some((1.0 / deg) as f32)
}

/// [`centre_pixels_per_degree`] of one eye's view rendered `width` pixels
/// wide; `None` for an orthographic eye, whose pixels subtend no angle at
/// the eye (the caller's default viewing condition applies).
pub fn eye_pixels_per_degree(view: &EyeView, width: u32) -> Option<f32> {
    if view.is_orthographic() {
        return None;
    }
    centre_pixels_per_degree(width, view.tan_half_fov().x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_value_against_the_mean_over_the_width() {
        // 90° across 160 px: f = 80 px; 2 atan(1/160) = 0.716 196°.
        let p = centre_pixels_per_degree(160, 1.0).unwrap();
        assert!((p - 1.396_282).abs() < 1e-5, "{p}");
        assert!(p < 160.0 / 90.0);
        assert!(centre_pixels_per_degree(0, 1.0).is_none());
        assert!(centre_pixels_per_degree(10, f32::NAN).is_none());
    }
}
