//! Stereo camera: head pose → two eye views, pixel rays and projection.
//!
//! This file is the single source of truth for the camera model; shaders
//! (`shaders/common/camera.glsl`) implement the same formulas and are tested
//! against these CPU functions.
//!
//! Model (glTF conventions, DESIGN.md):
//! - Each eye looks down its −Z with +Y up and +X to the right; both eyes have
//!   the head's orientation, so the **eye axes are parallel** (no toe-in).
//! - The eyes sit at `∓ipd/2` along the head's +X: left eye at `−ipd/2`,
//!   right eye at `+ipd/2`, both at the head position's height and depth.
//! - Each eye has the same **symmetric** perspective frustum (`yfov` vertical
//!   field of view, `aspect = width / height`). Real HMDs use asymmetric
//!   per-eye frusta; the symmetric parallel-axis pair is what a glTF
//!   perspective camera describes and keeps reprojection between the eyes a
//!   pure horizontal shift for a fronto-parallel plane.
//! - An **orthographic** camera (glTF `orthographic`, [`Projection`]) has
//!   parallel rays along −Z: the ray through a pixel starts on the eye's
//!   image plane, `ndc.x · xmag` along +X and `ndc.y · ymag` along +Y from the
//!   eye, with `xmag = ymag · aspect` (the image's aspect wins, as for a
//!   perspective camera's `aspectRatio`). Both eyes keep their `∓ipd/2`
//!   offset, so a point's disparity is the same at every depth.
//! - Pixel coordinates are continuous: `(0, 0)` is the top-left corner of the
//!   top-left pixel, `+x` right, `+y` down; pixel `(i, j)` has its centre at
//!   `(i + 0.5, j + 0.5)`.

use glam::{DVec3, Mat4, Quat, UVec2, Vec2, Vec3};
use serde::{Deserialize, Serialize};

use super::pose::HeadPose;

/// Default interpupillary distance, metres (DESIGN.md).
pub const DEFAULT_IPD: f32 = 0.063;
/// Default near distance for raster-style projections and ray `t_min`, metres.
pub const DEFAULT_ZNEAR: f32 = 0.01;

/// How an eye maps pixels to rays (glTF `camera.type`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Projection {
    /// A pinhole at the eye with the camera's `yfov`.
    #[default]
    Perspective,
    /// Parallel rays along the eye's −Z from its image plane; `ymag` is half
    /// the view's height in metres (glTF `orthographic.ymag`), `ymag ·
    /// aspect` half its width.
    Orthographic { ymag: f32 },
}

/// One eye of a stereo pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Eye {
    /// Index 0, at `−ipd/2` along the head's +X.
    Left,
    /// Index 1, at `+ipd/2` along the head's +X.
    Right,
}

impl Eye {
    /// Both eyes in index order.
    pub const BOTH: [Eye; 2] = [Eye::Left, Eye::Right];

    /// 0 for the left eye, 1 for the right (array and image-layer index).
    pub fn index(self) -> usize {
        match self {
            Eye::Left => 0,
            Eye::Right => 1,
        }
    }

    /// −1 for the left eye, +1 for the right: the eye sits at
    /// `sign · ipd/2` along the head's +X.
    pub fn sign(self) -> f32 {
        match self {
            Eye::Left => -1.0,
            Eye::Right => 1.0,
        }
    }

    /// The other eye.
    pub fn other(self) -> Eye {
        match self {
            Eye::Left => Eye::Right,
            Eye::Right => Eye::Left,
        }
    }
}

/// A head-mounted stereo camera in world space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StereoCamera {
    /// Head (eye midpoint) pose, its position relative to `anchor`.
    pub head: HeadPose,
    /// The world point the head position is relative to, in f64: a camera
    /// placed far from the origin keeps millimetre head motion and IPD
    /// (an f32 world position at 1e6 m is quantized to 6 cm).
    pub anchor: DVec3,
    /// Interpupillary distance, metres.
    pub ipd: f32,
    /// Vertical field of view of each eye, radians (perspective only).
    pub yfov: f32,
    /// Width / height of each eye's image.
    pub aspect: f32,
    /// Near distance, metres. **Not applied by any renderer**: primary rays
    /// start at the eye (t_min 0), so nothing is clipped, and a scene
    /// camera's glTF `znear` is not carried here (`from_scene`); the
    /// importer warns where a camera's znear exceeds 1 cm (feature table row
    /// "camera znear beyond 1 cm"; found by a session-47 audit; near
    /// clipping is not implemented).
    pub znear: f32,
    /// Perspective (the default) or orthographic.
    #[serde(default)]
    pub projection: Projection,
}

