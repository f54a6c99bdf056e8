//! Interface of the hash-grid table (shaders/hash_table/, src/methods/hash_table/):
//! set 1 of the table's passes (update.comp, count.comp) and of hash-cache's
//! (shaders/hash_cache/primary.comp, resolve.comp); hybrid's shaders add
//! their own bindings after these ([`super::hybrid`]). Also the test kernel
//! hash_test.comp.

use super::{read, write, Binding, CounterSlot, Interface, PushBlock, PushType};

crate::counter_slots! {
    /// Slots of the table's counters (`C_HT_*`). `FOUND + status` is
    /// indexed by lookup status in the shaders, so these four stay in order.
    pub enum TableCounter("HT") {
        PrimaryRays = "PRIMARY",
        BounceRays = "BOUNCE",
        ShadowRays = "SHADOW",
        Found = "FOUND" => "cells_found",
        Reserved = "RESERVED" => "cells_reserved",
        Evicted = "EVICTED" => "cells_evicted_stale",
        Failed = "FAILED" => "probe_failures",
        Updates = "UPDATES" => "cell_updates",
        Fallback = "FALLBACK" => "fallback_paths",
        /// Entries touched within the last `stale` frames (`count.comp`).
        Live = "LIVE" => "live_entries",
        /// Pixels without a lookup (hash-cache: primary rays that missed).
        Misses = "MISSES" => "primary_misses",
        /// Paths whose radiance came out ∞ or NaN, dropped (update.comp,
        /// hash_cache/primary.comp's misses).
        NonFiniteSamples = "NONFINITE_SAMPLES" => "non_finite_samples",
    }
}

/// Push constants of every pass over the table (`TablePush`).
pub const PUSH: PushBlock = PushBlock {
    name: "HASH_TABLE",
    fields: &[
        ("capacity", PushType::U32),
        ("max_probe", PushType::U32),
        // entries older than this many frames may be overwritten
        ("stale", PushType::U32),
        // bit 0 tiles, bit 1 distance-normal LoD, bit 2 debug views, bit 3 centre hits for TAA
        ("flags", PushType::U32),
        // voxel edge / pixel footprint before quantization
        ("lod_scale", PushType::F32),
        // running-mean count cap
        ("max_samples", PushType::U32),
        // the method's frame counter mod 2^32 (starts at 1)
        ("now", PushType::U32),
        ("pad", PushType::U32),
    ],
};

/// The table's bindings, in binding order (hybrid's interface starts with them).
pub const BINDINGS: [Binding; 14] = [
    read("frame"),
    write("keys"),
    write("cells"),
    write("pix_hit"),
    write("pix_ray"),
    write("pix_cell"),
    write("fallback"),
    write("color"),
    write("out_depth"),
    write("out_fh"),
    write("out_albedo"),
    write("position"),
    write("counters"),
    write("debug"),
];

pub const INTERFACE: Interface = Interface {
    name: "hash_table",
    set: 1,
    bindings: &BINDINGS,
    push: &[PUSH],
    counters: &[TableCounter::TABLE],
    spec: &[],
};

/// Push constants of hash_test.comp.
pub const TEST_PUSH: PushBlock = PushBlock {
    name: "HASH_TEST",
    fields: &[("count", PushType::U32), ("capacity", PushType::U32)],
};

/// The test kernel hash_test.comp (tests/hash_cache.rs): no scene set.
pub const TEST: Interface = Interface {
    name: "hash_test",
    set: 0,
    bindings: &[read("keys"), write("outs")],
    push: &[TEST_PUSH],
    counters: &[],
    spec: &[],
};
