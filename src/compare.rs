//! `stereocache compare`: every method along the same frames of a trace.
//! Writes, under `out/`:
//! - `<method>/` — what `replay` writes for that method (frames, frames.jsonl, summary.json);
//! - `side-by-side/frame_<k>.png` — one column per method (labelled), rows:
//!   left eye, right eye, and a zoomed crop of each, for the chosen frames;
//! - `summary.csv` and `summary.json` — one row per method: mean and p95
//!   GPU ms per frame, mean ms per pass, rays, memory of the method's buffers,
//!   and the `metrics` against the reference (with `rse_reference` and
//!   `mse_reference`, the reference's own estimated error, beside `rse` and
//!   `mse`); summary.json also has `reference` ([`ReferenceSummary`]).
//!
//! The reference is rendered as two independent halves of `spp/2` samples
//! (different seeds) whose mean is the reference; their difference estimates
//! its own error ([`crate::metrics::reference_noise`]). When that error is
//! above [`REFERENCE_NOISE_RATIO`] × the best method's RSE, the comparison
//! carries a warning (printed by the CLI as one `warning:` line, shown in the
//! report) with the `--reference-spp` that would suffice.

use crate::camera::StereoCamera;
use crate::error::{Error, Result};
use crate::evaluate::{half_seeds, Evaluator, ReferenceCache, ReferenceFrame};
use crate::methods::{MethodConfig, RenderSettings, StereoFrame};
use crate::metrics::ReferenceNoise;
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
}

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
    /// Error / stability / stereo metrics per method (filled by the metrics stage).
    pub metrics: BTreeMap<String, f64>,
}

