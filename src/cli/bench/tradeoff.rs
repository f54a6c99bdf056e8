//! `bench tradeoff`: run time against error for every method and a sweep of
//! their settings, DIR/tradeoff.csv and DIR/report.html.

use crate::cli::args::{self, GpuArgs, SceneArgs};
use crate::cli::experiment::runner::run_comparison;
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use stereocache::output;
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

/// A thin front-end over the one comparison runner (`compare`'s and every
/// experiment's, [`run_comparison`]): this command's options become
/// compare's (parsed by compare's own parser), its configurations are
/// [`stereocache::bench::tradeoff_configs`], and the run is recorded as a
/// compare run is (summary.csv/json, viewer, report.html), plus
/// `tradeoff.csv` (summary.csv's rows) and the sweep's ratios.
pub fn run(a: TradeoffArgs) -> Result<()> {
    let TradeoffArgs {
        gpu,
        scene,
        trace,
        frames,
        size,
        bounces,
        reference_spp,
        reference_cache,
        out,
    } = a;
    let words = [
        ("--trace", trace.display().to_string()),
        ("--frames", frames.to_string()),
        ("--size", size.to_string()),
        ("--bounces", bounces.to_string()),
        ("--reference-spp", reference_spp.to_string()),
        ("--reference-cache", reference_cache.display().to_string()),
        ("--every", "0".to_string()),
        ("--out", out.display().to_string()),
    ];
    let argv: Vec<String> = words
        .into_iter()
        .flat_map(|(k, v)| [k.to_string(), v])
        .collect();
    let mut compare = crate::cli::experiment::spec::parse(&argv).map_err(anyhow::Error::msg)?;
    compare.gpu = gpu;
    compare.scene = scene;
    let settings = compare
        .method_opts
        .settings(size, compare.spp, bounces, compare.seed, false)
        .map_err(anyhow::Error::msg)?;
    let configs = stereocache::bench::tradeoff_configs(&settings);
    let cmp = run_comparison(&compare, &configs, &out, None)?;
    let summary_csv = out.join("summary.csv");
    let csv = std::fs::read(&summary_csv)
        .with_context(|| format!("{}: cannot read", summary_csv.display()))?;
    output::write_file(&out.join("tradeoff.csv"), &csv)?;
    print!("{}", stereocache::bench::tradeoff_ratios(&cmp.rows));
    println!("wrote {}", out.join("tradeoff.csv").display());
    Ok(())
}
