//! [`HashTable`]: the table's buffers (keys, cells, the per-pixel requests
//! and outputs, counters, debug views), its memory, its shader interface
//! (set 1 = the bindings of src/interface/hash_table.rs, declared once by
//! [`HashTable::pass`]) and its passes: clear, update (insert results →
//! running means), live-entry count; plus the frame counter whose stamps
//! age entries out.

use super::pixels::PixelBuffers;
use super::push::TablePush;
use crate::gpu::{
    Buffer, ComputePass, ComputePipeline, DescriptorSet, GpuContext, GpuError, GpuResult, Recorder,
    SpecConstants,
};
use crate::interface::hash_table::{TableCounter, INTERFACE, PUSH};
use crate::interface::CounterSlot;
use crate::interface::Interface;
use crate::methods::hash_cache::settings::{
    auto_capacity, AUTO_CAPACITY, AUTO_ENTRIES_PER_PIXEL, MAX_CAPACITY,
};
use crate::methods::hash_cache::HashCacheSettings;
use crate::methods::reference::backend_shader;
use crate::rt::SceneGpu;
use std::sync::Arc;

/// Bytes per table entry: 8 (key word) + 16 (RGBA32F).
pub const ENTRY_BYTES: u64 = 24;

/// The frame counter stamped into table entries by a method's frame `k`
/// (0-based): k + 1 mod 2^32 (0 for k ≡ 2^32 − 1 only, which is harmless:
/// an entry is empty by its checksum 0, and ages use wrapping arithmetic).
pub fn stamp(k: u64) -> u32 {
    (k as u32).wrapping_add(1)
}

/// Dispatch grid of `count.comp` (256 entries per group, ≤ 1024 groups per row).
fn count_grid(capacity: u32) -> [u32; 3] {
    let groups = capacity.div_ceil(256);
    [groups.min(1024), groups.div_ceil(1024), 1]
}

fn pipeline(
    ctx: &Arc<GpuContext>,
    scene: &SceneGpu,
    label: &str,
    shader: &str,
    interface: &'static Interface,
    spec: &SpecConstants,
) -> GpuResult<ComputePipeline> {
    let name = shader.rsplit('/').next().unwrap_or(shader);
    ComputePipeline::with_interface(
        ctx,
        &format!("{label}.{name}"),
        backend_shader(shader, scene)?,
        std::slice::from_ref(&scene.layout),
        interface,
        Some(&PUSH),
        spec,
    )
}

/// How a method uses the table.
pub struct TableDesc<'a> {
    /// Prefix of buffer and pipeline names (`hash_cache`, `hybrid`).
    pub label: &'static str,
    /// Prefix of the table's pass names (`""`, `"hybrid."`): `{p}clear`,
    /// `{p}update`, `diag.{p}count`.
    pub passes: &'static str,
    /// Pixels of both eyes (2 × width × height).
    pub pixels: u64,
    /// Counter slots (at least the table's [`TableCounter`]s; the method's own follow).
    pub counter_slots: u64,
    /// The debug views written by the method's resolve (`[view][eye][pixel]`).
    pub debug_views: usize,
    /// Specialization constants of the table's pipelines and of the
    /// method's made by [`HashTable::pipeline`].
    pub spec: &'a SpecConstants,
}

/// The table read back from the GPU (tests, debugging).
pub struct TableSnapshot {
    pub keys: Vec<u64>,
    pub cells: Vec<[f32; 4]>,
    /// The frame counter the last frame stamped (mod 2^32).
    pub now: u32,
}

/// The per-pixel lookup requests read back ([`HashTable::pixel_requests`]).
pub struct PixelRequests {
    /// Direction to the first hit and its distance t (< 0: miss).
    pub rays: Vec<[f32; 4]>,
    /// Slot, status | winner << 4, checksum, meta.
    pub cells: Vec<[u32; 4]>,
}

pub struct HashTable {
    settings: HashCacheSettings,
    label: &'static str,
    passes: &'static str,
    spec: SpecConstants,
    keys: Buffer,
    cells: Buffer,
    pixels: PixelBuffers,
    counters: Buffer,
    debug: Buffer,
    update: ComputePipeline,
    count: ComputePipeline,
    /// Frames begun so far; frame k stamps entries with (k + 1) mod 2^32.
    frames: u64,
    /// The stamp of the frame being recorded.
    now: u32,
    /// Whether `hash_cache/primary.comp` also traces the pixel centre (push
    /// flag bit 3; only when a TAA reads it: [`Self::set_centre_hits`]).
    centre_hits: bool,
}

