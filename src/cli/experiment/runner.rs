//! Runs one comparison (a scene along a trace, several configurations, one
//! reference) and records it: what `compare` and every group of an
//! experiment run, so there is one way to run and record a comparison.

use crate::cli::common::{
    check_out, check_out_spares_inputs, open_along_trace, print_reference_noise, replay_writes,
    report_validation,
};
use crate::cli::compare::CompareArgs;
use anyhow::{bail, Result};
use std::path::Path;
use stereocache::compare::{Comparison, Config};

/// Runs `configs` with the shared settings of `a` (trace, frames, size,
/// reference, images, device) into `out`: the configurations' folders,
/// summary.csv, summary.json, side-by-side/, viewer/ and report.html; prints
/// the summary and ratio tables. `baseline` as `compare --baseline` (the
/// configuration the ratios divide by).
pub fn run_comparison(
    a: &CompareArgs,
    configs: &[Config],
    out: &Path,
    baseline: Option<&str>,
) -> Result<Comparison> {
    if a.reference_spp > 0 {
        stereocache::evaluate::check_reference_spp(a.reference_spp)?;
        stereocache::evaluate::check_reference_cache_dir(&a.reference_cache)?;
    }
    // A baseline that is not compared fails before the device is opened.
    let labels: Vec<String> = configs.iter().map(|c| c.label.clone()).collect();
    stereocache::compare::choose_baseline(&labels, baseline)?;
    check_out(out)?;
    // Each configuration's folder and its frames/ too (a file there failed
    // after the reference and the earlier configurations had rendered,
    // leaving their folders looking complete; an audit's finding).
    for l in &labels {
        check_out(&out.join(l))?;
        check_out(&out.join(l).join("frames"))?;
    }
    let settings = a
        .method_opts
        .settings(a.size, a.spp, a.bounces, a.seed, false)
        .map_err(anyhow::Error::msg)?;
    let (session, cameras) = open_along_trace(
        &a.trace, a.fps, a.frames, a.size, &a.scene, &a.gpu, &a.camera,
    )?;
    // The run's summaries, grids and viewer, and every configuration's
    // replay outputs.
    check_out_spares_inputs(out, &|rel| {
        let mut parts = rel.components();
        let first = parts
            .next()
            .map(|c| c.as_os_str().to_string_lossy().into_owned());
        let rest = parts.as_path();
        match first.as_deref() {
            Some("summary.json" | "summary.csv" | "report.html" | "experiment.json") => {
                rest.as_os_str().is_empty()
            }
            Some("side-by-side") => stereocache::output::is_grid_image(rest),
            Some("viewer") => stereocache::output::is_viewer_output(rest, false),
            Some(l) => labels.iter().any(|x| x == l) && replay_writes(rest),
            None => false,
        }
    })?;
    if let Some(k) = a.frames {
        if k > cameras.len() {
            bail!(
                "bad --frames {k}: {} gives only {} frames at {} fps",
                a.trace.display(),
                cameras.len(),
                a.fps
            );
        }
    }
    let opts = stereocache::compare::CompareOptions {
        methods: configs.iter().map(|c| c.config.clone()).collect(),
        frames: a.frames,
        fps: a.fps,
        every: a.every,
        out: out.to_path_buf(),
        exposure: a.exposure,
        trace: a.trace.clone(),
        shown_frames: a.show_frames.as_ref().map(|s| s.0.clone()),
        zoom: a.zoom,
        reference_spp: (a.reference_spp > 0).then_some(a.reference_spp),
        reference_cache: a.reference_cache.clone(),
        flip_ppd: a.flip_ppd,
        baseline: baseline.map(str::to_string),
    };
    let cmp = stereocache::compare::compare_configs(&session, &cameras, configs, &settings, &opts)?;
    print_tables(&cmp);
    let report = stereocache::report::write_report(out)?;
    println!(
        "wrote {} (summary.csv, summary.json, side-by-side/, one folder per method)",
        out.display()
    );
    println!("report: {}", report.display());
    report_validation(&session.ctx)?;
    Ok(cmp)
}

/// The summary table, the ratios and the reference's noise line.
pub fn print_tables(cmp: &Comparison) {
    print!("{}", stereocache::compare::summary_table(&cmp.rows));
    print!("{}", stereocache::compare::ratio_table(cmp));
    print_reference_noise(cmp);
}
