//! glTF animations → [`SceneAnimation`] (sampling: `animation.rs`).
//!
//! Errors name the animation and the channel: an unknown target path
//! (checked on the raw JSON, before the `gltf` crate would reject the whole
//! document with a generic message), sampler data that breaks glTF's rules
//! (`Channel::new`), and a channel on a node that has a `matrix`.
//! Morph-target weight channels and channels driving skin joints are
//! refused with one warning per animation.
//!
//! Channels an extension defines (`KHR_animation_pointer`'s `path:
//! "pointer"`, or any target carrying `extensions`) and channels without a
//! target node (glTF 2.0 schema, `animation.channel.target.node`: "When
//! undefined, the animated object MAY be defined by an extension") are
//! removed from the raw JSON before the typed parse, which requires a node
//! and a core path, with one warning per animation naming the extension:
//! the animation's other channels play (an animation left with none loads
//! and stands still). Samplers are kept, so the remaining channels' sampler
//! indices stay valid.

use super::animation::{Animation, Channel, Interpolation, LocalRest, SceneAnimation, TrsPath};
use super::gltf_buffers::AccessorReader;
use super::SceneError;
use glam::{Mat4, Quat, Vec3, Vec4};
use gltf::animation::{Interpolation as GltfInterp, Property};
use std::collections::BTreeSet;
use std::path::Path;

const KNOWN_PATHS: &[&str] = &["translation", "rotation", "scale", "weights"];

/// The target path `KHR_animation_pointer` defines.
const POINTER_PATH: &str = "pointer";
const ANIMATION_POINTER: &str = "KHR_animation_pointer";

fn label(index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) => format!("animation '{n}'"),
        None => format!("animation {index}"),
    }
}

/// Prepares the raw JSON's animations for the typed parse: removes the
/// channels an extension defines or that target no node (module docs), one
/// warning per animation naming the extension(s); rejects a channel whose
/// `target.path` is neither glTF's nor an extension's (no extension on the
/// target: most likely a typo), naming the animation and channel.
pub(crate) fn prepare_animation_json(
    path: &Path,
    root: &mut serde_json::Map<String, serde_json::Value>,
    warnings: &mut Vec<String>,
) -> Result<(), SceneError> {
    let Some(anims) = root.get_mut("animations").and_then(|a| a.as_array_mut()) else {
        return Ok(());
    };
    for (ai, a) in anims.iter_mut().enumerate() {
        let name = a.get("name").and_then(|n| n.as_str()).map(str::to_owned);
        let what = label(ai, name.as_deref());
        let Some(channels) = a.get_mut("channels").and_then(|c| c.as_array_mut()) else {
            continue;
        };
        // Channels dropped for an extension, and for no node and no extension.
        let (mut by_extension, mut nodeless) = (Vec::new(), Vec::new());
        let mut extensions = BTreeSet::new();
        let mut kept = Vec::with_capacity(channels.len());
        for (ci, c) in channels.drain(..).enumerate() {
            // A channel without a target or a path is left to the typed
            // parse (a one-line error: both are required).
            let Some(p) = c
                .pointer("/target/path")
                .and_then(|p| p.as_str())
                .map(str::to_owned)
            else {
                kept.push(c);
                continue;
            };
            let mut exts: Vec<String> = c
                .pointer("/target/extensions")
                .and_then(|e| e.as_object())
                .map(|e| e.keys().cloned().collect())
                .unwrap_or_default();
            if p == POINTER_PATH && !exts.iter().any(|e| e == ANIMATION_POINTER) {
                exts.push(ANIMATION_POINTER.into());
            }
            let core = KNOWN_PATHS.contains(&p.as_str());
            let has_node = c.pointer("/target/node").is_some();
            if core && has_node {
                kept.push(c);
            } else if !exts.is_empty() {
                extensions.extend(exts);
                by_extension.push(ci);
            } else if core {
                nodeless.push(ci);
            } else {
                // Not glTF's path, and no extension claims it: a typo.
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "{what} channel {ci}: unknown target path '{p}' (expected translation, \
                         rotation, scale or weights)"
                    ),
                ));
            }
        }
        *channels = kept;
        let list = |cs: &[usize]| {
            let s = if cs.len() == 1 { "" } else { "s" };
            let l: Vec<String> = cs.iter().map(usize::to_string).collect();
            format!("channel{s} {}", l.join(", "))
        };
        let mut why = Vec::new();
        if !by_extension.is_empty() {
            let names: Vec<String> = extensions.into_iter().collect();
            why.push(format!(
                "{} animate{} through {}, which stereocache does not support",
                list(&by_extension),
                if by_extension.len() == 1 { "s" } else { "" },
                names.join(" and ")
            ));
        }
        if !nodeless.is_empty() {
            why.push(format!(
                "{} target{} no node and no extension defines one",
                list(&nodeless),
                if nodeless.len() == 1 { "s" } else { "" },
            ));
        }
        if !why.is_empty() {
            warnings.push(format!(
                "{}: {what}: {}; those channels are ignored (its other channels play)",
                path.display(),
                why.join("; ")
            ));
        }
    }
    Ok(())
}

