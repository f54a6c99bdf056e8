//! `stereocache replay`: one method along a head-pose trace, written as
//! DIR/frames/, DIR/frames.jsonl and DIR/summary.json.

use super::args::{self, CameraArgs, GpuArgs, MethodArgs, SceneArgs};
use super::common::{
    check_out, check_out_spares_inputs, open_along_trace, replay_writes, report_validation,
};
use super::render::method;
use anyhow::{anyhow, Result};
use clap::Args;
use std::path::PathBuf;
use stereocache::methods::MethodKind;
use stereocache::replay::{replay, ReplayOptions, DEFAULT_FPS};
use stereocache::values::Size;

#[derive(Args)]
pub struct ReplayArgs {
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
    #[arg(long, default_value = "reference", value_parser = method)]
    method: MethodKind,
    /// Render only the first K frames (default: the whole trace).
    #[arg(long, value_parser = args::frames)]
    frames: Option<usize>,
    /// Render rate the trace is resampled at, frames per second.
    #[arg(long, default_value_t = DEFAULT_FPS, value_parser = args::fps)]
    fps: f64,
    /// Write images every k-th frame (0 = none; frames.jsonl gets every frame).
    #[arg(long, default_value_t = 1)]
    every: usize,
    /// Samples per pixel per frame.
    #[arg(long, default_value_t = 16, value_parser = args::spp)]
    spp: u32,
    /// Image size per eye, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240")]
    size: Size,
    /// Maximum scattering events per path.
    #[arg(long, default_value_t = 3, value_parser = args::bounces)]
    bounces: u32,
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// Exposure multiplier for the PNG previews.
    #[arg(long, default_value_t = 1.0, value_parser = args::exposure)]
    exposure: f32,
    /// Also write the method's debug views as PNG.
    #[arg(long)]
    debug_views: bool,
    #[command(flatten)]
    method_opts: MethodArgs,
    #[arg(long)]
    out: PathBuf,
}

/// Arguments are checked and the trace is read before the GPU is opened, so
/// bad input fails fast and writes nothing.
pub fn run(a: ReplayArgs) -> Result<()> {
    let settings = a
        .method_opts
        .settings(a.size, a.spp, a.bounces, a.seed, a.debug_views)
        .map_err(|e| anyhow!(e))?;
    let config = a
        .method_opts
        .config(a.method, a.debug_views)
        .map_err(|e| anyhow!(e))?;
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
    check_out(&a.out)?;
    let (session, cameras) = open_along_trace(
        &a.trace, a.fps, a.frames, a.size, &a.scene, &a.gpu, &a.camera,
    )?;
    check_out_spares_inputs(&a.out, &replay_writes)?;
    opts.frame_count(cameras.len())?;
    opts.settings = config.record(&settings);
    let mut method = session.create(&config, &settings)?;
    let summary = replay(&session, method.as_mut(), &cameras, &opts)?;
    println!("{summary}");
    report_validation(&session.ctx)
}
