//! `hash-cache`: a hash-grid radiance cache in world space (paper §4's
//! HashCache, after Roth et al. 2020, GI-1.0 (Boissé et al. 2023) and
//! Gautron 2021), with TAA on the output. The table, its buffers and its
//! update and count passes are [`crate::methods::hash_table`]'s.
//!
//! Passes per frame (both eyes per dispatch, `z` = eye): `params` → `clear`
//! → `primary` (jittered 1 spp first hits, voxel lookup / reservation, the
//! first toucher of an entry this frame becomes its updater; and one
//! unjittered ray through each pixel centre whose depth and first hit only
//! TAA reads, so its history rejection sees the same surface every frame,
//! [`CentreHits`]) → `update` (one
//! secondary path per updated entry; own path for pixels whose lookup
//! failed) → `resolve` (demodulation factor × entry radiance + emission,
//! `common/demodulation.glsl`) → `diag.count`
//! (live entries, a statistic: not counted in the frame time) → the one TAA
//! ([`TaaPass`], `--taa-*` options; unless `--hash-no-taa`).

pub mod args;
pub mod settings;

/// The table's keys and hashes, where they were before the table had its own module.
pub use super::hash_table::hash;
pub use super::hash_table::{PixelRequests, TableSnapshot, ENTRY_BYTES};
pub use settings::{HashCacheSettings, HashLod};

use super::hash_table::{self as table, HashTable, TableDesc};
use super::taa::{TaaInputs, TaaPass};
use super::{Color, FrameInput, FrameOutputs, FrameParams, Method, RenderSettings};
use crate::gpu::{Buffer, ComputePipeline, GpuContext, GpuResult, HostReadback, Recorder};
use crate::interface::{hash_cache, hash_table::INTERFACE};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

/// Names of the debug views, in the order the resolve pass writes them.
pub const DEBUG_VIEWS: [&str; 4] = ["voxel", "lod", "cell-samples", "lookup"];

const LOCAL: u32 = 8;

struct Pipelines {
    primary: ComputePipeline,
    resolve: ComputePipeline,
}

/// The pixel centres' view depth and first hits (`[eye][pixel]`), written by
/// `primary` for TAA's reprojection and rejection (bindings 14, 15 of
/// src/interface/hash_cache.rs). The shown colour comes from the jittered
/// hit, as do the method's depth / first-hit outputs.
struct CentreHits {
    depth: Buffer,
    first_hit: Buffer,
}

pub struct HashCache {
    ctx: Arc<GpuContext>,
    scene: Arc<SceneGpu>,
    settings: RenderSettings,
    table: HashTable,
    pipes: Pipelines,
    frame: Buffer,
    centre: CentreHits,
    /// The one TAA, built only where it runs (not under `--hash-no-taa`).
    taa: Option<TaaPass>,
    readback: HostReadback,
}

impl HashCache {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
        hash: &HashCacheSettings,
    ) -> GpuResult<Self> {
        let e2 = 2 * (settings.width * settings.height) as u64;
        let frame = Buffer::storage(
            ctx,
            "hash_cache.frame",
            std::mem::size_of::<FrameParams>() as u64,
        )?;
        let spec = settings.spec_constants(scene, env);
        let mut table = HashTable::new(
            ctx,
            scene,
            hash,
            TableDesc {
                label: "hash_cache",
                passes: "",
                pixels: e2,
                counter_slots: 16,
                debug_views: if hash.debug_views {
                    DEBUG_VIEWS.len()
                } else {
                    0
                },
                spec: &spec,
            },
        )?;
        let pipes = Pipelines {
            primary: table.pipeline(ctx, scene, "hash_cache/primary", &hash_cache::INTERFACE)?,
            resolve: table.pipeline(ctx, scene, "hash_cache/resolve", &INTERFACE)?,
        };
        let centre = CentreHits {
            depth: Buffer::storage(ctx, "hash_cache.taa_depth", e2 * 4)?,
            first_hit: Buffer::storage(ctx, "hash_cache.taa_fh", e2 * 16)?,
        };
        let taa = match hash.taa {
            true => Some(TaaPass::new(ctx, scene, settings, &hash.taa_settings)?),
            false => None,
        };
        // The pixel centres are traced only for a TAA that reads them.
        table.set_centre_hits(hash.taa || settings.taa_output.is_some());
        Ok(HashCache {
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            table,
            pipes,
            frame,
            centre,
            taa,
            readback: HostReadback::new(),
        })
    }

    /// Whether the `update` pass can change the image. With zero bounces a
    /// path from a first hit ends there: `path_radiance` returns exactly the
    /// hit's emission, which `update` subtracts, so every cell and fallback
    /// path would receive exactly 0 (rgb). Cells start at 0 and only `update`
    /// writes them, so without it `resolve` reads the same rgb (base × 0 +
    /// emission); the sample counts in `w` differ, which only the debug views
    /// show, so they keep the pass. `cell_updates` and `fallback_paths` then
    /// count 0: no update ran.
    fn update_has_work(&self) -> bool {
        self.settings.all_passes
            || self.settings.max_bounces > 0
            || self.table.settings().debug_views
    }

    /// Reads the table back (after `render_frame`).
    pub fn snapshot(&self) -> GpuResult<TableSnapshot> {
        self.table.snapshot()
    }

    /// The last frame's per-pixel lookup requests (after `render_frame`).
    pub fn pixel_requests(&self) -> GpuResult<PixelRequests> {
        self.table.pixel_requests()
    }

    /// Starts the frame counter at `frames` (tests of the wrap-around at 2^32).
    pub fn set_frame_counter(&mut self, frames: u64) {
        self.table.set_frame_counter(frames);
    }

    pub fn settings(&self) -> &HashCacheSettings {
        self.table.settings()
    }
}

