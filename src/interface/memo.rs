//! Interfaces of the memoization table's test kernels (shaders/memo/,
//! tests/memo.rs): the hash and probe kernel compared with the CPU twin
//! (src/materials/memo/table.rs) and the lock-and-validate stress kernel.

use super::{read, write, CounterSlot, Interface, PushBlock, PushType};

crate::counter_slots! {
    /// What the stress kernel's lanes saw (`C_MEMO_STRESS_*`). `FILLED +
    /// result` is indexed by memo_insert's result, so these five stay in order.
    pub enum StressCounter("MEMO_STRESS") {
        Hits = "HITS",
        /// Accepted reads whose record is not f(key): must stay 0.
        TornReads = "TORN_READS",
        /// Reads refused because the key changed during the read.
        Refused = "REFUSED",
        Misses = "MISSES",
        Filled = "FILLED",
        Evicted = "EVICTED",
        Present = "PRESENT",
        LockFailed = "LOCK_FAILED",
        /// Inserts that stored nothing: window full, eviction disabled.
        WindowFull = "WINDOW_FULL",
        /// Mode 2 (forced ABA): torn reads a validation by the key alone
        /// (the thesis's) would have accepted; the version refuses them.
        AbaKeyOnly = "ABA_KEY_ONLY",
    }
}

/// Push constants of memo/hash_test.comp.
pub const HASH_TEST_PUSH: PushBlock = PushBlock {
    name: "MEMO_HASH_TEST",
    fields: &[
        ("count", PushType::U32),
        ("capacity", PushType::U32),
        ("probe", PushType::U32),
        ("pad", PushType::U32),
    ],
};

/// memo/hash_test.comp: keys (graph, level, qu, qv) in, (H0, H1, 8 slots) out.
pub const HASH_TEST: Interface = Interface {
    name: "memo_hash_test",
    set: 0,
    bindings: &[read("keys"), write("outs")],
    push: &[HASH_TEST_PUSH],
    counters: &[],
    spec: &[],
};

/// Push constants of memo/stress.comp.
pub const STRESS_PUSH: PushBlock = PushBlock {
    name: "MEMO_STRESS",
    fields: &[
        // distinct keys the lanes draw from
        ("keys", PushType::U32),
        ("capacity", PushType::U32),
        ("probe", PushType::U32),
        // lookups per lane
        ("iterations", PushType::U32),
        // MEMO_RANDOM, MEMO_LRW, MEMO_LRU, MEMO_NO_EVICTION
        ("policy", PushType::U32),
        ("now", PushType::U32),
        ("seed", PushType::U32),
        // 0: lanes draw keys at random; 1: the forced read-during-write interleaving
        ("mode", PushType::U32),
    ],
};

/// Specialization constant id of the stress kernel's key re-read (1 = on).
pub const SPEC_REREAD: u32 = 0;

/// memo/stress.comp: the table's three buffers and the counters.
pub const STRESS: Interface = Interface {
    name: "memo_stress",
    set: 0,
    bindings: &[
        write("memo_keys"),
        write("memo_stamps"),
        write("memo_values"),
        write("counters"),
    ],
    push: &[STRESS_PUSH],
    counters: &[StressCounter::TABLE],
    spec: &[("MEMO_REREAD", SPEC_REREAD)],
};
