//! Helpers shared by the GPU tests: every test opens the GPU with the Khronos
//! validation layer on (when installed) and fails on any message it reports.
#![allow(dead_code)]

use glam::{Mat4, Vec2, Vec3};
use std::sync::Arc;
use stereocache::camera::{HeadPose, StereoCamera};
use stereocache::gpu::{GpuContext, GpuOptions};
use stereocache::methods::{
    FrameInput, MethodConfig, RenderSettings, SampleCacheSettings, StereoFrame,
};
use stereocache::rt::RtChoice;
use stereocache::scene::{generate::*, Environment, Material, Scene};
use stereocache::session::Session;

/// Validation always on; synchronization validation too when
/// `STEREOCACHE_SYNC_VALIDATION=1` (slow; see docs/ROBUSTNESS.md), guard
/// bands after every storage buffer when `STEREOCACHE_GUARD_BANDS=1`
/// (src/gpu/guard.rs: a frame fails on an out-of-bounds write).
pub fn gpu_options() -> GpuOptions {
    GpuOptions {
        validate: true,
        sync_validation: std::env::var("STEREOCACHE_SYNC_VALIDATION").is_ok_and(|v| v == "1"),
        guard_bands: std::env::var("STEREOCACHE_GUARD_BANDS").is_ok_and(|v| v == "1"),
        device: None,
        want_ray_query: true,
        ..Default::default()
    }
}

/// The ray backends to test on: the software traversal, and hardware ray
/// queries where the device has them (required when `CI` is set).
pub fn rt_backends(ctx: &GpuContext) -> Vec<RtChoice> {
    let mut v = vec![RtChoice::Software];
    if require(ctx.ray_query_enabled(), "ray queries") {
        v.push(RtChoice::Query);
    }
    v
}

/// One GPU context per test (lavapipe in CI).
pub fn context() -> Arc<GpuContext> {
    Arc::new(GpuContext::new(&gpu_options()).expect("a Vulkan 1.2 device (run scripts/setup.sh)"))
}

pub fn assert_no_validation_messages(ctx: &GpuContext) {
    let m = ctx.validation.messages();
    assert!(
        m.is_empty(),
        "{} validation message(s):\n{}",
        m.len(),
        m.join("\n")
    );
}

pub fn session(ctx: &Arc<GpuContext>, scene: Scene, rt: RtChoice) -> Session {
    Session::with_context(ctx.clone(), scene, rt).expect("scene upload")
}

pub fn render(
    s: &Session,
    method: &str,
    camera: StereoCamera,
    settings: &RenderSettings,
) -> StereoFrame {
    let mut m = s.method(method, settings).expect("method");
    render_at(m.as_mut(), 0, camera, None)
}

/// As [`render`], for a method with its own options
/// (`MethodConfig::taa(|c| c.alpha = 0.5)`; a `MethodKind` is the defaults).
pub fn render_config(
    s: &Session,
    config: impl Into<MethodConfig>,
    camera: StereoCamera,
    settings: &RenderSettings,
) -> StereoFrame {
    let mut m = s.create(config, settings).expect("method");
    render_at(m.as_mut(), 0, camera, None)
}

/// Renders frame `index` with `camera`, the previous frame's camera being
/// `prev_camera` (None on a trace's first frame).
pub fn render_at<M: stereocache::methods::Method + ?Sized>(
    m: &mut M,
    index: u32,
    camera: StereoCamera,
    prev_camera: Option<StereoCamera>,
) -> StereoFrame {
    m.render_frame(&FrameInput {
        index,
        camera,
        prev_camera,
    })
    .expect("render")
}

/// What the shared frame loop promises a method built on the hash table,
/// along 3 frames of `path`: one submit-and-wait per frame (the one batched
/// readback) and `table_occupancy` = live entries / `capacity`; `each` adds
/// the method's own per-frame checks. Ends with no validation message.
pub fn check_one_submit_and_occupancy(
    ctx: &GpuContext,
    m: &mut dyn stereocache::methods::Method,
    capacity: f64,
    path: impl Fn(u32) -> StereoCamera,
    mut each: impl FnMut(u32, &StereoFrame),
) {
    let mut prev = None;
    for f in 0..3 {
        let cam = path(f);
        let before = ctx.submit_count();
        let fr = render_at(m, f, cam, prev);
        prev = Some(cam);
        assert_eq!(
            ctx.submit_count() - before,
            1,
            "frame {f}: submit-and-waits"
        );
        let live = fr.stats.counters["live_entries"];
        assert!(live > 0.0, "frame {f}: the table holds entries");
        assert_eq!(
            fr.stats.counters["table_occupancy"],
            live / capacity,
            "frame {f}: occupancy"
        );
        each(f, &fr);
    }
    assert_no_validation_messages(ctx);
}