impl MethodRow {
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
pub fn suggested_reference_spp(spp: u32, rse_ref: f64, best: f64) -> u32 {
    let k = REFERENCE_NOISE_RATIO;
    let s = spp as f64;
    let want = if best > rse_ref / (1.0 - k) {
        s * rse_ref * (1.0 - k) / (k * (best - rse_ref))
    } else {
        s * rse_ref / (k * best)
    };
    let want = want.ceil().clamp(2.0, (1u64 << 31) as f64) as u32;
    want.next_power_of_two()
}

impl ReferenceSummary {
    fn new(spp: u32, seed: u32, noise: &[ReferenceNoise], rows: &[MethodRow]) -> Self {
        let n = ReferenceNoise::mean(noise);
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
            frames: noise.len(),
            rse: n.rse,
            rse_stderr: n.rse_stderr,
            mse: n.mse,
            mse_stderr: n.mse_stderr,
            estimator: "two independent halves A, B of spp/2: per pixel and channel ((A-B)/2)^2 estimates Var((A+B)/2); rse = mean of ((A-B)/2)^2/(((A+B)/2)^2 + 0.01), mse = mean of ((A-B)/2)^2",
            best_method: best.as_ref().map(|b| b.0.clone()),
            best_method_rse: best.as_ref().map(|b| b.1),
            ratio_to_best: ratio,
            warning_ratio: REFERENCE_NOISE_RATIO,
            suggested_spp: None,
            warning: None,
        };
        if let (Some((name, b)), Some(r)) = (&best, ratio) {
            if r > REFERENCE_NOISE_RATIO || !r.is_finite() {
                let s = suggested_reference_spp(spp, n.rse, *b);
                sum.suggested_spp = Some(s);
                sum.warning = Some(format!(
                    "the reference ({spp} spp) has an estimated RSE of {:.4} ± {:.1e} against the converged image, {r:.2}x the best method's ({name}, RSE {b:.4}); above {REFERENCE_NOISE_RATIO}x every method's error is inflated by the reference's noise: use --reference-spp {s} or more",
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
        if l.is_empty()
            || !l
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.=".contains(c))
        {
            return Err(Error::Usage(format!(
                "configuration label '{l}' must be letters, digits, '-', '_', '.', '='"
            )));
        }
    }
    if let Some(spp) = opts.reference_spp {
        crate::evaluate::check_reference_spp(spp)?;
    }
    let n = opts.frames.unwrap_or(cameras.len()).min(cameras.len());
    if n == 0 {
        return Err(Error::Usage("compare: the trace gives no frames".into()));
    }
    let shown = opts
        .shown_frames
        .clone()
        .unwrap_or_else(|| default_shown(n));
    if let Some(bad) = shown.iter().find(|&&f| f >= n) {
        return Err(Error::Usage(format!(
            "bad --show-frames: frame {bad} is past the last frame {}",
            n - 1
        )));
    }
    std::fs::create_dir_all(&opts.out).map_err(|e| Error::io(&opts.out, e))?;
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
            cameras[..n]
                .iter()
                .enumerate()
                .map(|(i, c)| cache.get(session, c, i as u32))
                .collect::<Result<_>>()?
        }
    };
    let mut rows = Vec::new();
    // kept[frame][method] = the frame as rendered by that method.
    let mut kept: Vec<Vec<StereoFrame>> = vec![Vec::new(); shown.len()];
    let mut kept_cameras: Vec<Option<StereoCamera>> = vec![None; shown.len()];
    for ((name, config), method) in labels.iter().zip(configs).zip(methods.iter_mut()) {
        let mut evaluator = Evaluator::default();
        let ropts = ReplayOptions {
            frames: Some(n),
            fps: opts.fps,
            every: opts.every,
            out: opts.out.join(name),
            exposure: opts.exposure,
            debug_views: false,
            trace: opts.trace.clone(),
            settings: config.config.record(settings),
        };
        let mut observer =
            |i: usize, cam: &StereoCamera, f: &StereoFrame| -> Result<BTreeMap<String, f64>> {
                if let Some(k) = shown.iter().position(|&s| s == i) {
                    kept[k].push(f.clone());
                    kept_cameras[k] = Some(*cam);
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
        rows.push(row);
    }
    let sbs = opts.out.join("side-by-side");
    std::fs::create_dir_all(&sbs).map_err(|e| Error::io(&sbs, e))?;
    for (k, &f) in shown.iter().enumerate() {
        let cam = kept_cameras[k].expect("shown frames were rendered");
        write_grid(
            &sbs.join(format!("frame_{f:05}.png")),
            &labels,
            &kept[k],
            &cam,
            opts.exposure,
            opts.zoom.max(1),
        )?;
    }
    let reference = opts.reference_spp.map(|spp| {
        let noise: Vec<ReferenceNoise> = references.iter().map(|r| r.noise).collect();
        ReferenceSummary::new(spp, reference_seed(settings.seed), &noise, &rows)
    });
    write_summaries(session, opts, settings, &rows, reference.as_ref())?;
    Ok(Comparison { rows, reference })
}

/// |left reprojected into the right view − right| on co-visible pixels
/// (same instance and primitive, depth within 1 %), 0 elsewhere: where the
/// two eyes disagree about the same surface point.
pub fn stereo_difference(f: &StereoFrame, cam: &StereoCamera) -> Vec<[f32; 4]> {
    use crate::metrics::{reproject, LinearImage};
    let (w, h) = (f.width as usize, f.height as usize);
    let views = cam.eyes();
    let (l, r) = (&f.eyes[0], &f.eyes[1]);
    let (Ok(li), Ok(ri)) = (
        LinearImage::from_rgba(&l.radiance, w, h),
        LinearImage::from_rgba(&r.radiance, w, h),
    ) else {
        return vec![[0.0; 4]; w * h];
    };
    match reproject(
        &li,
        &l.depth,
        &views[0],
        &r.depth,
        &views[1],
        0.01,
        Some((&l.first_hit, &r.first_hit)),
    ) {
        Ok((warped, cov)) => (0..w * h)
            .map(|i| {
                if !cov[i] {
                    return [0.0; 4];
                }
                let d = (0..3)
                    .map(|c| (warped.rgb[i][c] - ri.rgb[i][c]).abs())
                    .sum::<f32>()
                    / 3.0;
                [d, d, d, 1.0]
            })
            .collect(),
        Err(_) => vec![[0.0; 4]; w * h],
    }
}

/// One column per method: a label, left eye, right eye, zoomed centre crops,
/// the stereo difference (×4), and the methods' debug views where they have them.
fn write_grid(
    path: &Path,
    names: &[String],
    frames: &[StereoFrame],
    cam: &StereoCamera,
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
        let diff = tonemap::to_srgb8(&stereo_difference(f, cam), 4.0);
        blit(&mut img, gw, &diff, w, h, x0, row_y(4), None);
        for (k, dn) in debug_names.iter().enumerate() {
            if let Some((_, view)) = f.eyes[0].debug.iter().find(|(n, _)| n == dn) {
                let rgb: Vec<u8> = view
                    .iter()
                    .flat_map(|p| (0..3).map(move |c| (p[c].clamp(0.0, 1.0) * 255.0 + 0.5) as u8))
                    .collect();
                blit(&mut img, gw, &rgb, w, h, x0, row_y(5 + k as u32), None);
            }
        }
    }
    // Row captions in the first column.
    let captions: Vec<String> = ["left", "right", "left crop", "right crop", "stereo diff x4"]
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

fn write_summaries(
    session: &Session,
    opts: &CompareOptions,
    settings: &RenderSettings,
    rows: &[MethodRow],
    reference: Option<&ReferenceSummary>,
) -> Result<()> {
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
        for m in &metric_names {
            csv.push_str(
                &r.metrics
                    .get(m)
                    .map(|v| format!(",{v:.6e}"))
                    .unwrap_or_else(|| ",".into()),
            );
        }
        for p in &passes {
            csv.push_str(&format!(
                ",{:.4}",
                r.pass_mean_ms.get(p).copied().unwrap_or(0.0)
            ));
        }
        csv.push('\n');
    }
    let csv_path = opts.out.join("summary.csv");
    output::write_text(&csv_path, &csv)?;
    let caps = &session.ctx.caps;
    let json = serde_json::json!({
        "device": caps.name,
        "driver": format!("{} {}", caps.driver_name, caps.driver_info),
        "backend": session.backend,
        "scene": session.scene.source,
        "trace": opts.trace,
        "width": settings.width,
        "height": settings.height,
        "fps": opts.fps,
        "settings": settings,
        "reference": reference,
        "methods": rows,
    });
    output::write_json(&opts.out.join("summary.json"), &json)?;
    Ok(())
}

/// The short table printed at the end of a compare run.
pub fn summary_table(rows: &[MethodRow]) -> String {
    let mut s = format!(
        "{:<16} {:>9} {:>9} {:>12} {:>10} {:>9} {:>9} {:>10} {:>10}\n",
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
    let metric = |r: &MethodRow, k: &str| {
        r.metrics
            .get(k)
            .map(|v| format!("{v:.4}"))
            .unwrap_or_else(|| "-".into())
    };
    for r in rows {
        s.push_str(&format!(
            "{:<16} {:>9.2} {:>9.2} {:>12.0} {:>10.1} {:>9} {:>9} {:>10} {:>10}\n",
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
