//! The `stereocache` command line: info, render, compare, report, replay,
//! bench, scene, trace (one module each under `cli/`).

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    match cli::run(cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", cli::common::error_line(&e));
            ExitCode::FAILURE
        }
    }
}
