//! The recorder: every piece of GPU work is a named pass that declares the
//! buffers it reads and writes. The recorder inserts the barriers those
//! declarations imply, a pair of timestamps and a debug-utils label, so every
//! pass is timed and named the same way in reports and in RenderDoc/Nsight
//! captures (DESIGN.md, "Passes"). Compute passes are built with
//! [`Recorder::compute`] (src/gpu/compute_pass.rs: the declarations are the
//! bindings); [`Recorder::pass`] records fills, updates and copies.
//!
//! `Recorder<'a>` borrows every buffer, pipeline and set a compute pass
//! references for `'a`, so safe code cannot drop one before the work is
//! submitted and waited for ([`Recorder::finish`]).

use super::buffer::Buffer;
use super::context::GpuContext;
use super::error::{vk_err, GpuResult};
use super::readback::{HostReadback, ReadbackRange};
use ash::vk;
use serde::Serialize;
use std::collections::HashSet;
use std::marker::PhantomData;
use std::sync::Arc;

/// Timestamp pairs per query pool; the recorder adds pools as passes come.
const PASSES_PER_POOL: u32 = 64;

/// GPU time of one pass, from its timestamp pair.
#[derive(Clone, Debug, Serialize)]
pub struct PassTiming {
    pub name: String,
    pub ms: f64,
}

/// Records passes into one command buffer; `finish` submits, waits and
/// returns the timings. `'a` is the lifetime of the resources compute
/// passes reference.
pub struct Recorder<'a> {
    pub(crate) ctx: Arc<GpuContext>,
    /// The recorder's own command pool (destroyed in Drop) and its buffer.
    pool: vk::CommandPool,
    pub(crate) cb: vk::CommandBuffer,
    /// Query pools of `pool_sizes[i]` timestamp pairs each.
    queries: Vec<vk::QueryPool>,
    pool_sizes: Vec<u32>,
    names: Vec<String>,
    written: HashSet<vk::Buffer>,
    read: HashSet<vk::Buffer>,
    barriers: u32,
    finished: bool,
    /// Pools of the per-pass descriptor sets where push descriptors are absent.
    pub(crate) descriptor_pools: Vec<vk::DescriptorPool>,
    read_back: bool,
    _borrows: PhantomData<&'a Buffer>,
}

/// One pass being declared: `.read()`/`.write()` then an action.
pub struct Pass<'r, 'a> {
    rec: &'r mut Recorder<'a>,
    name: String,
    reads: Vec<vk::Buffer>,
    writes: Vec<vk::Buffer>,
    /// `fill`'s byte count per written buffer (`Buffer::fill_range`).
    fill_ranges: Vec<vk::DeviceSize>,
    /// VkBuffer sizes of the first read and the first written buffer
    /// (`update` and `copy` check their byte counts against them; a guard
    /// band counts, so the guard-band test can overrun into it).
    first_read_size: Option<vk::DeviceSize>,
    first_write_size: Option<vk::DeviceSize>,
}

