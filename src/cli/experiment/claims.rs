//! The paper's claims an experiment file states (`[[claim]]`) and what was
//! measured for each: printed after a run or merge, in `claims.md` and in
//! each comparison's report.
//!
//! ```toml
//! [[claim]]
//! text = "adaptive retrace traces far fewer rays than multi"
//! paper = "tracing 1.46 ms vs 7.15 ms (0.20x), RTX 3060, 1080p"
//! metric = "rays_per_frame"   # a summary.json row field, `pass:NAME[+NAME…]` (ms) or a metric
//! of = "adaptive"             # configuration label
//! over = "multi"              # optional: the measured figure is of / over
//! over-metric = "cpbd_reference" # optional: the denominator's metric (default `metric`;
//!                              # of the `over` configuration, else of `of` itself)
//! expect = "< 1"              # optional: what the paper's claim means here
//! group = "cornell-synth-walk" # optional: which comparison (default: every one with both)
//! ```
//!
//! **Verdicts.** In each comparison in scope (`group`, else every one
//! whose rows have the figure) the value meets `expect` or not; within a
//! 95 % interval of the bound (Student's t over the frames times the
//! standard error: 2.36 at 8 frames; 2 until session 50) it is
//! inconclusive, and so it is where
//! the figure has no standard error (no per-frame values) unless it is
//! deterministic ([`DETERMINISTIC`]). Over the comparisons: does not
//! reproduce if any does not, else inconclusive if any is, else
//! reproduces (a claim the paper makes of several scenes must hold in
//! each). Until session 46 only the first comparison was judged and a
//! missing standard error counted as none needed.

use super::spec::Group;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ClaimSpec {
    /// The claim in words.
    pub text: String,
    /// The paper's figure(s) behind it, with its device.
    pub paper: String,
    pub metric: Option<String>,
    pub of: Option<String>,
    pub over: Option<String>,
    #[serde(rename = "over-metric")]
    pub over_metric: Option<String>,
    pub expect: Option<String>,
    pub group: Option<String>,
}

/// The verdict of a claim whose metric its configuration's rows lack.
pub const NO_SUCH_FIGURE: &str = "no such figure";

/// Row figures with no sampling noise (counts and sizes), judged without a
/// standard error.
pub const DETERMINISTIC: &[&str] = &["rays_per_frame", "rays_total", "method_memory_bytes"];

/// The numeric fields of a summary row a claim can name (compare.rs
/// `MethodRow`).
const ROW_FIGURES: &[&str] = &[
    "frames",
    "mean_gpu_ms",
    "p95_gpu_ms",
    "steady_mean_gpu_ms",
    "steady_p95_gpu_ms",
    "rays_per_frame",
    "rays_total",
    "method_memory_bytes",
];

/// Whether a claim's `metric` or `over-metric` names a figure a summary row
/// can have.
fn is_figure_name(m: &str) -> bool {
    ROW_FIGURES.contains(&m)
        || stereocache::evaluate::METRIC_NAMES.contains(&m)
        || m.strip_prefix("pass:")
            .is_some_and(|p| !p.trim().is_empty())
}

/// What one comparison measured for a claim.
#[derive(Clone, Debug, Serialize)]
pub struct GroupMeasure {
    pub group: String,
    pub value: f64,
    pub stderr: Option<f64>,
    pub holds: Option<bool>,
    pub verdict: String,
    pub here: String,
}

/// `expect = "< 1"`: a comparison and a number.
fn parse_expect(s: &str) -> Option<(&str, f64)> {
    let s = s.trim();
    for op in ["<=", ">=", "<", ">"] {
        if let Some(rest) = s.strip_prefix(op) {
            // `nan` parses as a float but compares false with everything.
            return rest
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(|v| (op, v));
        }
    }
    None
}

