//! `EXT_mesh_gpu_instancing`: a node whose mesh is drawn once per element of
//! its instance attributes (TRANSLATION VEC3 float, ROTATION VEC4 float or
//! normalized byte/short quaternion, SCALE VEC3 float; each optional, all of
//! one count). Instance k's transform is node_world × T(k)·R(k)·S(k); the
//! node's children, camera and light are not instanced.
//!
//! The `gltf` crate does not parse the extension, so it is read from the raw
//! JSON (`instancing_json`, before the typed parse) and its accessors through
//! [`AccessorReader`] (`NodeInstancing::transforms`). Attributes whose names
//! start with `_` are application-specific (the extension allows them) and are
//! ignored; malformed data (an attribute that is not an accessor index, a
//! count mismatch, a wrong type, a non-finite value, a zero quaternion) is an
//! error naming the node and the attribute.

use super::gltf_buffers::AccessorReader;
use super::SceneError;
use glam::{Mat4, Quat, Vec3};
use gltf::accessor::DataType;
use std::collections::HashMap;
use std::path::Path;

pub(crate) const INSTANCING_EXTENSION: &str = "EXT_mesh_gpu_instancing";

const ATTRIBUTES: [&str; 3] = ["TRANSLATION", "ROTATION", "SCALE"];

/// One node's instance attributes: accessor indices, checked to exist.
#[derive(Clone, Debug, Default)]
pub(crate) struct NodeInstancing {
    /// TRANSLATION, ROTATION, SCALE.
    trs: [Option<usize>; 3],
    /// An application-specific attribute (`_ID`, …), for the count when the
    /// node has none of TRANSLATION/ROTATION/SCALE.
    other: Option<(String, usize)>,
}

fn node_label(index: usize, node: &serde_json::Value) -> String {
    match node.get("name").and_then(|n| n.as_str()) {
        Some(n) if !n.is_empty() => format!("node {index} '{n}'"),
        _ => format!("node {index}"),
    }
}

/// The instancing of every node that has the extension, from the raw JSON.
/// Unknown attribute names (not TRANSLATION/ROTATION/SCALE, not `_…`) are a
/// warning; an attribute that is not a valid accessor index is an error.
pub(crate) fn instancing_json(
    path: &Path,
    root: &serde_json::Map<String, serde_json::Value>,
    warnings: &mut Vec<String>,
) -> Result<HashMap<usize, NodeInstancing>, SceneError> {
    let mut out = HashMap::new();
    let Some(nodes) = root.get("nodes").and_then(|n| n.as_array()) else {
        return Ok(out);
    };
    let accessors = root
        .get("accessors")
        .and_then(|a| a.as_array())
        .map_or(0, Vec::len);
    for (ni, node) in nodes.iter().enumerate() {
        let Some(ext) = node.pointer(&format!("/extensions/{INSTANCING_EXTENSION}")) else {
            continue;
        };
        let label = node_label(ni, node);
        let err =
            |m: String| SceneError::invalid(path, format!("{label}: {INSTANCING_EXTENSION} {m}"));
        let attrs = ext
            .get("attributes")
            .and_then(|a| a.as_object())
            .ok_or_else(|| err("has no attributes object".into()))?;
        let mut inst = NodeInstancing::default();
        let mut unknown = Vec::new();
        for (name, value) in attrs {
            let index = value
                .as_u64()
                .ok_or_else(|| err(format!("attribute {name} is not an accessor index")))?;
            if index >= accessors as u64 {
                return Err(err(format!(
                    "attribute {name} refers to accessor {index}, but the file has {accessors} \
                     accessors"
                )));
            }
            let index = index as usize;
            match ATTRIBUTES.iter().position(|a| a == name) {
                Some(k) => inst.trs[k] = Some(index),
                None if name.starts_with('_') => {
                    inst.other.get_or_insert((name.clone(), index));
                }
                None => unknown.push(name.as_str()),
            }
        }
        if !unknown.is_empty() {
            warnings.push(format!(
                "{}: {label}: {INSTANCING_EXTENSION} attributes {} are not defined by the \
                 extension; ignored",
                path.display(),
                unknown.join(", ")
            ));
        }
        if inst.trs.iter().all(Option::is_none) && inst.other.is_none() {
            return Err(err(
                "has no attributes (expected TRANSLATION, ROTATION or SCALE)".into(),
            ));
        }
        out.insert(ni, inst);
    }
    Ok(out)
}

