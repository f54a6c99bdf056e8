//! Guard bands: a debugging aid against shader writes past the end of a
//! storage buffer (`GpuOptions::guard_bands`, `STEREOCACHE_GUARD_BANDS=1`).
//! Without robustBufferAccess (never enabled here) such a write lands in
//! whatever memory follows the buffer; on lavapipe device memory is host
//! memory, so it corrupts other buffers or, past an allocation block, the
//! process heap. With guard bands every buffer made by `Buffer::storage` /
//! `Buffer::indirect_args` is allocated with a band of `guard_len(size)`
//! bytes after its 16-byte aligned end, filled with [`CANARY`]; descriptors
//! bind and fills cover only the buffer's own `size`, so a correct shader
//! never touches the band. [`check`] copies every live band back and fails,
//! naming the buffer and the first overwritten byte, when one has changed
//! (the shared frame loop calls it after every frame when guard bands are on).
#![deny(clippy::undocumented_unsafe_blocks)]

use super::buffer::Buffer;
use super::context::GpuContext;
use super::error::{GpuError, GpuResult};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// The 32-bit pattern a band is filled with: a signalling-NaN bit pattern,
/// unlikely as a count, an index or a float a shader writes.
pub const CANARY: u32 = 0x7FA5_5A7F;

/// Largest band (bytes): a buffer's band is as long as the buffer itself
/// (a per-eye versus two-eye or per-pixel versus per-sample size mix-up
/// overruns by up to its whole size), at least 256 bytes, at most this.
const MAX_GUARD: u64 = 4 << 20;

/// Band length for a buffer of `size` bytes (a multiple of 16).
pub(crate) fn guard_len(size: u64) -> u64 {
    size.clamp(256, MAX_GUARD).div_ceil(16) * 16
}

/// Where a buffer's band starts: its size rounded up to 16 bytes, so a
/// fill of the buffer's own bytes (a multiple of 4) never reaches it.
pub(crate) fn guard_offset(size: u64) -> u64 {
    size.div_ceil(16) * 16
}

/// One live guarded buffer (registered by `Buffer`, removed at its drop).
#[derive(Clone, Debug)]
pub(crate) struct Band {
    pub raw: vk::Buffer,
    pub name: String,
    /// The buffer's own size (bytes a shader may touch).
    pub size: u64,
    pub offset: u64,
    pub len: u64,
}

/// Fills the band of a just-created buffer with the canary and waits.
pub(crate) fn arm(ctx: &GpuContext, band: &Band) -> GpuResult<()> {
    // SAFETY: `cb` is recording; the band lies inside the buffer's
    // allocation (offset + len is its allocated size), both multiples of 4,
    // and the buffer lives until submit_once has waited.
    ctx.submit_once_uncounted("guard band fill", |cb| unsafe {
        ctx.device
            .cmd_fill_buffer(cb, band.raw, band.offset, band.len, CANARY)
    })
}

/// Reads every live band back and fails with the buffers whose band changed
/// (name, first overwritten byte past the buffer's end, words changed).
/// Nothing to do when guard bands are off. Submits and waits once.
pub fn check(ctx: &Arc<GpuContext>) -> GpuResult<()> {
    let bands: Vec<Band> = match &ctx.guards {
        None => return Ok(()),
        Some(g) => g.lock().unwrap().values().cloned().collect(),
    };
    if bands.is_empty() {
        return Ok(());
    }
    let total: u64 = bands.iter().map(|b| b.len).sum();
    let staging = Buffer::new(
        ctx,
        "guard.readback",
        total,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
    )?;
    let mut at = 0u64;
    let regions: Vec<(vk::Buffer, vk::BufferCopy)> = bands
        .iter()
        .map(|b| {
            let r = vk::BufferCopy::default()
                .src_offset(b.offset)
                .dst_offset(at)
                .size(b.len);
            at += b.len;
            (b.raw, r)
        })
        .collect();
    // SAFETY: `cb` is recording; every band's buffer is live (registered
    // until its drop, and nothing drops while this runs: guard bands are a
    // test aid for one thread at a time — a context shared between threads
    // must not drop guarded buffers during a check), each region lies
    // inside its band and inside `staging`
    // (packed one after the other, `total` bytes), which lives until
    // submit_once has waited. All earlier submissions were waited for.
    ctx.submit_once_uncounted("guard band check", |cb| unsafe {
        for (raw, r) in &regions {
            ctx.device.cmd_copy_buffer(cb, *raw, staging.raw, &[*r]);
        }
        super::buffer::host_read_barrier(&ctx.device, cb);
    })?;
    let bytes = staging.read_mapped(0, total);
    let mut bad = Vec::new();
    let mut at = 0usize;
    for b in &bands {
        let words: &[u8] = &bytes[at..at + b.len as usize];
        at += b.len as usize;
        let changed: Vec<usize> = words
            .chunks_exact(4)
            .enumerate()
            .filter(|(_, w)| u32::from_le_bytes([w[0], w[1], w[2], w[3]]) != CANARY)
            .map(|(i, _)| i)
            .collect();
        if let Some(first) = changed.first() {
            bad.push(format!(
                "{} (byte {} past its end, {} of {} guard words changed)",
                b.name,
                b.offset - b.size + *first as u64 * 4,
                changed.len(),
                b.len / 4
            ));
        }
    }
    if bad.is_empty() {
        Ok(())
    } else {
        Err(GpuError::OutOfBounds(bad.join("; ")))
    }
}
