//! The compute-pass builder, in the pattern of kajiya's `SimpleRenderPass`:
//! a pass is made for a pipeline, and each `.read(&buf)` / `.write(&buf)`
//! both records the access for the recorder's barrier tracking and becomes
//! the next storage-buffer binding of the pass's set, in declaration order.
//! So a pass cannot use a buffer it did not declare. At `dispatch` the
//! declarations are checked against the pipeline's shader interface
//! (src/interface/: count, order by access, read versus write) and a
//! mismatch fails, naming the pass and the binding. The pipeline knows from
//! its SPIR-V which of those bindings the shader really uses and how
//! (src/gpu/reflect.rs, checked against the interface when the pipeline is
//! made): a binding the shader writes must be declared `.write()`, and only
//! the bindings it uses are bound and tracked, each with its real access, so
//! the recorder's barriers follow the pass's real hazards (read after write,
//! write after read or write) rather than the group's whole binding list.
//! The buffers are bound
//! with push descriptors (VK_KHR_push_descriptor); without the extension
//! (or with `STEREOCACHE_NO_PUSH_DESCRIPTOR=1`) each pass gets a descriptor
//! set from a pool the recorder owns and frees after the frame.
//!
//! ```ignore
//! rec.compute("reference.trace", &self.trace)
//!     .shared(&scene.set)          // persistent set 0
//!     .read(&self.frame)           // binding 0 (B_REFERENCE_FRAME)
//!     .write(&self.accum)          // binding 1 ...
//!     .push(&TracePush { .. })
//!     .dispatch(groups)?;
//! ```

use super::buffer::Buffer;
use super::descriptors::DescriptorSet;
use super::error::{vk_err, GpuError, GpuResult};
use super::pass::Recorder;
use super::pipeline::ComputePipeline;
use super::reflect::PassUse;
use crate::interface::Access;
use ash::vk;

/// Sets per fallback descriptor pool (with 32 storage buffers each).
const SETS_PER_POOL: u32 = 64;
const BUFFERS_PER_SET: u32 = 32;

/// A compute pass being declared; see the module docs.
pub struct ComputePass<'r, 'a> {
    rec: &'r mut Recorder<'a>,
    name: String,
    pipeline: &'a ComputePipeline,
    shared: Vec<&'a DescriptorSet>,
    bindings: Vec<(&'a Buffer, Access)>,
    push: Option<Vec<u8>>,
}

impl<'a> Recorder<'a> {
    /// A compute pass named `name` (timestamps, reports, debug label)
    /// running `pipeline`, which must have a shader interface
    /// ([`ComputePipeline::with_interface`]).
    pub fn compute<'r>(
        &'r mut self,
        name: &str,
        pipeline: &'a ComputePipeline,
    ) -> ComputePass<'r, 'a> {
        ComputePass {
            rec: self,
            name: name.to_string(),
            pipeline,
            shared: Vec::new(),
            bindings: Vec::new(),
            push: None,
        }
    }
}

