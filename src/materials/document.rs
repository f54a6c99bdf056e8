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
        let line = |n: roxmltree::Node| xml.text_pos_at(n.range().start).row;
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