impl StereoCamera {
    /// A stereo camera with the default IPD and near distance.
    pub fn new(head: HeadPose, yfov: f32, aspect: f32) -> Self {
        Self {
            head,
            anchor: DVec3::ZERO,
            ipd: DEFAULT_IPD,
            yfov,
            aspect,
            znear: DEFAULT_ZNEAR,
            projection: Projection::Perspective,
        }
    }

    /// A stereo camera whose head is a scene camera node: `camera_to_world`
    /// is the node's world transform (glTF camera looking down its −Z). Scale
    /// is dropped; the eye midpoint is the node's origin, which becomes the
    /// anchor (the head starts at position 0 relative to it).
    pub fn from_scene_camera(camera_to_world: Mat4, yfov: f32, aspect: f32) -> Self {
        let pose = HeadPose::from_mat4(camera_to_world);
        let mut c = Self::new(HeadPose::new(Vec3::ZERO, pose.orientation), yfov, aspect);
        c.anchor = pose.position.as_dvec3();
        c
    }

    /// [`Self::from_scene_camera`] for a scene's camera, perspective or
    /// orthographic (`ymag` and the image's `aspect`).
    pub fn from_scene(c: &crate::scene::SceneCamera, aspect: f32) -> Self {
        let mut cam = Self::from_scene_camera(c.transform, c.yfov, aspect);
        if let Some(mag) = c.orthographic {
            cam.projection = Projection::Orthographic { ymag: mag.y };
        }
        cam
    }

    /// The head (eye midpoint) position in world space.
    pub fn world_position(&self) -> DVec3 {
        self.anchor + self.head.position.as_dvec3()
    }

    /// The view of one eye.
    pub fn eye(&self, eye: Eye) -> EyeView {
        let offset = Vec3::new(eye.sign() * 0.5 * self.ipd, 0.0, 0.0);
        let world = self.anchor + self.head.transform_point(offset).as_dvec3();
        let position = world.as_vec3();
        let orientation = self.head.orientation;
        EyeView {
            eye,
            position,
            world,
            orientation,
            world_from_eye: Mat4::from_rotation_translation(orientation, position),
            yfov: self.yfov,
            aspect: self.aspect,
            projection: self.projection,
        }
    }

    /// Both eye views, indexed by [`Eye::index`].
    pub fn eyes(&self) -> [EyeView; 2] {
        Eye::BOTH.map(|e| self.eye(e))
    }
}

/// One eye's view: a pinhole camera with a symmetric frustum, or parallel
/// rays from a centred image rectangle ([`Projection::Orthographic`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EyeView {
    /// Which eye.
    pub eye: Eye,
    /// Eye position in world space (f32: see `world` far from the origin).
    pub position: Vec3,
    /// Eye position in world space in f64, for differences of positions far
    /// from the origin (`position` is this rounded to f32).
    pub world: DVec3,
    /// Eye orientation (eye space → world space), the head's orientation.
    pub orientation: Quat,
    /// Rigid world-from-eye matrix.
    pub world_from_eye: Mat4,
    /// Vertical field of view, radians.
    pub yfov: f32,
    /// Width / height.
    pub aspect: f32,
    /// Perspective or orthographic.
    pub projection: Projection,
}

impl EyeView {
    /// True for parallel rays ([`Projection::Orthographic`]).
    pub fn is_orthographic(&self) -> bool {
        matches!(self.projection, Projection::Orthographic { .. })
    }

    /// Half extents of the image: `(tan(yfov/2) · aspect, tan(yfov/2))` at
    /// distance 1 along −Z for a perspective eye, `(ymag · aspect, ymag)`
    /// in metres for an orthographic one. `camera.glsl` holds them in
    /// `pos_tanx.w` and `right_tany.w`.
    pub fn half_extents(&self) -> Vec2 {
        match self.projection {
            Projection::Perspective => self.tan_half_fov(),
            Projection::Orthographic { ymag } => Vec2::new(ymag * self.aspect, ymag),
        }
    }

