//! The push constants of every pass over the table (`HASH_TABLE_PUSH` of
//! src/interface/hash_table.rs, `pc` in `shaders/hash_table/table.glsl`).

use crate::methods::hash_cache::{HashCacheSettings, HashLod};

/// [`crate::interface::hash_table::PUSH`], field for field.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TablePush {
    pub capacity: u32,
    pub max_probe: u32,
    /// Entries older than this many frames may be overwritten.
    pub stale: u32,
    /// Bit 0 tiles, bit 1 distance-normal LoD, bit 2 debug views, bit 3
    /// pixel-centre hits for TAA (hash_cache/primary.comp).
    pub flags: u32,
    /// Voxel edge / pixel footprint before quantization.
    pub lod_scale: f32,
    /// Running-mean count cap.
    pub max_samples: u32,
    /// The frame stamp (the method's frame counter + 1, mod 2^32).
    pub now: u32,
    pub pad: u32,
}

const _: () =
    assert!(std::mem::size_of::<TablePush>() == crate::interface::hash_table::PUSH.size() as usize);

impl TablePush {
    /// The push constants for the settings `h`, the frame stamp `now` and
    /// whether the pixel centres are traced for TAA.
    pub fn new(h: &HashCacheSettings, now: u32, centre_hits: bool) -> TablePush {
        TablePush {
            capacity: h.capacity,
            max_probe: h.max_probe,
            stale: h.stale_frames,
            flags: h.tiles as u32
                | ((h.lod == HashLod::DistanceNormal) as u32) << 1
                | (h.debug_views as u32) << 2
                | (centre_hits as u32) << 3,
            lod_scale: h.lod_scale,
            max_samples: h.max_samples,
            now,
            pad: 0,
        }
    }
}
