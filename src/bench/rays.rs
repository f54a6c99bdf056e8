//! `bench rays`: primary and diffuse-bounce rays per second for each ray backend.

use crate::error::Result;
use crate::gpu::{shaders, Buffer, ComputePipeline, DescriptorSet, GpuError, Recorder};
use crate::interface::bench::{self, BenchRaysCounter};
use crate::interface::CounterSlot;
use crate::methods::{FrameInput, FrameParams};
use crate::session::Session;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
pub struct RayBench {
    pub backend: String,
    pub width: u32,
    pub height: u32,
    pub repeats: u32,
    pub primary_rays: u64,
    pub primary_ms: f64,
    pub bounce_rays: u64,
    pub bounce_ms: f64,
}

impl RayBench {
    pub fn primary_mrays_per_s(&self) -> f64 {
        self.primary_rays as f64 / (self.primary_ms * 1e3)
    }
    pub fn bounce_mrays_per_s(&self) -> f64 {
        self.bounce_rays as f64 / (self.bounce_ms * 1e3)
    }
}

/// Traces `repeats` rounds of primary + bounce rays for both eyes of `frame`;
/// the GPU time of the passes gives the rates.
pub fn bench_rays(
    session: &Session,
    frame: &FrameInput,
    width: u32,
    height: u32,
    repeats: u32,
) -> Result<RayBench> {
    let ctx = &session.ctx;
    let n = (width * height * 2) as u64;
    let fbuf = Buffer::storage(
        ctx,
        "bench.frame",
        std::mem::size_of::<FrameParams>() as u64,
    )?;
    let hits = Buffer::storage(ctx, "bench.hits", n * 16)?;
    let normals = Buffer::storage(ctx, "bench.normals", n * 16)?;
    let counters = Buffer::storage(ctx, "bench.counters", 16)?;
    let name = format!("bench/rays.{}", session.backend.shader_suffix());
    let spirv = shaders::spirv(&name)
        .ok_or_else(|| GpuError::Unsupported(format!("shader {name} missing")))?;
    let spec = session
        .scene_gpu
        .spec_constants(&session.scene.environment, 1, false);
    let pipe = ComputePipeline::with_interface(
        ctx,
        "bench.rays",
        spirv,
        std::slice::from_ref(&session.scene_gpu.layout),
        &bench::RAYS,
        Some(&bench::RAYS_PUSH),
        &spec,
    )?;
    let params = FrameParams::new(frame, width, height, 1, session.scene_gpu.origin);
    let groups = [width.div_ceil(8), height.div_ceil(8), 2];
    let bufs = [&fbuf, &hits, &normals, &counters];
    let set = &session.scene_gpu.set;
    let mut rec = Recorder::new(ctx, 5 + 2 * repeats)?;
    rec.pass("bench.params")
        .write(&fbuf)
        .update(bytemuck::bytes_of(&params));
    // One untimed round first: a CPU driver may compile (or load from its
    // disk cache) the pipeline at its first dispatch, which cost up to 5x
    // the round's time in the first run after a rebuild.
    rays_pass(&mut rec, "warmup.primary", &pipe, set, bufs, 0, groups)?;
    rays_pass(&mut rec, "warmup.bounce", &pipe, set, bufs, 1, groups)?;
    rec.pass("bench.clear").write(&counters).fill(0);
    for _ in 0..repeats {
        rays_pass(&mut rec, "primary", &pipe, set, bufs, 0, groups)?;
        rays_pass(&mut rec, "bounce", &pipe, set, bufs, 1, groups)?;
    }
    let timings = rec.finish()?;
    let c: Vec<u32> = counters.download_pod()?;
    let ms = |name: &str| {
        timings
            .iter()
            .filter(|t| t.name == name)
            .map(|t| t.ms)
            .sum::<f64>()
    };
    Ok(RayBench {
        backend: session.backend.to_string(),
        width,
        height,
        repeats,
        primary_rays: c[BenchRaysCounter::PrimaryRays.slot()] as u64,
        primary_ms: ms("primary"),
        bounce_rays: c[BenchRaysCounter::BounceRays.slot()] as u64,
        bounce_ms: ms("bounce"),
    })
}

/// Refuses a size and number of rounds whose primary rays (both eyes, one
/// per pixel a round; the bounce rays are fewer) bench/rays.comp's 32-bit
/// counters cannot count: they would wrap and report a rate near 0.
pub fn check_ray_count(width: u32, height: u32, repeats: u32) -> std::result::Result<(), String> {
    let rays = 2 * width as u64 * height as u64 * repeats as u64;
    if rays > u32::MAX as u64 {
        return Err(format!(
            "bench rays: {width}x{height} per eye for {repeats} rounds is {rays} primary rays, more than its 32-bit ray counters hold ({}); use fewer --repeats",
            u32::MAX
        ));
    }
    Ok(())
}

/// One pass of bench/rays.comp in mode 0 (primary) or 1 (bounce); `bufs`
/// in the binding order of src/interface/bench.rs (frame, hits, normals,
/// counters).
fn rays_pass<'a>(
    rec: &mut Recorder<'a>,
    name: &str,
    pipe: &'a ComputePipeline,
    scene_set: &'a DescriptorSet,
    bufs: [&'a Buffer; 4],
    mode: u32,
    groups: [u32; 3],
) -> crate::gpu::GpuResult<()> {
    rec.compute(name, pipe)
        .shared(scene_set)
        .read(bufs[0])
        .write(bufs[1])
        .write(bufs[2])
        .write(bufs[3])
        .push(&mode)
        .dispatch(groups)
}

#[cfg(test)]
mod tests {
    /// 1024×1024 for 2048 rounds traces exactly 2^32 primary rays: the
    /// counter would read 0; one round fewer fits.
    #[test]
    fn ray_counts_past_the_counters_are_refused() {
        let e = super::check_ray_count(1024, 1024, 2048).unwrap_err();
        assert!(e.contains("4294967296 primary rays"), "{e}");
        assert!(super::check_ray_count(1024, 1024, 2047).is_ok());
    }
}
