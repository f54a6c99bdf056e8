//! Temporal antialiasing as a self-contained pass (`shaders/hash_cache/taa.comp`):
//! owns its history (colour + length, view depth; double-buffered) and
//! reads a method's colour, first-hit position and depth buffers (interface
//! `hash_taa` of src/interface/hash_table.rs). Written for `hash-cache`; kept free of hash-cache state so the
//! standalone `taa` method can reuse or replace it.

use crate::gpu::{
    shaders, Buffer, ComputePipeline, DescriptorSet, GpuContext, GpuError, GpuResult, Recorder,
};
use crate::interface::hash_table::{TAA, TAA_PUSH};
use crate::rt::SceneGpu;
use std::sync::Arc;

/// Blend factor floor α_min (history length cap 1/α_min).
pub const ALPHA_MIN: f32 = 0.1;
/// Variance-clipping width γ (in standard deviations of the 3×3 neighbourhood).
pub const GAMMA: f32 = 1.25;
/// Relative view-depth tolerance of the disocclusion test.
pub const DEPTH_TOLERANCE: f32 = 0.05;

/// `HASH_TAA_PUSH` of src/interface/hash_table.rs.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TaaPush {
    alpha_min: f32,
    gamma: f32,
    depth_tolerance: f32,
    /// 1: ignore the history (first frame).
    reset: u32,
}
const _: () = assert!(std::mem::size_of::<TaaPush>() == TAA_PUSH.size() as usize);

pub struct Taa {
    pipeline: ComputePipeline,
    /// history[p] is read and history[1 − p] written in a frame of parity p.
    history: [Buffer; 2],
    depth: [Buffer; 2],
    frames: u64,
}

/// The buffers TAA reads, each `2 × width × height` entries, eye-major.
#[derive(Clone, Copy)]
pub struct TaaInputs<'a> {
    /// The `FrameBuf` of camera.glsl.
    pub frame: &'a Buffer,
    pub color: &'a Buffer,
    /// vec4: hit point with w = 1, or ray direction with w = 0.
    pub position: &'a Buffer,
    /// View depth, 0 = miss.
    pub depth: &'a Buffer,
}

impl Taa {
    /// History for `pixels` entries (both eyes).
    pub fn new(ctx: &Arc<GpuContext>, scene: &SceneGpu, pixels: u64) -> GpuResult<Taa> {
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("taa.{name}"), bytes);
        let history = [b("history0", pixels * 16)?, b("history1", pixels * 16)?];
        let hdepth = [b("depth0", pixels * 4)?, b("depth1", pixels * 4)?];
        // Traces no rays: one SPIR-V for both ray backends.
        let spirv = shaders::spirv("hash_cache/taa").ok_or_else(|| {
            GpuError::Unsupported("shader hash_cache/taa was not compiled".into())
        })?;
        let pipeline = ComputePipeline::with_interface(
            ctx,
            "taa.resolve",
            spirv,
            std::slice::from_ref(&scene.layout),
            &TAA,
            Some(&TAA_PUSH),
            &Default::default(),
        )?;
        Ok(Taa {
            pipeline,
            history,
            depth: hdepth,
            frames: 0,
        })
    }

    /// Starts a frame that runs TAA (before [`Taa::record`]).
    pub fn begin_frame(&mut self) {
        self.frames += 1;
    }

    /// Records the resolve of the frame begun last. Returns the buffer
    /// holding the result (rgb, history length in w) once the recorder has
    /// finished.
    pub fn record<'a>(
        &'a self,
        rec: &mut Recorder<'a>,
        scene_set: &'a DescriptorSet,
        inputs: TaaInputs<'a>,
        groups: [u32; 3],
    ) -> GpuResult<&'a Buffer> {
        let k = self.frames.saturating_sub(1);
        let p = (k % 2) as usize;
        rec.compute("taa", &self.pipeline)
            .shared(scene_set)
            .read(inputs.frame)
            .read(inputs.color)
            .read(inputs.position)
            .read(inputs.depth)
            .read(&self.history[p])
            .write(&self.history[1 - p])
            .read(&self.depth[p])
            .write(&self.depth[1 - p])
            .push(&TaaPush {
                alpha_min: ALPHA_MIN,
                gamma: GAMMA,
                depth_tolerance: DEPTH_TOLERANCE,
                reset: (k == 0) as u32,
            })
            .dispatch(groups)?;
        Ok(&self.history[1 - p])
    }

    /// Forget the history (the next frame shows the current colour only).
    pub fn reset(&mut self) {
        self.frames = 0;
    }

    pub fn memory_bytes(&self) -> u64 {
        self.history.iter().chain(&self.depth).map(|b| b.size).sum()
    }
}