impl<'a> Recorder<'a> {
    /// A recorder with timestamps for `max_passes` passes to begin with
    /// (more are added as needed).
    pub fn new(ctx: &Arc<GpuContext>, max_passes: u32) -> GpuResult<Recorder<'a>> {
        // A transient pool of its own: a command pool needs external
        // synchronisation, so recorders on several threads share none. Its
        // creation, allocation and (in Drop) destruction still hold the
        // context's `command_buffer_lock`, for the validation layer's sake.
        let pools = ctx.command_buffer_lock();
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: `ctx.device` is live; the pool is destroyed in Drop (or
        // below on failure).
        let pool = unsafe { ctx.device.create_command_pool(&pool_info, None) }
            .map_err(vk_err("vkCreateCommandPool"))?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: the pool was just made on this device; the buffer, once
        // allocated, is not recording.
        let cb = unsafe {
            ctx.device
                .allocate_command_buffers(&alloc)
                .map_err(vk_err("vkAllocateCommandBuffers"))
                .and_then(|cbs| {
                    ctx.device
                        .begin_command_buffer(cbs[0], &begin)
                        .map_err(vk_err("vkBeginCommandBuffer"))
                        .map(|_| cbs[0])
                })
        };
        let cb = match cb {
            Ok(cb) => cb,
            Err(e) => {
                // SAFETY: nothing from the pool was submitted; destroying it
                // frees its buffer.
                unsafe { ctx.device.destroy_command_pool(pool, None) };
                return Err(e);
            }
        };
        drop(pools);
        let mut rec = Recorder {
            ctx: ctx.clone(),
            pool,
            cb,
            queries: Vec::new(),
            pool_sizes: Vec::new(),
            names: Vec::new(),
            written: HashSet::new(),
            read: HashSet::new(),
            barriers: 0,
            finished: false,
            descriptor_pools: Vec::new(),
            read_back: false,
            _borrows: PhantomData,
        };
        rec.add_query_pool(max_passes.max(1))?;
        Ok(rec)
    }

    /// A query pool for `passes` more timestamp pairs, reset in the command
    /// buffer before any of its queries is written.
    fn add_query_pool(&mut self, passes: u32) -> GpuResult<()> {
        let qinfo = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(2 * passes);
        // SAFETY: plain object creation; destroyed in Drop after the
        // submission has been waited for (or never submitted).
        let pool = unsafe { self.ctx.device.create_query_pool(&qinfo, None) }
            .map_err(vk_err("vkCreateQueryPool"))?;
        // SAFETY: `cb` is recording, outside any render pass.
        unsafe {
            self.ctx
                .device
                .cmd_reset_query_pool(self.cb, pool, 0, 2 * passes)
        };
        self.queries.push(pool);
        self.pool_sizes.push(passes);
        Ok(())
    }

    /// (pool, first query) of pass `idx`'s timestamp pair.
    fn query_slot(&self, idx: u32) -> (vk::QueryPool, u32) {
        let mut i = idx;
        for (pool, &n) in self.queries.iter().zip(&self.pool_sizes) {
            if i < n {
                return (*pool, 2 * i);
            }
            i -= n;
        }
        unreachable!("query slot of pass {idx} not allocated")
    }

