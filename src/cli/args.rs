//! Argument groups shared by the subcommands (device, scene and lighting,
//! camera, every method's options) and the typed values with their
//! parse-time range checks. A subcommand flattens the groups it needs.

use anyhow::{anyhow, Result};
use clap::Args;
use stereocache::camera::HeadPose;
use stereocache::gpu::GpuOptions;
use stereocache::materials::memo::table::Eviction;
use stereocache::materials::memo::{MemoClock, MemoFill, MemoHits, MemoSettings};
pub use stereocache::methods::MethodArgs;
use stereocache::methods::{registry, MethodKind};
use stereocache::replay::MAX_FPS;
use stereocache::rt::RtChoice;
use stereocache::scene::{AnimationSelection, DefaultLighting};
use stereocache::session::{parse_pose, CameraSelect, Session};
use stereocache::values::{float_with, int_in, named, MAX_BOUNCES, MAX_FRAMES, MAX_SPP};

/// `--spp`: samples per pixel and frame, 1..=[`MAX_SPP`].
pub fn spp(s: &str) -> Result<u32, String> {
    int_in("--spp", 1, MAX_SPP, "samples per pixel")(s)
}

/// `--bounces`: scattering events per path, 0..=[`MAX_BOUNCES`].
pub fn bounces(s: &str) -> Result<u32, String> {
    int_in("--bounces", 0, MAX_BOUNCES, "scattering events per path")(s)
}

/// `--frames`: frames to render or measure, 1..=[`MAX_FRAMES`].
pub fn frames(s: &str) -> Result<usize, String> {
    int_in("--frames", 1, MAX_FRAMES, "frames")(s)
}

/// `--fps`: the rate a trace is resampled at, in (0, [`MAX_FPS`]].
pub fn fps(s: &str) -> Result<f64, String> {
    float_with(
        "--fps",
        |v: f64| v.is_finite() && v > 0.0 && v <= MAX_FPS,
        "frames per second in (0, 10000]",
    )(s)
}

/// `--time`: the scene time (seconds) animated instances are posed at, a
/// finite number (looping animations wrap it).
pub fn time(s: &str) -> Result<f64, String> {
    float_with("--time", |v: f64| v.is_finite(), "seconds, a finite number")(s)
}

/// `--exposure`: a positive multiplier.
pub fn exposure(s: &str) -> Result<f32, String> {
    float_with(
        "--exposure",
        stereocache::values::positive_f32,
        "a positive number",
    )(s)
}

/// `--flip-ppd`: FLIP's pixels per degree, a positive number.
pub fn flip_ppd(s: &str) -> Result<f32, String> {
    float_with(
        "--flip-ppd",
        stereocache::values::positive_f32,
        "pixels per degree, a positive number",
    )(s)
}

/// `--reference-spp` of compare and `bench tradeoff`: 0 (none) or an even
/// count up to [`MAX_SPP`] (checked for evenness where it is used, with the reason).
pub fn reference_spp(s: &str) -> Result<u32, String> {
    int_in("--reference-spp", 0, MAX_SPP, "samples per pixel")(s)
}

/// `--methods a,b,...`: registry names, at least one.
#[derive(Clone, Debug)]
pub struct MethodList(pub Vec<MethodKind>);

impl std::str::FromStr for MethodList {
    type Err = String;
    fn from_str(s: &str) -> Result<MethodList, String> {
        registry::parse_list(s)
            .map(MethodList)
            .map_err(|e| e.to_string())
    }
}

/// A comma-separated list of `T` (`--show-frames 0,5,9`, `--bounces 3,0`).
pub fn list_of<T: std::str::FromStr + Clone + Send + Sync + 'static>(
    s: &str,
    bad: impl Fn(&str) -> String,
) -> Result<Vec<T>, String> {
    s.split(',')
        .map(|v| v.trim().parse::<T>().map_err(|_| bad(s)))
        .collect()
}

#[derive(Args, Clone)]
pub struct GpuArgs {
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long)]
    pub device: Option<String>,
    /// Enable the Khronos validation layer and report its messages.
    #[arg(long)]
    pub validate: bool,
    /// With --validate, also enable synchronization validation.
    #[arg(long)]
    pub sync_validation: bool,
}

