//! The `stereocache` command line: info, render, bench, scene, trace.

use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use stereocache::camera::{
    convert_trace, synth, AxisConvention, ColumnMap, CsvOptions, Handedness, Mmsys17Options,
    Mmsys18Options, PoseTrace, SignedAxis, SynthKind, TimeUnit, TimeWindow, TraceFormat,
};
use stereocache::gpu::{GpuContext, GpuOptions};
use stereocache::methods::{
    FrameInput, HashCacheSettings, IsrtSettings, RenderSettings, SampleCacheSettings, TaaSettings,
};
use stereocache::output;
use stereocache::replay::{replay, trace_cameras, ReplayOptions, DEFAULT_FPS};
use stereocache::rt::RtChoice;
use stereocache::scene::{generate_to_dir, DefaultLighting};
use stereocache::session::{parse_pose, parse_size, CameraSelect, Session};

#[derive(Parser)]
#[command(
    name = "stereocache",
    version,
    about = "Headless Vulkan stereo ray tracer with a screen-space sample cache for VR rendering research"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Args, Clone)]
struct GpuArgs {
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long)]
    device: Option<String>,
    /// Enable the Khronos validation layer and report its messages.
    #[arg(long)]
    validate: bool,
    /// With --validate, also enable synchronization validation.
    #[arg(long)]
    sync_validation: bool,
}

impl GpuArgs {
    /// GPU options from the flags and the environment (watchdog, faults).
    fn options(&self) -> Result<GpuOptions> {
        GpuOptions {
            validate: self.validate || std::env::var_os("STEREOCACHE_VALIDATE").is_some(),
            sync_validation: self.sync_validation,
            device: self.device.clone(),
            want_ray_query: true,
            ..Default::default()
        }
        .with_env()
        .map_err(|e| anyhow!(e))
    }
}

#[derive(Args, Clone)]
struct SceneArgs {
    /// Scene: built-in name (cornell, hairball, plane), a .gltf/.glb file, or a directory holding one.
    #[arg(long, default_value = "cornell")]
    scene: String,
    /// Lighting for scenes without lights: sun-sky[:ELEV,AZIM,TURB], constant:R,G,B, env:PATH.hdr|.exr
    #[arg(long, default_value = "sun-sky")]
    lighting: String,
    /// Ray backend.
    #[arg(long, default_value = "auto")]
    rt: String,
}

impl SceneArgs {
    fn open(&self, gpu: &GpuArgs) -> Result<Session> {
        let lighting: DefaultLighting = self
            .lighting
            .parse()
            .map_err(|e| anyhow!("bad --lighting: {e}"))?;
        let rt: RtChoice = self
            .rt
            .parse()
            .map_err(|e: String| anyhow!("bad --rt: {e}"))?;
        let scene = Session::load_scene(&self.scene, &lighting)?;
        for w in &scene.warnings {
            eprintln!("warning: {w}");
        }
        Ok(Session::new(&gpu.options()?, scene, rt)?)
    }
}

/// Options of the sample-cache method (ignored by other methods).
#[derive(Args, Clone)]
struct CacheArgs {
    /// Cache slots per pixel N (1..=16).
    #[arg(long, default_value_t = 12)]
    slots: u32,
    /// Target visible samples per pixel.
    #[arg(long, default_value_t = 4)]
    n_target: u32,
    /// Tolerance around --n-target.
    #[arg(long, default_value_t = 1)]
    delta: u32,
    /// single | multi | adaptive
    #[arg(long, default_value = "adaptive")]
    retrace: String,
    /// uniform | adaptive
    #[arg(long, default_value = "uniform")]
    shading: String,
    /// Shading invocations per pixel and frame for adaptive shading (1.0 = 100 %).
    #[arg(long, default_value_t = 1.0)]
    shading_rate: f32,
    /// one-pass | two-pass
    #[arg(long, default_value = "one-pass")]
    reproject: String,
    /// mean (running mean, appendix C α_min floor for samples with a specular lobe) | fixed:ALPHA (α floored at ALPHA for every sample, §5.2)
    #[arg(long, default_value = "mean")]
    accumulation: String,
    /// Stereo blending of the two eyes (§3.6): none | moments | neighbourhood
    #[arg(long, default_value = "none")]
    stereo_blend: String,
    /// Sharpness R of the stereo blending in [0, 1] (1 = no neighbour contributes).
    #[arg(long, default_value_t = 0.5)]
    sharpness: f32,
}

impl CacheArgs {
    fn settings(&self, debug_views: bool) -> Result<SampleCacheSettings> {
        let s = SampleCacheSettings {
            slots: self.slots,
            n_target: self.n_target,
            delta: self.delta,
            retrace: self.retrace.parse().map_err(|e: String| anyhow!(e))?,
            shading: self.shading.parse().map_err(|e: String| anyhow!(e))?,
            shading_rate: self.shading_rate,
            reproject: self.reproject.parse().map_err(|e: String| anyhow!(e))?,
            accumulation: self.accumulation.parse().map_err(|e: String| anyhow!(e))?,
            stereo_blend: self.stereo_blend.parse().map_err(|e: String| anyhow!(e))?,
            sharpness: self.sharpness,
            debug_views,
            ..Default::default()
        };
        s.validate().map_err(|e| anyhow!(e))?;
        Ok(s)
    }
}

/// Options of the taa method (ignored by other methods).
#[derive(Args, Clone)]
struct TaaArgs {
    /// Blend factor of the new frame (fixed weights), or its lower bound α_min (pfj23).
    #[arg(long, default_value_t = 0.1)]
    taa_alpha: f32,
    /// fixed (EMA with --taa-alpha) | pfj23 (per-pixel sample-count weights, see docs)
    #[arg(long, default_value = "fixed")]
    taa_weights: String,
    /// Clipping box half-width in standard deviations of the 3×3 YCoCg neighbourhood.
    #[arg(long, default_value_t = 1.0)]
    taa_gamma: f32,
}

impl TaaArgs {
    fn settings(&self) -> Result<TaaSettings> {
        let s = TaaSettings {
            alpha: self.taa_alpha,
            weights: self.taa_weights.parse().map_err(|e: String| anyhow!(e))?,
            gamma: self.taa_gamma,
            ..Default::default()
        };
        s.validate().map_err(|e| anyhow!(e))?;
        Ok(s)
    }
}

/// Options of the isrt method (ignored by other methods).
#[derive(Args, Clone)]
struct IsrtArgs {
    /// Super-resolution cells per pixel side M (2, 3 or 4).
    #[arg(long, default_value_t = 3)]
    isrt_m: u32,
}

impl IsrtArgs {
    fn settings(&self) -> Result<IsrtSettings> {
        let s = IsrtSettings {
            m: self.isrt_m,
            ..Default::default()
        };
        s.validate().map_err(|e| anyhow!(e))?;
        Ok(s)
    }
}

/// Options of the hash-cache method (ignored by other methods).
#[derive(Args, Clone)]
struct HashArgs {
    /// Hash-cache table entries (24 B each; a multiple of 16).
    #[arg(long, default_value_t = 1 << 20)]
    hash_capacity: u32,
    /// distance | distance-normal (level of detail also from the incidence angle)
    #[arg(long, default_value = "distance")]
    hash_lod: String,
    /// Store voxels in 4x4 tiles across the hit normal's major axis (GI-1.0).
    #[arg(long)]
    hash_tiles: bool,
    /// Linear-probing bound (entries, or tiles with --hash-tiles).
    #[arg(long, default_value_t = 16)]
    hash_max_probe: u32,
    /// Entries untouched for more than this many frames may be overwritten.
    #[arg(long, default_value_t = 64)]
    hash_stale_frames: u32,
    /// Voxel edge as a multiple of the pixel footprint (before power-of-two quantization).
    #[arg(long, default_value_t = 1.0)]
    hash_lod_scale: f32,
    /// Running-mean sample count cap per entry.
    #[arg(long, default_value_t = 1024)]
    hash_max_samples: u32,
    /// Turn off the TAA pass on the hash cache's output.
    #[arg(long)]
    hash_no_taa: bool,
}

