//! Combining disjoint parts of one comparison (the shards of an experiment,
//! `stereocache experiment merge`) into one compare directory, as if every
//! configuration had run in one `compare`.
//!
//! Each part is a compare directory ([`crate::compare`]) over the same
//! scene, trace, frames and reference, holding some of the configurations.
//! The merge copies every configuration's folder, reads its row from its
//! part's summary.json and its per-frame metrics from its frames.jsonl, and
//! recomputes what depends on all rows: the ratios to the baseline (paired
//! per-frame series, [`crate::compare::fill_ratios`]) and the reference's
//! comparison with the best method ([`ReferenceSummary::from_noise`]). Means
//! and standard errors over frames are the parts' own (each row's frames are
//! all in one part), so a merge equals one run bit for bit in every figure
//! but the timings (serde_json parses floats exactly: `float_roundtrip`).
//!
//! Images: every part's side-by-side grids are kept (`frame_<f>.part<k>.png`,
//! each with that part's columns); the viewer's frames list every
//! configuration, and each configuration's crop is re-cut from its full
//! image at the first part's crop window, so all crops of a frame show the
//! same pixels (the window was chosen where the first part's configurations
//! differ most, not all of them: the one difference from one run).

use crate::compare::{
    choose_baseline, fill_ratios, write_summary_files, Comparison, FlipPpd, MethodRow,
    ReferenceSummary, SummaryHeader,
};
use crate::error::{Error, Result};
use crate::metrics::ReferenceNoise;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn bad(path: &Path, what: impl std::fmt::Display) -> Error {
    Error::Usage(format!("{}: {what}", path.display()))
}

fn read_json(path: &Path) -> Result<serde_json::Value> {
    let text =
        crate::input::read_to_string(path).map_err(|e| bad(path, format!("cannot read ({e})")))?;
    serde_json::from_str(&text).map_err(|e| bad(path, format!("invalid JSON: {e}")))
}

/// The per-frame metric series of a configuration's frames.jsonl, in frame
/// order (a metric absent from a frame, e.g. temporal ones on frame 0, is
/// skipped there, as the evaluator does).
fn series(frames_jsonl: &Path) -> Result<BTreeMap<String, Vec<f64>>> {
    let text = crate::input::read_to_string(frames_jsonl)
        .map_err(|e| bad(frames_jsonl, format!("cannot read ({e})")))?;
    let mut out: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for (ln, line) in text.lines().enumerate() {
        let v: serde_json::Value = serde_json::from_str(line)
            .map_err(|e| bad(frames_jsonl, format!("line {}: invalid JSON: {e}", ln + 1)))?;
        for (k, x) in v["metrics"].as_object().into_iter().flatten() {
            out.entry(k.clone())
                .or_default()
                .push(x.as_f64().unwrap_or(f64::NAN));
        }
    }
    Ok(out)
}

fn copy_dir(from: &Path, to: &Path) -> Result<()> {
    std::fs::create_dir_all(to).map_err(|e| Error::io(to, e))?;
    for entry in std::fs::read_dir(from).map_err(|e| Error::io(from, e))? {
        let entry = entry.map_err(|e| Error::io(from, e))?;
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if src.is_dir() {
            copy_dir(&src, &dst)?;
        } else {
            std::fs::copy(&src, &dst).map_err(|e| Error::io(&dst, e))?;
        }
    }
    Ok(())
}

/// The summary.json fields every part must agree on: what was rendered,
/// and where and how (timing ratios across parts from different devices,
/// drivers, backends or settings would be meaningless while the merged
/// summary names one device). Every row must also have the same frame
/// count (`frames`).
/// `flip` too: FLIP's pixels per degree (until session 50 a shard run with
/// `--set flip-ppd=…` merged with one at the derived PPD).
const SAME: &[&str] = &[
    "scene", "trace", "width", "height", "fps", "device", "driver", "backend", "settings", "flip",
];

