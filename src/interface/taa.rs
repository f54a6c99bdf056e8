//! Interface of shaders/taa/resolve.comp (`TaaPass`, src/methods/taa/pass.rs).

use super::{read, write, CounterSlot, Interface, PushBlock, PushType};

crate::counter_slots! {
    /// Slots of `taa.counters` (pixels over both eyes).
    pub enum TaaCounter("TAA") {
        Offscreen = "OFFSCREEN" => "taa_rejected_offscreen",
        Disoccluded = "DISOCCLUDED" => "taa_rejected_disocclusion",
        NoHistory = "NO_HISTORY" => "taa_no_history",
        Clipped = "CLIPPED" => "taa_clipped",
        Accepted = "ACCEPTED" => "taa_history_used",
        /// Sum of the history lengths (reported as `taa_mean_history`).
        HistorySum = "HISTORY_SUM",
    }
}

/// Push constants of resolve.comp.
pub const RESOLVE_PUSH: PushBlock = PushBlock {
    name: "TAA_RESOLVE",
    fields: &[
        // fixed α, or α_min for the count weights (unused by pfj23)
        ("alpha", PushType::F32),
        // clipping box half-width in standard deviations
        ("gamma", PushType::F32),
        // 0 fixed, 1 count, 2 pfj23
        ("weights", PushType::U32),
        // bit 0: a history exists; bit 1: reject disocclusions; bit 2: clip;
        // bit 3: the input colour is a sample sum (rgb / w); bit 4: motion
        // vectors of moving instances (where SC_ANIMATED); bit 5: Catmull-Rom
        // history where its 16 taps are consistent
        ("flags", PushType::U32),
    ],
};

pub const INTERFACE: Interface = Interface {
    name: "taa",
    set: 1,
    bindings: &[
        read("frame"),
        read("in_color"),
        read("in_depth"),
        read("in_fh"),
        read("hist_prev"),
        write("hist_cur"),
        read("prev_depth"),
        read("prev_fh"),
        write("counters"),
    ],
    push: &[RESOLVE_PUSH],
    counters: &[TaaCounter::TABLE],
    spec: &[],
};
