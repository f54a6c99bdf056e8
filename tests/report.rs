//! The HTML report of a compare run: self-contained (references no file),
//! its numbers equal summary.csv's, and it loads in a real headless browser
//! (Debian's chromium) without console errors into a non-blank page.

mod common;
use common::require;
use std::path::{Path, PathBuf};
use std::process::Command;

fn compare_run(tag: &str) -> PathBuf {
    let out = std::env::temp_dir().join(format!("stereocache-report-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/mmsys18-user1.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_stereocache"))
        .env("STEREOCACHE_VALIDATE", "1")
        .args([
            "compare",
            "--scene",
            "plane",
            "--trace",
            trace.to_str().unwrap(),
            "--methods",
            "sample-cache,reference",
            "--frames",
            "6",
        ])
        .args([
            "--size",
            "32x24",
            "--every",
            "0",
            "--rt",
            "software",
            "--reference-spp",
            "8",
        ])
        .args([
            "--reference-cache",
            out.join("refs").to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("report.html"));
    out
}

#[test]
fn report_is_self_contained_and_matches_the_summary() {
    let out = compare_run("summary");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    // Only data URIs: no external files to go missing.
    for attr in ["src=\"", "href=\""] {
        for (i, _) in html.match_indices(attr) {
            let rest = &html[i + attr.len()..];
            assert!(
                rest.starts_with("data:"),
                "report references a file: {}",
                &rest[..rest.len().min(60)]
            );
        }
    }
    assert!(html.contains("<svg"), "no plots");
    // The table carries the summary.csv numbers.
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for line in csv.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let method = cells[0];
        let table_row = html
            .split("<tr>")
            .find(|r| r.starts_with(&format!("<td>{method}</td>")))
            .and_then(|r| r.split("</tr>").next())
            .expect("method row in the table");
        for key in ["steady_mean_gpu_ms", "rse", "flip"] {
            let col = header.iter().position(|h| *h == key).unwrap();
            let v: f64 = cells[col].parse().unwrap();
            let shown = if v.abs() >= 100.0 {
                format!("{v:.1}")
            } else {
                format!("{v:.4}")
            };
            assert!(
                table_row.contains(&format!("<td>{shown}</td>")),
                "{method} {key}: {shown} not in {table_row}"
            );
        }
    }
    // The reference's own estimated error has its row, in the RSE column.
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let rse = json["reference"]["rse"]
        .as_f64()
        .expect("summary.json reference.rse");
    let row = html
        .split("<tr id=\"reference-row\">")
        .nth(1)
        .and_then(|r| r.split("</tr>").next())
        .expect("reference row in the table");
    assert!(
        row.contains(&format!("<td>{rse:.4}</td>")),
        "{rse:.4} not in {row}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn report_loads_in_headless_chromium() {
    let chromium = ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
        .into_iter()
        .find(|p| Path::new(p).exists());
    if !require(
        chromium.is_some(),
        "chromium (scripts/setup.sh --test installs it)",
    ) {
        return;
    }
    let chromium = chromium.expect("checked above");
    let out = compare_run("browser");
    let shot = out.join("shot.png");
    let profile = out.join("profile");
    let o = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
        ])
        .args([
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
            "--window-size=1200,1600",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", out.join("report.html").display()))
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&o.stderr);
    assert_no_console_messages(&log);
    let img = image::open(&shot)
        .unwrap_or_else(|e| panic!("no screenshot ({e}); chromium said:\n{log}"))
        .to_luma8();
    let px: Vec<f64> = img.pixels().map(|p| p.0[0] as f64).collect();
    let mean = px.iter().sum::<f64>() / px.len() as f64;
    let var = px.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / px.len() as f64;
    let dark = px.iter().filter(|&&v| v < 128.0).count();
    assert!(
        var > 100.0 && dark > px.len() / 200,
        "blank screenshot (mean {mean:.1}, variance {var:.1})"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// The viewer in headless chromium: `report.html#selftest` switches the
/// shown image by key (→), by button (the last source) and changes the
/// exposure, and writes what the canvas showed after each into the DOM.
/// Each switch must change the source and the canvas pixels; there must be
/// no console message. Also: the error maps and crops are PNGs beside the
/// report, and the page shows them with the reference column first.
#[test]
fn report_viewer_switches_method_in_headless_chromium() {
    let chromium = ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
        .into_iter()
        .find(|p| Path::new(p).exists());
    if !require(
        chromium.is_some(),
        "chromium (scripts/setup.sh --test installs it)",
    ) {
        return;
    }
    let out = compare_run("viewer");
    let index: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("viewer/index.json")).unwrap()).unwrap();
    let frames = index["frames"].as_array().expect("viewer frames");
    assert_eq!(frames.len(), 3, "first, middle and last frame shown");
    for f in frames {
        let dir = out.join(format!("viewer/frame_{:05}", f["frame"].as_u64().unwrap()));
        for name in ["reference.png", "reference.crop.png"]
            .into_iter()
            .map(String::from)
            .chain(["sample-cache", "reference"].iter().flat_map(|l| {
                ["", ".flip", ".crop", ".flip.crop"].map(|s| format!("method-{l}{s}.png"))
            }))
        {
            let img = image::open(dir.join(&name)).unwrap_or_else(|e| panic!("{name}: {e}"));
            let crop = name.contains(".crop");
            // 32x24 images: the crop window is the whole image.
            assert_eq!(
                (img.width(), img.height()),
                (32, 24),
                "{name} (crop {crop})"
            );
        }
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let table = html
        .split("<table class=\"imgs\"")
        .nth(1)
        .expect("error-map table");
    assert!(
        table.find("<th>reference (8 spp)</th>").unwrap()
            < table.find("<th>sample-cache</th>").unwrap(),
        "the reference column comes first"
    );
    assert!(table.contains("<th>HDR-FLIP</th>"), "no FLIP row");

    let profile = out.join("profile");
    let o = Command::new(chromium.expect("checked above"))
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=5000",
            "--dump-dom",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!(
            "file://{}#selftest",
            out.join("report.html").display()
        ))
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&o.stderr);
    assert_no_console_messages(&log);
    let dom = String::from_utf8_lossy(&o.stdout);
    let result = dom
        .split("<pre id=\"v-selftest\">")
        .nth(1)
        .and_then(|r| r.split("</pre>").next())
        .unwrap_or_else(|| panic!("no self-test output; chromium said:\n{log}"));
    let r: serde_json::Value = serde_json::from_str(&result.replace("&quot;", "\""))
        .unwrap_or_else(|e| panic!("self-test output {result}: {e}"));
    assert_eq!(
        r["sources"],
        serde_json::json!(["reference (8 spp)", "sample-cache", "reference"]),
        "{r}"
    );
    let (first, key, click, exposure) = (&r["first"], &r["key"], &r["click"], &r["exposure"]);
    assert_eq!(first["source"], "reference (8 spp)", "{r}");
    assert_eq!(key["source"], "sample-cache", "{r}");
    assert_eq!(click["source"], "reference", "{r}");
    assert_ne!(
        first["hash"], key["hash"],
        "→ did not change the canvas: {r}"
    );
    assert_ne!(
        key["hash"], click["hash"],
        "the button did not change the canvas: {r}"
    );
    assert_eq!(exposure["source"], "reference", "{r}");
    assert_ne!(
        click["hash"], exposure["hash"],
        "EV +2 did not change the canvas: {r}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// Chromium's stderr holds no page console message and no uncaught error.
fn assert_no_console_messages(log: &str) {
    let console: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("CONSOLE") || l.contains("Uncaught"))
        .collect();
    assert!(
        console.is_empty(),
        "console messages:\n{}",
        console.join("\n")
    );
}