impl HashArgs {
    fn settings(&self, debug_views: bool) -> Result<HashCacheSettings> {
        let s = HashCacheSettings {
            capacity: self.hash_capacity,
            max_probe: self.hash_max_probe,
            stale_frames: self.hash_stale_frames,
            lod: self.hash_lod.parse().map_err(|e: String| anyhow!(e))?,
            tiles: self.hash_tiles,
            lod_scale: self.hash_lod_scale,
            max_samples: self.hash_max_samples,
            taa: !self.hash_no_taa,
            debug_views,
        };
        s.validate().map_err(|e| anyhow!(e))?;
        Ok(s)
    }
}

/// Every method's options, flattened into the commands that create methods.
#[derive(Args, Clone)]
struct MethodArgs {
    #[command(flatten)]
    cache: CacheArgs,
    #[command(flatten)]
    taa: TaaArgs,
    #[command(flatten)]
    isrt: IsrtArgs,
    #[command(flatten)]
    hash: HashArgs,
    /// Use the plain shader builds even where the device supports subgroup
    /// operations (the sample cache's counters, lists and histogram).
    #[arg(long)]
    no_subgroup_ops: bool,
}

impl MethodArgs {
    /// The settings every method is created with (checked; one error line each).
    fn settings(
        &self,
        (width, height): (u32, u32),
        spp: u32,
        max_bounces: u32,
        seed: u32,
        debug_views: bool,
    ) -> Result<RenderSettings> {
        if spp == 0 {
            bail!("bad --spp 0: at least one sample per pixel");
        }
        Ok(RenderSettings {
            width,
            height,
            spp,
            max_bounces,
            seed,
            all_features: false,
            extra_features: Default::default(),
            all_passes: false,
            subgroup_ops: !self.no_subgroup_ops,
            cache: self.cache.settings(debug_views)?,
            taa: self.taa.settings()?,
            isrt: self.isrt.settings()?,
            hash: self.hash.settings(debug_views)?,
            light_sampling: Default::default(),
        })
    }
}

#[derive(Args, Clone)]
struct CameraArgs {
    /// A camera of the scene by name.
    #[arg(long, conflicts_with = "pose")]
    camera: Option<String>,
    /// Head pose in world space: px,py,pz,qx,qy,qz,qw.
    #[arg(long)]
    pose: Option<String>,
    /// Interpupillary distance in metres (default 0.063).
    #[arg(long)]
    ipd: Option<f32>,
    /// Vertical field of view in degrees (default: the scene camera's, else 60).
    #[arg(long)]
    fov: Option<f32>,
}

impl CameraArgs {
    fn select(&self) -> Result<CameraSelect> {
        Ok(match (&self.camera, &self.pose) {
            (Some(n), _) => CameraSelect::Named(n.clone()),
            (None, Some(p)) => CameraSelect::Pose(parse_pose(p).map_err(|e| anyhow!(e))?),
            _ => CameraSelect::Default,
        })
    }
    fn fov_radians(&self) -> Result<Option<f32>> {
        match self.fov {
            Some(f) if !(f > 1.0 && f < 179.0) => {
                bail!("bad --fov {f}: expected degrees between 1 and 179")
            }
            Some(f) => Ok(Some(f.to_radians())),
            None => Ok(None),
        }
    }
    fn ipd(&self) -> Result<Option<f32>> {
        match self.ipd {
            Some(i) if !(i.is_finite() && (0.0..1.0).contains(&i)) => {
                bail!("bad --ipd {i}: expected metres in [0, 1)")
            }
            other => Ok(other),
        }
    }
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    camera: CameraArgs,
    #[arg(long, default_value = "reference")]
    method: String,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Image size per eye, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240")]
    size: String,
    /// Maximum scattering events per path.
    #[arg(long, default_value_t = 3)]
    bounces: u32,
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// Exposure multiplier for the PNG previews.
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    #[command(flatten)]
    method_opts: MethodArgs,
    #[arg(long, default_value = "out/render")]
    out: PathBuf,
}

#[derive(Args)]
struct CompareArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    camera: CameraArgs,
    /// Head-pose trace in the project's CSV format.
    #[arg(long, default_value = "captures/mmsys18-user1.csv")]
    trace: PathBuf,
    /// Comma-separated methods, e.g. sample-cache,reference.
    #[arg(long, default_value = "sample-cache,reference")]
    methods: String,
    /// Render only the first K frames.
    #[arg(long)]
    frames: Option<usize>,
    #[arg(long, default_value_t = DEFAULT_FPS)]
    fps: f64,
    /// Per-method images every k-th frame (0 = none).
    #[arg(long, default_value_t = 1)]
    every: usize,
    /// Frames shown side by side, comma-separated (default: first, middle, last).
    #[arg(long)]
    show_frames: Option<String>,
    /// Magnification of the centre crop in the side-by-side grids.
    #[arg(long, default_value_t = 3)]
    zoom: u32,
    /// Samples per pixel of the reference frames the metrics use (0 = no
    /// metrics; even: two independent halves). 128: the shipped scenes' main
    /// job then has a reference RSE below 0.1x the best method's (hairball
    /// 0.027x, Cornell box 0.091x; docs/PERFORMANCE.md has the rule).
    #[arg(long, default_value_t = 128)]
    reference_spp: u32,
    /// Where reference frames are cached between runs.
    #[arg(long, default_value = "out/reference-cache")]
    reference_cache: PathBuf,
    #[arg(long, default_value_t = 1)]
    spp: u32,
    #[arg(long, default_value = "160x120")]
    size: String,
    #[arg(long, default_value_t = 3)]
    bounces: u32,
    #[arg(long, default_value_t = 1)]
    seed: u32,
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    #[command(flatten)]
    method_opts: MethodArgs,
    #[arg(long)]
    out: PathBuf,
}

