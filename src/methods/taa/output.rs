//! [`TaaOnOutput`]: the one TAA ([`TaaPass`]) on the output of any method
//! (`--taa-output`; the paper's Fig. 12: "We apply TAA on top of all methods
//! to level the playing field for the error comparison").
//!
//! The wrapped method records its passes as usual; the resolve is recorded
//! after them into the same [`Recorder`] (so a frame is still one submit),
//! reading the method's colour (radiance or sample sum), view depth and first
//! hits. The frame's radiance is the resolved colour; depth, first hits,
//! albedo, debug views and counters stay the method's, with TAA's counters
//! (`taa_*`) added. Methods that already end in this TAA (`taa`, and
//! `hash-cache`/`hybrid` with their TAA on) are not wrapped
//! ([`super::super::Method::resolves_with_taa`]), so an image passes through
//! it exactly once.

use super::{TaaInputs, TaaPass, TaaSettings};
use crate::gpu::{GpuContext, GpuResult, Recorder};
use crate::methods::{Color, FrameInput, FrameOutputs, Method, RenderSettings};
use crate::rt::SceneGpu;
use std::sync::Arc;

pub struct TaaOnOutput {
    inner: Box<dyn Method>,
    pass: TaaPass,
}

impl TaaOnOutput {
    /// `inner` rendered at `settings`' size, resolved with `taa`.
    pub fn new(
        inner: Box<dyn Method>,
        scene: &Arc<SceneGpu>,
        settings: &RenderSettings,
        taa: &TaaSettings,
    ) -> GpuResult<Self> {
        let pass = TaaPass::new(inner.context(), scene, settings, taa)?;
        Ok(TaaOnOutput { inner, pass })
    }

    pub fn pass(&self) -> &TaaPass {
        &self.pass
    }
}

impl Method for TaaOnOutput {
    /// The wrapped method's name: TAA is a setting of the run, not another method.
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn context(&self) -> &Arc<GpuContext> {
        self.inner.context()
    }

    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>> {
        let TaaOnOutput { inner, pass } = self;
        let mut out = inner.record(rec, input)?;
        let (resolved, counters) = pass.record(
            rec,
            input,
            TaaInputs {
                color: out.color,
                depth: out.depth,
                first_hit: out.first_hit,
            },
        )?;
        out.color = Color::Radiance(resolved);
        out.counters.push(counters);
        Ok(out)
    }

    fn resolves_with_taa(&self) -> bool {
        true
    }

    fn memory_bytes(&self) -> u64 {
        self.inner.memory_bytes() + self.pass.memory_bytes()
    }
}
