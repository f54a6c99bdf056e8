//! `stereocache compare`: every method along the same frames of a trace.
//! Writes, under `out/`:
//! - `<method>/` — what `replay` writes for that method (frames, frames.jsonl, summary.json);
//! - `side-by-side/frame_<k>.png` — one column per method (labelled), rows:
//!   left eye, right eye, and a zoomed crop of each, for the chosen frames;
//! - `viewer/` — the report's error maps, crops and viewer images
//!   ([`crate::report::images`]);
//! - `summary.csv` and `summary.json` — one row per method: mean and p95
//!   GPU ms per frame, mean ms per pass, rays, memory of the method's buffers,
//!   and the `metrics` against the reference (with `rse_reference` and
//!   `mse_reference`, the reference's own estimated error, beside `rse` and
//!   `mse`), each metric's standard error over frames (`metrics_stderr`,
//!   CSV columns `se:<metric>`) and the error figures' ratios to the
//!   baseline with their standard errors (`ratios`, [`RATIO_METRICS`],
//!   CSV columns `ratio:<metric>` and `ratio_se:<metric>`); summary.json also
//!   has `reference` ([`ReferenceSummary`]), `baseline`, `flip` (the pixels
//!   per degree FLIP used and where it came from) and `masks` (the
//!   co-visible fractions of the one temporal and stereo mask, from the
//!   reference's geometry: [`crate::evaluate`]).
//!
//! Uncertainty ([`crate::metrics::uncertainty`]): standard errors over
//! frames, widened by √((1 + ρ) / (1 − ρ)) for the series' lag-1
//! autocorrelation ρ (successive frames of a trace are alike); ratios `x̄/ȳ`
//! to the baseline use the delta method on the paired frames (both methods
//! render the same frames), widened the same way.
//!
//! The reference is rendered as two independent halves of `spp/2` samples
//! (different seeds) whose mean is the reference; their difference estimates
//! its own error ([`crate::metrics::reference_noise`]). When that error is
//! above [`REFERENCE_NOISE_RATIO`] × the best method's RSE, the comparison
//! carries a warning (printed by the CLI as one `warning:` line, shown in the
//! report) with the `--reference-spp` that would suffice.

use crate::camera::StereoCamera;
use crate::error::{Error, Result};
use crate::evaluate::{flip_ppd, half_seeds, Evaluator, ReferenceCache, ReferenceFrame};
use crate::methods::{MethodConfig, RenderSettings, StereoFrame};
use crate::metrics::{ratio_of_means, MeanStderr, ReferenceNoise};
use crate::output::{self, label, tonemap};
use crate::replay::{replay_observed, ReplayOptions, ReplaySummary};
use crate::session::Session;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
pub struct CompareOptions {
    pub methods: Vec<MethodConfig>,
    pub frames: Option<usize>,
    pub fps: f64,
    /// Per-method images every k-th frame (0 = none).
    pub every: usize,
    pub out: PathBuf,
    pub exposure: f32,
    pub trace: PathBuf,
    /// Frames shown side by side (default: first, middle, last).
    pub shown_frames: Option<Vec<usize>>,
    /// Magnification of the centre crop.
    pub zoom: u32,
    /// Samples per pixel of the reference frames the metrics compare against
    /// (`None`: no metrics); even, rendered as two independent halves.
    pub reference_spp: Option<u32>,
    /// Where reference frames are cached between runs.
    pub reference_cache: PathBuf,
    /// FLIP's pixels per degree (`None`: from the eye's field of view and
    /// width, [`crate::metrics::ppd`]).
    pub flip_ppd: Option<f32>,
    /// The configuration the error ratios divide by (`None`: `naive` when
    /// compared, else the first).
    pub baseline: Option<String>,
}

/// The error figures (lower is better, positive) whose ratios to the
/// baseline `summary.json` and the table give.
pub const RATIO_METRICS: &[&str] = &["rse", "mse", "flip", "temporal", "stereo_mean"];

/// One method's row of `summary.csv` / `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct MethodRow {
    /// The configuration's label (the method name in a plain compare).
    pub method: String,
    /// The rendering method it ran (`sample-cache`, `taa`, ...).
    pub kind: String,
    pub frames: usize,
    pub mean_gpu_ms: f64,
    pub p95_gpu_ms: f64,
    /// Mean / p95 over the frames after the first (frame 0 carries one-time driver costs).
    pub steady_mean_gpu_ms: f64,
    pub steady_p95_gpu_ms: f64,
    /// Mean ms per pass over the frames after the first (all frames for a one-frame run).
    pub pass_mean_ms: BTreeMap<String, f64>,
    pub rays_per_frame: f64,
    pub rays_total: u64,
    pub method_memory_bytes: u64,
    /// Error / stability / stereo metrics per method (filled by the metrics
    /// stage): means over frames.
    pub metrics: BTreeMap<String, f64>,
    /// Standard error over frames of each of `metrics` (`∞`, JSON `null`,
    /// below two frames).
    pub metrics_stderr: BTreeMap<String, f64>,
    /// [`RATIO_METRICS`] of this row over the baseline's, with delta-method
    /// standard errors (`mean` is the ratio).
    pub ratios: BTreeMap<String, MeanStderr>,
    /// Per-frame metric values (for the ratios), not written.
    #[serde(skip)]
    pub series: BTreeMap<String, Vec<f64>>,
}

impl MethodRow {
    /// A row of summary.json as written ([`Self::series`] empty; `null`
    /// standard errors read back as `∞`, `null` metrics — written for a
    /// metric that was not finite — as NaN, so a merge writes them as
    /// `null` again and warns about them as the run did); `None` when it is
    /// not one.
    pub fn from_json(v: &serde_json::Value) -> Option<Self> {
        let f = |k: &str| v[k].as_f64();
        let map = |k: &str, null: Option<f64>| -> BTreeMap<String, f64> {
            v[k].as_object()
                .map(|m| {
                    m.iter()
                        .filter_map(|(k, x)| x.as_f64().or(null).map(|x| (k.clone(), x)))
                        .collect()
                })
                .unwrap_or_default()
        };
        Some(MethodRow {
            method: v["method"].as_str()?.to_string(),
            kind: v["kind"].as_str()?.to_string(),
            frames: v["frames"].as_u64()? as usize,
            mean_gpu_ms: f("mean_gpu_ms")?,
            p95_gpu_ms: f("p95_gpu_ms")?,
            steady_mean_gpu_ms: f("steady_mean_gpu_ms")?,
            steady_p95_gpu_ms: f("steady_p95_gpu_ms")?,
            pass_mean_ms: map("pass_mean_ms", None),
            rays_per_frame: f("rays_per_frame")?,
            rays_total: v["rays_total"].as_u64()?,
            method_memory_bytes: v["method_memory_bytes"].as_u64()?,
            metrics: map("metrics", Some(f64::NAN)),
            metrics_stderr: map("metrics_stderr", Some(f64::INFINITY)),
            ratios: BTreeMap::new(),
            series: BTreeMap::new(),
        })
    }

