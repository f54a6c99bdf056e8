//! `sample-cache`: the screen-space sample cache of Philippi, Jensen &
//! Frisvad (EGSR 2025), §3.1–3.5 and appendices A, C, D. One cache per eye:
//! N layers of (first hit, radiance record) plus a 32-bit occupancy/visibility
//! mask per pixel, double-buffered so each frame reprojects the previous one.
//!
//! Memory per pixel per eye: 4 B mask + N × (16 B first hit + 16 B radiance),
//! twice (previous and current frame), i.e. 64 B per pixel per layer plus 8 B
//! of masks; plus N × 4 B of slot depths (one copy, with the shading
//! payload), 12 B of depth bounds and the per-pixel outputs.
//!
//! Passes per frame (both eyes in one dispatch each, `z` = eye):
//! `begin` → `clear` → `clear.depth` → `reproject` (→ `reproject.copy` for
//! two-pass) → `select` → `trace.args` → `trace.retrace` → `trace` →
//! (adaptive shading: `shade.count` → `shade.select` → `shade.args` →)
//! `shade` → `reconstruct` (→ `stereo.blend` with stereo blending);
//! docs/ARCHITECTURE.md lists them with what each does.
//! Every pass binds the 28 buffers of src/interface/sample_cache.rs (one
//! binding list for the group, declared in order by [`SampleCache::pass`]);
//! the shared frame loop reads the outputs and counters back.
//!
//! **Visibility only** ([`SampleCache::visibility_only`], used by `hybrid`):
//! the same cache without shading storage (specialization constant
//! `SHADING_STORAGE` = false: radiance records are neither read nor written,
//! their buffers and the shading outputs are 16-byte placeholders). Another
//! method calls [`SampleCache::begin_frame`], records
//! [`SampleCache::record_begun_visibility`] (`begin` … `trace`) into its own
//! recorder, then its own passes on the current cache
//! ([`SampleCache::current_buffers`]);
//! [`SampleCache::visibility_counter_output`] gives it the visibility counters
//! for its own `FrameOutputs` (one batched readback).

pub mod args;
pub mod background;
pub mod heuristics;
pub mod settings;

pub use settings::{Accumulation, Payload, Reproject, Retrace, SampleCacheSettings, Shading};

use super::reference::{backend_shader, optional_backend_shader};
use super::{
    Color, CounterOutput, FrameInput, FrameOutputs, FrameParams, Method, RaySlots, RenderSettings,
};
use crate::gpu::{
    Buffer, ComputePass, ComputePipeline, GpuContext, GpuError, GpuResult, HostReadback, Recorder,
    SpecConstants,
};
use crate::interface::sample_cache::{
    spec as spec_id, SampleCacheCounter, COUNTER_SLOTS, INTERFACE, PUSH,
};
use crate::interface::CounterSlot;
use crate::rt::SceneGpu;
use crate::scene::Environment;
use bytemuck::{Pod, Zeroable};
use std::sync::Arc;

/// Names of the debug views, in the order the reconstruct pass writes them.
pub const DEBUG_VIEWS: [&str; 4] = ["trace-mask", "spp", "shaded", "occupancy"];

const LOCAL: u32 = 8;
const HIST_M: u64 = heuristics::HIST_M as u64;

/// Push constants of every pass (`SAMPLE_CACHE_PUSH`, src/interface/sample_cache.rs).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Push {
    shading_rate: f32,
    fixed_alpha: f32,
    eps0: f32,
    eps1: f32,
    n_target: u32,
    delta: u32,
    blend_mode: u32,
    sharpness: f32,
}
const _: () = assert!(std::mem::size_of::<Push>() == PUSH.size() as usize);

