//! The typed node IR of one nodegraph: every node resolved to a standard-
//! library signature (overload chosen by its output type and its inputs'
//! types), every input a constant, a geometric property or an earlier node,
//! nodes in topological order from the outputs (depth-first, as the thesis's
//! compiler orders its SSA function, §4.2); nodes the outputs do not reach are
//! dropped. Nodes whose inputs are all constants are folded into constants
//! (so sin/cos of a constant `place2d` rotation are evaluated once, on the
//! CPU, and the GPU sees the same numbers as the oracle).
//!
//! Restrictions (errors, documented in docs/MATERIALS.md): `integer`,
//! `string` and `filename` inputs must be constants; an input may not use
//! `channels` or connect to another nodegraph; multi-output nodes are not in
//! the subset.

use super::document::{Document, RawGraph, RawPort};
use super::error::GraphError;
use super::eval;
use super::image::{self, GraphImage};
use super::signatures::{self, Sig};
use super::types::{Type, Value};
use std::collections::HashMap;

/// Longest chain of nodes, each reading the next, a graph may have. Real
/// material graphs chain tens of nodes; placing one recurses per link, so a
/// chain of thousands (a hostile document) would overflow the stack.
const MAX_CHAIN: usize = 512;

/// A geometric property a graph reads (MaterialX `defaultgeomprop` names
/// and the texcoord/position/normal/tangent nodes by their `space`).
/// MaterialX's spaces: "world"; "object", the geometry's own coordinates
/// before its transforms to world (here a glTF node's mesh space, or the
/// generators' `add_mesh` space: the instance's `object_to_world` taken
/// back, shaders `sc_graph_object_space`); and "model", object space before
/// local deformations, which is object space here (no skinning or morph
/// targets reach the renderer). Object space is the default of the
/// position/normal/tangent nodes and of the 3D noises' position, so a
/// solid texture sticks to an instanced or animated mesh.
///
/// `Uv` is texture coordinate set 0 and `Uv1` set 1 (the `texcoord`
/// node's `index`; glTF's TEXCOORD_0 and TEXCOORD_1, untransformed:
/// binding.rs `SceneGraphs::uv_swapped` says which mesh channel holds
/// each).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GeomProp {
    Uv,
    Uv1,
    Position,
    Normal,
    Tangent,
    Bitangent,
    PositionObject,
    NormalObject,
    TangentObject,
    BitangentObject,
}

impl GeomProp {
    pub fn from_name(s: &str) -> Option<GeomProp> {
        Some(match s {
            "UV0" => GeomProp::Uv,
            "UV1" => GeomProp::Uv1,
            "Pworld" => GeomProp::Position,
            "Nworld" => GeomProp::Normal,
            "Tworld" => GeomProp::Tangent,
            "Bworld" => GeomProp::Bitangent,
            "Pobject" | "Pmodel" => GeomProp::PositionObject,
            "Nobject" | "Nmodel" => GeomProp::NormalObject,
            "Tobject" | "Tmodel" => GeomProp::TangentObject,
            "Bobject" | "Bmodel" => GeomProp::BitangentObject,
            _ => return None,
        })
    }

    pub fn ty(self) -> Type {
        match self {
            GeomProp::Uv | GeomProp::Uv1 => Type::Vector2,
            _ => Type::Vector3,
        }
    }

    /// Whether it is an object-space value (the instance's transform taken back).
    pub fn is_object(self) -> bool {
        matches!(
            self,
            GeomProp::PositionObject
                | GeomProp::NormalObject
                | GeomProp::TangentObject
                | GeomProp::BitangentObject
        )
    }
}

/// The spaces the `space` input of position/normal/tangent may name.
const SPACES: [&str; 3] = ["model", "object", "world"];

#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    Const(Value),
    /// A string or filename constant.
    Str(String),
    Geom(GeomProp),
    /// An earlier node of `Graph::nodes`.
    Node(usize),
}

#[derive(Clone, Debug)]
pub struct Node {
    pub name: String,
    pub sig: &'static Sig,
    /// One source per signature input, in signature order.
    pub inputs: Vec<Source>,
}

