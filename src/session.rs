//! A rendering session: the GPU, a loaded scene with its lighting, the scene
//! on the GPU for the chosen ray backend, and the methods that render it.
//! The CLI and the tests open sessions the same way.

use crate::camera::{frame_bounds, HeadPose, StereoCamera, DEFAULT_IPD};
use crate::error::{Error, Result};
use crate::gpu::{GpuContext, GpuOptions};
use crate::methods::{Method, MethodConfig, MethodKind, RenderSettings};
use crate::rt::{BvhLayout, RtBackend, RtChoice, SceneGpu};
use crate::scene::{light_scene, load_scene, DefaultLighting, LightingDecision, Scene};
use glam::{Quat, Vec3};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Which camera the head sits at.
#[derive(Clone, Debug, Default)]
pub enum CameraSelect {
    /// The scene camera named `default`, else the first camera, else a view
    /// framing the scene's bounds ([`crate::camera::framing`]; the chosen
    /// camera and any warning printed on stderr once per session).
    #[default]
    Default,
    /// A scene camera by name.
    Named(String),
    /// An explicit head pose in world space.
    Pose(HeadPose),
}

/// Method names the CLI accepts, in registry order ([`MethodKind::ALL`]).
pub const METHODS: &[&str] = &{
    let mut names = [""; MethodKind::ALL.len()];
    let mut i = 0;
    while i < names.len() {
        names[i] = MethodKind::ALL[i].name();
        i += 1;
    }
    names
};

pub struct Session {
    pub ctx: Arc<GpuContext>,
    pub scene: Scene,
    pub scene_gpu: Arc<SceneGpu>,
    pub backend: RtBackend,
    /// Whether the chosen camera's line (a scene camera's, or the automatic
    /// framing's) was printed.
    camera_reported: AtomicBool,
    /// `scene.mesh_bounds()`, for the pose checks of an animated scene.
    mesh_bounds: Vec<Option<(Vec3, Vec3)>>,
    /// `scene.content_hash()`, computed on first use (the reference cache's key).
    content_hash: std::sync::OnceLock<u64>,
}

/// Bytes per triangle of the flattened software BVH's buffers
/// (`SoftwareBvh::tri_verts`: three vertices as vec4; `tri_ref`: two u32).
const FLATTENED_BYTES_PER_TRIANGLE: [(&str, u64); 2] = [("bvh.tri_verts", 48), ("bvh.tri_ref", 8)];

/// Refuses, before the BVH is built, a scene whose flattened software BVH
/// (every instance's triangles copied into world space) would need a
/// storage buffer larger than the device binds: 100,000 instances of a
/// 4,000-triangle mesh built for 100 s in 11–22 GB before the upload
/// failed on the limit. The triangle count is known once the scene is
/// parsed. Instances whose transform is singular (scaled to a point or
/// flattened onto a plane) are not counted: every triangle of theirs has
/// zero area in world space, and the BVH build leaves those out
/// (`rt::bvh::hittable`; tests/backends.rs `zero_area_triangles_change_no_pixel`
/// adds 5,000 such instances of a plane).
fn check_flattened_size(
    ctx: &GpuContext,
    scene: &Scene,
    backend: RtBackend,
    layout: BvhLayout,
) -> Result<()> {
    if backend != RtBackend::Software || layout != BvhLayout::Flattened {
        return Ok(());
    }
    let triangles: u64 = scene
        .instances
        .iter()
        .filter(|i| {
            let det = i.transform.determinant();
            det.is_finite() && det != 0.0
        })
        .map(|i| scene.meshes[i.mesh as usize].triangle_count() as u64)
        .sum();
    for (name, per) in FLATTENED_BYTES_PER_TRIANGLE {
        crate::gpu::buffer::check_storage_range(ctx, name, triangles.saturating_mul(per)).map_err(
            |e| {
                Error::Usage(format!(
                    "{}: {triangles} triangles once its {} instances are flattened: {e}",
                    scene.source.display(),
                    scene.instances.len()
                ))
            },
        )?;
    }
    Ok(())
}

