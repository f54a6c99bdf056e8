//! stereocache: a headless Vulkan stereo ray tracer for VR rendering research.
//!
//! Module map (DESIGN.md): `gpu` holds every line of unsafe Vulkan; `scene`
//! imports glTF and generates test scenes; `rt` builds the ray-tracing
//! structures (obvhs CWBVH for the software path, BLAS/TLAS for ray queries);
//! `camera` turns head poses into eye views and reads pose traces; `methods`
//! holds one folder per rendering method; `output` writes images.
//!
//! `unsafe` is denied outside `gpu` (the one module allowed it), so the
//! boundary is checked by the compiler.
#![deny(unsafe_code)]

pub mod bench;
pub mod camera;
pub mod compare;
pub mod error;
pub mod evaluate;
#[allow(unsafe_code)]
pub mod gpu;
pub mod input;
pub mod interface;
pub mod materials;
pub mod merge;
pub mod methods;
pub mod metrics;
pub mod output;
pub mod replay;
pub mod report;
pub mod rt;
pub mod scene;
pub mod session;
pub mod stereo;
pub mod values;