/// The cache's contents read back from the GPU (current frame), for tests
/// and debugging. Indices: mask `[eye][pixel]`, slots `[eye][slot][pixel]`.
pub struct CacheSnapshot {
    pub slots: u32,
    pub width: u32,
    pub height: u32,
    pub masks: Vec<u32>,
    pub first_hits: Vec<[u32; 4]>,
    pub radiance: Vec<[f32; 4]>,
    /// Per pixel: traced slot bits, shaded samples this frame, new samples, edge flag.
    pub pixel_stats: Vec<[u32; 4]>,
    /// Importance histogram `[eye][bucket]` of this frame's shading
    /// candidates, counted after primary tracing by `shade.count` (adaptive
    /// shading only; zeros under uniform shading): every visible sample
    /// except the round-robin sample of base-rate and unshaded pixels.
    pub histogram: Vec<u32>,
    /// Per eye: pixels with visible samples none of which was shaded before
    /// this frame, outside the base-rate pattern (adaptive shading).
    pub unshaded_pixels: [u32; 2],
    /// Per eye: base-rate pixels (one per 4×4 block) with a visible sample.
    pub base_pixels: [u32; 2],
    /// Per eye: pixels with a visible surface sample (adaptive shading's
    /// budget is the rate times these: what uniform shading shades).
    pub covered_pixels: [u32; 2],
    /// Length of this frame's shade list (adaptive shading; uniform
    /// shading has none: its `shade` pass picks each pixel's sample, and
    /// `pixel_stats` says which pixels it shaded).
    pub shade_count: u32,
    pub shade_list: Vec<u32>,
}

impl CacheSnapshot {
    /// An empty cache of `slots` layers over `width` × `height` per eye
    /// (every mask 0, every first hit NO_HIT), for tests to fill and
    /// [`SampleCache::load`].
    pub fn empty(slots: u32, width: u32, height: u32) -> Self {
        let n = (2 * width * height) as usize;
        CacheSnapshot {
            slots,
            width,
            height,
            masks: vec![0; n],
            first_hits: vec![[0, 0, 0, u32::MAX]; n * slots as usize],
            radiance: vec![[0.0; 4]; n * slots as usize],
            pixel_stats: vec![],
            histogram: vec![],
            unshaded_pixels: [0; 2],
            base_pixels: [0; 2],
            covered_pixels: [0; 2],
            shade_count: 0,
            shade_list: vec![],
        }
    }

    pub fn npix(&self) -> usize {
        (self.width * self.height) as usize
    }
    pub fn mask(&self, eye: usize, pixel: usize) -> u32 {
        self.masks[eye * self.npix() + pixel]
    }
    pub fn slot(&self, eye: usize, slot: u32, pixel: usize) -> usize {
        (eye * self.slots as usize + slot as usize) * self.npix() + pixel
    }
    pub fn occupied(&self, m: u32) -> u32 {
        m & ((1u32 << self.slots) - 1)
    }
    pub fn visible(&self, m: u32) -> u32 {
        (m >> self.slots) & ((1u32 << self.slots) - 1)
    }
    /// Slot `slot` of `pixel` holds a background sample ([`background`]).
    pub fn is_background(&self, eye: usize, slot: u32, pixel: usize) -> bool {
        background::is_background(self.first_hits[self.slot(eye, slot, pixel)])
    }
    /// The slots of `bits` that hold surface samples (not background ones).
    pub fn surface(&self, eye: usize, pixel: usize, bits: u32) -> u32 {
        let mut out = bits;
        let mut b = bits;
        while b != 0 {
            let s = b.trailing_zeros();
            b &= b - 1;
            if self.is_background(eye, s, pixel) {
                out &= !(1 << s);
            }
        }
        out
    }
    /// Pixels of `eye` with a visible surface sample: what uniform shading
    /// shades, and what adaptive shading's rate is a fraction of (the CPU
    /// count of shade_select.comp's `covered_pixels`).
    /// The record index ([`Self::slot`]) of every visible surface sample,
    /// both eyes, in eye, pixel and slot order.
    pub fn visible_surface_records(&self) -> Vec<usize> {
        let mut out = Vec::new();
        for e in 0..2 {
            for p in 0..self.npix() {
                let mut bits = self.surface(e, p, self.visible(self.mask(e, p)));
                while bits != 0 {
                    out.push(self.slot(e, bits.trailing_zeros(), p));
                    bits &= bits - 1;
                }
            }
        }
        out
    }

    pub fn covered(&self, eye: usize) -> usize {
        (0..self.npix())
            .filter(|&p| self.surface(eye, p, self.visible(self.mask(eye, p))) != 0)
            .count()
    }
}

/// Raw moments per pixel `[eye][pixel]`: rgb and the total effective sample count in w.
pub struct Moments {
    pub m1: Vec<[f32; 4]>,
    pub m2: Vec<[f32; 4]>,
}

