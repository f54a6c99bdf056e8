//! `taa`: 1 spp path tracing through a Halton(2, 3) sub-pixel sequence,
//! resolved by temporal antialiasing after Yang, Liu & Salvi 2020 (see
//! [`TaaPass`] and shaders/taa/resolve.comp). The colour source is the
//! reference path tracer at 1 spp with a fixed jitter per frame; depth and
//! first hits are the pixel centres' (unjittered), which the resolve uses for
//! reprojection and disocclusion tests.

pub mod args;
pub mod output;
pub mod pass;
pub mod settings;

pub use output::TaaOnOutput;
pub use pass::{TaaInputs, TaaPass};
pub use settings::{halton_jitter, TaaHistory, TaaSettings, TaaWeights};

use super::{Color, FrameInput, FrameOutputs, Method, Reference, RenderSettings};
use crate::gpu::{GpuContext, GpuResult, HostReadback, Recorder};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

pub struct Taa {
    ctx: Arc<GpuContext>,
    source: Reference,
    pass: TaaPass,
    readback: HostReadback,
}

impl Taa {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
        taa: &TaaSettings,
    ) -> GpuResult<Self> {
        let s = RenderSettings {
            spp: 1,
            ..settings.clone()
        };
        let source =
            Reference::with_name("taa.source", ctx, scene, env, &s)?.with_centre_hits_as_cost();
        let pass = TaaPass::new(ctx, scene, &s, taa)?;
        Ok(Taa {
            ctx: ctx.clone(),
            source,
            pass,
            readback: HostReadback::new(),
        })
    }

    pub fn pass(&self) -> &TaaPass {
        &self.pass
    }
}

impl Method for Taa {
    fn name(&self) -> &'static str {
        "taa"
    }

    fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>> {
        let Taa {
            source,
            pass,
            readback,
            ..
        } = self;
        let source: &'a Reference = source;
        source.record_passes(rec, input, Some(halton_jitter(input.index)))?;
        let out = source.outputs();
        let (resolved, counters) = pass.record(
            rec,
            input,
            TaaInputs {
                color: Color::Radiance(out.accum),
                depth: out.depth,
                first_hit: out.first_hit,
            },
        )?;
        let mut frame = source.frame_outputs(Color::Radiance(resolved), readback);
        frame.counters.push(counters);
        Ok(frame)
    }

    fn resolves_with_taa(&self) -> bool {
        true
    }

    fn memory_bytes(&self) -> u64 {
        self.source.memory_bytes() + self.pass.memory_bytes()
    }
}
