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
            } else if v != 0.0 && v.abs() < 1e-3 {
                // Two significant digits: a standard error of 2.3e-5 read
                // "0.0000" (exactly known) until session 50.
                format!("{v:.1e}")
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
    (
        "stereo_p95",
        "each frame's 95th percentile of the stereo discrepancy, mean over frames",
    ),
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

/// The report's sections by name, in page order: what an experiment's
/// `figures` may list (the page draws them all otherwise).
pub const SECTIONS: &[&str] = &[
    "summary",
    "ratios",
    "per-frame",
    "time-breakdown",
    "error-vs-time",
    "side-by-side",
    "error-maps",
    "viewer",
];

/// The experiment's title, what is not available yet, and each paper claim
/// beside what was measured (an experiment's comparison only).
fn experiment(d: &ReportData) -> String {
    let Some(e) = &d.experiment else {
        return String::new();
    };
    let s = |v: &serde_json::Value| esc(v.as_str().unwrap_or(""));
    let mut h = format!(
        "<h2 id=\"experiment\">Experiment {}: {}</h2>\n<p>{} &nbsp; <b>scale</b>: {}</p>\n",
        s(&e["name"]),
        s(&e["title"]),
        s(&e["paper"]),
        s(&e["scale"])
    );
    for m in e["missing"].as_array().into_iter().flatten() {
        h.push_str(&format!(
            "<p class=\"note\">Not yet available (run without it): {}</p>\n",
            s(m)
        ));
    }
    let claims = e["claims"].as_array().cloned().unwrap_or_default();
    if !claims.is_empty() {
        h.push_str("<table id=\"claims\"><tr><th>the paper's claim</th><th>paper</th><th>here</th><th>expected</th><th>verdict</th></tr>\n");
        for c in &claims {
            let verdict = esc(c["verdict"].as_str().unwrap_or("–"));
            h.push_str(&format!(
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{verdict}</td></tr>\n",
                s(&c["text"]),
                s(&c["paper"]),
                s(&c["here"]),
                esc(c["expect"].as_str().unwrap_or("–")),
            ));
        }
        h.push_str("</table>\n");
    }
    h
}

pub fn page(d: &ReportData) -> Result<String> {
    let s = &d.summary;
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>stereocache report</title>\n<style>body{font-family:sans-serif;margin:2em;max-width:1100px}table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:4px 8px;text-align:right}th{background:#eee}td:first-child{text-align:left}img{image-rendering:pixelated;max-width:100%}figure{margin:1em 0}table.imgs td,table.imgs th{text-align:center;vertical-align:top}table.imgs img{display:block}#v-sources button.on{background:#333;color:#fff}#v-wrap{overflow:auto;max-width:1060px;max-height:720px;border:1px solid #999;background:#222}#v-canvas{image-rendering:pixelated;display:block}.note{color:#555;font-size:90%}.se{color:#666;font-size:85%}</style></head><body>\n");
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
    h.push_str(&experiment(d));

    // Each section is drawn, then dropped again when an experiment does not ask for it.
    let mut mark = h.len();
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
    let keep_summary = d.draws("summary");
    let summary_part = h.split_off(mark);
    let ratios_part = ratios(d);
    if keep_summary {
        h.push_str(&summary_part);
    }
    if d.draws("ratios") {
        h.push_str(&ratios_part);
    }
    mark = h.len();
    if let Some(ppd) = s["flip"]["ppd"].as_f64() {
        h.push_str(&format!(
            "<p id=\"fair-metrics\">FLIP at {ppd:.3} pixels per degree ({}). Temporal and stereo metrics: one mask per frame for every method, from the {}: co-visible fraction temporal {}, stereo {}{}. ± = standard error over frames, widened by their lag-1 autocorrelation.</p>\n",
            esc(s["flip"]["source"].as_str().unwrap_or("")),
            esc(s["masks"]["source"].as_str().unwrap_or("reference geometry")),
            fmt(s["masks"]["temporal_covisible"].as_f64()),
            fmt(s["masks"]["stereo_covisible"].as_f64()),
            match (
                s["masks"]["temporal_frames"].as_u64(),
                s["masks"]["stereo_frames"].as_u64()
            ) {
                (Some(t), Some(st)) => format!(
                    "; scored on {t} and {st} frames (a frame with no co-visible pixel has no value)"
                ),
                _ => String::new(),
            },
        ));
    }
    h.push_str("<p class=\"note\">");
    for (k, v) in METRICS {
        h.push_str(&format!("<b>{k}</b>: {v}. "));
    }
    h.push_str("<b>±</b>: standard error of the mean over frames, widened by the frames' lag-1 autocorrelation (accumulating methods' frames are correlated; drift between runs is not in it); the reference row's is that of its noise estimate. ");
    h.push_str("Times are GPU timestamps on the device named above; * = frames after the first (frame 0 carries one-time driver costs such as pipeline compilation).</p>\n");

    let has_metrics = d.methods.iter().any(|m| m.metric("rse").is_some());
    if !keep_summary {
        h.truncate(mark);
    }
    let section = |h: &mut String, name: &str, mark: usize| {
        if !d.draws(name) {
            h.truncate(mark);
        }
    };
    mark = h.len();
    h.push_str("<h2>Per frame</h2>\n");
    if has_metrics {
        h.push_str(&format!(
            "<figure>{}</figure>\n",
            plots::per_frame(
                &d.methods,
                "Relative squared error per frame",
                "RSE",
                0,
                |f| f.metrics.get("rse").copied()
            )
        ));
    }
    h.push_str(&time_plot(d));
    section(&mut h, "per-frame", mark);
    mark = h.len();
    h.push_str("<h2>Where the time goes</h2>\n");
    h.push_str(&format!(
        "<figure>{}</figure>\n",
        plots::pass_breakdown(&d.methods)
    ));
    section(&mut h, "time-breakdown", mark);
    mark = h.len();
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
    section(&mut h, "error-vs-time", mark);
    mark = h.len();
    if !d.grids.is_empty() {
        h.push_str("<h2>Side by side</h2>\n<p class=\"note\">Columns: methods. Rows: left eye, right eye, centre crops of each (nearest-neighbour zoom), the stereo difference (|left reprojected into the right view − right|, the per-pixel term of <code>stereo_mean</code>, on the pixels its mask scores: those the reference's pixel-centre geometry shows co-visible, or the method's own where there is no reference; tone-mapped at exposure 4), then each method's debug views of the left eye where it has them.</p>\n");
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
    section(&mut h, "side-by-side", mark);
    if d.draws("error-maps") {
        h.push_str(&error_maps(d));
    }
    if d.draws("viewer") {
        h.push_str(&viewer(d));
    }
    h.push_str("</body></html>\n");
    Ok(h)
}

/// GPU time per frame over the steady frames (after the first); the first
/// frame's time (pipeline compilation and other one-time costs) in text, so
/// it does not flatten the plot.
fn time_plot(d: &ReportData) -> String {
    let steady = d.methods.iter().any(|m| m.frames.len() > 1);
    let first = usize::from(steady);
    let mut h = format!(
        "<figure>{}",
        plots::per_frame(
            &d.methods,
            if steady {
                "GPU time per frame (frames after the first)"
            } else {
                "GPU time per frame"
            },
            "ms",
            first,
            |f| Some(f.gpu_ms)
        )
    );
    if steady {
        let warm: Vec<String> = d
            .methods
            .iter()
            .filter_map(|m| m.frames.iter().find(|f| f.index == 0).map(|f| (f, m)))
            .map(|(f, m)| format!("{} {}", esc(&m.name), fmt(Some(f.gpu_ms))))
            .collect();
        h.push_str(&format!(
            "<figcaption id=\"warm-up\">Frame 0 (warm-up: one-time driver costs such as pipeline compilation), not plotted, in ms: {}.</figcaption>",
            warm.join(", ")
        ));
    }
    h.push_str("</figure>\n");
    h
}

fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// One image the report shows: (source name, image, FLIP map, crop, FLIP
/// crop, FLIP mean), PNGs.
type Source<'a> = (
    String,
    &'a [u8],
    Option<&'a [u8]>,
    Option<&'a [u8]>,
    Option<&'a [u8]>,
    Option<f64>,
);

/// One shown frame's images from `viewer/`: the reference's and each
/// configuration's, with their FLIP maps and crops.
struct Shown<'a> {
    frame: u64,
    width: u64,
    crop: Option<[u64; 4]>,
    sources: Vec<Source<'a>>,
}