/// The file's animations and node hierarchy; `None` when it has none.
pub(crate) fn import_animations(
    doc: &gltf::Document,
    reader: &AccessorReader,
    path: &Path,
    instance_paths: Vec<Vec<u32>>,
    instance_offsets: Vec<Mat4>,
    warnings: &mut Vec<String>,
) -> Result<Option<SceneAnimation>, SceneError> {
    if doc.animations().len() == 0 {
        return Ok(None);
    }
    let mut joint = vec![false; doc.nodes().len()];
    for skin in doc.skins() {
        for j in skin.joints() {
            joint[j.index()] = true;
        }
    }
    // Nodes whose subtree holds a light or a camera: those stay at their
    // rest pose (only mesh instances are re-posed), so an animation that
    // moves one is named in a warning (until session 50 silently static).
    let mut parent = vec![None; doc.nodes().len()];
    for n in doc.nodes() {
        for c in n.children() {
            parent[c.index()] = Some(n.index());
        }
    }
    let mut carries = vec![false; doc.nodes().len()];
    for n in doc
        .nodes()
        .filter(|n| n.light().is_some() || n.camera().is_some())
    {
        let mut at = Some(n.index());
        // Bounded: the importer refuses cycles, but this runs on the raw tree.
        for _ in 0..doc.nodes().len() {
            let Some(i) = at else { break };
            carries[i] = true;
            at = parent[i];
        }
    }
    let nodes: Vec<LocalRest> = doc
        .nodes()
        .map(|n| match n.transform() {
            gltf::scene::Transform::Matrix { matrix } => {
                LocalRest::Matrix(Mat4::from_cols_array_2d(&matrix))
            }
            gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => LocalRest::Trs {
                translation: Vec3::from(translation),
                rotation: Quat::from_array(rotation),
                scale: Vec3::from(scale),
            },
        })
        .collect();
    let mut animations = Vec::new();
    for anim in doc.animations() {
        let what = label(anim.index(), anim.name());
        let mut channels = Vec::new();
        let mut morph = false;
        let mut skinned = false;
        let mut moves_attachment = false;
        for (ci, ch) in anim.channels().enumerate() {
            let err = |m: String| SceneError::invalid(path, format!("{what} channel {ci}: {m}"));
            // The gltf crate does not validate these two indices, and its
            // accessors unwrap them: check the JSON first.
            let json = &doc.as_json().animations[anim.index()].channels[ci];
            let node = json.target.node.value();
            if node >= nodes.len() {
                return Err(err(format!(
                    "targets node {node}, but the file has {} node(s)",
                    nodes.len()
                )));
            }
            let sampler_index = json.sampler.value();
            let n_samplers = anim.samplers().count();
            if sampler_index >= n_samplers {
                return Err(err(format!(
                    "uses sampler {sampler_index}, but the animation has {n_samplers}"
                )));
            }
            let target = ch.target();
            let trs = match target.property() {
                Property::Translation => TrsPath::Translation,
                Property::Rotation => TrsPath::Rotation,
                Property::Scale => TrsPath::Scale,
                Property::MorphTargetWeights => {
                    morph = true;
                    continue;
                }
            };
            if matches!(nodes[node], LocalRest::Matrix(_)) {
                return Err(err(format!(
                    "targets node {node}, which has a matrix (animated nodes must use \
                     translation/rotation/scale)"
                )));
            }
            skinned |= joint[node];
            moves_attachment |= carries[node];
            let sampler = ch.sampler();
            let interpolation = match sampler.interpolation() {
                GltfInterp::Step => Interpolation::Step,
                GltfInterp::Linear => Interpolation::Linear,
                GltfInterp::CubicSpline => Interpolation::CubicSpline,
            };
            let ctx = format!("{what} channel {ci}");
            let times: Vec<f32> = reader
                .read_vec::<1>(&sampler.input(), &format!("{ctx} input"))?
                .into_iter()
                .map(|[t]| t)
                .collect();
            let out = sampler.output();
            let values: Vec<Vec4> = if trs == TrsPath::Rotation {
                reader
                    .read_vec::<4>(&out, &format!("{ctx} output"))?
                    .into_iter()
                    .map(Vec4::from)
                    .collect()
            } else {
                reader
                    .read_vec::<3>(&out, &format!("{ctx} output"))?
                    .into_iter()
                    .map(|v| Vec3::from(v).extend(0.0))
                    .collect()
            };
            let c = Channel::new(node, trs, interpolation, times, values)
                .map_err(|e| err(e.to_string()))?;
            channels.push(c);
        }
        if morph {
            warnings.push(format!(
                "{}: {what} animates morph-target weights, which stereocache does not support; \
                 those channels are ignored (meshes keep their default weights)",
                path.display()
            ));
        }
        if moves_attachment {
            warnings.push(format!(
                "{}: {what} moves a node that carries a light or camera; lights and cameras \
                 stay at their rest pose (only mesh instances are animated)",
                path.display()
            ));
        }
        if skinned {
            warnings.push(format!(
                "{}: {what} drives skin joints; skinning is not supported, so skinned meshes \
                 stay in their bind pose",
                path.display()
            ));
        }
        animations.push(Animation {
            name: anim
                .name()
                .map(str::to_owned)
                .unwrap_or_else(|| format!("animation{}", anim.index())),
            channels,
        });
    }
    let mut a = SceneAnimation {
        nodes,
        instance_paths,
        instance_offsets,
        animations,
        active: Vec::new(),
    };
    a.select(&Default::default())
        .expect("selecting all animations cannot fail");
    Ok(Some(a))
}
