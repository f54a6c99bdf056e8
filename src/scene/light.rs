//! Punctual lights (KHR_lights_punctual) in world space.

use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Emits from `position` in all directions; intensity in candela (W/sr·683 lm/W folded away: linear units).
    Point,
    /// Cone around `direction` with inner/outer angles in radians.
    Spot { inner_cone: f32, outer_cone: f32 },
    /// Parallel light travelling along `direction`; intensity is illuminance.
    /// `angular_radius` > 0 makes it a disc (the default sun), 0 a delta light.
    Directional { angular_radius: f32 },
}

#[derive(Clone, Debug)]
pub struct Light {
    pub name: String,
    pub kind: LightKind,
    /// Linear RGB colour × intensity.
    pub radiant: Vec3,
    pub position: Vec3,
    /// Unit direction the light travels (spot axis / sun rays), world space.
    pub direction: Vec3,
    /// KHR_lights_punctual range; `None` = infinite.
    pub range: Option<f32>,
}