fn shown_frames(d: &ReportData) -> Vec<Shown<'_>> {
    let Some(index) = &d.viewer else {
        return Vec::new();
    };
    let file = |f: u64, name: &str| {
        d.viewer_files
            .get(&format!("frame_{f:05}/{name}.png"))
            .map(Vec::as_slice)
    };
    let ref_name = match d.summary["reference"]["spp"].as_u64() {
        Some(spp) => format!("reference ({spp} spp)"),
        None => "reference".to_string(),
    };
    let mut out = Vec::new();
    for fr in index["frames"].as_array().into_iter().flatten() {
        let f = fr["frame"].as_u64().unwrap_or(0);
        let crop = fr["crop"].as_array().and_then(|c| {
            let v: Vec<u64> = c.iter().filter_map(|x| x.as_u64()).collect();
            (v.len() == 4).then(|| [v[0], v[1], v[2], v[3]])
        });
        let mut sources = Vec::new();
        if let Some(img) = file(f, "reference") {
            sources.push((
                ref_name.clone(),
                img,
                None,
                file(f, "reference.crop"),
                None,
                None,
            ));
        }
        for (j, l) in fr["labels"].as_array().into_iter().flatten().enumerate() {
            let l = l.as_str().unwrap_or("");
            let Some(img) = file(f, &format!("method-{l}")) else {
                continue;
            };
            sources.push((
                l.to_string(),
                img,
                file(f, &format!("method-{l}.flip")),
                file(f, &format!("method-{l}.crop")),
                file(f, &format!("method-{l}.flip.crop")),
                fr["flip_means"][j].as_f64(),
            ));
        }
        out.push(Shown {
            frame: f,
            width: fr["width"].as_u64().unwrap_or(1).max(1),
            crop,
            sources,
        });
    }
    out
}

