//! `stereocache trace`: convert head-pose recordings, write synthetic traces.

use anyhow::{anyhow, bail, Result};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use stereocache::camera::{
    convert_trace, synth, AxisConvention, ColumnMap, CsvOptions, Handedness, Mmsys17Options,
    Mmsys18Options, SignedAxis, SynthKind, TimeUnit, TimeWindow, TraceFormat,
};
use stereocache::values::{float_with, named};

#[derive(Subcommand)]
pub enum TraceCommand {
    /// Convert a head-pose recording (MMSys'18, MMSys'17, OpenXR-style or any CSV) to the project's CSV format.
    Convert(Box<ConvertArgs>),
    /// Write a seeded synthetic trace.
    Synth(SynthArgs),
}

/// Arguments of `trace synth`.
#[derive(Args)]
pub struct SynthArgs {
    /// head-turn, walk, saccade or still.
    #[arg(long, value_parser = named::<SynthKind>("--kind"))]
    kind: SynthKind,
    #[arg(long, default_value_t = 5.0, value_parser = float_with("--seconds", |s: f64| s.is_finite() && s > 0.0 && s <= 3600.0, "a duration in (0, 3600]"))]
    seconds: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[arg(long, default_value_t = 90.0, value_parser = float_with("--rate", |r: f64| r.is_finite() && (1.0..=10000.0).contains(&r), "Hz in [1, 10000]"))]
    rate: f64,
    #[arg(long)]
    out: PathBuf,
}

pub fn run(which: TraceCommand) -> Result<()> {
    match which {
        TraceCommand::Convert(a) => convert(&a),
        TraceCommand::Synth(a) => {
            let trace = synth(a.kind, a.seconds, a.seed, a.rate);
            trace.write_csv(&a.out)?;
            println!(
                "wrote {} ({} samples)",
                a.out.display(),
                trace.samples.len()
            );
            Ok(())
        }
    }
}

/// Recording formats `trace convert` reads.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum InputFormat {
    /// MMSys'18 multi-viewpoint 360° logs: `timestamp viewpoint w x y z` with a header.
    Mmsys18,
    /// Corbillon et al. MMSys'17 360° logs: `t frameId [pts] w x y z`, no header.
    Mmsys17,
    /// OpenXR-style CSV: `time,position.x,...,orientation.w[,flags]`, int64 ns, glTF axes.
    Openxr,
    /// Any delimited layout: give --time-unit and --handedness (and --columns, --up, --forward).
    Csv,
}

/// Arguments of `trace convert`.
#[derive(Args)]
pub struct ConvertArgs {
    /// The recording.
    input: PathBuf,
    /// Output trace (the project's CSV: t,px,py,pz,qx,qy,qz,qw).
    #[arg(long)]
    out: PathBuf,
    /// Format of the recording.
    #[arg(long, value_enum, default_value_t = InputFormat::Mmsys18)]
    format: InputFormat,
    /// First second to keep, from the recording's first sample (MMSys'18: on its own clock, which starts at 0).
    #[arg(long, default_value_t = 0.0)]
    start: f64,
    /// Last second to keep, counted as --start (default: to the end).
    #[arg(long)]
    end: Option<f64>,
    /// csv: the field of each quantity, by 0-based index or header name:
    /// t=0,x=1,y=2,z=3,qx=4,qy=5,qz=6,qw=7 (without x,y,z the position comes from a head–neck model).
    /// Default: header names t|time|timestamp, x|px, y|py, z|pz, qx, qy, qz, qw.
    #[arg(long, value_name = "MAP")]
    columns: Option<ColumnMap>,
    /// csv: unit of the time column (ticks = 100 ns, .NET DateTime.Ticks as HoloLens apps log).
    #[arg(long, value_enum)]
    time_unit: Option<TimeUnit>,
    /// csv: handedness of the recording's axes (Unity/HoloLens: left; OpenXR, glTF, OpenGL: right).
    #[arg(long, value_enum)]
    handedness: Option<Handedness>,
    /// csv: the up axis, x|y|z with optional sign [default: +y].
    #[arg(long, allow_hyphen_values = true)]
    up: Option<SignedAxis>,
    /// csv: the axis the head looks along (default: -z right-handed / +z left-handed with +y up; +x with ±z up).
    #[arg(long, allow_hyphen_values = true)]
    forward: Option<SignedAxis>,
}

/// `stereocache trace convert`: the format's options from the arguments,
/// then import, convention check and write.
fn convert(a: &ConvertArgs) -> Result<()> {
    if !(a.start.is_finite() && a.start >= 0.0) {
        bail!("bad --start {}: expected seconds ≥ 0", a.start);
    }
    let end = a.end.unwrap_or(f64::INFINITY);
    if end.is_nan() || end < a.start {
        bail!("bad --end {end}: expected seconds ≥ --start ({})", a.start);
    }
    let window = TimeWindow {
        start: a.start,
        end,
    };
    let csv_only = [
        ("--columns", a.columns.is_some()),
        ("--time-unit", a.time_unit.is_some()),
        ("--handedness", a.handedness.is_some()),
        ("--up", a.up.is_some()),
        ("--forward", a.forward.is_some()),
    ];
    if a.format != InputFormat::Csv {
        if let Some((flag, _)) = csv_only.iter().find(|(_, given)| *given) {
            bail!("{flag} applies to --format csv only; the other formats fix their columns, time unit and axes");
        }
    }
    let format = match a.format {
        InputFormat::Mmsys18 => TraceFormat::Mmsys18(Mmsys18Options {
            start: a.start,
            end,
            ..Default::default()
        }),
        InputFormat::Mmsys17 => TraceFormat::Mmsys17(Mmsys17Options {
            window,
            ..Default::default()
        }),
        InputFormat::Openxr => TraceFormat::OpenXr(window),
        InputFormat::Csv => {
            let Some(time_unit) = a.time_unit else {
                bail!(
                    "--format csv needs --time-unit s|ms|us|ns|ticks (the unit of the time column)"
                );
            };
            let Some(handedness) = a.handedness else {
                bail!("--format csv needs --handedness left|right (Unity/HoloLens recordings are left-handed; OpenXR and glTF right-handed)");
            };
            let up = a.up.unwrap_or(SignedAxis::PY);
            let forward = match a.forward {
                Some(f) => f,
                None => AxisConvention::default_forward(handedness, up).ok_or_else(|| {
                    anyhow!("--up {up} has no default forward axis; give --forward")
                })?,
            };
            let convention = AxisConvention::new(handedness, up, forward)
                .map_err(|e| anyhow!("bad --up/--forward: {e}"))?;
            TraceFormat::Csv(CsvOptions {
                columns: a.columns.clone(),
                window,
                ..CsvOptions::new(time_unit, convention)
            })
        }
    };
    // Converting a recording onto itself would replace it with its
    // conversion (until session 49 silently).
    let same = |p: &std::path::Path| std::fs::canonicalize(p).ok();
    if a.out == a.input || (same(&a.out).is_some() && same(&a.out) == same(&a.input)) {
        return Err(anyhow!(
            "{}: --out is the recording itself; give another file for the converted trace",
            a.out.display()
        ));
    }
    let trace = convert_trace(&a.input, &a.out, &format)?;
    for w in &trace.warnings {
        eprintln!("warning: {w}");
    }
    let axes = match &format {
        TraceFormat::Csv(o) => format!(", axes {} → glTF", o.convention),
        _ => String::new(),
    };
    println!(
        "wrote {} ({} samples, {:.2} s{axes})",
        a.out.display(),
        trace.samples.len(),
        trace.duration()
    );
    Ok(())
}
