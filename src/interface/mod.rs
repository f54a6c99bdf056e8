//! The shader interface, written once in Rust: for every group of compute
//! shaders, the per-pass storage buffers in binding order (name and access),
//! the push-constant blocks, the counter slots and the specialization
//! constant ids. build.rs includes this module (plain Rust, no dependencies)
//! and writes one GLSL header per group into `OUT_DIR/interface/` (included
//! as `#include "interface/<group>.glsl"`), so the shaders use the generated
//! names (`layout(set = 1, binding = B_REFERENCE_ACCUM)`, `C_TAA_CLIPPED`,
//! `REFERENCE_TRACE_PUSH`) and the two sides cannot drift. At record time
//! the pass builder (src/gpu/compute_pass.rs) checks each pass's
//! `.read()`/`.write()` declarations against the same table.

pub mod bench;
pub mod dielectric;
pub mod glsl;
pub mod isrt;
pub mod reference;
pub mod taa;
mod types;

pub use types::*;

/// Every interface group; build.rs writes a header for each.
pub const ALL: &[&Interface] = &[
    &reference::INTERFACE,
    &taa::INTERFACE,
    &isrt::INTERFACE,
    &bench::RAYS,
    &bench::SCATTER,
    &bench::SCATTER_SLOTS,
    &dielectric::INTERFACE,
];
