//! Binding material graphs to a scene's materials (issue 17): which graph
//! output feeds which material input. Two forms are read from glTF:
//!
//! * **`KHR_texture_procedurals`** (Khronos draft): MaterialX graphs as JSON
//!   in the document's `extensions.KHR_texture_procedurals.procedurals`, and
//!   on a material's texture reference
//!   `"extensions": {"KHR_texture_procedurals": {"index": G, "output": O}}`
//!   (`output` = index into the graph's `outputs`, optional for a graph with
//!   one output). Slots: `baseColorTexture` (colour, rgb), the packed
//!   `metallicRoughnessTexture` (g = roughness, b = metallic, as the texture),
//!   `normalTexture` (tangent-space normal in [0, 1], as the texture, with
//!   its `scale`) and `emissiveTexture` (rgb). The graph stands in for the
//!   texture: the material's factors multiply it, the fallback texture the
//!   extension requires is not sampled.
//! * **An attached `.mtlx`** in the material's extras:
//!   `"extras": {"materialx": {"file": "bricks.mtlx", "graph": "bricks",
//!   "outputs": {"base_color": "out1"}}}` — `file` relative to the glTF,
//!   `graph` optional when the file has one nodegraph, `outputs` optional:
//!   by default the outputs named `base_color`, `metallic`, `roughness`,
//!   `normal` (world space, as the `normalmap` node gives) and `emission`
//!   feed those inputs (the shipped library's convention, library.rs). Here
//!   the graph is the value: the factors of the bound inputs are set to 1.
//!
//! Graph errors are one line naming the file, the graph and the node;
//! binding errors name the glTF file and the material as well.

use super::codegen::Layout;
use super::document::{Document, RawGraph, RawNode, RawPort};
use super::error::GraphError;
use super::graph::Graph;
use super::types::Type;
use crate::scene::Material;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// A material input a graph output can feed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// rgb, multiplies the base colour factor.
    BaseColor,
    Metallic,
    Roughness,
    /// World-space normal (replaces the shading normal).
    Normal,
    /// Tangent-space normal encoded in [0, 1] like a normal texture.
    NormalTangent,
    /// rgb, multiplies the emissive factor.
    Emission,
}

impl Slot {
    /// Floats the slot reads from the graph's output array.
    pub fn width(self) -> usize {
        match self {
            Slot::Metallic | Slot::Roughness => 1,
            _ => 3,
        }
    }

    /// Bit of `ScGraphOutputs::mask` (shaders/common/material.glsl).
    pub fn bit(self) -> u32 {
        match self {
            Slot::BaseColor => 1,
            Slot::Metallic => 2,
            Slot::Roughness => 4,
            Slot::Normal => 8,
            Slot::NormalTangent => 32,
            Slot::Emission => 16,
        }
    }

    /// The extras form's output name of the slot.
    pub fn output_name(self) -> &'static str {
        match self {
            Slot::BaseColor => "base_color",
            Slot::Metallic => "metallic",
            Slot::Roughness => "roughness",
            Slot::Normal => "normal",
            Slot::NormalTangent => "normal_tangent",
            Slot::Emission => "emission",
        }
    }
}

/// One graph output feeding one material input: floats
/// `float..float + slot.width()` of graph `graph`'s output array (codegen::Layout).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotBind {
    pub slot: Slot,
    pub graph: usize,
    pub float: usize,
}

/// Where a graph came from: an attached `.mtlx` (kept for the glTF writer)
/// or the document's `KHR_texture_procedurals`.
#[derive(Clone, Debug, PartialEq)]
pub enum Origin {
    Mtlx { file: PathBuf, graph: String },
    Procedural(usize),
}

/// A scene's graphs and their bindings. Empty for scenes without graphs.
#[derive(Clone, Debug, Default)]
pub struct SceneGraphs {
    pub graphs: Vec<Graph>,
    pub origins: Vec<Origin>,
    /// (scene material index, its bound inputs), by material index.
    pub materials: Vec<(u32, Vec<SlotBind>)>,
    /// Text of each attached `.mtlx` by its path relative to the glTF (the
    /// writer stores them beside the file it writes).
    pub mtlx_texts: Vec<(PathBuf, String)>,
    /// Whether and how the graphs' outputs are memoized in rendering
    /// (`--memo …`; off by default). Set by the command line, not the file.
    pub memo: crate::materials::memo::MemoSettings,
    /// Materials whose graphs read texture coordinate set 0 (`texcoord`
    /// index 0, glTF TEXCOORD_0 untransformed) from the meshes' second uv
    /// channel (`Mesh::uvs2`) and set 1 from the first (`Mesh::uvs`); the
    /// others read set 0 from `uvs` and set 1 from `uvs2`. The glTF
    /// importer decides it from the channels the material's textures take
    /// (gltf_import.rs `graph_uv_channels`).
    pub uv_swapped: Vec<u32>,
}

