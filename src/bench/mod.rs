//! Benchmarks (never pass/fail tests), one file per `stereocache bench`
//! subcommand: `rays` (rays per second per backend), `sample_cache` (the
//! cache against a plain scatter and 1 spp path tracing), `tradeoff` (time
//! against error over a settings sweep), `scaling` (pixels and triangles),
//! `specialization` (specialized pipelines and skipped passes), `lights`
//! (light sampling at equal time), `materials` and `memo_fill` (the
//! material-graph memoization table: its sweep, and what a fill costs);
//! `interleave` holds what they share: among it the frame loop, which
//! poses an animated scene's instances at each frame's time (frame / fps)
//! as replay does.

pub mod interleave;
pub mod lights;
pub mod materials;
pub mod memo_fill;
pub mod rays;
pub mod sample_cache;
pub mod scaling;
pub mod specialization;
pub mod tradeoff;

pub use interleave::{
    check_frame_poses, frame_time, paired_ratio, pose_frame, run_interleaved, Interleaved,
};
pub use lights::{bench_lights, light_table, LightBenchRow};
pub use materials::{
    bench_materials, memo_configs, memo_csv, memo_table, MemoBenchRow, SweepVariant,
};
pub use memo_fill::{
    bench_fill_cost, fill_cost_configs, fill_cost_csv, fill_cost_table, FillCostRow,
};
pub use rays::{bench_rays, check_ray_count, RayBench};
pub use sample_cache::{bench_sample_cache, CacheBenchRow, ScatterBaselines};
pub use scaling::{fit_slope, steady_frame_ms};
pub use specialization::{
    bench_specialization, has_feature, spec_csv, spec_table, SpecBenchRow, FEATURE_FLAGS,
};
pub use tradeoff::{tradeoff_configs, tradeoff_ratios};
