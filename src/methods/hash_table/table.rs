//! [`HashTable`]: the table's buffers (keys, cells, the per-pixel requests
//! and outputs, counters, debug views), its memory, its descriptor
//! interface (set 1, bindings 0–13 of `shaders/hash_table/table.glsl`) and
//! its passes: clear, update (insert results → running means), live-entry
//! count; plus the frame counter whose stamps age entries out.

use super::counters::TABLE_COUNTER_SLOTS;
use super::pixels::PixelBuffers;
use super::push::TablePush;
use crate::gpu::{
    Buffer, ComputePipeline, DescriptorLayout, DescriptorSet, GpuContext, GpuError, GpuResult,
    Recorder, Resource, SpecConstants,
};
use crate::methods::hash_cache::HashCacheSettings;
use crate::methods::reference::backend_shader;
use crate::rt::SceneGpu;
use std::sync::Arc;

/// Bytes per table entry: 8 (key word) + 16 (RGBA32F).
pub const ENTRY_BYTES: u64 = 24;

/// Bindings of set 1 the table defines (0 = the frame's `FrameBuf`, 1–13 its
/// buffers); a method's own bindings follow.
pub const TABLE_BINDINGS: usize = 14;

/// The frame counter stamped into table entries by a method's frame `k`
/// (0-based): k + 1 mod 2^32 (0 never stamps, so a zeroed table is empty).
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
    layout: &Arc<DescriptorLayout>,
    label: &str,
    shader: &str,
    spec: &SpecConstants,
) -> GpuResult<ComputePipeline> {
    let name = shader.rsplit('/').next().unwrap_or(shader);
    ComputePipeline::new(
        ctx,
        &format!("{label}.{name}"),
        backend_shader(shader, scene)?,
        &[scene.layout.clone(), layout.clone()],
        std::mem::size_of::<TablePush>() as u32,
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
    /// Counter slots (at least [`TABLE_COUNTER_SLOTS`]; the method's own follow).
    pub counter_slots: u64,
    /// The debug views written by the method's resolve (`[view][eye][pixel]`).
    pub debug_views: usize,
    /// Bindings of set 1 after the table's [`TABLE_BINDINGS`].
    pub extra_bindings: usize,
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
    layout: Arc<DescriptorLayout>,
    update: ComputePipeline,
    count: ComputePipeline,
    /// Frames rendered so far; frame k stamps entries with (k + 1) mod 2^32.
    frames: u64,
}

impl HashTable {
    /// Checks the settings and the device, creates the buffers, the layout
    /// of set 1 and the table's pipelines, and clears the table.
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &SceneGpu,
        settings: &HashCacheSettings,
        desc: TableDesc,
    ) -> GpuResult<HashTable> {
        settings.validate().map_err(GpuError::Unsupported)?;
        if !ctx.caps.buffer_int64_atomics {
            return Err(GpuError::Unsupported(format!(
                "device '{}' lacks shaderBufferInt64Atomics, which the hash cache's keys need",
                ctx.caps.name
            )));
        }
        assert!(desc.counter_slots >= TABLE_COUNTER_SLOTS);
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
        let layout = DescriptorLayout::buffers(ctx, TABLE_BINDINGS + desc.extra_bindings)?;
        let mut init = Recorder::new(ctx, 1)?;
        init.pass(&format!("{label}.init"))
            .write(&keys)
            .write(&cells)
            .fill(0);
        init.finish()?;
        let pipe = |name: &str| pipeline(ctx, scene, &layout, label, name, desc.spec);
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
            layout,
            update,
            count,
            frames: 0,
        })
    }

    /// A pipeline of the method's over the scene's set and the table's set 1,
    /// with the table's push constants: `shader` (e.g. `hash_cache/primary`)
    /// for the scene's ray backend, named `{label}.{file name}`.
    pub fn pipeline(
        &self,
        ctx: &Arc<GpuContext>,
        scene: &SceneGpu,
        shader: &str,
    ) -> GpuResult<ComputePipeline> {
        pipeline(ctx, scene, &self.layout, self.label, shader, &self.spec)
    }

    pub fn settings(&self) -> &HashCacheSettings {
        &self.settings
    }

    /// Layout of set 1 (the method's pipelines use it too).
    pub fn layout(&self) -> &Arc<DescriptorLayout> {
        &self.layout
    }

    /// Set 1: `frame` (binding 0), the table's buffers (1–13), then the
    /// method's `extra` buffers.
    pub fn descriptor_set(
        &self,
        ctx: &Arc<GpuContext>,
        frame: &Buffer,
        extra: &[&Buffer],
    ) -> GpuResult<DescriptorSet> {
        let buffers: Vec<&Buffer> = [frame, &self.keys, &self.cells]
            .into_iter()
            .chain(self.pixels.all())
            .chain([&self.counters, &self.debug])
            .chain(extra.iter().copied())
            .collect();
        let r: Vec<Resource> = buffers.into_iter().map(Resource::Buffer).collect();
        DescriptorSet::new(ctx, &self.layout, &r)
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

    /// The push constants of this frame.
    pub fn push(&self) -> TablePush {
        TablePush::new(&self.settings, stamp(self.frames))
    }

    /// `{p}clear`: zeroes the counters.
    pub fn record_clear(&self, rec: &mut Recorder) {
        rec.pass(&format!("{}clear", self.passes))
            .write(&self.counters)
            .fill(0);
    }

    /// `{p}update` (`update.comp`): the updater of each entry touched this
    /// frame traces one secondary path into its running mean; a pixel whose
    /// lookup failed traces its own into `fallback`. `sets` = scene set, set 1.
    pub fn record_update(&self, rec: &mut Recorder, sets: &[&DescriptorSet], groups: [u32; 3]) {
        let px = &self.pixels;
        rec.pass(&format!("{}update", self.passes))
            .read(&px.hit)
            .read(&px.ray)
            .read(&px.cell)
            .write(&self.cells)
            .write(&px.fallback)
            .write(&self.counters)
            .dispatch(&self.update, sets, bytemuck::bytes_of(&self.push()), groups);
    }

    /// `diag.{p}count` (`count.comp`): live entries into the counters.
    pub fn record_count(&self, rec: &mut Recorder, sets: &[&DescriptorSet]) {
        rec.pass(&format!("diag.{}count", self.passes))
            .read(&self.keys)
            .write(&self.counters)
            .dispatch(
                &self.count,
                sets,
                bytemuck::bytes_of(&self.push()),
                count_grid(self.settings.capacity),
            );
    }

    /// After a frame's passes: the next frame stamps the next value.
    pub fn end_frame(&mut self) {
        self.frames += 1;
    }

    /// Starts the frame counter at `frames` (tests of the wrap-around at 2^32).
    pub fn set_frame_counter(&mut self, frames: u64) {
        self.frames = frames;
    }

    /// The counters read back (after the frame's recorder has finished).
    pub fn read_counters(&self) -> GpuResult<Vec<u32>> {
        self.counters.download_pod()
    }

    /// Reads the table back (after a frame).
    pub fn snapshot(&self) -> GpuResult<TableSnapshot> {
        Ok(TableSnapshot {
            keys: self.keys.download_pod()?,
            cells: self.cells.download_pod()?,
            now: stamp(self.frames.saturating_sub(1)),
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
