//! Named storage buffers allocated through gpu-allocator, with upload and
//! readback through staging copies.
#![deny(clippy::undocumented_unsafe_blocks)]

use super::context::GpuContext;
use super::error::{vk_err, GpuError, GpuResult};
use super::guard::{self, Band};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::atomic::Ordering;
use std::sync::Arc;

pub struct Buffer {
    ctx: Arc<GpuContext>,
    pub name: String,
    pub raw: vk::Buffer,
    pub size: u64,
    /// Bytes of guard band after the buffer (0: none; src/gpu/guard.rs).
    guard: u64,
    allocation: Option<Allocation>,
}

/// Usage every storage buffer gets (compute read/write, copies, fills).
const STORAGE_USAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::STORAGE_BUFFER.as_raw()
        | vk::BufferUsageFlags::TRANSFER_SRC.as_raw()
        | vk::BufferUsageFlags::TRANSFER_DST.as_raw(),
);

/// Refuses a buffer meant for storage-descriptor binding (bound whole, as
/// `descriptors.rs` does) that is larger than the device's
/// `maxStorageBufferRange`: binding it is invalid
/// (VUID-VkWriteDescriptorSet-descriptorType-00333) and the shader's
/// accesses past the range are undefined. Checked before `vkCreateBuffer`,
/// so nothing is allocated, uploaded or rendered first.
pub fn check_storage_range(ctx: &GpuContext, name: &str, size: u64) -> GpuResult<()> {
    let limit = ctx.caps.max_storage_buffer_range;
    let bytes = size.max(16);
    if bytes <= limit {
        return Ok(());
    }
    let hint = if name.starts_with("scene.") || name.starts_with("bvh.") {
        "the scene is too large for this device (fewer triangles, lights or a smaller environment map)"
    } else if name.starts_with("memo.") {
        "reduce --memo-entries (a tiled entry holds --memo-tile² texel records, (s+1)² with --memo-bilinear)"
    } else {
        "reduce --size, --slots (sample cache) or --hash-capacity (hash table)"
    };
    Err(GpuError::StorageRange {
        what: name.to_string(),
        bytes,
        limit,
        device: ctx.caps.name.clone(),
        hint,
    })
}

impl Buffer {
    /// The VkBuffer's size: `size` plus the guard band, if any (the extent
    /// a command may touch without undefined behaviour; writes into the
    /// band are what guard.rs reports).
    pub(crate) fn vk_size(&self) -> u64 {
        self.size + self.guard
    }

    /// A device buffer of `size` bytes (at least 16) usable as a storage
    /// buffer; refused when larger than the device's `maxStorageBufferRange`.
    pub fn storage(ctx: &Arc<GpuContext>, name: &str, size: u64) -> GpuResult<Buffer> {
        check_storage_range(ctx, name, size)?;
        Self::guarded(ctx, name, size, STORAGE_USAGE)
    }

