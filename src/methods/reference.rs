//! `reference`: the ground-truth path tracer. Both eyes, N samples per pixel
//! (in dispatches of at most 16 so no single dispatch runs long), up to B
//! bounces, pixel-centre first hits in the Listing 1 encoding.

use super::{
    Color, CounterOutput, FrameInput, FrameOutputs, FrameParams, Method, PixelOutputs, RaySlots,
    RenderSettings,
};
use crate::gpu::{
    shaders, Buffer, ComputePipeline, GpuContext, GpuError, GpuResult, HostReadback, Recorder,
};
use crate::interface::reference::{ReferenceCounter, INTERFACE, TRACE_PUSH};
use crate::interface::CounterSlot;
use crate::rt::SceneGpu;
use crate::scene::Environment;
use bytemuck::{Pod, Zeroable};
use std::sync::Arc;

const LOCAL: u32 = 8;
/// Samples per dispatch.
const CHUNK: u32 = 16;

/// Push constants of reference/trace.comp (`REFERENCE_TRACE_PUSH`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct TracePush {
    sample_base: u32,
    sample_count: u32,
    fixed_jitter: u32,
    pad: u32,
    jitter: [f32; 2],
}
const _: () = assert!(std::mem::size_of::<TracePush>() == TRACE_PUSH.size() as usize);

pub struct Reference {
    name: &'static str,
    ctx: Arc<GpuContext>,
    scene: Arc<SceneGpu>,
    settings: RenderSettings,
    primary: ComputePipeline,
    trace: ComputePipeline,
    frame: Buffer,
    accum: Buffer,
    first_hit: Buffer,
    depth: Buffer,
    albedo: Buffer,
    counters: Buffer,
    readback: HostReadback,
    /// Whether the pixel-centre pass (`primary`) is part of the method's
    /// cost: only where a TAA reads its depth and first hits.
    centre_is_cost: bool,
}

/// Loads a compiled shader of the scene's backend or says which is missing:
/// the scene's run-time build where it has one (material graphs,
/// `SceneGpu::shaders`), else the build-time SPIR-V.
pub(crate) fn backend_shader(name: &str, scene: &SceneGpu) -> GpuResult<&'static [u8]> {
    let full = format!("{name}.{}", scene.backend.shader_suffix());
    optional_backend_shader(name, scene)?
        .ok_or_else(|| GpuError::Unsupported(format!("shader {full} was not compiled")))
}

/// The same for a build that need not exist (a variant only some shaders
/// have): `None` where there is none, an error where it failed to compile.
pub(crate) fn optional_backend_shader(
    name: &str,
    scene: &SceneGpu,
) -> GpuResult<Option<&'static [u8]>> {
    let full = format!("{name}.{}", scene.backend.shader_suffix());
    shaders::lookup(&full, scene.shaders.as_deref()).map_err(GpuError::Unsupported)
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
        // Allocated first, as before: an over-range --size is refused naming it.
        let accum = Buffer::storage(ctx, "reference.accum", n * 16)?;
        let PixelOutputs {
            frame,
            first_hit,
            depth,
            albedo,
            counters,
        } = PixelOutputs::new(ctx, "reference", n, ReferenceCounter::ALL.len())?;
        let spec = settings.spec_constants(scene, env);
        let shared = [scene.layout.clone()];
        let primary = ComputePipeline::with_interface(
            ctx,
            "reference.primary",
            backend_shader("reference/primary", scene)?,
            &shared,
            &INTERFACE,
            None,
            &spec,
        )?;
        let trace = ComputePipeline::with_interface(
            ctx,
            "reference.trace",
            backend_shader("reference/trace", scene)?,
            &shared,
            &INTERFACE,
            Some(&TRACE_PUSH),
            &spec,
        )?;
        Ok(Reference {
            name,
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            primary,
            trace,
            frame,
            accum,
            first_hit,
            depth,
            albedo,
            counters,
            readback: HostReadback::new(),
            centre_is_cost: settings.taa_output.is_some(),
        })
    }

    /// Makes the pixel-centre pass part of the method's cost (the colour
    /// source of `taa`, whose TAA reads its depth and first hits). Otherwise
    /// it is a diagnostic pass (`diag.{name}.primary`) whose rays count as
    /// `centre_rays`: the 1 spp path tracer traces its first hit and path in
    /// one pass (`trace`), as the paper's (Fig. 13), and the centre ray only
    /// fills the frame's depth / first-hit / albedo outputs. `--taa-output`
    /// (whose TAA reads them) makes it a cost as well.
    pub fn with_centre_hits_as_cost(mut self) -> Self {
        self.centre_is_cost = true;
        self
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
    pub fn record_passes<'a>(
        &'a self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
        jitter: Option<[f32; 2]>,
    ) -> GpuResult<()> {
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
        // Binding order: src/interface/reference.rs. `primary` writes no
        // accumulator; it is declared (one binding list for both shaders) but
        // neither bound nor tracked for `primary` (src/gpu/reflect.rs).
        let centre = if self.centre_is_cost {
            format!("{p}.primary")
        } else {
            format!("{}{p}.primary", super::frame::DIAGNOSTIC_PASS_PREFIX)
        };
        rec.compute(&centre, &self.primary)
            .shared(&self.scene.set)
            .read(&self.frame)
            .write(&self.accum)
            .write(&self.first_hit)
            .write(&self.depth)
            .write(&self.albedo)
            .write(&self.counters)
            .dispatch(groups)?;
        let (fixed_jitter, jitter) = match jitter {
            Some(j) => (1u32, j),
            None => (0, [0.0; 2]),
        };
        for c in 0..chunks {
            let sample_base = c * CHUNK;
            rec.compute(&format!("{p}.trace"), &self.trace)
                .shared(&self.scene.set)
                .read(&self.frame)
                .write(&self.accum)
                .write(&self.first_hit)
                .write(&self.depth)
                .write(&self.albedo)
                .write(&self.counters)
                .push(&TracePush {
                    sample_base,
                    sample_count: CHUNK.min(spp - sample_base),
                    fixed_jitter,
                    pad: 0,
                    jitter,
                })
                .dispatch(groups)?;
        }
        Ok(())
    }

    /// The frame's outputs with `color` as its radiance (the accumulated
    /// mean for `reference`; a TAA resolve of it for `taa`).
    pub fn frame_outputs<'a>(
        &'a self,
        color: Color<'a>,
        readback: &'a HostReadback,
    ) -> FrameOutputs<'a> {
        use ReferenceCounter::*;
        FrameOutputs {
            width: self.settings.width,
            height: self.settings.height,
            color,
            depth: &self.depth,
            first_hit: &self.first_hit,
            albedo: &self.albedo,
            debug: None,
            counters: vec![CounterOutput::of::<ReferenceCounter>(&self.counters).rays(
                RaySlots::of(
                    if self.centre_is_cost {
                        &[PrimaryRays, CentreRays]
                    } else {
                        &[PrimaryRays]
                    },
                    &[BounceRays],
                    &[ShadowRays],
                ),
            )],
            host_counters: Default::default(),
            readback,
        }
    }
}

impl Method for Reference {
    fn name(&self) -> &'static str {
        self.name
    }

    fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        frame: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>> {
        let this: &'a Reference = self;
        this.record_passes(rec, frame, None)?;
        Ok(this.frame_outputs(Color::SampleSum(&this.accum), &this.readback))
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
