//! Interface of shaders/hybrid/ (src/methods/hybrid/): the hash table's
//! bindings ([`super::hash_table::BINDINGS`]) and push constants, then the
//! current sample cache's mask and first hits; counters after the table's.

use super::hash_table::{BINDINGS, PUSH};
use super::{read, Binding, CounterSlot, Interface};

crate::counter_slots! {
    /// Slots of hybrid's counters (`C_HY_*`): the table's slots first
    /// (`C_HT_*`, same order, asserted in the tests), then hybrid's own.
    pub enum HybridCounter("HY") {
        PrimaryRays = "PRIMARY",
        BounceRays = "BOUNCE",
        ShadowRays = "SHADOW",
        Found = "FOUND" => "cells_found",
        Reserved = "RESERVED" => "cells_reserved",
        Evicted = "EVICTED" => "cells_evicted_stale",
        Failed = "FAILED" => "probe_failures",
        Updates = "UPDATES" => "cell_updates",
        Fallback = "FALLBACK" => "fallback_paths",
        Live = "LIVE" => "live_entries",
        /// The table's misses count pixels without a visible sample here.
        Misses = "MISSES" => "pixels_without_samples",
        NonFiniteSamples = "NONFINITE_SAMPLES" => "non_finite_samples",
        LookedUp = "LOOKED_UP" => "samples_looked_up",
        Both = "BOTH" => "both_level_hits",
        FineOnly = "FINE_ONLY" => "fine_level_only",
        CoarseOnly = "COARSE_ONLY" => "coarse_level_only",
        NoLevel = "NO_LEVEL" => "no_level_hits",
        UpdatesFine = "UPD_FINE" => "updates_fine_level",
        UpdatesCoarse = "UPD_COARSE" => "updates_coarse_level",
        /// Pixels with visible surface and background samples (a
        /// silhouette against the environment): their colour mixes the two
        /// by coverage (resolve.comp), in both lookup modes.
        Silhouette = "SILHOUETTE" => "silhouette_pixels",
    }
}

const fn bindings() -> [Binding; 16] {
    let mut b = [read("mask_cur"); 16];
    let mut i = 0;
    while i < BINDINGS.len() {
        b[i] = BINDINGS[i];
        i += 1;
    }
    b[15] = read("fh_cur");
    b
}
const BINDINGS_HYBRID: [Binding; 16] = bindings();

/// Specialization constant id of the sample cache's slot count (N_SLOTS).
pub const SPEC_SLOTS: u32 = 20;
/// Specialization constant id of the lookup variant (PER_SAMPLE:
/// [`crate::methods::hybrid::HybridLookups::PerSample`]).
pub const SPEC_PER_SAMPLE: u32 = 21;

pub const INTERFACE: Interface = Interface {
    name: "hybrid",
    set: 1,
    bindings: &BINDINGS_HYBRID,
    push: &[PUSH],
    counters: &[HybridCounter::TABLE],
    spec: &[
        ("HYBRID_N_SLOTS", SPEC_SLOTS),
        ("HYBRID_PER_SAMPLE", SPEC_PER_SAMPLE),
    ],
};

#[cfg(test)]
mod tests {
    use super::super::hash_table::TableCounter;
    use super::*;

    #[test]
    fn the_tables_bindings_and_counters_come_first() {
        assert_eq!(&INTERFACE.bindings[..BINDINGS.len()], &BINDINGS[..]);
        let (t, h) = (TableCounter::TABLE.names, HybridCounter::TABLE.names);
        assert_eq!(&h[..t.len()], t);
    }
}
