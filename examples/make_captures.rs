//! Regenerates the pose traces shipped in `captures/`.
//!
//! ```text
//! cargo run --example make_captures -- [path/to/shared/captures/mmsys18]
//! ```
//!
//! Default input folder: `../shared/captures/mmsys18` relative to the crate.
//! Until the CLI has `stereocache trace convert|synth`, this is how the
//! shipped files are made; it uses the same library functions.

use std::path::PathBuf;

use stereocache::camera::{convert_mmsys18, synth, Mmsys18Options, SynthKind};

/// The excerpt of `user1_quaternion.txt` that is shipped (source seconds).
const MMSYS18_START: f64 = 10.0;
const MMSYS18_END: f64 = 40.0;

fn main() -> anyhow::Result<()> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let input_dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("../shared/captures/mmsys18"));
    let input_dir = input_dir.canonicalize().unwrap_or(input_dir);
    let out = root.join("captures");
    std::fs::create_dir_all(&out)?;

    let opts = Mmsys18Options {
        start: MMSYS18_START,
        end: MMSYS18_END,
        ..Default::default()
    };
    let trace = convert_mmsys18(
        input_dir.join("user1_quaternion.txt"),
        out.join("mmsys18-user1.csv"),
        &opts,
    )?;
    println!(
        "mmsys18-user1.csv: {} samples, {:.3} s",
        trace.samples.len(),
        trace.duration()
    );
    for w in &trace.warnings {
        println!("  warning: {w}");
    }

    for kind in [SynthKind::HeadTurn, SynthKind::Walk] {
        let name = format!("synth-{kind}.csv");
        let trace = synth(kind, 5.0, 1, 90.0);
        trace.write_csv(out.join(&name))?;
        println!("{name}: {} samples", trace.samples.len());
    }
    Ok(())
}
