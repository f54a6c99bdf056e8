//! The `stereocache` command line, one file per subcommand; `args` holds the
//! argument groups they share and the typed values with their range checks.

/// `println!` and `print!` for every subcommand (they shadow std's in the
/// modules below): standard output closed early (`stereocache … | head`,
/// `| true`) is not an error of the run. std's panic on EPIPE ("failed
/// printing to stdout: Broken pipe", exit 101); these drop the text and
/// the run goes on, so the files it writes are complete.
macro_rules! println {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}
macro_rules! print {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($arg)*);
    }};
}

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

/// `cmd` with every option that takes a value accepting one that starts
/// with `-` and is a number (`--ipd -1`, `--time -0.5`): clap otherwise
/// reads it as an unknown flag ("unexpected argument '-1' found" and the
/// usage), and the option's own range check never gives its one line.
///
/// `allow_negative_numbers` covers a value that is one number only; the
/// comma lists and sizes of [`HYPHEN_VALUES`] may start with `-` and not be
/// a number (`--pose -1,0,0,0,0,0,1`), so those options take any value
/// (until session 49 a head position with a negative x was refused as an
/// unknown flag; their own parsers give the one line for a bad value).
pub fn negative_numbers(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| {
        if HYPHEN_VALUES.contains(&a.get_id().as_str()) {
            a.allow_hyphen_values(true)
        } else if a.get_action().takes_values() {
            a.allow_negative_numbers(true)
        } else {
            a
        }
    })
    .mut_subcommands(negative_numbers)
}

/// Options whose values are lists or sizes that may start with `-`.
const HYPHEN_VALUES: &[&str] = &["pose", "size"];

/// Parses the process's arguments ([`negative_numbers`] applied), exiting
/// with clap's message on an error, as `Cli::parse` does.
pub fn parse() -> Cli {
    use clap::{CommandFactory, FromArgMatches};
    let matches = negative_numbers(Cli::command()).get_matches();
    Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
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