impl Method for HashCache {
    fn name(&self) -> &'static str {
        "hash-cache"
    }

    fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        input: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>> {
        self.table.begin_frame();
        let centre_hits = self.table.centre_hits();
        let update = self.update_has_work();
        let HashCache {
            scene,
            settings,
            table,
            pipes,
            frame,
            centre,
            taa,
            readback,
            ..
        } = self;
        let (scene, settings, t, p, frame, centre, readback): (
            &'a _,
            &'a RenderSettings,
            &'a HashTable,
            &'a Pipelines,
            &'a Buffer,
            &'a CentreHits,
            &'a HostReadback,
        ) = (scene, settings, table, pipes, frame, centre, readback);
        let (w, h) = (settings.width, settings.height);
        let params = FrameParams::new(input, w, h, settings.seed, scene.origin);
        let groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let scene_set = &scene.set;
        let px = t.pixels();

        rec.pass("params")
            .write(frame)
            .update(bytemuck::bytes_of(&params));
        t.record_clear(rec);
        if !update {
            // What `update` would leave in `fallback` for a probe failure
            // (rgb = 0); misses get theirs from `primary`, after this clear.
            rec.pass("clear.fallback").write(&px.fallback).fill(0);
        }
        t.pass(rec, "primary", &p.primary, scene_set, frame)
            .write(&centre.depth)
            .write(&centre.first_hit)
            .dispatch(groups)?;
        if update {
            t.record_update(rec, scene_set, frame, groups)?;
        }
        t.pass(rec, "resolve", &p.resolve, scene_set, frame)
            .dispatch(groups)?;
        t.record_count(rec, scene_set, frame)?;
        let mut counters = vec![table::table_counters(t.counters(), t.settings().capacity)];
        let mut shown = &px.color;
        if let Some(taa) = taa {
            let inputs = TaaInputs {
                depth: &centre.depth,
                first_hit: &centre.first_hit,
                ..px.taa_inputs()
            };
            let (resolved, c) = taa.record(rec, input, inputs)?;
            shown = resolved;
            counters.push(c);
        }
        Ok(FrameOutputs {
            width: w,
            height: h,
            color: Color::Radiance(shown),
            // The pixel centre's depth and first hit where they were traced
            // (for `--taa-output`'s TAA on this method as for its own);
            // otherwise the jittered hit's.
            depth: if centre_hits {
                &centre.depth
            } else {
                &px.depth
            },
            first_hit: if centre_hits {
                &centre.first_hit
            } else {
                &px.first_hit
            },
            albedo: &px.albedo,
            debug: t
                .settings()
                .debug_views
                .then_some((t.debug(), &DEBUG_VIEWS[..])),
            counters,
            host_counters: Default::default(),
            readback,
        })
    }

    fn resolves_with_taa(&self) -> bool {
        self.table.settings().taa
    }

    fn memory_bytes(&self) -> u64 {
        self.frame.size
            + self.centre.depth.size
            + self.centre.first_hit.size
            + self.table.memory_bytes()
            + self.taa.as_ref().map_or(0, TaaPass::memory_bytes)
    }
}
