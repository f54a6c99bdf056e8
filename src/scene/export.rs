//! Writes a [`Scene`] as glTF 2.0: `NAME.gltf` + `NAME.bin` + one PNG per
//! texture (`NAME_texN.png`, level 0 only; mips are rebuilt on load).
//!
//! Mapping: every `Mesh` becomes a glTF mesh with one primitive (POSITION,
//! NORMAL, TEXCOORD_0, TANGENT and COLOR_0 when present, u32 indices); every `Instance` a
//! node with that mesh and its matrix; every camera a node with a perspective
//! camera; punctual lights go through `KHR_lights_punctual`. Emissive values
//! above 1 are split into `emissiveFactor` ≤ 1 × `KHR_materials_emissive_strength`.
//!
//! Animation (glTF §3.11): a scene whose animation has one node per instance
//! (the generated animated scenes) writes its animated instances as TRS
//! nodes and its animations as samplers and channels on them.
//!
//! Not written: the environment (glTF has no sky or environment map) and
//! every light `--lighting` or default lighting added (all named
//! [`DEFAULT_SUN_NAME`]: the sun of `sun-sky` and the delta light of
//! `directional:` alike), which are the command line's, not the scene's: a
//! loaded file without lights gets default lighting (sun and sky), and
//! another `--lighting` choice has to be given again.
//!
//! All files are written under temporary names and renamed once complete, so
//! an interrupted export never leaves a half-written `.gltf` behind.

use super::animation::{Interpolation, LocalRest, SceneAnimation, TrsPath};
use super::default_lighting::DEFAULT_SUN_NAME;
use super::{AlphaMode, LightKind, Material, Scene, SceneError, TextureRef, TextureSampler};
use glam::{Mat4, Quat, Vec3};
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

/// Percent-encodes a file name for use as a relative URI.
fn uri_escape(name: &str) -> String {
    let mut out = String::new();
    for b in name.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

struct BinWriter {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl BinWriter {
    fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
            "target": target,
        }));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn floats<const N: usize>(&mut self, data: &[[f32; N]], kind: &str, bounds: bool) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        let view = self.view(&bytes, ARRAY_BUFFER);
        let mut acc = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": data.len(),
            "type": kind,
        });
        if bounds {
            let mut lo = [f32::INFINITY; N];
            let mut hi = [f32::NEG_INFINITY; N];
            for v in data {
                for k in 0..N {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
            acc["min"] = json!(lo.to_vec());
            acc["max"] = json!(hi.to_vec());
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, ELEMENT_ARRAY_BUFFER);
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": UNSIGNED_INT,
            "count": data.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }
}

/// The glTF `textures` and `samplers` the materials refer to: texture i
/// (i < the scene's texture count) is scene texture i with the default
/// sampler (sampler 0); a texture reference with another sampler gets a
/// further glTF texture on the same image (one per distinct pair).
struct TextureTable {
    samplers: Vec<TextureSampler>,
    /// (image, sampler) per glTF texture.
    textures: Vec<(u32, usize)>,
}

impl TextureTable {
    fn new(count: usize) -> TextureTable {
        TextureTable {
            samplers: vec![TextureSampler::default()],
            textures: (0..count as u32).map(|i| (i, 0)).collect(),
        }
    }

    fn index(&mut self, t: TextureRef) -> usize {
        let s = match self.samplers.iter().position(|s| *s == t.sampler) {
            Some(s) => s,
            None => {
                self.samplers.push(t.sampler);
                self.samplers.len() - 1
            }
        };
        match self.textures.iter().position(|&p| p == (t.texture, s)) {
            Some(k) => k,
            None => {
                self.textures.push((t.texture, s));
                self.textures.len() - 1
            }
        }
    }
}