    /// Normalized device coordinates of a continuous pixel position.
    fn ndc(pixel: Vec2, size: UVec2) -> Vec2 {
        let size = size.as_vec2();
        Vec2::new(2.0 * pixel.x / size.x - 1.0, 1.0 - 2.0 * pixel.y / size.y)
    }

    /// Where the ray through `pixel` starts, relative to the eye position:
    /// zero for a perspective eye, the pixel's point on the image plane
    /// (`ndc.x · xmag` along +X, `ndc.y · ymag` along +Y) for an
    /// orthographic one.
    pub fn ray_origin_offset(&self, pixel: Vec2, size: UVec2) -> Vec3 {
        match self.projection {
            Projection::Perspective => Vec3::ZERO,
            Projection::Orthographic { .. } => {
                let o = Self::ndc(pixel, size) * self.half_extents();
                self.orientation * Vec3::new(o.x, o.y, 0.0)
            }
        }
    }

    /// `(tan(yfov/2) · aspect, tan(yfov/2))`: half extents of the image plane
    /// at distance 1 along −Z.
    pub fn tan_half_fov(&self) -> Vec2 {
        let ty = (0.5 * self.yfov).tan();
        Vec2::new(ty * self.aspect, ty)
    }

    /// Rigid eye-from-world matrix (the view matrix).
    pub fn eye_from_world(&self) -> Mat4 {
        let inv = self.orientation.conjugate();
        Mat4::from_rotation_translation(inv, -(inv * self.position))
    }

    /// Unit world-space direction of the ray through continuous pixel
    /// coordinates `pixel` of an image of `size` pixels ((0,0) top-left
    /// corner, +y down; pixel centres at `+0.5`).
    ///
    /// In eye space: `ndc = (2·px/w − 1, 1 − 2·py/h)`,
    /// `d = normalize(ndc.x · tan.x, ndc.y · tan.y, −1)`.
    ///
    /// An orthographic eye's rays all point along its −Z.
    pub fn ray_direction(&self, pixel: Vec2, size: UVec2) -> Vec3 {
        if self.is_orthographic() {
            return (self.orientation * Vec3::NEG_Z).normalize();
        }
        let ndc = Self::ndc(pixel, size);
        let t = self.tan_half_fov();
        let d_eye = Vec3::new(ndc.x * t.x, ndc.y * t.y, -1.0).normalize();
        (self.orientation * d_eye).normalize()
    }

    /// Continuous pixel coordinates and view depth of a world-space point;
    /// `None` when the point is not in front of the eye (view depth ≤ 0 or
    /// not finite). The pixel may lie outside `[0, w] × [0, h]`: the caller
    /// decides what off-screen means. `view_depth` is the distance along the
    /// eye's −Z (not along the ray), the inverse of [`Self::ray_direction`]
    /// (and, orthographic, of [`Self::ray_origin_offset`]: parallel
    /// projection, no division by the depth).
    pub fn project(&self, world: Vec3, size: UVec2) -> Option<(Vec2, f32)> {
        self.project_offset(world - self.position, size)
    }