fn run_compare(a: CompareArgs) -> Result<()> {
    let (w, h) = parse_size(&a.size).map_err(|e| anyhow!(e))?;
    if a.frames == Some(0) {
        bail!("bad --frames 0: render at least one frame");
    }
    if !(a.fps.is_finite() && a.fps > 0.0 && a.fps <= 10_000.0) {
        bail!(
            "bad --fps {}: expected frames per second in (0, 10000]",
            a.fps
        );
    }
    let methods: Vec<String> = a
        .methods
        .split(',')
        .map(|m| m.trim().to_string())
        .filter(|m| !m.is_empty())
        .collect();
    if methods.is_empty() {
        bail!("bad --methods '{}': name at least one method", a.methods);
    }
    for m in &methods {
        if !stereocache::session::METHODS.contains(&m.as_str()) {
            bail!(
                "bad --methods: unknown method '{m}' (available: {})",
                stereocache::session::METHODS.join(", ")
            );
        }
    }
    let settings = a
        .method_opts
        .settings((w, h), a.spp, a.bounces, a.seed, false)?;
    let shown = match &a.show_frames {
        None => None,
        Some(s) => Some(
            s.split(',')
                .map(|v| v.trim().parse::<usize>())
                .collect::<std::result::Result<Vec<_>, _>>()
                .map_err(|_| {
                    anyhow!("bad --show-frames '{s}': expected frame numbers like 0,5,9")
                })?,
        ),
    };
    if a.reference_spp > 0 {
        stereocache::evaluate::check_reference_spp(a.reference_spp)?;
    }
    let select = a.camera.select()?;
    let (fov, ipd) = (a.camera.fov_radians()?, a.camera.ipd()?);
    let trace = PoseTrace::read_csv(&a.trace)?;
    for w in &trace.warnings {
        eprintln!("warning: {w}");
    }
    let session = a.scene.open(&a.gpu)?;
    let cameras = trace_cameras(&session, &trace, a.fps, w, h, &select, ipd, fov)?;
    if let Some(k) = a.frames {
        if k > cameras.len() {
            bail!(
                "bad --frames {k}: {} gives only {} frames at {} fps",
                a.trace.display(),
                cameras.len(),
                a.fps
            );
        }
    }
    let opts = stereocache::compare::CompareOptions {
        methods,
        frames: a.frames,
        fps: a.fps,
        every: a.every,
        out: a.out.clone(),
        exposure: a.exposure,
        trace: a.trace.clone(),
        shown_frames: shown,
        zoom: a.zoom,
        reference_spp: (a.reference_spp > 0).then_some(a.reference_spp),
        reference_cache: a.reference_cache.clone(),
    };
    let cmp = stereocache::compare::compare(&session, &cameras, &settings, &opts)?;
    print!("{}", stereocache::compare::summary_table(&cmp.rows));
    print_reference_noise(&cmp);
    let report = stereocache::report::write_report(&a.out)?;
    println!(
        "wrote {} (summary.csv, summary.json, side-by-side/, one folder per method)",
        a.out.display()
    );
    println!("report: {}", report.display());
    report_validation(&session.ctx)
}

/// The reference's estimated error under a compare table, and the one
/// `warning:` line when it is not small against the best method's.
fn print_reference_noise(cmp: &stereocache::compare::Comparison) {
    let Some(r) = &cmp.reference else { return };
    println!(
        "reference: {} spp (two independent halves of {}), estimated RSE {:.4} ± {:.1e}, MSE {:.3e} against the converged image{}",
        r.spp,
        r.half_spp,
        r.rse,
        r.rse_stderr,
        r.mse,
        match (&r.best_method, r.ratio_to_best) {
            (Some(m), Some(x)) => format!(" ({x:.3}x the best method's RSE, {m})"),
            _ => String::new(),
        }
    );
    if let Some(w) = &r.warning {
        eprintln!("warning: {w}");
    }
}

#[derive(Subcommand)]
enum Command {
    /// Print the chosen Vulkan device and its ray-tracing capabilities.
    Info {
        #[command(flatten)]
        gpu: GpuArgs,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Render one stereo frame and write DIR/{left,right}.{exr,png} and DIR/stats.json.
    Render(Box<RenderArgs>),
    /// Render several methods along the same frames of a trace, side by side.
    Compare(Box<CompareArgs>),
    /// Write DIR/report.html from a compare output directory.
    Report {
        /// The directory `stereocache compare --out` wrote.
        dir: PathBuf,
    },
    /// Render a method along a head-pose trace: DIR/frames/, DIR/frames.jsonl, DIR/summary.json.
    Replay(Box<ReplayArgs>),
    /// Benchmarks (figures for docs/PERFORMANCE.md).
    Bench {
        #[command(subcommand)]
        which: BenchCommand,
    },
    /// Scenes the project ships.
    Scene {
        #[command(subcommand)]
        which: SceneCommand,
    },
    /// Pose traces: convert recordings, make synthetic ones.
    Trace {
        #[command(subcommand)]
        which: TraceCommand,
    },
}

#[derive(Args)]
struct ReplayArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    #[command(flatten)]
    scene: SceneArgs,
    /// The camera the trace's first pose is placed at (frame 0 is this view).
    #[command(flatten)]
    camera: CameraArgs,
    /// Head-pose trace in the project's CSV format (captures/*.csv).
    #[arg(long)]
    trace: PathBuf,
    #[arg(long, default_value = "reference")]
    method: String,
    /// Render only the first K frames (default: the whole trace).
    #[arg(long)]
    frames: Option<usize>,
    /// Render rate the trace is resampled at, frames per second.
    #[arg(long, default_value_t = DEFAULT_FPS)]
    fps: f64,
    /// Write images every k-th frame (0 = none; frames.jsonl gets every frame).
    #[arg(long, default_value_t = 1)]
    every: usize,
    /// Samples per pixel per frame.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// Image size per eye, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240")]
    size: String,
    /// Maximum scattering events per path.
    #[arg(long, default_value_t = 3)]
    bounces: u32,
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// Exposure multiplier for the PNG previews.
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// Also write the method's debug views as PNG.
    #[arg(long)]
    debug_views: bool,
    #[command(flatten)]
    method_opts: MethodArgs,
    #[arg(long)]
    out: PathBuf,
}

