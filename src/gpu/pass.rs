//! The pass builder: every piece of GPU work is a named pass that declares the
//! buffers it reads and writes. The recorder inserts the barriers those
//! declarations imply and a pair of timestamps, so every pass is timed and
//! named the same way in reports (DESIGN.md, "Passes").

use super::buffer::Buffer;
use super::context::GpuContext;
use super::descriptors::DescriptorSet;
use super::error::{vk_err, GpuResult};
use super::pipeline::ComputePipeline;
use ash::vk;
use serde::Serialize;
use std::collections::HashSet;
use std::sync::Arc;

/// GPU time of one pass, from its timestamp pair.
#[derive(Clone, Debug, Serialize)]
pub struct PassTiming {
    pub name: String,
    pub ms: f64,
}

/// Records passes into one command buffer; `finish` submits, waits and
/// returns the timings.
pub struct Recorder {
    ctx: Arc<GpuContext>,
    cb: vk::CommandBuffer,
    queries: vk::QueryPool,
    max_passes: u32,
    names: Vec<String>,
    written: HashSet<vk::Buffer>,
    read: HashSet<vk::Buffer>,
    barriers: u32,
    finished: bool,
}

/// One pass being declared: `.read()`/`.write()` then an action.
pub struct Pass<'r> {
    rec: &'r mut Recorder,
    name: String,
    reads: Vec<vk::Buffer>,
    writes: Vec<vk::Buffer>,
}