impl NodeInstancing {
    /// Per instance, T·R·S (to be applied after the node's world transform).
    /// `label` names the node.
    pub(crate) fn transforms(
        &self,
        reader: &AccessorReader,
        doc: &gltf::Document,
        label: &str,
    ) -> Result<Vec<Mat4>, SceneError> {
        let err = |m: String| {
            SceneError::invalid(reader.path, format!("{label}: {INSTANCING_EXTENSION} {m}"))
        };
        let accessor = |i: usize, name: &str| {
            doc.accessors()
                .nth(i)
                .ok_or_else(|| err(format!("attribute {name}: accessor {i} does not exist")))
        };
        let what = |name: &str| format!("{INSTANCING_EXTENSION} {name} of {label}");
        let mut counts: Vec<(&str, usize)> = Vec::new();
        let mut vec3 = |k: usize| -> Result<Option<Vec<Vec3>>, SceneError> {
            let name = ATTRIBUTES[k];
            let Some(i) = self.trs[k] else {
                return Ok(None);
            };
            let a = accessor(i, name)?;
            if a.data_type() != DataType::F32 {
                return Err(err(format!(
                    "{name} (accessor {i}) has component type {:?}; the extension requires float",
                    a.data_type()
                )));
            }
            let v: Vec<Vec3> = reader
                .read_vec::<3>(&a, &what(name))?
                .into_iter()
                .map(Vec3::from)
                .collect();
            counts.push((name, v.len()));
            Ok(Some(v))
        };
        let translation = vec3(0)?;
        let scale = vec3(2)?;
        let rotation: Option<Vec<Quat>> = match self.trs[1] {
            None => None,
            Some(i) => {
                let a = accessor(i, "ROTATION")?;
                let ok = match a.data_type() {
                    DataType::F32 => true,
                    DataType::I8 | DataType::I16 => a.normalized(),
                    _ => false,
                };
                if !ok {
                    return Err(err(format!(
                        "ROTATION (accessor {i}) has component type {:?}{}; the extension \
                         requires float or normalized byte/short",
                        a.data_type(),
                        if a.normalized() { " (normalized)" } else { "" }
                    )));
                }
                let v = reader.read_vec::<4>(&a, &what("ROTATION"))?;
                counts.push(("ROTATION", v.len()));
                Some(v.into_iter().map(Quat::from_array).collect())
            }
        };
        if counts.is_empty() {
            if let Some((name, i)) = &self.other {
                counts.push((name.as_str(), accessor(*i, name)?.count()));
            }
        }
        let count = counts.first().map_or(0, |c| c.1);
        if counts.iter().any(|c| c.1 != count) {
            let list: Vec<String> = counts.iter().map(|(n, c)| format!("{n} {c}")).collect();
            return Err(err(format!(
                "attributes have different counts ({}); they must be equal",
                list.join(", ")
            )));
        }
        let mut out = Vec::with_capacity(count);
        for k in 0..count {
            let t = translation.as_ref().map_or(Vec3::ZERO, |v| v[k]);
            let s = scale.as_ref().map_or(Vec3::ONE, |v| v[k]);
            for (name, v) in [("TRANSLATION", t), ("SCALE", s)] {
                if !v.is_finite() {
                    return Err(err(format!("{name} of instance {k} is not finite ({v})")));
                }
            }
            let r = match &rotation {
                None => Quat::IDENTITY,
                Some(v) => {
                    let q = v[k];
                    // Unit quaternions per the extension; a nearly-unit one
                    // (quantised) is normalised, a zero or non-finite one refused.
                    match q.is_finite().then(|| q.length()).filter(|&l| l > 1e-6) {
                        Some(l) => q / l,
                        None => {
                            return Err(err(format!(
                                "ROTATION of instance {k} is not a unit quaternion ({q})"
                            )))
                        }
                    }
                }
            };
            out.push(Mat4::from_scale_rotation_translation(s, r, t));
        }
        Ok(out)
    }
}
