//! [`TaaPass`]: the temporal antialiasing resolve as a reusable technique
//! (the kajiya style of DESIGN.md): it owns its temporal resources (two
//! history buffers, the previous frame's depth and first hits) and records its
//! passes into a caller's [`Recorder`], given the caller's per-pixel colour,
//! depth and first-hit buffers (`[eye][pixel]`, both eyes). It is the
//! project's one TAA: `taa` runs it on 1 spp Halton-jittered path tracing,
//! `hash-cache` and `hybrid` on their output (paper §4: "TAA [YLS20] ... using
//! temporal weights as derived by Philippi et al. [PFJ23]"), and
//! [`super::TaaOnOutput`] on any other method's (`--taa-output`, Fig. 12).
//!
//! Binding order and counter slots: src/interface/taa.rs.
//! Passes (5): `taa.params` → `taa.clear` → `taa.resolve`
//! (shaders/taa/resolve.comp) → `taa.keep.depth` → `taa.keep.first_hit`.

use super::settings::{TaaHistory, TaaSettings, TaaWeights};
use crate::gpu::{shaders, Buffer, ComputePipeline, GpuContext, GpuError, GpuResult, Recorder};
use crate::interface::taa::{TaaCounter, INTERFACE, RESOLVE_PUSH};
use crate::methods::{Color, CounterOutput, FrameInput, FrameParams, RenderSettings};
use crate::rt::SceneGpu;
use bytemuck::{Pod, Zeroable};
use std::sync::Arc;

const LOCAL: u32 = 8;

/// Push constants of resolve.comp (`TAA_RESOLVE_PUSH`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ResolvePush {
    alpha: f32,
    gamma: f32,
    weights: u32,
    flags: u32,
}
const _: () = assert!(std::mem::size_of::<ResolvePush>() == RESOLVE_PUSH.size() as usize);

/// The caller's buffers the resolve reads, `[eye][pixel]`: colour (vec4,
/// either radiance or a sample sum, [`Color`]), view depth (f32, 0 = miss)
/// and first hits (uvec4, Listing 1; the pixel centres' where the method has
/// them, else its own). They are bound per pass (push descriptors), so they
/// may differ from frame to frame; each must hold both eyes' pixels.
#[derive(Clone, Copy)]
pub struct TaaInputs<'a> {
    pub color: Color<'a>,
    pub depth: &'a Buffer,
    pub first_hit: &'a Buffer,
}

pub struct TaaPass {
    settings: TaaSettings,
    width: u32,
    height: u32,
    seed: u32,
    scene: Arc<SceneGpu>,
    pipeline: ComputePipeline,
    frame: Buffer,
    history: [Buffer; 2],
    prev_depth: Buffer,
    prev_first_hit: Buffer,
    counters: Buffer,
    /// Frames recorded since creation or the last reset.
    frames: u64,
}

