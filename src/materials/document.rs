//! A MaterialX document (`.mtlx`, XML) read into plain element records:
//! nodegraphs with their interface inputs, nodes and outputs, nodedefs, and
//! the document-level nodes (shaders and materials) that bind graphs to a
//! material. Nothing is resolved here; `graph.rs` types and orders a graph.

use super::error::GraphError;

/// An `<input>` or `<output>` element.
#[derive(Clone, Debug, Default)]
pub struct RawPort {
    pub name: String,
    pub ty: Option<String>,
    pub value: Option<String>,
    pub nodename: Option<String>,
    pub output: Option<String>,
    pub interfacename: Option<String>,
    pub nodegraph: Option<String>,
    pub defaultgeomprop: Option<String>,
    /// The colour space of the port's value (`colorspace`, inherited from
    /// the nearest enclosing element that sets it; MaterialX §Color Spaces).
    pub colorspace: Option<String>,
    /// The `fileprefix` in scope (inherited likewise), prepended to a
    /// filename value.
    pub fileprefix: Option<String>,
    /// An attribute stereocache does not support (`channels`, ...), by name.
    pub unsupported: Option<String>,
    pub line: u32,
}

/// A node element: its tag is the node (category), e.g. `<noise3d name=.. type=..>`.
#[derive(Clone, Debug)]
pub struct RawNode {
    pub category: String,
    pub name: String,
    pub ty: Option<String>,
    pub inputs: Vec<RawPort>,
    pub line: u32,
}

#[derive(Clone, Debug)]
pub struct RawGraph {
    pub name: String,
    /// The nodedef the graph implements (its interface), if any.
    pub nodedef: Option<String>,
    pub inputs: Vec<RawPort>,
    pub nodes: Vec<RawNode>,
    pub outputs: Vec<RawPort>,
    pub line: u32,
}

#[derive(Clone, Debug)]
pub struct RawNodeDef {
    pub name: String,
    pub node: String,
    pub inputs: Vec<RawPort>,
    pub outputs: Vec<RawPort>,
}

#[derive(Clone, Debug, Default)]
pub struct Document {
    pub file: String,
    /// The folder image files are relative to; `None`: the folder of `file`.
    pub dir: Option<std::path::PathBuf>,
    pub graphs: Vec<RawGraph>,
    pub nodedefs: Vec<RawNodeDef>,
    /// Nodes outside any nodegraph (surface shaders, materials, loose nodes).
    pub nodes: Vec<RawNode>,
}

/// Element names that are not nodes.
const NOT_NODES: &[&str] = &[
    "input",
    "output",
    "nodegraph",
    "nodedef",
    "implementation",
    "typedef",
    "look",
    "collection",
    "geominfo",
    "propertyset",
    "variantset",
    "backdrop",
    "token",
    "unitdef",
    "unittypedef",
    "targetdef",
    "attributedef",
    "materialassign",
    "lookgroup",
    "visibility",
    "propertyassign",
    "propertysetassign",
    "variantassign",
    "member",
];

/// The value of attribute `k` on `n` or the nearest ancestor that sets it.
fn inherited(n: roxmltree::Node, k: &str) -> Option<String> {
    n.ancestors()
        .find_map(|e| e.attribute(k))
        .filter(|v| !v.is_empty())
        .map(str::to_string)
}

fn port(n: roxmltree::Node, line: u32) -> RawPort {
    let a = |k: &str| n.attribute(k).map(str::to_string);
    let unsupported = ["channels", "nodegraph_output"]
        .iter()
        .find(|k| n.attribute(**k).is_some_and(|v| !v.is_empty()))
        .map(|k| k.to_string());
    RawPort {
        name: n.attribute("name").unwrap_or("").to_string(),
        ty: a("type"),
        value: a("value"),
        nodename: a("nodename").filter(|s| !s.is_empty()),
        output: a("output").filter(|s| !s.is_empty()),
        interfacename: a("interfacename").filter(|s| !s.is_empty()),
        nodegraph: a("nodegraph").filter(|s| !s.is_empty()),
        defaultgeomprop: a("defaultgeomprop"),
        colorspace: inherited(n, "colorspace"),
        fileprefix: inherited(n, "fileprefix"),
        unsupported,
        line,
    }
}

