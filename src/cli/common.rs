//! Helpers several subcommands share: the device line benchmarks print
//! first, the validation verdict, the reference-noise line under a compare
//! table, the trace-driven session of replay and compare, and scene lists.

use anyhow::{bail, Result};
use stereocache::gpu::{DeviceCaps, GpuContext};
use stereocache::scene::{DefaultLighting, Environment, Scene};
use stereocache::session::Session;

/// The first line every benchmark prints: which device and driver measured.
pub fn device_line(c: &DeviceCaps) -> String {
    format!(
        "device: {} ({}), driver {} {}",
        c.name, c.device_type, c.driver_name, c.driver_info
    )
}

/// Reads the trace at `trace` (its warnings on stderr), opens the device and
/// the scene, and resamples the trace into one stereo camera per frame at
/// `fps` (the first `frames` only, when given) — what `replay` and
/// `compare` both start with.
pub fn open_along_trace(
    trace: &std::path::Path,
    fps: f64,
    frames: Option<usize>,
    size: stereocache::values::Size,
    scene: &super::args::SceneArgs,
    gpu: &super::args::GpuArgs,
    camera: &super::args::CameraArgs,
) -> Result<(Session, Vec<stereocache::camera::StereoCamera>)> {
    let select = camera.select();
    let trace = stereocache::camera::PoseTrace::read_csv(trace)?;
    for w in &trace.warnings {
        eprintln!("warning: {w}");
    }
    stereocache::replay::check_trace_length(&trace, fps, frames)?;
    // More frames than the trace gives: refused before the scene loads
    // (replay and compare would refuse them after).
    if let Some(k) = frames {
        let available = trace.resampled_len(fps);
        if k as f64 > available {
            bail!(
                "bad --frames {k}: {} has {available} frames at {fps} fps; use at most {available} or omit --frames",
                trace.source.display()
            );
        }
    }
    let session = scene.open(gpu)?;
    let cameras = stereocache::replay::trace_cameras(
        &session,
        &trace,
        fps,
        size.width,
        size.height,
        &select,
        camera.ipd,
        camera.fov_radians(),
        frames,
    )?;
    Ok((session, cameras))
}

/// Fails when the validation layer reported anything (the messages were printed).
pub fn report_validation(ctx: &GpuContext) -> Result<()> {
    let n = ctx.validation.count();
    if n > 0 {
        bail!("the Vulkan validation layer reported {n} message(s) (printed above)");
    }
    Ok(())
}

/// The reference's estimated error under a compare table, and the one
/// `warning:` line when it is not small against the best method's.
pub fn print_reference_noise(cmp: &stereocache::compare::Comparison) {
    let Some(r) = &cmp.reference else { return };
    let covisible = |k: &str| {
        cmp.rows
            .first()
            .and_then(|row| row.metrics.get(k))
            .map(|v| format!("{v:.3}"))
            .unwrap_or_else(|| "-".into())
    };
    let scored = |k: &str| {
        cmp.rows
            .first()
            .and_then(|row| stereocache::compare::scored_frames(row, k))
            .map(|n| n.to_string())
            .unwrap_or_else(|| "-".into())
    };
    println!(
        "metrics: FLIP at {:.3} pixels per degree ({}); temporal and stereo on one mask from the reference's geometry, co-visible {} and {}, scored on {} and {} frames (those with a co-visible pixel)",
        cmp.flip.ppd,
        cmp.flip.source,
        covisible("temporal_covisible"),
        covisible("stereo_covisible"),
        scored("temporal"),
        scored("stereo_mean"),
    );
    println!(
        "reference: {} spp (two independent halves of {}), estimated RSE {:.4} ± {:.1e}, MSE {:.3e} against the converged image, half-vs-half HDR-FLIP {:.4}{}",
        r.spp,
        r.half_spp,
        r.rse,
        r.rse_stderr,
        r.mse,
        r.flip_halves,
        match (&r.best_method, r.ratio_to_best) {
            (Some(m), Some(x)) => format!(" ({x:.3}x the best method's RSE, {m})"),
            _ => String::new(),
        }
    );
    if let Some(w) = &r.warning {
        eprintln!("warning: {w}");
    }
}

/// The environment's kind in words.
pub fn environment_kind(e: &Environment) -> &'static str {
    match e {
        Environment::Constant(_) => "constant",
        Environment::Sky { .. } => "sky",
        Environment::Map { .. } => "map",
    }
}

/// The scenes of a comma-separated `--scenes` list, each labelled by its file
/// stem (or its name), their lighting (`--lighting`, `None` without one) and
/// warnings printed.
pub fn load_labelled_scenes(
    list: &str,
    lighting: Option<&DefaultLighting>,
) -> Result<Vec<(String, Scene)>> {
    let mut scenes = Vec::new();
    for spec in list.split(',').map(str::trim) {
        let (scene, lit) = Session::load_scene_lit(spec, lighting)?;
        eprintln!("{spec}: {}", lit.line());
        for warning in &scene.warnings {
            eprintln!("warning: {warning}");
        }
        let label = std::path::Path::new(spec)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| spec.to_string());
        scenes.push((label, scene));
    }
    Ok(scenes)
}

/// Refuses an output directory that cannot be created or written, before any work.
pub fn check_out(dir: &std::path::Path) -> Result<()> {
    stereocache::values::check_output_dir(dir).map_err(anyhow::Error::msg)
}

/// Refuses a run whose outputs in `out` — the paths relative to it that
/// `writes` names — would overwrite a file the run has read (its scene, the
/// scene's buffers and images, an environment map, a trace): called once
/// the inputs are loaded, before anything is rendered.
pub fn check_out_spares_inputs(
    out: &std::path::Path,
    writes: &dyn Fn(&std::path::Path) -> bool,
) -> Result<()> {
    if let Some(p) = stereocache::input::overwritten_input(out, writes) {
        anyhow::bail!(
            "{}: the outputs would overwrite {}, an input of this run: choose another --out",
            out.display(),
            p.display()
        );
    }
    Ok(())
}

/// What `replay` (and each configuration of `compare`) writes under its
/// folder: `frames.jsonl`, `summary.json`, `frames/NNNNN_eye….{exr,png}`.
pub fn replay_writes(rel: &std::path::Path) -> bool {
    stereocache::output::is_replay_output(rel, false)
}

/// Refuses an output file that cannot be written, before any work.
pub fn check_out_file(file: &std::path::Path) -> Result<()> {
    stereocache::values::check_output_file(file).map_err(anyhow::Error::msg)
}

/// The error and its causes on one line. A cause whose text the message
/// already contains (library errors that print their source) is not repeated.
pub fn error_line(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !msg.contains(&c) {
            msg.push_str(": ");
            msg.push_str(&c);
        }
    }
    msg.replace('\n', " ")
}