struct Pipelines {
    begin: ComputePipeline,
    reproject: ComputePipeline,
    reproject_copy: Option<ComputePipeline>,
    select: ComputePipeline,
    retrace_args: ComputePipeline,
    retrace: ComputePipeline,
    trace: ComputePipeline,
    /// None for a visibility-only cache.
    shading: Option<ShadingPipelines>,
}

struct ShadingPipelines {
    /// None with `--shading skip` (nothing is shaded).
    shade: Option<ShadePipelines>,
    reconstruct: ComputePipeline,
    stereo_blend: ComputePipeline,
}

/// The passes that shade samples (§3.3, §3.5).
struct ShadePipelines {
    /// Adaptive shading's choice of samples (§3.5); `None` for uniform
    /// shading, whose `shade` pass takes each pixel's round-robin sample
    /// itself (one invocation per pixel, no list).
    adaptive: Option<AdaptiveSelect>,
    shade: ComputePipeline,
}

/// Adaptive shading's passes before `shade` (shade_select.comp, indirect_args.comp).
struct AdaptiveSelect {
    /// Phase 0: the importance histogram of this frame's candidates.
    count: ComputePipeline,
    /// Phase 1: the threshold and the shade list.
    select: ComputePipeline,
    /// The shade list's indirect dispatch.
    args: ComputePipeline,
}

/// The current frame's cache buffers (see [`SampleCache::current_buffers`]).
pub struct CacheBuffers<'a> {
    /// `[eye][pixel]` u32: occupancy bits 0..N−1, visibility bits N..2N−1.
    pub masks: &'a Buffer,
    /// `[eye][slot][pixel]` uvec4 first hits (Listing 1; w = 0xFFFFFFFF: none,
    /// or a background sample, [`background`]).
    pub first_hits: &'a Buffer,
}

pub struct SampleCache {
    ctx: Arc<GpuContext>,
    scene: Arc<SceneGpu>,
    settings: RenderSettings,
    cache: SampleCacheSettings,
    pipes: Pipelines,
    push: Push,
    frame: Buffer,
    masks: [Buffer; 2],
    first_hits: [Buffer; 2],
    radiance: [Buffer; 2],
    depth_min: Buffer,
    depth_max: Buffer,
    hist: Buffer,
    state: Buffer,
    shade_list: Buffer,
    target_src: Buffer,
    out_color: Buffer,
    out_m1: Buffer,
    out_m2: Buffer,
    out_depth: Buffer,
    out_fh: Buffer,
    out_albedo: Buffer,
    counters: Buffer,
    pixel_action: Buffer,
    pixel_stats: Buffer,
    retrace_list: Buffer,
    retrace_found: Buffer,
    /// Dispatch arguments of the retrace (bytes 0..12) and shade (16..28) passes.
    indirect: Buffer,
    /// `[eye][slot][pixel]` f32: each sample's distance from this frame's
    /// eye (written where the sample is placed, read by reconstruction);
    /// part of the shading payload (a placeholder without it).
    slot_depth: Buffer,
    /// The `.subgroup` shader builds are in use.
    subgroup: bool,
    debug: Buffer,
    out_blended: Buffer,
    /// Frames rendered so far (selects the ping-pong parity).
    frames: u64,
    readback: HostReadback,
}

impl SampleCache {
    /// The full method: visibility and shading (the `sample-cache` method).
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
        cache: &SampleCacheSettings,
    ) -> GpuResult<Self> {
        Self::build(ctx, scene, env, settings, cache, true)
    }

    /// The cache without shading storage: reprojection, adaptive retrace and
    /// density control only, for a method that shades the visible samples
    /// itself (`hybrid`). [`Method::render_frame`] refuses to run on it.
    pub fn visibility_only(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
        cache: &SampleCacheSettings,
    ) -> GpuResult<Self> {
        Self::build(ctx, scene, env, settings, cache, false)
    }
}

