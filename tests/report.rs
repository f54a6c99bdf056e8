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
    let console: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("CONSOLE") || l.contains("Uncaught"))
        .collect();
    assert!(
        console.is_empty(),
        "console messages:\n{}",
        console.join("\n")
    );
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
