//! `stereocache bench`: benchmarks (figures for docs/PERFORMANCE.md), one
//! file per benchmark; the measuring code is in the library's `bench` module.

mod lights;
mod materials;
mod rays;
mod sample_cache;
mod scaling;
mod specialization;
mod tradeoff;

use anyhow::Result;
use clap::Subcommand;

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Frame time per method at pixels ×1, ×2, ×4, ×8 and on hairballs of
    /// about 10k, 100k and 1M triangles, with fitted exponents.
    Scaling(scaling::ScalingArgs),
    /// Run time against error for every method and a sweep of their settings
    /// (one run, one device): DIR/tradeoff.csv and DIR/report.html.
    Tradeoff(tradeoff::TradeoffArgs),
    /// Sample cache against a plain scatter, per retrace mode, and against 1 spp path tracing.
    SampleCache(sample_cache::SampleCacheBenchArgs),
    /// Issue 6: GPU frame time of pipelines specialized to the scene's
    /// features against the all-features build, of each unused feature's code,
    /// and of skipping passes with nothing to do; both eyes, builds interleaved.
    Specialization(specialization::BenchSpecArgs),
    /// Issue 13: MSE at equal time of the reference path tracer with light
    /// sampling of emitters and maps (MIS) against BSDF sampling alone (the
    /// integrator before NEE) and NEE alone, on a static view, interleaved.
    Lights(lights::BenchLightsArgs),
    /// Primary and diffuse-bounce rays per second for each ray backend.
    Rays(rays::RaysArgs),
    /// Issue 17: the material-graph memoization cache off and on (primary,
    /// secondary, both hits), a table-size sweep and the eviction policies:
    /// frame-time ratios, hit rates, fills and evictions per frame.
    Materials(materials::BenchMaterialsArgs),
}

pub fn run(which: BenchCommand) -> Result<()> {
    match which {
        BenchCommand::Scaling(a) => scaling::run(a),
        BenchCommand::Tradeoff(a) => tradeoff::run(a),
        BenchCommand::SampleCache(a) => sample_cache::run(a),
        BenchCommand::Specialization(a) => specialization::run(a),
        BenchCommand::Lights(a) => lights::run(a),
        BenchCommand::Rays(a) => rays::run(a),
        BenchCommand::Materials(a) => materials::run(a),
    }
}
