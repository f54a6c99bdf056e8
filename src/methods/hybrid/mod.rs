//! `hybrid`: the sample cache without shading storage and the hash cache
//! (paper §4, "Hybrid"). The sample cache ([`SampleCache::visibility_only`])
//! keeps stable, adaptively retraced first hits per pixel; their radiance
//! comes from the hash cache's table, looked up per visible sample at the
//! hash cache's level of detail L and at the parent level L + 1.
//!
//! Per frame (both eyes per dispatch, `z` = eye):
//! * the sample cache's visibility passes (`params`, `begin`, `clear`,
//!   `reproject`, `select`, `trace`; `RenderSettings.cache` applies);
//! * `hybrid.clear` (counters);
//! * `hybrid.reserve` (`shaders/hybrid/reserve.comp`): per pixel one
//!   visible sample, round robin by frame index, and one of its two levels,
//!   chosen by a fair coin, is found or reserved in the table;
//! * `hybrid.update`: `shaders/hash_cache/update.comp` unchanged — the
//!   updater of each touched entry traces one secondary path from the
//!   sample's stored first hit (one path per pixel at most);
//! * `hybrid.resolve` (`shaders/hybrid/resolve.comp`): every visible sample
//!   finds (never inserts) both levels; sample colour = base colour × mean of
//!   the levels holding radiance + emission; pixel colour = mean over its
//!   samples;
//! * `diag.hybrid.count` (`hash_cache/count.comp`, live entries; a statistic
//!   left out of the frame time) → `taa`
//!   ([`crate::methods::hash_cache::Taa`], as the hash cache, unless
//!   `--hash-no-taa`).
//!
//! Cost of the lookups: 2 × (visible samples per pixel) probe walks per
//! pixel in `resolve` (≈ 8 at n_target = 4) and one in `reserve`; one
//! secondary path per pixel at most. Memory: the visibility-only sample
//! cache, the table (24 B per entry) and the hash cache's per-pixel buffers
//! and TAA history.

use super::hash_cache::{self, HashCacheSettings, Taa};
use super::reference::backend_shader;
use super::{
    FrameInput, FrameStats, Method, OutputBuffers, RayCounts, RenderSettings, SampleCache,
    StereoFrame,
};
use crate::gpu::{
    Buffer, ComputePipeline, DescriptorLayout, DescriptorSet, GpuContext, GpuError, GpuResult,
    Recorder, Resource,
};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

/// Counter slots of `shaders/hybrid/common.glsl` (after the hash cache's), with report names.
const COUNTERS: &[(usize, &str)] = &[
    (11, "samples_looked_up"),
    (12, "both_level_hits"),
    (13, "fine_level_only"),
    (14, "coarse_level_only"),
    (15, "no_level_hits"),
    (16, "updates_fine_level"),
    (17, "updates_coarse_level"),
];
const COUNTER_SLOTS: u64 = 32;
/// Specialization constant id of the sample cache's slot count (N_SLOTS).
const SPEC_SLOTS: u32 = 20;
const LOCAL: u32 = 8;

struct Pipelines {
    reserve: ComputePipeline,
    update: ComputePipeline,
    resolve: ComputePipeline,
    count: ComputePipeline,
}

pub struct Hybrid {
    ctx: Arc<GpuContext>,
    scene: Arc<SceneGpu>,
    settings: RenderSettings,
    hash: HashCacheSettings,
    cache: SampleCache,
    pipes: Pipelines,
    /// sets[i] binds the sample cache's buffers with index i as the current cache.
    sets: [DescriptorSet; 2],
    keys: Buffer,
    cells: Buffer,
    pix_hit: Buffer,
    pix_ray: Buffer,
    pix_cell: Buffer,
    fallback: Buffer,
    color: Buffer,
    out_depth: Buffer,
    out_fh: Buffer,
    out_albedo: Buffer,
    position: Buffer,
    counters: Buffer,
    debug: Buffer,
    taa: Taa,
    /// Frames rendered so far; frame k stamps entries with (k + 1) mod 2^32.
    frames: u64,
}

