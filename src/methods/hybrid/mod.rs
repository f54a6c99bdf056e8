//! `hybrid`: the sample cache without shading storage and the hash cache
//! (paper §4, "Hybrid"). The sample cache ([`SampleCache::visibility_only`])
//! keeps stable, adaptively retraced first hits per pixel; their radiance
//! comes from the hash cache's table at the hash cache's level of detail L
//! and at the parent level L + 1.
//!
//! Per frame (both eyes per dispatch, `z` = eye):
//! * the sample cache's visibility passes (`params`, `begin`, `clear`,
//!   `reproject`, `select`, `trace`; [`HybridConfig::cache`] applies);
//! * `hybrid.clear` (counters);
//! * `hybrid.reserve` (`shaders/hybrid/reserve.comp`): per pixel one visible
//!   sample and one of its two levels, chosen by a fair coin, is found or
//!   reserved in the table — the pixel's lookup for shading. Which sample:
//!   [`HybridLookups::PerPixel`] (default, §4) one drawn uniformly this frame,
//!   its point voxel-jittered as in HashCache; [`HybridLookups::PerSample`]
//!   round robin by frame index over the surface samples, unjittered;
//! * `hybrid.update`: the hash table's update pass
//!   ([`HashTable::record_update`], `shaders/hash_table/update.comp`) — the
//!   updater of each touched entry traces one secondary path from the
//!   sample's stored first hit (one path per pixel at most);
//! * `hybrid.resolve` (`shaders/hybrid/resolve.comp`): per-pixel lookups: the
//!   pixel's drawn surface sample finds (never inserts) both levels of its
//!   jittered point — the two lookups for reconstruction (§5.1: "three
//!   lookups per pixel") — and shows demodulation factor × mean of the
//!   levels holding radiance + emission, mixed with the pixel's background
//!   samples' environment by coverage; per-sample lookups: every visible
//!   sample finds both levels and the pixel shows the mean over its
//!   samples, background ones included;
//! * `diag.hybrid.count` (the table's `count.comp`, live entries; a statistic
//!   left out of the frame time) → the one TAA ([`TaaPass`], `--taa-*`
//!   options, as the hash cache; unless `--hash-no-taa`), on the closest
//!   visible surface sample's geometry.
//!
//! Cost of the lookups: per-pixel 3 probe walks per pixel; per-sample
//! 2 × (visible samples per pixel) in `resolve` (≈ 8 at n_target = 4) and one
//! in `reserve`; one secondary path per pixel at most. Memory: the
//! visibility-only sample cache, the table ([`HashTable`]: 24 B per entry and
//! its per-pixel buffers) and TAA history.

pub mod args;
pub mod config;

pub use config::{HybridConfig, HybridLookups};

use super::hash_cache::{HashCacheSettings, PixelRequests, TableSnapshot};
use super::hash_table::{self as table, HashTable, TableDesc};
use super::taa::TaaPass;
use super::{
    Color, CounterOutput, FrameInput, FrameOutputs, Method, RaySlots, RenderSettings, SampleCache,
};
use crate::gpu::{ComputePipeline, GpuContext, GpuResult, HostReadback, Recorder};
use crate::interface::hybrid::{HybridCounter, INTERFACE, SPEC_PER_SAMPLE, SPEC_SLOTS};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

/// Counter slots allocated (`C_HY_*` use the first 20).
const COUNTER_SLOTS: u64 = 32;
const _: () =
    assert!(<HybridCounter as crate::interface::CounterSlot>::ALL.len() as u64 <= COUNTER_SLOTS);
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
    /// The one TAA, built only where it runs (not under `--hash-no-taa`).
    taa: Option<TaaPass>,
    readback: HostReadback,
}

