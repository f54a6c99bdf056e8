//! The persistent host-visible staging buffer of a method's per-frame
//! readback: [`super::Recorder::read_back`] records copies of the frame's
//! outputs and counters into it at the end of the command buffer, so a frame
//! costs one submit-and-wait, and the buffer is reused frame after frame
//! (it grows when a frame needs more).

use super::buffer::Buffer;
use super::context::GpuContext;
use super::error::GpuResult;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::{Arc, Mutex};

/// Where one source landed in the staging buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadbackRange {
    pub offset: u64,
    pub len: u64,
}

/// A staging buffer kept across frames.
#[derive(Default)]
pub struct HostReadback {
    buffer: Mutex<Option<Buffer>>,
}

impl HostReadback {
    pub fn new() -> Self {
        Self::default()
    }

    /// The raw staging buffer, at least `bytes` long (reallocated when smaller).
    pub(crate) fn ensure(&self, ctx: &Arc<GpuContext>, bytes: u64) -> GpuResult<vk::Buffer> {
        let mut guard = self.buffer.lock().unwrap();
        if guard.as_ref().is_none_or(|b| b.size < bytes) {
            *guard = None;
            *guard = Some(Buffer::new(
                ctx,
                "frame.readback",
                bytes,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?);
        }
        Ok(guard.as_ref().unwrap().raw)
    }

    /// Bytes of `range` (after the recorder that copied them has finished).
    pub fn bytes(&self, range: ReadbackRange) -> Vec<u8> {
        let guard = self.buffer.lock().unwrap();
        let b = guard
            .as_ref()
            .expect("HostReadback::bytes before a read_back");
        b.read_mapped(range.offset, range.len)
    }

    /// `range` as plain-old-data values.
    pub fn pod<T: bytemuck::Pod>(&self, range: ReadbackRange) -> Vec<T> {
        let bytes = self.bytes(range);
        let n = bytes.len() / std::mem::size_of::<T>();
        bytemuck::pod_collect_to_vec(&bytes[..n * std::mem::size_of::<T>()])
    }

    /// Host memory held (0 before the first frame).
    pub fn size(&self) -> u64 {
        self.buffer.lock().unwrap().as_ref().map_or(0, |b| b.size)
    }
}
