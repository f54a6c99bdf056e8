//! `taa`: 1 spp path tracing through a Halton(2, 3) sub-pixel sequence,
//! resolved by temporal antialiasing after Yang, Liu & Salvi 2020 (see
//! [`TaaPass`] and shaders/taa/resolve.comp). The colour source is the
//! reference path tracer at 1 spp with a fixed jitter per frame; depth and
//! first hits are the pixel centres' (unjittered), which the resolve uses for
//! reprojection and disocclusion tests.

pub mod args;
pub mod pass;
pub mod settings;

pub use pass::{TaaInputs, TaaPass};
pub use settings::{halton_jitter, TaaSettings, TaaWeights};

use super::{FrameInput, Method, Reference, RenderSettings, StereoFrame};
use crate::gpu::{GpuContext, GpuResult, Recorder};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

pub struct Taa {
    ctx: Arc<GpuContext>,
    source: Reference,
    pass: TaaPass,
}

impl Taa {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
    ) -> GpuResult<Self> {
        let s = RenderSettings {
            spp: 1,
            ..settings.clone()
        };
        let source = Reference::with_name("taa.source", ctx, scene, env, &s)?;
        let out = source.outputs();
        let pass = TaaPass::new(
            ctx,
            scene,
            s.width,
            s.height,
            s.seed,
            &settings.taa,
            TaaInputs {
                color: out.accum,
                depth: out.depth,
                first_hit: out.first_hit,
            },
        )?;
        Ok(Taa {
            ctx: ctx.clone(),
            source,
            pass,
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

    fn render_frame(&mut self, input: &FrameInput) -> GpuResult<StereoFrame> {
        let mut rec = Recorder::new(&self.ctx, self.source.pass_count() + TaaPass::PASSES)?;
        self.source
            .record(&mut rec, input, Some(halton_jitter(input.index)));
        let out = self.source.outputs();
        self.pass.record(
            &mut rec,
            input,
            TaaInputs {
                color: out.accum,
                depth: out.depth,
                first_hit: out.first_hit,
            },
        );
        let passes = rec.finish()?;
        let resolved: Vec<[f32; 4]> = self
            .pass
            .read_output()?
            .into_iter()
            .map(|c| [c[0], c[1], c[2], 1.0])
            .collect();
        let mut frame = self.source.read_frame(passes, Some(resolved))?;
        frame.stats.counters = self.pass.counters()?;
        Ok(frame)
    }

    fn memory_bytes(&self) -> u64 {
        self.source.memory_bytes() + self.pass.memory_bytes()
    }
}