impl ClaimSpec {
    /// Checks the labels and the expectation against the experiment's comparisons.
    pub fn check(&self, groups: &[Group]) -> Result<(), String> {
        let at = |m: String| format!("[[claim]] '{}': {m}", self.text);
        if let Some(e) = &self.expect {
            parse_expect(e).ok_or_else(|| {
                at(format!(
                    "key 'expect': '{e}' is not a comparison with a finite number like \"< 1\" or \">= 2.5\""
                ))
            })?;
        }
        if self.metric.is_some() != self.of.is_some() {
            return Err(at("keys 'metric' and 'of' go together".into()));
        }
        if self.over_metric.is_some() && self.metric.is_none() {
            return Err(at("key 'over-metric' needs 'metric' and 'of'".into()));
        }
        if self.over.is_some() && self.metric.is_none() {
            return Err(at("key 'over' needs 'metric' and 'of'".into()));
        }
        // Metric names are checked here, before anything renders (a typo
        // was found only after every comparison had rendered, and one in
        // 'over-metric' never).
        for (k, m) in [("metric", &self.metric), ("over-metric", &self.over_metric)] {
            if let Some(m) = m {
                if !is_figure_name(m) {
                    return Err(at(format!(
                        "key '{k}': no figure '{m}' (a summary row's {}, `pass:NAME[+NAME…]`, or a metric: {})",
                        ROW_FIGURES.join(", "),
                        stereocache::evaluate::METRIC_NAMES.join(", ")
                    )));
                }
            }
        }
        if let Some(g) = &self.group {
            if !groups.iter().any(|x| &x.label == g) {
                return Err(at(format!(
                    "key 'group': no comparison '{g}' (comparisons: {})",
                    groups
                        .iter()
                        .map(|g| g.label.clone())
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
        }
        for (k, l) in [("of", &self.of), ("over", &self.over)] {
            if let Some(l) = l {
                if !groups
                    .iter()
                    .any(|g| g.configs.iter().any(|c| &c.label == l))
                {
                    return Err(at(format!("key '{k}': no configuration '{l}'")));
                }
            }
        }
        Ok(())
    }
}

/// A claim with what was measured.
#[derive(Clone, Debug, Serialize)]
pub struct ClaimResult {
    #[serde(flatten)]
    pub spec: ClaimSpec,
    /// The comparison it was measured in.
    pub measured_in: Option<String>,
    pub value: Option<f64>,
    /// The standard error of `value` over frames (delta method over the
    /// paired frames for a ratio, [`stereocache::metrics::uncertainty`]),
    /// where frames.jsonl has the per-frame figures.
    pub stderr: Option<f64>,
    /// The measurement in words.
    pub here: String,
    /// Whether `value` meets `expect` in every comparison (absent without one).
    pub holds: Option<bool>,
    /// `reproduces`, `does not reproduce`, or `inconclusive` (module
    /// documentation); `-` without `expect`.
    pub verdict: String,
    /// Each comparison's measure (`measured_in`, `value` and `stderr` are
    /// the first's).
    pub groups: Vec<GroupMeasure>,
}

/// Per-frame values of `metric` for configuration `label` of the comparison
/// in `dir` (frames.jsonl), keyed by frame index (the record's `index`, else
/// its line): a metric where a frame has it (a series may skip frames:
/// `temporal` has no frame 0, stereo figures none where the mask is empty),
/// the GPU time and pass times over the frames after the first (as the
/// summary's steady figures).
fn per_frame(dir: &Path, label: &str, metric: &str) -> Option<BTreeMap<u64, f64>> {
    let text = std::fs::read_to_string(dir.join(label).join("frames.jsonl")).ok()?;
    let frames: Vec<(u64, serde_json::Value)> = text
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .enumerate()
        .map(|(k, f)| (f["index"].as_u64().unwrap_or(k as u64), f))
        .collect();
    let steady = || frames.iter().skip(1);
    let v: BTreeMap<u64, f64> = if metric == "steady_mean_gpu_ms" {
        steady()
            .filter_map(|(k, f)| Some((*k, f["gpu_ms"].as_f64()?)))
            .collect()
    } else if let Some(p) = metric.strip_prefix("pass:") {
        steady()
            .map(|(k, f)| {
                let ms = p
                    .split('+')
                    .filter_map(|p| f["passes"][p.trim()].as_f64())
                    .sum();
                (*k, ms)
            })
            .collect()
    } else {
        frames
            .iter()
            .filter_map(|(k, f)| Some((*k, f["metrics"][metric].as_f64()?)))
            .collect()
    };
    (v.len() >= 2).then_some(v)
}

/// The ratio of the means of two per-frame series over the frames both
/// have (paired by frame index, not by position: two series that skip
/// different frames used to be paired out of step) and its standard error;
/// `None` below two shared frames.
fn paired_ratio(
    x: &BTreeMap<u64, f64>,
    y: &BTreeMap<u64, f64>,
) -> Option<stereocache::metrics::MeanStderr> {
    let (xs, ys): (Vec<f64>, Vec<f64>) =
        x.iter().filter_map(|(k, a)| Some((*a, *y.get(k)?))).unzip();
    if xs.len() < 2 {
        return None;
    }
    stereocache::metrics::ratio_of_means(&xs, &ys)
}

/// Field `metric` of the row labelled `label` in `summary`.
fn lookup(summary: &serde_json::Value, label: &str, metric: &str) -> Option<f64> {
    let row = summary["methods"]
        .as_array()?
        .iter()
        .find(|r| r["method"].as_str() == Some(label))?;
    if let Some(p) = metric.strip_prefix("pass:") {
        // `pass:a+b`: the sum of the passes the row has (None: none of them).
        let ms: Vec<f64> = p
            .split('+')
            .filter_map(|p| row["pass_mean_ms"][p.trim()].as_f64())
            .collect();
        return (!ms.is_empty()).then(|| ms.iter().sum());
    }
    row[metric]
        .as_f64()
        .or_else(|| row["metrics"][metric].as_f64())
}

/// Each claim measured from the comparisons written under `out` (`groups`
/// their labels, in order).
pub fn evaluate(claims: &[ClaimSpec], groups: &[String], out: &Path) -> Vec<ClaimResult> {
    let summaries: Vec<(String, serde_json::Value)> = groups
        .iter()
        .filter_map(|g| {
            let text = std::fs::read_to_string(out.join(g).join("summary.json")).ok()?;
            Some((g.clone(), serde_json::from_str(&text).ok()?))
        })
        .collect();
    claims
        .iter()
        .map(|c| {
            let mut r = ClaimResult {
                spec: c.clone(),
                measured_in: None,
                value: None,
                stderr: None,
                here: "not measured here (see the comparison's tables and images)".into(),
                holds: None,
                verdict: "-".into(),
                groups: Vec::new(),
            };
            let (Some(metric), Some(of)) = (&c.metric, &c.of) else {
                return r;
            };
            // A metric that no comparison's row of `of` has says so, with
            // the figures the row does have (a mistyped name, or one this
            // run did not produce, e.g. no reference), instead of "not
            // measured here".
            let rows_of = |label: &str| -> Vec<&serde_json::Value> {
                summaries
                    .iter()
                    .filter(|(g, _)| c.group.as_ref().is_none_or(|x| x == g))
                    .filter_map(|(_, s)| {
                        s["methods"]
                            .as_array()?
                            .iter()
                            .find(|r| r["method"].as_str() == Some(label))
                    })
                    .collect()
            };
            let rows = rows_of(of);
            let in_scope = |g: &String| c.group.as_ref().is_none_or(|x| x == g);
            if !rows.is_empty()
                && summaries
                    .iter()
                    .filter(|(g, _)| in_scope(g))
                    .all(|(_, s)| lookup(s, of, metric).is_none())
            {
                // Present but `null`: the run measured it and it was not
                // finite (e.g. a PSNR of +∞ where a frame equals the
                // reference), not a name this row lacks.
                let null = |r: &&serde_json::Value| {
                    r.get(metric.as_str()).is_some_and(|v| v.is_null())
                        || r["metrics"].get(metric.as_str()).is_some_and(|v| v.is_null())
                };
                if rows.iter().any(null) {
                    r.here = format!(
                        "metric '{metric}' of configuration '{of}' is not finite in this run (null in summary.json): it cannot be judged"
                    );
                    r.verdict = "inconclusive".into();
                    return r;
                }
                let mut known: Vec<String> = rows[0]
                    .as_object()
                    .map(|o| {
                        o.iter()
                            .filter(|(_, v)| v.is_number())
                            .map(|(k, _)| k.clone())
                            .collect()
                    })
                    .unwrap_or_default();
                if let Some(m) = rows[0]["metrics"].as_object() {
                    known.extend(m.keys().cloned());
                }
                known.push("pass:NAME[+NAME…]".into());
                r.here = format!(
                    "metric '{metric}' is not a figure of configuration '{of}' in this run (its figures: {})",
                    known.join(", ")
                );
                r.verdict = NO_SUCH_FIGURE.into();
                return r;
            }
            for (g, s) in &summaries {
                if c.group.as_ref().is_some_and(|x| x != g) {
                    continue;
                }
                let Some(a) = lookup(s, of, metric) else {
                    continue;
                };
                // The denominator: `over`'s (or `of`'s own) `over-metric`
                // (or `metric`).
                let den = match (&c.over, &c.over_metric) {
                    (None, None) => None,
                    (o, m) => Some((o.as_deref().unwrap_or(of), m.as_deref().unwrap_or(metric))),
                };
                let (value, what) = match den {
                    Some((over, m)) => match lookup(s, over, m) {
                        Some(b) if m == metric => (a / b, format!("{metric} {of} / {over}")),
                        Some(b) => (a / b, format!("{metric} of {of} / {m} of {over}")),
                        None => continue,
                    },
                    None => (a, format!("{metric} of {of}")),
                };
                let device = s["device"].as_str().unwrap_or("?");
                let dir = out.join(g);
                let x = per_frame(&dir, of, metric);
                let stderr = match den {
                    Some((over, m)) => x
                        .zip(per_frame(&dir, over, m))
                        .and_then(|(x, y)| paired_ratio(&x, &y)),
                    None => x.and_then(|x| {
                        stereocache::metrics::mean_stderr(&x.into_values().collect::<Vec<_>>())
                    }),
                };
                // A ratio with per-frame values is the ratio of the means over
                // the frames both series have (the summaries' means may be
                // over different frames).
                let value = match (den, stderr) {
                    (Some(_), Some(q)) => q.mean,
                    _ => value,
                };
                let frames = stderr.map(|q| q.n);
                let stderr = stderr.map(|q| q.stderr).filter(|se| se.is_finite());
                let expect = c.expect.as_deref().and_then(parse_expect);
                let holds = expect.map(|(op, t)| match op {
                    "<" => value < t,
                    "<=" => value <= t,
                    ">" => value > t,
                    _ => value >= t,
                });
                // Deterministic only if the denominator is too (a count over a
                // time is as noisy as the time).
                let deterministic = DETERMINISTIC.contains(&metric.as_str())
                    && den.is_none_or(|(_, m)| DETERMINISTIC.contains(&m));
                // Within a two-sided 95 % interval: Student's t over the
                // frames (2·se until session 50; 2.36·se at 8 frames).
                let half_width = |se: f64| {
                    let df = frames.map_or(0, |n| n.saturating_sub(1));
                    stereocache::metrics::t_quantile_975(df) * se
                };
                let near = |t: f64| match stderr {
                    Some(se) => (value - t).abs() < half_width(se),
                    None => !deterministic,
                };
                let verdict: String = match (expect, holds) {
                    // 0/0 and the like: nothing to judge.
                    (Some(_), Some(_)) if !value.is_finite() => "inconclusive".into(),
                    (Some((_, t)), Some(_)) if near(t) => "inconclusive".into(),
                    (_, Some(true)) => "reproduces".into(),
                    (_, Some(false)) => "does not reproduce".into(),
                    _ => "-".into(),
                };
                let spread = match (stderr, deterministic) {
                    (Some(se), _) => format!(" ± {}", fmt(se)),
                    (None, true) => String::new(),
                    (None, false) => " (no per-frame values: no standard error)".into(),
                };
                let here = format!(
                    "{what} = {}{spread} ({g}, {device}, {} at {}x{})",
                    fmt(value),
                    match frames {
                        Some(n) => format!("{n} frames"),
                        None => format!("{} frames rendered", s["methods"][0]["frames"]),
                    },
                    s["width"],
                    s["height"]
                );
                r.groups.push(GroupMeasure {
                    group: g.clone(),
                    value,
                    stderr,
                    holds,
                    verdict,
                    here,
                });
            }
            if let Some(first) = r.groups.first() {
                r.measured_in = Some(first.group.clone());
                r.value = Some(first.value);
                r.stderr = first.stderr;
                r.holds = first.holds.map(|_| r.groups.iter().all(|m| m.holds == Some(true)));
                let any = |v: &str| r.groups.iter().any(|m| m.verdict == v);
                r.verdict = if first.verdict == "-" {
                    "-".into()
                } else if any("does not reproduce") {
                    "does not reproduce".into()
                } else if any("inconclusive") {
                    "inconclusive".into()
                } else {
                    "reproduces".into()
                };
                r.here = r
                    .groups
                    .iter()
                    .map(|m| match r.groups.len() {
                        1 => m.here.clone(),
                        _ => format!("{} [{}]", m.here, m.verdict),
                    })
                    .collect::<Vec<_>>()
                    .join("; ");
            }
            r
        })
        .collect()
}

fn fmt(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e5) {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}

/// The claims as printed after a run.
pub fn text(results: &[ClaimResult]) -> String {
    let mut s = String::new();
    for r in results {
        s.push_str(&format!(
            "claim: {}\n  paper: {}\n  here:  {}{}\n",
            r.spec.text,
            r.spec.paper,
            r.here,
            match (&r.spec.expect, r.holds) {
                (Some(e), Some(_)) => format!(" (expected {e}: {})", r.verdict),
                _ => String::new(),
            }
        ));
    }
    s
}

/// claims.md: one row per claim.
pub fn markdown(title: &str, results: &[ClaimResult]) -> String {
    let mut s = format!(
        "# {title}\n\n± = standard error over frames (ratios: delta method over the paired frames), widened by the frames' lag-1 autocorrelation (metrics::uncertainty); inconclusive = the expected bound lies within a 95 % interval (Student's t over the frames × the standard error; the lag-1 autocorrelation bias-corrected), or the figure has no standard error. A claim with several comparisons must hold in each (each one's verdict in brackets). Each configuration is one run: drift of the machine between runs is not in the ± (timing claims especially; docs/REPRODUCTION.md).\n\n| claim | paper | here | expected | verdict |\n|---|---|---|---|---|\n"
    );
    let cell = |t: &str| t.replace('|', "\\|");
    for r in results {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} |\n",
            cell(&r.spec.text),
            cell(&r.spec.paper),
            cell(&r.here),
            cell(r.spec.expect.as_deref().unwrap_or("-")),
            r.verdict
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A comparison `g` under `out` whose rows `a` and `b` have `metric`
    /// means `ma`, `mb` (summary.json) and, with `frames`, per-frame values
    /// (frames.jsonl: `ma`/`mb` plus ±`spread` alternating, so the means
    /// hold); `rays_per_frame` 100 and 200, `cpbd_reference` of `a` 0.5.
    fn comparison(out: &Path, g: &str, (ma, mb): (f64, f64), frames: bool, spread: f64) {
        let d = out.join(g);
        let row = |l: &str, m: f64, rays: f64| {
            serde_json::json!({ "method": l, "frames": 6, "rays_per_frame": rays,
                "metrics": { "rse": m, "cpbd": m, "cpbd_reference": 0.5 } })
        };
        let s = serde_json::json!({ "device": "test", "width": 8, "height": 6,
            "methods": [row("a", ma, 100.0), row("b", mb, 200.0)] });
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("summary.json"), s.to_string()).unwrap();
        if frames {
            for (l, m) in [("a", ma), ("b", mb)] {
                std::fs::create_dir_all(d.join(l)).unwrap();
                let lines: Vec<String> = (0..6)
                    .map(|t| {
                        let v = m + if t % 2 == 0 { spread } else { -spread };
                        serde_json::json!({ "metrics": { "rse": v, "cpbd": v, "cpbd_reference": 0.5 } })
                            .to_string()
                    })
                    .collect();
                std::fs::write(d.join(l).join("frames.jsonl"), lines.join("\n")).unwrap();
            }
        }
    }

    fn claim(metric: &str, over: Option<&str>, expect: &str) -> ClaimSpec {
        ClaimSpec {
            text: "t".into(),
            paper: "p".into(),
            metric: Some(metric.into()),
            of: Some("a".into()),
            over: over.map(String::from),
            over_metric: None,
            expect: Some(expect.into()),
            group: None,
        }
    }

    fn dir(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("claims-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    /// A figure without per-frame values has no standard error: the
    /// verdict is inconclusive, however far from the bound, unless the
    /// figure is a count (deterministic).
    #[test]
    fn no_standard_error_is_inconclusive_unless_deterministic() {
        let out = dir("nose");
        comparison(&out, "g", (0.5, 1.0), false, 0.0);
        let g = ["g".to_string()];
        let r = evaluate(&[claim("rse", Some("b"), "< 1")], &g, &out);
        assert_eq!((r[0].value, r[0].stderr), (Some(0.5), None));
        assert_eq!(r[0].verdict, "inconclusive", "{}", r[0].here);
        assert!(r[0].here.contains("no standard error"), "{}", r[0].here);
        let r = evaluate(&[claim("rays_per_frame", Some("b"), "< 1")], &g, &out);
        assert_eq!(
            (r[0].value, r[0].verdict.as_str()),
            (Some(0.5), "reproduces")
        );
        // With per-frame values far from the bound: decided.
        comparison(&out, "g", (0.5, 1.0), true, 0.01);
        let r = evaluate(&[claim("rse", Some("b"), "< 1")], &g, &out);
        assert!(r[0].stderr.is_some_and(|se| se < 0.05), "{:?}", r[0].stderr);
        assert_eq!(r[0].verdict, "reproduces");
        let _ = std::fs::remove_dir_all(&out);
    }

    /// Every comparison in scope is judged, and the claim must hold in
    /// each: a second scene where it fails makes it fail; with `group` only
    /// that comparison counts.
    #[test]
    fn a_claim_must_hold_in_every_comparison() {
        let out = dir("groups");
        comparison(&out, "g1", (0.5, 1.0), true, 0.01);
        comparison(&out, "g2", (1.5, 1.0), true, 0.01);
        let g = ["g1".to_string(), "g2".to_string()];
        let r = evaluate(&[claim("rse", Some("b"), "< 1")], &g, &out);
        let verdicts: Vec<&str> = r[0].groups.iter().map(|m| m.verdict.as_str()).collect();
        assert_eq!(verdicts, ["reproduces", "does not reproduce"]);
        assert_eq!(r[0].verdict, "does not reproduce");
        assert_eq!(r[0].holds, Some(false));
        assert!(
            r[0].here.contains("g1") && r[0].here.contains("g2"),
            "{}",
            r[0].here
        );
        let mut one = claim("rse", Some("b"), "< 1");
        one.group = Some("g1".into());
        let r = evaluate(&[one], &g, &out);
        assert_eq!(
            (r[0].groups.len(), r[0].verdict.as_str()),
            (1, "reproduces")
        );
        // One inconclusive comparison (no per-frame values), the other
        // reproducing: inconclusive.
        std::fs::remove_dir_all(out.join("g2")).unwrap();
        comparison(&out, "g2", (0.99, 1.0), false, 0.0);
        let r = evaluate(&[claim("rse", Some("b"), "< 1")], &g, &out);
        assert_eq!(r[0].verdict, "inconclusive");
        let _ = std::fs::remove_dir_all(&out);
    }

    /// A ratio's two series pair by frame index, not by position: x = 2y on
    /// every frame, x on frames {0, 1, 2, 4, 5}, y on {1, 2, 3, 4, 5}. Over
    /// the shared frames the ratio is exactly 2 with no spread; paired by
    /// position it came out 1.7 ± 0.27 (and the value was the ratio of the
    /// two summaries' means over different frames).
    #[test]
    fn ratio_series_pair_by_frame_index() {
        let out = dir("pairing");
        let d = out.join("g");
        let y = |k: u64| (k + 1) as f64;
        let row = |l: &str, m: f64| serde_json::json!({ "method": l, "frames": 6, "metrics": { "rse": m } });
        let (xs, ys): (Vec<u64>, Vec<u64>) = (vec![0, 1, 2, 4, 5], vec![1, 2, 3, 4, 5]);
        let mean = |ks: &[u64], f: &dyn Fn(u64) -> f64| {
            ks.iter().map(|&k| f(k)).sum::<f64>() / ks.len() as f64
        };
        let s = serde_json::json!({ "device": "test", "width": 8, "height": 6,
            "methods": [row("a", mean(&xs, &|k| 2.0 * y(k))), row("b", mean(&ys, &y))] });
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("summary.json"), s.to_string()).unwrap();
        for (l, ks, scale) in [("a", &xs, 2.0), ("b", &ys, 1.0)] {
            std::fs::create_dir_all(d.join(l)).unwrap();
            let lines: Vec<String> = (0..6u64)
                .map(|k| {
                    let m = if ks.contains(&k) {
                        serde_json::json!({ "rse": scale * y(k) })
                    } else {
                        serde_json::json!({})
                    };
                    serde_json::json!({ "index": k, "metrics": m }).to_string()
                })
                .collect();
            std::fs::write(d.join(l).join("frames.jsonl"), lines.join("\n")).unwrap();
        }
        let r = evaluate(
            &[claim("rse", Some("b"), "< 1.9")],
            &["g".to_string()],
            &out,
        );
        assert!(
            (r[0].value.unwrap() - 2.0).abs() < 1e-12,
            "{:?}",
            r[0].value
        );
        assert!(r[0].stderr.is_some_and(|se| se < 1e-9), "{:?}", r[0].stderr);
        assert_eq!(r[0].verdict, "does not reproduce", "{}", r[0].here);
        let _ = std::fs::remove_dir_all(&out);
    }

    /// A metric the run wrote as `null` (not finite) cannot be judged: it
    /// is inconclusive and says so (it said the row lacked the metric while
    /// listing it among the row's figures); a count over a noisy time is not
    /// deterministic.
    #[test]
    fn null_metrics_and_noisy_denominators_are_inconclusive() {
        let out = dir("null");
        let d = out.join("g");
        std::fs::create_dir_all(&d).unwrap();
        let s = serde_json::json!({ "device": "test", "width": 8, "height": 6, "methods": [
            { "method": "a", "frames": 6, "rays_per_frame": 99.0, "steady_mean_gpu_ms": 100.0, "metrics": { "psnr": null } },
            { "method": "b", "frames": 6, "rays_per_frame": 100.0, "steady_mean_gpu_ms": 100.0, "metrics": { "psnr": 30.0 } }] });
        std::fs::write(d.join("summary.json"), s.to_string()).unwrap();
        let g = ["g".to_string()];
        let r = evaluate(&[claim("psnr", Some("b"), "> 1")], &g, &out);
        assert_eq!(r[0].verdict, "inconclusive", "{}", r[0].here);
        assert!(r[0].here.contains("not finite"), "{}", r[0].here);
        // Counts over counts stay deterministic; over a time they do not.
        let r = evaluate(&[claim("rays_per_frame", Some("b"), "< 1")], &g, &out);
        assert_eq!(r[0].verdict, "reproduces", "{}", r[0].here);
        let mut c = claim("rays_per_frame", None, "< 1");
        c.over_metric = Some("steady_mean_gpu_ms".into());
        let r = evaluate(&[c], &g, &out);
        assert_eq!(r[0].verdict, "inconclusive", "{}", r[0].here);
        let _ = std::fs::remove_dir_all(&out);
    }

    /// `over-metric`: a row's figure over another figure of the same row
    /// (CPBD over the reference's), paired per frame.
    #[test]
    fn over_metric_divides_by_another_figure() {
        let out = dir("overmetric");
        comparison(&out, "g", (0.45, 1.0), true, 0.01);
        let mut c = claim("cpbd", None, ">= 0.8");
        c.over_metric = Some("cpbd_reference".into());
        let r = evaluate(&[c], &["g".to_string()], &out);
        assert!(
            (r[0].value.unwrap() - 0.9).abs() < 1e-12,
            "{:?}",
            r[0].value
        );
        assert!(
            r[0].here
                .starts_with("cpbd of a / cpbd_reference of a = 0.9"),
            "{}",
            r[0].here
        );
        assert_eq!(r[0].verdict, "reproduces");
        let mut bad = claim("cpbd", None, ">= 0.8");
        (bad.metric, bad.of, bad.over_metric) = (None, None, Some("x".into()));
        assert!(bad.check(&[]).unwrap_err().contains("'over-metric' needs"));
        let _ = std::fs::remove_dir_all(&out);
    }
}
