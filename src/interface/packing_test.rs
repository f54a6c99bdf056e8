//! Interface of the test kernel shaders/common/packing_test.comp
//! (tests/stability.rs): common/packing.glsl's first-hit encoding (paper
//! Listing 1) and decoding on the GPU.

use super::{read, write, Interface, PushBlock, PushType};

/// Push constants: the number of inputs (padded to 16 bytes).
pub const PUSH: PushBlock = PushBlock {
    name: "PACKING_TEST",
    fields: &[
        ("count", PushType::U32),
        ("pad0", PushType::U32),
        ("pad1", PushType::U32),
        ("pad2", PushType::U32),
    ],
};

/// Inputs (barycentric u and v as float bits, material, primitive) in, eight
/// words each out: the encoded first hit, the decoded barycentrics' bits,
/// the material and the valid flag.
pub const INTERFACE: Interface = Interface {
    name: "packing_test",
    set: 0,
    bindings: &[read("keys"), write("outs")],
    push: &[PUSH],
    counters: &[],
    spec: &[],
};
