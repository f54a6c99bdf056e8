//! `isrt`: interactive stable ray tracing (Dal Corso et al. 2017) in the
//! layout the sample-cache paper compares against (Fig. 10): per eye an M × M
//! super-resolution grid per pixel where a sample's sub-pixel position fixes
//! its cell (shaders/isrt/common.glsl).
//!
//! Passes per frame (both eyes per dispatch, `z` = eye): `params` → `clear`
//! → `reproject` (one thread per previous cell; the sample lands in the cell
//! its new sub-pixel position falls into; 64-bit `atomicMin` on
//! depth | source index: the closest sample wins) → `gather` (copies the
//! winners) → `trace` (`--isrt-retrace every`, default: every sample
//! retraced; one behind a closer hit is replaced by that hit; every cell
//! left empty by the reprojection gets a new sample
//! through a random point in it, a miss a background sample: the ray's
//! direction, `sample_cache::background`; `--isrt-retrace one`, the paper's
//! Fig. 10 configuration: one sample per pixel retraced, empty cells filled
//! up to `--isrt-n-target`, shaders/isrt/trace_pixel.comp) → `shade` (one
//! sample per pixel, round robin; the radiance accumulated as the sample
//! cache's records, `--accumulation`) → `reconstruct` (coverage: the
//! shaded surface samples' mean for the surface samples' share of the
//! pixel, the environment for the background samples').
//!
//! Memory per pixel per eye: M² × (16 B first hit + 16 B radiance) × 2
//! (previous / current) + M² × 8 B reservations, plus the per-pixel outputs.

pub use settings::{IsrtRetrace, IsrtSettings};

pub mod args;

pub mod settings {
    use serde::Serialize;
    use std::str::FromStr;

    /// `--isrt-retrace`: which samples are retraced each frame.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum IsrtRetrace {
        /// Every sample, every frame; every empty cell filled (trace.comp).
        Every,
        /// One sample per pixel per frame, round robin; empty cells filled
        /// up to the density target `n_target` (trace_pixel.comp): the
        /// sample-cache paper's Fig. 10 configuration.
        OnePerPixel,
    }

    impl FromStr for IsrtRetrace {
        type Err = String;
        fn from_str(s: &str) -> Result<Self, String> {
            match s {
                "every" => Ok(IsrtRetrace::Every),
                "one" => Ok(IsrtRetrace::OnePerPixel),
                other => Err(format!(
                    "bad --isrt-retrace '{other}': expected every or one"
                )),
            }
        }
    }

    #[derive(Clone, Debug, PartialEq, Serialize)]
    pub struct IsrtSettings {
        /// Cells per pixel side (2, 3 or 4): M² samples per pixel at most.
        pub m: u32,
        /// Retrace tolerance relative to the hit distance (orthographic eyes:
        /// to the view's half height), as the sample cache's ε0.
        pub eps0: f32,
        pub retrace: IsrtRetrace,
        /// With [`IsrtRetrace::OnePerPixel`]: empty cells are filled until the
        /// pixel holds this many samples (0 = every cell; at most M²).
        pub n_target: u32,
        /// How shade.comp averages a cell's paths: the sample cache's
        /// `--accumulation` (Fig. 10 compares the two alike).
        pub accumulation: crate::methods::sample_cache::Accumulation,
    }

    impl Default for IsrtSettings {
        fn default() -> Self {
            IsrtSettings {
                m: 3,
                eps0: 1e-3,
                retrace: IsrtRetrace::Every,
                n_target: 0,
                accumulation: crate::methods::sample_cache::Accumulation::RunningMean,
            }
        }
    }

    impl IsrtSettings {
        /// The paper's Fig. 10 configuration for `m` (3 or 4, the caption's
        /// M): one sample per pixel retraced, no adaptive sampling, fill to
        /// the caption's density target for M² samples per pixel: n_target
        /// = 4 for 9 (M = 3), 6 for 16 (M = 4), as experiments/fig10-isrt.toml
        /// runs them. (Until session 48 it gave 4 for every M.)
        pub fn fig10(m: u32) -> Self {
            let n_target = match m {
                3 => 4,
                4 => 6,
                _ => panic!("Fig. 10 has M = 3 and M = 4, not {m}"),
            };
            IsrtSettings {
                m,
                retrace: IsrtRetrace::OnePerPixel,
                n_target,
                ..Default::default()
            }
        }

        pub fn validate(&self) -> Result<(), String> {
            if !(2..=4).contains(&self.m) {
                return Err(format!("bad --isrt-m {}: expected 2, 3 or 4", self.m));
            }
            if !(self.eps0 > 0.0 && self.eps0 < 0.1) {
                return Err(format!("bad isrt ε0 {}: expected (0, 0.1)", self.eps0));
            }
            if self.n_target > self.m * self.m {
                return Err(format!(
                    "bad --isrt-n-target {}: expected at most M² = {} cells",
                    self.n_target,
                    self.m * self.m
                ));
            }
            if self.n_target > 0 && self.retrace == IsrtRetrace::Every {
                return Err(format!(
                    "bad --isrt-n-target {}: a density target needs --isrt-retrace one (every fills every cell)",
                    self.n_target
                ));
            }
            Ok(())
        }
    }
}