/// `stereocache replay`: arguments are checked and the trace is read before
/// the GPU is opened, so bad input fails fast and writes nothing.
fn run_replay(a: ReplayArgs) -> Result<()> {
    let (w, h) = parse_size(&a.size).map_err(|e| anyhow!(e))?;
    let settings = a
        .method_opts
        .settings((w, h), a.spp, a.bounces, a.seed, a.debug_views)?;
    let mut opts = ReplayOptions {
        frames: a.frames,
        fps: a.fps,
        every: a.every,
        out: a.out.clone(),
        exposure: a.exposure,
        debug_views: a.debug_views,
        trace: a.trace.clone(),
        settings: serde_json::Value::Null,
    };
    opts.validate()?;
    let select = a.camera.select()?;
    let (fov, ipd) = (a.camera.fov_radians()?, a.camera.ipd()?);
    let trace = PoseTrace::read_csv(&a.trace)?;
    for w in &trace.warnings {
        eprintln!("warning: {w}");
    }
    let session = a.scene.open(&a.gpu)?;
    let cameras = trace_cameras(&session, &trace, a.fps, w, h, &select, ipd, fov)?;
    opts.frame_count(cameras.len())?;
    opts.settings = serde_json::to_value(&settings)?;
    let mut method = session.method(&a.method, &settings)?;
    let summary = replay(&session, method.as_mut(), &cameras, &opts)?;
    println!("{summary}");
    report_validation(&session.ctx)
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Frame time per method at pixels ×1, ×2, ×4, ×8 and on hairballs of
    /// about 10k, 100k and 1M triangles, with fitted exponents.
    Scaling {
        #[command(flatten)]
        gpu: GpuArgs,
        /// Ray backend.
        #[arg(long, default_value = "software")]
        rt: String,
        #[arg(long, default_value = "captures/mmsys18-user1.csv")]
        trace: PathBuf,
        /// Frames measured per point (after one warm-up frame).
        #[arg(long, default_value_t = 6)]
        frames: usize,
        /// Base size per eye (×1 pixels).
        #[arg(long, default_value = "48x36")]
        size: String,
        #[arg(long, default_value = "sample-cache,hash-cache,taa,naive")]
        methods: String,
    },
    /// Run time against error for every method and a sweep of their settings
    /// (one run, one device): DIR/tradeoff.csv and DIR/report.html.
    Tradeoff {
        #[command(flatten)]
        gpu: GpuArgs,
        #[command(flatten)]
        scene: SceneArgs,
        #[arg(long, default_value = "captures/mmsys18-user1.csv")]
        trace: PathBuf,
        #[arg(long, default_value_t = 16)]
        frames: usize,
        #[arg(long, default_value = "64x48")]
        size: String,
        #[arg(long, default_value_t = 3)]
        bounces: u32,
        /// Samples per pixel of the reference frames (even; as `compare`).
        #[arg(long, default_value_t = 128)]
        reference_spp: u32,
        #[arg(long, default_value = "out/reference-cache")]
        reference_cache: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
    /// Sample cache against a plain scatter, per retrace mode, and against 1 spp path tracing.
    SampleCache {
        #[command(flatten)]
        gpu: GpuArgs,
        #[command(flatten)]
        scene: SceneArgs,
        #[arg(long, default_value = "captures/mmsys18-user1.csv")]
        trace: PathBuf,
        /// Frames measured (after one warm-up frame).
        #[arg(long, default_value_t = 30)]
        frames: usize,
        #[arg(long, default_value = "160x120")]
        size: String,
        #[arg(long, default_value_t = 3)]
        bounces: u32,
        /// Shading of every sample-cache row: uniform or adaptive (§3.5).
        #[arg(long, default_value = "uniform")]
        shading: String,
    },
    /// Issue 6: GPU frame time of pipelines specialized to the scene's
    /// features against the all-features build, of each unused feature's code,
    /// and of skipping passes with nothing to do; both eyes, builds interleaved.
    Specialization(BenchSpecArgs),
    /// Issue 13: MSE at equal time of the reference path tracer with light
    /// sampling of emitters and maps (MIS) against BSDF sampling alone (the
    /// integrator before NEE) and NEE alone, on a static view, interleaved.
    Lights(BenchLightsArgs),
    /// Primary and diffuse-bounce rays per second for each ray backend.
    Rays {
        #[command(flatten)]
        gpu: GpuArgs,
        #[arg(long, default_value = "hairball")]
        scene: String,
        #[arg(long, default_value = "sun-sky")]
        lighting: String,
        #[arg(long, default_value = "256x256")]
        size: String,
        /// Rounds of primary + bounce rays.
        #[arg(long, default_value_t = 4)]
        repeats: u32,
    },
}

#[derive(Subcommand)]
enum SceneCommand {
    /// Write a generated scene (cornell, hairball, plane) as glTF into DIR.
    Generate {
        name: String,
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Subcommand)]
enum TraceCommand {
    /// Convert a head-pose recording (MMSys'18, MMSys'17, OpenXR-style or any CSV) to the project's CSV format.
    Convert(ConvertArgs),
    /// Write a seeded synthetic trace.
    Synth {
        /// head-turn, walk, saccade or still.
        #[arg(long)]
        kind: String,
        #[arg(long, default_value_t = 5.0)]
        seconds: f64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        #[arg(long, default_value_t = 90.0)]
        rate: f64,
        #[arg(long)]
        out: PathBuf,
    },
}

/// Recording formats `trace convert` reads.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum InputFormat {
    /// MMSys'18 multi-viewpoint 360° logs: `timestamp viewpoint w x y z` with a header.
    Mmsys18,
    /// Corbillon et al. MMSys'17 360° logs: `t frameId [pts] w x y z`, no header.
    Mmsys17,
    /// OpenXR-style CSV: `time,position.x,...,orientation.w[,flags]`, int64 ns, glTF axes.
    Openxr,
    /// Any delimited layout: give --time-unit and --handedness (and --columns, --up, --forward).
    Csv,
}

/// Arguments of `trace convert`.
#[derive(Args)]
struct ConvertArgs {
    /// The recording.
    input: PathBuf,
    /// Output trace (the project's CSV: t,px,py,pz,qx,qy,qz,qw).
    #[arg(long)]
    out: PathBuf,
    /// Format of the recording.
    #[arg(long, value_enum, default_value_t = InputFormat::Mmsys18)]
    format: InputFormat,
    /// First second to keep, from the recording's first sample (MMSys'18: on its own clock, which starts at 0).
    #[arg(long, default_value_t = 0.0)]
    start: f64,
    /// Last second to keep, counted as --start (default: to the end).
    #[arg(long)]
    end: Option<f64>,
    /// csv: the field of each quantity, by 0-based index or header name:
    /// t=0,x=1,y=2,z=3,qx=4,qy=5,qz=6,qw=7 (without x,y,z the position comes from a head–neck model).
    /// Default: header names t|time|timestamp, x|px, y|py, z|pz, qx, qy, qz, qw.
    #[arg(long, value_name = "MAP")]
    columns: Option<ColumnMap>,
    /// csv: unit of the time column (ticks = 100 ns, .NET DateTime.Ticks as HoloLens apps log).
    #[arg(long, value_enum)]
    time_unit: Option<TimeUnit>,
    /// csv: handedness of the recording's axes (Unity/HoloLens: left; OpenXR, glTF, OpenGL: right).
    #[arg(long, value_enum)]
    handedness: Option<Handedness>,
    /// csv: the up axis, x|y|z with optional sign [default: +y].
    #[arg(long, allow_hyphen_values = true)]
    up: Option<SignedAxis>,
    /// csv: the axis the head looks along (default: -z right-handed / +z left-handed with +y up; +x with z up).
    #[arg(long, allow_hyphen_values = true)]
    forward: Option<SignedAxis>,
}

/// `stereocache trace convert`: the format's options from the arguments,
/// then import, convention check and write.
fn run_trace_convert(a: &ConvertArgs) -> Result<()> {
    if !(a.start.is_finite() && a.start >= 0.0) {
        bail!("bad --start {}: expected seconds ≥ 0", a.start);
    }
    let end = a.end.unwrap_or(f64::INFINITY);
    if end.is_nan() || end < a.start {
        bail!("bad --end {end}: expected seconds ≥ --start ({})", a.start);
    }
    let window = TimeWindow {
        start: a.start,
        end,
    };
    let csv_only = [
        ("--columns", a.columns.is_some()),
        ("--time-unit", a.time_unit.is_some()),
        ("--handedness", a.handedness.is_some()),
        ("--up", a.up.is_some()),
        ("--forward", a.forward.is_some()),
    ];
    if a.format != InputFormat::Csv {
        if let Some((flag, _)) = csv_only.iter().find(|(_, given)| *given) {
            bail!("{flag} applies to --format csv only; the other formats fix their columns, time unit and axes");
        }
    }
    let format = match a.format {
        InputFormat::Mmsys18 => TraceFormat::Mmsys18(Mmsys18Options {
            start: a.start,
            end,
            ..Default::default()
        }),
        InputFormat::Mmsys17 => TraceFormat::Mmsys17(Mmsys17Options {
            window,
            ..Default::default()
        }),
        InputFormat::Openxr => TraceFormat::OpenXr(window),
        InputFormat::Csv => {
            let Some(time_unit) = a.time_unit else {
                bail!(
                    "--format csv needs --time-unit s|ms|us|ns|ticks (the unit of the time column)"
                );
            };
            let Some(handedness) = a.handedness else {
                bail!("--format csv needs --handedness left|right (Unity/HoloLens recordings are left-handed; OpenXR and glTF right-handed)");
            };
            let up = a.up.unwrap_or(SignedAxis::PY);
            let forward = match a.forward {
                Some(f) => f,
                None => AxisConvention::default_forward(handedness, up).ok_or_else(|| {
                    anyhow!("--up {up} has no default forward axis; give --forward")
                })?,
            };
            let convention = AxisConvention::new(handedness, up, forward)
                .map_err(|e| anyhow!("bad --up/--forward: {e}"))?;
            TraceFormat::Csv(CsvOptions {
                columns: a.columns.clone(),
                window,
                ..CsvOptions::new(time_unit, convention)
            })
        }
    };
    let trace = convert_trace(&a.input, &a.out, &format)?;
    for w in &trace.warnings {
        eprintln!("warning: {w}");
    }
    let axes = match &format {
        TraceFormat::Csv(o) => format!(", axes {} → glTF", o.convention),
        _ => String::new(),
    };
    println!(
        "wrote {} ({} samples, {:.2} s{axes})",
        a.out.display(),
        trace.samples.len(),
        trace.duration()
    );
    Ok(())
}