impl Hybrid {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
    ) -> GpuResult<Self> {
        let mut hash = settings.hash.clone();
        hash.validate().map_err(GpuError::Unsupported)?;
        // The hash cache's debug views are not produced here.
        hash.debug_views = false;
        let cache = SampleCache::visibility_only(ctx, scene, env, settings)?;
        let e2 = 2 * (settings.width * settings.height) as u64;
        let cap = hash.capacity as u64;
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("hybrid.{name}"), bytes);
        let keys = b("keys", cap * 8)?;
        let cells = b("cells", cap * 16)?;
        let pix_hit = b("pix_hit", e2 * 16)?;
        let pix_ray = b("pix_ray", e2 * 16)?;
        let pix_cell = b("pix_cell", e2 * 16)?;
        let fallback = b("fallback", e2 * 16)?;
        let color = b("color", e2 * 16)?;
        let out_depth = b("depth", e2 * 4)?;
        let out_fh = b("first_hit", e2 * 16)?;
        let out_albedo = b("albedo", e2 * 16)?;
        let position = b("position", e2 * 16)?;
        let counters = b("counters", COUNTER_SLOTS * 4)?;
        let debug = b("debug", 16)?;
        let frame = cache.frame_buffer();
        // Bindings 0..13 as shaders/hash_cache/common.glsl, 14..15 the current sample cache.
        let layout = DescriptorLayout::buffers(ctx, 16)?;
        let make_set = |i: usize| {
            let cur = cache.current_buffers(i);
            DescriptorSet::new(
                ctx,
                &layout,
                &[
                    Resource::Buffer(frame),
                    Resource::Buffer(&keys),
                    Resource::Buffer(&cells),
                    Resource::Buffer(&pix_hit),
                    Resource::Buffer(&pix_ray),
                    Resource::Buffer(&pix_cell),
                    Resource::Buffer(&fallback),
                    Resource::Buffer(&color),
                    Resource::Buffer(&out_depth),
                    Resource::Buffer(&out_fh),
                    Resource::Buffer(&out_albedo),
                    Resource::Buffer(&position),
                    Resource::Buffer(&counters),
                    Resource::Buffer(&debug),
                    Resource::Buffer(cur.masks),
                    Resource::Buffer(cur.first_hits),
                ],
            )
        };
        let sets = [make_set(0)?, make_set(1)?];
        let mut spec = settings.spec_constants(scene, env);
        spec.set(SPEC_SLOTS, settings.cache.slots);
        let layouts = [scene.layout.clone(), layout];
        let pipe = |name: &str| -> GpuResult<ComputePipeline> {
            ComputePipeline::new(
                ctx,
                &format!("hybrid.{}", name.rsplit('/').next().unwrap_or(name)),
                backend_shader(name, scene)?,
                &layouts,
                32,
                &spec,
            )
        };
        let pipes = Pipelines {
            reserve: pipe("hybrid/reserve")?,
            update: pipe("hash_cache/update")?,
            resolve: pipe("hybrid/resolve")?,
            count: pipe("hash_cache/count")?,
        };
        let taa = Taa::new(ctx, scene, e2, frame, &color, &position, &out_depth)?;
        let mut init = Recorder::new(ctx, 1)?;
        init.pass("hybrid.init").write(&keys).write(&cells).fill(0);
        init.finish()?;
        Ok(Hybrid {
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            hash,
            cache,
            pipes,
            sets,
            keys,
            cells,
            pix_hit,
            pix_ray,
            pix_cell,
            fallback,
            color,
            out_depth,
            out_fh,
            out_albedo,
            position,
            counters,
            debug,
            taa,
            frames: 0,
        })
    }

    /// The visibility-only sample cache (its snapshot holds this frame's
    /// visible samples after `render_frame`).
    pub fn sample_cache(&self) -> &SampleCache {
        &self.cache
    }

    pub fn hash_settings(&self) -> &HashCacheSettings {
        &self.hash
    }
}

