//! Descriptor set layouts and sets: storage buffers, arrays of sampled
//! images, and acceleration structures, bound by position.

use super::buffer::Buffer;
use super::context::GpuContext;
use super::error::{vk_err, GpuResult};
use super::texture::{GpuTexture, Sampler};
use ash::vk;
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingKind {
    StorageBuffer,
    /// An array of combined image samplers of this many elements (≥ 1).
    SampledImages(u32),
    AccelerationStructure,
}

pub struct DescriptorLayout {
    ctx: Arc<GpuContext>,
    pub raw: vk::DescriptorSetLayout,
    pub kinds: Vec<BindingKind>,
}

impl DescriptorLayout {
    /// Binding `i` of the set has kind `kinds[i]`, visible to compute shaders.
    pub fn new(ctx: &Arc<GpuContext>, kinds: &[BindingKind]) -> GpuResult<Arc<DescriptorLayout>> {
        let bindings: Vec<vk::DescriptorSetLayoutBinding> = kinds
            .iter()
            .enumerate()
            .map(|(i, k)| {
                let (ty, count) = descriptor_type(*k);
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(ty)
                    .descriptor_count(count)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: `info` and the bindings it points at live across the call;
        // the device is valid while `ctx` is.
        let raw = unsafe { ctx.device.create_descriptor_set_layout(&info, None) }
            .map_err(vk_err("vkCreateDescriptorSetLayout"))?;
        Ok(Arc::new(DescriptorLayout {
            ctx: ctx.clone(),
            raw,
            kinds: kinds.to_vec(),
        }))
    }

    /// A layout of `n` storage buffers at bindings 0..n.
    pub fn buffers(ctx: &Arc<GpuContext>, n: usize) -> GpuResult<Arc<DescriptorLayout>> {
        Self::new(ctx, &vec![BindingKind::StorageBuffer; n])
    }

    /// The per-pass set of `n` storage buffers that the pass builder binds
    /// (src/gpu/compute_pass.rs): a push-descriptor layout with `push`, else
    /// a plain one for per-pass sets.
    pub(crate) fn pass_buffers(
        ctx: &Arc<GpuContext>,
        n: usize,
        push: bool,
    ) -> GpuResult<Arc<DescriptorLayout>> {
        let bindings: Vec<vk::DescriptorSetLayoutBinding> = (0..n)
            .map(|i| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let mut info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        if push {
            info = info.flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR);
        }
        // SAFETY: `info` and the bindings it points at live across the call;
        // the device is valid while `ctx` is.
        let raw = unsafe { ctx.device.create_descriptor_set_layout(&info, None) }
            .map_err(vk_err("vkCreateDescriptorSetLayout"))?;
        Ok(Arc::new(DescriptorLayout {
            ctx: ctx.clone(),
            raw,
            kinds: vec![BindingKind::StorageBuffer; n],
        }))
    }
}

/// True when a pipeline created now binds its per-pass buffers with push
/// descriptors: the device has VK_KHR_push_descriptor and
/// `STEREOCACHE_NO_PUSH_DESCRIPTOR` is not `1` (which forces the per-pass
/// descriptor-set fallback for a whole run; tests of that path choose it
/// per pipeline, `PassBinding::DescriptorSets`). Each pipeline keeps the
/// answer it was created with.
pub(crate) fn use_push_descriptors(ctx: &GpuContext) -> bool {
    ctx.push_descriptor.is_some()
        && !std::env::var("STEREOCACHE_NO_PUSH_DESCRIPTOR").is_ok_and(|v| v == "1")
}

impl Drop for DescriptorLayout {
    fn drop(&mut self) {
        if self.ctx.is_abandoned() {
            return;
        }
        // SAFETY: every pipeline and set made with this layout holds an Arc of
        // it, so they are gone; a layout may be destroyed while command buffers
        // recorded with it are pending (only the sets and pipelines may not).
        unsafe {
            self.ctx
                .device
                .destroy_descriptor_set_layout(self.raw, None)
        };
    }
}

fn descriptor_type(k: BindingKind) -> (vk::DescriptorType, u32) {
    match k {
        BindingKind::StorageBuffer => (vk::DescriptorType::STORAGE_BUFFER, 1),
        BindingKind::SampledImages(n) => (vk::DescriptorType::COMBINED_IMAGE_SAMPLER, n.max(1)),
        BindingKind::AccelerationStructure => (vk::DescriptorType::ACCELERATION_STRUCTURE_KHR, 1),
    }
}

/// What to bind at one binding of a set.
pub enum Resource<'a> {
    Buffer(&'a Buffer),
    /// An image array: each element's image and the sampler it is read with.
    Images(Vec<(&'a GpuTexture, &'a Sampler)>),
    Accel(vk::AccelerationStructureKHR),
}

/// A descriptor set with its own pool, written once at creation.
pub struct DescriptorSet {
    ctx: Arc<GpuContext>,
    pool: vk::DescriptorPool,
    pub raw: vk::DescriptorSet,
    pub layout: Arc<DescriptorLayout>,
    /// Buffers of this persistent set that shaders write (the scene's
    /// memoization table): a pass whose pipeline writes the set counts
    /// them as written for the recorder's barriers. Empty: read-only.
    pub written: Vec<vk::Buffer>,
}

impl DescriptorSet {
    pub fn new(
        ctx: &Arc<GpuContext>,
        layout: &Arc<DescriptorLayout>,
        resources: &[Resource<'_>],
    ) -> GpuResult<DescriptorSet> {
        assert_eq!(
            resources.len(),
            layout.kinds.len(),
            "descriptor set: resource count differs from the layout"
        );
        let mut sizes: Vec<vk::DescriptorPoolSize> = Vec::new();
        for k in &layout.kinds {
            let (ty, count) = descriptor_type(*k);
            match sizes.iter_mut().find(|s| s.ty == ty) {
                Some(s) => s.descriptor_count += count,
                None => sizes.push(vk::DescriptorPoolSize {
                    ty,
                    descriptor_count: count,
                }),
            }
        }
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: `pool_info` and `sizes` live across the call.
        let pool = unsafe { ctx.device.create_descriptor_pool(&pool_info, None) }
            .map_err(vk_err("vkCreateDescriptorPool"))?;
        let layouts = [layout.raw];
        let alloc = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layouts);
        // SAFETY: the pool was just created for exactly this one set of this
        // layout (its sizes are the layout's), and `layouts` outlives the call.
        let raw = unsafe { ctx.device.allocate_descriptor_sets(&alloc) }
            .map_err(vk_err("vkAllocateDescriptorSets"))?[0];

        // Gather infos first so the write structs can point at them.
        let mut buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = Vec::new();
        let mut image_infos: Vec<Vec<vk::DescriptorImageInfo>> = Vec::new();
        let mut accel_handles: Vec<[vk::AccelerationStructureKHR; 1]> = Vec::new();
        for (r, k) in resources.iter().zip(&layout.kinds) {
            match (r, k) {
                (Resource::Buffer(b), BindingKind::StorageBuffer) => {
                    buffer_infos.push([vk::DescriptorBufferInfo::default()
                        .buffer(b.raw)
                        .offset(0)
                        .range(b.descriptor_range())])
                }
                (Resource::Images(list), BindingKind::SampledImages(n)) => {
                    assert!(
                        !list.is_empty() && list.len() as u32 <= (*n).max(1),
                        "image array size"
                    );
                    let mut v: Vec<vk::DescriptorImageInfo> = list
                        .iter()
                        .map(|(t, sampler)| {
                            vk::DescriptorImageInfo::default()
                                .sampler(sampler.raw)
                                .image_view(t.view)
                                .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)
                        })
                        .collect();
                    // Fill the rest of the array with the first image (every element must be valid).
                    while (v.len() as u32) < (*n).max(1) {
                        v.push(v[0]);
                    }
                    image_infos.push(v);
                }
                (Resource::Accel(a), BindingKind::AccelerationStructure) => {
                    accel_handles.push([*a])
                }
                _ => panic!("descriptor set: resource does not match the layout's binding kind"),
            }
        }
        let mut accel_writes: Vec<vk::WriteDescriptorSetAccelerationStructureKHR> = accel_handles
            .iter()
            .map(|h| {
                vk::WriteDescriptorSetAccelerationStructureKHR::default().acceleration_structures(h)
            })
            .collect();
        let (mut bi, mut ii, mut ai) = (0, 0, 0);
        let mut writes: Vec<vk::WriteDescriptorSet> = Vec::new();
        let accel_ptr = accel_writes.as_mut_ptr();
        for (binding, k) in layout.kinds.iter().enumerate() {
            let w = vk::WriteDescriptorSet::default()
                .dst_set(raw)
                .dst_binding(binding as u32);
            let w = match k {
                BindingKind::StorageBuffer => {
                    bi += 1;
                    w.descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .buffer_info(&buffer_infos[bi - 1])
                }
                BindingKind::SampledImages(_) => {
                    ii += 1;
                    w.descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                        .image_info(&image_infos[ii - 1])
                }
                BindingKind::AccelerationStructure => {
                    ai += 1;
                    let mut w = w.descriptor_type(vk::DescriptorType::ACCELERATION_STRUCTURE_KHR);
                    w.descriptor_count = 1;
                    // SAFETY: accel_writes outlives `writes` and is not moved until update_descriptor_sets returns.
                    w.p_next = unsafe { accel_ptr.add(ai - 1) } as *const std::ffi::c_void;
                    w
                }
            };
            writes.push(w);
        }
        // SAFETY: every write points into `buffer_infos`, `image_infos` or
        // `accel_writes`, all alive and unmoved until after this call; each
        // resource matched its binding's kind above, and the set is not in use.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
        drop(writes);
        drop(accel_writes);
        Ok(DescriptorSet {
            ctx: ctx.clone(),
            pool,
            raw,
            layout: layout.clone(),
            written: Vec::new(),
        })
    }
}

impl Drop for DescriptorSet {
    fn drop(&mut self) {
        if self.ctx.is_abandoned() {
            return;
        }
        // SAFETY: sets are bound only by recorders that borrow them until their
        // submission finished (an abandoned context returned above), so no
        // pending command buffer uses the set freed with its pool.
        unsafe { self.ctx.device.destroy_descriptor_pool(self.pool, None) };
    }
}
