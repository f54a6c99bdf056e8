//! `bench sample-cache`: the sample cache per retrace mode and reprojection
//! variant, against a plain scatter and 1 spp path tracing, on one trace.

use crate::cli::args::{self, GpuArgs, SceneArgs};
use crate::cli::common::{device_line, report_validation};
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use stereocache::bench::{CacheBenchRow, ScatterBaselines};
use stereocache::camera::PoseTrace;
use stereocache::methods::sample_cache::Shading;
use stereocache::methods::{RenderSettings, SampleCacheSettings};
use stereocache::replay::{trace_cameras, DEFAULT_FPS};
use stereocache::session::CameraSelect;
use stereocache::values::Size;

#[derive(Args)]
pub struct SampleCacheBenchArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    #[command(flatten)]
    scene: SceneArgs,
    #[arg(long, default_value = "captures/mmsys18-user1.csv")]
    trace: PathBuf,
    /// Frames measured (after one warm-up frame).
    #[arg(long, default_value_t = 30, value_parser = args::frames)]
    frames: usize,
    #[arg(long, default_value = "160x120")]
    size: Size,
    #[arg(long, default_value_t = 3, value_parser = args::bounces)]
    bounces: u32,
    /// Shading of every sample-cache row: uniform or adaptive (§3.5).
    #[arg(long, default_value = "uniform")]
    shading: Shading,
}

pub fn run(a: SampleCacheBenchArgs) -> Result<()> {
    let SampleCacheBenchArgs {
        gpu,
        scene,
        trace,
        frames,
        size,
        bounces,
        shading,
    } = a;
    if shading == Shading::Skip {
        bail!("bad --shading skip: this bench times the shading pass; use uniform or adaptive");
    }
    let Size {
        width: w,
        height: h,
    } = size;
    let trace_data = PoseTrace::read_csv(&trace)?;
    stereocache::replay::check_bench_frames(&trace_data, DEFAULT_FPS, frames, 1)?;
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
        Some(frames + 1),
    )?;
    stereocache::bench::check_frame_poses(&session, cameras.len(), DEFAULT_FPS)?;
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
        ..Default::default()
    };
    let cache = SampleCacheSettings {
        shading,
        ..SampleCacheSettings::default()
    };
    let (rows, scatter) =
        stereocache::bench::bench_sample_cache(&session, &cameras, DEFAULT_FPS, &base, &cache)?;
    print_table(&rows, &scatter);
    print_ratios(
        &rows,
        &scatter,
        session.ctx.caps.has_subgroup_ops(&["arithmetic", "ballot"]),
    );
    report_validation(&session.ctx)
}

/// One line per configuration and the two scatter baselines.
fn print_table(rows: &[CacheBenchRow], scatter: &ScatterBaselines) {
    println!(
        "{:<48} {:>10} {:>12} {:>10} {:>10} {:>14} {:>12}",
        "method", "frame ms", "reproject ms", "trace ms", "shade ms", "retrace rays", "rays/frame"
    );
    for r in rows {
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
        "plain scatter of all cached slots", "", scatter.all_slots_ms, scatter.slots_per_pixel
    );
}

/// The ratios the docs quote (same run, same device); `subgroup`: whether the
/// device has the subgroup operations the default builds use.
fn print_ratios(rows: &[CacheBenchRow], scatter: &ScatterBaselines, subgroup: bool) {
    let row = |l: &str| rows.iter().find(|r| r.label.contains(l)).unwrap();
    let (adaptive, multi, single, two, naive, plain) = (
        row("adaptive, one-pass)"),
        row("multi"),
        row("single"),
        row("two-pass"),
        row("1 spp"),
        row("plain builds"),
    );
    println!("ratios (same run, same device; the scatters are timed after the interleaved frames, not interleaved with them):");
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
    let (r, se) =
        stereocache::bench::paired_ratio(&adaptive.frame_ms_per_frame, &naive.frame_ms_per_frame);
    println!(
        "  sample-cache (adaptive) / 1 spp frame:   {r:.2}x time (± {se:.2}, standard error of the ratio of the means; methods interleaved frame by frame)"
    );
    let (r, se) =
        stereocache::bench::paired_ratio(&adaptive.frame_ms_per_frame, &plain.frame_ms_per_frame);
    println!(
        "  subgroup-op / plain shader builds:       {r:.2}x frame (± {se:.2}), {:.2}x reproject, {:.2}x shade{}",
        adaptive.reproject_ms / plain.reproject_ms,
        adaptive.shade_ms / plain.shade_ms,
        if subgroup { "" } else { " (this device has no subgroup arithmetic/ballot: both are the plain builds)" }
    );
}
