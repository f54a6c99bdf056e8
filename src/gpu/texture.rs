//! Sampled 2D images (material textures with mip chains, environment maps).
#![deny(clippy::undocumented_unsafe_blocks)]

use super::buffer::Buffer;
use super::context::GpuContext;
use super::error::{vk_err, GpuError, GpuResult};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::atomic::Ordering;
use std::sync::Arc;

/// Bytes per texel of the formats textures are created with.
fn texel_bytes(format: vk::Format) -> Option<u64> {
    match format {
        vk::Format::R8G8B8A8_SRGB | vk::Format::R8G8B8A8_UNORM => Some(4),
        vk::Format::R32G32B32A32_SFLOAT => Some(16),
        _ => None,
    }
}

pub struct GpuTexture {
    ctx: Arc<GpuContext>,
    pub name: String,
    pub image: vk::Image,
    pub view: vk::ImageView,
    allocation: Option<Allocation>,
    bytes: u64,
}

impl GpuTexture {
    /// Creates a sampled image of `format` from tightly packed mip levels
    /// (level 0 first) and leaves it in SHADER_READ_ONLY_OPTIMAL.
    pub fn new(
        ctx: &Arc<GpuContext>,
        name: &str,
        format: vk::Format,
        width: u32,
        height: u32,
        levels: &[&[u8]],
    ) -> GpuResult<GpuTexture> {
        let mip_count = levels.len() as u32;
        // The copies below read `extent × texel` bytes per level from the
        // staging buffer: check the levels hold them.
        let texel = texel_bytes(format).ok_or_else(|| {
            GpuError::Unsupported(format!(
                "texture {name}: format {format:?} is not supported"
            ))
        })?;
        for (m, l) in levels.iter().enumerate() {
            let need = u64::from((width >> m).max(1)) * u64::from((height >> m).max(1)) * texel;
            assert!(
                l.len() as u64 >= need,
                "texture {name}: mip level {m} has {} bytes, needs {need}",
                l.len()
            );
        }
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width,
                height,
                depth: 1,
            })
            .mip_levels(mip_count)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: a valid create-info on the live device.
        let image =
            unsafe { ctx.device.create_image(&info, None) }.map_err(vk_err("vkCreateImage"))?;
        // SAFETY: `image` was just created on this device.
        let requirements = unsafe { ctx.device.get_image_memory_requirements(image) };
        let allocation = ctx
            .allocator
            .lock()
            .unwrap()
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location: MemoryLocation::GpuOnly,
                linear: false,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|e| match e {
                gpu_allocator::AllocationError::OutOfMemory => GpuError::OutOfMemory {
                    what: name.into(),
                    bytes: requirements.size,
                },
                other => GpuError::Alloc {
                    what: name.into(),
                    message: other.to_string(),
                },
            })?;
        // SAFETY: the allocation was made for `image`'s requirements and is
        // bound once, before any use.
        unsafe {
            ctx.device
                .bind_image_memory(image, allocation.memory(), allocation.offset())
        }
        .map_err(vk_err("vkBindImageMemory"))?;
        ctx.set_name(image, name);
        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::COLOR)
            .base_mip_level(0)
            .level_count(mip_count)
            .base_array_layer(0)
            .layer_count(1);
        let view_info = vk::ImageViewCreateInfo::default()
            .image(image)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(range);
        // SAFETY: `image` has memory bound; the view's format and range
        // match its creation.
        let view = unsafe { ctx.device.create_image_view(&view_info, None) }
            .map_err(vk_err("vkCreateImageView"))?;

        // One staging buffer with all levels, copied level by level.
        let total: usize = levels.iter().map(|l| l.len()).sum();
        let mut packed = Vec::with_capacity(total);
        let mut offsets = Vec::new();
        for l in levels {
            offsets.push(packed.len() as u64);
            packed.extend_from_slice(l);
        }
        let staging = Buffer::new(
            ctx,
            &format!("{name}.staging"),
            total as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.upload_mapped(&packed);
        // SAFETY: `cb` is recording; the image and the staging buffer live
        // until `submit_once` has waited; each region lies within its mip
        // level and within the staging data (sizes checked at the top); the
        // barriers move every level UNDEFINED → TRANSFER_DST → SHADER_READ.
        ctx.submit_once("texture upload", |cb| unsafe {
            let to_dst = vk::ImageMemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::empty())
                .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .old_layout(vk::ImageLayout::UNDEFINED)
                .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image)
                .subresource_range(range);
            ctx.device.cmd_pipeline_barrier(
                cb,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_dst],
            );
            let regions: Vec<vk::BufferImageCopy> = (0..mip_count)
                .map(|m| {
                    vk::BufferImageCopy::default()
                        .buffer_offset(offsets[m as usize])
                        .image_subresource(
                            vk::ImageSubresourceLayers::default()
                                .aspect_mask(vk::ImageAspectFlags::COLOR)
                                .mip_level(m)
                                .base_array_layer(0)
                                .layer_count(1),
                        )
                        .image_extent(vk::Extent3D {
                            width: (width >> m).max(1),
                            height: (height >> m).max(1),
                            depth: 1,
                        })
                })
                .collect();
            ctx.device.cmd_copy_buffer_to_image(
                cb,
                staging.raw,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &regions,
            );
            let to_read = vk::ImageMemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::SHADER_READ)
                .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
                .new_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image)
                .subresource_range(range);
            ctx.device.cmd_pipeline_barrier(
                cb,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_read],
            );
        })?;
        ctx.allocated_bytes
            .fetch_add(requirements.size, Ordering::Relaxed);
        Ok(GpuTexture {
            ctx: ctx.clone(),
            name: name.into(),
            image,
            view,
            allocation: Some(allocation),
            bytes: requirements.size,
        })
    }
}