impl Node {
    pub fn ty(&self) -> Type {
        self.sig.out
    }
    pub fn op(&self) -> &'static str {
        self.sig.node
    }

    /// The geometric property a `texcoord` node reads, by its `index`
    /// (checked at build: 0 or 1), or a `position`, `normal` or `tangent`
    /// node, by its `space` input (checked at build: one of [`SPACES`]).
    pub fn geom_prop(&self) -> Option<GeomProp> {
        if self.op() == "texcoord" {
            return Some(match self.int_input("index") {
                Some(1) => GeomProp::Uv1,
                _ => GeomProp::Uv,
            });
        }
        let (world, object) = match self.op() {
            "position" => (GeomProp::Position, GeomProp::PositionObject),
            "normal" => (GeomProp::Normal, GeomProp::NormalObject),
            "tangent" => (GeomProp::Tangent, GeomProp::TangentObject),
            _ => return None,
        };
        Some(match self.str_input("space") {
            Some("world") => world,
            _ => object,
        })
    }

    /// The constant integer of input `name`, if it has one.
    pub fn int_input(&self, name: &str) -> Option<i32> {
        let (k, _, _) = self.sig.input(name)?;
        match &self.inputs[k] {
            Source::Const(v) => Some(v.v[0] as i32),
            _ => None,
        }
    }

    /// The constant string of input `name`, if it has one.
    pub fn str_input(&self, name: &str) -> Option<&str> {
        let (k, _, _) = self.sig.input(name)?;
        match &self.inputs[k] {
            Source::Str(s) => Some(s),
            _ => None,
        }
    }
}

#[derive(Clone, Debug)]
pub struct Output {
    pub name: String,
    pub ty: Type,
    pub source: Source,
}

/// A typed, ordered nodegraph: a function (uv, position, normal, tangent and
/// its handedness) -> outputs.
#[derive(Clone, Debug)]
pub struct Graph {
    pub file: String,
    pub name: String,
    pub nodes: Vec<Node>,
    pub outputs: Vec<Output>,
    /// The image nodes' files (image.rs), in node order.
    pub images: Vec<GraphImage>,
    /// Fallbacks taken while loading (e.g. a cubic filter read as linear),
    /// each naming the file, graph and node.
    pub warnings: Vec<String>,
}

impl Graph {
    /// The image of node `i` (an `image` node).
    pub fn image_of(&self, i: usize) -> Option<(usize, &GraphImage)> {
        self.images.iter().enumerate().find(|(_, im)| im.node == i)
    }

    /// Whether the graph's outputs are a function of uv set 0 alone: no
    /// node reads the position, normal, tangent, bitangent or uv set 1,
    /// directly or through a default geometric property (heighttonormal
    /// differentiates its height input in uv, so it reads geometry only if
    /// that input does; normalmap's N and T inputs are default geometric
    /// properties). Only such graphs can be memoized by texel (thesis
    /// §5.3.2's key, the mesh's first uv channel).
    pub fn reads_only_uv(&self) -> bool {
        let other = |s: &Source| matches!(s, Source::Geom(g) if *g != GeomProp::Uv);
        self.nodes.iter().all(|n| {
            !matches!(n.op(), "position" | "normal" | "tangent" | "bitangent")
                && n.geom_prop() != Some(GeomProp::Uv1)
                && !n.inputs.iter().any(other)
        }) && !self.outputs.iter().any(|o| other(&o.source))
    }

    /// The uv sets the graph reads: bit k for `texcoord` index k (or the
    /// default geometric property UV0/UV1 of an input).
    pub fn uv_sets(&self) -> u32 {
        let bit = |g: GeomProp| match g {
            GeomProp::Uv => 1,
            GeomProp::Uv1 => 2,
            _ => 0,
        };
        let of = |s: &Source| match s {
            Source::Geom(g) => bit(*g),
            _ => 0,
        };
        self.nodes
            .iter()
            .map(|n| n.geom_prop().map_or(0, bit) | n.inputs.iter().map(of).fold(0, |a, b| a | b))
            .chain(self.outputs.iter().map(|o| of(&o.source)))
            .fold(0, |a, b| a | b)
    }