impl TaaPass {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        render: &RenderSettings,
        settings: &TaaSettings,
    ) -> GpuResult<TaaPass> {
        settings.validate().map_err(GpuError::Unsupported)?;
        let (width, height, seed) = (render.width, render.height, render.seed);
        let n = pixels(width, height);
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("taa.{name}"), bytes);
        let frame = b("frame", std::mem::size_of::<FrameParams>() as u64)?;
        let history = [b("history0", n * 16)?, b("history1", n * 16)?];
        let prev_depth = b("prev_depth", n * 4)?;
        let prev_first_hit = b("prev_first_hit", n * 16)?;
        let counters = b("counters", 8 * 4)?;
        // camera.glsl lives in set 1, so set 0 is the scene's: the instance
        // transforms (motion vectors where the scene animates, SC_ANIMATED).
        let spirv = shaders::spirv("taa/resolve")
            .ok_or_else(|| GpuError::Unsupported("shader taa/resolve was not compiled".into()))?;
        let pipeline = ComputePipeline::with_interface(
            ctx,
            "taa.resolve",
            spirv,
            std::slice::from_ref(&scene.layout),
            &INTERFACE,
            Some(&RESOLVE_PUSH),
            &scene.spec_constants(&None, 0, false),
        )?;
        Ok(TaaPass {
            settings: settings.clone(),
            width,
            height,
            seed,
            scene: scene.clone(),
            pipeline,
            frame,
            history,
            prev_depth,
            prev_first_hit,
            counters,
            frames: 0,
        })
    }

    /// Forgets the history: the next frame starts a new one.
    pub fn reset(&mut self) {
        self.frames = 0;
    }

    pub fn settings(&self) -> &TaaSettings {
        &self.settings
    }

    /// Records the resolve of one frame after the caller's passes that write
    /// `inputs`, and returns the resolved colour (rgb, w = history length in
    /// frames; 1 = no history used) with the pass's counters, to be read
    /// back once the recorder has finished.
    pub fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
        inputs: TaaInputs<'a>,
    ) -> GpuResult<(&'a Buffer, CounterOutput<'a>)> {
        check_inputs(self.width, self.height, inputs)?;
        let (color, sample_sum) = match inputs.color {
            Color::Radiance(b) => (b, false),
            Color::SampleSum(b) => (b, true),
        };
        let p = (self.frames % 2) as usize;
        let has_history = self.frames > 0;
        self.frames += 1;
        let this: &'a TaaPass = self;
        let params = FrameParams::new(input, this.width, this.height, this.seed, this.scene.origin);
        let s = &this.settings;
        let push = ResolvePush {
            alpha: s.alpha,
            gamma: s.gamma,
            weights: match s.weights {
                TaaWeights::Fixed => 0,
                TaaWeights::Count => 1,
                TaaWeights::Pfj23 => 2,
            },
            flags: has_history as u32
                | (s.reject_disocclusions as u32) << 1
                | (s.clip as u32) << 2
                | (sample_sum as u32) << 3
                | (s.motion_vectors as u32) << 4
                | ((s.history == TaaHistory::CatmullRom) as u32) << 5,
        };
        rec.pass("taa.params")
            .write(&this.frame)
            .update(bytemuck::bytes_of(&params));
        rec.pass("taa.clear").write(&this.counters).fill(0);
        let groups = [this.width.div_ceil(LOCAL), this.height.div_ceil(LOCAL), 2];
        // Binding order: src/interface/taa.rs.
        rec.compute("taa.resolve", &this.pipeline)
            .shared(&this.scene.set)
            .read(&this.frame)
            .read(color)
            .read(inputs.depth)
            .read(inputs.first_hit)
            .read(&this.history[p])
            .write(&this.history[1 - p])
            .read(&this.prev_depth)
            .read(&this.prev_first_hit)
            .write(&this.counters)
            .push(&push)
            .dispatch(groups)?;
        rec.pass("taa.keep.depth")
            .read(inputs.depth)
            .write(&this.prev_depth)
            .copy(this.prev_depth.size.min(inputs.depth.size));
        rec.pass("taa.keep.first_hit")
            .read(inputs.first_hit)
            .write(&this.prev_first_hit)
            .copy(this.prev_first_hit.size.min(inputs.first_hit.size));
        let counters = CounterOutput::of::<TaaCounter>(&this.counters)
            .per_pixel(TaaCounter::HistorySum, "taa_mean_history");
        Ok((&this.history[1 - p], counters))
    }

    /// The resolved colour of the last recorded frame, `[eye][pixel]`:
    /// rgb, w = history length in frames (1 = no history used).
    pub fn output(&self) -> &Buffer {
        &self.history[(self.frames % 2) as usize]
    }

    /// GPU memory the pass owns.
    pub fn memory_bytes(&self) -> u64 {
        self.frame.size
            + self.history[0].size
            + self.history[1].size
            + self.prev_depth.size
            + self.prev_first_hit.size
            + self.counters.size
    }
}

/// Pixels of both eyes.
fn pixels(width: u32, height: u32) -> u64 {
    2 * (width * height) as u64
}

/// Every input holds both eyes' pixels.
fn check_inputs(width: u32, height: u32, inputs: TaaInputs<'_>) -> GpuResult<()> {
    let n = pixels(width, height);
    let color = match inputs.color {
        Color::Radiance(b) | Color::SampleSum(b) => b,
    };
    for (buf, bytes) in [
        (color, n * 16),
        (inputs.depth, n * 4),
        (inputs.first_hit, n * 16),
    ] {
        if buf.size < bytes {
            return Err(GpuError::Unsupported(format!(
                "taa: input buffer {} holds {} bytes, the resolve reads {bytes}",
                buf.name, buf.size
            )));
        }
    }
    Ok(())
}