impl SampleCache {
    fn build(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
        cache: &SampleCacheSettings,
        shading: bool,
    ) -> GpuResult<Self> {
        let cache = cache.clone();
        cache.validate().map_err(GpuError::Unsupported)?;
        if !(ctx.enabled.buffer_int64_atomics && ctx.enabled.shader_int64) {
            return Err(GpuError::Unsupported(format!(
                "device '{}' lacks shaderBufferInt64Atomics or shaderInt64 (64-bit integers), which the sample cache's depth bounds need",
                ctx.caps.name
            )));
        }
        let npix = (settings.width * settings.height) as u64;
        if npix > (1 << 26) {
            return Err(GpuError::Unsupported(
                "the sample cache addresses at most 2^26 pixels per eye".into(),
            ));
        }
        let n = cache.slots as u64;
        let e2 = 2 * npix;
        let two_pass = cache.reproject == Reproject::TwoPass;
        let b =
            |name: &str, bytes: u64| Buffer::storage(ctx, &format!("sample_cache.{name}"), bytes);
        // Buffers only the shading passes use: placeholders when visibility
        // only; the radiance records also without a payload (`--payload none`).
        let sb = |name: &str, bytes: u64| b(name, if shading { bytes } else { 16 });
        let storage = shading && cache.payload == Payload::Radiance;
        let frame = b("frame", std::mem::size_of::<FrameParams>() as u64)?;
        let masks = [b("mask0", e2 * 4)?, b("mask1", e2 * 4)?];
        let first_hits = [b("first_hit0", e2 * n * 16)?, b("first_hit1", e2 * n * 16)?];
        let rb = |name: &str| b(name, if storage { e2 * n * 16 } else { 16 });
        let radiance = [rb("radiance0")?, rb("radiance1")?];
        let slot_depth = b("slot_depth", if storage { e2 * n * 4 } else { 16 })?;
        let depth_min = b("depth_min", e2 * 8)?;
        let depth_max = b("depth_max", e2 * 4)?;
        let hist = b("histogram", 2 * HIST_M * 4)?;
        let state = b("state", STATE_WORDS as u64 * 4)?;
        // The shade list: adaptive shading's only (uniform shading picks
        // each pixel's sample in the shade pass).
        let adaptive = shading && cache.shading == Shading::Adaptive;
        let shade_list = b("shade_list", if adaptive { (e2 * n + e2) * 4 } else { 16 })?;
        let target_src = b("target_src", if two_pass { e2 * n * 4 } else { 16 })?;
        let out_color = sb("color", e2 * 16)?;
        let out_m1 = sb("moment1", e2 * 16)?;
        let out_m2 = sb("moment2", e2 * 16)?;
        let out_depth = sb("depth", e2 * 4)?;
        let out_fh = sb("out_first_hit", e2 * 16)?;
        let out_albedo = sb("albedo", e2 * 16)?;
        let counters = b("counters", COUNTER_SLOTS * 4)?;
        let pixel_action = b("pixel_action", e2 * 16)?;
        let pixel_stats = b("pixel_stats", e2 * 16)?;
        let retrace_list = b("retrace_list", e2 * n * 4)?;
        let retrace_found = b("retrace_found", e2 * 4)?;
        let indirect = Buffer::indirect_args(ctx, "sample_cache.indirect_args", 32)?;
        let debug = sb("debug", 4 * e2 * 16)?;
        let out_blended = sb("blended", e2 * 16)?;

        let mut spec = settings.spec_constants(scene, env);
        spec.set(spec_id::SLOTS, cache.slots)
            .set(spec_id::RETRACE, cache.retrace as u32)
            .set(spec_id::SHADING, cache.shading as u32)
            .set(spec_id::ACCUM, cache.accumulation.mode())
            .flag(spec_id::TWO_PASS, two_pass)
            .flag(spec_id::SHADING_STORAGE, storage)
            .flag(spec_id::DEBUG_VIEWS, cache.debug_views);
        let shared = [scene.layout.clone()];
        // The `.subgroup` build of a shader where it exists and the device
        // can run it (subgroup arithmetic and ballot in compute shaders).
        let subgroup =
            settings.subgroup_ops && ctx.caps.has_subgroup_ops(&["arithmetic", "ballot"]);
        let shader = |name: &str| {
            let sg = format!("sample_cache/{name}.subgroup");
            if subgroup {
                // No `.subgroup` build of this shader: the plain one is the
                // build. One that failed to compile (a scene's run-time
                // shaders) falls back too, but says so (it was silent).
                match optional_backend_shader(&sg, scene) {
                    Ok(Some(spirv)) => return Ok(spirv),
                    Ok(None) => {}
                    Err(e) => eprintln!("warning: {sg}: {e}; using the plain build"),
                }
            }
            backend_shader(&format!("sample_cache/{name}"), scene)
        };
        let pipe_with = |name: &str, label: &str, spec: &SpecConstants| {
            ComputePipeline::with_interface(
                ctx,
                &format!("sample_cache.{label}"),
                shader(name)?,
                &shared,
                &INTERFACE,
                Some(&PUSH),
                spec,
            )
        };
        let pipe = |name: &str| pipe_with(name, name, &spec);
        let args_pipe = |list: u32, label: &str| {
            let mut s = spec.clone();
            s.set(spec_id::ARGS_LIST, list);
            pipe_with("indirect_args", label, &s)
        };
        let pipes = Pipelines {
            begin: pipe("begin")?,
            reproject: pipe("reproject")?,
            reproject_copy: if two_pass {
                Some(pipe("reproject_copy")?)
            } else {
                None
            },
            select: pipe("select")?,
            retrace_args: args_pipe(0, "retrace_args")?,
            retrace: pipe("retrace")?,
            trace: pipe("trace")?,
            shading: if shading {
                Some(ShadingPipelines {
                    shade: if cache.shading == Shading::Skip {
                        None
                    } else {
                        Some(ShadePipelines {
                            adaptive: if cache.shading == Shading::Adaptive {
                                let mut s = spec.clone();
                                s.set(spec_id::SELECT_PHASE, 0);
                                Some(AdaptiveSelect {
                                    count: pipe_with("shade_select", "shade_count", &s)?,
                                    select: pipe("shade_select")?,
                                    args: args_pipe(1, "shade_args")?,
                                })
                            } else {
                                None
                            },
                            shade: pipe("shade")?,
                        })
                    },
                    reconstruct: pipe("reconstruct")?,
                    stereo_blend: pipe("stereo_blend")?,
                })
            } else {
                None
            },
        };

        // Empty caches; importance bounds "unset" so the first frame uses defaults.
        let mut init = Recorder::new(ctx, 8)?;
        init.pass("sample_cache.init")
            .write(&masks[0])
            .write(&masks[1])
            .write(&radiance[0])
            .write(&radiance[1])
            .write(&hist)
            .fill(0);
        init.pass("sample_cache.init.first_hits")
            .write(&first_hits[0])
            .write(&first_hits[1])
            .fill(u32::MAX);
        // The importance bounds' minima start at +∞ (common.glsl's layout).
        let mut state_init = [0u32; STATE_WORDS];
        state_init[..2].fill(u32::MAX);
        state_init[4..6].fill(u32::MAX);
        init.pass("sample_cache.init.state")
            .write(&state)
            .update(bytemuck::cast_slice(&state_init));
        init.finish()?;

        Ok(SampleCache {
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            push: push_constants(&cache),
            cache,
            pipes,
            frame,
            masks,
            first_hits,
            radiance,
            depth_min,
            depth_max,
            hist,
            state,
            shade_list,
            target_src,
            out_color,
            out_m1,
            out_m2,
            out_depth,
            out_fh,
            out_albedo,
            counters,
            pixel_action,
            pixel_stats,
            retrace_list,
            retrace_found,
            indirect,
            slot_depth,
            debug,
            out_blended,
            subgroup,
            frames: 0,
            readback: HostReadback::new(),
        })
    }

