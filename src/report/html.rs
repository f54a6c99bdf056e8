//! The report page.

use super::data::ReportData;
use super::plots;
use crate::error::Result;
use base64::Engine;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn fmt(v: Option<f64>) -> String {
    match v {
        Some(v) if v.is_finite() => {
            if v.abs() >= 100.0 {
                format!("{v:.1}")
            } else {
                format!("{v:.4}")
            }
        }
        _ => "–".into(),
    }
}

/// Metrics shown in the table, with their meaning.
const METRICS: &[(&str, &str)] = &[
    ("rse", "relative squared error (ε = 0.01), lower is better"),
    ("flip", "HDR-FLIP, lower is better"),
    ("ssim", "SSIM on display luma, higher is better"),
    ("cpbd", "CPBD sharpness (reference: cpbd_reference)"),
    (
        "temporal_excess",
        "temporal instability minus the reference's",
    ),
    (
        "stereo_excess",
        "stereo discrepancy minus the reference pair's",
    ),
    ("stereo_p95", "95th percentile stereo discrepancy"),
];

/// The error figures' ratios to the baseline with their standard errors
/// (empty when the summary has none).
fn ratios(d: &ReportData) -> String {
    let keys = crate::compare::RATIO_METRICS;
    if !d.methods.iter().any(|m| m.ratio(keys[0]).is_some()) {
        return String::new();
    }
    let base = d.summary["baseline"].as_str().unwrap_or("the baseline");
    let mut h = format!(
        "<table id=\"ratios\"><caption>ratios to {} (mean over frames over the baseline's; ± delta-method standard error over the paired frames)</caption><tr><th>method</th>",
        esc(base)
    );
    for k in keys {
        h.push_str(&format!("<th>{k} / {}</th>", esc(base)));
    }
    h.push_str("</tr>\n");
    for m in &d.methods {
        h.push_str(&format!("<tr><td>{}</td>", esc(&m.name)));
        for k in keys {
            let v = match m.ratio(k) {
                Some((r, Some(se))) => format!("{} ± {}", fmt(Some(r)), fmt(Some(se))),
                Some((r, None)) => fmt(Some(r)),
                None => "–".into(),
            };
            h.push_str(&format!("<td>{v}</td>"));
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
    h
}

pub fn page(d: &ReportData) -> Result<String> {
    let s = &d.summary;
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>stereocache report</title>\n<style>body{font-family:sans-serif;margin:2em;max-width:1100px}table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:4px 8px;text-align:right}th{background:#eee}td:first-child{text-align:left}img{image-rendering:pixelated;max-width:100%}figure{margin:1em 0}.note{color:#555;font-size:90%}.se{color:#666;font-size:85%}</style></head><body>\n");
    h.push_str("<h1>stereocache comparison</h1>\n<p>");
    for (k, label) in [
        ("scene", "scene"),
        ("trace", "trace"),
        ("device", "device"),
        ("driver", "driver"),
        ("backend", "ray backend"),
    ] {
        let v = s[k]
            .as_str()
            .map(str::to_string)
            .unwrap_or_else(|| s[k].to_string());
        h.push_str(&format!("<b>{label}</b>: {} &nbsp; ", esc(&v)));
    }
    h.push_str(&format!(
        "<b>size</b>: {}×{} per eye &nbsp; <b>fps</b>: {}</p>\n",
        s["width"], s["height"], s["fps"]
    ));

    h.push_str("<h2>Summary</h2>\n<table id=\"summary\"><tr><th>method</th><th>frames</th><th>mean GPU ms*</th><th>p95 GPU ms*</th><th>rays / frame</th><th>memory MiB</th>");
    for (m, _) in METRICS {
        h.push_str(&format!("<th>{m}</th><th class=\"se\">±</th>"));
    }
    h.push_str("</tr>\n");
    for m in &d.methods {
        let r = &m.row;
        h.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
            esc(&m.name),
            r["frames"],
            fmt(r["steady_mean_gpu_ms"].as_f64()),
            fmt(r["steady_p95_gpu_ms"].as_f64()),
            fmt(r["rays_per_frame"].as_f64()),
            fmt(r["method_memory_bytes"]
                .as_f64()
                .map(|b| b / (1u64 << 20) as f64))
        ));
        for (k, _) in METRICS {
            // The value, then its standard error over frames in its own column.
            h.push_str(&format!(
                "<td>{}</td><td class=\"se\">{}</td>",
                fmt(m.metric(k)),
                fmt(m.metric_stderr(k))
            ));
        }
        h.push_str("</tr>\n");
    }
    let reference = &s["reference"];
    if let Some(rse) = reference["rse"].as_f64() {
        // The reference's own estimated error, in the RSE column.
        h.push_str(&format!(
            "<tr id=\"reference-row\"><td>reference ({} spp, estimated)</td><td>{}</td><td>–</td><td>–</td><td>–</td><td>–</td>",
            reference["spp"], reference["frames"]
        ));
        for (k, _) in METRICS {
            let (v, se) = if *k == "rse" {
                (fmt(Some(rse)), fmt(reference["rse_stderr"].as_f64()))
            } else {
                ("–".into(), "–".into())
            };
            h.push_str(&format!("<td>{v}</td><td class=\"se\">{se}</td>"));
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
    if let Some(rse) = reference["rse"].as_f64() {
        h.push_str(&format!(
            "<p id=\"reference-noise\">The reference: {} spp, rendered as two independent halves of {} spp whose difference estimates its own error: RSE {} ± {}, MSE {} against the converged image{}. Every method's RSE contains this much of the reference's noise. HDR-FLIP of one half against the other: {} (what FLIP scores the reference's noise alone at, at half its samples).</p>\n",
            reference["spp"],
            reference["half_spp"],
            fmt(Some(rse)),
            reference["rse_stderr"].as_f64().map(|v| format!("{v:.1e}")).unwrap_or_else(|| "–".into()),
            reference["mse"].as_f64().map(|v| format!("{v:.3e}")).unwrap_or_else(|| "–".into()),
            match (reference["best_method"].as_str(), reference["ratio_to_best"].as_f64()) {
                (Some(m), Some(x)) => format!(", {x:.3}× the best method's RSE ({})", esc(m)),
                _ => String::new(),
            },
            fmt(reference["flip_halves"].as_f64()),
        ));
    }
    if let Some(w) = reference["warning"].as_str() {
        h.push_str(&format!(
            "<p class=\"warning\" id=\"reference-warning\">warning: {}</p>\n",
            esc(w)
        ));
    }
    h.push_str(&ratios(d));
    if let Some(ppd) = s["flip"]["ppd"].as_f64() {
        h.push_str(&format!(
            "<p id=\"fair-metrics\">FLIP at {ppd:.3} pixels per degree ({}). Temporal and stereo metrics: one mask per frame for every method, from the {}: co-visible fraction temporal {}, stereo {}. ± = standard error over frames (frames taken as independent).</p>\n",
            esc(s["flip"]["source"].as_str().unwrap_or("")),
            esc(s["masks"]["source"].as_str().unwrap_or("reference geometry")),
            fmt(s["masks"]["temporal_covisible"].as_f64()),
            fmt(s["masks"]["stereo_covisible"].as_f64()),
        ));
    }
    h.push_str("<p class=\"note\">");
    for (k, v) in METRICS {
        h.push_str(&format!("<b>{k}</b>: {v}. "));
    }
    h.push_str("<b>±</b>: standard error of the mean over frames (frames taken as independent; temporally accumulating methods' frames are correlated, so it understates run-to-run variation); the reference row's is that of its noise estimate. ");
    h.push_str("Times are GPU timestamps on the device named above; * = frames after the first (frame 0 carries one-time driver costs such as pipeline compilation).</p>\n");

    let has_metrics = d.methods.iter().any(|m| m.metric("rse").is_some());
    h.push_str("<h2>Per frame</h2>\n");
    if has_metrics {
        h.push_str(&format!(
            "<figure>{}</figure>\n",
            plots::per_frame(&d.methods, "Relative squared error per frame", "RSE", |f| f
                .metrics
                .get("rse")
                .copied())
        ));
    }
    h.push_str(&format!(
        "<figure>{}</figure>\n",
        plots::per_frame(&d.methods, "GPU time per frame", "ms", |f| Some(f.gpu_ms))
    ));
    h.push_str("<h2>Where the time goes</h2>\n");
    h.push_str(&format!(
        "<figure>{}</figure>\n",
        plots::pass_breakdown(&d.methods)
    ));
    if has_metrics {
        h.push_str("<h2>Error against time</h2>\n");
        h.push_str(&format!(
            "<figure>{}</figure>\n",
            plots::pareto(&d.methods, "rse")
        ));
        h.push_str(&format!(
            "<figure>{}</figure>\n",
            plots::pareto(&d.methods, "flip")
        ));
    }
    if !d.grids.is_empty() {
        h.push_str("<h2>Side by side</h2>\n<p class=\"note\">Columns: methods. Rows: left eye, right eye, centre crops of each (nearest-neighbour zoom).</p>\n");
        for (name, bytes) in &d.grids {
            let b64 = base64::engine::general_purpose::STANDARD.encode(bytes);
            // PNG width from the IHDR chunk; small grids are shown enlarged (pixelated).
            let w = bytes
                .get(16..20)
                .map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
                .unwrap_or(0);
            let shown = if w > 0 && w < 500 {
                w * (900 / w).max(1)
            } else {
                w
            };
            h.push_str(&format!(
                "<figure><img alt=\"{}\" width=\"{shown}\" src=\"data:image/png;base64,{b64}\"><figcaption>{}</figcaption></figure>\n",
                esc(name),
                esc(name)
            ));
        }
    }
    h.push_str("</body></html>\n");
    Ok(h)
}
