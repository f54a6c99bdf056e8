//! Head–neck model: translation for orientation-only head tracking.
//!
//! An orientation-only tracker (a 3-DoF headset, a 360° video player log)
//! gives no position. Real heads do not rotate about the eyes: they rotate
//! about the upper neck, so the eyes translate when the head turns or nods.
//! The model puts a pivot at the top of the neck and the eye midpoint at a
//! fixed offset from it in head space.
//!
//! Default offset: 0.075 m up and 0.0805 m forward — the neck-to-eye defaults
//! of the Oculus PC SDK (`OVR_DEFAULT_NECK_TO_EYE_VERTICAL`/`_HORIZONTAL`,
//! LibOVR 0.4 and later), which Oculus derived from ANSUR-88 anthropometric
//! averages. Google Cardboard's neck model uses almost the same numbers
//! (0.075 m up, 0.08 m forward).

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use super::pose::HeadPose;

/// Eye midpoint relative to a neck pivot, in head space (glTF axes: +Y up,
/// −Z forward).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeadNeckModel {
    /// Pivot → eye midpoint in head space, metres.
    pub eye_offset: Vec3,
}

impl Default for HeadNeckModel {
    fn default() -> Self {
        Self {
            eye_offset: Vec3::new(0.0, Self::DEFAULT_UP, -Self::DEFAULT_FORWARD),
        }
    }
}

impl HeadNeckModel {
    /// Neck pivot to eye height, metres (Oculus SDK default).
    pub const DEFAULT_UP: f32 = 0.075;
    /// Neck pivot to eyes, forward, metres (Oculus SDK default).
    pub const DEFAULT_FORWARD: f32 = 0.0805;

    /// No neck: the head rotates about the eye midpoint (position stays 0).
    pub const NONE: Self = Self {
        eye_offset: Vec3::ZERO,
    };

    /// Eye-midpoint position for an orientation, with the pivot placed so
    /// that the identity orientation puts the eyes at the origin:
    /// `position = R·offset − offset`.
    pub fn eye_position(&self, orientation: Quat) -> Vec3 {
        orientation * self.eye_offset - self.eye_offset
    }

    /// The full head pose for an orientation (see [`Self::eye_position`]).
    pub fn pose(&self, orientation: Quat) -> HeadPose {
        let q = orientation.normalize();
        HeadPose {
            position: self.eye_position(q),
            orientation: q,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rest_pose_is_origin_and_yaw_moves_eyes_on_a_circle() {
        let m = HeadNeckModel::default();
        assert_eq!(m.eye_position(Quat::IDENTITY), Vec3::ZERO);
        // A 90° left turn (about +Y) swings the eyes from −Z to −X around
        // the pivot, which sits 0.0805 m behind the eyes.
        let p = m.eye_position(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2));
        let f = HeadNeckModel::DEFAULT_FORWARD;
        assert!((p - Vec3::new(-f, 0.0, f)).length() < 1e-6, "{p}");
    }
}