impl Method for Hybrid {
    fn name(&self) -> &'static str {
        "hybrid"
    }

    fn render_frame(&mut self, input: &FrameInput) -> GpuResult<StereoFrame> {
        let (w, h) = (self.settings.width, self.settings.height);
        let npix = (w * h) as usize;
        let now = hash_cache::stamp(self.frames);
        let push = hash_cache::push_constants(&self.hash, now);
        let groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let p = &self.pipes;

        let mut rec = Recorder::new(&self.ctx, 24)?;
        let cur = self.cache.record_visibility(&mut rec, input)?;
        let cache = self.cache.current_buffers(cur);
        let frame = self.cache.frame_buffer();
        let sets = [&self.scene.set, &self.sets[cur]];
        rec.pass("hybrid.clear").write(&self.counters).fill(0);
        rec.pass("hybrid.reserve")
            .read(frame)
            .read(cache.masks)
            .read(cache.first_hits)
            .write(&self.keys)
            .write(&self.pix_hit)
            .write(&self.pix_ray)
            .write(&self.pix_cell)
            .write(&self.counters)
            .dispatch(&p.reserve, &sets, &push, groups);
        rec.pass("hybrid.update")
            .read(&self.pix_hit)
            .read(&self.pix_ray)
            .read(&self.pix_cell)
            .write(&self.cells)
            .write(&self.fallback)
            .write(&self.counters)
            .dispatch(&p.update, &sets, &push, groups);
        rec.pass("hybrid.resolve")
            .read(cache.masks)
            .read(cache.first_hits)
            .read(&self.pix_cell)
            .read(&self.cells)
            .read(&self.fallback)
            .write(&self.keys)
            .write(&self.color)
            .write(&self.position)
            .write(&self.out_depth)
            .write(&self.out_fh)
            .write(&self.out_albedo)
            .write(&self.counters)
            .dispatch(&p.resolve, &sets, &push, groups);
        rec.pass("diag.hybrid.count")
            .read(&self.keys)
            .write(&self.counters)
            .dispatch(
                &p.count,
                &sets,
                &push,
                hash_cache::count_grid(self.hash.capacity),
            );
        let out = if self.hash.taa {
            Some(self.taa.record(
                &mut rec,
                &self.scene.set,
                [frame, &self.color, &self.position, &self.out_depth],
                groups,
            ))
        } else {
            None
        };
        let passes = rec.finish()?;
        self.cache.end_frame();
        self.frames += 1;

        let outputs = OutputBuffers {
            color: out.unwrap_or(&self.color),
            depth: &self.out_depth,
            first_hit: &self.out_fh,
            albedo: &self.out_albedo,
            debug: None,
        };
        let eyes = outputs.read(npix)?;
        let counters: Vec<u32> = self.counters.download_pod()?;
        let (primary, visibility) = self.cache.visibility_counters()?;
        let mut stats = FrameStats {
            passes,
            rays: RayCounts {
                primary,
                bounce: counters[1] as u64,
                shadow: counters[2] as u64,
            },
            counters: visibility,
        };
        for (i, name) in hash_cache::COUNTERS.iter().chain(COUNTERS) {
            // The hash cache's own misses count pixels without a visible sample here.
            let name = if *name == "primary_misses" {
                "pixels_without_samples"
            } else {
                name
            };
            stats.counters.insert(name.to_string(), counters[*i] as f64);
        }
        stats.counters.insert(
            "table_occupancy".into(),
            counters[9] as f64 / self.hash.capacity as f64,
        );
        Ok(StereoFrame {
            width: w,
            height: h,
            eyes,
            stats,
        })
    }

    fn memory_bytes(&self) -> u64 {
        self.cache.memory_bytes()
            + [
                &self.keys,
                &self.cells,
                &self.pix_hit,
                &self.pix_ray,
                &self.pix_cell,
                &self.fallback,
                &self.color,
                &self.out_depth,
                &self.out_fh,
                &self.out_albedo,
                &self.position,
                &self.counters,
                &self.debug,
            ]
            .iter()
            .map(|b| b.size)
            .sum::<u64>()
            + self.taa.memory_bytes()
    }
}