    /// Whether any node reads an object-space property (the hit shaders
    /// then take the world values back through the instance's transform,
    /// scene_shaders.rs; other scenes compile none of it).
    pub fn reads_object_space(&self) -> bool {
        let object = |s: &Source| matches!(s, Source::Geom(g) if g.is_object());
        self.nodes
            .iter()
            .any(|n| n.geom_prop().is_some_and(GeomProp::is_object) || n.inputs.iter().any(object))
            || self.outputs.iter().any(|o| object(&o.source))
    }

    pub fn output(&self, name: &str) -> Option<&Output> {
        self.outputs.iter().find(|o| o.name == name)
    }

    /// The type of a source.
    pub fn source_ty(&self, s: &Source) -> Type {
        match s {
            Source::Const(v) => v.ty,
            Source::Str(_) => Type::String,
            Source::Geom(g) => g.ty(),
            Source::Node(i) => self.nodes[*i].ty(),
        }
    }

    /// Loads graph `name` of `doc`; `libs` supply nodedefs (interfaces of graphs that implement one).
    pub fn build(doc: &Document, name: &str, libs: &[&Document]) -> Result<Graph, GraphError> {
        let raw = doc
            .graph(name)
            .ok_or_else(|| GraphError::file(&doc.file, format!("no nodegraph named `{name}`")))?;
        Builder::new(doc, raw, libs)?.run()
    }

    /// Every nodegraph of a document.
    pub fn build_all(doc: &Document, libs: &[&Document]) -> Result<Vec<Graph>, GraphError> {
        doc.graphs
            .iter()
            .map(|g| Graph::build(doc, &g.name, libs))
            .collect()
    }
}

/// What an interface input resolves to.
enum Iface {
    Value(Source),
}

struct Builder<'a> {
    doc: &'a Document,
    raw: &'a RawGraph,
    iface: HashMap<String, (Option<Type>, Iface)>,
    by_name: HashMap<&'a str, usize>,
    /// raw index -> its source once placed (a node or a folded constant).
    placed: HashMap<usize, Source>,
    on_stack: Vec<usize>,
    nodes: Vec<Node>,
    images: Vec<GraphImage>,
    warnings: Vec<String>,
}

impl<'a> Builder<'a> {
    fn err(&self, node: Option<&str>, line: u32, msg: impl Into<String>) -> GraphError {
        GraphError {
            file: self.doc.file.clone(),
            graph: Some(self.raw.name.clone()),
            node: node.map(str::to_string),
            line: Some(line),
            message: msg.into(),
        }
    }