    /// `project` of the point `self.position + offset`: callers that know
    /// the offset more precisely than the world point (far from the origin)
    /// pass it directly.
    pub fn project_offset(&self, offset: Vec3, size: UVec2) -> Option<(Vec2, f32)> {
        let p = self.orientation.conjugate() * offset;
        let depth = -p.z;
        if !(depth > 0.0 && depth.is_finite()) {
            return None;
        }
        let t = self.half_extents();
        let s = if self.is_orthographic() { 1.0 } else { depth };
        let ndc = Vec2::new(p.x / (s * t.x), p.y / (s * t.y));
        let size = size.as_vec2();
        let pixel = Vec2::new(0.5 * (ndc.x + 1.0) * size.x, 0.5 * (1.0 - ndc.y) * size.y);
        Some((pixel, depth))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::EulerRot;

    fn cam() -> StereoCamera {
        let head = HeadPose::new(
            Vec3::new(0.3, 1.6, 2.0),
            Quat::from_euler(EulerRot::YXZ, 0.6, -0.25, 0.05),
        );
        StereoCamera::new(head, 90f32.to_radians(), 16.0 / 9.0)
    }

    #[test]
    fn eyes_are_ipd_apart_along_head_x() {
        let c = cam();
        let [l, r] = c.eyes();
        let d = r.position - l.position;
        assert!((d.length() - DEFAULT_IPD).abs() < 1e-6);
        assert!(d.normalize().abs_diff_eq(c.head.right(), 1e-5));
        assert!(((l.position + r.position) * 0.5).abs_diff_eq(c.head.position, 1e-6));
        assert_eq!(l.eye.index(), 0);
        assert_eq!(r.eye.index(), 1);
    }

    #[test]
    fn centre_pixel_looks_forward_and_corners_match_fov() {
        let c = cam();
        let v = c.eye(Eye::Left);
        let size = UVec2::new(64, 36);
        let d = v.ray_direction(size.as_vec2() * 0.5, size);
        assert!(d.abs_diff_eq(c.head.forward(), 1e-5));
        // Top edge centre is yfov/2 above forward.
        let top = v.ray_direction(Vec2::new(32.0, 0.0), size);
        let angle = top.angle_between(c.head.forward());
        assert!((angle - 45f32.to_radians()).abs() < 1e-4);
        assert!(top.dot(c.head.up()) > 0.0);
        // Left edge is to the left.
        let left = v.ray_direction(Vec2::new(0.0, 18.0), size);
        assert!(left.dot(c.head.right()) < 0.0);
    }

    #[test]
    fn project_inverts_ray_direction() {
        let c = cam();
        let size = UVec2::new(64, 48);
        for e in Eye::BOTH {
            let v = c.eye(e);
            for &(px, py) in &[(0.5, 0.5), (10.25, 40.75), (63.9, 0.1), (32.0, 24.0)] {
                let p = Vec2::new(px, py);
                let dir = v.ray_direction(p, size);
                for &dist in &[0.05f32, 1.0, 37.0] {
                    let (q, depth) = v.project(v.position + dir * dist, size).unwrap();
                    assert!((q - p).length() < 2e-3, "{e:?} {p} -> {q} at {dist}");
                    let expected = dist * dir.dot(c.head.forward());
                    assert!((depth - expected).abs() < 1e-4 * dist.max(1.0));
                }
            }
            assert!(v.project(v.position - c.head.forward(), size).is_none());
        }
    }

    /// Far from the origin the f64 anchor keeps the IPD and small head
    /// motion that an f32 world position (spacing 6 cm at 1e6 m) would lose.
    #[test]
    fn anchored_eyes_keep_their_separation_far_from_the_origin() {
        let mut c = cam();
        c.anchor = DVec3::new(1e6, 1e6, -1e6);
        c.head.position += Vec3::new(0.001, 0.0, 0.0);
        let [l, r] = c.eyes();
        let ipd = (r.world - l.world).length();
        assert!((ipd - c.ipd as f64).abs() < 1e-6, "{ipd}");
        let mid = 0.5 * (l.world + r.world);
        assert!((mid - c.world_position()).length() < 1e-6);
    }

    #[test]
    fn world_from_eye_and_eye_from_world_are_inverse() {
        let v = cam().eye(Eye::Right);
        let m = v.world_from_eye * v.eye_from_world();
        assert!(m.abs_diff_eq(Mat4::IDENTITY, 1e-5));
    }

    #[test]
    fn from_scene_camera_uses_node_transform() {
        let m =
            Mat4::from_rotation_translation(Quat::from_rotation_y(1.0), Vec3::new(0.0, 1.5, 0.0));
        let c = StereoCamera::from_scene_camera(m, 1.0, 1.0);
        assert!(c
            .world_position()
            .abs_diff_eq(DVec3::new(0.0, 1.5, 0.0), 1e-6));
        assert_eq!(c.head.position, Vec3::ZERO);
        assert!(c
            .head
            .forward()
            .abs_diff_eq(m.transform_vector3(Vec3::NEG_Z), 1e-6));
        assert_eq!(c.ipd, DEFAULT_IPD);
    }
}