/// The first line every benchmark prints: which device and driver measured.
fn device_line(c: &stereocache::gpu::DeviceCaps) -> String {
    format!(
        "device: {} ({}), driver {} {}",
        c.name, c.device_type, c.driver_name, c.driver_info
    )
}

fn report_validation(ctx: &GpuContext) -> Result<()> {
    let n = ctx.validation.count();
    if n > 0 {
        bail!("the Vulkan validation layer reported {n} message(s) (printed above)");
    }
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info { gpu, json } => {
            let ctx = GpuContext::new(&gpu.options()?)?;
            stereocache::gpu::info::print(&ctx, json);
            report_validation(&ctx)
        }
        Command::Compare(args) => run_compare(*args),
        Command::Report { dir } => {
            let path = stereocache::report::write_report(&dir)?;
            println!("wrote {}", path.display());
            Ok(())
        }
        Command::Render(args) => {
            let RenderArgs {
                gpu,
                scene,
                camera,
                method,
                spp,
                size,
                bounces,
                seed,
                exposure,
                method_opts,
                out,
            } = *args;
            let (w, h) = parse_size(&size).map_err(|e| anyhow!(e))?;
            let settings = method_opts.settings((w, h), spp, bounces, seed, false)?;
            if !(exposure.is_finite() && exposure > 0.0) {
                bail!("bad --exposure {exposure}: expected a positive number");
            }
            let select = camera.select()?;
            let (fov, ipd) = (camera.fov_radians()?, camera.ipd()?);
            let session = scene.open(&gpu)?;
            let cam = session.camera(&select, w, h, ipd, fov)?;
            let mut m = session.method(&method, &settings)?;
            let frame = m.render_frame(&FrameInput {
                index: 0,
                camera: cam,
                prev_camera: None,
            })?;
            std::fs::create_dir_all(&out).with_context(|| {
                format!("{}: cannot create the output directory", out.display())
            })?;
            output::write_eye(&out, "left", w, h, &frame.eyes[0], exposure)?;
            output::write_eye(&out, "right", w, h, &frame.eyes[1], exposure)?;
            let stats = serde_json::json!({
                "device": session.ctx.caps.name,
                "driver": format!("{} {}", session.ctx.caps.driver_name, session.ctx.caps.driver_info),
                "backend": session.backend,
                "scene": session.scene.source,
                "triangles": session.scene_gpu.triangle_count,
                "method": m.name(),
                "settings": settings,
                "camera": { "position": cam.world_position().to_array(), "orientation": cam.head.orientation.to_array(), "ipd": cam.ipd, "yfov_deg": cam.yfov.to_degrees() },
                "gpu_ms": frame.stats.gpu_ms(),
                "passes": frame.stats.passes,
                "rays": frame.stats.rays,
                "method_memory_bytes": m.memory_bytes(),
                "scene_memory_bytes": session.scene_gpu.bytes,
            });
            output::write_json(&out.join("stats.json"), &stats)?;
            println!(
                "rendered {} ({}x{} per eye, {} spp, {} backend) in {:.1} GPU ms on {}: {}",
                session.scene.source.display(),
                w,
                h,
                spp,
                session.backend,
                frame.stats.gpu_ms(),
                session.ctx.caps.name,
                out.display()
            );
            report_validation(&session.ctx)
        }
        Command::Replay(args) => run_replay(*args),
        Command::Bench {
            which:
                BenchCommand::Rays {
                    gpu,
                    scene,
                    lighting,
                    size,
                    repeats,
                },
        } => {
            let (w, h) = parse_size(&size).map_err(|e| anyhow!(e))?;
            let lighting: DefaultLighting = lighting
                .parse()
                .map_err(|e| anyhow!("bad --lighting: {e}"))?;
            let loaded = Session::load_scene(&scene, &lighting)?;
            let ctx = std::sync::Arc::new(GpuContext::new(&gpu.options()?)?);
            println!("{}", device_line(&ctx.caps));
            println!(
                "scene: {} ({} triangles), {}x{} per eye, both eyes, {} rounds",
                loaded.source.display(),
                loaded.instanced_triangle_count(),
                w,
                h,
                repeats
            );
            let mut results = Vec::new();
            let backends: Vec<RtChoice> = if ctx.ray_query_enabled() {
                vec![RtChoice::Software, RtChoice::Query]
            } else {
                vec![RtChoice::Software]
            };
            for rt in backends {
                let session = Session::with_context(ctx.clone(), loaded.clone(), rt)?;
                let cam = session.camera(&CameraSelect::Default, w, h, None, None)?;
                let r = stereocache::bench::bench_rays(
                    &session,
                    &FrameInput {
                        index: 0,
                        camera: cam,
                        prev_camera: None,
                    },
                    w,
                    h,
                    repeats,
                )?;
                println!(
                    "{:>9}: primary {:8.3} Mrays/s ({} rays, {:.2} ms)   diffuse bounce {:8.3} Mrays/s ({} rays, {:.2} ms)",
                    r.backend,
                    r.primary_mrays_per_s(),
                    r.primary_rays,
                    r.primary_ms,
                    r.bounce_mrays_per_s(),
                    r.bounce_rays,
                    r.bounce_ms
                );
                results.push(r);
            }
            if let [s, q] = results.as_slice() {
                println!(
                    "software / ray query time per ray: primary {:.2}x, bounce {:.2}x",
                    q.primary_mrays_per_s() / s.primary_mrays_per_s(),
                    q.bounce_mrays_per_s() / s.bounce_mrays_per_s()
                );
            } else {
                println!(
                    "(this device has no ray queries: only the software backend was measured)"
                );
            }
            report_validation(&ctx)
        }
        Command::Bench {
            which:
                BenchCommand::Scaling {
                    gpu,
                    rt,
                    trace,
                    frames,
                    size,
                    methods,
                },
        } => {
            let (w0, h0) = parse_size(&size).map_err(|e| anyhow!(e))?;
            let rt: RtChoice = rt.parse().map_err(|e: String| anyhow!("bad --rt: {e}"))?;
            let methods: Vec<String> = methods.split(',').map(|m| m.trim().to_string()).collect();
            for m in &methods {
                if !stereocache::session::METHODS.contains(&m.as_str()) {
                    bail!("bad --methods: unknown method '{m}'");
                }
            }
            if frames == 0 {
                bail!("bad --frames 0");
            }
            let trace_data = PoseTrace::read_csv(&trace)?;
            let ctx = std::sync::Arc::new(GpuContext::new(&gpu.options()?)?);
            let c = &ctx.caps;
            println!("{}", device_line(c));
            println!(
                "trace {} ({frames} frames after 1 warm-up per point, methods interleaved frame by frame), 3 bounces, both eyes",
                trace.display()
            );
            let base = |w: u32, h: u32| RenderSettings {
                width: w,
                height: h,
                spp: 1,
                max_bounces: 3,
                seed: 1,
                ..Default::default()
            };
            let cameras_for =
                |s: &Session, w: u32, h: u32| -> Result<Vec<stereocache::camera::StereoCamera>> {
                    let mut cams = trace_cameras(
                        s,
                        &trace_data,
                        DEFAULT_FPS,
                        w,
                        h,
                        &CameraSelect::Default,
                        None,
                        None,
                    )?;
                    cams.truncate(frames + 1);
                    Ok(cams)
                };
            // Pixels.
            let session = Session::with_context(
                ctx.clone(),
                stereocache::scene::generate("hairball").expect("built-in"),
                rt,
            )?;
            println!(
                "\nresolution scaling (hairball, {} backend): GPU ms per stereo frame",
                session.backend
            );
            let factors = [1.0f64, 2.0, 4.0, 8.0];
            let mut by_method: Vec<Vec<(f64, f64)>> = vec![Vec::new(); methods.len()];
            for f in factors {
                let (w, h) = (
                    (w0 as f64 * f.sqrt()).round() as u32,
                    (h0 as f64 * f.sqrt()).round() as u32,
                );
                let cams = cameras_for(&session, w, h)?;
                let mut line = format!("  {w:>4}x{h:<4} ({:>6} px/eye):", w * h);
                let times =
                    stereocache::bench::steady_frame_ms(&session, &methods, &base(w, h), &cams)?;
                for (i, (m, ms)) in methods.iter().zip(times).enumerate() {
                    by_method[i].push(((w * h) as f64, ms));
                    line.push_str(&format!("  {m} {ms:8.2}"));
                }
                println!("{line}");
            }
            print_against_naive(&methods, &by_method, "pixels per eye");
            for (i, m) in methods.iter().enumerate() {
                let logs: Vec<(f64, f64)> =
                    by_method[i].iter().map(|(p, t)| (p.ln(), t.ln())).collect();
                println!(
                    "  {m}: time ∝ pixels^{:.2} (1.0 = linear)",
                    stereocache::bench::fit_slope(&logs)
                );
            }
            drop(session);
            // Triangles.
            println!("\ntriangle scaling ({w0}x{h0} per eye): GPU ms per stereo frame");
            let mut by_method: Vec<Vec<(f64, f64)>> = vec![Vec::new(); methods.len()];
            for tubes in [21u32, 208, 2080] {
                let scene = stereocache::scene::generate::hairball::hairball_with_tubes(tubes);
                let tris = scene.instanced_triangle_count() as f64;
                let session = Session::with_context(ctx.clone(), scene, rt)?;
                let cams = cameras_for(&session, w0, h0)?;
                let mut line = format!("  {:>8} triangles:", tris as u64);
                let times =
                    stereocache::bench::steady_frame_ms(&session, &methods, &base(w0, h0), &cams)?;
                for (i, (m, ms)) in methods.iter().zip(times).enumerate() {
                    by_method[i].push((tris, ms));
                    line.push_str(&format!("  {m} {ms:8.2}"));
                }
                println!("{line}");
            }
            print_against_naive(&methods, &by_method, "triangles");
            for (i, m) in methods.iter().enumerate() {
                let logs: Vec<(f64, f64)> =
                    by_method[i].iter().map(|(n, t)| (n.ln(), t.ln())).collect();
                let lin: Vec<(f64, f64)> = by_method[i].iter().map(|(n, t)| (n.ln(), *t)).collect();
                println!(
                    "  {m}: time ∝ triangles^{:.2}; +{:.2} ms per ×e triangles (logarithmic growth shows as a small exponent)",
                    stereocache::bench::fit_slope(&logs),
                    stereocache::bench::fit_slope(&lin)
                );
            }
            report_validation(&ctx)
        }
        Command::Bench {
            which:
                BenchCommand::Tradeoff {
                    gpu,
                    scene,
                    trace,
                    frames,
                    size,
                    bounces,
                    reference_spp,
                    reference_cache,
                    out,
                },
        } => {
            let (w, h) = parse_size(&size).map_err(|e| anyhow!(e))?;
            if frames == 0 || reference_spp == 0 {
                bail!("bad --frames/--reference-spp: both must be at least 1");
            }
            stereocache::evaluate::check_reference_spp(reference_spp)?;
            let trace_data = PoseTrace::read_csv(&trace)?;
            let session = scene.open(&gpu)?;
            let cameras = trace_cameras(
                &session,
                &trace_data,
                DEFAULT_FPS,
                w,
                h,
                &CameraSelect::Default,
                None,
                None,
            )?;
            if frames > cameras.len() {
                bail!(
                    "bad --frames {frames}: {} gives {} frames",
                    trace.display(),
                    cameras.len()
                );
            }
            let c = &session.ctx.caps;
            println!("{}", device_line(c));
            println!(
                "scene: {} ({} triangles), backend {}, trace {} ({frames} frames at {DEFAULT_FPS} Hz), {w}x{h} per eye, {bounces} bounces, reference {reference_spp} spp",
                session.scene.source.display(),
                session.scene_gpu.triangle_count,
                session.backend,
                trace.display()
            );
            let base = RenderSettings {
                width: w,
                height: h,
                spp: 1,
                max_bounces: bounces,
                seed: 1,
                ..Default::default()
            };
            let configs = stereocache::bench::tradeoff_configs(&base);
            let opts = stereocache::compare::CompareOptions {
                methods: Vec::new(),
                frames: Some(frames),
                fps: DEFAULT_FPS,
                every: 0,
                out: out.clone(),
                exposure: 1.0,
                trace: trace.clone(),
                shown_frames: None,
                zoom: 3,
                reference_spp: Some(reference_spp),
                reference_cache,
            };
            let cmp =
                stereocache::compare::compare_configs(&session, &cameras, &configs, &base, &opts)?;
            let rows = &cmp.rows;
            let summary_csv = out.join("summary.csv");
            let csv = std::fs::read(&summary_csv)
                .with_context(|| format!("{}: cannot read", summary_csv.display()))?;
            output::write_file(&out.join("tradeoff.csv"), &csv)?;
            print!("{}", stereocache::compare::summary_table(rows));
            print_reference_noise(&cmp);
            print!("{}", stereocache::bench::tradeoff_ratios(rows));
            let report = stereocache::report::write_report(&out)?;
            println!(
                "wrote {} (tradeoff.csv, report: {})",
                out.display(),
                report.display()
            );
            report_validation(&session.ctx)
        }
        Command::Bench {
            which:
                BenchCommand::SampleCache {
                    gpu,
                    scene,
                    trace,
                    frames,
                    size,
                    bounces,
                    shading,
                },
        } => {
            let (w, h) = parse_size(&size).map_err(|e| anyhow!(e))?;
            let shading: stereocache::methods::sample_cache::Shading =
                shading.parse().map_err(|e: String| anyhow!(e))?;
            if frames == 0 {
                bail!("bad --frames 0: measure at least one frame");
            }
            let trace_data = PoseTrace::read_csv(&trace)?;
            let session = scene.open(&gpu)?;
            let mut cameras = trace_cameras(
                &session,
                &trace_data,
                DEFAULT_FPS,
                w,
                h,
                &CameraSelect::Default,
                None,
                None,
            )?;
            cameras.truncate(frames + 1);
            let c = &session.ctx.caps;
            println!("{}", device_line(c));
            println!(
                "scene: {} ({} triangles), backend {}, trace {} ({} frames at {} Hz after 1 warm-up), {}x{} per eye, {} bounces",
                session.scene.source.display(),
                session.scene_gpu.triangle_count,
                session.backend,
                trace.display(),
                cameras.len() - 1,
                DEFAULT_FPS,
                w,
                h,
                bounces
            );
            let base = RenderSettings {
                width: w,
                height: h,
                spp: 1,
                max_bounces: bounces,
                seed: 1,
                all_features: false,
                cache: SampleCacheSettings {
                    shading,
                    ..SampleCacheSettings::default()
                },
                ..Default::default()
            };
            let (rows, scatter) =
                stereocache::bench::bench_sample_cache(&session, &cameras, &base)?;
            println!(
                "{:<48} {:>10} {:>12} {:>10} {:>10} {:>14} {:>12}",
                "method",
                "frame ms",
                "reproject ms",
                "trace ms",
                "shade ms",
                "retrace rays",
                "rays/frame"
            );
            for r in &rows {
                println!(
                    "{:<48} {:>10.2} {:>12.2} {:>10.2} {:>10.2} {:>14.0} {:>12.0}",
                    r.label,
                    r.frame_ms,
                    r.reproject_ms,
                    r.trace_ms,
                    r.shade_ms,
                    r.retrace_rays_per_frame,
                    r.rays_per_frame
                );
            }
            println!(
                "{:<48} {:>10} {:>12.2}",
                "plain one-sample scatter", "", scatter.one_sample_ms
            );
            println!(
                "{:<48} {:>10} {:>12.2}   ({:.2} occupied slots per pixel)",
                "plain scatter of all cached slots",
                "",
                scatter.all_slots_ms,
                scatter.slots_per_pixel
            );
            let row = |l: &str| rows.iter().find(|r| r.label.contains(l)).unwrap();
            let (adaptive, multi, single, two, naive, plain) = (
                row("adaptive, one-pass)"),
                row("multi"),
                row("single"),
                row("two-pass"),
                row("1 spp"),
                row("plain builds"),
            );
            println!("ratios (same run, same device):");
            println!(
                "  one-pass reprojection / plain scatter:   {:.2}x time",
                adaptive.reproject_ms / scatter.one_sample_ms
            );
            println!(
                "  one-pass reprojection / all-slot scatter: {:.2}x time (the slot reservation, visibility and depth bounds of Listing 2 alone)",
                adaptive.reproject_ms / scatter.all_slots_ms
            );
            println!(
                "  two-pass / one-pass reprojection:        {:.2}x time",
                two.reproject_ms / adaptive.reproject_ms
            );
            println!(
                "  adaptive / multi retrace:                {:.2}x rays, {:.2}x trace time",
                adaptive.retrace_rays_per_frame / multi.retrace_rays_per_frame,
                adaptive.trace_ms / multi.trace_ms
            );
            println!(
                "  single / multi retrace:                  {:.2}x rays, {:.2}x trace time",
                single.retrace_rays_per_frame / multi.retrace_rays_per_frame,
                single.trace_ms / multi.trace_ms
            );
            let (r, se) = stereocache::bench::paired_ratio(
                &adaptive.frame_ms_per_frame,
                &naive.frame_ms_per_frame,
            );
            println!(
                "  sample-cache (adaptive) / 1 spp frame:   {r:.2}x time (± {se:.2}, standard error of the per-frame ratios; methods interleaved frame by frame)"
            );
            let (r, se) = stereocache::bench::paired_ratio(
                &adaptive.frame_ms_per_frame,
                &plain.frame_ms_per_frame,
            );
            let subgroup = session.ctx.caps.has_subgroup_ops(&["arithmetic", "ballot"]);
            println!(
                "  subgroup-op / plain shader builds:       {r:.2}x frame (± {se:.2}), {:.2}x reproject, {:.2}x shade{}",
                adaptive.reproject_ms / plain.reproject_ms,
                adaptive.shade_ms / plain.shade_ms,
                if subgroup { "" } else { " (this device has no subgroup arithmetic/ballot: both are the plain builds)" }
            );
            report_validation(&session.ctx)
        }
        Command::Bench {
            which: BenchCommand::Specialization(args),
        } => run_bench_specialization(args),
        Command::Bench {
            which: BenchCommand::Lights(args),
        } => run_bench_lights(args),
        Command::Scene {
            which: SceneCommand::Generate { name, out },
        } => {
            let path = generate_to_dir(&name, &out)?;
            println!("wrote {}", path.display());
            Ok(())
        }
        Command::Trace { which } => match which {
            TraceCommand::Convert(a) => run_trace_convert(&a),
            TraceCommand::Synth {
                kind,
                seconds,
                seed,
                rate,
                out,
            } => {
                let kind: SynthKind = kind.parse().map_err(|e| anyhow!("bad --kind: {e}"))?;
                if !(seconds.is_finite() && seconds > 0.0 && seconds <= 3600.0) {
                    bail!("bad --seconds {seconds}: expected a duration in (0, 3600]");
                }
                if !(rate.is_finite() && (1.0..=10000.0).contains(&rate)) {
                    bail!("bad --rate {rate}: expected Hz in [1, 10000]");
                }
                let trace = synth(kind, seconds, seed, rate);
                trace.write_csv(&out)?;
                println!("wrote {} ({} samples)", out.display(), trace.samples.len());
                Ok(())
            }
        },
    }
}