impl Document {
    /// Parses `text` (the contents of `file`, named in errors).
    pub fn parse(file: &str, text: &str) -> Result<Document, GraphError> {
        if let Some(line) = nesting_exceeds(text, MAX_XML_DEPTH) {
            return Err(GraphError::file(
                file,
                format!("elements nest deeper than {MAX_XML_DEPTH} levels (line {line})"),
            ));
        }
        let xml = roxmltree::Document::parse(text)
            .map_err(|e| GraphError::file(file, format!("not a valid XML document ({e})")))?;
        let root = xml.root_element();
        if root.tag_name().name() != "materialx" {
            return Err(GraphError::file(
                file,
                format!(
                    "root element is <{}>, not <materialx>",
                    root.tag_name().name()
                ),
            ));
        }
        // Line of a node's start: by binary search over the line starts
        // (roxmltree's text_pos_at scans from the top, quadratic over a
        // document's nodes).
        let line_starts: Vec<usize> = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        let line =
            |n: roxmltree::Node| line_starts.partition_point(|&s| s <= n.range().start) as u32;
        let children = |n: roxmltree::Node<'_, '_>, tag: &str| -> Vec<RawPort> {
            n.children()
                .filter(|c| c.is_element() && c.tag_name().name() == tag)
                .map(|c| port(c, line(c)))
                .collect()
        };
        let node = |n: roxmltree::Node| RawNode {
            category: n.tag_name().name().to_string(),
            name: n.attribute("name").unwrap_or("").to_string(),
            ty: n.attribute("type").map(str::to_string),
            inputs: children(n, "input"),
            line: line(n),
        };
        let mut doc = Document {
            file: file.to_string(),
            ..Default::default()
        };
        for e in root.children().filter(|c| c.is_element()) {
            match e.tag_name().name() {
                "nodegraph" => doc.graphs.push(RawGraph {
                    name: e.attribute("name").unwrap_or("").to_string(),
                    nodedef: e.attribute("nodedef").map(str::to_string),
                    inputs: children(e, "input"),
                    outputs: children(e, "output"),
                    nodes: e
                        .children()
                        .filter(|c| c.is_element() && !NOT_NODES.contains(&c.tag_name().name()))
                        .map(node)
                        .collect(),
                    line: line(e),
                }),
                "nodedef" => doc.nodedefs.push(RawNodeDef {
                    name: e.attribute("name").unwrap_or("").to_string(),
                    node: e.attribute("node").unwrap_or("").to_string(),
                    inputs: children(e, "input"),
                    outputs: children(e, "output"),
                }),
                t if !NOT_NODES.contains(&t) => doc.nodes.push(node(e)),
                _ => {}
            }
        }
        Ok(doc)
    }

    /// Reads and parses a file.
    pub fn load(path: &std::path::Path) -> Result<Document, GraphError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| GraphError::file(&file, format!("cannot read ({e})")))?;
        Document::parse(&file, &text)
    }

    /// Where a filename value `f` of this document points.
    pub fn resolve(&self, f: &str) -> std::path::PathBuf {
        let dir = self.dir.clone().unwrap_or_else(|| {
            std::path::Path::new(&self.file)
                .parent()
                .map(std::path::Path::to_path_buf)
                .unwrap_or_default()
        });
        dir.join(f)
    }

    pub fn graph(&self, name: &str) -> Option<&RawGraph> {
        self.graphs.iter().find(|g| g.name == name)
    }
}

/// Deepest element nesting a document may have: MaterialX documents nest a
/// handful of levels, and the XML parser recurses once per level, so a
/// hostile document nested tens of thousands deep would overflow the stack.
const MAX_XML_DEPTH: usize = 256;

/// The line where `text`'s element nesting first exceeds `max`, if it does,
/// found by a scan of its tags (comments, CDATA sections, processing
/// instructions and declarations skipped; quoted attribute values may hold
/// `>`). Malformed markup is left to the parser.
fn nesting_exceeds(text: &str, max: usize) -> Option<usize> {
    let b = text.as_bytes();
    let skip_to = |from: usize, end: &[u8]| -> usize {
        b[from..]
            .windows(end.len())
            .position(|w| w == end)
            .map_or(b.len(), |p| from + p + end.len())
    };
    let (mut i, mut depth) = (0usize, 0usize);
    while i < b.len() {
        if b[i] != b'<' {
            i += 1;
            continue;
        }
        let rest = &b[i..];
        if rest.starts_with(b"<!--") {
            i = skip_to(i + 4, b"-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i = skip_to(i + 9, b"]]>");
        } else if rest.starts_with(b"<?") {
            i = skip_to(i + 2, b"?>");
        } else if rest.starts_with(b"<!") {
            i = skip_to(i + 2, b">");
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            i = skip_to(i + 2, b">");
        } else {
            // A start tag: to its '>' outside quotes; "/>" closes it at once.
            let mut j = i + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, q @ (b'"' | b'\'')) => quote = Some(q),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            if j >= b.len() || b[j - 1] != b'/' {
                depth += 1;
                if depth > max {
                    return Some(1 + b[..i].iter().filter(|&&c| c == b'\n').count());
                }
            }
            i = j + 1;
        }
    }
    None
}

#[cfg(test)]
mod nesting_tests {
    use super::nesting_exceeds;

    #[test]
    fn counts_open_elements_only() {
        let flat =
            "<?xml version=\"1.0\"?><!-- <a><a> --><m><n a=\"x>y\"/><n/><![CDATA[<a><a>]]></m>";
        assert_eq!(nesting_exceeds(flat, 1), None);
        let deep = format!("<m>\n{}{}</m>", "<a>".repeat(300), "</a>".repeat(300));
        assert_eq!(nesting_exceeds(&deep, 256), Some(2));
        assert_eq!(nesting_exceeds(&deep, 301), None);
    }
}