    /// The device this recorder records for.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    pub fn pass(&mut self, name: &str) -> Pass<'_, 'a> {
        Pass {
            rec: self,
            name: name.to_string(),
            reads: Vec::new(),
            writes: Vec::new(),
            fill_ranges: Vec::new(),
            first_read_size: None,
            first_write_size: None,
        }
    }

    /// Number of passes recorded so far.
    pub fn pass_count(&self) -> usize {
        self.names.len()
    }

    /// Barriers the recorder inserted (for tests of the hazard tracking).
    pub fn barrier_count(&self) -> u32 {
        self.barriers
    }

    pub(crate) fn begin_pass(
        &mut self,
        name: &str,
        reads: &[vk::Buffer],
        writes: &[vk::Buffer],
    ) -> u32 {
        let capacity: u32 = self.pool_sizes.iter().sum();
        if self.names.len() as u32 >= capacity {
            // Out of query-pool memory is the only failure; it is reported
            // at `finish` as a missing pool would be (no timings), so the
            // pass is still recorded.
            if let Err(e) = self.add_query_pool(PASSES_PER_POOL) {
                panic!("recorder: cannot add a query pool for pass {name}: {e}");
            }
        }
        self.label_begin(name);
        let hazard = reads.iter().any(|b| self.written.contains(b))
            || writes
                .iter()
                .any(|b| self.written.contains(b) || self.read.contains(b));
        if hazard {
            // One global barrier for every hazard; the indirect-command
            // stage is in it because dispatch arguments are written by
            // shaders (Pass::dispatch_indirect).
            let barrier = vk::MemoryBarrier::default()
                .src_access_mask(
                    vk::AccessFlags::SHADER_WRITE
                        | vk::AccessFlags::SHADER_READ
                        | vk::AccessFlags::TRANSFER_WRITE
                        | vk::AccessFlags::TRANSFER_READ
                        | vk::AccessFlags::INDIRECT_COMMAND_READ,
                )
                .dst_access_mask(
                    vk::AccessFlags::SHADER_READ
                        | vk::AccessFlags::SHADER_WRITE
                        | vk::AccessFlags::TRANSFER_READ
                        | vk::AccessFlags::TRANSFER_WRITE
                        | vk::AccessFlags::INDIRECT_COMMAND_READ,
                );
            let stages = vk::PipelineStageFlags::COMPUTE_SHADER
                | vk::PipelineStageFlags::TRANSFER
                | vk::PipelineStageFlags::DRAW_INDIRECT;
            // SAFETY: `cb` is recording, outside any render pass; the barrier
            // structs live across the call.
            unsafe {
                self.ctx.device.cmd_pipeline_barrier(
                    self.cb,
                    stages,
                    stages,
                    vk::DependencyFlags::empty(),
                    &[barrier],
                    &[],
                    &[],
                )
            };
            self.written.clear();
            self.read.clear();
            self.barriers += 1;
        }
        self.read.extend(reads.iter().copied());
        self.written.extend(writes.iter().copied());
        let idx = self.names.len() as u32;
        self.names.push(name.to_string());
        let (pool, q) = self.query_slot(idx);
        // The start is written at BOTTOM_OF_PIPE: when every earlier command
        // has completed (vkCmdWriteTimestamp's first scope is all earlier
        // commands, limited to the stage named). At TOP_OF_PIPE (until
        // session 50) it waited only for earlier commands to *start*, so on
        // a GPU that overlaps dispatches without a barrier between them a
        // pass's interval covered its predecessor's work too and the sum of
        // pass times (gpu_ms) counted overlaps twice. Now the intervals tile
        // the frame: [all earlier work done, this pass done]. (llvmpipe runs
        // commands one after another: no difference there.)
        // SAFETY: `pool` was reset earlier in this command buffer; `q` < its size.
        unsafe {
            self.ctx.device.cmd_write_timestamp(
                self.cb,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                pool,
                q,
            )
        };
        idx
    }

    pub(crate) fn end_pass(&mut self, idx: u32) {
        let (pool, q) = self.query_slot(idx);
        // SAFETY: as in `begin_pass`.
        unsafe {
            self.ctx.device.cmd_write_timestamp(
                self.cb,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                pool,
                q + 1,
            )
        };
        self.label_end();
    }

    /// Opens a debug-utils label named after the pass (RenderDoc and Nsight
    /// show it) where VK_EXT_debug_utils is enabled.
    fn label_begin(&self, name: &str) {
        if let Some(du) = &self.ctx.debug_utils_device {
            let Ok(cname) = std::ffi::CString::new(name) else {
                return;
            };
            let label = vk::DebugUtilsLabelEXT::default().label_name(&cname);
            let _layer = self.ctx.command_buffer_lock();
            // SAFETY: `cb` is recording; the label's string outlives the call.
            unsafe { du.cmd_begin_debug_utils_label(self.cb, &label) };
        }
    }

    fn label_end(&self) {
        if let Some(du) = &self.ctx.debug_utils_device {
            let _layer = self.ctx.command_buffer_lock();
            // SAFETY: closes the label `label_begin` opened in this command buffer.
            unsafe { du.cmd_end_debug_utils_label(self.cb) };
        }
    }

    /// Records copies of `sources` into `staging` (packed one after the
    /// other, each at a 16-byte aligned offset) after every pass recorded
    /// so far, for the host to read after [`Recorder::finish`]: the frame's
    /// one batched readback. Not a pass (no timestamps), so frame
    /// statistics list the method's passes only.
    pub fn read_back(
        &mut self,
        staging: &'a HostReadback,
        sources: &[&'a Buffer],
    ) -> GpuResult<Vec<ReadbackRange>> {
        if self.read_back {
            return Err(super::GpuError::Interface(
                "Recorder::read_back called twice for one command buffer".into(),
            ));
        }
        self.read_back = true;
        let mut ranges = Vec::with_capacity(sources.len());
        let mut offset = 0u64;
        for b in sources {
            ranges.push(ReadbackRange {
                offset,
                len: b.size,
            });
            offset += b.size.div_ceil(16) * 16;
        }
        let dst = staging.ensure(&self.ctx, offset)?;
        let stages = vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER;
        let before = vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::TRANSFER_READ);
        let after = vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::HOST_READ);
        // SAFETY: `cb` is recording; every source and `dst` are live buffers
        // borrowed for 'a, and each region lies inside both.
        unsafe {
            let dev = &self.ctx.device;
            dev.cmd_pipeline_barrier(
                self.cb,
                stages,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[before],
                &[],
                &[],
            );
            for (b, r) in sources.iter().zip(&ranges) {
                let region = [vk::BufferCopy::default()
                    .src_offset(0)
                    .dst_offset(r.offset)
                    .size(r.len)];
                dev.cmd_copy_buffer(self.cb, b.raw, dst, &region);
            }
            dev.cmd_pipeline_barrier(
                self.cb,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &[after],
                &[],
                &[],
            );
        }
        // Later passes that write a source must wait for the copy.
        self.read.extend(sources.iter().map(|b| b.raw));
        Ok(ranges)
    }

    /// Ends the command buffer, submits, waits, and returns one timing per pass.
    pub fn finish(mut self) -> GpuResult<Vec<PassTiming>> {
        self.finished = true;
        // SAFETY: `cb` is recording (begun in `new`, ended only here) and no
        // debug label is left open (each pass closes its own).
        unsafe { self.ctx.device.end_command_buffer(self.cb) }
            .map_err(vk_err("vkEndCommandBuffer"))?;
        self.ctx.submit_and_wait(self.cb, "frame")?;
        let n = self.names.len();
        let mut timings = Vec::with_capacity(n);
        if n > 0 {
            let mut raw = vec![0u64; 2 * n];
            let mut done = 0usize;
            for (pool, &size) in self.queries.iter().zip(&self.pool_sizes) {
                let k = (size as usize).min(n - done);
                if k == 0 {
                    break;
                }
                // SAFETY: the first `k` pairs of `pool` were written by the
                // submission just waited for.
                unsafe {
                    self.ctx.device.get_query_pool_results(
                        *pool,
                        0,
                        &mut raw[2 * done..2 * (done + k)],
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                }
                .map_err(vk_err("vkGetQueryPoolResults"))?;
                done += k;
            }
            let bits = self.ctx.caps.timestamp_valid_bits;
            let mask = if bits >= 64 || bits == 0 {
                u64::MAX
            } else {
                (1u64 << bits) - 1
            };
            let period = self.ctx.caps.timestamp_period_ns as f64;
            for (i, name) in self.names.iter().enumerate() {
                let (a, b) = (raw[2 * i] & mask, raw[2 * i + 1] & mask);
                let ticks = b.wrapping_sub(a) & mask;
                timings.push(PassTiming {
                    name: name.clone(),
                    ms: ticks as f64 * period * 1e-6,
                });
            }
        }
        Ok(timings)
    }
}

