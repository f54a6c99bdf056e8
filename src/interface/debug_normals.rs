//! Interface of shaders/debug_normals/ (the `debug-normals` method: the
//! shading normal at each pixel-centre first hit as a colour).

use super::{read, write, CounterSlot, Interface};

crate::counter_slots! {
    /// Slots of `debug_normals.counters`: the rays the frame traced.
    pub enum DebugNormalsCounter("DEBUG_NORMALS") {
        PrimaryRays = "PRIMARY_RAYS",
    }
}

pub const INTERFACE: Interface = Interface {
    name: "debug_normals",
    set: 1,
    bindings: &[
        read("frame"),
        write("color"),
        write("first_hit"),
        write("depth"),
        write("albedo"),
        write("counters"),
    ],
    push: &[],
    counters: &[DebugNormalsCounter::TABLE],
    spec: &[],
};