    fn from_summary(s: &ReplaySummary) -> Self {
        MethodRow {
            method: s.method.clone(),
            kind: s.method.clone(),
            frames: s.frames,
            mean_gpu_ms: s.mean_gpu_ms,
            p95_gpu_ms: s.p95_gpu_ms,
            steady_mean_gpu_ms: s.steady_mean_gpu_ms,
            steady_p95_gpu_ms: s.steady_p95_gpu_ms,
            pass_mean_ms: if s.steady_pass_mean_ms.is_empty() {
                s.pass_mean_ms.clone()
            } else {
                s.steady_pass_mean_ms.clone()
            },
            rays_per_frame: s.rays_per_frame,
            rays_total: s.rays.total,
            method_memory_bytes: s.method_memory_bytes,
            metrics: BTreeMap::new(),
            metrics_stderr: BTreeMap::new(),
            ratios: BTreeMap::new(),
            series: BTreeMap::new(),
        }
    }
}

/// The reference's estimated RSE is "not small" when it exceeds this
/// fraction of the best method's measured RSE: every measured RSE contains
/// the reference's (metrics::reference_noise), so at 0.1 the best method's
/// figure is inflated by up to 10 %, the others' by less.
pub const REFERENCE_NOISE_RATIO: f64 = 0.1;

/// The reference the metrics used and its own error, estimated from its two
/// independent halves (`reference` in summary.json).
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceSummary {
    /// Samples per pixel of the reference (the mean of the two halves).
    pub spp: u32,
    /// Samples per pixel of each half.
    pub half_spp: u32,
    /// The seeds of the two halves.
    pub half_seeds: [u32; 2],
    /// Frames (each both eyes) the estimate averages over.
    pub frames: usize,
    /// Estimated error of the reference against the converged image, means
    /// over frames and eyes with standard errors: `rse` is the RSE (ε = 0.01)
    /// the converged image itself would be measured at against this
    /// reference, i.e. the part of every method's RSE that is the
    /// reference's noise; `mse` likewise (linear).
    pub rse: f64,
    pub rse_stderr: f64,
    pub mse: f64,
    pub mse_stderr: f64,
    /// HDR-FLIP of half A against half B, mean over frames and eyes: what
    /// FLIP scores the noise of two independent `spp/2` references at (a
    /// scale for the reference's part of every method's FLIP, not an
    /// additive floor: [`ReferenceFrame::flip_halves`]).
    pub flip_halves: f64,
    pub estimator: &'static str,
    /// The method with the lowest measured RSE, and that RSE.
    pub best_method: Option<String>,
    pub best_method_rse: Option<f64>,
    /// `rse / best_method_rse`.
    pub ratio_to_best: Option<f64>,
    /// The warning threshold on `ratio_to_best` ([`REFERENCE_NOISE_RATIO`]).
    pub warning_ratio: f64,
    /// `--reference-spp` that would bring `ratio_to_best` to the threshold
    /// ([`suggested_reference_spp`]); present with the warning.
    pub suggested_spp: Option<u32>,
    /// The warning printed (without its `warning: ` prefix), if any.
    pub warning: Option<String>,
}

/// Reference samples per pixel that bring the reference's RSE to
/// [`REFERENCE_NOISE_RATIO`] × the best method's, from a run at `spp`:
/// unbiased Monte Carlo error falls as 1/spp (`ρ' = ρ · spp/S'`), and the
/// best method's measured RSE is its true RSE plus the reference's (`best =
/// b + ρ`), so `ρ'/(b + ρ') = k` gives `S' = spp · ρ (1 − k)/(k (best − ρ))`.
/// When the reference's noise is most of the best method's figure (`best ≤
/// ρ / (1 − k)`, no estimate of `b`), `S' = spp · ρ/(k · best)`, a lower
/// bound. Rounded up to a power of two.
/// Degenerate figures (a best RSE of 0, a non-finite ratio) give the
/// largest count rather than a NaN turned into 1; every result is one
/// `--reference-spp` accepts: even and at most [`crate::values::MAX_SPP`]
/// (where more would be needed the warning says so).
pub fn suggested_reference_spp(spp: u32, rse_ref: f64, best: f64) -> u32 {
    let k = REFERENCE_NOISE_RATIO;
    let s = spp as f64;
    let want = if best > rse_ref / (1.0 - k) {
        s * rse_ref * (1.0 - k) / (k * (best - rse_ref))
    } else {
        s * rse_ref / (k * best)
    };
    let want = if want.is_nan() { f64::INFINITY } else { want };
    let want = want.ceil().clamp(2.0, crate::values::MAX_SPP as f64) as u32;
    want.next_power_of_two()
}

impl ReferenceSummary {
    fn new(spp: u32, seed: u32, references: &[ReferenceFrame], rows: &[MethodRow]) -> Self {
        let noise: Vec<ReferenceNoise> = references.iter().map(|r| r.noise).collect();
        let n = ReferenceNoise::mean(&noise);
        let flip_halves =
            references.iter().map(|r| r.flip_halves).sum::<f64>() / references.len().max(1) as f64;
        Self::from_noise(spp, seed, n, flip_halves, noise.len(), rows)
    }

    /// The summary of a reference whose noise over `frames` frames was `n`
    /// (and half-vs-half FLIP `flip_halves`), against `rows`: what
    /// [`crate::merge`] rebuilds when the rows come from several parts.
    pub fn from_noise(
        spp: u32,
        seed: u32,
        n: ReferenceNoise,
        flip_halves: f64,
        frames: usize,
        rows: &[MethodRow],
    ) -> Self {
        let best = rows
            .iter()
            .filter_map(|r| r.metrics.get("rse").map(|&v| (r.method.clone(), v)))
            .filter(|(_, v)| v.is_finite())
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let ratio = best.as_ref().map(|(_, b)| n.rse / b);
        let mut sum = ReferenceSummary {
            spp,
            half_spp: spp / 2,
            half_seeds: half_seeds(seed),
            frames,
            rse: n.rse,
            rse_stderr: n.rse_stderr,
            mse: n.mse,
            mse_stderr: n.mse_stderr,
            flip_halves,
            estimator: "two independent halves A, B of spp/2: per pixel and channel ((A-B)/2)^2 estimates Var((A+B)/2); rse = mean of ((A-B)/2)^2/(T^2 + 0.01), T the mean of (A+B)/2 over the pixel's 8 neighbours (the pixel's own value would correlate with its noise), mse = mean of ((A-B)/2)^2",
            best_method: best.as_ref().map(|b| b.0.clone()),
            best_method_rse: best.as_ref().map(|b| b.1),
            ratio_to_best: ratio,
            warning_ratio: REFERENCE_NOISE_RATIO,
            suggested_spp: None,
            warning: None,
        };
        if let (Some((name, b)), Some(r)) = (&best, ratio) {
            // (A noise-free reference, RSE 0, inflates nothing: no warning,
            // whatever 0/0 gives.)
            if n.rse > 0.0 && (r > REFERENCE_NOISE_RATIO || !r.is_finite()) {
                let s = suggested_reference_spp(spp, n.rse, *b);
                sum.suggested_spp = Some(s);
                let advice = if s >= crate::values::MAX_SPP {
                    format!("use --reference-spp {s} (the largest; it may not be enough)")
                } else {
                    format!("use --reference-spp {s} or more")
                };
                sum.warning = Some(format!(
                    "the reference ({spp} spp) has an estimated RSE of {:.4} ± {:.1e} against the converged image, {r:.2}x the best method's ({name}, RSE {b:.4}); above {REFERENCE_NOISE_RATIO}x every method's error is inflated by the reference's noise: {advice}",
                    n.rse, n.rse_stderr
                ));
            }
        }
        sum
    }
}