impl Session {
    /// Opens the GPU and uploads `scene` for the backend `rt` resolves to.
    pub fn new(gpu: &GpuOptions, scene: Scene, rt: RtChoice) -> Result<Session> {
        let mut opts = gpu.clone();
        opts.want_ray_query = rt != RtChoice::Software;
        // `--rt query` needs ray queries: choose passes over devices without
        // them (each rejected with its reason) instead of opening one and
        // failing afterwards.
        opts.require.ray_query |= rt == RtChoice::Query;
        let ctx = Arc::new(GpuContext::new(&opts)?);
        Self::with_context(ctx, scene, rt)
    }

    /// Uploads `scene` on an existing context (several backends on one device).
    pub fn with_context(ctx: Arc<GpuContext>, scene: Scene, rt: RtChoice) -> Result<Session> {
        Self::with_layout(ctx, scene, rt, None)
    }

    /// As `with_context` with the software BVH layout forced (`None`: the
    /// automatic choice, `BvhLayout::auto`).
    pub fn with_layout(
        ctx: Arc<GpuContext>,
        scene: Scene,
        rt: RtChoice,
        layout: Option<BvhLayout>,
    ) -> Result<Session> {
        let backend = rt.resolve(&ctx).map_err(Error::Usage)?;
        let layout = layout.unwrap_or_else(|| BvhLayout::auto(&scene));
        check_flattened_size(&ctx, &scene, backend, layout)?;
        let scene_gpu = Arc::new(SceneGpu::upload_with(&ctx, &scene, backend, layout)?);
        Ok(Session {
            ctx,
            mesh_bounds: scene.mesh_bounds(),
            scene,
            scene_gpu,
            backend,
            camera_reported: AtomicBool::new(false),
            content_hash: std::sync::OnceLock::new(),
        })
    }

    /// [`Scene::content_hash`] of this session's scene, computed once (the
    /// scene is not changed after the session is made).
    pub fn scene_content_hash(&self) -> u64 {
        *self.content_hash.get_or_init(|| self.scene.content_hash())
    }

    /// Poses the scene's instances at time `t` (seconds: the replay's frame
    /// time, so a 90 Hz and a 45 Hz replay see the same motion) and uploads
    /// them with the previous frame's pose at `prev_t` (`None`: the first
    /// frame of a run, no motion) beside them for the motion vectors
    /// (`SceneGpu::set_instance_motion`). The frame loop calls it once per
    /// frame. Nothing happens for a static scene. Returns the wall time it
    /// took (animation sampling, TLAS rebuild, upload).
    pub fn pose_instances(&self, t: f64, prev_t: Option<f64>) -> Result<std::time::Duration> {
        let start = std::time::Instant::now();
        if self.scene.is_animated() {
            let transforms = self.scene.instance_transforms_at(t);
            self.check_pose(t, &transforms)?;
            let prev = match prev_t {
                Some(p) => self.scene.instance_transforms_at(p),
                None => transforms.clone(),
            };
            self.scene_gpu.set_instance_motion(&prev, &transforms)?;
        }
        Ok(start.elapsed())
    }

    /// Refuses, before anything renders, an animation that at any of
    /// `times` places an instance where [`Scene::check_placement`] does not
    /// allow (a broken key value): what [`Self::pose_instances`] would
    /// find in the middle of a run. Nothing to do for a static scene.
    pub fn check_poses(&self, times: impl IntoIterator<Item = f64>) -> Result<()> {
        if self.scene.is_animated() {
            for t in times {
                self.check_pose(t, &self.scene.instance_transforms_at(t))?;
            }
        }
        Ok(())
    }

    fn check_pose(&self, t: f64, transforms: &[glam::Mat4]) -> Result<()> {
        self.scene
            .check_placement(&self.mesh_bounds, transforms)
            .map_err(|m| {
                Error::Usage(format!(
                    "{}: at {t} s of its animation, {m}",
                    self.scene.source.display()
                ))
            })
    }