/// `bench scaling`: every method's frame time over naive's at each point
/// (same run, same device), when naive was measured.
fn print_against_naive(methods: &[String], by_method: &[Vec<(f64, f64)>], x: &str) {
    let Some(n) = methods.iter().position(|m| m == "naive") else {
        return;
    };
    for (i, m) in methods.iter().enumerate() {
        if i == n {
            continue;
        }
        let r: Vec<String> = by_method[i]
            .iter()
            .zip(&by_method[n])
            .map(|((_, t), (_, tn))| format!("{:.2}x", t / tn))
            .collect();
        println!("  {m} / naive by {x}: {}", r.join(", "));
    }
}

/// The error and its causes on one line. A cause whose text the message
/// already contains (library errors that print their source) is not repeated.
fn error_line(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !msg.contains(&c) {
            msg.push_str(": ");
            msg.push_str(&c);
        }
    }
    msg.replace('\n', " ")
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = error_line(&e);
            eprintln!("error: {msg}");
            ExitCode::FAILURE
        }
    }
}

/// Arguments of `bench specialization`.
#[derive(Args)]
struct BenchSpecArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    /// Scenes, comma-separated: built-in names, .gltf/.glb files or directories.
    #[arg(long, default_value = "cornell,hairball,plane")]
    scenes: String,
    /// Lighting for scenes without lights (see `render --lighting`).
    #[arg(long, default_value = "sun-sky")]
    lighting: String,
    /// Ray backend.
    #[arg(long, default_value = "auto")]
    rt: String,
    #[arg(long, default_value = "naive,sample-cache,hash-cache")]
    methods: String,
    /// Bounce counts, comma-separated (single-feature builds at the largest).
    #[arg(long, default_value = "3,0")]
    bounces: String,
    #[arg(long, default_value = "captures/mmsys18-user1.csv")]
    trace: PathBuf,
    /// Frames measured per build (after one warm-up frame).
    #[arg(long, default_value_t = 8)]
    frames: usize,
    #[arg(long, default_value = "64x48")]
    size: String,
    /// Also write the table as CSV to this file.
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(Args)]
struct BenchLightsArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    /// Scenes, comma-separated: built-in names, .gltf/.glb files or directories.
    #[arg(long, default_value = "cornell,plane")]
    scenes: String,
    /// Lighting for scenes without lights (see `render --lighting`).
    #[arg(long, default_value = "sun-sky")]
    lighting: String,
    /// Ray backend.
    #[arg(long, default_value = "auto")]
    rt: String,
    /// Strategies, comma-separated (the first is the equal-time baseline): bsdf, mis, nee.
    #[arg(long, default_value = "bsdf,mis,nee")]
    strategies: String,
    #[arg(long, default_value = "64x64")]
    size: String,
    /// Samples per pixel of each measured frame.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// Samples per pixel of the reference image (MIS, its own seed).
    #[arg(long, default_value_t = 2048)]
    reference_spp: u32,
    #[arg(long, default_value_t = 3)]
    bounces: u32,
    /// Frames measured per strategy (after one warm-up frame).
    #[arg(long, default_value_t = 8)]
    frames: usize,
}

