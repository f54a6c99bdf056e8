//! [`TaaPass`]: the temporal antialiasing resolve as a reusable technique
//! (the kajiya style of DESIGN.md): it owns its temporal resources (two
//! history buffers, the previous frame's depth and first hits) and records its
//! passes into a caller's [`Recorder`], given the caller's per-pixel colour,
//! depth and first-hit buffers (`[eye][pixel]`, both eyes). `taa` runs it on
//! 1 spp Halton-jittered path tracing; `hash-cache` can run it on its output.
//!
//! Passes (5): `taa.params` → `taa.clear` → `taa.resolve`
//! (shaders/taa/resolve.comp) → `taa.keep.depth` → `taa.keep.first_hit`.

use super::settings::{TaaSettings, TaaWeights};
use crate::gpu::{
    shaders, Buffer, ComputePipeline, DescriptorLayout, DescriptorSet, GpuContext, GpuError,
    GpuResult, Recorder, Resource,
};
use crate::methods::{FrameInput, FrameParams};
use crate::rt::SceneGpu;
use std::collections::BTreeMap;
use std::sync::Arc;

const LOCAL: u32 = 8;

/// Counter slots of resolve.comp (`C_*`) with their report names.
const COUNTERS: &[(usize, &str)] = &[
    (0, "taa_rejected_offscreen"),
    (1, "taa_rejected_disocclusion"),
    (2, "taa_no_history"),
    (3, "taa_clipped"),
    (4, "taa_history_used"),
];

/// The caller's buffers the resolve reads, `[eye][pixel]`: colour (vec4, rgb =
/// radiance, w ignored), view depth (f32, 0 = miss) and pixel-centre first hits
/// (uvec4, Listing 1). They are bound when the pass is created, so the same
/// buffers must be passed to every [`TaaPass::record`] and outlive the pass.
#[derive(Clone, Copy)]
pub struct TaaInputs<'a> {
    pub color: &'a Buffer,
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
    /// sets[p] reads history[p] and writes history[1 − p].
    sets: [DescriptorSet; 2],
    frame: Buffer,
    history: [Buffer; 2],
    prev_depth: Buffer,
    prev_first_hit: Buffer,
    counters: Buffer,
    bound: [ash::vk::Buffer; 3],
    /// Frames recorded since creation or the last reset.
    frames: u64,
}

