//! Placing a pose trace's stage in a scene.
//!
//! A trace gives the head in *stage space*. A [`Stage`] holds the rigid
//! `world_from_stage` transform; a head pose `pose` in stage space is
//! `world_from_stage · pose` in world space.
//!
//! [`Stage::at_camera`] aligns a trace with a scene camera so that the
//! **first sample's view equals the camera's view exactly**, and later motion
//! is relative to it:
//!
//! ```text
//! world_from_stage = camera_to_world · first_pose⁻¹
//! world_pose(t)    = world_from_stage · pose(t)
//!                  = camera_to_world · (first_pose⁻¹ · pose(t))
//! ```
//!
//! The whole first pose is cancelled, including its pitch and roll: if the
//! wearer's head was tilted at the first sample, the scene's horizon is
//! tilted by the opposite amount whenever the head is level later. For
//! recordings that start roughly level (the shipped ones do) this is the
//! least surprising rule: the first frame is exactly the view the scene
//! author chose.

use glam::Mat4;
use serde::{Deserialize, Serialize};

use super::pose::HeadPose;
use super::stereo::{StereoCamera, DEFAULT_ZNEAR};
use super::trace::PoseSample;

/// Where the trace's stage sits in the world.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stage {
    /// Rigid world-from-stage transform (no scale: traces are in metres and
    /// scenes are in metres).
    pub world_from_stage: Mat4,
}

impl Default for Stage {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Stage {
    /// Stage space is world space.
    pub const IDENTITY: Self = Self {
        world_from_stage: Mat4::IDENTITY,
    };

    /// A stage at an explicit transform; scale and shear are dropped.
    pub fn from_transform(world_from_stage: Mat4) -> Self {
        Self {
            world_from_stage: HeadPose::from_mat4(world_from_stage).to_mat4(),
        }
    }

    /// The stage that maps `first` (the trace's first head pose, its "rest"
    /// pose) onto a scene camera node with world transform `camera_to_world`
    /// (scale dropped): `world_from_stage = camera_to_world · first⁻¹`.
    pub fn at_camera(camera_to_world: Mat4, first: &HeadPose) -> Self {
        let camera = HeadPose::from_mat4(camera_to_world);
        Self {
            world_from_stage: camera.compose(&first.inverse()).to_mat4(),
        }
    }

    /// The rigid part of `world_from_stage` as a pose.
    pub fn as_pose(&self) -> HeadPose {
        HeadPose::from_mat4(self.world_from_stage)
    }

    /// A stage-space head pose in world space.
    pub fn world_pose(&self, stage_pose: &HeadPose) -> HeadPose {
        self.as_pose().compose(stage_pose)
    }

    /// The world-space stereo camera for one trace sample: the sample's head
    /// pose through the stage, the sample's IPD or `default_ipd`, and the
    /// given vertical field of view (radians) and aspect (width / height).
    pub fn eye_camera(
        &self,
        sample: &PoseSample,
        yfov: f32,
        aspect: f32,
        default_ipd: f32,
    ) -> StereoCamera {
        let head = self.world_pose(&sample.pose);
        StereoCamera {
            head,
            anchor: glam::DVec3::ZERO,
            ipd: sample.ipd.unwrap_or(default_ipd),
            yfov,
            aspect,
            znear: DEFAULT_ZNEAR,
            projection: Default::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{EulerRot, Quat, Vec3};

    #[test]
    fn first_sample_reproduces_camera_and_motion_is_relative() {
        let cam = Mat4::from_rotation_translation(
            Quat::from_euler(EulerRot::YXZ, 2.0, -0.1, 0.0),
            Vec3::new(4.0, 1.7, -3.0),
        );
        let first = HeadPose::new(Vec3::new(0.2, 0.0, 0.1), Quat::from_rotation_y(-0.8));
        let stage = Stage::at_camera(cam, &first);
        let s0 = PoseSample {
            t: 0.0,
            pose: first,
            ipd: None,
        };
        let c0 = stage.eye_camera(&s0, 1.0, 1.0, 0.063);
        let expect = HeadPose::from_mat4(cam);
        assert!((c0.head.position - expect.position).length() < 1e-5);
        assert!(c0.head.orientation.angle_between(expect.orientation) < 1e-3);

        // Stepping 1 m along the head's own forward at rest moves the world
        // camera 1 m along the scene camera's forward.
        let moved = PoseSample {
            t: 1.0,
            pose: HeadPose::new(first.position + first.forward(), first.orientation),
            ipd: Some(0.07),
        };
        let c1 = stage.eye_camera(&moved, 1.0, 1.0, 0.063);
        let d = c1.head.position - c0.head.position;
        assert!((d - expect.forward()).length() < 1e-5, "{d}");
        assert_eq!(c1.ipd, 0.07);
    }
}
