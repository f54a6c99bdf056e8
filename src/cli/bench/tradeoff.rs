//! `bench tradeoff`: run time against error for every method and a sweep of
//! their settings, DIR/tradeoff.csv and DIR/report.html.

use crate::cli::args::{self, GpuArgs, SceneArgs};
use crate::cli::common::{check_out, device_line, print_reference_noise, report_validation};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::PathBuf;
use stereocache::camera::PoseTrace;
use stereocache::methods::RenderSettings;
use stereocache::output;
use stereocache::replay::{trace_cameras, DEFAULT_FPS};
use stereocache::session::CameraSelect;
use stereocache::values::Size;

#[derive(Args)]
pub struct TradeoffArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    #[command(flatten)]
    scene: SceneArgs,
    #[arg(long, default_value = "captures/mmsys18-user1.csv")]
    trace: PathBuf,
    #[arg(long, default_value_t = 16, value_parser = args::frames)]
    frames: usize,
    #[arg(long, default_value = "64x48")]
    size: Size,
    #[arg(long, default_value_t = 3, value_parser = args::bounces)]
    bounces: u32,
    /// Samples per pixel of the reference frames (even; as `compare`).
    #[arg(long, default_value_t = 128, value_parser = args::reference_spp)]
    reference_spp: u32,
    #[arg(long, default_value = "out/reference-cache")]
    reference_cache: PathBuf,
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: TradeoffArgs) -> Result<()> {
    let Size {
        width: w,
        height: h,
    } = a.size;
    let (frames, bounces, reference_spp) = (a.frames, a.bounces, a.reference_spp);
    let (trace, out) = (&a.trace, &a.out);
    stereocache::evaluate::check_reference_spp(reference_spp)?;
    check_out(out)?;
    let trace_data = PoseTrace::read_csv(trace)?;
    let session = a.scene.open(&a.gpu)?;
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
        reference_cache: a.reference_cache.clone(),
        flip_ppd: None,
        baseline: None,
    };
    let cmp = stereocache::compare::compare_configs(&session, &cameras, &configs, &base, &opts)?;
    let rows = &cmp.rows;
    let summary_csv = out.join("summary.csv");
    let csv = std::fs::read(&summary_csv)
        .with_context(|| format!("{}: cannot read", summary_csv.display()))?;
    output::write_file(&out.join("tradeoff.csv"), &csv)?;
    print!("{}", stereocache::compare::summary_table(rows));
    print!("{}", stereocache::compare::ratio_table(&cmp));
    print_reference_noise(&cmp);
    print!("{}", stereocache::bench::tradeoff_ratios(rows));
    let report = stereocache::report::write_report(out)?;
    println!(
        "wrote {} (tradeoff.csv, report: {})",
        out.display(),
        report.display()
    );
    report_validation(&session.ctx)
}
