//! Errors of material-graph loading: one line naming the file, the graph and
//! the node (`FILE: graph `G`, node `N`: problem`).

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub struct GraphError {
    pub file: String,
    pub graph: Option<String>,
    pub node: Option<String>,
    pub line: Option<u32>,
    pub message: String,
}

impl fmt::Display for GraphError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        // Line 0: a graph that did not come from XML (KHR_texture_procedurals JSON).
        if let Some(l) = self.line.filter(|&l| l > 0) {
            write!(f, ":{l}")?;
        }
        write!(f, ":")?;
        if let Some(g) = &self.graph {
            write!(f, " graph `{g}`")?;
        }
        if let Some(n) = &self.node {
            write!(
                f,
                "{} node `{n}`",
                if self.graph.is_some() { "," } else { "" }
            )?;
        }
        if self.graph.is_some() || self.node.is_some() {
            write!(f, ":")?;
        }
        write!(f, " {}", self.message)
    }
}

impl std::error::Error for GraphError {}

impl GraphError {
    pub fn file(file: &str, message: impl Into<String>) -> GraphError {
        GraphError {
            file: file.into(),
            graph: None,
            node: None,
            line: None,
            message: message.into(),
        }
    }
}