    /// Loads a scene by name or path and lights it by the rule of
    /// [`crate::scene::default_lighting`]: `lighting` is an explicit choice
    /// (`--lighting`), always added; `None` adds the default sun and sky to
    /// a scene without lighting of its own.
    pub fn load_scene(spec: &str, lighting: Option<&DefaultLighting>) -> Result<Scene> {
        Ok(Self::load_scene_lit(spec, lighting)?.0)
    }

    /// As [`Self::load_scene`], with the lighting decision (commands print
    /// its [`LightingDecision::line`]).
    pub fn load_scene_lit(
        spec: &str,
        lighting: Option<&DefaultLighting>,
    ) -> Result<(Scene, LightingDecision)> {
        let mut scene = load_scene(spec)?;
        let decision = light_scene(&mut scene, lighting)?;
        Ok((scene, decision))
    }

    /// The stereo camera for a selection, image aspect and IPD.
    pub fn camera(
        &self,
        select: &CameraSelect,
        width: u32,
        height: u32,
        ipd: Option<f32>,
        yfov_override: Option<f32>,
    ) -> Result<StereoCamera> {
        let aspect = width as f32 / height as f32;
        let default_fov = 60f32.to_radians();
        // The scene camera used, for the one line that names it.
        let mut scene_camera = None;
        let mut cam = match select {
            CameraSelect::Pose(p) => StereoCamera::new(*p, default_fov, aspect),
            CameraSelect::Named(name) => {
                let c = self.scene.camera(name).ok_or_else(|| {
                    let names: Vec<&str> =
                        self.scene.cameras.iter().map(|c| c.name.as_str()).collect();
                    Error::Usage(format!(
                        "{}: no camera named '{name}' (cameras: {})",
                        self.scene.source.display(),
                        if names.is_empty() {
                            "none".to_string()
                        } else {
                            names.join(", ")
                        }
                    ))
                })?;
                scene_camera = Some(c);
                StereoCamera::from_scene(c, aspect)
            }
            CameraSelect::Default => {
                match self.scene.camera("default").or(self.scene.cameras.first()) {
                    Some(c) => {
                        scene_camera = Some(c);
                        StereoCamera::from_scene(c, aspect)
                    }
                    None => {
                        let (lo, hi) = self.scene.world_bounds();
                        let framing = frame_bounds(
                            lo,
                            hi,
                            yfov_override.unwrap_or(default_fov),
                            aspect,
                            ipd.unwrap_or(DEFAULT_IPD),
                        );
                        if !self.camera_reported.swap(true, Ordering::Relaxed) {
                            eprintln!("{}", framing.line());
                            if let Some(w) = &framing.warning {
                                eprintln!("warning: {}: {w}", self.scene.source.display());
                            }
                        }
                        framing.camera
                    }
                }
            }
        };
        // Every session camera keeps its world position in the f64 anchor
        // and starts with the head at 0 relative to it (see StereoCamera).
        cam.anchor = cam.world_position();
        cam.head.position = Vec3::ZERO;
        cam.ipd = ipd.unwrap_or(DEFAULT_IPD);
        if let Some(f) = yfov_override {
            if cam.projection != crate::camera::Projection::Perspective {
                return Err(Error::Usage(format!(
                    "{}: the chosen camera is orthographic: --fov does not apply to it (its ymag sets the view's height)",
                    self.scene.source.display()
                )));
            }
            cam.yfov = f;
        }
        if let Some(c) = scene_camera {
            if !self.camera_reported.swap(true, Ordering::Relaxed) {
                eprintln!("{}", scene_camera_line(&c.name, &cam));
            }
        }
        Ok(cam)
    }

    /// Creates a rendering method from its configuration (the registry's
    /// constructor); a [`MethodKind`] is the method with default options.
    pub fn create(
        &self,
        config: impl Into<MethodConfig>,
        settings: &RenderSettings,
    ) -> Result<Box<dyn Method>> {
        config.into().create(self, settings)
    }