impl Recorder {
    pub fn new(ctx: &Arc<GpuContext>, max_passes: u32) -> GpuResult<Recorder> {
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(ctx.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let cb = unsafe { ctx.device.allocate_command_buffers(&alloc) }
            .map_err(vk_err("vkAllocateCommandBuffers"))?[0];
        let qinfo = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(2 * max_passes.max(1));
        let queries = unsafe { ctx.device.create_query_pool(&qinfo, None) }
            .map_err(vk_err("vkCreateQueryPool"))?;
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        unsafe {
            ctx.device
                .begin_command_buffer(cb, &begin)
                .map_err(vk_err("vkBeginCommandBuffer"))?;
            ctx.device
                .cmd_reset_query_pool(cb, queries, 0, 2 * max_passes.max(1));
        }
        Ok(Recorder {
            ctx: ctx.clone(),
            cb,
            queries,
            max_passes,
            names: Vec::new(),
            written: HashSet::new(),
            read: HashSet::new(),
            barriers: 0,
            finished: false,
        })
    }

    pub fn pass(&mut self, name: &str) -> Pass<'_> {
        Pass {
            rec: self,
            name: name.to_string(),
            reads: Vec::new(),
            writes: Vec::new(),
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

    fn begin_pass(&mut self, name: &str, reads: &[vk::Buffer], writes: &[vk::Buffer]) -> u32 {
        assert!(
            (self.names.len() as u32) < self.max_passes,
            "recorder: more than {} passes",
            self.max_passes
        );
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
        unsafe {
            self.ctx.device.cmd_write_timestamp(
                self.cb,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                self.queries,
                2 * idx,
            )
        };
        idx
    }

    fn end_pass(&mut self, idx: u32) {
        unsafe {
            self.ctx.device.cmd_write_timestamp(
                self.cb,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                self.queries,
                2 * idx + 1,
            )
        };
    }

    /// Ends the command buffer, submits, waits, and returns one timing per pass.
    pub fn finish(mut self) -> GpuResult<Vec<PassTiming>> {
        self.finished = true;
        unsafe { self.ctx.device.end_command_buffer(self.cb) }
            .map_err(vk_err("vkEndCommandBuffer"))?;
        self.ctx.submit_and_wait(self.cb, "frame")?;
        let n = self.names.len();
        let mut timings = Vec::with_capacity(n);
        if n > 0 {
            let mut raw = vec![0u64; 2 * n];
            unsafe {
                self.ctx.device.get_query_pool_results(
                    self.queries,
                    0,
                    &mut raw,
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                )
            }
            .map_err(vk_err("vkGetQueryPoolResults"))?;
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

impl Drop for Recorder {
    fn drop(&mut self) {
        if self.ctx.is_abandoned() {
            return;
        }
        unsafe {
            if !self.finished {
                let _ = self.ctx.device.end_command_buffer(self.cb);
            }
            self.ctx
                .device
                .free_command_buffers(self.ctx.command_pool, &[self.cb]);
            self.ctx.device.destroy_query_pool(self.queries, None);
        }
    }
}

impl<'r> Pass<'r> {
    pub fn read(mut self, b: &Buffer) -> Self {
        self.reads.push(b.raw);
        self
    }
    pub fn write(mut self, b: &Buffer) -> Self {
        self.writes.push(b.raw);
        self
    }

    /// Dispatches `pipeline` with descriptor sets bound at 0.. and push constants.
    pub fn dispatch(
        self,
        pipeline: &ComputePipeline,
        sets: &[&DescriptorSet],
        push: &[u8],
        groups: [u32; 3],
    ) {
        self.record(pipeline, sets, push, |dev, cb| {
            if groups.iter().all(|&g| g > 0) {
                unsafe { dev.cmd_dispatch(cb, groups[0], groups[1], groups[2]) };
            }
        });
    }

    /// Like [`Self::dispatch`], with the workgroup counts read on the device
    /// from the `VkDispatchIndirectCommand` at byte `offset` of `args` (a
    /// [`Buffer::indirect_args`] written by an earlier pass; it is read by
    /// this one). The writer keeps the counts within
    /// `maxComputeWorkGroupCount`.
    pub fn dispatch_indirect(
        mut self,
        pipeline: &ComputePipeline,
        sets: &[&DescriptorSet],
        push: &[u8],
        args: &Buffer,
        offset: u64,
    ) {
        assert!(
            offset % 4 == 0 && offset + 12 <= args.size,
            "pass {}: indirect arguments outside their buffer",
            self.name
        );
        self.reads.push(args.raw);
        let raw = args.raw;
        self.record(pipeline, sets, push, |dev, cb| unsafe {
            dev.cmd_dispatch_indirect(cb, raw, offset)
        });
    }

    fn record(
        self,
        pipeline: &ComputePipeline,
        sets: &[&DescriptorSet],
        push: &[u8],
        dispatch: impl FnOnce(&ash::Device, vk::CommandBuffer),
    ) {
        let Pass {
            rec,
            name,
            reads,
            writes,
        } = self;
        let idx = rec.begin_pass(&name, &reads, &writes);
        let dev = &rec.ctx.device;
        let raw_sets: Vec<vk::DescriptorSet> = sets.iter().map(|s| s.raw).collect();
        unsafe {
            dev.cmd_bind_pipeline(rec.cb, vk::PipelineBindPoint::COMPUTE, pipeline.raw);
            if !raw_sets.is_empty() {
                dev.cmd_bind_descriptor_sets(
                    rec.cb,
                    vk::PipelineBindPoint::COMPUTE,
                    pipeline.layout,
                    0,
                    &raw_sets,
                    &[],
                );
            }
            if pipeline.push_size > 0 {
                assert!(
                    push.len() as u32 <= pipeline.push_size,
                    "pass {name}: push constants larger than declared"
                );
                let mut data = push.to_vec();
                data.resize(pipeline.push_size as usize, 0);
                dev.cmd_push_constants(
                    rec.cb,
                    pipeline.layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    &data,
                );
            }
        }
        dispatch(dev, rec.cb);
        rec.end_pass(idx);
    }

    /// Fills the whole of every written buffer with a 32-bit value.
    pub fn fill(self, value: u32) {
        let Pass {
            rec,
            name,
            reads,
            writes,
        } = self;
        let idx = rec.begin_pass(&name, &reads, &writes);
        for b in &writes {
            unsafe {
                rec.ctx
                    .device
                    .cmd_fill_buffer(rec.cb, *b, 0, vk::WHOLE_SIZE, value)
            };
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
        } = self;
        assert!(
            data.len() <= 65536 && data.len() % 4 == 0,
            "pass {name}: vkCmdUpdateBuffer size"
        );
        let idx = rec.begin_pass(&name, &reads, &writes);
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
        } = self;
        let idx = rec.begin_pass(&name, &reads, &writes);
        let region = [vk::BufferCopy::default().size(bytes)];
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