use super::reference::backend_shader;
use super::{
    Color, CounterOutput, FrameInput, FrameOutputs, FrameParams, Method, RaySlots, RenderSettings,
};
use crate::gpu::{
    Buffer, ComputePass, ComputePipeline, GpuContext, GpuError, GpuResult, HostReadback, Recorder,
};
use crate::interface::isrt::{IsrtCounter, INTERFACE, PUSH, SPEC_M};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use bytemuck::{Pod, Zeroable};
use std::sync::Arc;

const LOCAL: u32 = 8;

/// Push constants of every isrt pass (`ISRT_PUSH`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct IsrtPush {
    eps0: f32,
    /// trace_pixel.comp's density target (0 = every cell).
    n_target: u32,
    /// shade.comp's `--accumulation` (`Accumulation::mode`, `fixed_alpha`).
    accum_mode: u32,
    fixed_alpha: f32,
}
const _: () = assert!(std::mem::size_of::<IsrtPush>() == PUSH.size() as usize);

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
    frame: Buffer,
    first_hits: [Buffer; 2],
    radiance: [Buffer; 2],
    claim: Buffer,
    out_color: Buffer,
    out_depth: Buffer,
    out_fh: Buffer,
    out_albedo: Buffer,
    counters: Buffer,
    readback: HostReadback,
    frames: u64,
}