    /// Index (0/1) of the buffers holding the current frame's cache.
    fn cur(&self) -> usize {
        // Frame f reads buffers[f % 2] and writes buffers[1 − f % 2]; after
        // begin_frame increments `frames`, the current (latest) cache is in:
        (self.frames % 2) as usize
    }

    /// Reads the current cache back (after `render_frame`).
    pub fn snapshot(&self) -> GpuResult<CacheSnapshot> {
        let c = self.cur();
        let state: Vec<u32> = self.state.download_pod()?;
        Ok(CacheSnapshot {
            slots: self.cache.slots,
            width: self.settings.width,
            height: self.settings.height,
            masks: self.masks[c].download_pod()?,
            first_hits: self.first_hits[c].download_pod()?,
            radiance: self.radiance[c].download_pod()?,
            pixel_stats: self.pixel_stats.download_pod()?,
            histogram: self.hist.download_pod()?,
            unshaded_pixels: [state[10], state[11]],
            base_pixels: [state[12], state[13]],
            covered_pixels: [state[16], state[17]],
            shade_count: state[8],
            shade_list: self.shade_list.download_pod()?,
        })
    }

    /// Replaces the current cache — what the next frame reprojects — with
    /// `snap`'s masks, first hits and radiance records (tests construct
    /// cache contents this way; the other fields of `snap` are ignored).
    pub fn load(&mut self, snap: &CacheSnapshot) -> GpuResult<()> {
        let c = self.cur();
        let expect = (2 * self.settings.width * self.settings.height) as usize;
        let n = expect * self.cache.slots as usize;
        if snap.masks.len() != expect
            || snap.first_hits.len() != n
            || (self.has_radiance() && snap.radiance.len() != n)
        {
            return Err(GpuError::Unsupported(
                "SampleCache::load: the snapshot's size does not match the cache".into(),
            ));
        }
        self.masks[c].upload(bytemuck::cast_slice(&snap.masks))?;
        self.first_hits[c].upload(bytemuck::cast_slice(&snap.first_hits))?;
        if self.has_radiance() {
            self.radiance[c].upload(bytemuck::cast_slice(&snap.radiance))?;
        }
        Ok(())
    }

