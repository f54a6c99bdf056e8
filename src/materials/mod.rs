//! Procedural material graphs (issue 17): MaterialX 1.39 documents read
//! into a typed node IR, evaluated on the CPU (the test oracle) and compiled
//! to GLSL (one SSA function per graph) and SPIR-V at load. A graph is a
//! function (uv, position, normal, tangent) -> outputs, so a cache can later
//! wrap it (the thesis's memoization keys it by graph id and uv).
//! docs/MATERIALS.md describes the supported subset and the binding.
//!
//! One concept per file: `types` (data types, values), `signatures` (the
//! stdlib nodedefs of the subset), `document` (XML -> element records),
//! `graph` (typing, topological order, folding), `noise` and `eval` (CPU),
//! `image` (the `image` node: files, sampling twin), `codegen` (GLSL), `compile` (glslc and the on-disk cache), `harness`
//! (GPU evaluation at points), `library` (the shipped graphs), `binding`
//! (graphs bound to a scene's materials, from glTF) and `scene_shaders`
//! (the scene's graphs as one GLSL include, and the hit-shading shaders
//! recompiled with it at run time); `memo` is the memoization cache of
//! the graphs' outputs (thesis §5–6).

pub mod binding;
pub mod codegen;
pub mod compile;
pub mod document;
pub mod error;
pub mod eval;
pub mod graph;
pub mod harness;
pub mod image;
pub mod library;
pub mod memo;
pub mod noise;
pub mod scene_shaders;
pub mod signatures;
pub mod types;

pub use binding::{SceneGraphs, Slot, SlotBind};
pub use document::Document;
pub use error::GraphError;
pub use eval::{evaluate, Geom, ObjectFrame};
pub use graph::Graph;
pub use types::{Type, Value};
