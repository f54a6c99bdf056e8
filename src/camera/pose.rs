//! A rigid head pose: where the head is and which way it looks.
//!
//! Conventions (DESIGN.md): glTF axes — right-handed, +Y up, metres, column
//! vectors. The head frame is a camera frame: it looks down its −Z, +Y is up
//! and +X points to the wearer's right. The eyes sit at ±IPD/2 along the
//! head's +X (see [`super::stereo`]).

use glam::{Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};

/// A head pose: the transform from head space to its parent space (stage or
/// world space, depending on who holds it).
///
/// `position` is the eye midpoint (the "cyclopean eye"), `orientation` the
/// unit quaternion that rotates head-space vectors into the parent space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeadPose {
    /// Eye midpoint in the parent space, metres.
    pub position: Vec3,
    /// Unit quaternion, head space → parent space.
    pub orientation: Quat,
}

impl Default for HeadPose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl HeadPose {
    /// At the origin, looking down −Z with +Y up.
    pub const IDENTITY: Self = Self {
        position: Vec3::ZERO,
        orientation: Quat::IDENTITY,
    };

    /// A pose from a position and an orientation (normalized here).
    pub fn new(position: Vec3, orientation: Quat) -> Self {
        Self {
            position,
            orientation: orientation.normalize(),
        }
    }

    /// The rigid part of a parent-from-head matrix (a glTF camera node's
    /// world transform, say). Scale and shear are dropped: a camera's view
    /// does not depend on its node's scale.
    pub fn from_mat4(parent_from_head: Mat4) -> Self {
        let (_scale, rotation, translation) = parent_from_head.to_scale_rotation_translation();
        Self::new(translation, rotation)
    }

    /// The rigid parent-from-head matrix.
    pub fn to_mat4(&self) -> Mat4 {
        Mat4::from_rotation_translation(self.orientation, self.position)
    }

    /// The inverse transform (head-from-parent as a pose).
    pub fn inverse(&self) -> Self {
        let inv = self.orientation.conjugate();
        Self {
            position: -(inv * self.position),
            orientation: inv,
        }
    }

    /// Composition `self · rhs`: `rhs` is expressed in `self`'s frame.
    pub fn compose(&self, rhs: &HeadPose) -> Self {
        Self {
            position: self.position + self.orientation * rhs.position,
            orientation: (self.orientation * rhs.orientation).normalize(),
        }
    }

    /// A point in head space → parent space.
    pub fn transform_point(&self, p: Vec3) -> Vec3 {
        self.position + self.orientation * p
    }

    /// The head's +X (wearer's right) in the parent space.
    pub fn right(&self) -> Vec3 {
        self.orientation * Vec3::X
    }

    /// The head's +Y (up) in the parent space.
    pub fn up(&self) -> Vec3 {
        self.orientation * Vec3::Y
    }

    /// The viewing direction, the head's −Z, in the parent space.
    pub fn forward(&self) -> Vec3 {
        self.orientation * Vec3::NEG_Z
    }

    /// Position lerp and shortest-arc orientation slerp, `s` in [0, 1].
    pub fn interpolate(&self, other: &HeadPose, s: f32) -> Self {
        Self {
            position: self.position.lerp(other.position, s),
            orientation: self.orientation.slerp(other.orientation, s).normalize(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_composes_to_identity() {
        let p = HeadPose::new(
            Vec3::new(1.0, 2.0, -3.0),
            Quat::from_euler(glam::EulerRot::YXZ, 0.4, -0.2, 0.1),
        );
        let id = p.compose(&p.inverse());
        assert!(id.position.length() < 1e-5);
        assert!(id.orientation.angle_between(Quat::IDENTITY) < 1e-3);
    }

    #[test]
    fn mat4_round_trip_drops_scale() {
        let q = Quat::from_rotation_y(0.7);
        let m =
            Mat4::from_scale_rotation_translation(Vec3::splat(2.0), q, Vec3::new(1.0, 0.0, 5.0));
        let p = HeadPose::from_mat4(m);
        assert!(p.orientation.angle_between(q) < 1e-4);
        assert!((p.position - Vec3::new(1.0, 0.0, 5.0)).length() < 1e-5);
        assert!(p.forward().abs_diff_eq(q * Vec3::NEG_Z, 1e-5));
    }
}
