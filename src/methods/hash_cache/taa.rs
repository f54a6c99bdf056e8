//! Temporal antialiasing as a self-contained pass (`shaders/hash_cache/taa.comp`):
//! owns its history (colour + length, view depth; double-buffered) and its
//! descriptor set, and reads a method's colour, first-hit position and depth
//! buffers. Written for `hash-cache`; kept free of hash-cache state so the
//! standalone `taa` method can reuse or replace it.

use crate::gpu::{
    shaders, Buffer, ComputePipeline, DescriptorLayout, DescriptorSet, GpuContext, GpuError,
    GpuResult, Recorder, Resource,
};
use crate::rt::SceneGpu;
use std::sync::Arc;

/// Blend factor floor α_min (history length cap 1/α_min).
pub const ALPHA_MIN: f32 = 0.1;
/// Variance-clipping width γ (in standard deviations of the 3×3 neighbourhood).
pub const GAMMA: f32 = 1.25;
/// Relative view-depth tolerance of the disocclusion test.
pub const DEPTH_TOLERANCE: f32 = 0.05;

pub struct Taa {
    pipeline: ComputePipeline,
    /// sets[p] reads history[p] and writes history[1 − p].
    sets: [DescriptorSet; 2],
    history: [Buffer; 2],
    depth: [Buffer; 2],
    frames: u64,
}

impl Taa {
    /// `frame` is the `FrameBuf` of camera.glsl; `color`, `position` (vec4: hit
    /// point with w = 1, or ray direction with w = 0) and `depth` (view depth,
    /// 0 = miss) hold `2 × width × height` entries, eye-major.
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &SceneGpu,
        pixels: u64,
        frame: &Buffer,
        color: &Buffer,
        position: &Buffer,
        depth: &Buffer,
    ) -> GpuResult<Taa> {
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("taa.{name}"), bytes);
        let history = [b("history0", pixels * 16)?, b("history1", pixels * 16)?];
        let hdepth = [b("depth0", pixels * 4)?, b("depth1", pixels * 4)?];
        let layout = DescriptorLayout::buffers(ctx, 8)?;
        let make = |p: usize| {
            DescriptorSet::new(
                ctx,
                &layout,
                &[
                    Resource::Buffer(frame),
                    Resource::Buffer(color),
                    Resource::Buffer(position),
                    Resource::Buffer(depth),
                    Resource::Buffer(&history[p]),
                    Resource::Buffer(&history[1 - p]),
                    Resource::Buffer(&hdepth[p]),
                    Resource::Buffer(&hdepth[1 - p]),
                ],
            )
        };
        let sets = [make(0)?, make(1)?];
        // Traces no rays: one SPIR-V for both ray backends.
        let spirv = shaders::spirv("hash_cache/taa").ok_or_else(|| {
            GpuError::Unsupported("shader hash_cache/taa was not compiled".into())
        })?;
        let pipeline = ComputePipeline::new(
            ctx,
            "taa.resolve",
            spirv,
            &[scene.layout.clone(), layout],
            16,
            &Default::default(),
        )?;
        Ok(Taa {
            pipeline,
            sets,
            history,
            depth: hdepth,
            frames: 0,
        })
    }

    /// Records the resolve; `inputs` are the buffers given to `new` (for the
    /// recorder's hazard tracking). Returns the buffer holding the result
    /// (rgb, history length in w) once the recorder has finished.
    pub fn record<'a>(
        &'a mut self,
        rec: &mut Recorder,
        scene_set: &DescriptorSet,
        inputs: [&Buffer; 4],
        groups: [u32; 3],
    ) -> &'a Buffer {
        let p = (self.frames % 2) as usize;
        let mut push = Vec::with_capacity(16);
        for f in [ALPHA_MIN, GAMMA, DEPTH_TOLERANCE] {
            push.extend_from_slice(&f.to_le_bytes());
        }
        push.extend_from_slice(&((self.frames == 0) as u32).to_le_bytes());
        let mut pass = rec.pass("taa");
        for b in inputs {
            pass = pass.read(b);
        }
        pass.read(&self.history[p])
            .read(&self.depth[p])
            .write(&self.history[1 - p])
            .write(&self.depth[1 - p])
            .dispatch(&self.pipeline, &[scene_set, &self.sets[p]], &push, groups);
        self.frames += 1;
        &self.history[1 - p]
    }

    /// Forget the history (the next frame shows the current colour only).
    pub fn reset(&mut self) {
        self.frames = 0;
    }

    pub fn memory_bytes(&self) -> u64 {
        self.history.iter().chain(&self.depth).map(|b| b.size).sum()
    }
}