impl Drop for Recorder<'_> {
    fn drop(&mut self) {
        if self.ctx.is_abandoned() {
            return;
        }
        // SAFETY: the command buffer is either finished and waited for or
        // never submitted, so nothing in flight uses these objects.
        unsafe {
            let pools = self.ctx.command_buffer_lock();
            if !self.finished {
                let _ = self.ctx.device.end_command_buffer(self.cb);
            }
            // Frees `cb` with it.
            self.ctx.device.destroy_command_pool(self.pool, None);
            drop(pools);
            for pool in &self.queries {
                self.ctx.device.destroy_query_pool(*pool, None);
            }
            for pool in &self.descriptor_pools {
                self.ctx.device.destroy_descriptor_pool(*pool, None);
            }
        }
    }
}

/// The buffers are borrowed for the recorder's `'a`, as a compute pass's
/// are: the commands reference them until the submit has been waited for.
impl<'a> Pass<'_, 'a> {
    pub fn read(mut self, b: &'a Buffer) -> Self {
        self.reads.push(b.raw);
        self.first_read_size.get_or_insert(b.vk_size());
        self
    }
    pub fn write(mut self, b: &'a Buffer) -> Self {
        self.writes.push(b.raw);
        self.first_write_size.get_or_insert(b.vk_size());
        self.fill_ranges.push(b.fill_range());
        self
    }

    /// Fills the whole of every written buffer with a 32-bit value.
    pub fn fill(self, value: u32) {
        let Pass {
            rec,
            name,
            reads,
            writes,
            fill_ranges,
            ..
        } = self;
        let idx = rec.begin_pass(&name, &reads, &writes);
        for (b, range) in writes.iter().zip(&fill_ranges) {
            // SAFETY: `cb` is recording; `b` is a live buffer borrowed for 'a and
            // the fill covers its whole size (short of a guard band).
            unsafe { rec.ctx.device.cmd_fill_buffer(rec.cb, *b, 0, *range, value) };
        }
        rec.end_pass(idx);
    }

    /// Writes `data` (≤ 65536 bytes, a multiple of 4) at the start of the
    /// first written buffer, inline in the command buffer (per-frame parameters).
    pub fn update(self, data: &[u8]) {
        let Pass {
            rec,
            name,
            reads,
            writes,
            first_write_size,
            ..
        } = self;
        assert!(
            data.len() <= 65536 && data.len() % 4 == 0,
            "pass {name}: vkCmdUpdateBuffer size"
        );
        let dst = first_write_size
            .unwrap_or_else(|| panic!("pass {name}: update without a written buffer"));
        assert!(
            data.len() as u64 <= dst,
            "pass {name}: {} bytes into a buffer of {dst}",
            data.len()
        );
        let idx = rec.begin_pass(&name, &reads, &writes);
        // SAFETY: `cb` is recording; `data` is at most 65536 bytes, a multiple
        // of 4, and fits the first written buffer (asserted above).
        unsafe { rec.ctx.device.cmd_update_buffer(rec.cb, writes[0], 0, data) };
        rec.end_pass(idx);
    }

    /// Copies the first read buffer into the first written buffer (`bytes` long).
    pub fn copy(self, bytes: u64) {
        let Pass {
            rec,
            name,
            reads,
            writes,
            first_read_size,
            first_write_size,
            ..
        } = self;
        let (src, dst) = first_read_size
            .zip(first_write_size)
            .unwrap_or_else(|| panic!("pass {name}: copy needs a read and a written buffer"));
        assert!(
            bytes > 0 && bytes <= src.min(dst),
            "pass {name}: copy of {bytes} bytes from a buffer of {src} into one of {dst}"
        );
        let idx = rec.begin_pass(&name, &reads, &writes);
        let region = [vk::BufferCopy::default().size(bytes)];
        // SAFETY: `cb` is recording; both buffers are live, borrowed for 'a,
        // and `bytes` (> 0, as Vulkan requires) lies within both (asserted
        // above).
        unsafe {
            rec.ctx
                .device
                .cmd_copy_buffer(rec.cb, reads[0], writes[0], &region)
        };
        rec.end_pass(idx);
    }
}

/// Workgroup count covering `n` items with groups of `local`.
pub fn groups_for(n: u32, local: u32) -> u32 {
    n.div_ceil(local)
}
