//! The `stereocache` command line, one file per subcommand; `args` holds the
//! argument groups they share and the typed values with their range checks.

pub mod args;
mod bench;
pub mod common;
pub(crate) mod compare;
mod experiment;
mod info;
mod render;
mod replay;
mod report;
mod scene;
mod trace;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "stereocache",
    version,
    about = "Headless Vulkan stereo ray tracer with a screen-space sample cache for VR rendering research"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print the chosen Vulkan device and its ray-tracing capabilities.
    Info(info::InfoArgs),
    /// Render one stereo frame and write DIR/{left,right}.{exr,png} and DIR/stats.json.
    Render(Box<render::RenderArgs>),
    /// Render several methods along the same frames of a trace, side by side.
    Compare(Box<compare::CompareArgs>),
    /// The paper's experiments as files: run one (or a shard of it), merge shards.
    Experiment {
        #[command(subcommand)]
        which: experiment::ExperimentCommand,
    },
    /// Write DIR/report.html from a compare output directory.
    Report(report::ReportArgs),
    /// Render a method along a head-pose trace: DIR/frames/, DIR/frames.jsonl, DIR/summary.json.
    Replay(Box<replay::ReplayArgs>),
    /// Benchmarks (figures for docs/PERFORMANCE.md).
    Bench {
        #[command(subcommand)]
        which: bench::BenchCommand,
    },
    /// Scenes the project ships.
    Scene {
        #[command(subcommand)]
        which: scene::SceneCommand,
    },
    /// Pose traces: convert recordings, make synthetic ones.
    Trace {
        #[command(subcommand)]
        which: trace::TraceCommand,
    },
}

/// Runs the parsed command.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info(a) => info::run(a),
        Command::Render(a) => render::run(*a),
        Command::Compare(a) => compare::run(*a),
        Command::Experiment { which } => experiment::run(which),
        Command::Report(a) => report::run(a),
        Command::Replay(a) => replay::run(*a),
        Command::Bench { which } => bench::run(which),
        Command::Scene { which } => scene::run(which),
        Command::Trace { which } => trace::run(which),
    }
}
