//! `stereocache compare`: several methods along the same frames of a trace,
//! side by side, with metrics against a reference.

use super::args::{self, CameraArgs, GpuArgs, MethodArgs, MethodList, SceneArgs};
use super::common::{check_out, open_along_trace, print_reference_noise, report_validation};
use anyhow::{anyhow, bail, Result};
use clap::Args;
use std::path::PathBuf;
use stereocache::replay::DEFAULT_FPS;
use stereocache::values::Size;

#[derive(Args)]
pub struct CompareArgs {
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
    methods: MethodList,
    /// Render only the first K frames.
    #[arg(long, value_parser = args::frames)]
    frames: Option<usize>,
    #[arg(long, default_value_t = DEFAULT_FPS, value_parser = args::fps)]
    fps: f64,
    /// Per-method images every k-th frame (0 = none).
    #[arg(long, default_value_t = 1)]
    every: usize,
    /// Frames shown side by side, comma-separated (default: first, middle, last).
    #[arg(long, value_parser = show_frames)]
    show_frames: Option<ShownFrames>,
    /// Magnification of the centre crop in the side-by-side grids.
    #[arg(long, default_value_t = 3)]
    zoom: u32,
    /// Samples per pixel of the reference frames the metrics use (0 = no
    /// metrics; even: two independent halves). 128: the shipped scenes' main
    /// job then has a reference RSE below 0.1x the best method's (hairball
    /// 0.027x, Cornell box 0.091x; docs/PERFORMANCE.md has the rule).
    #[arg(long, default_value_t = 128, value_parser = args::reference_spp)]
    reference_spp: u32,
    /// Where reference frames are cached between runs.
    #[arg(long, default_value = "out/reference-cache")]
    reference_cache: PathBuf,
    #[arg(long, default_value_t = 1, value_parser = args::spp)]
    spp: u32,
    #[arg(long, default_value = "160x120")]
    size: Size,
    #[arg(long, default_value_t = 3, value_parser = args::bounces)]
    bounces: u32,
    #[arg(long, default_value_t = 1)]
    seed: u32,
    #[arg(long, default_value_t = 1.0, value_parser = args::exposure)]
    exposure: f32,
    #[command(flatten)]
    method_opts: MethodArgs,
    #[arg(long)]
    out: PathBuf,
}

/// `--show-frames 0,5,9`.
#[derive(Clone, Debug)]
pub struct ShownFrames(Vec<usize>);

fn show_frames(s: &str) -> Result<ShownFrames, String> {
    args::list_of(s, |s| {
        format!("bad --show-frames '{s}': expected frame numbers like 0,5,9")
    })
    .map(ShownFrames)
}

pub fn run(a: CompareArgs) -> Result<()> {
    let settings = a
        .method_opts
        .settings(a.size, a.spp, a.bounces, a.seed, false)
        .map_err(|e| anyhow!(e))?;
    let methods = a
        .methods
        .0
        .iter()
        .map(|&k| a.method_opts.config(k, false))
        .collect::<Result<Vec<_>, String>>()
        .map_err(|e| anyhow!(e))?;
    if a.reference_spp > 0 {
        stereocache::evaluate::check_reference_spp(a.reference_spp)?;
    }
    check_out(&a.out)?;
    let (session, cameras) =
        open_along_trace(&a.trace, a.fps, a.size, &a.scene, &a.gpu, &a.camera)?;
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
        shown_frames: a.show_frames.map(|s| s.0),
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
