//! `debug-normals`: a scene-checking view, not a renderer. Per eye one
//! pixel-centre primary ray per pixel (the scene's shared ray tracing, either
//! backend); the colour is the world-space shading normal at the first hit
//! mapped to [0, 1] (0.5·n + 0.5), black where the ray escapes. Depth, first
//! hits and albedo are those of `reference`'s primary pass, so compare and
//! metrics treat it like any other method. Useful for checking imported
//! geometry (interpolated normals, glTF normal maps and their tangents).

use super::{
    Color, CounterOutput, FrameInput, FrameOutputs, FrameParams, Method, PixelOutputs, RaySlots,
    RenderSettings,
};
use crate::gpu::{Buffer, ComputePipeline, GpuContext, GpuResult, HostReadback, Recorder};
use crate::interface::debug_normals::{DebugNormalsCounter, INTERFACE};
use crate::interface::CounterSlot;
use crate::methods::reference::backend_shader;
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

const LOCAL: u32 = 8;

pub struct DebugNormals {
    ctx: Arc<GpuContext>,
    scene: Arc<SceneGpu>,
    settings: RenderSettings,
    primary: ComputePipeline,
    frame: Buffer,
    color: Buffer,
    first_hit: Buffer,
    depth: Buffer,
    albedo: Buffer,
    counters: Buffer,
    readback: HostReadback,
}

impl DebugNormals {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
    ) -> GpuResult<Self> {
        let n = (settings.width * settings.height * 2) as u64;
        let color = Buffer::storage(ctx, "debug_normals.color", n * 16)?;
        let PixelOutputs {
            frame,
            first_hit,
            depth,
            albedo,
            counters,
        } = PixelOutputs::new(ctx, "debug_normals", n, DebugNormalsCounter::ALL.len())?;
        let primary = ComputePipeline::with_interface(
            ctx,
            "debug_normals.primary",
            backend_shader("debug_normals/primary", scene)?,
            std::slice::from_ref(&scene.layout),
            &INTERFACE,
            None,
            &settings.spec_constants(scene, env),
        )?;
        Ok(DebugNormals {
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            primary,
            frame,
            color,
            first_hit,
            depth,
            albedo,
            counters,
            readback: HostReadback::new(),
        })
    }
}

impl Method for DebugNormals {
    fn name(&self) -> &'static str {
        "debug-normals"
    }

    fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>> {
        let this: &'a DebugNormals = self;
        let (w, h) = (this.settings.width, this.settings.height);
        let params = FrameParams::new(input, w, h, this.settings.seed, this.scene.origin);
        rec.pass("debug_normals.params")
            .write(&this.frame)
            .update(bytemuck::bytes_of(&params));
        rec.pass("debug_normals.clear")
            .write(&this.counters)
            .fill(0);
        // Binding order: src/interface/debug_normals.rs.
        rec.compute("debug_normals.primary", &this.primary)
            .shared(&this.scene.set)
            .read(&this.frame)
            .write(&this.color)
            .write(&this.first_hit)
            .write(&this.depth)
            .write(&this.albedo)
            .write(&this.counters)
            .dispatch([w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2])?;
        use DebugNormalsCounter::*;
        Ok(FrameOutputs {
            width: w,
            height: h,
            color: Color::Radiance(&this.color),
            depth: &this.depth,
            first_hit: &this.first_hit,
            albedo: &this.albedo,
            debug: None,
            counters: vec![CounterOutput::of::<DebugNormalsCounter>(&this.counters)
                .rays(RaySlots::of(&[PrimaryRays], &[], &[]))],
            host_counters: Default::default(),
            readback: &this.readback,
        })
    }

    fn memory_bytes(&self) -> u64 {
        [
            &self.frame,
            &self.color,
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