impl TaaPass {
    /// Passes `record` adds to a recorder.
    pub const PASSES: u32 = 5;

    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        width: u32,
        height: u32,
        seed: u32,
        settings: &TaaSettings,
        inputs: TaaInputs<'_>,
    ) -> GpuResult<TaaPass> {
        settings.validate().map_err(GpuError::Unsupported)?;
        let n = 2 * (width * height) as u64;
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("taa.{name}"), bytes);
        let frame = b("frame", std::mem::size_of::<FrameParams>() as u64)?;
        let history = [b("history0", n * 16)?, b("history1", n * 16)?];
        let prev_depth = b("prev_depth", n * 4)?;
        let prev_first_hit = b("prev_first_hit", n * 16)?;
        let counters = b("counters", 8 * 4)?;
        for (buf, bytes) in [
            (inputs.color, n * 16),
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
        let layout = DescriptorLayout::buffers(ctx, 9)?;
        let make_set = |p: usize| {
            DescriptorSet::new(
                ctx,
                &layout,
                &[
                    Resource::Buffer(&frame),
                    Resource::Buffer(inputs.color),
                    Resource::Buffer(inputs.depth),
                    Resource::Buffer(inputs.first_hit),
                    Resource::Buffer(&history[p]),
                    Resource::Buffer(&history[1 - p]),
                    Resource::Buffer(&prev_depth),
                    Resource::Buffer(&prev_first_hit),
                    Resource::Buffer(&counters),
                ],
            )
        };
        let sets = [make_set(0)?, make_set(1)?];
        // camera.glsl lives in set 1, so set 0 is the scene's (bound, unused).
        let layouts = [scene.layout.clone(), layout];
        let spirv = shaders::spirv("taa/resolve")
            .ok_or_else(|| GpuError::Unsupported("shader taa/resolve was not compiled".into()))?;
        let pipeline =
            ComputePipeline::new(ctx, "taa.resolve", spirv, &layouts, 16, &Default::default())?;
        Ok(TaaPass {
            settings: settings.clone(),
            width,
            height,
            seed,
            scene: scene.clone(),
            pipeline,
            sets,
            frame,
            history,
            prev_depth,
            prev_first_hit,
            counters,
            bound: [inputs.color.raw, inputs.depth.raw, inputs.first_hit.raw],
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
    /// `inputs`. The resolved colour (rgb, w = history length in frames) is in
    /// [`TaaPass::output`] once the recorder has finished.
    pub fn record(&mut self, rec: &mut Recorder, input: &FrameInput, inputs: TaaInputs<'_>) {
        assert_eq!(
            [inputs.color.raw, inputs.depth.raw, inputs.first_hit.raw],
            self.bound,
            "TaaPass::record: inputs differ from the buffers bound at creation"
        );
        let p = (self.frames % 2) as usize;
        let params = FrameParams::new(input, self.width, self.height, self.seed, self.scene.origin);
        let flags = (self.frames > 0) as u32
            | (self.settings.reject_disocclusions as u32) << 1
            | (self.settings.clip as u32) << 2;
        let weights = match self.settings.weights {
            TaaWeights::Fixed => 0u32,
            TaaWeights::Pfj23 => 1,
        };
        let mut push = Vec::with_capacity(16);
        push.extend(self.settings.alpha.to_le_bytes());
        push.extend(self.settings.gamma.to_le_bytes());
        push.extend(weights.to_le_bytes());
        push.extend(flags.to_le_bytes());
        rec.pass("taa.params")
            .write(&self.frame)
            .update(bytemuck::bytes_of(&params));
        rec.pass("taa.clear").write(&self.counters).fill(0);
        let sets = [&self.scene.set, &self.sets[p]];
        let groups = [self.width.div_ceil(LOCAL), self.height.div_ceil(LOCAL), 2];
        rec.pass("taa.resolve")
            .read(&self.frame)
            .read(inputs.color)
            .read(inputs.depth)
            .read(inputs.first_hit)
            .read(&self.history[p])
            .read(&self.prev_depth)
            .read(&self.prev_first_hit)
            .write(&self.history[1 - p])
            .write(&self.counters)
            .dispatch(&self.pipeline, &sets, &push, groups);
        rec.pass("taa.keep.depth")
            .read(inputs.depth)
            .write(&self.prev_depth)
            .copy(self.prev_depth.size.min(inputs.depth.size));
        rec.pass("taa.keep.first_hit")
            .read(inputs.first_hit)
            .write(&self.prev_first_hit)
            .copy(self.prev_first_hit.size.min(inputs.first_hit.size));
        self.frames += 1;
    }

    /// The resolved colour of the last recorded frame, `[eye][pixel]`:
    /// rgb, w = history length in frames (1 = no history used).
    pub fn output(&self) -> &Buffer {
        &self.history[(self.frames % 2) as usize]
    }

    /// Reads [`TaaPass::output`] back.
    pub fn read_output(&self) -> GpuResult<Vec<[f32; 4]>> {
        self.output().download_pod()
    }

    /// Per-frame counters of the last frame (pixels over both eyes), and the
    /// mean history length.
    pub fn counters(&self) -> GpuResult<BTreeMap<String, f64>> {
        let c: Vec<u32> = self.counters.download_pod()?;
        let mut m: BTreeMap<String, f64> = COUNTERS
            .iter()
            .map(|(i, name)| (name.to_string(), c[*i] as f64))
            .collect();
        m.insert(
            "taa_mean_history".into(),
            c[5] as f64 / (2 * self.width * self.height) as f64,
        );
        Ok(m)
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