/// What a comparison measured: one row per configuration, and the reference
/// (when metrics were computed).
#[derive(Clone, Debug)]
pub struct Comparison {
    pub rows: Vec<MethodRow>,
    pub reference: Option<ReferenceSummary>,
    /// The label the ratios divide by.
    pub baseline: String,
    /// FLIP's pixels per degree and its source.
    pub flip: FlipPpd,
}

/// The pixels per degree FLIP was computed at (`flip` in summary.json).
#[derive(Clone, Debug, Serialize)]
pub struct FlipPpd {
    pub ppd: f32,
    /// `"--flip-ppd"` or how it was derived.
    pub source: String,
}

/// The baseline label: `requested` when it is one of `labels`, else
/// `naive` when compared, else the first; an error names the labels.
pub fn choose_baseline(labels: &[String], requested: Option<&str>) -> Result<String> {
    match requested {
        Some(b) if labels.iter().any(|l| l == b) => Ok(b.to_string()),
        Some(b) => Err(Error::Usage(format!(
            "bad --baseline '{b}': not among the compared configurations ({})",
            labels.join(", ")
        ))),
        None => labels
            .iter()
            .find(|l| l.as_str() == "naive")
            .or(labels.first())
            .cloned()
            .ok_or_else(|| Error::Usage("nothing to compare".into())),
    }
}

/// Fills every row's [`MethodRow::ratios`] against the row labelled `baseline`.
pub fn fill_ratios(rows: &mut [MethodRow], baseline: &str) {
    let Some(base) = rows.iter().find(|r| r.method == baseline).cloned() else {
        return;
    };
    for r in rows.iter_mut() {
        r.ratios = RATIO_METRICS
            .iter()
            .filter_map(|&k| {
                let (x, y) = (r.series.get(k)?, base.series.get(k)?);
                ratio_of_means(x, y).map(|q| (k.to_string(), q))
            })
            .collect();
    }
}

/// Default frames shown side by side: first, middle and last.
fn default_shown(n: usize) -> Vec<usize> {
    let mut v = vec![0, n / 2, n.saturating_sub(1)];
    v.dedup();
    v
}

/// One configuration of a comparison: a label (its folder and column name),
/// the method with its own options, and the shared settings it runs with.
#[derive(Clone, Debug)]
pub struct Config {
    pub label: String,
    pub config: MethodConfig,
    pub settings: RenderSettings,
}

/// The files of a comparison folder that describe a whole run (not one
/// configuration's folder).
const RUN_OUTPUTS: &[&str] = &[
    "experiment.json",
    "summary.json",
    "summary.csv",
    "side-by-side",
    "report.html",
    "viewer",
];

/// Removes a previous run's summaries, grids, report, viewer and
/// experiment.json from the comparison folder `out` before a new run (or
/// merge) writes there: a run that fails part way must not leave them
/// beside its own method folders, looking like its results; the report
/// embeds every grid in side-by-side/ (a rerun with fewer frames showed the
/// old frames' grids) and draws an experiment.json's claims and figures
/// (until session 50 a plain compare into an experiment's folder showed the
/// old claims; the experiment runner writes its own after its comparisons).
/// In the two folders only the files a run writes there go
/// (`side-by-side/frame_NNNNN[.partK].png`; `viewer/index.json`,
/// `viewer/frame_NNNNN/*.png`): a user's own files in them stay.
pub fn remove_stale_outputs(out: &Path) -> Result<()> {
    for stale in RUN_OUTPUTS {
        let p = out.join(stale);
        let r = match *stale {
            "side-by-side" => {
                output::remove_run_files(&p, &|rel, dir| !dir && output::is_grid_image(rel))
            }
            "viewer" => output::remove_run_files(&p, &output::is_viewer_output),
            _ => output::remove_stale(&p),
        };
        r.map_err(|e| Error::io(&p, e))?;
        if p.is_dir() {
            // Gone where nothing else was in it.
            let _ = std::fs::remove_dir(&p);
        }
    }
    Ok(())
}

/// Every method of `opts.methods` with the same settings.
pub fn compare(
    session: &Session,
    cameras: &[StereoCamera],
    settings: &RenderSettings,
    opts: &CompareOptions,
) -> Result<Comparison> {
    if opts.methods.is_empty() {
        return Err(Error::Usage(
            "compare needs at least one method (--methods a,b,...)".into(),
        ));
    }
    let configs: Vec<Config> = opts
        .methods
        .iter()
        .map(|m| Config {
            label: m.kind().name().to_string(),
            config: m.clone(),
            settings: settings.clone(),
        })
        .collect();
    compare_configs(session, cameras, &configs, settings, opts)
}

/// The seed of the reference frames the metrics compare against. They must
/// not share random numbers with the methods: under the methods' own seed a
/// 1 spp path tracer's sample is also the reference's first sample, and a
/// supersampled image at the reference's sample count *is* the reference
/// (error exactly 0), which biases those methods' errors low.
pub fn reference_seed(method_seed: u32) -> u32 {
    method_seed ^ 0x9E37_79B9
}

/// A configuration label names its output folder: letters, digits and
/// `-_.=`, not empty and not `.` or `..` (which would name no folder of
/// its own).
pub fn check_label(l: &str) -> std::result::Result<(), String> {
    if l.is_empty()
        || l == "."
        || l == ".."
        || !l
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.=".contains(c))
    {
        let shown: String = l.chars().take(40).collect();
        return Err(format!(
            "configuration label '{shown}' must be letters, digits, '-', '_', '.', '=' (and not '.' or '..')"
        ));
    }
    Ok(())
}

/// Refuses `--show-frames` past the last of `n` frames, or naming a frame
/// twice (before anything renders; `compare_configs` checks again). (A
/// repeated frame used to pass here and panic after every method had
/// rendered, before the summaries were written.)
pub fn check_shown_frames(shown: &[usize], n: usize) -> std::result::Result<(), String> {
    if let Some(bad) = shown.iter().find(|&&f| f >= n) {
        return Err(format!(
            "bad --show-frames: frame {bad} is past the last frame {}",
            n.saturating_sub(1)
        ));
    }
    if let Some((_, f)) = shown
        .iter()
        .enumerate()
        .find(|&(i, f)| shown[..i].contains(f))
    {
        return Err(format!("bad --show-frames: frame {f} is listed twice"));
    }
    Ok(())
}