impl HashTable {
    /// Checks the settings and the device, creates the buffers and the
    /// table's pipelines, and clears the table.
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &SceneGpu,
        settings: &HashCacheSettings,
        desc: TableDesc,
    ) -> GpuResult<HashTable> {
        settings.validate().map_err(GpuError::Unsupported)?;
        let mut settings = settings.clone();
        if settings.capacity == AUTO_CAPACITY {
            let (cap, short) = auto_capacity(desc.pixels, ctx.caps.max_storage_buffer_range);
            if short {
                eprintln!(
                    "warning: {}: the hash table holds {cap} entries, fewer than {AUTO_ENTRIES_PER_PIXEL} per pixel of both eyes ({} pixels; {}): expect failed lookups, whose pixels show their own 1 spp path",
                    desc.label,
                    desc.pixels,
                    if cap == MAX_CAPACITY {
                        "the largest table".to_string()
                    } else {
                        format!("device '{}' binds {} bytes", ctx.caps.name, ctx.caps.max_storage_buffer_range)
                    }
                );
            }
            settings.capacity = cap;
        }
        let settings = &settings;
        if !(ctx.enabled.buffer_int64_atomics && ctx.enabled.shader_int64) {
            return Err(GpuError::Unsupported(format!(
                "device '{}' lacks shaderBufferInt64Atomics or shaderInt64 (64-bit integers), which the hash cache's keys need",
                ctx.caps.name
            )));
        }
        assert!(desc.counter_slots >= TableCounter::ALL.len() as u64);
        let label = desc.label;
        let cap = settings.capacity as u64;
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("{label}.{name}"), bytes);
        let keys = b("keys", cap * 8)?;
        let cells = b("cells", cap * 16)?;
        let pixels = PixelBuffers::new(ctx, label, desc.pixels)?;
        let counters = b("counters", desc.counter_slots * 4)?;
        let debug = b(
            "debug",
            (desc.debug_views as u64 * desc.pixels * 16).max(16),
        )?;
        let mut init = Recorder::new(ctx, 1)?;
        init.pass(&format!("{label}.init"))
            .write(&keys)
            .write(&cells)
            .fill(0);
        init.finish()?;
        let pipe = |name: &str| pipeline(ctx, scene, label, name, &INTERFACE, desc.spec);
        let update = pipe("hash_table/update")?;
        let count = pipe("hash_table/count")?;
        Ok(HashTable {
            settings: settings.clone(),
            label,
            passes: desc.passes,
            spec: desc.spec.clone(),
            keys,
            cells,
            pixels,
            counters,
            debug,
            update,
            count,
            frames: 0,
            now: stamp(0),
            centre_hits: false,
        })
    }

    /// A pipeline of the method's over the scene's set and set 1 of
    /// `interface` (the table's, or one that starts with the table's
    /// bindings), with the table's push constants: `shader` (e.g.
    /// `hash_cache/primary`) for the scene's ray backend, named
    /// `{label}.{file name}`.
    pub fn pipeline(
        &self,
        ctx: &Arc<GpuContext>,
        scene: &SceneGpu,
        shader: &str,
        interface: &'static Interface,
    ) -> GpuResult<ComputePipeline> {
        pipeline(ctx, scene, self.label, shader, interface, &self.spec)
    }

    pub fn settings(&self) -> &HashCacheSettings {
        &self.settings
    }

    /// A pass of `pipeline` with the scene's set and the table's bindings
    /// declared in binding order (`frame` at 0: the method's `FrameBuf`) and
    /// this frame's push constants; a method's own bindings may follow.
    pub fn pass<'r, 'a>(
        &'a self,
        rec: &'r mut Recorder<'a>,
        name: &str,
        pipeline: &'a ComputePipeline,
        scene_set: &'a DescriptorSet,
        frame: &'a Buffer,
    ) -> ComputePass<'r, 'a> {
        let px = &self.pixels;
        rec.compute(name, pipeline)
            .shared(scene_set)
            .read(frame)
            .write(&self.keys)
            .write(&self.cells)
            .write(&px.hit)
            .write(&px.ray)
            .write(&px.cell)
            .write(&px.fallback)
            .write(&px.color)
            .write(&px.depth)
            .write(&px.first_hit)
            .write(&px.albedo)
            .write(&px.position)
            .write(&self.counters)
            .write(&self.debug)
            .push(&self.push())
    }

    pub fn keys(&self) -> &Buffer {
        &self.keys
    }
    pub fn cells(&self) -> &Buffer {
        &self.cells
    }
    pub fn pixels(&self) -> &PixelBuffers {
        &self.pixels
    }
    pub fn counters(&self) -> &Buffer {
        &self.counters
    }
    pub fn debug(&self) -> &Buffer {
        &self.debug
    }

    /// Starts a frame: its passes stamp the entries they touch with the
    /// next value of the frame counter.
    pub fn begin_frame(&mut self) {
        self.now = stamp(self.frames);
        self.frames += 1;
    }

    /// The push constants of the frame being recorded.
    pub fn push(&self) -> TablePush {
        TablePush::new(&self.settings, self.now, self.centre_hits)
    }

    /// Has `hash_cache/primary.comp` trace a second, unjittered ray through
    /// each pixel centre for a TAA (the method's own or `--taa-output`'s).
    /// Off, that ray is neither traced nor counted: the paper's HashCache
    /// traces "jittered first hits at 1 spp".
    pub fn set_centre_hits(&mut self, on: bool) {
        self.centre_hits = on;
    }

    pub fn centre_hits(&self) -> bool {
        self.centre_hits
    }

    /// `{p}clear`: zeroes the counters.
    pub fn record_clear<'a>(&'a self, rec: &mut Recorder<'a>) {
        rec.pass(&format!("{}clear", self.passes))
            .write(&self.counters)
            .fill(0);
    }

    /// `{p}update` (`update.comp`): the updater of each entry touched this
    /// frame traces one secondary path into its running mean; a pixel whose
    /// lookup failed traces its own into `fallback`.
    pub fn record_update<'a>(
        &'a self,
        rec: &mut Recorder<'a>,
        scene_set: &'a DescriptorSet,
        frame: &'a Buffer,
        groups: [u32; 3],
    ) -> GpuResult<()> {
        let name = format!("{}update", self.passes);
        self.pass(rec, &name, &self.update, scene_set, frame)
            .dispatch(groups)
    }

    /// `diag.{p}count` (`count.comp`): live entries into the counters.
    pub fn record_count<'a>(
        &'a self,
        rec: &mut Recorder<'a>,
        scene_set: &'a DescriptorSet,
        frame: &'a Buffer,
    ) -> GpuResult<()> {
        let name = format!("diag.{}count", self.passes);
        self.pass(rec, &name, &self.count, scene_set, frame)
            .dispatch(count_grid(self.settings.capacity))
    }

    /// Starts the frame counter at `frames` (tests of the wrap-around at 2^32).
    pub fn set_frame_counter(&mut self, frames: u64) {
        self.frames = frames;
    }

    /// Reads the table back (after a frame).
    pub fn snapshot(&self) -> GpuResult<TableSnapshot> {
        Ok(TableSnapshot {
            keys: self.keys.download_pod()?,
            cells: self.cells.download_pod()?,
            now: stamp(self.frames.saturating_sub(1)),
        })
    }

    /// The per-pixel lookup requests of the last frame read back
    /// (`[eye][pixel]`, tests): the rays (direction, t; t < 0 a miss) and
    /// the cells (slot, status | winner << 4, checksum, meta: the level of
    /// detail looked up is `VoxelKey { meta, .. }.level()`).
    pub fn pixel_requests(&self) -> GpuResult<PixelRequests> {
        Ok(PixelRequests {
            rays: self.pixels.ray.download_pod()?,
            cells: self.pixels.cell.download_pod()?,
        })
    }

    /// Bytes of the table's buffers (the method adds its frame buffer, TAA …).
    pub fn memory_bytes(&self) -> u64 {
        [&self.keys, &self.cells, &self.counters, &self.debug]
            .into_iter()
            .chain(self.pixels.all())
            .map(|b| b.size)
            .sum()
    }
}