/// Per shown frame: the reference column, every configuration beside it,
/// their HDR-FLIP maps, and crops where the configurations differ most.
/// The images carry the ids the viewer draws from.
fn error_maps(d: &ReportData) -> String {
    let frames = shown_frames(d);
    if frames.is_empty() {
        return String::new();
    }
    let idx = d.viewer.as_ref().expect("frames come from the index");
    let mut h = format!(
        "<h2 id=\"error-maps\">Against the reference</h2>\n<p class=\"note\">{} of the left eye, at {} pixels per degree; colour ramp black (0) → purple → orange → pale yellow (1). Crops: {}, enlarged with nearest-neighbour pixels. Images tonemapped as the grids (exposure {}, ACES fit, sRGB). PNGs in <code>viewer/</code> beside this page.</p>\n",
        esc(idx["error_map"].as_str().unwrap_or("")),
        fmt(idx["ppd"].as_f64()),
        esc(idx["crop_rule"].as_str().unwrap_or("")),
        fmt(idx["exposure"].as_f64()),
    );
    for (k, f) in frames.iter().enumerate() {
        let scale = (240 / f.width).max(1);
        let shown_w = f.width * scale;
        let img = |id: &str, bytes: &[u8], w: u64, alt: &str| {
            format!(
                "<img id=\"{id}\" alt=\"{}\" width=\"{w}\" src=\"{}\">",
                esc(alt),
                data_uri(bytes)
            )
        };
        h.push_str(&format!(
            "<h3>frame {}</h3>\n<table class=\"imgs\" id=\"errors-{}\"><tr><th></th>",
            f.frame, f.frame
        ));
        for s in &f.sources {
            h.push_str(&format!("<th>{}</th>", esc(&s.0)));
        }
        h.push_str("</tr>\n<tr><th>image</th>");
        for (j, s) in f.sources.iter().enumerate() {
            h.push_str(&format!(
                "<td>{}</td>",
                img(&format!("v{k}-{j}"), s.1, shown_w, &s.0)
            ));
        }
        h.push_str("</tr>\n");
        if f.sources.iter().any(|s| s.2.is_some()) {
            h.push_str("<tr><th>HDR-FLIP</th>");
            for (j, s) in f.sources.iter().enumerate() {
                match s.2 {
                    Some(b) => h.push_str(&format!(
                        "<td>{}mean {}</td>",
                        img(
                            &format!("v{k}-{j}-flip"),
                            b,
                            shown_w,
                            &format!("{} FLIP", s.0)
                        ),
                        fmt(s.5)
                    )),
                    None => h.push_str("<td></td>"),
                }
            }
            h.push_str("</tr>\n");
        }
        if let Some([cx, cy, cw, ch]) = f.crop {
            let cs = (192 / cw.max(1)).max(1) * cw;
            h.push_str(&format!("<tr><th>crop<br>x {cx}, y {cy}<br>{cw}×{ch}</th>"));
            for s in &f.sources {
                match s.3 {
                    Some(b) => h.push_str(&format!("<td>{}</td>", img("", b, cs, &s.0))),
                    None => h.push_str("<td></td>"),
                }
            }
            h.push_str("</tr>\n<tr><th>FLIP crop</th>");
            for s in &f.sources {
                match s.4 {
                    Some(b) => h.push_str(&format!("<td>{}</td>", img("", b, cs, &s.0))),
                    None => h.push_str("<td></td>"),
                }
            }
            h.push_str("</tr>\n");
        }
        h.push_str("</table>\n");
    }
    h.replace(" id=\"\"", "")
}