    /// Per-pixel raw moments μ1, μ2 (Eq. 5–6; w = total effective count) of the last frame.
    pub fn moments(&self) -> GpuResult<Moments> {
        Ok(Moments {
            m1: self.out_m1.download_pod()?,
            m2: self.out_m2.download_pod()?,
        })
    }

    /// Per-pixel colour of the last frame as reconstruction left it, before
    /// the stereo blend (`[eye · w·h + pixel]`; the frame's radiance is the
    /// blended image when blending is on).
    pub fn unblended_colour(&self) -> GpuResult<Vec<[f32; 4]>> {
        self.out_color.download_pod()
    }

    /// A compute pass of this group running `pipe`, with the scene's set
    /// and all 28 buffers of src/interface/sample_cache.rs declared in
    /// binding order — `prev` (0/1) the ping-pong half read as the previous
    /// frame's cache, `1 − prev` the one written — and the push constants.
    /// The group has one binding list, so every pass declares every buffer;
    /// the pass builder binds and tracks only those its shader uses, with the
    /// access the shader really makes (reflected from its SPIR-V), so the
    /// barriers between passes are the real hazards.
    fn pass<'r, 'a>(
        &'a self,
        rec: &'r mut Recorder<'a>,
        name: &str,
        pipe: &'a ComputePipeline,
        prev: usize,
    ) -> ComputePass<'r, 'a> {
        let cur = 1 - prev;
        rec.compute(name, pipe)
            .shared(&self.scene.set)
            .read(&self.frame)
            .read(&self.masks[prev])
            .write(&self.masks[cur])
            .read(&self.first_hits[prev])
            .write(&self.first_hits[cur])
            .read(&self.radiance[prev])
            .write(&self.radiance[cur])
            .write(&self.depth_min)
            .write(&self.depth_max)
            .write(&self.hist)
            .write(&self.state)
            .write(&self.shade_list)
            .write(&self.target_src)
            .write(&self.out_color)
            .write(&self.out_m1)
            .write(&self.out_m2)
            .write(&self.out_depth)
            .write(&self.out_fh)
            .write(&self.out_albedo)
            .write(&self.counters)
            .write(&self.pixel_action)
            .write(&self.pixel_stats)
            .write(&self.debug)
            .write(&self.out_blended)
            .write(&self.retrace_list)
            .write(&self.retrace_found)
            .write(&self.indirect)
            .write(&self.slot_depth)
            .push(&self.push)
    }

