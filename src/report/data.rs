//! What a report reads from a compare directory.

use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One frame of one method (from frames.jsonl).
#[derive(Clone, Debug)]
pub struct FramePoint {
    pub index: usize,
    pub gpu_ms: f64,
    pub metrics: BTreeMap<String, f64>,
}

#[derive(Clone, Debug)]
pub struct MethodData {
    pub name: String,
    /// The method's row of summary.json as it was written.
    pub row: serde_json::Value,
    pub frames: Vec<FramePoint>,
}

impl MethodData {
    pub fn metric(&self, k: &str) -> Option<f64> {
        self.row["metrics"][k].as_f64()
    }
    /// The standard error over frames of metric `k` (absent or `null`: unknown).
    pub fn metric_stderr(&self, k: &str) -> Option<f64> {
        self.row["metrics_stderr"][k].as_f64()
    }
    /// The ratio of metric `k` to the baseline's and its standard error.
    pub fn ratio(&self, k: &str) -> Option<(f64, Option<f64>)> {
        let q = &self.row["ratios"][k];
        Some((q["mean"].as_f64()?, q["stderr"].as_f64()))
    }
    /// The rendering method behind the configuration (its label otherwise).
    pub fn kind(&self) -> String {
        self.row["kind"].as_str().unwrap_or(&self.name).to_string()
    }
    pub fn mean_gpu_ms(&self) -> f64 {
        self.row["steady_mean_gpu_ms"]
            .as_f64()
            .or(self.row["mean_gpu_ms"].as_f64())
            .unwrap_or(0.0)
    }
    pub fn pass_ms(&self) -> BTreeMap<String, f64> {
        self.row["pass_mean_ms"]
            .as_object()
            .map(|m| {
                m.iter()
                    .filter(|(k, _)| !k.starts_with(crate::methods::frame::DIAGNOSTIC_PASS_PREFIX))
                    .filter_map(|(k, v)| v.as_f64().map(|v| (k.clone(), v)))
                    .collect()
            })
            .unwrap_or_default()
    }
}

pub struct ReportData {
    pub dir: PathBuf,
    pub summary: serde_json::Value,
    pub methods: Vec<MethodData>,
    /// Side-by-side grid images (file name, bytes).
    pub grids: Vec<(String, Vec<u8>)>,
    /// `viewer/index.json` ([`super::images`]) when compare wrote one.
    pub viewer: Option<serde_json::Value>,
    /// The PNGs under `viewer/` by path relative to it (`frame_<f>/<name>.png`).
    pub viewer_files: BTreeMap<String, Vec<u8>>,
    /// `experiment.json` when the directory is one comparison of an
    /// experiment (`stereocache experiment run`): its title, the paper's
    /// claims with what was measured, and the figures to draw.
    pub experiment: Option<serde_json::Value>,
}

impl ReportData {
    /// Whether the report draws `section` ([`super::html::SECTIONS`]): all
    /// of them unless an experiment names its figures.
    pub fn draws(&self, section: &str) -> bool {
        match self
            .experiment
            .as_ref()
            .and_then(|e| e["figures"].as_array())
        {
            Some(f) if !f.is_empty() => f.iter().any(|x| x.as_str() == Some(section)),
            _ => true,
        }
    }
}

fn bad(path: &Path, what: impl std::fmt::Display) -> Error {
    Error::Usage(format!("{}: {what}", path.display()))
}

/// Reads a compare directory; a missing or malformed file is an error naming it.
pub fn load(dir: &Path) -> Result<ReportData> {
    let sp = dir.join("summary.json");
    let text = std::fs::read_to_string(&sp).map_err(|e| {
        bad(
            &sp,
            format!("cannot read ({e}); is this a `stereocache compare` output directory?"),
        )
    })?;
    let summary: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(&sp, format!("invalid JSON: {e}")))?;
    let rows = summary["methods"]
        .as_array()
        .ok_or_else(|| bad(&sp, "no \"methods\" list"))?;
    let mut methods = Vec::new();
    for row in rows {
        let name = row["method"]
            .as_str()
            .ok_or_else(|| bad(&sp, "a method row has no name"))?
            .to_string();
        let fp = dir.join(&name).join("frames.jsonl");
        let text =
            std::fs::read_to_string(&fp).map_err(|e| bad(&fp, format!("cannot read ({e})")))?;
        let mut frames = Vec::new();
        for (ln, line) in text.lines().enumerate() {
            let v: serde_json::Value = serde_json::from_str(line)
                .map_err(|e| bad(&fp, format!("line {}: invalid JSON: {e}", ln + 1)))?;
            frames.push(FramePoint {
                index: v["index"].as_u64().unwrap_or(ln as u64) as usize,
                gpu_ms: v["gpu_ms"].as_f64().unwrap_or(0.0),
                metrics: v["metrics"]
                    .as_object()
                    .map(|m| {
                        m.iter()
                            .filter_map(|(k, v)| v.as_f64().map(|v| (k.clone(), v)))
                            .collect()
                    })
                    .unwrap_or_default(),
            });
        }
        methods.push(MethodData {
            name,
            row: row.clone(),
            frames,
        });
    }
    let mut grids = Vec::new();
    let sbs = dir.join("side-by-side");
    if let Ok(rd) = std::fs::read_dir(&sbs) {
        let mut names: Vec<PathBuf> = rd
            .flatten()
            .map(|e| e.path())
            // The grids a run writes (a user's own PNG there is not one).
            .filter(|p| {
                p.file_name()
                    .is_some_and(|n| crate::output::is_grid_image(Path::new(n)))
            })
            .collect();
        names.sort();
        for p in names {
            let bytes = std::fs::read(&p).map_err(|e| bad(&p, e))?;
            grids.push((p.file_name().unwrap().to_string_lossy().into_owned(), bytes));
        }
    }
    let (viewer, viewer_files) = load_viewer(dir)?;
    let ep = dir.join("experiment.json");
    let experiment = match std::fs::read_to_string(&ep) {
        Ok(text) => {
            Some(serde_json::from_str(&text).map_err(|e| bad(&ep, format!("invalid JSON: {e}")))?)
        }
        Err(_) => None,
    };
    Ok(ReportData {
        experiment,
        dir: dir.to_path_buf(),
        summary,
        methods,
        grids,
        viewer,
        viewer_files,
    })
}

type ViewerFiles = (Option<serde_json::Value>, BTreeMap<String, Vec<u8>>);

/// `viewer/index.json` and the PNGs of its frames (none: an older compare
/// directory without them).
fn load_viewer(dir: &Path) -> Result<ViewerFiles> {
    let vdir = dir.join("viewer");
    let ip = vdir.join("index.json");
    let Ok(text) = std::fs::read_to_string(&ip) else {
        return Ok((None, BTreeMap::new()));
    };
    let index: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(&ip, format!("invalid JSON: {e}")))?;
    let mut files = BTreeMap::new();
    for f in index["frames"].as_array().into_iter().flatten() {
        let sub = format!("frame_{:05}", f["frame"].as_u64().unwrap_or(0));
        let fdir = vdir.join(&sub);
        let rd = std::fs::read_dir(&fdir).map_err(|e| bad(&fdir, format!("cannot read ({e})")))?;
        for p in rd.flatten().map(|e| e.path()) {
            if p.extension().is_some_and(|e| e == "png") {
                let bytes = std::fs::read(&p).map_err(|e| bad(&p, e))?;
                let name = p.file_name().unwrap().to_string_lossy().into_owned();
                files.insert(format!("{sub}/{name}"), bytes);
            }
        }
    }
    Ok((Some(index), files))
}
