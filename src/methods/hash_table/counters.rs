//! The table's counters as frame statistics: typed slots
//! ([`TableCounter`], src/interface/hash_table.rs; `C_HT_*` in the shaders)
//! read back by the shared frame loop, and the occupancy derived from them.

use crate::interface::hash_table::TableCounter;
use crate::interface::CounterSlot;
use crate::methods::{CounterOutput, RaySlots};

/// Report name of the table's occupancy: live entries / capacity.
pub const OCCUPANCY: &str = "table_occupancy";

/// The table's counter buffer as a frame output: every reported slot,
/// slots 0–2 as the frame's ray counts, and [`OCCUPANCY`] (live entries /
/// `capacity`).
pub fn table_counters(buffer: &crate::gpu::Buffer, capacity: u32) -> CounterOutput<'_> {
    use TableCounter::*;
    with_occupancy(
        CounterOutput::of::<TableCounter>(buffer).rays(RaySlots::of(
            &[PrimaryRays],
            &[BounceRays],
            &[ShadowRays],
        )),
        Live,
        capacity,
    )
}

/// Adds [`OCCUPANCY`] (`live` / `capacity`) to a counter output whose slot
/// `live` counts the table's live entries (the `count` pass's result).
pub fn with_occupancy<C: CounterSlot>(
    counters: CounterOutput<'_>,
    live: C,
    capacity: u32,
) -> CounterOutput<'_> {
    counters.ratio(live, OCCUPANCY, capacity as f64)
}
