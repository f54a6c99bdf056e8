//! Interface of the test kernel shaders/common/reflect_test.comp
//! (tests/shader_interface.rs): one binding of each kind of use the SPIR-V
//! reflection (src/gpu/reflect.rs) tells apart, at set 0 (no persistent set).

use super::{read, write, Interface};

pub const INTERFACE: Interface = Interface {
    name: "reflect_test",
    set: 0,
    bindings: &[
        // loaded only
        read("src"),
        // stored only
        write("dst"),
        // an atomic add: read and written
        write("count"),
        // only its length is taken: used, not accessed
        read("sized"),
        // not referenced by the shader at all
        write("unused"),
    ],
    push: &[],
    counters: &[],
    spec: &[],
};