impl Hybrid {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
        config: &HybridConfig,
    ) -> GpuResult<Self> {
        let mut hash = config.hash.clone();
        hash.validate().map_err(crate::gpu::GpuError::Unsupported)?;
        // The hash cache's debug views are not produced here.
        hash.debug_views = false;
        let cache = SampleCache::visibility_only(ctx, scene, env, settings, &config.cache)?;
        let e2 = 2 * (settings.width * settings.height) as u64;
        let mut spec = settings.spec_constants(scene, env);
        spec.set(SPEC_SLOTS, config.cache.slots);
        spec.flag(SPEC_PER_SAMPLE, config.lookups == HybridLookups::PerSample);
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
                spec: &spec,
            },
        )?;
        let pipes = Pipelines {
            reserve: table.pipeline(ctx, scene, "hybrid/reserve", &INTERFACE)?,
            resolve: table.pipeline(ctx, scene, "hybrid/resolve", &INTERFACE)?,
        };
        let taa = match hash.taa {
            true => Some(TaaPass::new(ctx, scene, settings, &hash.taa_settings)?),
            false => None,
        };
        Ok(Hybrid {
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            cache,
            table,
            pipes,
            taa,
            readback: HostReadback::new(),
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

    /// Reads the table back (after `render_frame`).
    pub fn snapshot(&self) -> GpuResult<TableSnapshot> {
        self.table.snapshot()
    }

    /// The last frame's per-pixel update requests of `reserve.comp` (after
    /// `render_frame`): the level in a cell's meta is the one updated.
    pub fn pixel_requests(&self) -> GpuResult<PixelRequests> {
        self.table.pixel_requests()
    }
}

impl Method for Hybrid {
    fn name(&self) -> &'static str {
        "hybrid"
    }

    fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>> {
        self.cache.begin_frame();
        self.table.begin_frame();
        let Hybrid {
            scene,
            settings,
            cache: sample_cache,
            table,
            pipes,
            taa,
            readback,
            ..
        } = self;
        let (scene, settings, sample_cache, t, p, readback): (
            &'a Arc<SceneGpu>,
            &'a RenderSettings,
            &'a SampleCache,
            &'a HashTable,
            &'a Pipelines,
            &'a HostReadback,
        ) = (scene, settings, sample_cache, table, pipes, readback);
        let (w, h) = (settings.width, settings.height);
        let groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let scene_set = &scene.set;
        let px = t.pixels();

        let cur = sample_cache.record_begun_visibility(rec, input)?;
        let cache = sample_cache.current_buffers(cur);
        let frame = sample_cache.frame_buffer();
        t.record_clear(rec);
        t.pass(rec, "hybrid.reserve", &p.reserve, scene_set, frame)
            .read(cache.masks)
            .read(cache.first_hits)
            .dispatch(groups)?;
        t.record_update(rec, scene_set, frame, groups)?;
        t.pass(rec, "hybrid.resolve", &p.resolve, scene_set, frame)
            .read(cache.masks)
            .read(cache.first_hits)
            .dispatch(groups)?;
        t.record_count(rec, scene_set, frame)?;
        use HybridCounter::*;
        // Primary rays are the sample cache's visibility rays. The
        // table's counters come after them, so where both report a name,
        // hybrid's value is the one in the frame's counters.
        let mut counters = vec![
            sample_cache.visibility_counter_output(),
            table::with_occupancy(
                CounterOutput::of::<HybridCounter>(t.counters()).rays(RaySlots::of(
                    &[],
                    &[BounceRays],
                    &[ShadowRays],
                )),
                Live,
                t.settings().capacity,
            ),
        ];
        let mut shown = &px.color;
        if let Some(taa) = taa {
            let (resolved, c) = taa.record(rec, input, px.taa_inputs())?;
            shown = resolved;
            counters.push(c);
        }
        Ok(FrameOutputs {
            width: w,
            height: h,
            color: Color::Radiance(shown),
            depth: &px.depth,
            first_hit: &px.first_hit,
            albedo: &px.albedo,
            debug: None,
            counters,
            host_counters: Default::default(),
            readback,
        })
    }

    fn resolves_with_taa(&self) -> bool {
        self.table.settings().taa
    }

    fn memory_bytes(&self) -> u64 {
        self.cache.memory_bytes()
            + self.table.memory_bytes()
            + self.taa.as_ref().map_or(0, TaaPass::memory_bytes)
    }
}
