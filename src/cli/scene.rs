//! `stereocache scene`: the scenes the project ships.

use anyhow::Result;
use clap::Subcommand;
use std::path::PathBuf;
use stereocache::scene::generate_to_dir;

#[derive(Subcommand)]
pub enum SceneCommand {
    /// Write a generated scene (cornell, hairball, plane, cornell-moving,
    /// hairball-rotating, material-balls; the moving ones with their glTF
    /// animation, material-balls with its .mtlx files) into DIR.
    Generate {
        name: String,
        #[arg(long)]
        out: PathBuf,
    },
}

pub fn run(which: SceneCommand) -> Result<()> {
    match which {
        SceneCommand::Generate { name, out } => {
            let path = generate_to_dir(&name, &out)?;
            println!("wrote {}", path.display());
            Ok(())
        }
    }
}