    fn new(
        doc: &'a Document,
        raw: &'a RawGraph,
        libs: &[&'a Document],
    ) -> Result<Self, GraphError> {
        let mut b = Builder {
            doc,
            raw,
            iface: HashMap::new(),
            by_name: HashMap::new(),
            placed: HashMap::new(),
            on_stack: Vec::new(),
            nodes: Vec::new(),
            images: Vec::new(),
            warnings: Vec::new(),
        };
        // The interface: the implemented nodedef's inputs (defaults), then the graph's own inputs.
        if let Some(nd) = &raw.nodedef {
            let def = std::iter::once(doc)
                .chain(libs.iter().copied())
                .flat_map(|d| d.nodedefs.iter())
                .find(|d| &d.name == nd)
                .ok_or_else(|| b.err(None, raw.line, format!("nodedef `{nd}` not found")))?;
            for p in &def.inputs {
                let v = b.constant_port(None, p)?;
                b.iface.insert(
                    p.name.clone(),
                    (p.ty.as_deref().and_then(Type::from_name), Iface::Value(v)),
                );
            }
        }
        for p in &raw.inputs {
            let v = b.constant_port(None, p)?;
            b.iface.insert(
                p.name.clone(),
                (p.ty.as_deref().and_then(Type::from_name), Iface::Value(v)),
            );
        }
        for (i, n) in raw.nodes.iter().enumerate() {
            if b.by_name.insert(n.name.as_str(), i).is_some() {
                return Err(b.err(Some(&n.name), n.line, "two nodes have this name"));
            }
        }
        Ok(b)
    }

    /// A constant port (interface input): its value or default geometric property.
    fn constant_port(&self, node: Option<&str>, p: &RawPort) -> Result<Source, GraphError> {
        let ty = p.ty.as_deref().unwrap_or("");
        let ty = Type::from_name(ty).ok_or_else(|| {
            self.err(
                node,
                p.line,
                format!("input `{}`: unsupported type `{ty}`", p.name),
            )
        })?;
        if let Some(g) = &p.defaultgeomprop {
            if p.value.is_none() {
                return GeomProp::from_name(g).map(Source::Geom).ok_or_else(|| {
                    self.err(
                        node,
                        p.line,
                        format!("input `{}`: unknown geometric property `{g}`", p.name),
                    )
                });
            }
        }
        self.parse_value(node, p, ty, p.value.as_deref().unwrap_or(""))
    }

    fn parse_value(
        &self,
        node: Option<&str>,
        p: &RawPort,
        ty: Type,
        s: &str,
    ) -> Result<Source, GraphError> {
        if matches!(ty, Type::String | Type::Filename) {
            return Ok(Source::Str(s.to_string()));
        }
        if s.trim().is_empty() {
            // A `value` written but empty is no number: refused (it read as
            // 0 until session 52, e.g. a fractal of 0 octaves, without a
            // word; an audit's finding). No `value` at all keeps zeros.
            if p.value.is_some() {
                return Err(self.err(
                    node,
                    p.line,
                    format!("input `{}`: bad {ty} value: empty", p.name),
                ));
            }
            return Ok(Source::Const(Value::new(ty, &[])));
        }
        Value::parse(ty, s).map(Source::Const).map_err(|e| {
            self.err(
                node,
                p.line,
                format!("input `{}`: bad {ty} value: {e}", p.name),
            )
        })
    }

    fn run(mut self) -> Result<Graph, GraphError> {
        let raw = self.raw;
        if raw.outputs.is_empty() {
            return Err(self.err(None, raw.line, "the nodegraph has no outputs"));
        }
        let mut outputs = Vec::new();
        for o in &raw.outputs {
            let ty =
                o.ty.as_deref()
                    .and_then(Type::from_name)
                    .filter(|t| t.is_varying())
                    .ok_or_else(|| {
                        self.err(
                            None,
                            o.line,
                            format!(
                                "output `{}`: unsupported type `{}`",
                                o.name,
                                o.ty.as_deref().unwrap_or("")
                            ),
                        )
                    })?;
            let source = self.connect(None, o, ty)?;
            outputs.push(Output {
                name: o.name.clone(),
                ty,
                source,
            });
        }
        Ok(Graph {
            file: self.doc.file.clone(),
            name: raw.name.clone(),
            nodes: self.nodes,
            outputs,
            images: self.images,
            warnings: self.warnings,
        })
    }

    /// The source of port `p` (of `node`, or a graph output), whose type must be `want`.
    fn connect(
        &mut self,
        node: Option<&str>,
        p: &RawPort,
        want: Type,
    ) -> Result<Source, GraphError> {
        if let Some(a) = &p.unsupported {
            return Err(self.err(
                node,
                p.line,
                format!("input `{}`: attribute `{a}` is not supported", p.name),
            ));
        }
        if let Some(g) = &p.nodegraph {
            return Err(self.err(
                node,
                p.line,
                format!(
                    "input `{}`: connections to other nodegraphs (`{g}`) are not supported",
                    p.name
                ),
            ));
        }
        let src = if let Some(up) = &p.nodename {
            if p.output.is_some() {
                return Err(self.err(
                    node,
                    p.line,
                    format!(
                        "input `{}`: node `{up}` has one output; `output=` is not supported",
                        p.name
                    ),
                ));
            }
            let Some(&ri) = self.by_name.get(up.as_str()) else {
                return Err(self.err(
                    node,
                    p.line,
                    format!(
                        "missing input: `{}` refers to node `{up}`, which is not in the graph",
                        p.name
                    ),
                ));
            };
            self.place(ri)?
        } else if let Some(i) = &p.interfacename {
            match self.iface.get(i) {
                Some((_, Iface::Value(v))) => v.clone(),
                None => return Err(self.err(node, p.line, format!("missing input: `{}` refers to interface input `{i}`, which the graph does not declare", p.name))),
            }
        } else if let Some(v) = &p.value {
            self.parse_value(node, p, want, v)?
        } else {
            return Err(self.err(
                node,
                p.line,
                format!(
                    "missing input: `{}` has no value, node or interface connection",
                    p.name
                ),
            ));
        };
        let got = match &src {
            Source::Str(_) if matches!(want, Type::String | Type::Filename) => want,
            s => self.ty_of(s),
        };
        // Types must be equal, as MaterialX's validate() requires ("Mismatched
        // types in port connection", "Interface name refers to value element
        // of a different type"): a vector3 into a color3 (same width) or an
        // integer interface input into a float is refused; `convert` changes
        // a type.
        if got != want {
            let what = if node.is_some() { "input" } else { "output" };
            return Err(self.err(
                node,
                p.line,
                format!(
                    "bad type: {what} `{}` is {want}, its source is {got} (mismatched types in a connection; use a `convert` node)",
                    p.name
                ),
            ));
        }
        if !want.is_varying() && !matches!(src, Source::Const(_) | Source::Str(_)) {
            return Err(self.err(
                node,
                p.line,
                format!("input `{}` ({want}) must be a constant", p.name),
            ));
        }
        Ok(match src {
            Source::Const(v) => Source::Const(Value { ty: want, ..v }),
            s => s,
        })
    }

    fn ty_of(&self, s: &Source) -> Type {
        match s {
            Source::Const(v) => v.ty,
            Source::Str(_) => Type::String,
            Source::Geom(g) => g.ty(),
            Source::Node(i) => self.nodes[*i].ty(),
        }
    }

    /// Places raw node `ri` (and, first, everything it reads, depth first:
    /// at most [`MAX_CHAIN`] nodes deep); returns its source.
    fn place(&mut self, ri: usize) -> Result<Source, GraphError> {
        if let Some(s) = self.placed.get(&ri) {
            return Ok(s.clone());
        }
        let raw = &self.raw.nodes[ri];
        if let Some(pos) = self.on_stack.iter().position(|&r| r == ri) {
            let mut names: Vec<&str> = self.on_stack[pos..]
                .iter()
                .map(|&r| self.raw.nodes[r].name.as_str())
                .collect();
            names.push(&raw.name);
            return Err(self.err(
                Some(&raw.name),
                raw.line,
                format!("cycle: {}", names.join(" -> ")),
            ));
        }
        let name = raw.name.as_str();
        if !signatures::is_supported(&raw.category) {
            return Err(self.err(
                Some(name),
                raw.line,
                format!(
                    "unknown node `{}` (not in the supported subset of the standard library)",
                    raw.category
                ),
            ));
        }
        let out = raw.ty.as_deref().and_then(Type::from_name).ok_or_else(|| {
            self.err(
                Some(name),
                raw.line,
                format!(
                    "bad type: `{}` is not a supported output type",
                    raw.ty.as_deref().unwrap_or("")
                ),
            )
        })?;
        let sig = self.choose(ri, out)?;
        if self.on_stack.len() >= MAX_CHAIN {
            return Err(self.err(
                Some(name),
                raw.line,
                format!(
                    "reads through a chain of more than {MAX_CHAIN} nodes (the graph is placed recursively, one level per node of a chain)"
                ),
            ));
        }
        self.on_stack.push(ri);
        let mut inputs: Vec<Option<Source>> = vec![None; sig.inputs.len()];
        for p in &raw.inputs {
            let (k, t, _) = sig.input(&p.name).expect("checked by choose");
            inputs[k] = Some(self.connect(Some(name), p, t)?);
        }
        self.on_stack.pop();
        let mut resolved = Vec::with_capacity(inputs.len());
        for (k, s) in inputs.into_iter().enumerate() {
            let (iname, t, d) = sig.inputs[k];
            resolved.push(match s {
                Some(s) => s,
                None => match d.strip_prefix('@') {
                    Some(g) => Source::Geom(GeomProp::from_name(g).ok_or_else(|| {
                        self.err(
                            Some(name),
                            raw.line,
                            format!("input `{iname}`: unknown geometric property `{g}`"),
                        )
                    })?),
                    None if matches!(t, Type::String | Type::Filename) => {
                        Source::Str(d.to_string())
                    }
                    None => Source::Const(Value::parse(t, d).expect("library defaults parse")),
                },
            });
        }
        let node = Node {
            name: raw.name.clone(),
            sig,
            inputs: resolved,
        };
        if let Some(e) = check_node(&node) {
            return Err(self.err(Some(name), raw.line, e));
        }
        // Constant folding: a node with only constant inputs is a constant.
        let constant = node
            .inputs
            .iter()
            .all(|s| matches!(s, Source::Const(_) | Source::Str(_)));
        // Geometry nodes read the surface point, not their (uniform) inputs;
        // an image node reads its file (and the footprint).
        let reads_geometry = matches!(
            sig.node,
            "texcoord" | "position" | "normal" | "tangent" | "heighttonormal" | "image"
        );
        if sig.node == "image" {
            match self.image(ri, &node)? {
                Some(im) => self.images.push(im),
                None => {
                    // The file cannot be read: the node is its `default`
                    // input (MaterialX: "a default value to use if the file
                    // reference can not be resolved"), with a warning.
                    let (k, _, _) = node
                        .sig
                        .input("default")
                        .expect("image has a default input");
                    let src = node.inputs[k].clone();
                    self.placed.insert(ri, src.clone());
                    return Ok(src);
                }
            }
        }
        let src = if constant && !reads_geometry {
            Source::Const(eval::eval_constant(&node))
        } else {
            self.nodes.push(node);
            Source::Node(self.nodes.len() - 1)
        };
        self.placed.insert(ri, src.clone());
        Ok(src)
    }

    /// The file and settings of image node `node` (raw node `ri`), which
    /// becomes `self.nodes[self.nodes.len()]`; None, with a warning, where
    /// the file name is empty or the file cannot be read or decoded (the
    /// node then gives its `default`). Unsupported settings are errors.
    fn image(&mut self, ri: usize, node: &Node) -> Result<Option<GraphImage>, GraphError> {
        let raw = &self.raw.nodes[ri];
        let err = |m: String| self.err(Some(&raw.name), raw.line, m);
        let text = |name: &str| -> String {
            match node.sig.input(name).map(|(k, _, _)| &node.inputs[k]) {
                Some(Source::Str(s)) => s.clone(),
                _ => String::new(),
            }
        };
        let file_port = raw.inputs.iter().find(|p| p.name == "file");
        let attr = |f: fn(&RawPort) -> Option<String>| file_port.and_then(f).unwrap_or_default();
        let colorspace = attr(|p| p.colorspace.clone());
        let set = image::settings(|k| {
            if k == "colorspace" {
                colorspace.clone()
            } else {
                text(k)
            }
        })
        .map_err(err)?;
        let file = format!("{}{}", attr(|p| p.fileprefix.clone()), text("file"));
        let warn = |m: String| {
            format!(
                "{}: graph `{}`, node `{}`: {m}",
                self.doc.file, self.raw.name, raw.name
            )
        };
        let unread = if file.is_empty() {
            Err("input `file` is empty".to_string())
        } else {
            image::read(&self.doc.resolve(&file), set.encoding)
        };
        let texture = match unread {
            Ok(t) => t,
            Err(e) => {
                let w = warn(format!(
                    "{e}; the node gives its `default` input (MaterialX's rule for a file that cannot be read)"
                ));
                self.warnings.push(w);
                return Ok(None);
            }
        };
        let path = self.doc.resolve(&file);
        if let Some(w) = set.warning {
            let w = warn(w);
            self.warnings.push(w);
        }
        Ok(Some(GraphImage {
            node: self.nodes.len(),
            file,
            path,
            texture: std::sync::Arc::new(texture),
            sampler: set.sampler,
            constant: set.constant,
        }))
    }

    /// The overload of raw node `ri` with output `out` whose inputs match the
    /// element's declared input types (and names).
    fn choose(&self, ri: usize, out: Type) -> Result<&'static Sig, GraphError> {
        let raw = &self.raw.nodes[ri];
        let mut any = false;
        let mut last_err = String::new();
        'sig: for s in signatures::candidates(&raw.category, out) {
            any = true;
            for p in &raw.inputs {
                let Some((_, t, _)) = s.input(&p.name) else {
                    last_err = format!("node `{}` has no input `{}`", raw.category, p.name);
                    continue 'sig;
                };
                let declared = match p.ty.as_deref() {
                    Some(d) => Type::from_name(d),
                    None => self.upstream_ty(p),
                };
                if let Some(d) = declared {
                    if d != t {
                        last_err = format!("bad type: input `{}` is {d}, no `{}` signature with output {out} takes that", p.name, raw.category);
                        continue 'sig;
                    }
                }
            }
            return Ok(s);
        }
        let msg = if any {
            last_err
        } else {
            format!(
                "bad type: `{}` has no signature with output type {out}",
                raw.category
            )
        };
        Err(self.err(Some(&raw.name), raw.line, msg))
    }

    /// The declared type of the node an untyped port connects to.
    fn upstream_ty(&self, p: &RawPort) -> Option<Type> {
        let up = p.nodename.as_deref()?;
        let ri = *self.by_name.get(up)?;
        self.raw.nodes[ri].ty.as_deref().and_then(Type::from_name)
    }
}

