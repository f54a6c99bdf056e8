//! `stereocache info`: the chosen Vulkan device and its ray-tracing capabilities.

use super::args::GpuArgs;
use super::common::report_validation;
use anyhow::Result;
use clap::Args;
use stereocache::gpu::GpuContext;

#[derive(Args)]
pub struct InfoArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(a: InfoArgs) -> Result<()> {
    let ctx = GpuContext::new(&a.gpu.options()?)?;
    stereocache::gpu::info::print(&ctx, a.json);
    report_validation(&ctx)
}
