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
//! expect = "< 1"              # optional: what the paper's claim means here
//! group = "cornell-synth-walk" # optional: which comparison (default: the first with both)
//! ```

use super::spec::Group;
use serde::{Deserialize, Serialize};
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
    pub expect: Option<String>,
    pub group: Option<String>,
}

/// The verdict of a claim whose metric its configuration's rows lack.
pub const NO_SUCH_FIGURE: &str = "no such figure";

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
    /// Whether `value` meets `expect` (absent without one).
    pub holds: Option<bool>,
    /// `reproduces`, `does not reproduce`, or `inconclusive` when the
    /// threshold is within two standard errors of `value`; `-` without `expect`.
    pub verdict: String,
}

/// Per-frame values of `metric` for configuration `label` of the comparison
/// in `dir` (frames.jsonl): a metric where a frame has it, the GPU time and
/// pass times over the frames after the first (as the summary's steady figures).
fn per_frame(dir: &Path, label: &str, metric: &str) -> Option<Vec<f64>> {
    let text = std::fs::read_to_string(dir.join(label).join("frames.jsonl")).ok()?;
    let frames: Vec<serde_json::Value> = text
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    let steady = || frames.iter().skip(1);
    let v: Vec<f64> = if metric == "steady_mean_gpu_ms" {
        steady().filter_map(|f| f["gpu_ms"].as_f64()).collect()
    } else if let Some(p) = metric.strip_prefix("pass:") {
        steady()
            .map(|f| {
                p.split('+')
                    .filter_map(|p| f["passes"][p.trim()].as_f64())
                    .sum()
            })
            .collect()
    } else {
        frames
            .iter()
            .filter_map(|f| f["metrics"][metric].as_f64())
            .collect()
    };
    (v.len() >= 2).then_some(v)
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
                let (value, what) = match &c.over {
                    Some(over) => match lookup(s, over, metric) {
                        Some(b) => (a / b, format!("{metric} {of} / {over}")),
                        None => continue,
                    },
                    None => (a, format!("{metric} of {of}")),
                };
                let device = s["device"].as_str().unwrap_or("?");
                let dir = out.join(g);
                let x = per_frame(&dir, of, metric);
                let stderr = match &c.over {
                    Some(over) => x
                        .zip(per_frame(&dir, over, metric))
                        .and_then(|(x, y)| stereocache::metrics::ratio_of_means(&x, &y)),
                    None => x.and_then(|x| stereocache::metrics::mean_stderr(&x)),
                }
                .map(|q| q.stderr)
                .filter(|se| se.is_finite());
                r.measured_in = Some(g.clone());
                r.value = Some(value);
                r.stderr = stderr;
                let expect = c.expect.as_deref().and_then(parse_expect);
                r.holds = expect.map(|(op, t)| match op {
                    "<" => value < t,
                    "<=" => value <= t,
                    ">" => value > t,
                    _ => value >= t,
                });
                let near = |t: f64| stderr.is_some_and(|se| (value - t).abs() < 2.0 * se);
                r.verdict = match (expect, r.holds) {
                    (Some((_, t)), Some(_)) if near(t) => "inconclusive".into(),
                    (_, Some(true)) => "reproduces".into(),
                    (_, Some(false)) => "does not reproduce".into(),
                    _ => "-".into(),
                };
                r.here = format!(
                    "{what} = {}{} ({g}, {device}, {} frames at {}x{})",
                    fmt(value),
                    stderr
                        .map(|se| format!(" ± {}", fmt(se)))
                        .unwrap_or_default(),
                    s["methods"][0]["frames"],
                    s["width"],
                    s["height"]
                );
                break;
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
        "# {title}\n\n± = standard error over frames (ratios: delta method over the paired frames); inconclusive = the expected bound lies within two standard errors.\n\n| claim | paper | here | expected | verdict |\n|---|---|---|---|---|\n"
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
