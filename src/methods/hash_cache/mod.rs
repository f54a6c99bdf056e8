//! `hash-cache`: a hash-grid radiance cache in world space (paper §4's
//! HashCache, after Roth et al. 2020, GI-1.0 (Boissé et al. 2023) and
//! Gautron 2021), with TAA on the output.
//!
//! Table: `capacity` entries of 24 B — a 64-bit key word (checksum << 32 |
//! last access frame mod 2^32, updated with 64-bit compare-and-swap) and an
//! RGBA32F record (demodulated radiance running mean, sample count).
//! Keys, hashes and probing: [`hash`] (CPU twin of `shaders/hash_cache/hash.glsl`).
//!
//! Passes per frame (both eyes per dispatch, `z` = eye): `params` → `clear`
//! → `primary` (jittered 1 spp first hits, voxel lookup / reservation, the
//! first toucher of an entry this frame becomes its updater) → `update` (one
//! secondary path per updated entry; own path for pixels whose lookup
//! failed) → `resolve` (base colour × entry radiance + emission) → `diag.count`
//! (live entries, a statistic: not counted in the frame time) → `taa`.

pub mod args;
pub mod hash;
pub mod settings;
pub mod taa;

pub use settings::{HashCacheSettings, HashLod};
pub use taa::Taa;

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

/// Counter slots written by the shaders (common.glsl `C_*`), with report names.
pub(crate) const COUNTERS: &[(usize, &str)] = &[
    (3, "cells_found"),
    (4, "cells_reserved"),
    (5, "cells_evicted_stale"),
    (6, "probe_failures"),
    (7, "cell_updates"),
    (8, "fallback_paths"),
    (9, "live_entries"),
    (10, "primary_misses"),
];

/// Names of the debug views, in the order the resolve pass writes them.
pub const DEBUG_VIEWS: [&str; 4] = ["voxel", "lod", "cell-samples", "lookup"];

/// Bytes per table entry: 8 (key word) + 16 (RGBA32F).
pub const ENTRY_BYTES: u64 = 24;

const LOCAL: u32 = 8;

/// The frame counter stamped into table entries by a method's frame `k`
/// (0-based): k + 1 mod 2^32 (0 never stamps, so a zeroed table is empty).
pub(crate) fn stamp(k: u64) -> u32 {
    (k as u32).wrapping_add(1)
}

/// The push constants of `shaders/hash_cache/common.glsl` (`Push`) for the
/// settings `h` and the frame stamp `now`; shared with `hybrid`, whose
/// shaders include the same file.
pub(crate) fn push_constants(h: &HashCacheSettings, now: u32) -> Vec<u8> {
    let flags = h.tiles as u32
        | ((h.lod == HashLod::DistanceNormal) as u32) << 1
        | (h.debug_views as u32) << 2;
    let mut v = Vec::with_capacity(32);
    for u in [h.capacity, h.max_probe, h.stale_frames, flags] {
        v.extend_from_slice(&u.to_le_bytes());
    }
    v.extend_from_slice(&h.lod_scale.to_le_bytes());
    for u in [h.max_samples, now, 0] {
        v.extend_from_slice(&u.to_le_bytes());
    }
    v
}

/// Dispatch grid of `count.comp` (256 entries per group, ≤ 1024 groups per row).
pub(crate) fn count_grid(capacity: u32) -> [u32; 3] {
    let groups = capacity.div_ceil(256);
    [groups.min(1024), groups.div_ceil(1024), 1]
}

/// The table read back from the GPU (tests, debugging).
pub struct TableSnapshot {
    pub keys: Vec<u64>,
    pub cells: Vec<[f32; 4]>,
    /// The frame counter the last frame stamped (mod 2^32).
    pub now: u32,
}

struct Pipelines {
    primary: ComputePipeline,
    update: ComputePipeline,
    resolve: ComputePipeline,
    count: ComputePipeline,
}