/// `swapped`: the material's channels are written as TEXCOORD_1 (Mesh::uvs)
/// and TEXCOORD_0 (Mesh::uvs2), SceneGraphs::uv_swapped.
fn material_json(
    m: &Material,
    swapped: bool,
    used: &mut Vec<&'static str>,
    table: &mut TextureTable,
) -> Value {
    let mut tex = |t: Option<TextureRef>| t.map(|t| json!({ "index": table.index(t) }));
    // An unlit material (its base colour held as emission, Material::unlit)
    // goes back as KHR_materials_unlit where that colour fits a base colour
    // factor (≤ 1); a brighter one is written as the emitter it renders as.
    let as_unlit = m.unlit && m.emissive.max_element() <= 1.0;
    let mut pbr = Map::new();
    if as_unlit {
        pbr.insert(
            "baseColorFactor".into(),
            json!(m.emissive.extend(m.base_color.w).to_array()),
        );
        pbr.insert("metallicFactor".into(), json!(0.0));
        pbr.insert("roughnessFactor".into(), json!(1.0));
        if let Some(t) = tex(m.emissive_texture) {
            pbr.insert("baseColorTexture".into(), t);
        }
    } else {
        pbr.insert("baseColorFactor".into(), json!(m.base_color.to_array()));
        pbr.insert("metallicFactor".into(), json!(m.metallic));
        pbr.insert("roughnessFactor".into(), json!(m.roughness));
        if let Some(t) = tex(m.base_color_texture) {
            pbr.insert("baseColorTexture".into(), t);
        }
    }
    if let Some(t) = tex(m.metallic_roughness_texture) {
        pbr.insert("metallicRoughnessTexture".into(), t);
    }
    let mut out = Map::new();
    out.insert("name".into(), json!(m.name));
    out.insert("pbrMetallicRoughness".into(), Value::Object(pbr));
    if let Some(t) = m.normal_texture {
        out.insert(
            "normalTexture".into(),
            json!({ "index": tex(Some(t)).map(|j| j["index"].clone()), "scale": m.normal_scale }),
        );
    }
    let mut ext = Map::new();
    if as_unlit {
        ext.insert("KHR_materials_unlit".into(), json!({}));
    }
    let peak = if as_unlit {
        0.0
    } else {
        m.emissive.max_element()
    };
    if peak > 0.0 {
        let (factor, strength) = if peak > 1.0 {
            (m.emissive / peak, peak)
        } else {
            (m.emissive, 1.0)
        };
        out.insert("emissiveFactor".into(), json!(factor.to_array()));
        if strength != 1.0 {
            ext.insert(
                "KHR_materials_emissive_strength".into(),
                json!({ "emissiveStrength": strength }),
            );
        }
    }
    if let Some(t) = tex(m.emissive_texture).filter(|_| !as_unlit) {
        out.insert("emissiveTexture".into(), t);
        if peak <= 0.0 {
            // A texture needs a non-zero factor to show; glTF's default is 0.
            out.insert("emissiveFactor".into(), json!([0.0, 0.0, 0.0]));
        }
    }
    match m.alpha_mode {
        AlphaMode::Opaque => {}
        AlphaMode::Mask => {
            out.insert("alphaMode".into(), json!("MASK"));
            out.insert("alphaCutoff".into(), json!(m.alpha_cutoff));
        }
        AlphaMode::Blend => {
            out.insert("alphaMode".into(), json!("BLEND"));
        }
    }
    if m.double_sided {
        out.insert("doubleSided".into(), json!(true));
    }
    if m.transmission > 0.0 || m.transmission_texture.is_some() {
        let mut t = Map::new();
        t.insert("transmissionFactor".into(), json!(m.transmission));
        if let Some(tt) = tex(m.transmission_texture) {
            t.insert("transmissionTexture".into(), tt);
        }
        ext.insert("KHR_materials_transmission".into(), Value::Object(t));
    }
    if !as_unlit
        && (m.specular != 1.0
            || m.specular_color != Vec3::ONE
            || m.specular_texture.is_some()
            || m.specular_color_texture.is_some())
    {
        let mut sp = Map::new();
        sp.insert("specularFactor".into(), json!(m.specular));
        if m.specular_color != Vec3::ONE {
            sp.insert(
                "specularColorFactor".into(),
                json!(m.specular_color.to_array()),
            );
        }
        if let Some(t) = tex(m.specular_texture) {
            sp.insert("specularTexture".into(), t);
        }
        if let Some(t) = tex(m.specular_color_texture) {
            sp.insert("specularColorTexture".into(), t);
        }
        ext.insert("KHR_materials_specular".into(), Value::Object(sp));
    }
    let c = &m.clearcoat;
    if c.factor > 0.0 || c.texture.is_some() {
        let mut cc = Map::new();
        cc.insert("clearcoatFactor".into(), json!(c.factor));
        cc.insert("clearcoatRoughnessFactor".into(), json!(c.roughness));
        if let Some(t) = tex(c.texture) {
            cc.insert("clearcoatTexture".into(), t);
        }
        if let Some(t) = tex(c.roughness_texture) {
            cc.insert("clearcoatRoughnessTexture".into(), t);
        }
        if let Some(t) = c.normal_texture {
            cc.insert(
                "clearcoatNormalTexture".into(),
                json!({ "index": tex(Some(t)).map(|j| j["index"].clone()), "scale": c.normal_scale }),
            );
        }
        ext.insert("KHR_materials_clearcoat".into(), Value::Object(cc));
    }
    if let Some(v) = &m.volume {
        // A volume boundary: any thickness > 0 (stereocache traces the real
        // distance; the factor is for rasterizers).
        let mut vol = Map::new();
        vol.insert("thicknessFactor".into(), json!(1.0));
        vol.insert(
            "attenuationColor".into(),
            json!(v.attenuation_color.to_array()),
        );
        if v.attenuation_distance.is_finite() {
            vol.insert("attenuationDistance".into(), json!(v.attenuation_distance));
        }
        ext.insert("KHR_materials_volume".into(), Value::Object(vol));
    }
    if m.ior != 1.5 {
        ext.insert("KHR_materials_ior".into(), json!({ "ior": m.ior }));
    }
    for k in ext.keys() {
        let name: &'static str = match k.as_str() {
            "KHR_materials_emissive_strength" => "KHR_materials_emissive_strength",
            "KHR_materials_transmission" => "KHR_materials_transmission",
            "KHR_materials_specular" => "KHR_materials_specular",
            "KHR_materials_clearcoat" => "KHR_materials_clearcoat",
            "KHR_materials_volume" => "KHR_materials_volume",
            "KHR_materials_unlit" => "KHR_materials_unlit",
            _ => "KHR_materials_ior",
        };
        if !used.contains(&name) {
            used.push(name);
        }
    }
    if !ext.is_empty() {
        out.insert("extensions".into(), Value::Object(ext));
    }
    let mut out = Value::Object(out);
    // Slots reading the second uv channel (Mesh::uvs2, written as TEXCOORD_1,
    // or the first where `swapped`), and slots reading theirs through a
    // map: its KHR_texture_transform (write_gltf has refused maps that
    // shear).
    for (k, (_, pointer)) in super::gltf_uv::SLOTS.iter().enumerate() {
        let Some(info) = out.pointer_mut(pointer).and_then(Value::as_object_mut) else {
            continue;
        };
        if (m.second_uv_slots & (1 << k) != 0) != swapped {
            info.insert("texCoord".into(), json!(1));
        }
        if let Some(t) = m.uv_affine[k].and_then(|a| a.as_transform()) {
            info.insert(
                "extensions".into(),
                json!({ super::gltf_uv::TEXTURE_TRANSFORM: {
                    "offset": t.offset.to_array(),
                    "rotation": t.rotation,
                    "scale": t.scale.to_array(),
                } }),
            );
            if !used.contains(&super::gltf_uv::TEXTURE_TRANSFORM) {
                used.push(super::gltf_uv::TEXTURE_TRANSFORM);
            }
        }
    }
    out
}