    /// A device buffer that shaders write: with guard bands on
    /// (src/gpu/guard.rs) it is allocated with a canary-filled band after
    /// its `size` bytes and registered for `guard::check`; else as `new`.
    fn guarded(
        ctx: &Arc<GpuContext>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> GpuResult<Buffer> {
        let Some(guards) = &ctx.guards else {
            return Self::new(ctx, name, size, usage, MemoryLocation::GpuOnly);
        };
        let size = size.max(16);
        let (offset, len) = (guard::guard_offset(size), guard::guard_len(size));
        let mut b = Self::create(ctx, name, offset + len, usage, MemoryLocation::GpuOnly)?;
        b.size = size;
        b.guard = offset + len - size;
        let band = Band {
            raw: b.raw,
            name: name.to_string(),
            size,
            offset,
            len,
        };
        guard::arm(ctx, &band)?;
        guards
            .lock()
            .unwrap()
            .insert(vk::Handle::as_raw(b.raw), band);
        Ok(b)
    }

    /// The range a descriptor binds: the whole buffer, or with a guard band
    /// exactly its `size` (the band stays outside every descriptor).
    pub(crate) fn descriptor_range(&self) -> vk::DeviceSize {
        if self.guard == 0 {
            vk::WHOLE_SIZE
        } else {
            self.size
        }
    }

    /// The byte count `vkCmdFillBuffer` covers to fill the whole buffer:
    /// `VK_WHOLE_SIZE`, or with a guard band `size` rounded up to 4 bytes
    /// (the band starts at a 16-byte boundary past it).
    pub(crate) fn fill_range(&self) -> vk::DeviceSize {
        if self.guard == 0 {
            vk::WHOLE_SIZE
        } else {
            self.size.div_ceil(4) * 4
        }
    }

    /// A buffer with exactly `usage` (plus device addresses when ray query is
    /// enabled). No `maxStorageBufferRange` check: for staging copies and
    /// buffers reached by device address (acceleration structures and their
    /// scratch), never bound as storage descriptors; those use
    /// [`Self::storage`], [`Self::indirect_args`] or [`Self::with_data`].
    pub fn new(
        ctx: &Arc<GpuContext>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> GpuResult<Buffer> {
        Self::create(ctx, name, size, usage, location)
    }

    /// `new` without a guard band (`guarded` adds one around it).
    fn create(
        ctx: &Arc<GpuContext>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> GpuResult<Buffer> {
        let size = size.max(16);
        let mut usage = usage;
        if ctx.ray_query_enabled() {
            usage |= vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        }
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: a valid create-info on the live device; the device-address
        // usage is added only when bufferDeviceAddress is enabled.
        let raw = unsafe { ctx.device.create_buffer(&info, None) }.map_err(|e| match e {
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
                GpuError::OutOfMemory {
                    what: name.to_string(),
                    bytes: size,
                }
            }
            other => GpuError::Vk {
                call: "vkCreateBuffer",
                result: other,
            },
        })?;
        // SAFETY: `raw` was just created on this device.
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(raw) };
        let allocation = ctx
            .allocator
            .lock()
            .unwrap()
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: `raw` has no memory bound and was never used.
                unsafe { ctx.device.destroy_buffer(raw, None) };
                return Err(match e {
                    gpu_allocator::AllocationError::OutOfMemory => GpuError::OutOfMemory {
                        what: name.to_string(),
                        bytes: size,
                    },
                    other => GpuError::Alloc {
                        what: name.to_string(),
                        message: other.to_string(),
                    },
                });
            }
        };
        // SAFETY: the allocation was made for `raw`'s requirements and is
        // bound once, before any use of the buffer.
        unsafe {
            ctx.device
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        }
        .map_err(vk_err("vkBindBufferMemory"))?;
        ctx.set_name(raw, name);
        ctx.allocated_bytes.fetch_add(size, Ordering::Relaxed);
        Ok(Buffer {
            ctx: ctx.clone(),
            name: name.to_string(),
            raw,
            size,
            guard: 0,
            allocation: Some(allocation),
        })
    }

    /// A storage buffer that compute shaders fill with
    /// `VkDispatchIndirectCommand`s for [`super::pass::Pass::dispatch_indirect`].
    pub fn indirect_args(ctx: &Arc<GpuContext>, name: &str, size: u64) -> GpuResult<Buffer> {
        check_storage_range(ctx, name, size)?;
        Self::guarded(
            ctx,
            name,
            size,
            STORAGE_USAGE | vk::BufferUsageFlags::INDIRECT_BUFFER,
        )
    }

    /// A storage buffer filled with `data` (through a staging copy); the
    /// range is checked before the staging copy is made.
    pub fn with_data(
        ctx: &Arc<GpuContext>,
        name: &str,
        data: &[u8],
        extra_usage: vk::BufferUsageFlags,
    ) -> GpuResult<Buffer> {
        check_storage_range(ctx, name, data.len() as u64)?;
        let buf = Self::new(
            ctx,
            name,
            data.len() as u64,
            STORAGE_USAGE | extra_usage,
            MemoryLocation::GpuOnly,
        )?;
        buf.upload(data)?;
        Ok(buf)
    }

    /// Copies `data` to the start of the buffer and waits.
    pub fn upload(&self, data: &[u8]) -> GpuResult<()> {
        if data.is_empty() {
            return Ok(());
        }
        assert!(
            data.len() as u64 <= self.size,
            "upload larger than buffer {}",
            self.name
        );
        let staging = Self::new(
            &self.ctx,
            &format!("{}.staging", self.name),
            data.len() as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write_mapped(data);
        // SAFETY: `cb` is recording; both buffers live until `submit_once`
        // has waited, and the region lies within both (`data.len()` ≤ sizes).
        self.ctx.submit_once("buffer upload", |cb| unsafe {
            let region = [vk::BufferCopy::default().size(data.len() as u64)];
            self.ctx
                .device
                .cmd_copy_buffer(cb, staging.raw, self.raw, &region);
        })
    }

    /// Writes into a host-visible buffer's mapping (staging buffers).
    pub(crate) fn upload_mapped(&self, data: &[u8]) {
        self.write_mapped(data)
    }

    fn write_mapped(&self, data: &[u8]) {
        assert!(
            data.len() as u64 <= self.size,
            "write of {} bytes into the {}-byte buffer {}",
            data.len(),
            self.size,
            self.name
        );
        let alloc = self.allocation.as_ref().unwrap();
        let ptr = alloc
            .mapped_ptr()
            .expect("staging buffer is host visible")
            .as_ptr() as *mut u8;
        // SAFETY: the mapping covers the allocation, which is at least
        // `self.size` ≥ `data.len()` bytes (asserted above); host memory and
        // the mapping cannot overlap.
        unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), ptr, data.len()) };
    }

    /// Copies `len` bytes at `offset` out of a host-visible buffer's mapping
    /// (the frame's staging buffer, src/gpu/readback.rs; the caller has
    /// waited for the copies into it).
    pub(crate) fn read_mapped(&self, offset: u64, len: u64) -> Vec<u8> {
        assert!(
            offset + len <= self.size,
            "read_mapped outside {}",
            self.name
        );
        let alloc = self.allocation.as_ref().unwrap();
        let ptr = alloc
            .mapped_ptr()
            .expect("readback buffer is host visible")
            .as_ptr() as *const u8;
        let mut out = vec![0u8; len as usize];
        // SAFETY: the mapping covers `size` bytes and the range lies inside it;
        // no GPU work writes it any more (the submission was waited for).
        unsafe {
            std::ptr::copy_nonoverlapping(ptr.add(offset as usize), out.as_mut_ptr(), out.len())
        };
        out
    }

    /// Reads the whole buffer back to the host (waits for the GPU).
    /// The copy's writes are made visible to the host by a barrier before
    /// the fence (a fence wait alone does not, by the specification; until
    /// session 48 this relied on the staging memory being host-coherent).
    pub fn download(&self) -> GpuResult<Vec<u8>> {
        let staging = Self::new(
            &self.ctx,
            &format!("{}.readback", self.name),
            self.size,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        // SAFETY: `cb` is recording; both buffers are `self.size` bytes and
        // live until `submit_once` has waited.
        self.ctx.submit_once("buffer readback", |cb| unsafe {
            let region = [vk::BufferCopy::default().size(self.size)];
            self.ctx
                .device
                .cmd_copy_buffer(cb, self.raw, staging.raw, &region);
            host_read_barrier(&self.ctx.device, cb);
        })?;
        let alloc = staging.allocation.as_ref().unwrap();
        let ptr = alloc
            .mapped_ptr()
            .expect("readback buffer is host visible")
            .as_ptr() as *const u8;
        let mut out = vec![0u8; self.size as usize];
        // SAFETY: the GPU finished writing (submit_once waited); the mapping
        // holds `self.size` bytes, the length of `out`.
        unsafe { std::ptr::copy_nonoverlapping(ptr, out.as_mut_ptr(), out.len()) };
        Ok(out)
    }

    /// Reads the buffer back as a vector of plain-old-data values.
    pub fn download_pod<T: bytemuck::Pod>(&self) -> GpuResult<Vec<T>> {
        let bytes = self.download()?;
        let n = bytes.len() / std::mem::size_of::<T>();
        Ok(bytemuck::pod_collect_to_vec(
            &bytes[..n * std::mem::size_of::<T>()],
        ))
    }

    pub fn device_address(&self) -> u64 {
        assert!(
            self.ctx.ray_query_enabled(),
            "device address of {} without bufferDeviceAddress enabled",
            self.name
        );
        let info = vk::BufferDeviceAddressInfo::default().buffer(self.raw);
        // SAFETY: bufferDeviceAddress is enabled (asserted), so every buffer
        // was created with SHADER_DEVICE_ADDRESS usage and bound memory.
        unsafe { self.ctx.device.get_buffer_device_address(&info) }
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if self.ctx.is_abandoned() {
            return;
        }
        if let Some(guards) = &self.ctx.guards {
            guards.lock().unwrap().remove(&vk::Handle::as_raw(self.raw));
        }
        // SAFETY: recorders and sets that use the buffer hold it (or finished
        // waiting) before it drops, and after an abandoned submission we
        // returned above; the allocation is freed after the buffer.
        unsafe { self.ctx.device.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator.lock().unwrap().free(a);
        }
        self.ctx
            .allocated_bytes
            .fetch_sub(self.size + self.guard, Ordering::Relaxed);
    }
}

/// TRANSFER_WRITE → HOST_READ: makes a recorded copy's writes available to
/// the host once the submission's fence is waited on (as
/// `Recorder::read_back` does).
///
/// # Safety
/// `cb` is a command buffer of `device` in the recording state.
pub(crate) unsafe fn host_read_barrier(device: &ash::Device, cb: vk::CommandBuffer) {
    let after = [vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::HOST_READ)];
    // SAFETY: the caller's: `cb` is recording on `device`.
    unsafe {
        device.cmd_pipeline_barrier(
            cb,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::HOST,
            vk::DependencyFlags::empty(),
            &after,
            &[],
            &[],
        );
    }
}
