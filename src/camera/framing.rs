//! Automatic framing: the stereo camera for a scene without a camera of its
//! own, fitted to the scene's world bounds (issue 18).
//!
//! Rule ([`frame_bounds`]):
//! - **Direction**: the head looks at the box's largest face, i.e. along the
//!   axis of its smallest extent (ties: Z, then Y, then X), from the positive
//!   side: down −Z with +Y up (the glTF camera's own convention), down −Y
//!   (seen from above, a model lying on the XZ plane) with −Z up (the
//!   scene's far side at the top of the image, +X still to the right), or
//!   down −X with +Y up (the head's right is then −Z).
//! - **Distance**: the smallest at which all 8 corners of the box lie in
//!   both eyes' images with the margin [`FRAMING_MARGIN`]: with `w`, `h` the
//!   face's extents along the head's X and Y, `d` the depth along the view
//!   axis, the eyes at ±ipd/2 and `tx = tan(yfov/2)·aspect`, `ty =
//!   tan(yfov/2)`, the near face at distance `n` from the eyes has its corners
//!   at |x| ≤ (w + ipd)/2, |y| ≤ h/2 in each eye's frame, so
//!   `n = margin · max((w + ipd)/2 / tx, (h/2) / ty)` and the head sits
//!   `n + d/2` from the box's centre. The far face's corners project closer
//!   to the centre, so every corner's normalized image coordinate is within
//!   ±1/margin in x and y.
//! - **Near plane**: `znear = min(DEFAULT_ZNEAR, n/2)`: never clips the
//!   box (its nearest point is `n` away), and stays the default 1 cm for
//!   every scene whose near face is at least 2 cm from the eyes.
//! - **Warning** (one): when the IPD exceeds the box's largest extent, the
//!   eyes are farther apart than the model is large: the fit keeps it in both
//!   images, so it fills only a small part of each.

use glam::{Quat, Vec3};

use super::pose::HeadPose;
use super::stereo::{StereoCamera, DEFAULT_ZNEAR};

/// The box's projection reaches at most 1/FRAMING_MARGIN of each image
/// half-extent (about 5% of the image free on each side at the binding
/// edges).
pub const FRAMING_MARGIN: f32 = 1.1;

/// Extent used for a scene without extent (a point or no geometry), metres.
const MIN_EXTENT: f32 = 1e-3;

/// The automatic framing of a box.
#[derive(Clone, Debug, PartialEq)]
pub struct Framing {
    /// The camera: head at `head_position`, world anchor 0.
    pub camera: StereoCamera,
    /// The box's extents (as used: a box without any extent is taken as a
    /// 1 mm cube).
    pub extent: Vec3,
    /// The axis looked along: 0 = x, 1 = y, 2 = z (the smallest extent).
    pub view_axis: usize,
    /// Distance from the eyes to the box's near face.
    pub near_face: f32,
    /// The warning when the IPD exceeds the box's size.
    pub warning: Option<String>,
}

impl Framing {
    /// The one stderr line describing the chosen camera.
    pub fn line(&self) -> String {
        let p = self.camera.head.position;
        let f = self.camera.head.orientation * Vec3::NEG_Z;
        let u = self.camera.head.orientation * Vec3::Y;
        format!(
            "camera: automatic framing of the scene's bounds ({} × {} × {} m): head at ({}, {}, {}), looking along {} with {} up, yfov {:.1}°, znear {} m, near face {} m away",
            fmt(self.extent.x),
            fmt(self.extent.y),
            fmt(self.extent.z),
            fmt(p.x),
            fmt(p.y),
            fmt(p.z),
            axis_name(f),
            axis_name(u),
            self.camera.yfov.to_degrees(),
            fmt(self.camera.znear),
            fmt(self.near_face),
        )
    }
}

/// Four significant digits.
fn fmt(v: f32) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}

/// "−Z", "+Y", ... for an axis-aligned unit vector (else its components).
fn axis_name(v: Vec3) -> String {
    let a = v.abs();
    let (i, m) = if a.x >= a.y && a.x >= a.z {
        (0, v.x)
    } else if a.y >= a.z {
        (1, v.y)
    } else {
        (2, v.z)
    };
    if (m.abs() - 1.0).abs() < 1e-4 {
        format!("{}{}", if m > 0.0 { "+" } else { "−" }, ["X", "Y", "Z"][i])
    } else {
        format!("({:.3}, {:.3}, {:.3})", v.x, v.y, v.z)
    }
}

