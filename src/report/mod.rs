//! `stereocache report DIR`: a self-contained HTML page from a compare
//! directory (summary.json, `<method>/frames.jsonl`, side-by-side grids):
//! the summary table, error and frame time per frame, a stacked per-pass
//! breakdown per method (like the paper's Fig. 13), error against frame time
//! (Pareto view), the image grids, per shown frame the reference column with
//! every method's image, HDR-FLIP map and crops beside it ([`images`]), and
//! an interactive viewer (viewer.js, inline). Plots are SVG (plotters) inlined in
//! the page; images are embedded as data URIs, so the page is one file.

pub mod data;
pub mod html;
pub mod images;
pub mod plots;

pub use data::{load, ReportData};

use crate::error::Result;
use std::path::{Path, PathBuf};

/// Writes `dir/report.html` and returns its path.
pub fn write_report(dir: &Path) -> Result<PathBuf> {
    let data = load(dir)?;
    let page = html::page(&data)?;
    let path = dir.join("report.html");
    crate::output::write_text(&path, &page)?;
    Ok(path)
}