pub struct HashCache {
    ctx: Arc<GpuContext>,
    scene: Arc<SceneGpu>,
    settings: RenderSettings,
    hash: HashCacheSettings,
    pipes: Pipelines,
    set: DescriptorSet,
    frame: Buffer,
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

impl HashCache {
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Arc<SceneGpu>,
        env: &Option<Environment>,
        settings: &RenderSettings,
    ) -> GpuResult<Self> {
        let hash = settings.hash.clone();
        hash.validate().map_err(GpuError::Unsupported)?;
        if !ctx.enabled.buffer_int64_atomics {
            return Err(GpuError::Unsupported(format!(
                "device '{}' lacks shaderBufferInt64Atomics, which the hash cache's keys need",
                ctx.caps.name
            )));
        }
        let e2 = 2 * (settings.width * settings.height) as u64;
        let cap = hash.capacity as u64;
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("hash_cache.{name}"), bytes);
        let frame = b("frame", std::mem::size_of::<FrameParams>() as u64)?;
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
        let counters = b("counters", 16 * 4)?;
        let debug = b(
            "debug",
            if hash.debug_views {
                DEBUG_VIEWS.len() as u64 * e2 * 16
            } else {
                16
            },
        )?;
        let layout = DescriptorLayout::buffers(ctx, 14)?;
        let set = DescriptorSet::new(
            ctx,
            &layout,
            &[
                Resource::Buffer(&frame),
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
            ],
        )?;
        let spec = settings.spec_constants(scene, env);
        let layouts = [scene.layout.clone(), layout];
        let pipe = |name: &str| -> GpuResult<ComputePipeline> {
            ComputePipeline::new(
                ctx,
                &format!("hash_cache.{name}"),
                backend_shader(&format!("hash_cache/{name}"), scene)?,
                &layouts,
                32,
                &spec,
            )
        };
        let pipes = Pipelines {
            primary: pipe("primary")?,
            update: pipe("update")?,
            resolve: pipe("resolve")?,
            count: pipe("count")?,
        };
        let taa = Taa::new(ctx, scene, e2, &frame, &color, &position, &out_depth)?;
        let mut init = Recorder::new(ctx, 1)?;
        init.pass("hash_cache.init")
            .write(&keys)
            .write(&cells)
            .fill(0);
        init.finish()?;
        Ok(HashCache {
            ctx: ctx.clone(),
            scene: scene.clone(),
            settings: settings.clone(),
            hash,
            pipes,
            set,
            frame,
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

    /// The frame counter stamped into entries by frame `k` (0-based): k + 1 mod 2^32.
    fn stamp(k: u64) -> u32 {
        stamp(k)
    }

    fn push_constants(&self, now: u32) -> Vec<u8> {
        push_constants(&self.hash, now)
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
        self.settings.all_passes || self.settings.max_bounces > 0 || self.hash.debug_views
    }

    /// Reads the table back (after `render_frame`).
    pub fn snapshot(&self) -> GpuResult<TableSnapshot> {
        Ok(TableSnapshot {
            keys: self.keys.download_pod()?,
            cells: self.cells.download_pod()?,
            now: Self::stamp(self.frames.saturating_sub(1)),
        })
    }

    /// Starts the frame counter at `frames` (tests of the wrap-around at 2^32).
    pub fn set_frame_counter(&mut self, frames: u64) {
        self.frames = frames;
    }

    pub fn settings(&self) -> &HashCacheSettings {
        &self.hash
    }
}

impl Method for HashCache {
    fn name(&self) -> &'static str {
        "hash-cache"
    }

    fn render_frame(&mut self, input: &FrameInput) -> GpuResult<StereoFrame> {
        let (w, h) = (self.settings.width, self.settings.height);
        let npix = (w * h) as usize;
        let now = Self::stamp(self.frames);
        let params = FrameParams::new(input, w, h, self.settings.seed, self.scene.origin);
        let push = self.push_constants(now);
        let groups = [w.div_ceil(LOCAL), h.div_ceil(LOCAL), 2];
        let count_grid = count_grid(self.hash.capacity);
        let p = &self.pipes;
        let sets = [&self.scene.set, &self.set];

        let mut rec = Recorder::new(&self.ctx, 8)?;
        rec.pass("params")
            .write(&self.frame)
            .update(bytemuck::bytes_of(&params));
        rec.pass("clear").write(&self.counters).fill(0);
        let update = self.update_has_work();
        if !update {
            // What `update` would leave in `fallback` for a probe failure
            // (rgb = 0); misses get theirs from `primary`, after this clear.
            rec.pass("clear.fallback").write(&self.fallback).fill(0);
        }
        rec.pass("primary")
            .read(&self.frame)
            .write(&self.keys)
            .write(&self.pix_hit)
            .write(&self.pix_ray)
            .write(&self.pix_cell)
            .write(&self.fallback)
            .write(&self.position)
            .write(&self.out_depth)
            .write(&self.out_fh)
            .write(&self.out_albedo)
            .write(&self.counters)
            .dispatch(&p.primary, &sets, &push, groups);
        if update {
            rec.pass("update")
                .read(&self.pix_hit)
                .read(&self.pix_ray)
                .read(&self.pix_cell)
                .write(&self.cells)
                .write(&self.fallback)
                .write(&self.counters)
                .dispatch(&p.update, &sets, &push, groups);
        }
        rec.pass("resolve")
            .read(&self.pix_hit)
            .read(&self.pix_ray)
            .read(&self.pix_cell)
            .read(&self.cells)
            .read(&self.fallback)
            .write(&self.color)
            .write(&self.debug)
            .dispatch(&p.resolve, &sets, &push, groups);
        rec.pass("diag.count")
            .read(&self.keys)
            .write(&self.counters)
            .dispatch(&p.count, &sets, &push, count_grid);
        let out = if self.hash.taa {
            Some(self.taa.record(
                &mut rec,
                &self.scene.set,
                [&self.frame, &self.color, &self.position, &self.out_depth],
                groups,
            ))
        } else {
            None
        };
        let passes = rec.finish()?;
        self.frames += 1;

        let outputs = OutputBuffers {
            color: out.unwrap_or(&self.color),
            depth: &self.out_depth,
            first_hit: &self.out_fh,
            albedo: &self.out_albedo,
            debug: self
                .hash
                .debug_views
                .then_some((&self.debug, &DEBUG_VIEWS[..])),
        };
        let eyes = outputs.read(npix)?;
        let counters: Vec<u32> = self.counters.download_pod()?;
        let mut stats = FrameStats {
            passes,
            rays: RayCounts {
                primary: counters[0] as u64,
                bounce: counters[1] as u64,
                shadow: counters[2] as u64,
            },
            counters: Default::default(),
        };
        stats.counters = named_counters(&counters, COUNTERS);
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
        [
            &self.frame,
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