/// Every pixel's radiance in both eyes is finite and non-negative.
pub fn assert_finite_non_negative(fr: &StereoFrame, what: &str) {
    for (e, eye) in fr.eyes.iter().enumerate() {
        for (i, p) in eye.radiance.iter().enumerate() {
            assert!(
                p.iter().all(|c| c.is_finite() && *c >= 0.0),
                "{what}: eye {e} pixel {i} radiance {p:?}"
            );
        }
    }
}

/// The session's default camera (`CameraSelect::Default`) for `w`×`h` eyes.
pub fn default_camera(s: &Session, w: u32, h: u32) -> StereoCamera {
    s.camera(
        &stereocache::session::CameraSelect::Default,
        w,
        h,
        None,
        None,
    )
    .expect("default camera")
}

/// A camera at `eye` looking at `target` (+Y up) as a stereo camera.
pub fn look_at_camera(eye: Vec3, target: Vec3, yfov_deg: f32, aspect: f32) -> StereoCamera {
    let c = look_at("test", eye, target, Vec3::Y, yfov_deg);
    StereoCamera::from_scene_camera(c.transform, c.yfov, aspect)
}

/// A sphere of `radius` at `centre` with material `m` inside a constant environment `env`.
pub fn sphere_in_environment(m: Material, centre: Vec3, radius: f32, env: Vec3) -> Scene {
    let mut s = Scene {
        source: "test:sphere".into(),
        ..Default::default()
    };
    let mat = add_material(&mut s, m);
    add_mesh(
        &mut s,
        uv_sphere("sphere", 96, 48),
        mat,
        Mat4::from_scale_rotation_translation(Vec3::splat(radius), glam::Quat::IDENTITY, centre),
    );
    s.environment = Some(Environment::Constant(env));
    s.validate().unwrap();
    s
}

/// The same sphere with every triangle unwelded and given its face normal, so
/// shading normals equal geometric normals (no shading-normal energy loss).
pub fn faceted(mut m: stereocache::scene::Mesh) -> stereocache::scene::Mesh {
    let mut out = stereocache::scene::Mesh {
        name: m.name.clone(),
        material: m.material,
        ..Default::default()
    };
    for t in m.indices.chunks_exact(3) {
        let p: Vec<Vec3> = t.iter().map(|&i| m.positions[i as usize]).collect();
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for (k, &i) in t.iter().enumerate() {
            out.indices.push(out.positions.len() as u32);
            out.positions.push(p[k]);
            out.normals.push(n);
            out.uvs.push(m.uvs[i as usize]);
        }
    }
    m.indices.clear();
    out
}

/// Albedo of the furnace sphere of tests/hybrid.rs and tests/hash_cache.rs
/// (distinct per channel, so a channel mix-up shows).
pub const FURNACE_ALBEDO: Vec3 = Vec3::new(0.5, 0.25, 0.75);

/// Furnace: a faceted grey Lambert sphere with no specular lobe in a
/// constant white environment. Every path leaves the convex sphere after one
/// bounce carrying `albedo` × 1.
pub fn furnace_sphere(albedo: Vec3) -> Scene {
    let mut mat = Material::diffuse("grey", albedo);
    mat.specular = 0.0;
    faceted_sphere_in_environment(mat, Vec3::ONE)
}

/// Like `sphere_in_environment` but faceted (see `faceted`).
pub fn faceted_sphere_in_environment(m: Material, env: Vec3) -> Scene {
    let mut s = Scene {
        source: "test:faceted-sphere".into(),
        ..Default::default()
    };
    let mat = add_material(&mut s, m);
    add_mesh(
        &mut s,
        faceted(uv_sphere("sphere", 48, 24)),
        mat,
        Mat4::IDENTITY,
    );
    s.environment = Some(Environment::Constant(env));
    s.validate().unwrap();
    s
}

/// A square of side `size` in the XZ plane facing +Y, inside a constant environment.
/// A 1 m square (2 × 2 cells) in the z = 0 plane facing +Z, centred on
/// the origin, of material `m`, in `env`; the scene's source is `source`.
pub fn square_in_environment(source: &str, m: Material, env: Environment) -> Scene {
    let mut s = Scene {
        source: source.into(),
        ..Default::default()
    };
    let mat = add_material(&mut s, m);
    add_mesh(
        &mut s,
        grid(
            "square",
            Vec3::new(-0.5, -0.5, 0.0),
            Vec3::X,
            Vec3::Y,
            2,
            2,
            Vec2::ONE,
        ),
        mat,
        Mat4::IDENTITY,
    );
    s.environment = Some(env);
    s.validate().unwrap();
    s
}

