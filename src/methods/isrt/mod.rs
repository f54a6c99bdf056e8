//! `isrt`: interactive stable ray tracing (Dal Corso et al. 2017) in the
//! layout the sample-cache paper compares against (Fig. 10): per eye an M × M
//! super-resolution grid per pixel where a sample's sub-pixel position fixes
//! its cell (shaders/isrt/common.glsl).
//!
//! Passes per frame (both eyes per dispatch, `z` = eye): `params` → `clear`
//! → `reproject` (one thread per previous cell; the sample lands in the cell
//! its new sub-pixel position falls into; 64-bit `atomicMin` on
//! depth | source index: the closest sample wins) → `gather` (copies the
//! winners) → `trace` (every sample retraced; occluded ones dropped; every
//! empty cell gets a new sample through a random point in it, a miss a
//! background sample: the ray's direction, `sample_cache::background`) → `shade` (one
//! sample per pixel, round robin; demodulated running mean) → `reconstruct`
//! (mean over the pixel's shaded and background samples).
//!
//! Memory per pixel per eye: M² × (16 B first hit + 16 B radiance) × 2
//! (previous / current) + M² × 8 B reservations, plus the per-pixel outputs.

pub use settings::IsrtSettings;

pub mod args;

pub mod settings {
    use serde::Serialize;

    #[derive(Clone, Debug, PartialEq, Serialize)]
    pub struct IsrtSettings {
        /// Cells per pixel side (2, 3 or 4): M² samples per pixel at most.
        pub m: u32,
        /// Retrace tolerance relative to the hit distance (as the sample cache's ε0).
        pub eps0: f32,
    }

    impl Default for IsrtSettings {
        fn default() -> Self {
            IsrtSettings { m: 3, eps0: 1e-3 }
        }
    }

    impl IsrtSettings {
        pub fn validate(&self) -> Result<(), String> {
            if !(2..=4).contains(&self.m) {
                return Err(format!("bad --isrt-m {}: expected 2, 3 or 4", self.m));
            }
            if !(self.eps0 > 0.0 && self.eps0 < 0.1) {
                return Err(format!("bad isrt ε0 {}: expected (0, 0.1)", self.eps0));
            }
            Ok(())
        }
    }
}

use super::reference::backend_shader;
use super::{
    named_counters, FrameInput, FrameParams, FrameStats, Method, OutputBuffers, RayCounts,
    RenderSettings, StereoFrame,
};
use crate::gpu::{
    Buffer, ComputePipeline, DescriptorLayout, DescriptorSet, GpuContext, GpuError, GpuResult,
    Recorder, Resource,
};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

/// Specialization constant id of `M` in shaders/isrt/common.glsl.
const SPEC_M: u32 = 30;
const LOCAL: u32 = 8;

/// Counter slots of common.glsl (`C_*`) with report names.
const COUNTERS: &[(usize, &str)] = &[
    (0, "reprojected_samples"),
    (1, "reproject_offscreen"),
    (2, "kept_samples"),
    (3, "retrace_rays"),
    (4, "retrace_lost"),
    (5, "new_sample_rays"),
    (6, "new_samples"),
    (7, "shaded_samples"),
    (10, "samples"),
    (11, "background_samples"),
];

/// The grid read back from the GPU (current frame), for tests and debugging.
/// Cells are `[eye][gy][gx]` over a (W·M) × (H·M) grid per eye.
pub struct IsrtSnapshot {
    pub m: u32,
    pub width: u32,
    pub height: u32,
    pub first_hits: Vec<[u32; 4]>,
    pub radiance: Vec<[f32; 4]>,
}

impl IsrtSnapshot {
    pub fn grid_width(&self) -> u32 {
        self.width * self.m
    }
    pub fn cells_per_eye(&self) -> usize {
        (self.width * self.m * self.height * self.m) as usize
    }
    /// Index of cell (gx, gy) of `eye`.
    pub fn cell(&self, eye: usize, gx: u32, gy: u32) -> usize {
        eye * self.cells_per_eye() + (gy * self.grid_width() + gx) as usize
    }
    /// The cell holds a surface sample.
    pub fn occupied(&self, cell: usize) -> bool {
        self.first_hits[cell][3] != u32::MAX
    }
    /// The cell holds a background sample (a ray that missed the scene,
    /// [`crate::methods::sample_cache::background`]).
    pub fn background(&self, cell: usize) -> bool {
        crate::methods::sample_cache::background::is_background(self.first_hits[cell])
    }
}

