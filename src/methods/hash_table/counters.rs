//! The table's counters as frame statistics: typed slots
//! ([`TableCounter`], src/interface/hash_table.rs; `C_HT_*` in the shaders)
//! read back by the shared frame loop, and the occupancy derived from them.

use crate::interface::hash_table::TableCounter;
use crate::methods::{CounterOutput, FrameStats, RaySlots};

/// The table's counter buffer as a frame output: every reported slot, and
/// slots 0–2 as the frame's ray counts.
pub fn table_counters(buffer: &crate::gpu::Buffer) -> CounterOutput<'_> {
    use TableCounter::*;
    CounterOutput::of::<TableCounter>(buffer).rays(RaySlots::of(
        &[PrimaryRays],
        &[BounceRays],
        &[ShadowRays],
    ))
}

/// Adds `table_occupancy` (live entries / capacity) to a frame's statistics.
pub fn add_occupancy(stats: &mut FrameStats, capacity: u32) {
    let live = stats.counters.get("live_entries").copied().unwrap_or(0.0);
    stats
        .counters
        .insert("table_occupancy".into(), live / capacity as f64);
}
