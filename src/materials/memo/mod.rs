//! Memoization of material-graph outputs in a texture-space cache shared by
//! both eyes (Urbach 2023, thesis §4–5; issue 17). One concept per file:
//! `table` (keys, the two hashes, probing, eviction: the CPU twin of
//! shaders/memo/table.glsl and a single-threaded model of the table) and
//! `lod` (the level of detail from ray cones and texel-centre snapping,
//! twin of shaders/memo/lod.glsl), `settings` (what `--memo …` asks of the
//! cache in rendering) and `state` (the per-frame parameters and counters
//! the rendering shaders share with the host).

pub mod lod;
pub mod settings;
pub mod state;
pub mod table;

pub use settings::{MemoFill, MemoHits, MemoSettings};
pub use table::MemoClock;
