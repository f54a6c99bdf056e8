//! `reference`: the ground-truth path tracer. Both eyes, N samples per pixel
//! (in dispatches of at most 16 so no single dispatch runs long), up to B
//! bounces, pixel-centre first hits in the Listing 1 encoding.

use super::{
    EyeImage, FrameInput, FrameParams, FrameStats, Method, RayCounts, RenderSettings, StereoFrame,
};
use crate::gpu::{
    shaders, Buffer, ComputePipeline, DescriptorLayout, DescriptorSet, GpuContext, GpuError,
    GpuResult, Recorder, Resource,
};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

const LOCAL: u32 = 8;
/// Samples per dispatch.
const CHUNK: u32 = 16;

pub struct Reference {
    ctx: Arc<GpuContext>,
    scene: Arc<SceneGpu>,
    settings: RenderSettings,
    primary: ComputePipeline,
    trace: ComputePipeline,
    set: DescriptorSet,
    frame: Buffer,
    accum: Buffer,
    first_hit: Buffer,
    depth: Buffer,
    albedo: Buffer,
    counters: Buffer,
}

/// Loads a compiled shader of the scene's backend or says which is missing.
pub(crate) fn backend_shader(name: &str, scene: &SceneGpu) -> GpuResult<&'static [u8]> {
    let full = format!("{name}.{}", scene.backend.shader_suffix());
    shaders::spirv(&full)
        .ok_or_else(|| GpuError::Unsupported(format!("shader {full} was not compiled")))
}

impl Reference {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
    ) -> GpuResult<Self> {
        let n = (settings.width * settings.height * 2) as u64;
        let frame = Buffer::storage(
            ctx,
            "reference.frame",
            std::mem::size_of::<FrameParams>() as u64,
        )?;
        let accum = Buffer::storage(ctx, "reference.accum", n * 16)?;
        let first_hit = Buffer::storage(ctx, "reference.first_hit", n * 16)?;
        let depth = Buffer::storage(ctx, "reference.depth", n * 4)?;
        let albedo = Buffer::storage(ctx, "reference.albedo", n * 16)?;
        let counters = Buffer::storage(ctx, "reference.counters", 16)?;
        let layout = DescriptorLayout::buffers(ctx, 6)?;
        let set = DescriptorSet::new(
            ctx,
            &layout,
            &[
                Resource::Buffer(&frame),
                Resource::Buffer(&accum),
                Resource::Buffer(&first_hit),
                Resource::Buffer(&depth),
                Resource::Buffer(&albedo),
                Resource::Buffer(&counters),
            ],
        )?;
        let spec = scene.spec_constants(env, settings.max_bounces, settings.all_features);
        let layouts = [scene.layout.clone(), layout];
        let primary = ComputePipeline::new(
            ctx,
            "reference.primary",
            backend_shader("reference/primary", scene)?,
            &layouts,
            0,
            &spec,
        )?;
        let trace = ComputePipeline::new(
            ctx,
            "reference.trace",
            backend_shader("reference/trace", scene)?,
            &layouts,
            8,
            &spec,
        )?;
        Ok(Reference {
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            primary,
            trace,
            set,
            frame,
            accum,
            first_hit,
            depth,
            albedo,
            counters,
        })
    }
}

impl Method for Reference {
    fn name(&self) -> &'static str {
        "reference"
    }

    fn render_frame(&mut self, input: &FrameInput) -> GpuResult<StereoFrame> {
        let (w, h) = (self.settings.width, self.settings.height);
        let spp = self.settings.spp.max(1);
        let chunks = spp.div_ceil(CHUNK);
        let params = FrameParams::new(input, w, h, self.settings.seed);
        let groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let mut rec = Recorder::new(&self.ctx, 5 + chunks)?;
        rec.pass("reference.params")
            .write(&self.frame)
            .update(bytemuck::bytes_of(&params));
        rec.pass("reference.clear")
            .write(&self.accum)
            .write(&self.counters)
            .fill(0);
        let sets = [&self.scene.set, &self.set];
        rec.pass("reference.primary")
            .read(&self.frame)
            .write(&self.first_hit)
            .write(&self.depth)
            .write(&self.albedo)
            .write(&self.counters)
            .dispatch(&self.primary, &sets, &[], groups);
        for c in 0..chunks {
            let base = c * CHUNK;
            let count = CHUNK.min(spp - base);
            let push: Vec<u8> = [base, count].iter().flat_map(|v| v.to_le_bytes()).collect();
            rec.pass("reference.trace")
                .read(&self.frame)
                .write(&self.accum)
                .write(&self.counters)
                .dispatch(&self.trace, &sets, &push, groups);
        }
        let passes = rec.finish()?;
        let accum: Vec<[f32; 4]> = self.accum.download_pod()?;
        let first_hit: Vec<[u32; 4]> = self.first_hit.download_pod()?;
        let depth: Vec<f32> = self.depth.download_pod()?;
        let albedo: Vec<[f32; 4]> = self.albedo.download_pod()?;
        let counters: Vec<u32> = self.counters.download_pod()?;
        let npix = (w * h) as usize;
        let eye = |e: usize| EyeImage {
            radiance: accum[e * npix..(e + 1) * npix]
                .iter()
                .map(|a| {
                    if a[3] > 0.0 {
                        [a[0] / a[3], a[1] / a[3], a[2] / a[3], 1.0]
                    } else {
                        [0.0; 4]
                    }
                })
                .collect(),
            depth: depth[e * npix..(e + 1) * npix].to_vec(),
            first_hit: first_hit[e * npix..(e + 1) * npix].to_vec(),
            albedo: albedo[e * npix..(e + 1) * npix].to_vec(),
            debug: Vec::new(),
        };
        Ok(StereoFrame {
            width: w,
            height: h,
            eyes: [eye(0), eye(1)],
            stats: FrameStats {
                passes,
                rays: RayCounts {
                    primary: counters[0] as u64,
                    bounce: counters[1] as u64,
                    shadow: counters[2] as u64,
                },
                counters: Default::default(),
            },
        })
    }

    fn memory_bytes(&self) -> u64 {
        [
            &self.frame,
            &self.accum,
            &self.first_hit,
            &self.depth,
            &self.albedo,
            &self.counters,
        ]
        .iter()
        .map(|b| b.size)
        .sum()
    }
}