/// Checks constant inputs the implementations need in range.
fn check_node(n: &Node) -> Option<String> {
    let int = |name: &str| n.int_input(name);
    // (`index` is always a constant: no node outputs an integer, and
    // interface inputs resolve to their values.)
    match n.op() {
        "fractal3d" => int("octaves")
            .filter(|o| !(0..=16).contains(o))
            .map(|o| format!("input `octaves` is {o}; 0 to 16 are supported")),
        // MaterialX's NG_place2d picks by `switch`, which for other values
        // returns neither order but (0, 0); stdlib_defs lists 0 and 1 only.
        "place2d" => int("operationorder")
            .filter(|o| !(0..=1).contains(o))
            .map(|o| format!("input `operationorder` is {o}; 0 (SRT) or 1 (TRS)")),
        "worleynoise2d" | "worleynoise3d" => int("style")
            .filter(|s| !(0..=1).contains(s))
            .map(|s| format!("input `style` is {s}; 0 (distance) or 1 (solid)")),
        // Graphs see two uv sets (MxGeom.uv and uv1: glTF's TEXCOORD_0
        // and TEXCOORD_1); a further set would be silently read as another.
        "texcoord" => int("index").filter(|i| !(0..=1).contains(i)).map(|i| {
            format!(
                "input `index` is {i}: only texture coordinate sets 0 and 1 (glTF TEXCOORD_0 and TEXCOORD_1) reach material graphs"
            )
        }),
        "extract" => int("index")
            .filter(|i| *i < 0 || *i as usize >= n.sig.inputs[0].1.width())
            .map(|i| format!("input `index` {i} is out of range")),
        // One tangent set (the mesh's TANGENT) reaches graphs.
        "tangent" if int("index").is_some_and(|i| i != 0) => Some(format!(
            "input `index` is {}: only tangent set 0 (glTF TANGENT) reaches material graphs",
            int("index").unwrap_or(0)
        )),
        "position" | "normal" | "tangent" => n
            .str_input("space")
            .filter(|s| !SPACES.contains(s))
            .map(|s| format!("input `space` is `{s}`: one of model, object or world")),
        _ => None,
    }
}