    /// Records this frame's visibility passes (`params`, `begin`, `clear`,
    /// `reproject`, `select`, `trace`) into `rec` and returns the index of the
    /// buffers that hold this frame's cache ([`Self::current_buffers`]).
    /// Writes `input` into [`Self::frame_buffer`]. For a method that records
    /// from `&'a mut self` (the shared frame loop), where nothing can be
    /// changed after recording: call [`Self::begin_frame`] first, then this.
    pub fn record_begun_visibility<'a>(
        &'a self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
    ) -> GpuResult<usize> {
        let cur = self.cur();
        self.record_visibility_from(rec, input, 1 - cur)?;
        Ok(cur)
    }

    /// The visibility passes of a frame that reads the cache `prev` (0/1).
    fn record_visibility_from<'a>(
        &'a self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
        prev: usize,
    ) -> GpuResult<()> {
        let (w, h) = (self.settings.width, self.settings.height);
        let cur_mask = &self.masks[1 - prev];
        let mut params = FrameParams::new(input, w, h, self.settings.seed, self.scene.origin);
        params.size_seed[3] = input.index;
        let groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let p = &self.pipes;
        rec.pass("params")
            .write(&self.frame)
            .update(bytemuck::bytes_of(&params));
        self.pass(rec, "begin", &p.begin, prev)
            .dispatch([1, 1, 1])?;
        rec.pass("clear")
            .write(cur_mask)
            .write(&self.depth_max)
            .fill(0);
        rec.pass("clear.depth")
            .write(&self.depth_min)
            .fill(u32::MAX);
        if p.reproject_copy.is_some() {
            rec.pass("clear.targets").write(&self.target_src).fill(0);
        }
        self.pass(rec, "reproject", &p.reproject, prev)
            .dispatch(groups)?;
        if let Some(copy) = &p.reproject_copy {
            self.pass(rec, "reproject.copy", copy, prev)
                .dispatch(groups)?;
        }
        self.pass(rec, "select", &p.select, prev).dispatch(groups)?;
        self.pass(rec, "trace.args", &p.retrace_args, prev)
            .dispatch([1, 1, 1])?;
        self.pass(rec, "trace.retrace", &p.retrace, prev)
            .dispatch_indirect(&self.indirect, 0)?;
        self.pass(rec, "trace", &p.trace, prev).dispatch(groups)?;
        Ok(())
    }

    /// Starts a frame to be recorded with [`Self::record_begun_visibility`]
    /// (flips the ping-pong parity before recording; [`Self::snapshot`]
    /// reads this frame's cache once it has run).
    pub fn begin_frame(&mut self) {
        self.frames += 1;
    }

    /// The mask and first-hit buffers with index `i` (0 or 1). During a frame
    /// the current cache is the index [`Self::record_begun_visibility`] returned;
    /// between frames it is `frames rendered % 2`. A method that binds them in
    /// descriptor sets builds one set per index.
    pub fn current_buffers(&self, i: usize) -> CacheBuffers<'_> {
        CacheBuffers {
            masks: &self.masks[i],
            first_hits: &self.first_hits[i],
        }
    }

    /// The per-frame camera buffer (`FrameBuf` of camera.glsl), written by
    /// [`Self::record_begun_visibility`]'s `params` pass.
    pub fn frame_buffer(&self) -> &Buffer {
        &self.frame
    }

    /// The visibility counters (`retrace_rays`, `new_sample_rays`,
    /// `visible_samples`, ...) for the shared frame loop's readback, for a
    /// method that records [`Self::record_begun_visibility`] and returns its
    /// own `FrameOutputs`: every reported slot but `shaded_samples`,
    /// `visible_samples_per_pixel`, and retrace + new-sample + background
    /// rays as primary rays.
    pub fn visibility_counter_output(&self) -> CounterOutput<'_> {
        use SampleCacheCounter::*;
        let mut c = CounterOutput::of::<SampleCacheCounter>(&self.counters)
            .rays(RaySlots::of(&[RetraceRays, NewRays, BgRays], &[], &[]))
            .per_pixel(Visible, "visible_samples_per_pixel");
        c.report.retain(|(slot, _)| *slot != Shaded.slot());
        c
    }

    pub fn settings(&self) -> &SampleCacheSettings {
        &self.cache
    }

    /// True when the cache entries carry the radiance record (a shading
    /// cache with `--payload radiance`); false for a visibility-only cache
    /// and `--payload none`, whose entries are the 128-bit first hits alone.
    pub fn has_radiance(&self) -> bool {
        self.pipes.shading.is_some() && self.cache.payload == Payload::Radiance
    }

    /// Bytes of one ping-pong half of the cache (mask, first hits and
    /// radiance records as allocated: a 16-byte placeholder for the records
    /// without radiance).
    pub fn cache_bytes(&self) -> u64 {
        self.masks[0].size + self.first_hits[0].size + self.radiance[0].size
    }

    /// True when the pipelines use the subgroup-operation builds (the
    /// settings allow it and the device supports subgroup arithmetic and ballot).
    pub fn uses_subgroup_ops(&self) -> bool {
        self.subgroup
    }
}

/// Words of the `state` buffer (layout: shaders/sample_cache/common.glsl).
const STATE_WORDS: usize = 18;

