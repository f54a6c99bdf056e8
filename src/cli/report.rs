//! `stereocache report`: DIR/report.html from a compare output directory.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ReportArgs {
    /// The directory `stereocache compare --out` wrote.
    dir: PathBuf,
}

pub fn run(a: ReportArgs) -> Result<()> {
    let path = stereocache::report::write_report(&a.dir)?;
    println!("wrote {}", path.display());
    Ok(())
}
