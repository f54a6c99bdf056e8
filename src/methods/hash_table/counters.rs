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

/// Share of a run's table lookups that may fail before the run warns.
pub const FAILED_LOOKUP_WARNING: f64 = 0.01;

/// The table's lookups of one frame (found, reserved, evicted, failed) and
/// those that failed, from its reported counters; `None` for a method
/// without the table's counters.
pub fn lookups_and_failures(
    counters: &std::collections::BTreeMap<String, f64>,
) -> Option<(f64, f64)> {
    use TableCounter::*;
    let get = |c: TableCounter| counters.get(c.report_name()?).copied();
    let failed = get(Failed)?;
    let lookups = get(Found)? + get(Reserved)? + get(Evicted)? + failed;
    Some((lookups, failed))
}

/// The warning of a run whose table failed more than
/// [`FAILED_LOOKUP_WARNING`] of its lookups: a full table (no entry within
/// the probe window old enough to replace) answers those pixels with their
/// own 1 spp path, so the method is not the one configured there.
pub fn failed_lookup_warning(method: &str, lookups: f64, failed: f64) -> Option<String> {
    (lookups > 0.0 && failed > FAILED_LOOKUP_WARNING * lookups).then(|| {
        format!(
            "{method}: {:.1} % of the hash table's lookups failed (the table is full: no entry within --hash-max-probe old enough to replace), and those pixels showed their own 1 spp path; raise --hash-capacity",
            100.0 * failed / lookups
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_table_warns() {
        let c: std::collections::BTreeMap<String, f64> = [
            ("cells_found", 900.0),
            ("cells_reserved", 50.0),
            ("cells_evicted_stale", 20.0),
            ("probe_failures", 30.0),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
        assert_eq!(lookups_and_failures(&c), Some((1000.0, 30.0)));
        let w = failed_lookup_warning("hash-cache", 1000.0, 30.0).unwrap();
        assert!(
            w.starts_with("hash-cache: 3.0 % of the hash table's lookups failed"),
            "{w}"
        );
        assert_eq!(failed_lookup_warning("hash-cache", 1000.0, 10.0), None);
        assert_eq!(failed_lookup_warning("hash-cache", 0.0, 0.0), None);
        assert_eq!(lookups_and_failures(&Default::default()), None);
    }
}