/// Merges the compare directories `parts` (each holding some of `labels`,
/// together all of them, each once) into `out`, rows in the order of
/// `labels`; `baseline` as `compare --baseline`. Writes summary.csv,
/// summary.json, the configurations' folders, side-by-side/ and viewer/.
pub fn merge_comparison(
    parts: &[PathBuf],
    labels: &[String],
    baseline: Option<&str>,
    out: &Path,
) -> Result<Comparison> {
    let summaries: Vec<serde_json::Value> = parts
        .iter()
        .map(|p| read_json(&p.join("summary.json")))
        .collect::<Result<_>>()?;
    let first = summaries
        .first()
        .ok_or_else(|| Error::Usage("merge: no parts to merge".into()))?;
    for (p, s) in parts.iter().zip(&summaries) {
        for k in SAME {
            if s[*k] != first[*k] {
                return Err(bad(
                    &p.join("summary.json"),
                    format!(
                        "'{k}' is {} but {} in {}: not parts of one comparison",
                        s[*k],
                        first[*k],
                        parts[0].display()
                    ),
                ));
            }
        }
        if s["reference"]["spp"] != first["reference"]["spp"] {
            return Err(bad(
                &p.join("summary.json"),
                "its reference differs from the first part's",
            ));
        }
        let frames = |s: &serde_json::Value| -> Vec<serde_json::Value> {
            s["methods"]
                .as_array()
                .map(|m| m.iter().map(|r| r["frames"].clone()).collect())
                .unwrap_or_default()
        };
        let want = frames(first).first().cloned();
        if let Some(f) = frames(s).into_iter().find(|f| Some(f) != want.as_ref()) {
            return Err(bad(
                &p.join("summary.json"),
                format!(
                    "a row has {f} frames but {} has {}: not parts of one comparison",
                    parts[0].display(),
                    want.unwrap_or_default()
                ),
            ));
        }
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    // An earlier merge's or run's files go first (until session 50 a merge
    // only added: an earlier merge's grids of other parts stayed in the
    // report, and a configuration's folder kept files its part lacks).
    crate::compare::remove_stale_outputs(out)?;
    let mut rows = Vec::new();
    for label in labels {
        let mut found = None;
        for (p, s) in parts.iter().zip(&summaries) {
            for row in s["methods"].as_array().into_iter().flatten() {
                if row["method"].as_str() == Some(label.as_str()) {
                    if found.is_some() {
                        return Err(bad(p, format!("'{label}' is in more than one part")));
                    }
                    found = Some((p, row));
                }
            }
        }
        let (p, row) = found.ok_or_else(|| {
            Error::Usage(format!(
                "merge: no part holds '{label}' (parts: {})",
                parts
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })?;
        let mut r = MethodRow::from_json(row)
            .ok_or_else(|| bad(&p.join("summary.json"), format!("bad row for '{label}'")))?;
        r.series = series(&p.join(label).join("frames.jsonl"))?;
        let dst = out.join(label);
        // The previous outputs of this label only (a user's own files there stay).
        crate::output::remove_run_files(&dst, &crate::output::is_replay_output)
            .map_err(|e| Error::io(&dst, e))?;
        copy_dir(&p.join(label), &dst)?;
        rows.push(r);
    }
    let baseline = choose_baseline(labels, baseline)?;
    fill_ratios(&mut rows, &baseline);
    let rj = &first["reference"];
    let reference = match rj["spp"].as_u64() {
        None => None,
        Some(spp) => {
            let f = |k: &str| rj[k].as_f64().unwrap_or(f64::NAN);
            let noise = ReferenceNoise {
                rse: f("rse"),
                rse_stderr: f("rse_stderr"),
                mse: f("mse"),
                mse_stderr: f("mse_stderr"),
                pixels: 0,
            };
            let seed = rj["half_seeds"][0].as_u64().unwrap_or(0) as u32;
            let mut r = ReferenceSummary::from_noise(
                spp as u32,
                0,
                noise,
                f("flip_halves"),
                rj["frames"].as_u64().unwrap_or(0) as usize,
                &rows,
            );
            r.half_seeds = [seed, rj["half_seeds"][1].as_u64().unwrap_or(0) as u32];
            Some(r)
        }
    };
    let flip = FlipPpd {
        ppd: first["flip"]["ppd"].as_f64().unwrap_or(f64::NAN) as f32,
        source: first["flip"]["source"].as_str().unwrap_or("").to_string(),
    };
    let cmp = Comparison {
        rows,
        reference,
        baseline,
        flip,
    };
    write_summary_files(out, &SummaryHeader::from_summary(first), &cmp)?;
    merge_grids(parts, out)?;
    merge_viewer(parts, labels, out)?;
    Ok(cmp)
}

/// Every part's side-by-side grids, `frame_<f>.part<k>.png`: the plain
/// `frame_<f>.png` grids of a compare run (a part's other files there, a
/// user's or an earlier merge's, are not copied).
fn merge_grids(parts: &[PathBuf], out: &Path) -> Result<()> {
    let dst = out.join("side-by-side");
    std::fs::create_dir_all(&dst).map_err(|e| Error::io(&dst, e))?;
    for (k, p) in parts.iter().enumerate() {
        let Ok(rd) = std::fs::read_dir(p.join("side-by-side")) else {
            continue;
        };
        for e in rd.flatten() {
            let src = e.path();
            let (Some(stem), Some("png")) = (
                src.file_stem().and_then(|s| s.to_str()),
                src.extension().and_then(|s| s.to_str()),
            ) else {
                continue;
            };
            if !crate::output::is_numbered(Path::new(&e.file_name()), "frame_", ".png") {
                continue;
            }
            let to = dst.join(format!("{stem}.part{}.png", k + 1));
            std::fs::copy(&src, &to).map_err(|e| Error::io(&to, e))?;
        }
    }
    Ok(())
}

/// Re-cuts `window` (x, y, w, h) out of the PNG at `full` into `to`.
fn recrop(full: &Path, to: &Path, window: [u32; 4]) -> Result<()> {
    let img = image::open(full)
        .map_err(|e| bad(full, format!("cannot read ({e})")))?
        .to_rgb8();
    let [x, y, w, h] = window;
    let c = image::imageops::crop_imm(&img, x, y, w, h).to_image();
    crate::output::write_encoded(to, |o| crate::output::encode_png_rgb8(o, w, h, c.as_raw()))?;
    Ok(())
}

/// viewer/: per shown frame, the union of the parts' configurations (in the
/// order of `labels`), their images copied, crops re-cut at the first part's window.
fn merge_viewer(parts: &[PathBuf], labels: &[String], out: &Path) -> Result<()> {
    let indices: Vec<(PathBuf, serde_json::Value)> = parts
        .iter()
        .filter_map(|p| {
            let ip = p.join("viewer").join("index.json");
            ip.exists().then(|| read_json(&ip).map(|v| (p.clone(), v)))
        })
        .collect::<Result<_>>()?;
    let Some((_, first)) = indices.first() else {
        return Ok(());
    };
    let mut doc = first.clone();
    let mut frames = Vec::new();
    for f0 in first["frames"].as_array().into_iter().flatten() {
        let frame = f0["frame"].as_u64().unwrap_or(0);
        let sub = format!("frame_{frame:05}");
        let dst = out.join("viewer").join(&sub);
        std::fs::create_dir_all(&dst).map_err(|e| Error::io(&dst, e))?;
        let window: Option<[u32; 4]> = f0["crop"].as_array().map(|c| {
            let g = |i: usize| c.get(i).and_then(|v| v.as_u64()).unwrap_or(0) as u32;
            [g(0), g(1), g(2), g(3)]
        });
        // label -> (part dir, FLIP mean)
        let mut have: BTreeMap<String, (PathBuf, Option<f64>)> = BTreeMap::new();
        for (p, idx) in &indices {
            let Some(fr) = idx["frames"]
                .as_array()
                .into_iter()
                .flatten()
                .find(|x| x["frame"].as_u64() == Some(frame))
            else {
                continue;
            };
            for (i, l) in fr["labels"].as_array().into_iter().flatten().enumerate() {
                if let Some(l) = l.as_str() {
                    let mean = fr["flip_means"].get(i).and_then(|v| v.as_f64());
                    have.insert(l.to_string(), (p.clone(), mean));
                }
            }
        }
        let mut entry = f0.clone();
        let shown: Vec<&String> = labels.iter().filter(|l| have.contains_key(*l)).collect();
        entry["labels"] = serde_json::json!(shown);
        if f0.get("flip_means").is_some() {
            entry["flip_means"] =
                serde_json::json!(shown.iter().map(|l| have[*l].1).collect::<Vec<_>>());
        }
        let src0 = parts_dir(&indices[0].0, &sub);
        for name in ["reference.png", "reference.crop.png"] {
            if src0.join(name).exists() {
                std::fs::copy(src0.join(name), dst.join(name))
                    .map_err(|e| Error::io(dst.join(name), e))?;
            }
        }
        for l in shown {
            let src = parts_dir(&have[l].0, &sub);
            for kind in ["", ".flip"] {
                let full = format!("method-{l}{kind}.png");
                if !src.join(&full).exists() {
                    continue;
                }
                std::fs::copy(src.join(&full), dst.join(&full))
                    .map_err(|e| Error::io(dst.join(&full), e))?;
                if let Some(w) = window {
                    recrop(
                        &src.join(&full),
                        &dst.join(format!("method-{l}{kind}.crop.png")),
                        w,
                    )?;
                }
            }
        }
        frames.push(entry);
    }
    doc["frames"] = serde_json::json!(frames);
    if indices.len() > 1 {
        doc["crop_rule"] = serde_json::json!(format!(
            "{} (merged from {} parts: the window of the first part, every configuration's crop re-cut there)",
            first["crop_rule"].as_str().unwrap_or(""),
            indices.len()
        ));
    }
    let path = out.join("viewer").join("index.json");
    crate::output::write_text(
        &path,
        &serde_json::to_string_pretty(&doc).unwrap_or_default(),
    )?;
    Ok(())
}

fn parts_dir(part: &Path, sub: &str) -> PathBuf {
    part.join("viewer").join(sub)
}