impl SceneGraphs {
    pub fn is_empty(&self) -> bool {
        self.materials.is_empty()
    }

    /// The graphs' image nodes, graph by graph in node order: image k of
    /// this list is texture `scene.textures.len() + k` of the scene's GPU
    /// texture list (rt/gpu_scene.rs uploads them after the scene's own).
    pub fn images(&self) -> impl Iterator<Item = &super::image::GraphImage> + '_ {
        self.graphs.iter().flat_map(|g| g.images.iter())
    }

    /// Texture references of the images (as [`SceneGraphs::images`], the
    /// first at texture `first`), per graph.
    pub fn image_refs(&self, first: u32) -> Vec<Vec<crate::scene::TextureRef>> {
        let mut k = first;
        self.graphs
            .iter()
            .map(|g| {
                g.images
                    .iter()
                    .map(|im| {
                        k += 1;
                        crate::scene::TextureRef {
                            texture: k - 1,
                            sampler: im.sampler,
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// Fallbacks the graphs' loading took, one line each.
    pub fn warnings(&self) -> impl Iterator<Item = &String> + '_ {
        self.graphs.iter().flat_map(|g| g.warnings.iter())
    }

    pub fn binds(&self, slot: Slot) -> bool {
        self.materials
            .iter()
            .any(|(_, b)| b.iter().any(|s| s.slot == slot))
    }

    /// The uv sets the graphs bound to `material` read (bit k: set k,
    /// `Graph::uv_sets`).
    pub fn uv_sets_of(&self, material: u32) -> u32 {
        self.of_material(material)
            .iter()
            .map(|b| self.graphs[b.graph].uv_sets())
            .fold(0, |a, b| a | b)
    }

    pub fn of_material(&self, material: u32) -> &[SlotBind] {
        self.materials
            .iter()
            .find(|(m, _)| *m == material)
            .map_or(&[], |(_, b)| b.as_slice())
    }

    /// Attaches the one nodegraph of the `.mtlx` text `text` (stored as
    /// `file`, relative to the glTF) to `material` by the extras form's
    /// output names — what a glTF material's `extras.materialx` does; the
    /// generated scenes use it.
    pub fn attach_mtlx(
        &mut self,
        material: u32,
        m: &mut Material,
        file: &str,
        text: &str,
    ) -> Result<(), GraphError> {
        let doc = Document::parse(file, text)?;
        let name = match doc.graphs.as_slice() {
            [one] => one.name.clone(),
            other => {
                return Err(GraphError::file(
                    file,
                    format!("has {} nodegraphs, not one", other.len()),
                ))
            }
        };
        self.attach_doc(material, m, file, &doc, &name, text, &[])
    }

    #[allow(clippy::too_many_arguments)]
    fn attach_doc(
        &mut self,
        material: u32,
        m: &mut Material,
        file: &str,
        doc: &Document,
        graph: &str,
        text: &str,
        outputs: &[(String, String)],
    ) -> Result<(), GraphError> {
        let origin = Origin::Mtlx {
            file: PathBuf::from(file),
            graph: graph.to_string(),
        };
        let g = self.intern(origin, || Graph::build(doc, graph, &[]))?;
        if !self.mtlx_texts.iter().any(|(p, _)| p == Path::new(file)) {
            self.mtlx_texts
                .push((PathBuf::from(file), text.to_string()));
        }
        self.bind_by_names(material, m, g, outputs)
    }

    /// Index of the graph from `origin`, loading it with `load` the first time.
    fn intern(
        &mut self,
        origin: Origin,
        load: impl FnOnce() -> Result<Graph, GraphError>,
    ) -> Result<usize, GraphError> {
        if let Some(i) = self.origins.iter().position(|o| *o == origin) {
            return Ok(i);
        }
        self.graphs.push(load()?);
        self.origins.push(origin);
        Ok(self.graphs.len() - 1)
    }

    /// Binds `graph` (already interned) to `material` by the extras form's
    /// output names (`outputs`: slot name → output name overrides), and sets
    /// the bound inputs' factors to 1 and their textures off.
    pub fn bind_by_names(
        &mut self,
        material: u32,
        m: &mut Material,
        graph: usize,
        outputs: &[(String, String)],
    ) -> Result<(), GraphError> {
        let g = &self.graphs[graph];
        let layout = Layout::of(g);
        let slots = [
            Slot::BaseColor,
            Slot::Metallic,
            Slot::Roughness,
            Slot::Normal,
            Slot::NormalTangent,
            Slot::Emission,
        ];
        for (k, _) in outputs {
            if !slots.iter().any(|s| s.output_name() == k) {
                return Err(graph_err(
                    g,
                    None,
                    format!(
                        "`{k}` is not a material input (base_color, metallic, roughness, normal, normal_tangent, emission)"
                    ),
                ));
            }
        }
        let mut binds = Vec::new();
        for slot in slots {
            let explicit = outputs.iter().find(|(k, _)| k == slot.output_name());
            let name = explicit.map_or(slot.output_name(), |(_, v)| v.as_str());
            match layout.get(name) {
                Some((ty, float)) => {
                    check_type(g, name, ty, slot)?;
                    binds.push(SlotBind { slot, graph, float });
                }
                None if explicit.is_some() => {
                    return Err(graph_err(g, Some(name), "no such output"));
                }
                None => {}
            }
        }
        if binds.is_empty() {
            return Err(graph_err(
                g,
                None,
                "no output named base_color, metallic, roughness, normal, normal_tangent or emission",
            ));
        }
        if binds.iter().any(|b| b.slot == Slot::Normal)
            && binds.iter().any(|b| b.slot == Slot::NormalTangent)
        {
            return Err(graph_err(
                g,
                None,
                "both `normal` (world space) and `normal_tangent` are bound; bind one",
            ));
        }
        for b in &binds {
            match b.slot {
                Slot::BaseColor => {
                    m.base_color = Vec3::ONE.extend(m.base_color.w);
                    m.base_color_texture = None;
                }
                Slot::Metallic => m.metallic = 1.0,
                Slot::Roughness => m.roughness = 1.0,
                Slot::Normal | Slot::NormalTangent => m.normal_texture = None,
                Slot::Emission => {
                    m.emissive = Vec3::ONE;
                    m.emissive_texture = None;
                }
            }
            if matches!(b.slot, Slot::Metallic | Slot::Roughness) {
                m.metallic_roughness_texture = None;
            }
        }
        self.push(material, binds);
        Ok(())
    }

    fn push(&mut self, material: u32, binds: Vec<SlotBind>) {
        match self.materials.iter_mut().find(|(k, _)| *k == material) {
            Some((_, b)) => {
                b.retain(|x| !binds.iter().any(|y| y.slot == x.slot));
                b.extend(binds);
            }
            None => self.materials.push((material, binds)),
        }
    }
}

fn graph_err(g: &Graph, node: Option<&str>, msg: impl Into<String>) -> GraphError {
    GraphError {
        file: g.file.clone(),
        graph: Some(g.name.clone()),
        node: node.map(str::to_string),
        line: None,
        message: msg.into(),
    }
}

fn check_type(g: &Graph, output: &str, ty: Type, slot: Slot) -> Result<(), GraphError> {
    let ok = match slot {
        Slot::Metallic | Slot::Roughness => ty.width() == 1,
        _ => matches!(ty.width(), 3 | 4),
    };
    if ok {
        Ok(())
    } else {
        let want = match slot {
            Slot::Metallic | Slot::Roughness => "float",
            Slot::Normal | Slot::NormalTangent => "vector3",
            _ => "color3",
        };
        Err(graph_err(
            g,
            Some(output),
            format!(
                "output of type {} cannot feed {} (needs {want})",
                ty.name(),
                slot.output_name()
            ),
        ))
    }
}

fn material_label(i: usize, m: &serde_json::Value) -> String {
    match m.get("name").and_then(|n| n.as_str()) {
        Some(n) if !n.is_empty() => format!("material {i} '{n}'"),
        _ => format!("material {i}"),
    }
}

/// Reads both binding forms from a glTF document's JSON (`gltf_path` locates
/// attached `.mtlx` files and names errors) and applies them to `materials`
/// (glTF material i = `materials[i]`). Errors: `material I 'NAME': <graph error>`.
pub fn from_gltf_json(
    gltf_path: &Path,
    root: &serde_json::Value,
    materials: &mut [Material],
) -> Result<SceneGraphs, String> {
    let mut sg = SceneGraphs::default();
    let Some(ms) = root.get("materials").and_then(|m| m.as_array()) else {
        return Ok(sg);
    };
    let procedurals = root.pointer("/extensions/KHR_texture_procedurals/procedurals");
    let dir = gltf_path.parent().unwrap_or(Path::new("."));
    for (i, mj) in ms.iter().enumerate().take(materials.len()) {
        let label = material_label(i, mj);
        let fail = |e: GraphError| format!("{label}: {e}");
        if let Some(x) = mj.pointer("/extras/materialx") {
            let (file, graph, outputs) = parse_extras(x).map_err(|e| format!("{label}: {e}"))?;
            let path = dir.join(&file);
            let shown = path.display().to_string();
            let text = std::fs::read_to_string(&path)
                .map_err(|e| fail(GraphError::file(&shown, format!("cannot read ({e})"))))?;
            let doc = Document::parse(&shown, &text).map_err(fail)?;
            let name = match graph {
                Some(g) => g,
                None if doc.graphs.len() == 1 => doc.graphs[0].name.clone(),
                None => {
                    return Err(fail(GraphError::file(
                        &doc.file,
                        format!(
                            "has {} nodegraphs; name one in extras.materialx.graph",
                            doc.graphs.len()
                        ),
                    )))
                }
            };
            sg.attach_doc(
                i as u32,
                &mut materials[i],
                &file,
                &doc,
                &name,
                &text,
                &outputs,
            )
            .map_err(fail)?;
        }
        // KHR_texture_procedurals on the texture references.
        let refs = [
            ("/pbrMetallicRoughness/baseColorTexture", "baseColorTexture"),
            (
                "/pbrMetallicRoughness/metallicRoughnessTexture",
                "metallicRoughnessTexture",
            ),
            ("/normalTexture", "normalTexture"),
            ("/emissiveTexture", "emissiveTexture"),
        ];
        let mut binds = Vec::new();
        for (ptr, slot_name) in refs {
            let Some(ext) = mj
                .pointer(ptr)
                .and_then(|t| t.pointer("/extensions/KHR_texture_procedurals"))
            else {
                continue;
            };
            let what = format!("{label}: {slot_name}.extensions.KHR_texture_procedurals");
            let index = ext.get("index").and_then(|v| v.as_u64()).ok_or_else(|| {
                format!("{what}: `index` (into procedurals) is missing or not a number")
            })? as usize;
            let list = procedurals.and_then(|p| p.as_array()).ok_or_else(|| {
                format!(
                    "{what}: the document has no extensions.KHR_texture_procedurals.procedurals"
                )
            })?;
            let pj = list.get(index).ok_or_else(|| {
                format!(
                    "{what}: index {index} is out of range ({} procedurals)",
                    list.len()
                )
            })?;
            let gi = sg
                .intern(Origin::Procedural(index), || {
                    procedural_graph(&gltf_path.display().to_string(), index, pj)
                })
                .map_err(|e| format!("{label}: {e}"))?;
            let g = &sg.graphs[gi];
            let layout = Layout::of(g);
            let out = match ext.get("output") {
                Some(o) => o
                    .as_u64()
                    .map(|o| o as usize)
                    .ok_or_else(|| format!("{what}: `output` is not a number"))?,
                None if layout.outputs.len() == 1 => 0,
                None => {
                    return Err(format!(
                        "{label}: {}",
                        graph_err(
                            g,
                            None,
                            format!(
                                "has {} outputs; {slot_name} must name one with `output`",
                                layout.outputs.len()
                            )
                        )
                    ))
                }
            };
            let (oname, ty, float) = layout.outputs.get(out).cloned().ok_or_else(|| {
                format!(
                    "{label}: {}",
                    graph_err(
                        g,
                        None,
                        format!(
                            "{slot_name} names output {out}, the graph has {}",
                            layout.outputs.len()
                        )
                    )
                )
            })?;
            let slots: &[(Slot, usize)] = match slot_name {
                "baseColorTexture" => &[(Slot::BaseColor, 0)],
                "metallicRoughnessTexture" => &[(Slot::Roughness, 1), (Slot::Metallic, 2)],
                "normalTexture" => &[(Slot::NormalTangent, 0)],
                _ => &[(Slot::Emission, 0)],
            };
            let need3 = if slot_name == "metallicRoughnessTexture" {
                Slot::Emission // any 3-wide slot: the packed tuple needs ≥ 3 channels
            } else {
                slots[0].0
            };
            check_type(g, &oname, ty, need3).map_err(|e| format!("{label}: {e}"))?;
            for &(slot, c) in slots {
                binds.push(SlotBind {
                    slot,
                    graph: gi,
                    float: float + c,
                });
            }
            let m = &mut materials[i];
            match slot_name {
                "baseColorTexture" => m.base_color_texture = None,
                "metallicRoughnessTexture" => m.metallic_roughness_texture = None,
                "normalTexture" => m.normal_texture = None,
                _ => m.emissive_texture = None,
            }
        }
        if !binds.is_empty() {
            sg.push(i as u32, binds);
        }
    }
    Ok(sg)
}

type Extras = (String, Option<String>, Vec<(String, String)>);

fn parse_extras(x: &serde_json::Value) -> Result<Extras, String> {
    let file = x
        .get("file")
        .and_then(|f| f.as_str())
        .ok_or("extras.materialx.file (the .mtlx path) is missing or not a string")?
        .to_string();
    let graph = match x.get("graph") {
        None => None,
        Some(g) => Some(
            g.as_str()
                .ok_or("extras.materialx.graph is not a string")?
                .to_string(),
        ),
    };
    let mut outputs = Vec::new();
    if let Some(o) = x.get("outputs") {
        let o = o
            .as_object()
            .ok_or("extras.materialx.outputs is not an object")?;
        for (k, v) in o {
            let v = v
                .as_str()
                .ok_or(format!("extras.materialx.outputs.{k} is not a string"))?;
            outputs.push((k.clone(), v.to_string()));
        }
    }
    Ok((file, graph, outputs))
}

/// A JSON value as a MaterialX value string (`1, 0.5, 0` for tuples).
fn value_string(v: &serde_json::Value) -> Option<String> {
    match v {
        serde_json::Value::Number(n) => Some(n.to_string()),
        serde_json::Value::Bool(b) => Some(b.to_string()),
        serde_json::Value::String(s) => Some(s.clone()),
        serde_json::Value::Array(a) => a
            .iter()
            .map(|x| x.as_f64().map(|f| f.to_string()))
            .collect::<Option<Vec<_>>>()
            .map(|v| v.join(", ")),
        _ => None,
    }
}

/// One `KHR_texture_procedurals` graph (JSON) as a typed graph: converted
/// to the element records a `.mtlx` gives (`document.rs`) and built by the
/// same code, so the same nodes, checks and errors apply. Connections:
/// `node` (index into `nodes`), `input` (index into the graph's `inputs`),
/// `output` (index into the upstream node's outputs: multi-output nodes are
/// not supported, as in `.mtlx`).
pub fn procedural_graph(
    gltf: &str,
    index: usize,
    pj: &serde_json::Value,
) -> Result<Graph, GraphError> {
    let file = format!("{gltf}: KHR_texture_procedurals procedurals[{index}]");
    let name = pj
        .get("name")
        .and_then(|n| n.as_str())
        .filter(|n| !n.is_empty())
        .map_or_else(|| format!("procedural{index}"), str::to_string);
    let err = |node: Option<String>, msg: String| GraphError {
        file: file.clone(),
        graph: Some(name.clone()),
        node,
        line: None,
        message: msg,
    };
    if let Some(t) = pj.get("nodetype").and_then(|t| t.as_str()) {
        if t != "nodegraph" {
            return Err(err(None, format!("nodetype is `{t}`, not `nodegraph`")));
        }
    }
    let arr = |v: &serde_json::Value, k: &str| -> Vec<serde_json::Value> {
        v.get(k)
            .and_then(|a| a.as_array())
            .cloned()
            .unwrap_or_default()
    };
    let inputs = arr(pj, "inputs");
    let nodes = arr(pj, "nodes");
    let outputs = arr(pj, "outputs");
    let str_of =
        |v: &serde_json::Value, k: &str| v.get(k).and_then(|s| s.as_str()).map(str::to_string);
    let iname =
        |k: usize, v: &serde_json::Value| str_of(v, "name").unwrap_or_else(|| format!("input{k}"));
    let nname =
        |k: usize, v: &serde_json::Value| str_of(v, "name").unwrap_or_else(|| format!("node{k}"));
    // A port with its connection resolved to names.
    let port = |owner: Option<String>,
                p: &serde_json::Value,
                pname: String|
     -> Result<RawPort, GraphError> {
        let mut r = RawPort {
            name: pname,
            ty: str_of(p, "type"),
            colorspace: str_of(p, "colorspace"),
            ..Default::default()
        };
        if p.get("texture").is_some() {
            return Err(err(
                owner.clone(),
                format!(
                    "input `{}` refers to a glTF texture; image inputs take the file as `value` (relative to the glTF)",
                    r.name
                ),
            ));
        }
        if let Some(v) = p.get("value") {
            r.value = Some(value_string(v).ok_or_else(|| {
                err(
                    owner.clone(),
                    format!(
                        "input `{}` has a value that is not a number, tuple or string",
                        r.name
                    ),
                )
            })?);
        }
        if let Some(n) = p.get("node") {
            let k = n
                .as_u64()
                .map(|k| k as usize)
                .filter(|&k| k < nodes.len())
                .ok_or_else(|| {
                    err(
                        owner.clone(),
                        format!(
                            "`{}` connects to node {n}, the graph has {} nodes",
                            r.name,
                            nodes.len()
                        ),
                    )
                })?;
            r.nodename = Some(nname(k, &nodes[k]));
            if let Some(o) = p.get("output") {
                // Index into the upstream node's outputs: 0 of a single-output node is the node itself.
                let outs = arr(&nodes[k], "outputs");
                if o.as_u64() != Some(0) || outs.len() > 1 {
                    r.output = Some(format!("{o}"));
                }
            }
        } else if let Some(n) = p.get("input") {
            let k = n
                .as_u64()
                .map(|k| k as usize)
                .filter(|&k| k < inputs.len())
                .ok_or_else(|| {
                    err(
                        owner.clone(),
                        format!(
                            "`{}` connects to graph input {n}, the graph has {}",
                            r.name,
                            inputs.len()
                        ),
                    )
                })?;
            r.interfacename = Some(iname(k, &inputs[k]));
        }
        Ok(r)
    };
    let mut raw = RawGraph {
        name: name.clone(),
        nodedef: None,
        inputs: Vec::new(),
        nodes: Vec::new(),
        outputs: Vec::new(),
        line: 0,
    };
    for (k, p) in inputs.iter().enumerate() {
        raw.inputs.push(port(None, p, iname(k, p))?);
    }
    for (k, n) in nodes.iter().enumerate() {
        let nn = nname(k, n);
        let category =
            str_of(n, "nodetype").ok_or_else(|| err(Some(nn.clone()), "has no nodetype".into()))?;
        let mut ins = Vec::new();
        for (j, p) in arr(n, "inputs").iter().enumerate() {
            let pn = str_of(p, "name").unwrap_or_else(|| format!("in{j}"));
            ins.push(port(Some(nn.clone()), p, pn)?);
        }
        // A `constant` node may carry its value on the node itself.
        if let Some(v) = n.get("value") {
            let mut p = RawPort {
                name: "value".into(),
                ty: str_of(n, "type"),
                ..Default::default()
            };
            p.value = value_string(v);
            ins.push(p);
        }
        raw.nodes.push(RawNode {
            category,
            name: nn,
            ty: str_of(n, "type"),
            inputs: ins,
            line: 0,
        });
    }
    for (k, o) in outputs.iter().enumerate() {
        let on = str_of(o, "name").unwrap_or_else(|| format!("out{k}"));
        raw.outputs.push(port(None, o, on)?);
    }
    let doc = Document {
        file: file.clone(),
        dir: Some(
            Path::new(gltf)
                .parent()
                .map(Path::to_path_buf)
                .unwrap_or_default(),
        ),
        graphs: vec![raw],
        ..Default::default()
    };
    Graph::build(&doc, &name, &[])
}