/// The head orientation looking along −axis (see the module docs).
fn orientation(view_axis: usize) -> Quat {
    match view_axis {
        // −Z forward, +Y up.
        2 => Quat::IDENTITY,
        // −Y forward (from above), −Z up, +X right.
        1 => Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        // −X forward, +Y up, −Z right.
        _ => Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
    }
}

/// Frames the world box `lo`..`hi` for eyes of vertical field of view
/// `yfov` (radians), `aspect` = width / height and separation `ipd`
/// (module docs). The camera's `ipd` is `ipd`, its anchor 0.
pub fn frame_bounds(lo: Vec3, hi: Vec3, yfov: f32, aspect: f32, ipd: f32) -> Framing {
    let finite = lo.is_finite() && hi.is_finite();
    let mut extent = if finite {
        (hi - lo).max(Vec3::ZERO)
    } else {
        Vec3::ZERO
    };
    let centre = if finite { 0.5 * (lo + hi) } else { Vec3::ZERO };
    if extent.max_element() < MIN_EXTENT * 1e-3 {
        extent = Vec3::splat(MIN_EXTENT);
    }
    let view_axis = if extent.z <= extent.y && extent.z <= extent.x {
        2
    } else if extent.y <= extent.x {
        1
    } else {
        0
    };
    let q = orientation(view_axis);
    // The extents along the head's X, Y and Z (the rotations permute axes).
    let along = |v: Vec3| (extent * (q * v).abs()).element_sum();
    let (w, h, d) = (along(Vec3::X), along(Vec3::Y), along(Vec3::Z));
    let ty = (0.5 * yfov).tan();
    let tx = ty * aspect;
    let near_face = FRAMING_MARGIN * (0.5 * (w + ipd) / tx).max(0.5 * h / ty);
    let back = q * Vec3::Z;
    let head = HeadPose::new(centre + back * (near_face + 0.5 * d), q);
    let mut camera = StereoCamera::new(head, yfov, aspect);
    camera.ipd = ipd;
    camera.znear = DEFAULT_ZNEAR.min(0.5 * near_face);
    let size = extent.max_element();
    let warning = (ipd > size).then(|| {
        format!(
            "the scene is {} m across, less than the eye separation ({} m): the automatic framing keeps it in both eyes' images, so it fills only a small part of each (a smaller --ipd, or a camera in the file, frames it closer)",
            fmt(size),
            fmt(ipd)
        )
    });
    Framing {
        camera,
        extent,
        view_axis,
        near_face,
        warning,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orientations_look_along_the_axis_with_the_documented_up() {
        let cases = [
            (2, Vec3::NEG_Z, Vec3::Y),
            (1, Vec3::NEG_Y, Vec3::NEG_Z),
            (0, Vec3::NEG_X, Vec3::Y),
        ];
        for (axis, forward, up) in cases {
            let q = orientation(axis);
            assert!((q * Vec3::NEG_Z - forward).length() < 1e-6, "{axis}");
            assert!((q * Vec3::Y - up).length() < 1e-6, "{axis}");
        }
    }

    #[test]
    fn near_plane_is_the_default_for_ordinary_scenes() {
        let f = frame_bounds(Vec3::splat(-1.0), Vec3::ONE, 1.0, 1.5, 0.063);
        assert_eq!(f.camera.znear, DEFAULT_ZNEAR);
        assert!(f.warning.is_none());
        // A 5 mm cube: the near plane is half the distance to its near face.
        let f = frame_bounds(Vec3::ZERO, Vec3::splat(0.005), 1.0, 1.5, 0.0);
        assert!(f.near_face < 0.02);
        assert_eq!(f.camera.znear, 0.5 * f.near_face);
        assert!(f.warning.is_none());
        let f = frame_bounds(Vec3::ZERO, Vec3::splat(0.005), 1.0, 1.5, 0.063);
        assert!(f.warning.as_deref().unwrap().contains("0.005000 m across"));
    }
}
