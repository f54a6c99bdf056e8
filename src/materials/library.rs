//! The shipped graph library: `scenes/materials/*.mtlx`, one material per
//! file (a nodegraph whose outputs are named after the material inputs they
//! feed, see `binding.rs`).

use super::document::Document;
use super::error::GraphError;
use super::graph::Graph;
use std::path::PathBuf;

/// The shipped files' names and texts, embedded (the generated scenes use
/// them wherever the binary runs).
pub const EMBEDDED: &[(&str, &str)] = &[
    (
        "bricks.mtlx",
        include_str!("../../scenes/materials/bricks.mtlx"),
    ),
    (
        "cardboard.mtlx",
        include_str!("../../scenes/materials/cardboard.mtlx"),
    ),
    (
        "concrete.mtlx",
        include_str!("../../scenes/materials/concrete.mtlx"),
    ),
    (
        "fabric.mtlx",
        include_str!("../../scenes/materials/fabric.mtlx"),
    ),
    (
        "granite.mtlx",
        include_str!("../../scenes/materials/granite.mtlx"),
    ),
    (
        "lava.mtlx",
        include_str!("../../scenes/materials/lava.mtlx"),
    ),
    (
        "leather.mtlx",
        include_str!("../../scenes/materials/leather.mtlx"),
    ),
    (
        "marble.mtlx",
        include_str!("../../scenes/materials/marble.mtlx"),
    ),
    (
        "rust.mtlx",
        include_str!("../../scenes/materials/rust.mtlx"),
    ),
    (
        "terrazzo.mtlx",
        include_str!("../../scenes/materials/terrazzo.mtlx"),
    ),
    (
        "tiles.mtlx",
        include_str!("../../scenes/materials/tiles.mtlx"),
    ),
    (
        "wood.mtlx",
        include_str!("../../scenes/materials/wood.mtlx"),
    ),
];

/// The graph of an embedded file (its one nodegraph), named `materials/<file>` in errors.
pub fn embedded(file: &str) -> Result<Graph, GraphError> {
    let text = EMBEDDED
        .iter()
        .find(|(n, _)| *n == file)
        .map(|(_, t)| *t)
        .ok_or_else(|| GraphError::file(file, "not a shipped library file"))?;
    let doc = Document::parse(&format!("materials/{file}"), text)?;
    let name = doc
        .graphs
        .first()
        .map(|g| g.name.clone())
        .ok_or_else(|| GraphError::file(file, "has no nodegraph"))?;
    Graph::build(&doc, &name, &[])
}

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
