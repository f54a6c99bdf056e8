//! `stereocache compare`: several methods along the same frames of a trace,
//! side by side, with metrics against a reference.

use super::args::{self, CameraArgs, GpuArgs, MethodArgs, MethodList, SceneArgs};
use super::experiment::runner::run_comparison;
use anyhow::{anyhow, Result};
use clap::Args;
use std::path::PathBuf;
use stereocache::compare::Config;
use stereocache::replay::DEFAULT_FPS;
use stereocache::values::Size;

#[derive(Args)]
pub struct CompareArgs {
    #[command(flatten)]
    pub(crate) gpu: GpuArgs,
    #[command(flatten)]
    pub(crate) scene: SceneArgs,
    #[command(flatten)]
    pub(crate) camera: CameraArgs,
    /// Head-pose trace in the project's CSV format.
    #[arg(long, default_value = "captures/mmsys18-user1.csv")]
    pub(crate) trace: PathBuf,
    /// Comma-separated methods, e.g. sample-cache,reference.
    #[arg(long, default_value = "sample-cache,reference")]
    pub(crate) methods: MethodList,
    /// Render only the first K frames.
    #[arg(long, value_parser = args::frames)]
    pub(crate) frames: Option<usize>,
    #[arg(long, default_value_t = DEFAULT_FPS, value_parser = args::fps)]
    pub(crate) fps: f64,
    /// Per-method images every k-th frame (0 = none).
    #[arg(long, default_value_t = 1)]
    pub(crate) every: usize,
    /// Frames shown side by side, comma-separated (default: first, middle, last).
    #[arg(long, value_parser = show_frames)]
    pub(crate) show_frames: Option<ShownFrames>,
    /// Magnification of the centre crop in the side-by-side grids.
    #[arg(long, default_value_t = 3, value_parser = stereocache::values::int_in("--zoom", 1u32, 64, "a magnification"))]
    pub(crate) zoom: u32,
    /// Samples per pixel of the reference frames the metrics use (0 = no
    /// metrics; even: two independent halves). 128: the shipped scenes' main
    /// job then has a reference RSE below 0.1x the best method's (hairball
    /// 0.027x, Cornell box 0.091x; docs/PERFORMANCE.md has the rule).
    #[arg(long, default_value_t = 128, value_parser = args::reference_spp)]
    pub(crate) reference_spp: u32,
    /// Where reference frames are cached between runs.
    #[arg(long, default_value = "out/reference-cache")]
    pub(crate) reference_cache: PathBuf,
    /// FLIP's pixels per degree (default: one pixel's angle at the centre of
    /// the eye image, from --fov and --size; 67 is a desktop monitor at 0.7 m).
    #[arg(long, value_parser = args::flip_ppd)]
    pub(crate) flip_ppd: Option<f32>,
    /// The configuration error ratios are given against (default: naive
    /// when compared, else the first of --methods).
    #[arg(long)]
    pub(crate) baseline: Option<String>,
    #[arg(long, default_value_t = 1, value_parser = args::spp)]
    pub(crate) spp: u32,
    #[arg(long, default_value = "160x120")]
    pub(crate) size: Size,
    #[arg(long, default_value_t = 3, value_parser = args::bounces)]
    pub(crate) bounces: u32,
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u32,
    #[arg(long, default_value_t = 1.0, value_parser = args::exposure)]
    pub(crate) exposure: f32,
    #[command(flatten)]
    pub(crate) method_opts: MethodArgs,
    #[arg(long)]
    pub(crate) out: PathBuf,
}

/// `--show-frames 0,5,9`.
#[derive(Clone, Debug)]
pub struct ShownFrames(pub(crate) Vec<usize>);

fn show_frames(s: &str) -> Result<ShownFrames, String> {
    args::list_of(s, |s| {
        format!("bad --show-frames '{s}': expected frame numbers like 0,5,9")
    })
    .map(ShownFrames)
}

/// One compare run: the methods of `--methods`, each labelled by its name,
/// with the shared settings; run by the experiment runner as a one-comparison
/// experiment ([`super::experiment::runner::run_comparison`]).
pub fn run(a: CompareArgs) -> Result<()> {
    let settings = a
        .method_opts
        .settings(a.size, a.spp, a.bounces, a.seed, false)
        .map_err(|e| anyhow!(e))?;
    let configs = a
        .methods
        .0
        .iter()
        .map(|&k| {
            Ok(Config {
                label: k.name().to_string(),
                config: a.method_opts.config(k, false)?,
                settings: settings.clone(),
            })
        })
        .collect::<Result<Vec<_>, String>>()
        .map_err(|e| anyhow!(e))?;
    let out = a.out.clone();
    let baseline = a.baseline.clone();
    run_comparison(&a, &configs, &out, baseline.as_deref())?;
    Ok(())
}
