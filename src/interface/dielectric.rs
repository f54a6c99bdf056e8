//! Interface of the test kernel shaders/common/dielectric_test.comp (tests/dielectric.rs).

use super::{read, write, Interface, PushBlock, PushType};

/// Push constants: the number of cases.
pub const PUSH: PushBlock = PushBlock {
    name: "DIELECTRIC",
    fields: &[("count", PushType::U32)],
};

pub const INTERFACE: Interface = Interface {
    name: "dielectric",
    set: 1,
    bindings: &[read("cases"), write("outs")],
    push: &[PUSH],
    counters: &[],
    spec: &[],
};
