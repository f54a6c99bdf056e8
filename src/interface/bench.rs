//! Interfaces of the benchmark kernels in shaders/bench/ (src/bench.rs).

use super::{read, write, CounterSlot, Interface, PushBlock, PushType};

crate::counter_slots! {
    /// Slots of `bench rays`' counters.
    pub enum BenchRaysCounter("BENCH_RAYS") {
        PrimaryRays = "PRIMARY_RAYS",
        BounceRays = "BOUNCE_RAYS",
        Hits = "HITS",
    }
}

/// Push constants of bench/rays.comp: 0 primary rays, 1 bounce rays.
pub const RAYS_PUSH: PushBlock = PushBlock {
    name: "BENCH_RAYS",
    fields: &[("mode", PushType::U32)],
};

/// bench/rays.comp. `hits` and `normals` are written by mode 0, read by mode 1.
pub const RAYS: Interface = Interface {
    name: "bench_rays",
    set: 1,
    bindings: &[
        read("frame"),
        write("hits"),
        write("normals"),
        write("counters"),
    ],
    push: &[RAYS_PUSH],
    counters: &[BenchRaysCounter::TABLE],
    spec: &[],
};

/// bench/scatter.comp: one first hit per pixel forward-projected.
pub const SCATTER: Interface = Interface {
    name: "bench_scatter",
    set: 1,
    bindings: &[read("frame"), read("src"), write("dst")],
    push: &[],
    counters: &[],
    spec: &[],
};

/// Push constants of bench/scatter_slots.comp.
pub const SCATTER_SLOTS_PUSH: PushBlock = PushBlock {
    name: "BENCH_SCATTER_SLOTS",
    fields: &[("slots", PushType::U32)],
};

/// bench/scatter_slots.comp: every occupied slot forward-projected.
pub const SCATTER_SLOTS: Interface = Interface {
    name: "bench_scatter_slots",
    set: 1,
    bindings: &[
        read("frame"),
        read("masks"),
        read("src_fh"),
        read("src_rad"),
        write("dst_fh"),
        write("dst_rad"),
    ],
    push: &[SCATTER_SLOTS_PUSH],
    counters: &[],
    spec: &[],
};
