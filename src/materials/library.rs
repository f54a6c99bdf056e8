//! The shipped graph library: `scenes/materials/*.mtlx`, one material per
//! file (a nodegraph whose outputs are named after the material inputs they
//! feed, see `binding.rs`).

use super::document::Document;
use super::error::GraphError;
use super::graph::Graph;
use std::path::PathBuf;

/// The library's folder.
pub fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/materials")
}

/// Every shipped .mtlx file, sorted by name.
pub fn files() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir())
        .map(|rd| {
            rd.flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e == "mtlx"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Every graph of every shipped file.
pub fn load_all() -> Result<Vec<Graph>, GraphError> {
    let mut out = Vec::new();
    for f in files() {
        let doc = Document::load(&f)?;
        out.extend(Graph::build_all(&doc, &[])?);
    }
    Ok(out)
}