pub fn plane_in_environment(m: Material, size: f32, env: Vec3) -> Scene {
    let mut s = Scene {
        source: "test:plane".into(),
        ..Default::default()
    };
    let mat = add_material(&mut s, m);
    let h = 0.5 * size;
    add_mesh(
        &mut s,
        grid(
            "plane",
            Vec3::new(-h, 0.0, h),
            Vec3::X * size,
            Vec3::NEG_Z * size,
            4,
            4,
            Vec2::ONE,
        ),
        mat,
        Mat4::IDENTITY,
    );
    s.environment = Some(Environment::Constant(env));
    s.validate().unwrap();
    s
}

pub fn head_at(p: Vec3) -> HeadPose {
    HeadPose::new(p, glam::Quat::IDENTITY)
}

/// True when a 5×5 grid of rays over the pixel all hit geometry (a CPU
/// stand-in for "geometry covers the whole pixel").
pub fn fully_covered(
    bvh: &stereocache::rt::SoftwareBvh,
    v: &stereocache::camera::EyeView,
    pixel: usize,
    w: u32,
    h: u32,
) -> bool {
    let c = pixel_centre(pixel, w) - Vec2::splat(0.5);
    (0..25).all(|k| {
        let o = Vec2::new((k % 5) as f32 * 0.245 + 0.01, (k / 5) as f32 * 0.245 + 0.01);
        bvh.closest_hit(
            bvh.to_local(v.world),
            v.ray_direction(c + o, glam::UVec2::new(w, h)),
            0.0,
            1e30,
        )
        .is_some()
    })
}

pub fn pixel_centre(pixel: usize, w: u32) -> Vec2 {
    Vec2::new(
        (pixel as u32 % w) as f32 + 0.5,
        (pixel as u32 / w) as f32 + 0.5,
    )
}

/// Position of a stored first hit from the software BVH's triangle data, in
/// the BVH's frame (relative to `bvh.origin`; world space for scenes whose
/// render origin is 0, i.e. every scene near its file's origin).
pub fn stored_position(bvh: &stereocache::rt::SoftwareBvh, fh: [u32; 4]) -> Vec3 {
    let k = bvh
        .tri_ref
        .iter()
        .position(|r| r[0] == fh[3] && r[1] == fh[2])
        .expect("stored triangle exists");
    let [v0, v1, v2] = bvh.triangle(k);
    let b = Vec2::new((fh[0] & 0xFF_FFFF) as f32, (fh[1] & 0xFF_FFFF) as f32) / 16_777_215.0;
    v0 + b.x * (v1 - v0) + b.y * (v2 - v0)
}

/// The barycentric weights of a stored first hit (Listing 1: barycentrics in
/// 24 bits each, then primitive and instance) and the vertex indices of its
/// triangle in the scene's mesh.
pub fn first_hit_weights(scene: &Scene, fh: [u32; 4]) -> ([usize; 3], [f32; 3]) {
    let inst = &scene.instances[fh[3] as usize];
    let mesh = &scene.meshes[inst.mesh as usize];
    let t = fh[2] as usize;
    let idx = [0, 1, 2].map(|k| mesh.indices[3 * t + k] as usize);
    let b = Vec2::new((fh[0] & 0xFF_FFFF) as f32, (fh[1] & 0xFF_FFFF) as f32) / 16_777_215.0;
    (idx, [1.0 - b.x - b.y, b.x, b.y])
}

/// Every instance's triangles in world space.
pub fn world_triangles(s: &Scene) -> Vec<[Vec3; 3]> {
    s.instances
        .iter()
        .flat_map(|i| {
            let m = &s.meshes[i.mesh as usize];
            (0..m.triangle_count())
                .map(move |t| m.triangle(t).map(|p| i.transform.transform_point3(p)))
        })
        .collect()
}