struct Pipelines {
    reproject: ComputePipeline,
    gather: ComputePipeline,
    trace: ComputePipeline,
    shade: ComputePipeline,
    reconstruct: ComputePipeline,
}

pub struct Isrt {
    ctx: Arc<GpuContext>,
    scene: Arc<SceneGpu>,
    settings: RenderSettings,
    isrt: IsrtSettings,
    pipes: Pipelines,
    /// sets[p] reads fh/rad[p] as "previous" and writes [1 − p].
    sets: [DescriptorSet; 2],
    frame: Buffer,
    first_hits: [Buffer; 2],
    radiance: [Buffer; 2],
    claim: Buffer,
    out_color: Buffer,
    out_depth: Buffer,
    out_fh: Buffer,
    out_albedo: Buffer,
    counters: Buffer,
    frames: u64,
}

impl Isrt {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
    ) -> GpuResult<Self> {
        let isrt = settings.isrt.clone();
        isrt.validate().map_err(GpuError::Unsupported)?;
        if !ctx.enabled.buffer_int64_atomics {
            return Err(GpuError::Unsupported(format!(
                "device '{}' lacks shaderBufferInt64Atomics, which isrt's cell reservation needs",
                ctx.caps.name
            )));
        }
        let m2 = (isrt.m * isrt.m) as u64;
        let npix = (settings.width * settings.height) as u64;
        let cells = 2 * npix * m2;
        if npix * m2 > u32::MAX as u64 {
            return Err(GpuError::Unsupported(
                "isrt addresses at most 2^32 cells per eye".into(),
            ));
        }
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("isrt.{name}"), bytes);
        let frame = b("frame", std::mem::size_of::<FrameParams>() as u64)?;
        let first_hits = [b("first_hit0", cells * 16)?, b("first_hit1", cells * 16)?];
        let radiance = [b("radiance0", cells * 16)?, b("radiance1", cells * 16)?];
        let claim = b("claim", cells * 8)?;
        let out_color = b("color", 2 * npix * 16)?;
        let out_depth = b("depth", 2 * npix * 4)?;
        let out_fh = b("out_first_hit", 2 * npix * 16)?;
        let out_albedo = b("albedo", 2 * npix * 16)?;
        let counters = b("counters", 16 * 4)?;
        let layout = DescriptorLayout::buffers(ctx, 11)?;
        let make_set = |p: usize| {
            let q = 1 - p;
            DescriptorSet::new(
                ctx,
                &layout,
                &[
                    Resource::Buffer(&frame),
                    Resource::Buffer(&first_hits[p]),
                    Resource::Buffer(&first_hits[q]),
                    Resource::Buffer(&radiance[p]),
                    Resource::Buffer(&radiance[q]),
                    Resource::Buffer(&claim),
                    Resource::Buffer(&out_color),
                    Resource::Buffer(&out_depth),
                    Resource::Buffer(&out_fh),
                    Resource::Buffer(&out_albedo),
                    Resource::Buffer(&counters),
                ],
            )
        };
        let sets = [make_set(0)?, make_set(1)?];
        let mut spec = settings.spec_constants(scene, env);
        spec.set(SPEC_M, isrt.m);
        let layouts = [scene.layout.clone(), layout];
        let pipe = |name: &str| -> GpuResult<ComputePipeline> {
            ComputePipeline::new(
                ctx,
                &format!("isrt.{name}"),
                backend_shader(&format!("isrt/{name}"), scene)?,
                &layouts,
                16,
                &spec,
            )
        };
        let pipes = Pipelines {
            reproject: pipe("reproject")?,
            gather: pipe("gather")?,
            trace: pipe("trace")?,
            shade: pipe("shade")?,
            reconstruct: pipe("reconstruct")?,
        };
        // Empty grids.
        let mut init = Recorder::new(ctx, 2)?;
        init.pass("isrt.init.first_hits")
            .write(&first_hits[0])
            .write(&first_hits[1])
            .fill(u32::MAX);
        init.pass("isrt.init.radiance")
            .write(&radiance[0])
            .write(&radiance[1])
            .fill(0);
        init.finish()?;
        Ok(Isrt {
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            isrt,
            pipes,
            sets,
            frame,
            first_hits,
            radiance,
            claim,
            out_color,
            out_depth,
            out_fh,
            out_albedo,
            counters,
            frames: 0,
        })
    }

    pub fn settings(&self) -> &IsrtSettings {
        &self.isrt
    }

    /// Reads the current grid back (after `render_frame`).
    pub fn snapshot(&self) -> GpuResult<IsrtSnapshot> {
        let c = (self.frames % 2) as usize;
        Ok(IsrtSnapshot {
            m: self.isrt.m,
            width: self.settings.width,
            height: self.settings.height,
            first_hits: self.first_hits[c].download_pod()?,
            radiance: self.radiance[c].download_pod()?,
        })
    }
}