/// The error for a slot whose uv map ([`Material::uv_affine`]) shears:
/// `KHR_texture_transform` has offset, rotation and scale only.
fn check_uv_maps(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    for (i, m) in scene.materials.iter().enumerate() {
        for (k, a) in m.uv_affine.iter().enumerate() {
            if a.is_some_and(|a| a.as_transform().is_none()) {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "material {i} '{}': the {} reads its uv channel through a map that \
                         shears, which KHR_texture_transform cannot express",
                        m.name,
                        super::gltf_uv::SLOTS[k].0
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn matrix(m: &Mat4) -> Value {
    json!(m.to_cols_array())
}

/// A file written under its temporary name through the one output path
/// (`output::AtomicFile`), renamed into place by [`Staged::commit`] once
/// every file of the export is written.
struct Staged(crate::output::AtomicFile);

/// The rest nodes of an animated scene whose glTF nodes are its instances
/// (node i = instance i, as the generated animated scenes are built); `None`
/// for a static scene. An imported node hierarchy cannot be written (yet).
fn animation_nodes<'a>(
    scene: &'a Scene,
    path: &Path,
) -> Result<Option<&'a [LocalRest]>, SceneError> {
    let Some(a) = &scene.animation else {
        return Ok(None);
    };
    let flat = a.nodes.len() == scene.instances.len()
        && a.instance_paths
            .iter()
            .enumerate()
            .all(|(i, p)| p.as_slice() == [i as u32]);
    if !flat {
        return Err(SceneError::invalid(
            path,
            "cannot write the animation of a node hierarchy (only one node per instance)",
        ));
    }
    Ok(Some(&a.nodes))
}

/// glTF `animations` (§3.11): one sampler per channel, key times as SCALAR
/// accessors with min/max, values as VEC3 (translation, scale) or VEC4
/// (rotation x, y, z, w); CUBICSPLINE values keep glTF's (in, value, out) order.
fn animations_json(a: &SceneAnimation, bw: &mut BinWriter) -> Vec<Value> {
    a.animations
        .iter()
        .map(|anim| {
            let mut samplers = Vec::new();
            let mut channels = Vec::new();
            for (k, c) in anim.channels.iter().enumerate() {
                let times: Vec<[f32; 1]> = c.times.iter().map(|&t| [t]).collect();
                let input = bw.floats(&times, "SCALAR", true);
                let output = if c.path == TrsPath::Rotation {
                    let v: Vec<[f32; 4]> = c.values.iter().map(|v| v.to_array()).collect();
                    bw.floats(&v, "VEC4", false)
                } else {
                    let v: Vec<[f32; 3]> =
                        c.values.iter().map(|v| v.truncate().to_array()).collect();
                    bw.floats(&v, "VEC3", false)
                };
                let interpolation = match c.interpolation {
                    Interpolation::Step => "STEP",
                    Interpolation::Linear => "LINEAR",
                    Interpolation::CubicSpline => "CUBICSPLINE",
                };
                samplers.push(
                    json!({ "input": input, "output": output, "interpolation": interpolation }),
                );
                channels.push(
                    json!({ "sampler": k, "target": { "node": c.node, "path": c.path.name() } }),
                );
            }
            json!({ "name": anim.name, "samplers": samplers, "channels": channels })
        })
        .collect()
}

fn write_error(e: crate::output::OutputError) -> SceneError {
    let (path, message) = e.into_parts();
    SceneError::Invalid { path, message }
}

fn stage(dst: PathBuf, bytes: &[u8]) -> Result<Staged, SceneError> {
    let mut f = crate::output::AtomicFile::create(&dst).map_err(write_error)?;
    if let Err(e) = f.write_all(bytes) {
        f.discard();
        return Err(write_error(e));
    }
    Ok(Staged(f))
}

impl Staged {
    fn commit(self) -> Result<(), SceneError> {
        self.0.commit().map_err(write_error)
    }
}

/// Writes `scene` as `path` (`.gltf`) with a sibling `.bin` and PNG textures.
pub fn write_gltf(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .ok_or_else(|| SceneError::invalid(path, "output path needs a UTF-8 file name"))?;
    check_uv_maps(scene, path)?;
    let mut used: Vec<&'static str> = Vec::new();
    let mut staged = Vec::new();

    // Textures → PNG files.
    let mut images = Vec::new();
    for (i, t) in scene.textures.iter().enumerate() {
        let file = format!("{stem}_tex{i}.png");
        let level0 = t.mips.first().cloned().unwrap_or_default();
        let img = image::RgbaImage::from_raw(t.width, t.height, level0).ok_or_else(|| {
            SceneError::invalid(
                path,
                format!("texture {i} '{}': level 0 has the wrong size", t.name),
            )
        })?;
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(|e| {
                SceneError::invalid(
                    path,
                    format!("texture {i} '{}': PNG encoding failed: {e}", t.name),
                )
            })?;
        staged.push(stage(dir.join(&file), &png)?);
        images.push(json!({ "name": t.name, "uri": uri_escape(&file), "mimeType": "image/png" }));
    }
    let mut table = TextureTable::new(scene.textures.len());

    // Geometry → one buffer.
    let mut bw = BinWriter {
        bin: Vec::new(),
        views: Vec::new(),
        accessors: Vec::new(),
    };
    let mut meshes = Vec::new();
    for m in &scene.meshes {
        let pos: Vec<[f32; 3]> = m.positions.iter().map(|v| v.to_array()).collect();
        let nrm: Vec<[f32; 3]> = m.normals.iter().map(|v| v.to_array()).collect();
        let uv: Vec<[f32; 2]> = m.uvs.iter().map(|v| v.to_array()).collect();
        // A material whose graphs read uv set 0 from the second channel
        // (SceneGraphs::uv_swapped) has its channels written the other way
        // round, so TEXCOORD_0 is that set again (material_json names the
        // slots' sets to match).
        let swapped = scene.graphs.uv_swapped.contains(&m.material);
        let (set1, set2) = match swapped {
            true => ("TEXCOORD_1", "TEXCOORD_0"),
            false => ("TEXCOORD_0", "TEXCOORD_1"),
        };
        let mut attributes = Map::new();
        attributes.insert("POSITION".into(), json!(bw.floats(&pos, "VEC3", true)));
        attributes.insert("NORMAL".into(), json!(bw.floats(&nrm, "VEC3", false)));
        attributes.insert(set1.into(), json!(bw.floats(&uv, "VEC2", false)));
        if !m.tangents.is_empty() {
            // A normal texture read through a uv map is written under the
            // map as its transform, and a reader turns supplied tangents by
            // the transform of the texture they serve (the normal
            // texture's, else the clearcoat normal texture's): store them
            // turned back.
            let map = scene.materials.get(m.material as usize).and_then(|mat| {
                let slot = if mat.normal_texture.is_some() {
                    super::gltf_uv::NORMAL_SLOT
                } else {
                    super::gltf_uv::CLEARCOAT_NORMAL_SLOT
                };
                mat.uv_affine[slot].and_then(|a| a.as_transform())
            });
            let tan: Vec<[f32; 4]> = m
                .tangents
                .iter()
                .zip(&m.normals)
                .map(|(t, n)| map.map_or(*t, |tr| tr.tangent_back(*n, *t)).to_array())
                .collect();
            attributes.insert("TANGENT".into(), json!(bw.floats(&tan, "VEC4", false)));
        }
        if !m.colors.is_empty() {
            let col: Vec<[f32; 4]> = m.colors.iter().map(|v| v.to_array()).collect();
            attributes.insert("COLOR_0".into(), json!(bw.floats(&col, "VEC4", false)));
        }
        // The second uv channel as TEXCOORD_1 (its material's slots that
        // read it name texCoord 1: material_json), or TEXCOORD_0 (above).
        if !m.uvs2.is_empty() {
            let uv2: Vec<[f32; 2]> = m.uvs2.iter().map(|v| v.to_array()).collect();
            attributes.insert(set2.into(), json!(bw.floats(&uv2, "VEC2", false)));
        }
        let indices = bw.indices(&m.indices);
        meshes.push(json!({
            "name": m.name,
            "primitives": [{
                "attributes": attributes,
                "indices": indices,
                "material": m.material,
                "mode": 4,
            }],
        }));
    }

    // Nodes: instances, cameras, lights.
    let anim_nodes = animation_nodes(scene, path)?;
    let mut nodes = Vec::new();
    for (i, inst) in scene.instances.iter().enumerate() {
        let mut n = json!({ "name": inst.name, "mesh": inst.mesh });
        if let Some(LocalRest::Trs {
            translation,
            rotation,
            scale,
        }) = anim_nodes.map(|a| a[i])
        {
            // An animated node: TRS (glTF §5.25 forbids animating a matrix).
            n["translation"] = json!(translation.to_array());
            n["rotation"] = json!(rotation.to_array());
            n["scale"] = json!(scale.to_array());
        } else if inst.transform != Mat4::IDENTITY {
            n["matrix"] = matrix(&inst.transform);
        }
        nodes.push(n);
    }
    let mut cameras = Vec::new();
    for c in &scene.cameras {
        nodes.push(
            json!({ "name": c.name, "camera": cameras.len(), "matrix": matrix(&c.transform) }),
        );
        if let Some(mag) = c.orthographic {
            // zfar is required by glTF; a ray tracer has no far plane.
            let o = json!({ "xmag": mag.x, "ymag": mag.y, "znear": c.znear, "zfar": f32::MAX });
            cameras.push(json!({ "name": c.name, "type": "orthographic", "orthographic": o }));
            continue;
        }
        let mut p = json!({ "yfov": c.yfov, "znear": c.znear });
        if let Some(a) = c.aspect {
            p["aspectRatio"] = json!(a);
        }
        cameras.push(json!({ "name": c.name, "type": "perspective", "perspective": p }));
    }
    let mut lights = Vec::new();
    for l in scene.lights.iter().filter(|l| l.name != DEFAULT_SUN_NAME) {
        let intensity = l.radiant.max_element().max(0.0);
        let color = if intensity > 0.0 {
            l.radiant / intensity
        } else {
            Vec3::ONE
        };
        let mut j = json!({ "name": l.name, "color": color.to_array(), "intensity": intensity });
        match l.kind {
            LightKind::Point => j["type"] = json!("point"),
            LightKind::Spot {
                inner_cone,
                outer_cone,
            } => {
                j["type"] = json!("spot");
                j["spot"] = json!({ "innerConeAngle": inner_cone, "outerConeAngle": outer_cone });
            }
            LightKind::Directional { .. } => j["type"] = json!("directional"),
        }
        if let Some(r) = l.range {
            j["range"] = json!(r);
        }
        // Orient the node's −Z along the light direction.
        let dir = l.direction.try_normalize().unwrap_or(Vec3::NEG_Y);
        let rot = Quat::from_rotation_arc(Vec3::NEG_Z, dir);
        let m = Mat4::from_rotation_translation(rot, l.position);
        nodes.push(json!({
            "name": l.name,
            "matrix": matrix(&m),
            "extensions": { "KHR_lights_punctual": { "light": lights.len() } },
        }));
        lights.push(j);
    }
    if !lights.is_empty() {
        used.push("KHR_lights_punctual");
    }

    let mut materials: Vec<Value> = scene
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let swapped = scene.graphs.uv_swapped.contains(&(i as u32));
            material_json(m, swapped, &mut used, &mut table)
        })
        .collect();
    // Material graphs attached as .mtlx files (materials::binding's extras
    // form) are written as such, the files beside the glTF. Graphs read from
    // KHR_texture_procedurals are not written (the factors remain).
    for (mi, binds) in &scene.graphs.materials {
        let origin = binds.first().map(|b| &scene.graphs.origins[b.graph]);
        if let Some(crate::materials::binding::Origin::Mtlx { file, graph }) = origin {
            materials[*mi as usize]["extras"] = json!({ "materialx": {
                "file": file.to_string_lossy().replace('\\', "/"),
                "graph": graph,
            } });
        }
    }
    for (file, text) in &scene.graphs.mtlx_texts {
        let dst = dir.join(file);
        if let Some(parent) = dst.parent() {
            std::fs::create_dir_all(parent).map_err(|e| SceneError::write(parent, e))?;
        }
        staged.push(stage(dst, text.as_bytes())?);
    }
    // The image files the attached documents read (MaterialX `image`
    // nodes), copied to the same place relative to the written document;
    // an absolute filename stays where it is.
    let mut copied: Vec<PathBuf> = Vec::new();
    for (g, origin) in scene.graphs.graphs.iter().zip(&scene.graphs.origins) {
        let crate::materials::binding::Origin::Mtlx { file, .. } = origin else {
            continue;
        };
        for im in &g.images {
            if Path::new(&im.file).is_absolute() {
                continue;
            }
            let dst = dir.join(file).parent().unwrap_or(dir).join(&im.file);
            if copied.contains(&dst) || dst == im.path {
                continue;
            }
            let bytes = std::fs::read(&im.path).map_err(|e| SceneError::io(&im.path, e))?;
            if let Some(parent) = dst.parent() {
                std::fs::create_dir_all(parent).map_err(|e| SceneError::write(parent, e))?;
            }
            staged.push(stage(dst.clone(), &bytes)?);
            copied.push(dst);
        }
    }

    let animations = scene
        .animation
        .as_ref()
        .map(|a| animations_json(a, &mut bw));
    let bin_file = format!("{stem}.bin");
    let mut root = json!({
        "asset": { "version": "2.0", "generator": concat!("stereocache ", env!("CARGO_PKG_VERSION")) },
        "scene": 0,
        "scenes": [{ "name": stem, "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": bw.accessors,
        "bufferViews": bw.views,
        "buffers": [{ "uri": uri_escape(&bin_file), "byteLength": bw.bin.len() }],
    });
    if !cameras.is_empty() {
        root["cameras"] = json!(cameras);
    }
    if let Some(a) = animations {
        root["animations"] = json!(a);
    }
    if !images.is_empty() {
        root["images"] = json!(images);
        let textures: Vec<Value> = table
            .textures
            .iter()
            .map(|&(source, sampler)| json!({ "source": source, "sampler": sampler }))
            .collect();
        root["textures"] = json!(textures);
        // Sampler 0: repeat wrapping, trilinear filtering (the default).
        let samplers: Vec<Value> = table.samplers.iter().map(|s| s.to_gltf_json()).collect();
        root["samplers"] = json!(samplers);
    }
    if !lights.is_empty() {
        root["extensions"] = json!({ "KHR_lights_punctual": { "lights": lights } });
    }
    if !used.is_empty() {
        used.sort_unstable();
        root["extensionsUsed"] = json!(used);
    }
    let text = serde_json::to_string_pretty(&root)
        .map_err(|e| SceneError::invalid(path, format!("cannot serialise glTF JSON: {e}")))?;
    staged.push(stage(dir.join(&bin_file), &bw.bin)?);
    let gltf = stage(path.to_path_buf(), text.as_bytes())?;
    for s in staged {
        s.commit()?;
    }
    gltf.commit()
}