/// The interactive viewer: one canvas showing the reference or a
/// configuration on a shown frame, drawn from the images of
/// [`error_maps`] (src/report/viewer.js).
fn viewer(d: &ReportData) -> String {
    let frames = shown_frames(d);
    if frames.is_empty() {
        return String::new();
    }
    let data = serde_json::json!({
        "zoom": (480 / frames[0].width).clamp(1, 16).next_power_of_two(),
        "frames": frames.iter().enumerate().map(|(k, f)| serde_json::json!({
            "frame": f.frame,
            "sources": f.sources.iter().enumerate().map(|(j, s)| serde_json::json!({
                "name": s.0,
                "id": format!("v{k}-{j}"),
                "flip": s.2.map(|_| format!("v{k}-{j}-flip")),
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    });
    format!(
        "<h2 id=\"viewer\">Viewer</h2>\n<p class=\"note\">Switch between the reference and the configurations on the same frame: buttons or keys 1–9, ← →, <b>f</b> flips back to the previous one; <b>[</b> <b>]</b> change frame; zoom (nearest-neighbour pixels) with the wheel over the image, + and −; <b>e</b> shows the HDR-FLIP map instead. Exposure: the slider multiplies radiance by 2^EV on the tonemapped PNGs, undoing sRGB and the ACES fit per pixel in the canvas and applying them again (8-bit PNGs: highlights the ACES curve saturated at 255 stay saturated when darkened).</p>\n<div><select id=\"v-frame\"></select> <span id=\"v-sources\"></span> zoom <button id=\"v-zoom-out\">−</button> <span id=\"v-zoom\"></span> <button id=\"v-zoom-in\">+</button> EV <input type=\"range\" id=\"v-ev\" min=\"-6\" max=\"6\" step=\"0.5\" value=\"0\"> <span id=\"v-ev-val\"></span> <label><input type=\"checkbox\" id=\"v-err\"> FLIP map</label></div>\n<div id=\"v-name\"></div><div id=\"v-wrap\"><canvas id=\"v-canvas\"></canvas></div><pre id=\"v-selftest\"></pre>\n<script type=\"application/json\" id=\"viewer-data\">{}</script>\n<script>\n{}</script>\n",
        data.to_string().replace("</", "<\\/"),
        include_str!("viewer.js")
    )
}

#[cfg(test)]
mod tests {
    use super::fmt;

    /// Small figures keep two significant digits (a standard error of
    /// 2.3e-5 read "0.0000" until session 50); others as before.
    #[test]
    fn small_figures_are_not_rounded_to_zero() {
        assert_eq!(fmt(Some(2.3e-5)), "2.3e-5");
        assert_eq!(fmt(Some(-4.0e-4)), "-4.0e-4");
        assert_eq!(fmt(Some(0.0)), "0.0000");
        assert_eq!(fmt(Some(0.0123)), "0.0123");
        assert_eq!(fmt(Some(123.45)), "123.5");
        assert_eq!(fmt(None), "–");
    }
}