fn run_bench_lights(a: BenchLightsArgs) -> Result<()> {
    use stereocache::methods::LightSampling;
    let (w, h) = parse_size(&a.size).map_err(|e| anyhow!(e))?;
    if a.frames == 0 || a.spp == 0 || a.reference_spp == 0 {
        bail!("bad --frames/--spp/--reference-spp: each must be at least 1");
    }
    let rt: RtChoice = a.rt.parse().map_err(|e: String| anyhow!("bad --rt: {e}"))?;
    let lighting: DefaultLighting = a
        .lighting
        .parse()
        .map_err(|e| anyhow!("bad --lighting: {e}"))?;
    let mut strategies = Vec::new();
    for s in a.strategies.split(',').map(str::trim) {
        strategies.push(match s {
            "mis" => LightSampling::Mis,
            "nee" => LightSampling::Nee,
            "bsdf" => LightSampling::Bsdf,
            _ => bail!("bad --strategies: unknown strategy '{s}' (expected bsdf, mis or nee)"),
        });
    }
    let scenes = load_labelled_scenes(&a.scenes, &lighting)?;
    let ctx = std::sync::Arc::new(GpuContext::new(&a.gpu.options()?)?);
    println!("{}", device_line(&ctx.caps));
    println!(
        "{w}x{h} per eye, both eyes, {} spp, bounces {}, reference {} spp (MIS), {} frames per strategy after 1 warm-up, interleaved frame by frame",
        a.spp, a.bounces, a.reference_spp, a.frames
    );
    let base = RenderSettings {
        width: w,
        height: h,
        spp: a.spp,
        max_bounces: a.bounces,
        seed: 1,
        ..Default::default()
    };
    let mut rows = Vec::new();
    for (label, scene) in scenes {
        let session = Session::with_context(ctx.clone(), scene, rt)?;
        let camera = session.camera(&CameraSelect::Default, w, h, None, None)?;
        println!(
            "scene {label}: backend {}, emissive triangles {}, environment {}",
            session.backend,
            session.scene_gpu.features.emissive_triangles,
            session
                .scene
                .environment
                .as_ref()
                .map(environment_kind)
                .unwrap_or("none")
        );
        rows.extend(stereocache::bench::bench_lights(
            &session,
            &label,
            camera,
            &base,
            &strategies,
            a.reference_spp,
            a.frames,
        )?);
    }
    print!("{}", stereocache::bench::light_table(&rows));
    report_validation(&ctx)
}

