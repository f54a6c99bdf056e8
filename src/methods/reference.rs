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
    name: &'static str,
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
        Self::with_name("reference", ctx, scene, env, settings)
    }

    /// The same path tracer under another method name (`naive`, `supersample`,
    /// the colour source of `taa`): see `super::baseline`.
    pub fn with_name(
        name: &'static str,
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
        let spec = settings.spec_constants(scene, env);
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
            24,
            &spec,
        )?;
        Ok(Reference {
            name,
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

/// The per-pixel buffers a `Reference` frame leaves on the GPU, `[eye][pixel]`.
pub struct ReferenceOutputs<'a> {
    /// rgb = sum of the frame's samples, w = their count (radiance itself at 1 spp).
    pub accum: &'a Buffer,
    /// View depth of the pixel-centre first hit, 0 = miss.
    pub depth: &'a Buffer,
    /// Pixel-centre first hits (Listing 1).
    pub first_hit: &'a Buffer,
    pub albedo: &'a Buffer,
}

impl Reference {
    /// Passes `record` adds to a recorder.
    pub fn pass_count(&self) -> u32 {
        3 + self.settings.spp.max(1).div_ceil(CHUNK)
    }

    /// The buffers `record` fills.
    pub fn outputs(&self) -> ReferenceOutputs<'_> {
        ReferenceOutputs {
            accum: &self.accum,
            depth: &self.depth,
            first_hit: &self.first_hit,
            albedo: &self.albedo,
        }
    }

    /// Records one frame (params, clear, primary, trace) into `rec`. With
    /// `jitter = Some(j)` every sample goes through sub-pixel position `j`
    /// (in [0, 1)²) instead of a random one per sample.
    pub fn record(&self, rec: &mut Recorder, input: &FrameInput, jitter: Option<[f32; 2]>) {
        let (w, h) = (self.settings.width, self.settings.height);
        let spp = self.settings.spp.max(1);
        let chunks = spp.div_ceil(CHUNK);
        let params = FrameParams::new(input, w, h, self.settings.seed, self.scene.origin);
        let groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let p = self.name;
        rec.pass(&format!("{p}.params"))
            .write(&self.frame)
            .update(bytemuck::bytes_of(&params));
        rec.pass(&format!("{p}.clear"))
            .write(&self.accum)
            .write(&self.counters)
            .fill(0);
        let sets = [&self.scene.set, &self.set];
        rec.pass(&format!("{p}.primary"))
            .read(&self.frame)
            .write(&self.first_hit)
            .write(&self.depth)
            .write(&self.albedo)
            .write(&self.counters)
            .dispatch(&self.primary, &sets, &[], groups);
        let (fixed, j) = match jitter {
            Some(j) => (1u32, j),
            None => (0, [0.0; 2]),
        };
        for c in 0..chunks {
            let base = c * CHUNK;
            let count = CHUNK.min(spp - base);
            let mut push: Vec<u8> = [base, count, fixed, 0]
                .iter()
                .flat_map(|v| v.to_le_bytes())
                .collect();
            push.extend(j.iter().flat_map(|v| v.to_le_bytes()));
            rec.pass(&format!("{p}.trace"))
                .read(&self.frame)
                .write(&self.accum)
                .write(&self.counters)
                .dispatch(&self.trace, &sets, &push, groups);
        }
    }

    /// Ray counts of the last recorded frame.
    pub fn ray_counts(&self) -> GpuResult<RayCounts> {
        let counters: Vec<u32> = self.counters.download_pod()?;
        Ok(RayCounts {
            primary: counters[0] as u64,
            bounce: counters[1] as u64,
            shadow: counters[2] as u64,
        })
    }

    /// Reads the last frame back; `radiance` overrides the accumulated mean
    /// (`[eye][pixel]`, e.g. a TAA resolve of it).
    pub fn read_frame(
        &self,
        passes: Vec<crate::gpu::PassTiming>,
        radiance: Option<Vec<[f32; 4]>>,
    ) -> GpuResult<StereoFrame> {
        let (w, h) = (self.settings.width, self.settings.height);
        let radiance = match radiance {
            Some(r) => r,
            None => {
                let accum: Vec<[f32; 4]> = self.accum.download_pod()?;
                accum
                    .iter()
                    .map(|a| {
                        if a[3] > 0.0 {
                            [a[0] / a[3], a[1] / a[3], a[2] / a[3], 1.0]
                        } else {
                            [0.0; 4]
                        }
                    })
                    .collect()
            }
        };
        let first_hit: Vec<[u32; 4]> = self.first_hit.download_pod()?;
        let depth: Vec<f32> = self.depth.download_pod()?;
        let albedo: Vec<[f32; 4]> = self.albedo.download_pod()?;
        let npix = (w * h) as usize;
        let eye = |e: usize| EyeImage {
            radiance: radiance[e * npix..(e + 1) * npix].to_vec(),
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
                rays: self.ray_counts()?,
                counters: Default::default(),
            },
        })
    }
}

impl Method for Reference {
    fn name(&self) -> &'static str {
        self.name
    }

    fn render_frame(&mut self, input: &FrameInput) -> GpuResult<StereoFrame> {
        let mut rec = Recorder::new(&self.ctx, self.pass_count())?;
        self.record(&mut rec, input, None);
        let passes = rec.finish()?;
        self.read_frame(passes, None)
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