impl<'a> ComputePass<'_, 'a> {
    /// The next persistent set (set 0, then 1, ... before the per-pass set).
    pub fn shared(mut self, set: &'a DescriptorSet) -> Self {
        self.shared.push(set);
        self
    }

    /// The next binding, only read by the shader.
    pub fn read(mut self, b: &'a Buffer) -> Self {
        self.bindings.push((b, Access::Read));
        self
    }

    /// The next binding, written (and perhaps read) by the shader.
    pub fn write(mut self, b: &'a Buffer) -> Self {
        self.bindings.push((b, Access::Write));
        self
    }

    /// The push constants (a `#[repr(C)]` Pod struct whose size is the
    /// pipeline's push block's, asserted at compile time beside its type).
    pub fn push<T: bytemuck::Pod>(mut self, value: &T) -> Self {
        self.push = Some(bytemuck::bytes_of(value).to_vec());
        self
    }

    /// Dispatches `groups` workgroups (nothing when one count is 0).
    pub fn dispatch(self, groups: [u32; 3]) -> GpuResult<()> {
        self.record(None, |dev, cb| {
            if groups.iter().all(|&g| g > 0) {
                // SAFETY: `cb` is recording with the pipeline and its sets bound.
                unsafe { dev.cmd_dispatch(cb, groups[0], groups[1], groups[2]) };
            }
        })
    }

    /// Dispatches with the workgroup counts read on the device from the
    /// `VkDispatchIndirectCommand` at byte `offset` of `args` (a
    /// [`Buffer::indirect_args`] written by an earlier pass; read by this
    /// one for the barriers, not bound).
    pub fn dispatch_indirect(self, args: &'a Buffer, offset: u64) -> GpuResult<()> {
        if offset % 4 != 0 || offset + 12 > args.size {
            return Err(GpuError::Interface(format!(
                "pass {}: indirect arguments at byte {offset} outside {} ({} bytes)",
                self.name, args.name, args.size
            )));
        }
        let raw = args.raw;
        self.record(Some(raw), move |dev, cb| {
            // SAFETY: the argument range lies inside `args` (checked above),
            // which the recorder borrows for its lifetime.
            unsafe { dev.cmd_dispatch_indirect(cb, raw, offset) }
        })
    }

    /// The declarations against the pipeline's interface.
    fn check(&self) -> GpuResult<()> {
        let p = self.pipeline;
        let pass = &self.name;
        let iface = p.interface;
        if self.shared.len() as u32 != p.shared_sets {
            return Err(GpuError::Interface(format!(
                "pass {pass}: {} shared set(s) given, pipeline {} has {}",
                self.shared.len(),
                p.name,
                p.shared_sets
            )));
        }
        // What the shader really does (reflected from its SPIR-V when the
        // pipeline was made) against the declarations: a binding it writes
        // must be declared `.write()`; one it reads, `.read()` or `.write()`.
        for (i, (u, (b, got))) in p.uses.iter().zip(&self.bindings).enumerate() {
            if *u == PassUse::Write && *got != Access::Write {
                return Err(GpuError::Interface(format!(
                    "pass {pass}: binding {i} `{}` is written by shader {}, declared .{}({})",
                    iface.bindings[i].name,
                    p.name,
                    got.word(),
                    b.name
                )));
            }
        }
        for (i, want) in iface.bindings.iter().enumerate() {
            match self.bindings.get(i) {
                None => {
                    return Err(GpuError::Interface(format!(
                        "pass {pass}: binding {i} `{}` ({}) of interface {} was not declared ({} declared)",
                        want.name,
                        want.access.word(),
                        iface.name,
                        self.bindings.len()
                    )))
                }
                Some((b, got)) if *got != want.access => {
                    return Err(GpuError::Interface(format!(
                        "pass {pass}: binding {i} `{}` of interface {} is {}, declared .{}({})",
                        want.name,
                        iface.name,
                        want.access.word(),
                        got.word(),
                        b.name
                    )))
                }
                _ => {}
            }
        }
        if self.bindings.len() > iface.bindings.len() {
            let (b, _) = self.bindings[iface.bindings.len()];
            return Err(GpuError::Interface(format!(
                "pass {pass}: {} declared, interface {} has {} binding(s) (first extra: {})",
                self.bindings.len(),
                iface.name,
                iface.bindings.len(),
                b.name
            )));
        }
        let push_len = self.push.as_ref().map_or(0, |v| v.len()) as u32;
        if push_len != p.push_size {
            return Err(GpuError::Interface(format!(
                "pass {pass}: {push_len} bytes of push constants given, pipeline {} takes {}",
                p.name, p.push_size
            )));
        }
        Ok(())
    }

    fn record(
        self,
        indirect: Option<vk::Buffer>,
        dispatch: impl FnOnce(&ash::Device, vk::CommandBuffer),
    ) -> GpuResult<()> {
        self.check()?;
        let ComputePass {
            rec,
            name,
            pipeline,
            shared,
            bindings,
            push,
        } = self;
        // Only the bindings the shader uses are bound, and the hazards are
        // those of its real accesses (a buffer declared `.write()` that the
        // shader only reads is tracked as read).
        let used: Vec<(u32, &Buffer, PassUse)> = bindings
            .iter()
            .zip(&pipeline.uses)
            .enumerate()
            .filter(|(_, (_, u))| **u != PassUse::Unused)
            .map(|(i, ((b, _), u))| (i as u32, *b, *u))
            .collect();
        let mut reads: Vec<vk::Buffer> = used
            .iter()
            .filter(|(_, _, u)| *u == PassUse::Read)
            .map(|(_, b, _)| b.raw)
            .collect();
        reads.extend(indirect);
        let mut writes: Vec<vk::Buffer> = used
            .iter()
            .filter(|(_, _, u)| *u == PassUse::Write)
            .map(|(_, b, _)| b.raw)
            .collect();
        // A pipeline that writes a persistent set (the scene's memoization
        // table) writes the buffers that set lists as written.
        if pipeline.writes_persistent {
            for s in &shared {
                writes.extend(s.written.iter().copied());
            }
        }
        let fallback_set = match pipeline.push_descriptors {
            true => None,
            false => Some(allocate_pass_set(rec, pipeline)?),
        };
        let idx = rec.begin_pass(&name, &reads, &writes);
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = used
            .iter()
            .map(|(_, b, _)| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(b.raw)
                    .offset(0)
                    .range(b.descriptor_range())]
            })
            .collect();
        let writes: Vec<vk::WriteDescriptorSet> = infos
            .iter()
            .zip(&used)
            .map(|(info, (i, _, _))| {
                vk::WriteDescriptorSet::default()
                    .dst_set(fallback_set.unwrap_or_default())
                    .dst_binding(*i)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(info)
            })
            .collect();
        let dev = &rec.ctx.device;
        let cb = rec.cb;
        let raw_shared: Vec<vk::DescriptorSet> = shared.iter().map(|s| s.raw).collect();
        // SAFETY: `cb` is recording; the pipeline, its layout, the shared
        // sets and every bound buffer are borrowed for the recorder's
        // lifetime 'a, so they outlive the submission; the writes match the
        // pipeline's per-pass layout (checked against its interface above).
        unsafe {
            dev.cmd_bind_pipeline(cb, vk::PipelineBindPoint::COMPUTE, pipeline.raw);
            if !raw_shared.is_empty() {
                dev.cmd_bind_descriptor_sets(
                    cb,
                    vk::PipelineBindPoint::COMPUTE,
                    pipeline.layout,
                    0,
                    &raw_shared,
                    &[],
                );
            }
            let pd = rec.ctx.push_descriptor.as_ref();
            match (pd.filter(|_| pipeline.push_descriptors), fallback_set) {
                (Some(pd), _) => {
                    if !writes.is_empty() {
                        pd.cmd_push_descriptor_set(
                            cb,
                            vk::PipelineBindPoint::COMPUTE,
                            pipeline.layout,
                            pipeline.shared_sets,
                            &writes,
                        )
                    }
                }
                (None, Some(set)) => {
                    dev.update_descriptor_sets(&writes, &[]);
                    dev.cmd_bind_descriptor_sets(
                        cb,
                        vk::PipelineBindPoint::COMPUTE,
                        pipeline.layout,
                        pipeline.shared_sets,
                        &[set],
                        &[],
                    );
                }
                (None, None) => {
                    unreachable!("a fallback set is allocated without push descriptors")
                }
            }
            if let Some(data) = &push {
                if !data.is_empty() {
                    dev.cmd_push_constants(
                        cb,
                        pipeline.layout,
                        vk::ShaderStageFlags::COMPUTE,
                        0,
                        data,
                    );
                }
            }
        }
        dispatch(dev, cb);
        rec.end_pass(idx);
        Ok(())
    }
}