/// Runs a one-key-per-lane test kernel (`shaders/<spirv>.comp`, interface
/// `interface` with push block `push_block`): binding 0 reads `keys` (four
/// words a key), binding 1 receives `words` u32 per key, one dispatch of
/// 64-lane workgroups per push constant block of `pushes`. Returns the outputs, one
/// `Vec<u32>` per entry of `pushes`.
pub fn run_key_kernel<P: bytemuck::Pod>(
    ctx: &Arc<GpuContext>,
    spirv: &str,
    interface: &'static stereocache::interface::Interface,
    push_block: &'static stereocache::interface::PushBlock,
    keys: &[[u32; 4]],
    words: usize,
    pushes: &[P],
) -> Vec<Vec<u32>> {
    use stereocache::gpu::{shaders, Buffer, ComputePipeline, Recorder};
    let n = keys.len() as u32;
    let key_buf = Buffer::with_data(
        ctx,
        "test.keys",
        bytemuck::cast_slice(keys),
        Default::default(),
    )
    .unwrap();
    let out = Buffer::storage(ctx, "test.out", (keys.len() * words * 4) as u64).unwrap();
    let pipe = ComputePipeline::with_interface(
        ctx,
        spirv,
        shaders::spirv(spirv).unwrap_or_else(|| panic!("{spirv} compiled")),
        &[],
        interface,
        Some(push_block),
        &Default::default(),
    )
    .unwrap();
    pushes
        .iter()
        .map(|push| {
            let mut rec = Recorder::new(ctx, 1).unwrap();
            rec.compute(spirv, &pipe)
                .read(&key_buf)
                .write(&out)
                .push(push)
                .dispatch([n.div_ceil(64), 1, 1])
                .unwrap();
            rec.finish().unwrap();
            out.download_pod().unwrap()
        })
        .collect()
}

/// A shipped scene (built-in name or path) with default lighting where it has none.
pub fn shipped(name: &str) -> Scene {
    let mut s = stereocache::scene::load_scene(name).unwrap();
    stereocache::scene::apply_default_lighting(
        &mut s,
        &stereocache::scene::DefaultLighting::default(),
    )
    .unwrap();
    s
}

/// `start`'s head turned about +Y by `deg_per_frame`·frame and moved along its
/// +X by `drift_per_frame`·frame metres: a simple moving trace for tests.
pub fn turning_head(
    start: &StereoCamera,
    frame: u32,
    deg_per_frame: f32,
    drift_per_frame: f32,
) -> StereoCamera {
    let mut c = *start;
    let yaw = glam::Quat::from_rotation_y((deg_per_frame * frame as f32).to_radians());
    c.head.orientation = (start.head.orientation * yaw).normalize();
    c.head.position = start.head.position
        + start.head.orientation * Vec3::new(drift_per_frame * frame as f32, 0.0, 0.0);
    c
}

/// A high-spp `reference` render of both eyes (the target of convergence tests).
pub fn reference_frame(
    s: &Session,
    camera: StereoCamera,
    width: u32,
    height: u32,
    spp: u32,
) -> StereoFrame {
    let settings = RenderSettings {
        width,
        height,
        spp,
        max_bounces: 2,
        seed: 99,
        ..Default::default()
    };
    render(s, "reference", camera, &settings)
}

/// A shipped scene on the software backend seen from its default camera at
/// `w`×`h`, with a `spp` reference of that view (the static-view convergence tests).
pub fn static_view_with_reference(
    ctx: &Arc<GpuContext>,
    name: &str,
    w: u32,
    h: u32,
    spp: u32,
) -> (Session, StereoCamera, StereoFrame) {
    let s = session(ctx, shipped(name), RtChoice::Software);
    let cam = default_camera(&s, w, h);
    let reference = reference_frame(&s, cam, w, h, spp);
    (s, cam, reference)
}

/// Per-pixel, per-channel squared differences of two stereo frames' radiance.
pub fn squared_errors(a: &StereoFrame, b: &StereoFrame) -> Vec<f64> {
    a.eyes
        .iter()
        .zip(&b.eyes)
        .flat_map(|(p, q)| p.radiance.iter().zip(&q.radiance))
        .flat_map(|(p, q)| (0..3).map(move |k| ((p[k] - q[k]) as f64).powi(2)))
        .collect()
}

/// Mean of `v` and the standard error of that mean.
pub fn mean_and_standard_error(v: &[f64]) -> (f64, f64) {
    let k = v.len() as f64;
    let mean = v.iter().sum::<f64>() / k;
    let se = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt();
    (mean, se)
}

/// Form factor from a differential area at the origin facing +Y to a parallel
/// rectangle [x0, x1] × [z0, z1] at height c facing it (radiative-transfer
/// tables, e.g. Howell's catalogue, case B-3: a differential element under a
/// corner of a parallel rectangle, F = 1/2π [X/√(1+X²) atan(Y/√(1+X²)) +
/// Y/√(1+Y²) atan(X/√(1+Y²))], X = a/c, Y = b/c; odd in X and Y, so any
/// rectangle is a signed sum over its four corners). Irradiance E = π·Le·F.
pub fn form_factor_to_parallel_rect(x0: f64, x1: f64, z0: f64, z1: f64, c: f64) -> f64 {
    let corner = |a: f64, b: f64| {
        let (x, y) = (a / c, b / c);
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
    };
    corner(x1, z1) - corner(x0, z1) - corner(x1, z0) + corner(x0, z0)
}