/// Every configuration along the same frames; references use `reference_settings`
/// with `opts.reference_spp` samples per pixel and their own seed ([`reference_seed`]).
pub fn compare_configs(
    session: &Session,
    cameras: &[StereoCamera],
    configs: &[Config],
    reference_settings: &RenderSettings,
    opts: &CompareOptions,
) -> Result<Comparison> {
    let settings = reference_settings;
    if configs.is_empty() {
        return Err(Error::Usage("nothing to compare".into()));
    }
    let labels: Vec<String> = configs.iter().map(|c| c.label.clone()).collect();
    for l in &labels {
        check_label(l).map_err(Error::Usage)?;
    }
    if let Some(spp) = opts.reference_spp {
        crate::evaluate::check_reference_spp(spp)?;
        crate::evaluate::check_reference_cache_dir(&opts.reference_cache)?;
    }
    let baseline = choose_baseline(&labels, opts.baseline.as_deref())?;
    if let Some(p) = opts.flip_ppd {
        check_flip_ppd(p)?;
    }
    let n = opts.frames.unwrap_or(cameras.len()).min(cameras.len());
    if n == 0 {
        return Err(Error::Usage("compare: the trace gives no frames".into()));
    }
    session.check_poses((0..n).map(|k| k as f64 / opts.fps))?;
    let shown = opts
        .shown_frames
        .clone()
        .unwrap_or_else(|| default_shown(n));
    check_shown_frames(&shown, n).map_err(Error::Usage)?;
    std::fs::create_dir_all(&opts.out).map_err(|e| Error::io(&opts.out, e))?;
    remove_stale_outputs(&opts.out)?;
    // Every method is created before the first frame so bad method options
    // fail fast; debug views are on so the grids can show them.
    let mut methods = Vec::new();
    for c in configs {
        let mut with_debug = c.config.clone();
        with_debug.enable_debug_views();
        methods.push(session.create(with_debug, &c.settings)?);
    }
    // Reference frames (rendered once as two independent halves, cached on
    // disk) for the metrics.
    let references: Vec<ReferenceFrame> = match opts.reference_spp {
        None => Vec::new(),
        Some(spp) => {
            let rs = RenderSettings {
                spp,
                seed: reference_seed(settings.seed),
                ..settings.clone()
            };
            let mut cache = ReferenceCache::new(opts.reference_cache.clone(), rs)?;
            cache.flip_ppd = opts.flip_ppd;
            // Each reference at its frame's pose (a moving scene's instances
            // at frame i / fps, as the replay poses them; nothing for a
            // static scene). The cache key includes the pose.
            cameras[..n]
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    session.pose_instances(i as f64 / opts.fps, None)?;
                    cache.get(session, c, i as u32)
                })
                .collect::<Result<_>>()?
        }
    };
    let mut rows = Vec::new();
    // kept[frame][method] = the frame as rendered by that method.
    let mut kept: Vec<Vec<StereoFrame>> = vec![Vec::new(); shown.len()];
    let mut kept_cameras: Vec<Option<StereoCamera>> = vec![None; shown.len()];
    for ((name, config), method) in labels.iter().zip(configs).zip(methods.iter_mut()) {
        let mut evaluator = Evaluator::new(opts.flip_ppd);
        evaluator.moving = session.scene.instance_moves();
        let moving = evaluator.moving.contains(&true);
        let ropts = ReplayOptions {
            frames: Some(n),
            fps: opts.fps,
            every: opts.every,
            out: opts.out.join(name),
            exposure: opts.exposure,
            debug_views: false,
            trace: opts.trace.clone(),
            // The configuration's own settings (its spp, seed, bounces,
            // `--taa-output`), not the shared ones: until session 50 every
            // method's summary.json recorded the [run] values (bench
            // tradeoff's supersample-4spp said spp 1).
            settings: config.config.record(&config.settings),
        };
        let mut observer =
            |i: usize, cam: &StereoCamera, f: &StereoFrame| -> Result<BTreeMap<String, f64>> {
                if let Some(k) = shown.iter().position(|&s| s == i) {
                    kept[k].push(f.clone());
                    kept_cameras[k] = Some(*cam);
                }
                // The pose the reference of frame i was rendered at, for the
                // temporal mask's motion (Evaluator::pose).
                if moving {
                    evaluator.pose = session.scene.instance_transforms_at(i as f64 / opts.fps);
                }
                match references.get(i) {
                    Some(r) => evaluator.frame(cam, f, r),
                    None => Ok(BTreeMap::new()),
                }
            };
        let summary = replay_observed(session, method.as_mut(), cameras, &ropts, &mut observer)?;
        let mut row = MethodRow::from_summary(&summary);
        row.method = name.clone();
        row.kind = config.config.kind().name().to_string();
        row.metrics = evaluator.means();
        row.metrics_stderr = evaluator.stderrs();
        row.series = evaluator.series().clone();
        rows.push(row);
    }
    fill_ratios(&mut rows, &baseline);
    let flip = match opts.flip_ppd {
        Some(ppd) => FlipPpd {
            ppd,
            source: "--flip-ppd".into(),
        },
        None if cameras[0].projection != crate::camera::Projection::Perspective => FlipPpd {
            ppd: flip_ppd(&cameras[0], settings.width),
            source: "default: an orthographic camera's pixels subtend no angle (metrics::flip::DEFAULT_PPD)".into(),
        },
        None => FlipPpd {
            ppd: flip_ppd(&cameras[0], settings.width),
            source: format!(
                "derived: one pixel's angle at the centre of a {} px wide eye image, horizontal field of view {:.2} deg (metrics::ppd)",
                settings.width,
                (2.0 * cameras[0].eye(crate::camera::Eye::Left).tan_half_fov().x.atan()).to_degrees()
            ),
        },
    };
    let sbs = opts.out.join("side-by-side");
    std::fs::create_dir_all(&sbs).map_err(|e| Error::io(&sbs, e))?;
    for (k, &f) in shown.iter().enumerate() {
        let cam = kept_cameras[k].expect("shown frames were rendered");
        write_grid(
            &sbs.join(format!("frame_{f:05}.png")),
            &labels,
            &kept[k],
            &cam,
            references.get(f).map(|r| &r.frame),
            opts.exposure,
            opts.zoom.max(1),
        )?;
    }
    // The report's error maps, crops and viewer images (left eye).
    crate::report::images::write(
        &opts.out,
        &labels,
        &shown,
        &kept,
        &references,
        opts.exposure,
        flip.ppd,
    )?;
    let reference = opts
        .reference_spp
        .map(|spp| ReferenceSummary::new(spp, reference_seed(settings.seed), &references, &rows));
    let cmp = Comparison {
        rows,
        reference,
        baseline,
        flip,
    };
    write_summaries(session, opts, settings, &cmp)?;
    if let Some(w) = non_finite_metrics_warning(&opts.out, &cmp.rows) {
        eprintln!("warning: {w}");
    }
    Ok(cmp)
}