impl Isrt {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
        isrt: &IsrtSettings,
    ) -> GpuResult<Self> {
        let isrt = isrt.clone();
        isrt.validate().map_err(GpuError::Unsupported)?;
        if !(ctx.enabled.buffer_int64_atomics && ctx.enabled.shader_int64) {
            return Err(GpuError::Unsupported(format!(
                "device '{}' lacks shaderBufferInt64Atomics or shaderInt64 (64-bit integers), which isrt's cell reservation needs",
                ctx.caps.name
            )));
        }
        let m2 = (isrt.m * isrt.m) as u64;
        let npix = (settings.width * settings.height) as u64;
        let cells = 2 * npix * m2;
        // common.glsl cell_index counts both eyes' cells in one uint.
        if cells > u32::MAX as u64 {
            return Err(GpuError::Unsupported(format!(
                "isrt addresses at most 2^32 cells, both eyes together: {}x{} with M = {} has {cells}",
                settings.width, settings.height, isrt.m
            )));
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
        let counters = b(
            "counters",
            <IsrtCounter as crate::interface::CounterSlot>::ALL.len() as u64 * 4,
        )?;
        let mut spec = settings.spec_constants(scene, env);
        spec.set(SPEC_M, isrt.m);
        let shared = [scene.layout.clone()];
        let pipe = |name: &str| -> GpuResult<ComputePipeline> {
            ComputePipeline::with_interface(
                ctx,
                &format!("isrt.{name}"),
                backend_shader(&format!("isrt/{name}"), scene)?,
                &shared,
                &INTERFACE,
                Some(&PUSH),
                &spec,
            )
        };
        let pipes = Pipelines {
            reproject: pipe("reproject")?,
            gather: pipe("gather")?,
            trace: match isrt.retrace {
                IsrtRetrace::Every => pipe("trace")?,
                IsrtRetrace::OnePerPixel => pipe("trace_pixel")?,
            },
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
            frame,
            first_hits,
            radiance,
            claim,
            out_color,
            out_depth,
            out_fh,
            out_albedo,
            counters,
            readback: HostReadback::new(),
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

    /// Replaces the current grid — what the next frame reprojects — with
    /// `snap`'s first hits and radiance records (tests construct grid
    /// contents this way, as `SampleCache::load`).
    pub fn load(&mut self, snap: &IsrtSnapshot) -> GpuResult<()> {
        let c = (self.frames % 2) as usize;
        let cells =
            2 * (self.settings.width * self.settings.height * self.isrt.m * self.isrt.m) as usize;
        if snap.m != self.isrt.m || snap.first_hits.len() != cells || snap.radiance.len() != cells {
            return Err(GpuError::Unsupported(
                "Isrt::load: the snapshot's size does not match the grid".into(),
            ));
        }
        self.first_hits[c].upload(bytemuck::cast_slice(&snap.first_hits))?;
        self.radiance[c].upload(bytemuck::cast_slice(&snap.radiance))?;
        Ok(())
    }
}

impl Isrt {
    /// A pass of `pipeline` with every binding of src/interface/isrt.rs
    /// declared (one binding list for all five shaders), `parity` choosing
    /// which grid is the previous frame's.
    fn pass<'r, 'a>(
        &'a self,
        rec: &'r mut Recorder<'a>,
        name: &str,
        pipeline: &'a ComputePipeline,
        parity: usize,
    ) -> ComputePass<'r, 'a> {
        rec.compute(name, pipeline)
            .shared(&self.scene.set)
            .read(&self.frame)
            .read(&self.first_hits[parity])
            .write(&self.first_hits[1 - parity])
            .read(&self.radiance[parity])
            .write(&self.radiance[1 - parity])
            .write(&self.claim)
            .write(&self.out_color)
            .write(&self.out_depth)
            .write(&self.out_fh)
            .write(&self.out_albedo)
            .write(&self.counters)
            .push(&IsrtPush {
                eps0: self.isrt.eps0,
                n_target: self.isrt.n_target,
                accum_mode: self.isrt.accumulation.mode(),
                fixed_alpha: self.isrt.accumulation.fixed_alpha(),
            })
    }
}

impl Method for Isrt {
    fn name(&self) -> &'static str {
        "isrt"
    }

    fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>> {
        let parity = (self.frames % 2) as usize;
        self.frames += 1;
        let this: &'a Isrt = self;
        let (w, h) = (this.settings.width, this.settings.height);
        let m = this.isrt.m;
        let params = FrameParams::new(input, w, h, this.settings.seed, this.scene.origin);
        let pixel_groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let cell_groups = [(w * m).div_ceil(LOCAL), (h * m).div_ceil(LOCAL), 2];
        let p = &this.pipes;
        rec.pass("params")
            .write(&this.frame)
            .update(bytemuck::bytes_of(&params));
        rec.pass("clear").write(&this.counters).fill(0);
        rec.pass("clear.claims").write(&this.claim).fill(u32::MAX);
        this.pass(rec, "reproject", &p.reproject, parity)
            .dispatch(cell_groups)?;
        this.pass(rec, "gather", &p.gather, parity)
            .dispatch(cell_groups)?;
        let trace_groups = match this.isrt.retrace {
            IsrtRetrace::Every => cell_groups,
            IsrtRetrace::OnePerPixel => pixel_groups,
        };
        this.pass(rec, "trace", &p.trace, parity)
            .dispatch(trace_groups)?;
        this.pass(rec, "shade", &p.shade, parity)
            .dispatch(pixel_groups)?;
        this.pass(rec, "reconstruct", &p.reconstruct, parity)
            .dispatch(pixel_groups)?;
        use IsrtCounter::*;
        Ok(FrameOutputs {
            width: w,
            height: h,
            color: Color::Radiance(&this.out_color),
            depth: &this.out_depth,
            first_hit: &this.out_fh,
            albedo: &this.out_albedo,
            debug: None,
            counters: vec![CounterOutput::of::<IsrtCounter>(&this.counters)
                .rays(RaySlots::of(
                    &[RetraceRays, NewRays],
                    &[BounceRays],
                    &[ShadowRays],
                ))
                .per_pixel(Samples, "samples_per_pixel")],
            host_counters: Default::default(),
            readback: &this.readback,
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
