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
    let c = &ctx.caps;
    if a.json {
        println!("{}", serde_json::to_string_pretty(c)?);
        return report_validation(&ctx);
    }
    println!("device:              {} ({})", c.name, c.device_type);
    println!("driver:              {} {}", c.driver_name, c.driver_info);
    println!("Vulkan API:          {}", c.api_version);
    println!(
        "ray query:           {}",
        if c.ray_query {
            "yes (VK_KHR_ray_query + acceleration structures)"
        } else {
            "no (software traversal)"
        }
    );
    println!("64-bit buffer atomics: {}", c.buffer_int64_atomics);
    println!("shaderInt64:         {}", c.shader_int64);
    println!(
        "subgroup size:       {} ({})",
        c.subgroup_size,
        c.subgroup_ops.join(", ")
    );
    println!("descriptor indexing: {}", c.descriptor_indexing);
    println!(
        "timestamp period:    {} ns ({} valid bits)",
        c.timestamp_period_ns, c.timestamp_valid_bits
    );
    println!(
        "device-local memory: {:.1} GiB",
        c.device_local_bytes as f64 / (1u64 << 30) as f64
    );
    println!(
        "validation layer:    {}",
        if ctx.validation_enabled { "on" } else { "off" }
    );
    report_validation(&ctx)
}