/// One line naming the configurations whose mean metrics are not finite
/// (`null` in summary.json) or whose images held ∞ or NaN pixels (the
/// metrics score those as black: `non_finite_pixels`, the mean per frame
/// of both eyes' count), and a reference whose path tracer dropped such
/// samples (`non_finite_reference_samples`) or whose halves held such pixels
/// (`non_finite_reference_pixels`), or `None` when none of these happened.
pub fn non_finite_metrics_warning(out: &Path, rows: &[MethodRow]) -> Option<String> {
    let mut bad: Vec<String> = rows
        .iter()
        .filter_map(|r| {
            let keys: Vec<&str> = r
                .metrics
                .iter()
                .filter(|(_, v)| !v.is_finite())
                .map(|(k, _)| k.as_str())
                .collect();
            let pixels = r
                .metrics
                .get("non_finite_pixels")
                .copied()
                .filter(|n| *n > 0.0)
                .map(|n| {
                    format!("{n:.1} pixels of ∞ or NaN per frame, those channels scored as 0")
                });
            let mut what: Vec<String> = Vec::new();
            if !keys.is_empty() {
                what.push(format!(
                    "metrics not finite, written as null: {}",
                    keys.join(", ")
                ));
            }
            what.extend(pixels);
            (!what.is_empty()).then(|| format!("{} ({})", r.method, what.join("; ")))
        })
        .collect();
    // The reference is shared by every row: named once, from any row that has it.
    let reference = |key: &str| {
        rows.iter()
            .filter_map(|r| r.metrics.get(key).copied())
            .find(|n| *n > 0.0)
    };
    let mut what: Vec<String> = Vec::new();
    if let Some(n) = reference("non_finite_reference_samples") {
        what.push(format!(
            "{n:.1} samples of ∞ or NaN per frame dropped by its path tracer, counted as black"
        ));
    }
    if let Some(n) = reference("non_finite_reference_pixels") {
        what.push(format!(
            "{n:.1} pixels of ∞ or NaN per frame in its two halves, both eyes: the other half's value used where it is finite, else those channels counted as 0 in the mean"
        ));
    }
    if !what.is_empty() {
        bad.push(format!("the reference ({})", what.join("; ")));
    }
    (!bad.is_empty()).then(|| {
        format!(
            "{}: images or metrics that are not finite: {}",
            out.join("summary.json").display(),
            bad.join("; ")
        )
    })
}

/// `--flip-ppd` must be a finite positive number.
pub fn check_flip_ppd(ppd: f32) -> Result<()> {
    if ppd.is_finite() && ppd > 0.0 {
        Ok(())
    } else {
        Err(Error::Usage(format!(
            "bad --flip-ppd {ppd}: expected pixels per degree, a positive number (e.g. 67 for a desktop monitor at 0.7 m)"
        )))
    }
}

/// |left reprojected into the right view − right| per pixel — the term
/// `stereo_mean` averages ([`crate::metrics::pixel_difference`]) — on the
/// pixels of the stereo metric's mask, 0 elsewhere. The mask comes from
/// `geometry`'s pixel-centre depth and first hits (same instance, depth
/// within [`crate::evaluate::DEPTH_TOLERANCE`]): `compare` passes the
/// frame's reference, as the metric uses it (issue 15: every method on one
/// mask), and the method's own frame only where it renders no reference.
/// Until session 58 the picture always used the method's own depth and
/// ids, so it showed other pixels than `stereo_mean` scored (and nothing
/// at all for a method that reports no depth).
pub fn stereo_difference(
    f: &StereoFrame,
    cam: &StereoCamera,
    geometry: &StereoFrame,
) -> Vec<[f32; 4]> {
    use crate::metrics::{pixel_difference, Covisibility, Geometry, LinearImage};
    let (w, h) = (f.width as usize, f.height as usize);
    let views = cam.eyes();
    let eye = |e: usize| Geometry {
        depth: &geometry.eyes[e].depth,
        view: &views[e],
        first_hits: Some(&geometry.eyes[e].first_hit),
    };
    let difference = || -> Option<Vec<[f32; 4]>> {
        let left = LinearImage::from_rgba(&f.eyes[0].radiance, w, h).ok()?;
        let right = LinearImage::from_rgba(&f.eyes[1].radiance, w, h).ok()?;
        let cov = Covisibility::new(eye(0), eye(1), w, h, crate::evaluate::DEPTH_TOLERANCE).ok()?;
        let warped = cov.warp(&left).ok()?;
        Some(
            (0..w * h)
                .map(|i| match cov.is_covisible(i) {
                    true => {
                        let d = pixel_difference(warped.rgb[i], right.rgb[i]);
                        [d, d, d, 1.0]
                    }
                    false => [0.0; 4],
                })
                .collect(),
        )
    };
    difference().unwrap_or_else(|| vec![[0.0; 4]; w * h])
}