    /// Creates a rendering method by its CLI name, with default options (an
    /// unknown name is a usage error listing the registry's names).
    pub fn method(&self, name: &str, settings: &RenderSettings) -> Result<Box<dyn Method>> {
        self.create(name.parse::<MethodKind>()?, settings)
    }
}

/// Parses `WxH` with a clear message for anything else.
pub fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("bad --size '{s}': expected WIDTHxHEIGHT, e.g. 640x480"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad --size '{s}': width '{w}' is not a positive integer"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad --size '{s}': height '{h}' is not a positive integer"))?;
    if w == 0 || h == 0 {
        return Err(format!(
            "bad --size '{s}': width and height must be at least 1"
        ));
    }
    if w > 16384 || h > 16384 {
        return Err(format!("bad --size '{s}': at most 16384 pixels per side"));
    }
    Ok((w, h))
}

/// Parses `px,py,pz,qx,qy,qz,qw` (metres, unit quaternion).
pub fn parse_pose(s: &str) -> std::result::Result<HeadPose, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("bad --pose '{s}': expected 7 numbers px,py,pz,qx,qy,qz,qw"))?;
    if v.len() != 7 || v.iter().any(|x| !x.is_finite()) {
        return Err(format!(
            "bad --pose '{s}': expected 7 finite numbers px,py,pz,qx,qy,qz,qw"
        ));
    }
    let bound = crate::scene::MAX_WORLD_COORDINATE;
    if v[..3].iter().any(|x| x.abs() > bound) {
        return Err(format!(
            "bad --pose '{s}': the position is beyond ±{bound:e} m (world coordinates must stay within it, as the scene's do)"
        ));
    }
    // The norm in f64: an f32 one overflows to ∞ from components of about
    // 2e19 on (`1e20,0,0,0` became a NaN orientation without a word).
    let q = [v[3], v[4], v[5], v[6]].map(f64::from);
    let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    if norm < 1e-6 {
        return Err(format!("bad --pose '{s}': the quaternion has zero length"));
    }
    let [x, y, z, w] = q.map(|c| (c / norm) as f32);
    Ok(HeadPose::new(
        Vec3::new(v[0], v[1], v[2]),
        Quat::from_xyzw(x, y, z, w),
    ))
}

/// The one stderr line naming the scene camera a session renders with.
fn scene_camera_line(name: &str, cam: &StereoCamera) -> String {
    match cam.projection {
        crate::camera::Projection::Perspective => format!(
            "camera: the scene's '{name}': perspective, yfov {:.1}°",
            cam.yfov.to_degrees()
        ),
        crate::camera::Projection::Orthographic { ymag } => format!(
            "camera: the scene's '{name}': orthographic, a {} × {} m view (ymag {ymag}, the image's aspect {})",
            2.0 * ymag * cam.aspect,
            2.0 * ymag,
            cam.aspect
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Any non-zero quaternion of finite f32 components is a rotation: the
    /// norm of (1e20, 0, 0, 0) overflowed in f32 and made it NaN. Expected:
    /// the unit quaternions (1, 0, 0, 0) and (0, 0, 0.6, 0.8) (a 3-4-5
    /// triangle, exact but for the rounding of 0.6 and 0.8 to f32 and the
    /// normalization in f32: 2e-7 is 3 ulps at 0.8).
    #[test]
    fn a_huge_pose_quaternion_is_normalized_not_nan() {
        let p = parse_pose("0,0,0,1e20,0,0,0").unwrap();
        assert_eq!(p.orientation, Quat::from_xyzw(1.0, 0.0, 0.0, 0.0));
        let p = parse_pose("1,2,3,0,0,3e30,4e30").unwrap();
        assert!(
            p.orientation
                .abs_diff_eq(Quat::from_xyzw(0.0, 0.0, 0.6, 0.8), 2e-7),
            "{:?}",
            p.orientation
        );
        assert_eq!(p.position, Vec3::new(1.0, 2.0, 3.0));
        assert!(parse_pose("0,0,0,0,0,0,0").is_err());
    }
}
