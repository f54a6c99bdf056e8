//! The table's counter slots (`C_*` in `shaders/hash_table/table.glsl`) and
//! how a frame's counters become statistics. Slots 0–2 are the ray counts;
//! a method's own counters follow [`TABLE_COUNTER_SLOTS`].

use crate::methods::{named_counters, RayCounts};
use std::collections::BTreeMap;

/// Slots written by the table's shaders (and by the methods' lookup passes),
/// with report names. Slot 10 counts pixels without a lookup: named by the
/// method (`primary_misses` in hash-cache).
pub const TABLE_COUNTERS: &[(usize, &str)] = &[
    (3, "cells_found"),
    (4, "cells_reserved"),
    (5, "cells_evicted_stale"),
    (6, "probe_failures"),
    (7, "cell_updates"),
    (8, "fallback_paths"),
    (9, "live_entries"),
];
const C_LIVE: usize = 9;
const C_MISSES: usize = 10;

/// Counter slots the table's shaders use (0..=10).
pub const TABLE_COUNTER_SLOTS: u64 = 11;

/// Ray counts of slots 0 (primary), 1 (bounce) and 2 (shadow).
pub fn ray_counts(values: &[u32]) -> RayCounts {
    RayCounts {
        primary: values[0] as u64,
        bounce: values[1] as u64,
        shadow: values[2] as u64,
    }
}

/// The table's counters as statistics: the named slots, slot 10 as
/// `misses`, and `table_occupancy` (live entries / capacity).
pub fn table_counters(values: &[u32], capacity: u32, misses: &str) -> BTreeMap<String, f64> {
    let mut c = named_counters(values, TABLE_COUNTERS);
    c.insert(misses.to_string(), values[C_MISSES] as f64);
    c.insert(
        "table_occupancy".into(),
        values[C_LIVE] as f64 / capacity as f64,
    );
    c
}