/// Whether a test can go on: true when `available`. Otherwise the test would
/// skip `what` (a device feature, a data file, a tool): with the environment
/// variable `CI` set that is a failure — a skip must not hide a check in CI —
/// and elsewhere it says on stderr what is skipped and returns false. Use as
/// `if !require(ctx.ray_query_enabled(), "ray queries") { return; }`.
pub fn require(available: bool, what: &str) -> bool {
    require_in_ci(std::env::var_os("CI").is_some(), available, what)
}

/// [`require`] with the CI decision passed in (unit-tested in tests/skips.rs).
pub fn require_in_ci(ci: bool, available: bool, what: &str) -> bool {
    if available {
        return true;
    }
    assert!(
        !ci,
        "CI is set but {what} is not available: this test may not skip in CI"
    );
    eprintln!("skipped: {what} not available");
    false
}

/// [`require`] for a data file outside the repository (`../shared`).
pub fn require_file(path: &std::path::Path) -> bool {
    require(path.exists(), &path.display().to_string())
}

/// Exact unpolarised Fresnel reflectance of a dielectric interface, η = n_t/n_i.
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let s2 = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if s2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - s2).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// What a sample-cache test creates its cache from: the shared settings and
/// the cache's own options (`st.width` etc. read the shared settings).
#[derive(Clone, Debug)]
pub struct CacheSetup {
    pub settings: RenderSettings,
    pub cache: SampleCacheSettings,
}

impl std::ops::Deref for CacheSetup {
    type Target = RenderSettings;
    fn deref(&self) -> &RenderSettings {
        &self.settings
    }
}

impl std::ops::DerefMut for CacheSetup {
    fn deref_mut(&mut self) -> &mut RenderSettings {
        &mut self.settings
    }
}

impl CacheSetup {
    /// The `sample-cache` method with these options.
    pub fn config(&self) -> MethodConfig {
        MethodConfig::SampleCache(self.cache.clone())
    }
}

/// Settings of the sample-cache tests: `w`×`h` per eye, 1 spp, 2 bounces,
/// specialized pipelines, the given cache settings and seed.
pub fn cache_settings(w: u32, h: u32, cache: SampleCacheSettings, seed: u32) -> CacheSetup {
    CacheSetup {
        settings: RenderSettings {
            width: w,
            height: h,
            spp: 1,
            max_bounces: 2,
            seed,
            all_features: false,
            ..Default::default()
        },
        cache,
    }
}

/// A sample cache of `st` on the session's scene (its snapshot API is not on
/// the `Method` trait).
pub fn cache_method(
    s: &Session,
    st: &CacheSetup,
) -> stereocache::methods::sample_cache::SampleCache {
    stereocache::methods::sample_cache::SampleCache::new(
        &s.ctx,
        &s.scene_gpu,
        &s.scene.environment,
        &st.settings,
        &st.cache,
    )
    .expect("sample cache")
}

/// Renders `frames` frames of a still camera (each frame's previous camera is
/// the same) with one method instance; returns the last.
pub fn render_still(
    m: &mut dyn stereocache::methods::Method,
    cam: StereoCamera,
    frames: u32,
) -> StereoFrame {
    let mut last = None;
    for f in 0..frames {
        last = Some(render_at(m, f, cam, Some(cam)));
    }
    last.expect("at least one frame")
}

/// The `stereocache` binary under coreutils' `timeout`, so a hang fails the
/// test with status 124 instead of stalling the suite; validation layer on.
pub fn cli(timeout_s: u32) -> std::process::Command {
    let mut c = std::process::Command::new("timeout");
    c.arg(timeout_s.to_string())
        .arg(env!("CARGO_BIN_EXE_stereocache"));
    c.env("STEREOCACHE_VALIDATE", "1");
    c
}

