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
//! * `hybrid.update`: the hash table's update pass
//!   ([`HashTable::record_update`], `shaders/hash_table/update.comp`) — the
//!   updater of each touched entry traces one secondary path from the
//!   sample's stored first hit (one path per pixel at most);
//! * `hybrid.resolve` (`shaders/hybrid/resolve.comp`): every visible sample
//!   finds (never inserts) both levels; sample colour = base colour × mean of
//!   the levels holding radiance + emission; pixel colour = mean over its
//!   samples;
//! * `diag.hybrid.count` (the table's `count.comp`, live entries; a statistic
//!   left out of the frame time) → `taa`
//!   ([`crate::methods::hash_cache::Taa`], as the hash cache, unless
//!   `--hash-no-taa`).
//!
//! Cost of the lookups: 2 × (visible samples per pixel) probe walks per
//! pixel in `resolve` (≈ 8 at n_target = 4) and one in `reserve`; one
//! secondary path per pixel at most. Memory: the visibility-only sample
//! cache, the table ([`HashTable`]: 24 B per entry and its per-pixel buffers)
//! and TAA history.

use super::hash_cache::{HashCacheSettings, Taa};
use super::hash_table::{self as table, HashTable, TableDesc, TABLE_COUNTER_SLOTS};
use super::{
    named_counters, FrameInput, FrameStats, Method, RenderSettings, SampleCache, StereoFrame,
};
use crate::gpu::{ComputePipeline, DescriptorSet, GpuContext, GpuResult, Recorder};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

/// Counter slots of `shaders/hybrid/common.glsl` (after the table's), with report names.
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
const _: () = assert!(COUNTER_SLOTS > TABLE_COUNTER_SLOTS + COUNTERS.len() as u64 - 1);
/// Specialization constant id of the sample cache's slot count (N_SLOTS).
const SPEC_SLOTS: u32 = 20;
const LOCAL: u32 = 8;

struct Pipelines {
    reserve: ComputePipeline,
    resolve: ComputePipeline,
}

pub struct Hybrid {
    ctx: Arc<GpuContext>,
    scene: Arc<SceneGpu>,
    settings: RenderSettings,
    cache: SampleCache,
    table: HashTable,
    pipes: Pipelines,
    /// sets[i] binds the sample cache's buffers with index i as the current cache.
    sets: [DescriptorSet; 2],
    taa: Taa,
}

impl Hybrid {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
    ) -> GpuResult<Self> {
        let mut hash = settings.hash.clone();
        hash.validate().map_err(crate::gpu::GpuError::Unsupported)?;
        // The hash cache's debug views are not produced here.
        hash.debug_views = false;
        let cache = SampleCache::visibility_only(ctx, scene, env, settings)?;
        let e2 = 2 * (settings.width * settings.height) as u64;
        let mut spec = settings.spec_constants(scene, env);
        spec.set(SPEC_SLOTS, settings.cache.slots);
        let table = HashTable::new(
            ctx,
            scene,
            &hash,
            TableDesc {
                label: "hybrid",
                passes: "hybrid.",
                pixels: e2,
                counter_slots: COUNTER_SLOTS,
                debug_views: 0,
                // 14..15: the current sample cache's masks and first hits.
                extra_bindings: 2,
                spec: &spec,
            },
        )?;
        let frame = cache.frame_buffer();
        let make_set = |i: usize| {
            let cur = cache.current_buffers(i);
            table.descriptor_set(ctx, frame, &[cur.masks, cur.first_hits])
        };
        let sets = [make_set(0)?, make_set(1)?];
        let pipes = Pipelines {
            reserve: table.pipeline(ctx, scene, "hybrid/reserve")?,
            resolve: table.pipeline(ctx, scene, "hybrid/resolve")?,
        };
        let taa = table.pixels().taa(ctx, scene, frame)?;
        Ok(Hybrid {
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            cache,
            table,
            pipes,
            sets,
            taa,
        })
    }

    /// The visibility-only sample cache (its snapshot holds this frame's
    /// visible samples after `render_frame`).
    pub fn sample_cache(&self) -> &SampleCache {
        &self.cache
    }

    pub fn hash_settings(&self) -> &HashCacheSettings {
        self.table.settings()
    }
}

impl Method for Hybrid {
    fn name(&self) -> &'static str {
        "hybrid"
    }

    fn render_frame(&mut self, input: &FrameInput) -> GpuResult<StereoFrame> {
        let (w, h) = (self.settings.width, self.settings.height);
        let npix = (w * h) as usize;
        let push = self.table.push();
        let push = bytemuck::bytes_of(&push);
        let groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let p = &self.pipes;

        let mut rec = Recorder::new(&self.ctx, 24)?;
        let cur = self.cache.record_visibility(&mut rec, input);
        let cache = self.cache.current_buffers(cur);
        let frame = self.cache.frame_buffer();
        let t = &self.table;
        let px = t.pixels();
        let sets = [&self.scene.set, &self.sets[cur]];
        t.record_clear(&mut rec);
        rec.pass("hybrid.reserve")
            .read(frame)
            .read(cache.masks)
            .read(cache.first_hits)
            .write(t.keys())
            .write(&px.hit)
            .write(&px.ray)
            .write(&px.cell)
            .write(t.counters())
            .dispatch(&p.reserve, &sets, push, groups);
        t.record_update(&mut rec, &sets, groups);
        rec.pass("hybrid.resolve")
            .read(cache.masks)
            .read(cache.first_hits)
            .read(&px.cell)
            .read(t.cells())
            .read(&px.fallback)
            .write(t.keys())
            .write(&px.color)
            .write(&px.position)
            .write(&px.depth)
            .write(&px.first_hit)
            .write(&px.albedo)
            .write(t.counters())
            .dispatch(&p.resolve, &sets, push, groups);
        t.record_count(&mut rec, &sets);
        let shown = px.record_taa(
            &mut self.taa,
            t.settings().taa,
            &mut rec,
            &self.scene.set,
            frame,
            groups,
        );
        let passes = rec.finish()?;
        self.cache.end_frame();

        let eyes = t.pixels().outputs(shown, None).read(npix)?;
        let counters = t.read_counters()?;
        let (primary, visibility) = self.cache.visibility_counters()?;
        let mut stats = FrameStats {
            passes,
            rays: table::ray_counts(&counters),
            counters: visibility,
        };
        stats.rays.primary = primary;
        // The table's misses count pixels without a visible sample here.
        stats.counters.extend(table::table_counters(
            &counters,
            t.settings().capacity,
            "pixels_without_samples",
        ));
        stats.counters.extend(named_counters(&counters, COUNTERS));
        self.table.end_frame();
        Ok(StereoFrame {
            width: w,
            height: h,
            eyes,
            stats,
        })
    }

    fn memory_bytes(&self) -> u64 {
        self.cache.memory_bytes() + self.table.memory_bytes() + self.taa.memory_bytes()
    }
}