/// `stereocache bench specialization`: every argument is checked and every
/// scene loaded before the GPU is opened, so bad input fails fast.
fn run_bench_specialization(a: BenchSpecArgs) -> Result<()> {
    let (w, h) = parse_size(&a.size).map_err(|e| anyhow!(e))?;
    if a.frames == 0 {
        bail!("bad --frames 0: measure at least one frame");
    }
    let rt: RtChoice = a.rt.parse().map_err(|e: String| anyhow!("bad --rt: {e}"))?;
    let lighting: DefaultLighting = a
        .lighting
        .parse()
        .map_err(|e| anyhow!("bad --lighting: {e}"))?;
    let methods: Vec<String> = a.methods.split(',').map(|m| m.trim().to_string()).collect();
    for m in &methods {
        if !stereocache::session::METHODS.contains(&m.as_str()) {
            bail!("bad --methods: unknown method '{m}'");
        }
    }
    let mut bounces = Vec::new();
    for b in a.bounces.split(',') {
        match b.trim().parse::<u32>() {
            Ok(n) if n <= 64 => bounces.push(n),
            _ => bail!(
                "bad --bounces '{}': expected comma-separated counts in 0..=64",
                a.bounces
            ),
        }
    }
    let trace = PoseTrace::read_csv(&a.trace)?;
    let scenes = load_labelled_scenes(&a.scenes, &lighting)?;
    let ctx = std::sync::Arc::new(GpuContext::new(&a.gpu.options()?)?);
    println!("{}", device_line(&ctx.caps));
    println!(
        "{w}x{h} per eye, both eyes, 1 spp, bounces {}, trace {} ({} frames at {DEFAULT_FPS} Hz after 1 warm-up), builds interleaved frame by frame",
        a.bounces,
        a.trace.display(),
        a.frames
    );
    let base = RenderSettings {
        width: w,
        height: h,
        spp: 1,
        seed: 1,
        ..Default::default()
    };
    let mut rows = Vec::new();
    for (label, scene) in scenes {
        let triangles = scene.instanced_triangle_count();
        let session = Session::with_context(ctx.clone(), scene, rt)?;
        let f = session.scene_gpu.features;
        let flags = |on: bool| -> Vec<String> {
            let mut v: Vec<String> = stereocache::bench::FEATURE_FLAGS
                .iter()
                .filter(|n| stereocache::bench::has_feature(&f, n) == on)
                .map(|n| n.to_string())
                .collect();
            if on {
                v.push(format!(
                    "environment: {}",
                    session
                        .scene
                        .environment
                        .as_ref()
                        .map(environment_kind)
                        .unwrap_or("none")
                ));
            }
            v
        };
        println!(
            "\nscene {label} ({triangles} triangles, backend {}): uses {}; lacks {}",
            session.backend,
            flags(true).join(", "),
            flags(false).join(", ")
        );
        let mut cameras = trace_cameras(
            &session,
            &trace,
            DEFAULT_FPS,
            w,
            h,
            &CameraSelect::Default,
            None,
            None,
        )?;
        if cameras.len() < a.frames + 1 {
            bail!(
                "bad --frames {}: {} gives {} frames",
                a.frames,
                a.trace.display(),
                cameras.len()
            );
        }
        cameras.truncate(a.frames + 1);
        let r = stereocache::bench::bench_specialization(
            &session, &label, &methods, &bounces, &cameras, &base,
        )?;
        print!("{}", stereocache::bench::spec_table(&r));
        rows.extend(r);
    }
    println!("\nall scenes:");
    print!("{}", stereocache::bench::spec_table(&rows));
    if let Some(out) = &a.out {
        let csv = stereocache::bench::spec_csv(&rows);
        output::write_text(out, &csv)?;
        println!("wrote {}", out.display());
    }
    report_validation(&ctx)
}

/// The environment's kind in words.
fn environment_kind(e: &stereocache::scene::Environment) -> &'static str {
    use stereocache::scene::Environment;
    match e {
        Environment::Constant(_) => "constant",
        Environment::Sky { .. } => "sky",
        Environment::Map { .. } => "map",
    }
}

/// The scenes of a comma-separated `--scenes` list, each labelled by its file
/// stem (or its name), their warnings printed.
fn load_labelled_scenes(
    list: &str,
    lighting: &DefaultLighting,
) -> Result<Vec<(String, stereocache::scene::Scene)>> {
    let mut scenes = Vec::new();
    for spec in list.split(',').map(str::trim) {
        let scene = Session::load_scene(spec, lighting)?;
        for warning in &scene.warnings {
            eprintln!("warning: {warning}");
        }
        let label = std::path::Path::new(spec)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| spec.to_string());
        scenes.push((label, scene));
    }
    Ok(scenes)
}