/// One column per method: a label, left eye, right eye, zoomed centre crops,
/// the stereo difference on the stereo metric's mask (`reference`'s
/// geometry where there is one: [`stereo_difference`]; through the
/// preview's tone curve at exposure 4: `to_srgb8`, not a linear ×4), and
/// the methods' debug views where they
/// have them (clamped and sRGB-encoded as `replay --debug-views` writes
/// them: `to_srgb8_clamped`).
fn write_grid(
    path: &Path,
    names: &[String],
    frames: &[StereoFrame],
    cam: &StereoCamera,
    reference: Option<&StereoFrame>,
    exposure: f32,
    zoom: u32,
) -> Result<()> {
    let (w, h) = (frames[0].width, frames[0].height);
    let scale = if w >= 160 { 2 } else { 1 };
    let label_h = 7 * scale + 6;
    let gap = 2;
    // Debug-view rows: every view name any method has, in first-seen order.
    let mut debug_names: Vec<String> = Vec::new();
    for f in frames {
        for (n, _) in &f.eyes[0].debug {
            if !debug_names.contains(n) {
                debug_names.push(n.clone());
            }
        }
    }
    let rows = 5 + debug_names.len() as u32;
    let cols = frames.len() as u32;
    let gw = cols * w + (cols + 1) * gap;
    let gh = label_h + rows * h + (rows + 1) * gap;
    let mut img = vec![32u8; (gw * gh * 3) as usize];
    let row_y = |r: u32| label_h + gap + r * (h + gap);
    for (c, (name, f)) in names.iter().zip(frames).enumerate() {
        let x0 = gap + c as u32 * (w + gap);
        let text = if label::text_width(name, scale) > w {
            name.chars().take((w / (6 * scale)) as usize).collect()
        } else {
            name.clone()
        };
        label::Canvas {
            data: &mut img,
            width: gw,
            height: gh,
        }
        .text(x0 + 2, 3, &text, scale, [255, 255, 255]);
        for (e, eye) in f.eyes.iter().enumerate() {
            let rgb = tonemap::to_srgb8(&eye.radiance, exposure);
            blit(&mut img, gw, &rgb, w, h, x0, row_y(e as u32), None);
            // Zoomed crop around the centre.
            let (cw, ch) = ((w / zoom).max(1), (h / zoom).max(1));
            let crop = ((w - cw) / 2, (h - ch) / 2, cw, ch);
            blit(
                &mut img,
                gw,
                &rgb,
                w,
                h,
                x0,
                row_y(2 + e as u32),
                Some(crop),
            );
        }
        let diff = tonemap::to_srgb8(&stereo_difference(f, cam, reference.unwrap_or(f)), 4.0);
        blit(&mut img, gw, &diff, w, h, x0, row_y(4), None);
        for (k, dn) in debug_names.iter().enumerate() {
            if let Some((_, view)) = f.eyes[0].debug.iter().find(|(n, _)| n == dn) {
                let rgb = tonemap::to_srgb8_clamped(view);
                blit(&mut img, gw, &rgb, w, h, x0, row_y(5 + k as u32), None);
            }
        }
    }
    // Row captions in the first column.
    let captions: Vec<String> = [
        "left",
        "right",
        "left crop",
        "right crop",
        "stereo diff exp 4",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain(debug_names.iter().map(|n| format!("{n} (left)")))
    .collect();
    for (r, cap) in captions.iter().enumerate() {
        label::Canvas {
            data: &mut img,
            width: gw,
            height: gh,
        }
        .text(gap + 2, row_y(r as u32) + 2, cap, 1, [255, 255, 0]);
    }
    output::write_encoded(path, |out| output::encode_png_rgb8(out, gw, gh, &img))?;
    Ok(())
}

/// Copies a w×h RGB8 image (or a crop of it, scaled up to w×h with nearest
/// neighbour) into the grid at (x0, y0).
#[allow(clippy::too_many_arguments)]
fn blit(
    dst: &mut [u8],
    dw: u32,
    src: &[u8],
    w: u32,
    h: u32,
    x0: u32,
    y0: u32,
    crop: Option<(u32, u32, u32, u32)>,
) {
    for y in 0..h {
        for x in 0..w {
            let (sx, sy) = match crop {
                None => (x, y),
                Some((cx, cy, cw, ch)) => (cx + x * cw / w, cy + y * ch / h),
            };
            let s = ((sy * w + sx) * 3) as usize;
            let d = (((y0 + y) * dw + x0 + x) * 3) as usize;
            dst[d..d + 3].copy_from_slice(&src[s..s + 3]);
        }
    }
}

/// What summary.json says about the run beside its rows: the device, the
/// scene and trace, the size and the settings (a merge of parts copies it
/// from the first part, [`crate::merge`]).
#[derive(Clone, Debug)]
pub struct SummaryHeader {
    pub device: serde_json::Value,
    pub driver: serde_json::Value,
    pub backend: serde_json::Value,
    pub scene: serde_json::Value,
    pub trace: serde_json::Value,
    pub width: serde_json::Value,
    pub height: serde_json::Value,
    pub fps: serde_json::Value,
    pub settings: serde_json::Value,
}

impl SummaryHeader {
    fn new(session: &Session, opts: &CompareOptions, settings: &RenderSettings) -> Self {
        let caps = &session.ctx.caps;
        let v = |x: serde_json::Result<serde_json::Value>| x.unwrap_or_default();
        SummaryHeader {
            device: caps.name.clone().into(),
            driver: format!("{} {}", caps.driver_name, caps.driver_info).into(),
            backend: v(serde_json::to_value(session.backend)),
            scene: v(serde_json::to_value(&session.scene.source)),
            trace: v(serde_json::to_value(&opts.trace)),
            width: settings.width.into(),
            height: settings.height.into(),
            fps: opts.fps.into(),
            settings: v(serde_json::to_value(settings)),
        }
    }

    /// The header of a summary.json as written.
    pub fn from_summary(s: &serde_json::Value) -> Self {
        SummaryHeader {
            device: s["device"].clone(),
            driver: s["driver"].clone(),
            backend: s["backend"].clone(),
            scene: s["scene"].clone(),
            trace: s["trace"].clone(),
            width: s["width"].clone(),
            height: s["height"].clone(),
            fps: s["fps"].clone(),
            settings: s["settings"].clone(),
        }
    }
}

fn write_summaries(
    session: &Session,
    opts: &CompareOptions,
    settings: &RenderSettings,
    cmp: &Comparison,
) -> Result<()> {
    write_summary_files(&opts.out, &SummaryHeader::new(session, opts, settings), cmp)
}

/// Writes `out/summary.csv` and `out/summary.json` of `cmp`.
pub fn write_summary_files(out: &Path, header: &SummaryHeader, cmp: &Comparison) -> Result<()> {
    let rows = &cmp.rows;
    let reference = cmp.reference.as_ref();
    let mut passes: Vec<String> = rows
        .iter()
        .flat_map(|r| r.pass_mean_ms.keys().cloned())
        .collect();
    passes.sort();
    passes.dedup();
    let mut metric_names: Vec<String> = rows
        .iter()
        .flat_map(|r| r.metrics.keys().cloned())
        .collect();
    metric_names.sort();
    metric_names.dedup();
    let mut csv = String::from(
        "method,frames,mean_gpu_ms,p95_gpu_ms,steady_mean_gpu_ms,steady_p95_gpu_ms,rays_per_frame,rays_total,method_memory_bytes",
    );
    for m in &metric_names {
        csv.push_str(&format!(",{m}"));
    }
    for m in &metric_names {
        csv.push_str(&format!(",se:{m}"));
    }
    for m in RATIO_METRICS {
        csv.push_str(&format!(",ratio:{m},ratio_se:{m}"));
    }
    for p in &passes {
        csv.push_str(&format!(",pass_ms:{p}"));
    }
    csv.push('\n');
    for r in rows {
        csv.push_str(&format!(
            "{},{},{:.4},{:.4},{:.4},{:.4},{:.1},{},{}",
            r.method,
            r.frames,
            r.mean_gpu_ms,
            r.p95_gpu_ms,
            r.steady_mean_gpu_ms,
            r.steady_p95_gpu_ms,
            r.rays_per_frame,
            r.rays_total,
            r.method_memory_bytes
        ));
        let num = |v: Option<f64>| match v {
            Some(v) if v.is_finite() => format!(",{v:.6e}"),
            _ => ",".into(),
        };
        for m in &metric_names {
            csv.push_str(&num(r.metrics.get(m).copied()));
        }
        for m in &metric_names {
            csv.push_str(&num(r.metrics_stderr.get(m).copied()));
        }
        for m in RATIO_METRICS {
            let q = r.ratios.get(*m);
            csv.push_str(&num(q.map(|q| q.mean)));
            csv.push_str(&num(q.map(|q| q.stderr)));
        }
        for p in &passes {
            csv.push_str(&format!(
                ",{:.4}",
                r.pass_mean_ms.get(p).copied().unwrap_or(0.0)
            ));
        }
        csv.push('\n');
    }
    let csv_path = out.join("summary.csv");
    output::write_text(&csv_path, &csv)?;
    let h = header;
    let json = serde_json::json!({
        "device": h.device,
        "driver": h.driver,
        "backend": h.backend,
        "scene": h.scene,
        "trace": h.trace,
        "width": h.width,
        "height": h.height,
        "fps": h.fps,
        "settings": h.settings,
        "reference": reference,
        "baseline": cmp.baseline,
        "flip": cmp.flip,
        "masks": masks(rows),
        "methods": rows,
    });
    output::write_json(&out.join("summary.json"), &json)?;
    Ok(())
}

/// `masks` in summary.json: where the temporal and stereo masks come from,
/// their co-visible fractions and how many frames the temporal and stereo
/// metrics were scored on (those with a non-empty mask; the same for every
/// row).
fn masks(rows: &[MethodRow]) -> serde_json::Value {
    let first = rows
        .iter()
        .find(|r| r.metrics.contains_key("stereo_covisible"));
    serde_json::json!({
        "source": "reference pixel-centre geometry (depth and first-hit ids of the reference frames), one mask per frame for every method",
        "depth_tolerance_rel": crate::evaluate::DEPTH_TOLERANCE,
        "temporal_covisible": first.and_then(|r| r.metrics.get("temporal_covisible")),
        "stereo_covisible": first.and_then(|r| r.metrics.get("stereo_covisible")),
        "temporal_frames": first.and_then(|r| scored_frames(r, "temporal")),
        "stereo_frames": first.and_then(|r| scored_frames(r, "stereo_mean")),
    })
}

/// How many frames `row`'s `metric` was scored on (`None` without per-frame
/// values): frames with an empty co-visible mask have no temporal or stereo
/// value and count in neither the mean nor its standard error.
pub fn scored_frames(row: &MethodRow, metric: &str) -> Option<usize> {
    if row.series.is_empty() {
        return None;
    }
    Some(row.series.get(metric).map_or(0, Vec::len))
}

/// The short table printed at the end of a compare run: means over frames
/// with their standard errors (`±`).
pub fn summary_table(rows: &[MethodRow]) -> String {
    let mut s = format!(
        "{:<16} {:>9} {:>9} {:>12} {:>10} {:>17} {:>17} {:>17} {:>17}\n",
        "method",
        "GPU ms",
        "p95 ms",
        "rays/frame",
        "mem MiB",
        "RSE",
        "FLIP",
        "temporal+",
        "stereo+"
    );
    let metric = |r: &MethodRow, k: &str| match r.metrics.get(k) {
        Some(v) => match r.metrics_stderr.get(k) {
            Some(se) if se.is_finite() => format!("{v:.4}±{se:.4}"),
            _ => format!("{v:.4}"),
        },
        None => "-".into(),
    };
    for r in rows {
        s.push_str(&format!(
            "{:<16} {:>9.2} {:>9.2} {:>12.0} {:>10.1} {:>17} {:>17} {:>17} {:>17}\n",
            r.method,
            r.steady_mean_gpu_ms,
            r.steady_p95_gpu_ms,
            r.rays_per_frame,
            r.method_memory_bytes as f64 / (1u64 << 20) as f64,
            metric(r, "rse"),
            metric(r, "flip"),
            metric(r, "temporal_excess"),
            metric(r, "stereo_excess"),
        ));
    }
    s
}

/// The error figures' ratios to the baseline with their standard errors
/// (delta method over the paired frames), printed under [`summary_table`];
/// empty without metrics.
pub fn ratio_table(cmp: &Comparison) -> String {
    if cmp.rows.iter().all(|r| r.ratios.is_empty()) {
        return String::new();
    }
    let mut s = format!(
        "ratios to {} (mean over frames / the baseline's, ± delta-method SE over paired frames):\n{:<16}",
        cmp.baseline, "method"
    );
    for k in RATIO_METRICS {
        s.push_str(&format!(" {:>17}", format!("{k}/base")));
    }
    s.push('\n');
    for r in &cmp.rows {
        s.push_str(&format!("{:<16}", r.method));
        for k in RATIO_METRICS {
            let v = match r.ratios.get(*k) {
                Some(q) if q.stderr.is_finite() => format!("{:.3}±{:.3}", q.mean, q.stderr),
                Some(q) if q.mean.is_finite() => format!("{:.3}", q.mean),
                _ => "-".into(),
            };
            s.push_str(&format!(" {v:>17}"));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The side-by-side's stereo row shows what `stereo_mean` scores: on
    /// the reference's mask, the metric's per-pixel term. A fronto-parallel
    /// textured plane at 1 m (the metrics' 64 × 64 rig: 4 px of disparity),
    /// its right eye wrong by 0.5 at one pixel, rendered by a method that
    /// reports no depth (as a method may, or one whose depth is wrong): the
    /// row holds 0.5 at that pixel, 0 at the other co-visible ones, and its
    /// mean over the mask is `stereo_discrepancy_masked`'s; from the
    /// method's own geometry (until session 58) the row was black.
    #[test]
    fn the_stereo_row_shows_the_metrics_pixels() {
        use crate::metrics::reproject::tests::{rig, texture};
        use crate::metrics::{stereo_discrepancy_masked, Covisibility, Geometry, LinearImage};
        let cam = rig();
        let n = 64 * 64;
        let image = |shift: usize| -> Vec<[f32; 4]> {
            (0..n)
                .map(|k| {
                    let t = texture(k % 64 + shift, k / 64);
                    [t[0], t[1], t[2], 1.0]
                })
                .collect()
        };
        let (bad_i, bad_j) = (20usize, 30usize);
        let mut right = image(4);
        for c in &mut right[bad_j * 64 + bad_i][..3] {
            *c += 0.5;
        }
        let eye = |radiance: Vec<[f32; 4]>, depth: f32| crate::methods::EyeImage {
            radiance,
            depth: vec![depth; n],
            first_hit: vec![[0, 0, 0, 0]; n],
            ..Default::default()
        };
        let frame = |l, r, depth| StereoFrame {
            width: 64,
            height: 64,
            eyes: [eye(l, depth), eye(r, depth)],
            stats: Default::default(),
        };
        let method = frame(image(0), right, 0.0);
        let reference = frame(image(0), image(4), 1.0);
        let row = stereo_difference(&method, &cam, &reference);
        let views = cam.eyes();
        let geometry = |e: usize| Geometry {
            depth: &reference.eyes[e].depth,
            view: &views[e],
            first_hits: Some(&reference.eyes[e].first_hit),
        };
        let cov = Covisibility::new(
            geometry(0),
            geometry(1),
            64,
            64,
            crate::evaluate::DEPTH_TOLERANCE,
        )
        .unwrap();
        assert_eq!(
            cov.fraction(),
            60.0 / 64.0,
            "all but the 4 columns only the right eye sees"
        );
        for (k, p) in row.iter().enumerate() {
            let want = if k == bad_j * 64 + bad_i { 0.5 } else { 0.0 };
            assert!(
                (p[0] - want).abs() < 1e-5 && p[3] == if cov.is_covisible(k) { 1.0 } else { 0.0 },
                "pixel ({}, {}): {p:?}, want {want}",
                k % 64,
                k / 64
            );
        }
        let img = |e: usize| LinearImage::from_rgba(&method.eyes[e].radiance, 64, 64).unwrap();
        let metric = stereo_discrepancy_masked(&img(0), &img(1), &cov).unwrap();
        let shown =
            row.iter().map(|p| p[0] as f64).sum::<f64>() / (cov.fraction() as f64 * n as f64);
        assert!(
            (shown - metric.mean as f64).abs() < 1e-6,
            "row {shown}, stereo_mean {}",
            metric.mean
        );
        assert!(
            stereo_difference(&method, &cam, &method)
                .iter()
                .all(|p| p[0] == 0.0),
            "the method's own (empty) depth masks every pixel"
        );
    }

    /// The suggested reference spp is always a value `--reference-spp`
    /// accepts (even, 2..=MAX_SPP), also where the best method's RSE is 0
    /// (0/0 gave a NaN that became 1; the cap was 2^31) or the count needed
    /// is beyond the largest (4096 spp at 0.02 against 0.03 asks ~94 500).
    /// The formula's known answer: 64 spp at 0.01 against 0.05 wants
    /// 64 · 0.01 · 0.9 / (0.1 · 0.04) = 144, rounded up to 256.
    #[test]
    fn suggested_reference_spp_is_always_accepted() {
        for (spp, rse_ref, best) in [
            (64, 0.0, 0.0),
            (64, 0.01, 0.0),
            (64, 0.01, 0.05),
            (64, 0.01, 0.011),
            (64, 0.0, 0.1),
            (4096, 0.02, 0.03),
        ] {
            let s = suggested_reference_spp(spp, rse_ref, best);
            assert!(
                (2..=crate::values::MAX_SPP).contains(&s) && s % 2 == 0,
                "{spp} {rse_ref} {best}: {s}"
            );
        }
        assert_eq!(suggested_reference_spp(64, 0.01, 0.05), 256);
        assert_eq!(
            suggested_reference_spp(4096, 0.02, 0.03),
            crate::values::MAX_SPP
        );
    }

    /// A metric written as `null` (not finite) survives a read back, as a
    /// merge does: it is still there, still not finite, still warned about.
    #[test]
    fn null_metrics_read_back_as_not_finite() {
        let r = MethodRow::from_json(&serde_json::json!({
            "method": "a", "kind": "naive", "frames": 2, "mean_gpu_ms": 1.0,
            "p95_gpu_ms": 1.0, "steady_mean_gpu_ms": 1.0, "steady_p95_gpu_ms": 1.0,
            "rays_per_frame": 1.0, "rays_total": 2, "method_memory_bytes": 0,
            "metrics": {"rse": null, "mse": 0.5},
            "metrics_stderr": {"rse": null, "mse": 0.1}
        }))
        .unwrap();
        assert!(r.metrics["rse"].is_nan());
        assert_eq!(r.metrics["mse"], 0.5);
        assert_eq!(r.metrics_stderr["rse"], f64::INFINITY);
        let w = non_finite_metrics_warning(Path::new("out"), &[r]).expect("warned");
        assert!(w.contains("rse"), "{w}");
    }

    /// `--show-frames` naming a frame twice is refused before rendering
    /// (it panicked after rendering every method).
    #[test]
    fn shown_frames_are_checked() {
        assert!(check_shown_frames(&[0, 3, 5], 6).is_ok());
        let e = check_shown_frames(&[3, 0, 3], 6).unwrap_err();
        assert!(e.contains("frame 3 is listed twice"), "{e}");
        assert!(check_shown_frames(&[6], 6)
            .unwrap_err()
            .contains("past the last frame 5"));
    }

    /// A reference or image holding ∞ gave `"rse": null` in summary.json
    /// without a word; now one warning line names the configurations and
    /// metrics.
    #[test]
    fn non_finite_metrics_are_one_warning() {
        let row = |label: &str, rse: f64| {
            let mut r = MethodRow::from_json(&serde_json::json!({
                "method": label, "kind": "naive", "frames": 2, "mean_gpu_ms": 1.0,
                "p95_gpu_ms": 1.0, "steady_mean_gpu_ms": 1.0, "steady_p95_gpu_ms": 1.0,
                "rays_per_frame": 1.0, "rays_total": 2, "method_memory_bytes": 0
            }))
            .unwrap();
            r.metrics.insert("rse".into(), rse);
            r.metrics.insert("mse".into(), 1.0);
            r
        };
        let out = Path::new("out/cmp");
        assert_eq!(non_finite_metrics_warning(out, &[row("a", 0.5)]), None);
        let w = non_finite_metrics_warning(
            out,
            &[row("a", 0.5), row("b", f64::NAN), row("c", f64::INFINITY)],
        )
        .unwrap();
        assert!(
            w.starts_with("out/cmp/summary.json: images or metrics that are not finite")
                && w.ends_with(
                    ": b (metrics not finite, written as null: rse); c (metrics not finite, written as null: rse)"
                ),
            "{w}"
        );
        // Finite metrics over sanitized pixels: named with their count.
        let mut d = row("d", 0.5);
        d.metrics.insert("non_finite_pixels".into(), 2.5);
        let w = non_finite_metrics_warning(out, &[row("a", 0.5), d]).unwrap();
        assert!(
            w.ends_with(": d (2.5 pixels of ∞ or NaN per frame, those channels scored as 0)"),
            "{w}"
        );
        // A reference with such pixels: one clause, however many rows share it.
        let with_ref = |label: &str, n: f64| {
            let mut r = row(label, 0.5);
            r.metrics.insert("non_finite_reference_pixels".into(), n);
            r
        };
        assert_eq!(
            non_finite_metrics_warning(out, &[with_ref("a", 0.0), with_ref("b", 0.0)]),
            None
        );
        let w = non_finite_metrics_warning(out, &[with_ref("a", 1.5), with_ref("b", 1.5)]).unwrap();
        assert!(
            w.ends_with(": the reference (1.5 pixels of ∞ or NaN per frame in its two halves, both eyes: the other half's value used where it is finite, else those channels counted as 0 in the mean)"),
            "{w}"
        );
        let mut s = row("s", 0.5);
        s.metrics.insert("non_finite_reference_samples".into(), 4.0);
        let w = non_finite_metrics_warning(out, &[s]).unwrap();
        assert!(
            w.ends_with(": the reference (4.0 samples of ∞ or NaN per frame dropped by its path tracer, counted as black)"),
            "{w}"
        );
    }
}