/// The push constants of `c` (the same for every pass and frame).
fn push_constants(c: &SampleCacheSettings) -> Push {
    let blend_mode = match c.stereo_blend {
        crate::stereo::BlendMode::None => 0,
        crate::stereo::BlendMode::Moments => 1,
        crate::stereo::BlendMode::Neighbourhood => 2,
    };
    Push {
        shading_rate: c.shading_rate,
        fixed_alpha: c.accumulation.fixed_alpha(),
        eps0: c.eps0,
        eps1: c.eps1,
        n_target: c.n_target,
        delta: c.delta,
        blend_mode,
        sharpness: c.sharpness,
    }
}

impl Method for SampleCache {
    fn name(&self) -> &'static str {
        "sample-cache"
    }

    fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>> {
        if self.pipes.shading.is_none() {
            return Err(GpuError::Unsupported(
                "a visibility-only sample cache does not shade; render it through `hybrid`".into(),
            ));
        }
        self.begin_frame();
        let this: &'a SampleCache = self;
        let Some(sp) = &this.pipes.shading else {
            unreachable!("checked above")
        };
        let (w, h) = (this.settings.width, this.settings.height);
        let prev = 1 - this.record_begun_visibility(rec, input)?;
        let groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        if let Some(shade) = &sp.shade {
            match &shade.adaptive {
                Some(a) => {
                    this.pass(rec, "shade.count", &a.count, prev)
                        .dispatch(groups)?;
                    this.pass(rec, "shade.select", &a.select, prev)
                        .dispatch(groups)?;
                    // shade.comp runs over the list's length (indirect dispatch).
                    this.pass(rec, "shade.args", &a.args, prev)
                        .dispatch([1, 1, 1])?;
                    this.pass(rec, "shade", &shade.shade, prev)
                        .dispatch_indirect(&this.indirect, 16)?;
                }
                // Uniform: one invocation per pixel (64 per group, x the
                // pixel, y the eye; groups capped at 65535, the smallest
                // maxComputeWorkGroupCount[0], the shader striding over the
                // rest), each shading its pixel's round-robin sample
                // (shade.comp).
                None => {
                    this.pass(rec, "shade", &shade.shade, prev).dispatch([
                        (w * h).div_ceil(64).min(65535),
                        2,
                        1,
                    ])?;
                }
            }
        }
        this.pass(rec, "reconstruct", &sp.reconstruct, prev)
            .dispatch(groups)?;
        let blend = this.cache.stereo_blend != crate::stereo::BlendMode::None;
        if blend {
            this.pass(rec, "stereo.blend", &sp.stereo_blend, prev)
                .dispatch(groups)?;
        }
        use SampleCacheCounter::*;
        Ok(FrameOutputs {
            width: w,
            height: h,
            color: Color::Radiance(if blend {
                &this.out_blended
            } else {
                &this.out_color
            }),
            depth: &this.out_depth,
            first_hit: &this.out_fh,
            albedo: &this.out_albedo,
            debug: this
                .cache
                .debug_views
                .then_some((&this.debug, &DEBUG_VIEWS[..])),
            counters: vec![CounterOutput::of::<SampleCacheCounter>(&this.counters)
                .rays(RaySlots::of(
                    &[RetraceRays, NewRays, BgRays],
                    &[BounceRays],
                    &[ShadowRays],
                ))
                .per_pixel(Visible, "visible_samples_per_pixel")],
            host_counters: Default::default(),
            readback: &this.readback,
        })
    }

    fn memory_bytes(&self) -> u64 {
        let mut total = self.frame.size
            + self.depth_min.size
            + self.depth_max.size
            + self.hist.size
            + self.state.size;
        for b in self
            .masks
            .iter()
            .chain(&self.first_hits)
            .chain(&self.radiance)
        {
            total += b.size;
        }
        for b in [
            &self.shade_list,
            &self.target_src,
            &self.out_color,
            &self.out_m1,
            &self.out_m2,
            &self.out_depth,
            &self.out_fh,
            &self.out_albedo,
            &self.counters,
            &self.pixel_action,
            &self.pixel_stats,
            &self.retrace_list,
            &self.retrace_found,
            &self.indirect,
            &self.slot_depth,
            &self.debug,
            &self.out_blended,
        ] {
            total += b.size;
        }
        total
    }
}