/// A per-pass descriptor set for `pipeline` from the recorder's pools (the
/// path without VK_KHR_push_descriptor); the pools die with the recorder.
fn allocate_pass_set(
    rec: &mut Recorder<'_>,
    pipeline: &ComputePipeline,
) -> GpuResult<vk::DescriptorSet> {
    let layout = [pipeline.pass_layout_raw()];
    let n = pipeline.interface.bindings.len() as u32;
    if n > BUFFERS_PER_SET {
        return Err(GpuError::Interface(format!(
            "pipeline {}: {n} bindings, the fallback descriptor pools hold {BUFFERS_PER_SET} per set",
            pipeline.name
        )));
    }
    if let Some(&pool) = rec.descriptor_pools.last() {
        let alloc = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layout);
        // SAFETY: pool and layout are live objects of this device.
        match unsafe { rec.ctx.device.allocate_descriptor_sets(&alloc) } {
            Ok(sets) => return Ok(sets[0]),
            Err(vk::Result::ERROR_OUT_OF_POOL_MEMORY | vk::Result::ERROR_FRAGMENTED_POOL) => {}
            Err(e) => return Err(vk_err("vkAllocateDescriptorSets")(e)),
        }
    }
    let sizes = [vk::DescriptorPoolSize {
        ty: vk::DescriptorType::STORAGE_BUFFER,
        descriptor_count: SETS_PER_POOL * BUFFERS_PER_SET,
    }];
    let info = vk::DescriptorPoolCreateInfo::default()
        .max_sets(SETS_PER_POOL)
        .pool_sizes(&sizes);
    // SAFETY: plain object creation; destroyed when the recorder drops,
    // after its submission was waited for.
    let pool = unsafe { rec.ctx.device.create_descriptor_pool(&info, None) }
        .map_err(vk_err("vkCreateDescriptorPool"))?;
    rec.descriptor_pools.push(pool);
    let alloc = vk::DescriptorSetAllocateInfo::default()
        .descriptor_pool(pool)
        .set_layouts(&layout);
    // SAFETY: as above, from a fresh pool with room for the set.
    let sets = unsafe { rec.ctx.device.allocate_descriptor_sets(&alloc) }
        .map_err(vk_err("vkAllocateDescriptorSets"))?;
    Ok(sets[0])
}
