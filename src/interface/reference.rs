//! Interface of shaders/reference/ (the path tracer of `reference`, `naive`,
//! `supersample` and the colour source of `taa`).

use super::{read, write, CounterSlot, Interface, PushBlock, PushType};

crate::counter_slots! {
    /// Slots of `reference.counters`: the rays the frame traced.
    pub enum ReferenceCounter("REFERENCE") {
        PrimaryRays = "PRIMARY_RAYS",
        BounceRays = "BOUNCE_RAYS",
        ShadowRays = "SHADOW_RAYS",
        // pixel-centre rays of `primary` (primary rays only where a TAA reads them)
        CentreRays = "CENTRE_RAYS" => "centre_rays",
        // samples whose radiance came out ∞ or NaN, dropped (counted as black)
        NonFiniteSamples = "NONFINITE_SAMPLES" => "non_finite_samples",
    }
}

/// Push constants of reference/trace.comp.
pub const TRACE_PUSH: PushBlock = PushBlock {
    name: "REFERENCE_TRACE",
    fields: &[
        ("sample_base", PushType::U32),
        ("sample_count", PushType::U32),
        ("fixed_jitter", PushType::U32),
        ("pad", PushType::U32),
        ("jitter", PushType::Vec2),
    ],
};

pub const INTERFACE: Interface = Interface {
    name: "reference",
    set: 1,
    bindings: &[
        read("frame"),
        write("accum"),
        write("first_hit"),
        write("depth"),
        write("albedo"),
        write("counters"),
    ],
    push: &[TRACE_PUSH],
    counters: &[ReferenceCounter::TABLE],
    spec: &[],
};