impl Drop for GpuTexture {
    fn drop(&mut self) {
        if self.ctx.is_abandoned() {
            return;
        }
        // SAFETY: users of the texture (descriptor sets, recorders) hold the
        // session that holds it, so no pending work refers to it (an
        // abandoned context returned above); the view goes before the image.
        unsafe {
            self.ctx.device.destroy_image_view(self.view, None);
            self.ctx.device.destroy_image(self.image, None);
        }
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator.lock().unwrap().free(a);
        }
        self.ctx
            .allocated_bytes
            .fetch_sub(self.bytes, Ordering::Relaxed);
    }
}

/// A sampler object owned with its context.
pub struct Sampler {
    ctx: Arc<GpuContext>,
    pub raw: vk::Sampler,
}

impl Sampler {
    /// Trilinear, repeat addressing (material textures) or clamp in v (environment maps).
    pub fn new(ctx: &Arc<GpuContext>, repeat_v: bool) -> GpuResult<Sampler> {
        let v = if repeat_v {
            vk::SamplerAddressMode::REPEAT
        } else {
            vk::SamplerAddressMode::CLAMP_TO_EDGE
        };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::REPEAT)
            .address_mode_v(v)
            .address_mode_w(vk::SamplerAddressMode::REPEAT)
            .max_lod(vk::LOD_CLAMP_NONE);
        Self::from_info(ctx, &info)
    }

    /// A sampler of the given settings (filters, address modes, LOD range;
    /// no extension structures in its chain).
    pub fn from_info(
        ctx: &Arc<GpuContext>,
        info: &vk::SamplerCreateInfo<'_>,
    ) -> GpuResult<Sampler> {
        assert!(info.p_next.is_null(), "Sampler::from_info: no p_next chain");
        // SAFETY: a create-info with no extension chain (checked above) on
        // the live device; its fields are plain values, validated by the
        // driver (and the validation layer in tests).
        let raw =
            unsafe { ctx.device.create_sampler(info, None) }.map_err(vk_err("vkCreateSampler"))?;
        Ok(Sampler {
            ctx: ctx.clone(),
            raw,
        })
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        if self.ctx.is_abandoned() {
            return;
        }
        // SAFETY: as for GpuTexture: no pending work uses the sampler.
        unsafe { self.ctx.device.destroy_sampler(self.raw, None) };
    }
}