/// The one error line of a command that must fail on bad input: it did not
/// hang (timeout's 124), exited non-zero, did not panic, and wrote exactly
/// one line starting with `error` to stderr, an `error:` line (returned).
pub fn single_error_line(o: &std::process::Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_ne!(
        o.status.code(),
        Some(124),
        "{what} hung (killed by timeout)"
    );
    assert!(!o.status.success(), "{what} should fail; stderr:\n{stderr}");
    assert!(!stderr.contains("panicked"), "{what} panicked:\n{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
    assert_eq!(
        errors.len(),
        1,
        "{what}: expected one error line, got:\n{stderr}"
    );
    assert!(errors[0].starts_with("error:"), "{what}: {}", errors[0]);
    errors[0].to_string()
}

/// A file of `tests/data/bad_scenes`.
pub fn bad_scene(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/bad_scenes")
        .join(name)
}

/// One glTF-style node per instance (node i = instance i) with identity rest
/// TRS, and one animation of `channels`.
pub fn flat_animation(
    n: usize,
    channels: Vec<stereocache::scene::animation::Channel>,
) -> stereocache::scene::animation::SceneAnimation {
    let mut a = stereocache::scene::animation::SceneAnimation {
        nodes: vec![
            stereocache::scene::animation::LocalRest::Trs {
                translation: Vec3::ZERO,
                rotation: glam::Quat::IDENTITY,
                scale: Vec3::ONE,
            };
            n
        ],
        instance_paths: (0..n as u32).map(|i| vec![i]).collect(),
        instance_offsets: Vec::new(),
        animations: vec![stereocache::scene::animation::Animation {
            name: "test".into(),
            channels,
        }],
        active: Vec::new(),
    };
    a.select(&Default::default()).unwrap();
    a
}

pub fn linear(
    node: usize,
    times: Vec<f32>,
    values: Vec<glam::Vec4>,
) -> stereocache::scene::animation::Channel {
    stereocache::scene::animation::Channel::new(
        node,
        stereocache::scene::animation::TrsPath::Translation,
        stereocache::scene::animation::Interpolation::Linear,
        times,
        values,
    )
    .unwrap()
}

/// The mean of colour channel `k` over both eyes' pixels of `fr`, and its
/// standard error.
pub fn channel_mean_se(fr: &StereoFrame, k: usize) -> (f64, f64) {
    let v: Vec<f64> = fr
        .eyes
        .iter()
        .flat_map(|e| e.radiance.iter().map(move |p| p[k] as f64))
        .collect();
    mean_and_standard_error(&v)
}

/// A directional light of illuminance `e` (grey) towards `to_light` (unit),
/// a delta light for `angular_radius` 0, else a disc of that radius.
pub fn directional_light(to_light: Vec3, e: f32, angular_radius: f32) -> stereocache::scene::Light {
    stereocache::scene::Light {
        name: "sun".into(),
        kind: stereocache::scene::LightKind::Directional { angular_radius },
        radiant: Vec3::splat(e),
        position: Vec3::ZERO,
        direction: -to_light,
        range: None,
    }
}

/// A 2 m quad in y = 0 facing +Y (u along +x, v along −z; with `mirror_u`
/// u along −x), with MikkTSpace tangents: +X and w = +1, or −X and w = −1
/// mirrored (asserted).
pub fn tangent_quad(mirror_u: bool) -> stereocache::scene::Mesh {
    let mut quad = grid(
        "quad",
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::X * 2.0,
        Vec3::NEG_Z * 2.0,
        1,
        1,
        Vec2::ONE,
    );
    if mirror_u {
        for uv in &mut quad.uvs {
            uv.x = 1.0 - uv.x;
        }
    }
    stereocache::scene::mesh_ops::generate_tangents(&mut quad);
    let s = if mirror_u { -1.0 } else { 1.0 };
    let want = glam::Vec4::new(s, 0.0, 0.0, s);
    assert!(
        quad.tangents.iter().all(|t| t.abs_diff_eq(want, 1e-6)),
        "quad tangents {:?}, expected {want}",
        quad.tangents
    );
    quad
}

/// Per channel: a mean and its standard error.
pub type ChannelMeans = [(f64, f64); 3];

/// Per channel: the mean radiance over the pixels of both eyes whose first
/// hit is on material `material`, and its standard error.
pub fn material_mean(scene: &Scene, f: &StereoFrame, material: u32) -> ChannelMeans {
    std::array::from_fn(|k| {
        let v: Vec<f64> = f
            .eyes
            .iter()
            .flat_map(|e| {
                e.radiance
                    .iter()
                    .zip(&e.first_hit)
                    .filter_map(move |(r, fh)| {
                        let on = fh[3] != u32::MAX
                            && scene.meshes[scene.instances[fh[3] as usize].mesh as usize].material
                                == material;
                        on.then_some(r[k] as f64)
                    })
            })
            .collect();
        mean_and_standard_error(&v)
    })
}

/// Emission seen through next-event estimation (lights.glsl
/// `emitted_radiance`) must be what a BSDF-sampled hit sees (material_at):
/// renders `scene` with the reference, one bounce, 64 spp, by NEE alone and
/// by BSDF sampling alone, and asserts the mean over `receiver`'s pixels
/// agrees per channel within 5 combined standard errors. Returns (NEE,
/// BSDF) means.
pub fn assert_light_samplers_agree(
    s: &Session,
    receiver: u32,
    cam: StereoCamera,
    w: u32,
    h: u32,
    what: &str,
) -> (ChannelMeans, ChannelMeans) {
    assert_light_samplers_agree_at(s, receiver, cam, w, h, 1, what)
}

/// [`assert_light_samplers_agree`] with paths of up to `bounces` bounces.
pub fn assert_light_samplers_agree_at(
    s: &Session,
    receiver: u32,
    cam: StereoCamera,
    w: u32,
    h: u32,
    bounces: u32,
    what: &str,
) -> (ChannelMeans, ChannelMeans) {
    use stereocache::methods::LightSampling;
    let mean = |ls: LightSampling| {
        let settings = RenderSettings {
            width: w,
            height: h,
            spp: 64,
            max_bounces: bounces,
            seed: 9,
            all_features: false,
            light_sampling: ls,
            ..Default::default()
        };
        material_mean(&s.scene, &render(s, "reference", cam, &settings), receiver)
    };
    let (nee, bsdf) = (mean(LightSampling::Nee), mean(LightSampling::Bsdf));
    eprintln!("{what}: receiver mean by NEE {nee:?}, by BSDF sampling {bsdf:?}");
    for k in 0..3 {
        let ((a, sa), (b, sb)) = (nee[k], bsdf[k]);
        assert!(
            (a - b).abs() <= 5.0 * (sa * sa + sb * sb).sqrt(),
            "{what} channel {k}: NEE {a} ± {sa}, BSDF {b} ± {sb}"
        );
    }
    (nee, bsdf)
}

/// The two terms of [`gltf_brdf_albedo`].
pub struct GltfAlbedo {
    /// The specular term's share, E_spec.
    pub specular: [f64; 3],
    /// The diffuse term's share, E_diff.
    pub diffuse: [f64; 3],
}

impl GltfAlbedo {
    pub fn total(&self, k: usize) -> f64 {
        self.specular[k] + self.diffuse[k]
    }
}

/// Directional albedo E(μ) = ∫ f(ωo, ωi) cos θi dωi of the glTF 2.0
/// metallic-roughness BRDF, per channel, for a view at cos θo = `mu`: the
/// specification's model (Appendix B), mix(dielectric_brdf, metal_brdf,
/// metallic) with the dielectric's fresnel_mix(ior 1.5): α = roughness²,
/// F_d = 0.04 + 0.96(1 − |V·H|)⁵, F_m = base + (1 − base)(1 − |V·H|)⁵,
/// f = (1 − metallic)·(1 − F_d)·base/π + F·D(α)·G(α)/(4|N·V||N·L|) with
/// F = lerp(F_d, F_m, metallic) (Schlick is linear in f0, so this is the
/// simplified implementation's f0 = lerp(0.04, base, metallic)), D the
/// Trowbridge-Reitz distribution and G Smith's height-correlated
/// masking-shadowing. (The appendix's "simplified implementation" also puts
/// the mixed F on the diffuse, which darkens the diffuse of a 0.604 grey
/// at metallic ½ by 29 %; the model does not.) The renderer clamps α to ≥ 10⁻³
/// (`ggx_alpha`), which this does too.
///
/// Computed in f64 by midpoint quadrature, written from the specification's
/// formulas and not from the shaders: the specular term over half vectors
/// drawn by the distribution's own inverse CDF (cos²θh = (1 − u)/(1 + (α² −
/// 1)u), so the grid follows the lobe down to α = 10⁻³; the shaders sample
/// visible normals instead), E_spec = E_h[F·G·(V·H)/(μ·cos θh)] over
/// reflected directions above the surface; the diffuse term over a
/// cosine-weighted grid of directions, E_diff = (1 − metallic)·base·E[1 − F_d(V·H)].
pub fn gltf_brdf_albedo(mu: f64, base: [f64; 3], metallic: f64, roughness: f64) -> GltfAlbedo {
    use std::f64::consts::PI;
    let a = (roughness * roughness).max(1e-3);
    let a2 = a * a;
    let o = [(1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu];
    let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    let lambda = |c: f64| {
        let t2 = (1.0 - c * c).max(0.0) / (c * c);
        0.5 * ((1.0 + a2 * t2).sqrt() - 1.0)
    };
    let f0: [f64; 3] = std::array::from_fn(|k| 0.04 + (base[k] - 0.04) * metallic);
    let fresnel = |k: usize, vh: f64| f0[k] + (1.0 - f0[k]) * (1.0 - vh.abs()).powi(5);
    let dir = |cos_t: f64, phi: f64| {
        let s = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        [s * phi.cos(), s * phi.sin(), cos_t]
    };
    let n = 384;
    let mut spec = [0.0f64; 3];
    let mut diff = [0.0f64; 3];
    for i in 0..n {
        for j in 0..n {
            let (u, v) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let phi = 2.0 * PI * v;
            // Specular: h ~ D(h)·cos θh.
            let ch = ((1.0 - u) / (1.0 + (a2 - 1.0) * u)).sqrt();
            let h = dir(ch, phi);
            let oh = dot(o, h);
            if oh > 0.0 {
                let l = [
                    2.0 * oh * h[0] - o[0],
                    2.0 * oh * h[1] - o[1],
                    2.0 * oh * h[2] - o[2],
                ];
                if l[2] > 0.0 {
                    let g = 1.0 / (1.0 + lambda(mu) + lambda(l[2]));
                    for (k, s) in spec.iter_mut().enumerate() {
                        *s += fresnel(k, oh) * g * oh / (mu * ch);
                    }
                }
            }
            // Diffuse: l ~ cos θl / π.
            let l = dir(u.sqrt(), phi);
            let hv = [o[0] + l[0], o[1] + l[1], o[2] + l[2]];
            let vh = dot(o, hv) / dot(hv, hv).sqrt();
            let f_d = 0.04 + 0.96 * (1.0 - vh.abs()).powi(5);
            for d in diff.iter_mut() {
                *d += 1.0 - f_d;
            }
        }
    }
    let m = (n * n) as f64;
    GltfAlbedo {
        specular: spec.map(|s| s / m),
        diffuse: std::array::from_fn(|k| (1.0 - metallic) * base[k] * diff[k] / m),
    }
}

/// A directory under the system temporary directory, named after the
/// process and `tag`, removed with everything in it when dropped (so a
/// test run leaves nothing behind, passing or failing).
pub struct TempDir(std::path::PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> TempDir {
        let d = std::env::temp_dir().join(format!("stereocache-test-{}-{tag}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        TempDir(d)
    }
}

impl std::ops::Deref for TempDir {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A grey Lambert plane (XZ, facing +Y) of side `size` in a white environment.
pub fn grey_plane(size: f32) -> Scene {
    let mut m = Material::diffuse("grey", Vec3::splat(0.5));
    m.specular = 0.0;
    plane_in_environment(m, size, Vec3::ONE)
}

/// A head at `p` looking straight down (−Y; image +X right, −Z up).
pub fn looking_down(p: Vec3, yfov: f32) -> StereoCamera {
    let head = HeadPose::new(p, glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2));
    StereoCamera::new(head, yfov, 1.0)
}

/// The level of detail of a pixel request's meta word.
pub fn meta_level(meta: u32) -> i32 {
    stereocache::methods::hash_cache::hash::VoxelKey {
        coord: [0; 3],
        meta,
    }
    .level()
}

/// The footprint across an eye ray (unit direction `d`, hit distance `t`)
/// of the pixel it passes through, for a perspective eye looking along `fwd`
/// with vertical field of view `yfov` over `h` pixel rows: the centre
/// pixel's angular spread 2·tan(yfov/2)/h times cos²φ, φ the ray's angle to
/// the view axis (a planar image's pixel subtends cos²φ of the centre's
/// along the radius, cos φ across it; the smaller is taken).
pub fn off_axis_pixel_footprint(d: Vec3, t: f32, fwd: Vec3, yfov: f32, h: u32) -> f32 {
    let cos = d.dot(fwd);
    t * (2.0 * (0.5 * yfov).tan() / h as f32) * cos * cos
}

/// Asserts that `taa_bytes`, the memory a hash-cache-based method saves
/// without its TAA, is the TAA's per-pixel buffers for `w`×`h` per eye —
/// two colour histories (16 B each), the previous depth (4 B) and first hit
/// (16 B) per pixel of both eyes — plus a frame-parameter and a counter
/// buffer (under 4 KiB).
pub fn assert_taa_memory_share(taa_bytes: u64, w: u32, h: u32) {
    let per_pixel = 2 * (w * h) as u64 * (16 + 16 + 4 + 16);
    assert!(
        taa_bytes >= per_pixel && taa_bytes < per_pixel + 4096,
        "the TAA's share of the memory: {taa_bytes} B, its buffers {per_pixel} B + < 4 KiB"
    );
}
