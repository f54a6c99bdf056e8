//! `stereocache compare` writes every promised file, with one summary row per method.

mod common;
use common::single_error_line;
use std::path::Path;
use std::process::Command;

/// `stereocache compare` on the Cornell box along the synthetic head turn at
/// 24×18, software backend, 8 spp references cached under `out/refs`,
/// validation on, with `args` (methods, frames, ...) added.
fn compare_cornell(out: &Path, args: &[&str]) -> std::process::Output {
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/synth-head-turn.csv");
    Command::new(env!("CARGO_BIN_EXE_stereocache"))
        .env("STEREOCACHE_VALIDATE", "1")
        .args([
            "compare",
            "--scene",
            "cornell",
            "--trace",
            trace.to_str().unwrap(),
        ])
        .args([
            "--size",
            "24x18",
            "--rt",
            "software",
            "--out",
            out.to_str().unwrap(),
        ])
        .args([
            "--reference-spp",
            "8",
            "--reference-cache",
            out.join("refs").to_str().unwrap(),
        ])
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn compare_writes_every_file() {
    let out = std::env::temp_dir().join(format!("stereocache-compare-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let methods = ["sample-cache", "taa", "naive"];
    let o = compare_cornell(
        &out,
        &[
            "--methods",
            &methods.join(","),
            "--frames",
            "10",
            "--every",
            "5",
        ],
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    for m in methods {
        for f in [
            "frames.jsonl",
            "summary.json",
            "frames/00000_left.exr",
            "frames/00005_right.png",
        ] {
            assert!(out.join(m).join(f).exists(), "{m}/{f} missing");
        }
        let lines = std::fs::read_to_string(out.join(m).join("frames.jsonl"))
            .unwrap()
            .lines()
            .count();
        assert_eq!(lines, 10, "{m}: frames.jsonl lines");
    }
    for f in ["frame_00000.png", "frame_00005.png", "frame_00009.png"] {
        let p = out.join("side-by-side").join(f);
        let img = image::open(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        assert!(
            img.width() >= 2 * 24 && img.height() >= 4 * 18,
            "grid too small"
        );
    }
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 1 + methods.len(), "{csv}");
    assert!(rows[0].starts_with("method,frames,mean_gpu_ms"));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let list = json["methods"].as_array().unwrap();
    assert_eq!(list.len(), methods.len());
    for (row, m) in list.iter().zip(methods) {
        assert_eq!(row["method"], m);
        assert!(row["mean_gpu_ms"].as_f64().unwrap() > 0.0);
        assert!(row["rays_total"].as_u64().unwrap() > 0);
        assert!(row["method_memory_bytes"].as_u64().unwrap() > 0);
        // Metrics against the reference: every frame after the first has temporal ones.
        for k in [
            "rse",
            "flip",
            "ssim",
            "stereo_mean",
            "stereo_mean_reference",
            "temporal_excess",
        ] {
            let v = row["metrics"][k]
                .as_f64()
                .unwrap_or_else(|| panic!("{m}: metric {k} missing"));
            assert!(v.is_finite(), "{m}: {k} = {v}");
        }
        let second: serde_json::Value = serde_json::from_str(
            std::fs::read_to_string(out.join(m).join("frames.jsonl"))
                .unwrap()
                .lines()
                .nth(1)
                .unwrap(),
        )
        .unwrap();
        assert!(
            second["metrics"]["temporal"].as_f64().is_some(),
            "{m}: frames.jsonl lacks metrics"
        );
        // The CSV carries the same numbers.
        let line = rows
            .iter()
            .find(|l| l.starts_with(&format!("{m},")))
            .unwrap();
        let mean: f64 = line.split(',').nth(2).unwrap().parse().unwrap();
        assert!((mean - row["mean_gpu_ms"].as_f64().unwrap()).abs() < 1e-3);
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn compare_refuses_unknown_methods() {
    let o = Command::new(env!("CARGO_BIN_EXE_stereocache"))
        .args([
            "compare",
            "--methods",
            "sample-cache,magic",
            "--out",
            "/tmp/never-written",
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("unknown method 'magic'") && !stderr.contains("panicked"),
        "{stderr}"
    );
    assert!(!Path::new("/tmp/never-written").exists());
}

/// The metrics' reference frames draw their own random numbers: a
/// supersampled method at the reference's own sample count is an independent
/// estimate of the same image, so its error is not 0 (it was, exactly, when
/// the reference shared the methods' seed). Asserted only what is certain
/// whatever the noise: 0 < RSE(supersample at N spp) < RSE(naive).
#[test]
fn reference_frames_are_independent_of_the_methods_samples() {
    let out = std::env::temp_dir().join(format!("stereocache-refseed-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = compare_cornell(
        &out,
        &[
            "--methods",
            "naive,supersample",
            "--spp",
            "8",
            "--frames",
            "2",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "rse").expect("rse column");
    let rse = |method: &str| -> f64 {
        let row = csv
            .lines()
            .find(|l| l.starts_with(&format!("{method},")))
            .unwrap_or_else(|| panic!("{method} row"));
        row.split(',').nth(col).unwrap().parse().unwrap()
    };
    let (naive, ss) = (rse("naive"), rse("supersample"));
    eprintln!("RSE naive {naive}, supersample (8 spp against 8 spp) {ss}");
    assert!(
        ss > 0.0,
        "supersample at the reference's spp matches it exactly: shared random numbers"
    );
    assert!(ss < naive, "8 spp ({ss}) should beat 1 spp ({naive})");
    let _ = std::fs::remove_dir_all(&out);
}

/// `compare --scene plane` along the real user1 trace at 32×24, software
/// backend, naive (1 spp) only, 2 frames, references at `reference_spp`
/// cached in `cache`, and `extra` arguments.
fn compare_plane_naive(
    out: &Path,
    cache: &Path,
    reference_spp: &str,
    extra: &[&str],
) -> std::process::Output {
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/mmsys18-user1.csv");
    Command::new(env!("CARGO_BIN_EXE_stereocache"))
        .env("STEREOCACHE_VALIDATE", "1")
        .args([
            "compare",
            "--scene",
            "plane",
            "--trace",
            trace.to_str().unwrap(),
        ])
        .args(["--methods", "naive", "--frames", "2", "--every", "0"])
        .args([
            "--size",
            "32x24",
            "--rt",
            "software",
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--reference-spp", reference_spp])
        .args(["--reference-cache", cache.to_str().unwrap()])
        .args(extra)
        .output()
        .unwrap()
}

/// The reference is two independent halves whose difference estimates its
/// own error, reported beside the methods' (summary.json `reference`, the
/// `rse_reference` column of summary.csv, the report) with one `warning:`
/// line when it is above 0.1× the best method's RSE.
///
/// Expected figures: naive and the reference are the same unbiased path
/// tracer at 1 and S spp, so the reference's RSE is ρ₁/S and naive's
/// measured RSE is ρ₁ + ρ₁/S (its own error plus the reference's): the ratio
/// is 1/(S + 1) whatever the scene — 0.33 at S = 2 (warns) and 0.03 at S = 32
/// (does not), each more than 3× away from the 0.1 threshold, far beyond the
/// estimates' scatter at 2 × 2 × 32×24 pixels (their standard errors are a
/// few per cent; printed).
#[test]
fn the_reference_estimates_its_own_noise_and_warns_when_it_is_not_small() {
    let base = std::env::temp_dir().join(format!("stereocache-refnoise-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let cache = base.join("refs");
    let mut seen = Vec::new();
    for (spp, warns) in [("2", true), ("32", false)] {
        let out = base.join(format!("spp{spp}"));
        let o = compare_plane_naive(&out, &cache, spp, &[]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{stderr}");
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
        let r = &json["reference"];
        let (rse, se) = (
            r["rse"].as_f64().unwrap(),
            r["rse_stderr"].as_f64().unwrap(),
        );
        let naive = json["methods"][0]["metrics"]["rse"].as_f64().unwrap();
        let ratio = r["ratio_to_best"].as_f64().unwrap();
        eprintln!(
            "reference {spp} spp: RSE {rse:.4e} ± {se:.1e}, naive {naive:.4e}, ratio {ratio:.3}"
        );
        assert_eq!(r["spp"].as_u64(), spp.parse::<u64>().ok());
        assert_eq!(
            r["half_spp"].as_u64().unwrap() * 2,
            r["spp"].as_u64().unwrap()
        );
        assert_eq!(r["best_method"], "naive");
        assert!(rse > 0.0 && se > 0.0 && se < 0.2 * rse, "RSE {rse} ± {se}");
        assert!((ratio - rse / naive).abs() < 1e-9 * ratio);
        // Beside the methods' errors: in their rows and the CSV.
        let row = &json["methods"][0]["metrics"];
        assert!((row["rse_reference"].as_f64().unwrap() - rse).abs() < 1e-9 * rse);
        assert!(row["mse_reference"].as_f64().unwrap() > 0.0);
        let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
        assert!(
            csv.lines()
                .next()
                .unwrap()
                .split(',')
                .any(|h| h == "rse_reference"),
            "{csv}"
        );
        let html = std::fs::read_to_string(out.join("report.html")).unwrap();
        assert!(
            html.contains("id=\"reference-noise\""),
            "report lacks the reference's error"
        );
        let warnings: Vec<&str> = stderr
            .lines()
            .filter(|l| l.starts_with("warning:"))
            .collect();
        assert!(stdout.contains("reference: "), "{stdout}");
        if warns {
            assert!(ratio > 0.1, "ratio {ratio}");
            assert_eq!(warnings.len(), 1, "{stderr}");
            assert!(
                warnings[0].contains("the reference (2 spp)")
                    && warnings[0].contains("--reference-spp"),
                "{}",
                warnings[0]
            );
            assert!(r["warning"].is_string() && r["suggested_spp"].as_u64().unwrap() > 2);
            assert!(html.contains("id=\"reference-warning\""));
        } else {
            assert!(ratio < 0.1, "ratio {ratio}");
            assert!(warnings.is_empty(), "{stderr}");
            assert!(r["warning"].is_null());
            assert!(!html.contains("id=\"reference-warning\""));
        }
        seen.push((rse, r.clone()));
    }
    // The cache holds both halves of every frame: 2 frames × 2 runs, each
    // file a header (magic, size, the halves' dropped-sample counts: 32
    // bytes), 4 radiance images (2 halves × 2 eyes) and depth + first hits
    // per eye.
    let n = 32 * 24;
    let files: Vec<_> = std::fs::read_dir(&cache).unwrap().flatten().collect();
    assert_eq!(files.len(), 4);
    for f in &files {
        assert_eq!(
            f.metadata().unwrap().len() as usize,
            32 + 4 * n * 16 + 2 * n * 20
        );
    }
    // A rerun reads them back: the same estimate, no warning lost.
    let out = base.join("again");
    let o = compare_plane_naive(&out, &cache, "2", &[]);
    assert!(o.status.success());
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["reference"]["rse"], seen[0].1["rse"]);
    assert_eq!(
        String::from_utf8_lossy(&o.stderr)
            .lines()
            .filter(|l| l.starts_with("warning:"))
            .count(),
        1
    );
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn an_odd_reference_spp_is_refused_before_any_work() {
    let out = std::env::temp_dir().join(format!("stereocache-oddref-{}", std::process::id()));
    let o = Command::new(env!("CARGO_BIN_EXE_stereocache"))
        .args(["compare", "--methods", "naive", "--reference-spp", "7"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let error = single_error_line(&o, "--reference-spp 7");
    assert!(
        error.contains("bad --reference-spp 7") && error.contains("even"),
        "{error}"
    );
    assert!(!out.exists());
}

/// The reference cache keys on the loaded scene's content: the same scene
/// file under another `--lighting` renders (and stores) new references
/// instead of reusing those of the old lighting (until session 47 the key
/// held the lights' count alone, so `constant:5` after `constant:1` was
/// scored against the constant:1 references: naive's RSE 17.3). Plane at
/// 32×24, 2 frames.
#[test]
fn references_are_not_reused_across_lighting() {
    let base = std::env::temp_dir().join(format!("stereocache-refkey-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let cache = base.join("refs");
    let refs = || std::fs::read_dir(&cache).map(|d| d.count()).unwrap_or(0);
    let mut counts = Vec::new();
    for (k, lighting) in ["constant:1", "constant:5", "constant:1"]
        .iter()
        .enumerate()
    {
        let out = base.join(format!("run{k}"));
        let o = compare_plane_naive(&out, &cache, "4", &["--lighting", lighting]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
        // 1 spp of a plane under a constant sky against its 4 spp
        // reference: RSE well below 1, where a reference of the other
        // lighting (5× or 1/5 the radiance) gives ≥ 0.64 = (1 − 1/5)²
        // everywhere.
        let rse = json["methods"][0]["metrics"]["rse"].as_f64().unwrap();
        assert!(rse < 0.2, "{lighting}: naive's RSE {rse}");
        counts.push(refs());
    }
    // Two new frames for the new lighting; the third run reuses the first's.
    assert!(counts[0] > 0, "{counts:?}");
    assert_eq!(counts[1], 2 * counts[0], "{counts:?}");
    assert_eq!(counts[2], counts[1], "{counts:?}");
    let _ = std::fs::remove_dir_all(&base);
}