impl Method for Isrt {
    fn name(&self) -> &'static str {
        "isrt"
    }

    fn render_frame(&mut self, input: &FrameInput) -> GpuResult<StereoFrame> {
        let (w, h) = (self.settings.width, self.settings.height);
        let npix = (w * h) as usize;
        let m = self.isrt.m;
        let parity = (self.frames % 2) as usize;
        let (prev_fh, prev_rad) = (&self.first_hits[parity], &self.radiance[parity]);
        let (cur_fh, cur_rad) = (&self.first_hits[1 - parity], &self.radiance[1 - parity]);
        let params = FrameParams::new(input, w, h, self.settings.seed, self.scene.origin);
        let mut push = Vec::with_capacity(16);
        push.extend(self.isrt.eps0.to_le_bytes());
        push.extend([0u8; 12]);
        let sets = [&self.scene.set, &self.sets[parity]];
        let pixel_groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let cell_groups = [(w * m).div_ceil(LOCAL), (h * m).div_ceil(LOCAL), 2];
        let p = &self.pipes;
        let mut rec = Recorder::new(&self.ctx, 9)?;
        rec.pass("params")
            .write(&self.frame)
            .update(bytemuck::bytes_of(&params));
        rec.pass("clear").write(&self.counters).fill(0);
        rec.pass("clear.claims").write(&self.claim).fill(u32::MAX);
        rec.pass("reproject")
            .read(&self.frame)
            .read(prev_fh)
            .write(&self.claim)
            .write(&self.counters)
            .dispatch(&p.reproject, &sets, &push, cell_groups);
        rec.pass("gather")
            .read(&self.claim)
            .read(prev_fh)
            .read(prev_rad)
            .write(cur_fh)
            .write(cur_rad)
            .write(&self.counters)
            .dispatch(&p.gather, &sets, &push, cell_groups);
        rec.pass("trace")
            .write(cur_fh)
            .write(cur_rad)
            .write(&self.counters)
            .dispatch(&p.trace, &sets, &push, cell_groups);
        rec.pass("shade")
            .read(cur_fh)
            .write(cur_rad)
            .write(&self.counters)
            .dispatch(&p.shade, &sets, &push, pixel_groups);
        rec.pass("reconstruct")
            .read(cur_fh)
            .read(cur_rad)
            .write(&self.out_color)
            .write(&self.out_depth)
            .write(&self.out_fh)
            .write(&self.out_albedo)
            .dispatch(&p.reconstruct, &sets, &push, pixel_groups);
        let passes = rec.finish()?;
        self.frames += 1;

        let outputs = OutputBuffers {
            color: &self.out_color,
            depth: &self.out_depth,
            first_hit: &self.out_fh,
            albedo: &self.out_albedo,
            debug: None,
        };
        let eyes = outputs.read(npix)?;
        let counters: Vec<u32> = self.counters.download_pod()?;
        let mut stats = FrameStats {
            passes,
            rays: RayCounts {
                primary: counters[3] as u64 + counters[5] as u64,
                bounce: counters[8] as u64,
                shadow: counters[9] as u64,
            },
            counters: Default::default(),
        };
        stats.counters = named_counters(&counters, COUNTERS);
        stats.counters.insert(
            "samples_per_pixel".into(),
            counters[10] as f64 / (2 * npix) as f64,
        );
        Ok(StereoFrame {
            width: w,
            height: h,
            eyes,
            stats,
        })
    }

    fn memory_bytes(&self) -> u64 {
        let mut total = self.frame.size + self.claim.size + self.counters.size;
        for b in self.first_hits.iter().chain(&self.radiance) {
            total += b.size;
        }
        for b in [
            &self.out_color,
            &self.out_depth,
            &self.out_fh,
            &self.out_albedo,
        ] {
            total += b.size;
        }
        total
    }
}