impl GpuArgs {
    /// GPU options from the flags and the environment (watchdog, faults).
    pub fn options(&self) -> Result<GpuOptions> {
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

/// `--lighting`: sun-sky[:ELEV,AZIM,TURB], constant:V|R,G,B, env:PATH, directional:…, joined by '+'.
pub fn lighting(s: &str) -> Result<DefaultLighting, String> {
    named::<DefaultLighting>("--lighting")(s)
}

/// `--rt`: auto, query or software.
pub fn rt(s: &str) -> Result<RtChoice, String> {
    named::<RtChoice>("--rt")(s)
}

#[derive(Args, Clone)]
pub struct SceneArgs {
    /// Scene: built-in name (cornell, hairball, plane, cornell-moving, hairball-rotating, material-balls; cornell:alpha=A sets both spheres to GGX alpha A), a .gltf/.glb file, or a directory holding one; procedural[-uv|-heavy-uv]:[SEED:]SCENE replaces every material of SCENE by a seeded pick from the graph library (README), spin:NODE:SCENE turns SCENE's node NODE about the vertical (one turn in 4 s).
    #[arg(long, default_value = "cornell")]
    pub scene: String,
    /// Which of the scene's glTF animations play: all (looped), an index or a name.
    #[arg(long, default_value = "all")]
    pub animation: AnimationSelection,
    /// Lighting added to the scene, even one with lights of its own (whose environment it replaces): sun-sky[:ELEV,AZIM,TURB], constant:V|R,G,B, env:PATH.hdr|.exr, directional:ELEV,AZIM[,R,G,B], A+B. Default: sun-sky, only where the scene has no punctual light, environment or emitter brighter than 1 (glows ≤ 1 do not count)
    #[arg(long, value_parser = lighting)]
    pub lighting: Option<DefaultLighting>,
    /// Ray backend.
    #[arg(long, default_value = "auto", value_parser = rt)]
    pub rt: RtChoice,
    /// Memoize the scene's material-graph outputs in a texture-space cache
    /// shared by both eyes and every pass (Urbach 2023; nearest texel with
    /// centre snapping, or the tiled and bilinear variants below): off,
    /// primary, secondary or both hits.
    #[arg(long, default_value = "off")]
    pub memo: MemoHits,
    /// Entries of the memoization table (60 B each: key, stamp, write version, one 48 B record, 68 B with --memo-clock counter; with --memo-tile s, s²
    /// texel records of 48 B an entry, (s+1)² with --memo-bilinear) [default: 2^20 texels' worth: 1048576 entries,
    /// 2^20 / s² with --memo-tile s]
    #[arg(long)]
    pub memo_entries: Option<u32>,
    /// Its linear-probing window.
    #[arg(long, default_value_t = MemoSettings::default().probe)]
    pub memo_probe: u32,
    /// Its eviction policy: random, lrw (least recently written), lru, or
    /// none (a miss whose probing window is full stores nothing: the
    /// thesis's "no eviction" baseline, Table 6.2).
    #[arg(long, default_value = "lru")]
    pub memo_eviction: Eviction,
    /// Where lrw and lru take an access's time from: frame (the frame
    /// counter; entries of one frame are equally old) or counter (a 64-bit
    /// atomic counter every stamp advances: exact order, 8 B more an entry,
    /// needs shaderBufferInt64Atomics; thesis Table 6.2; not with random).
    #[arg(long, default_value = "frame")]
    pub memo_clock: MemoClock,
    /// Levels added to its level of detail (+1: texels half the size).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub memo_bias: f32,
    /// Texels per entry edge: 1 (non-tiled) or the tiled variant's s = 2, 4, 8
    /// (s×s texels an entry, nearest texel, filled whole on a miss).
    #[arg(long, default_value_t = 1)]
    pub memo_tile: u32,
    /// Bilinear lookup between the four nearest texel centres (with
    /// --memo-tile: tiles then hold (s+1)² texels, the one-texel overlap;
    /// without: four lookups of single texels).
    #[arg(long)]
    pub memo_bilinear: bool,
    /// How the tiled variants fill a missing tile: subgroup (the subgroup's
    /// lanes evaluate its texels together, thesis §5.4.3; the plain fill on
    /// devices without subgroup ballot and shuffle) or plain (the lane that
    /// missed evaluates the whole tile).
    #[arg(long, default_value = "subgroup")]
    pub memo_fill: MemoFill,
}

impl SceneArgs {
    /// Loads the scene (warnings printed), then opens the GPU and uploads it.
    pub fn open(&self, gpu: &GpuArgs) -> Result<Session> {
        let memo = self.memo_settings()?;
        let (mut scene, lit) = Session::load_scene_lit(&self.scene, self.lighting.as_ref())?;
        eprintln!("{}", lit.line());
        if self.animation != AnimationSelection::All {
            let a = scene.animation.as_mut().ok_or_else(|| {
                anyhow!("{}: --animation: the scene has no animations", self.scene)
            })?;
            a.select(&self.animation)
                .map_err(|m| anyhow!("{}: --animation: {m}", self.scene))?;
        }
        for w in &scene.warnings {
            eprintln!("warning: {w}");
        }
        if memo.enabled() && scene.graphs.is_empty() {
            eprintln!(
                "warning: {}: --memo {}: the scene has no material graphs; nothing is memoized",
                self.scene,
                self.memo_name()
            );
        }
        scene.graphs.memo = memo;
        Ok(Session::new(&gpu.options()?, scene, self.rt)?)
    }

    fn memo_name(&self) -> &'static str {
        match self.memo {
            MemoHits::Off => "off",
            MemoHits::Primary => "primary",
            MemoHits::Secondary => "secondary",
            MemoHits::Both => "both",
        }
    }

    /// The memoization settings, checked (one line naming the option).
    pub fn memo_settings(&self) -> Result<MemoSettings> {
        let s = MemoSettings {
            hits: self.memo,
            entries: self
                .memo_entries
                .unwrap_or(MemoSettings::default_entries(self.memo_tile)),
            probe: self.memo_probe,
            eviction: self.memo_eviction,
            clock: self.memo_clock,
            bias: self.memo_bias,
            tile: self.memo_tile,
            bilinear: self.memo_bilinear,
            fill: self.memo_fill,
        };
        s.validate().map_err(|e| anyhow!(e))?;
        Ok(s)
    }
}

/// `--pose px,py,pz,qx,qy,qz,qw`.
pub fn pose(s: &str) -> Result<HeadPose, String> {
    parse_pose(s)
}

/// `--fov`: degrees strictly between 1 and 179.
pub fn fov(s: &str) -> Result<f32, String> {
    float_with(
        "--fov",
        |f: f32| f > 1.0 && f < 179.0,
        "degrees between 1 and 179",
    )(s)
}

/// `--ipd`: metres in [0, 1).
pub fn ipd(s: &str) -> Result<f32, String> {
    float_with(
        "--ipd",
        |i: f32| i.is_finite() && (0.0..1.0).contains(&i),
        "metres in [0, 1)",
    )(s)
}

#[derive(Args, Clone)]
pub struct CameraArgs {
    /// A camera of the scene by name.
    #[arg(long, conflicts_with = "pose")]
    pub camera: Option<String>,
    /// Head pose in world space: px,py,pz,qx,qy,qz,qw.
    #[arg(long, value_parser = pose)]
    pub pose: Option<HeadPose>,
    /// Interpupillary distance in metres (default 0.063).
    #[arg(long, value_parser = ipd)]
    pub ipd: Option<f32>,
    /// Vertical field of view in degrees (default: the scene camera's, else 60).
    #[arg(long, value_parser = fov)]
    pub fov: Option<f32>,
}

impl CameraArgs {
    pub fn select(&self) -> CameraSelect {
        match (&self.camera, &self.pose) {
            (Some(n), _) => CameraSelect::Named(n.clone()),
            (None, Some(p)) => CameraSelect::Pose(*p),
            _ => CameraSelect::Default,
        }
    }

    pub fn fov_radians(&self) -> Option<f32> {
        self.fov.map(f32::to_radians)
    }
}
