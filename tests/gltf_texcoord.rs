//! glTF texCoord / TEXCOORD_1 and KHR_texture_transform (issue 18), done at
//! import: each primitive's mesh gets the uv set its material's textures
//! name, with the extension's offset, rotation and scale applied.
//!
//! Known answers: the mesh uvs a quad gets are computed by hand from the
//! extension's T · R · S (rotation as the extension's own example, the
//! sample model TextureTransformTest and glTF issue 1563 have it:
//! u' = sx·cos r·u + sy·sin r·v + ox, v' = −sx·sin r·u + sy·cos r·v + oy;
//! the README's literal GLSL listing has the opposite sign, which these
//! values tell apart). On the GPU (lavapipe, validation on), a transformed
//! 2×2 texture shows the texel that uv' predicts, uv' computed here from
//! the hit's position on the quad.

mod common;
use base64::Engine;
use common::*;
use glam::{Vec2, Vec3, Vec4};
use serde_json::{json, Value};
use std::f32::consts::FRAC_PI_2;
use std::path::{Path, PathBuf};
use stereocache::methods::RenderSettings;
use stereocache::rt::RtChoice;
use stereocache::scene::{load_gltf, Scene};

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("gltf_texcoord-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// 2×2 image, row 0 first (glTF v = 0 is the top): red, green / blue, white.
const TEXELS: [[u8; 4]; 4] = [
    [255, 0, 0, 255],
    [0, 255, 0, 255],
    [0, 0, 255, 255],
    [255, 255, 255, 255],
];

fn png_data_uri() -> String {
    let img = image::RgbaImage::from_raw(2, 2, TEXELS.concat()).unwrap();
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png)
    )
}

/// One quad: its rectangle (x0, y0, x1, y1) in z = 0 facing +z, vertex
/// attributes beyond POSITION/NORMAL (name → 4 values), and its material.
struct Quad {
    rect: (f32, f32, f32, f32),
    attrs: Vec<(&'static str, Vec<Vec<f32>>)>,
    material: usize,
}

/// The corner uvs every test quad uses: u along +x, v along −y, 0..1.
fn unit_uvs() -> Vec<Vec<f32>> {
    vec![
        vec![0.0, 1.0],
        vec![1.0, 1.0],
        vec![1.0, 0.0],
        vec![0.0, 0.0],
    ]
}

/// Quad k of a row of three 1 m squares 0.1 m apart.
fn rect(k: usize) -> (f32, f32, f32, f32) {
    let cx = k as f32 * 1.1 - 1.1;
    (cx - 0.5, -0.5, cx + 0.5, 0.5)
}

#[derive(Default)]
struct Buffer {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Buffer {
    /// An f32 accessor of `count` elements of type `ty` over `data`.
    fn floats(
        &mut self,
        data: &[f32],
        ty: &str,
        count: usize,
        minmax: Option<(Vec<f32>, Vec<f32>)>,
    ) -> usize {
        let offset = self.bin.len();
        for x in data {
            self.bin.extend_from_slice(&x.to_le_bytes());
        }
        self.views
            .push(json!({ "buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4 }));
        let mut a = json!({ "bufferView": self.views.len() - 1, "componentType": 5126,
                            "count": count, "type": ty });
        if let Some((lo, hi)) = minmax {
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }
}

/// A glTF of `quads` with `materials`, every texture image 0 through a
/// NEAREST/REPEAT sampler; `extra` is merged into the root.
fn write_doc(
    d: &Path,
    quads: &[Quad],
    materials: Vec<Value>,
    textures: usize,
    extra: Value,
) -> PathBuf {
    let mut b = Buffer::default();
    let mut meshes = Vec::new();
    for q in quads {
        let (x0, y0, x1, y1) = q.rect;
        let pos = [x0, y0, 0.0, x1, y0, 0.0, x1, y1, 0.0, x0, y1, 0.0];
        let mut attributes = serde_json::Map::new();
        attributes.insert(
            "POSITION".into(),
            json!(b.floats(
                &pos,
                "VEC3",
                4,
                Some((vec![x0, y0, 0.0], vec![x1, y1, 0.0]))
            )),
        );
        attributes.insert(
            "NORMAL".into(),
            json!(b.floats(&[0.0, 0.0, 1.0].repeat(4), "VEC3", 4, None)),
        );
        for (name, values) in &q.attrs {
            let ty = if values[0].len() == 2 { "VEC2" } else { "VEC4" };
            let flat: Vec<f32> = values.iter().flatten().copied().collect();
            attributes.insert((*name).into(), json!(b.floats(&flat, ty, 4, None)));
        }
        // 12 bytes of u16 indices keep the next view 4-aligned.
        let offset = b.bin.len();
        for i in [0u16, 1, 2, 0, 2, 3] {
            b.bin.extend_from_slice(&i.to_le_bytes());
        }
        b.views
            .push(json!({ "buffer": 0, "byteOffset": offset, "byteLength": 12 }));
        b.accessors.push(
            json!({ "bufferView": b.views.len() - 1, "componentType": 5123,
                                 "count": 6, "type": "SCALAR" }),
        );
        meshes.push(json!({ "primitives": [{ "attributes": attributes,
            "indices": b.accessors.len() - 1, "material": q.material }] }));
    }
    let n = quads.len();
    let mut root = json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": (0..n).collect::<Vec<_>>() }],
        "nodes": (0..n).map(|k| json!({ "mesh": k })).collect::<Vec<_>>(),
        "meshes": meshes,
        "materials": materials,
        "samplers": [{ "magFilter": 9728, "minFilter": 9728, "wrapS": 10497, "wrapT": 10497 }],
        "textures": (0..textures).map(|_| json!({ "source": 0, "sampler": 0 })).collect::<Vec<_>>(),
        "images": [{ "uri": png_data_uri() }],
        "accessors": b.accessors, "bufferViews": b.views,
        "buffers": [{ "byteLength": b.bin.len(), "uri": format!("data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&b.bin)) }],
    });
    if let (Value::Object(r), Value::Object(e)) = (&mut root, extra) {
        r.extend(e);
    }
    let path = d.join("quads.gltf");
    std::fs::write(&path, serde_json::to_string_pretty(&root).unwrap()).unwrap();
    path
}

/// A double-sided material (no culling warning) with the given texture slots.
fn material(name: &str, slots: Value) -> Value {
    let mut m = json!({ "name": name, "doubleSided": true,
        "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 1.0 } });
    for (k, v) in slots.as_object().unwrap() {
        match k.as_str() {
            "baseColorTexture" | "metallicRoughnessTexture" => {
                m["pbrMetallicRoughness"][k] = v.clone()
            }
            _ => m[k] = v.clone(),
        }
    }
    m
}

fn transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Value {
    json!({ "KHR_texture_transform": { "offset": offset, "rotation": rotation, "scale": scale } })
}

/// The hand-worked transform of the brief: offset (0.5, 0), rotation π/2,
/// scale (2, 2): u' = 2v + 0.5, v' = −2u.
fn brief_transform() -> Value {
    transform([0.5, 0.0], FRAC_PI_2, [2.0, 2.0])
}

/// The extension README's example: offset (0, 1), rotation π/2, scale ½:
/// u' = ½v, v' = 1 − ½u ("the lower left quadrant").
fn spec_example() -> Value {
    transform([0.0, 1.0], FRAC_PI_2, [0.5, 0.5])
}

/// cos(π/2) in f32 is −4.4·10⁻⁸: times scale 2 and |uv| ≤ 1, plus rounding
/// of values ≤ 2.5 (2⁻²² each): well under 10⁻⁶.
const UV_TOL: f32 = 1e-6;

fn assert_uvs(got: &[Vec2], want: &[[f32; 2]], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (g, w) in got.iter().zip(want) {
        assert!(
            (*g - Vec2::from(*w)).abs().max_element() < UV_TOL,
            "{what}: uvs {got:?}, expected {want:?}"
        );
    }
}

#[test]
fn a_texture_reading_texcoord_1_gives_the_mesh_texcoord_1() {
    let d = dir("set1");
    let uv1 = vec![
        vec![0.1, 0.2],
        vec![0.3, 0.4],
        vec![0.5, 0.6],
        vec![0.7, 0.8],
    ];
    let quads = [
        Quad {
            rect: rect(0),
            attrs: vec![("TEXCOORD_0", unit_uvs()), ("TEXCOORD_1", uv1.clone())],
            material: 0,
        },
        // The extension's texCoord overrides the textureInfo's.
        Quad {
            rect: rect(1),
            attrs: vec![("TEXCOORD_0", unit_uvs()), ("TEXCOORD_1", uv1.clone())],
            material: 1,
        },
    ];
    let mats = vec![
        material(
            "one",
            json!({ "baseColorTexture": { "index": 0, "texCoord": 1 } }),
        ),
        material(
            "override",
            json!({ "baseColorTexture": { "index": 0, "texCoord": 1,
                "extensions": { "KHR_texture_transform": { "texCoord": 0 } } } }),
        ),
    ];
    let path = write_doc(
        &d,
        &quads,
        mats,
        1,
        json!({ "extensionsUsed": ["KHR_texture_transform"] }),
    );
    let scene = load_gltf(&path).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let want1: Vec<[f32; 2]> = uv1.iter().map(|v| [v[0], v[1]]).collect();
    assert_eq!(
        scene.meshes[0].uvs,
        want1.iter().map(|&v| Vec2::from(v)).collect::<Vec<_>>()
    );
    let want0: Vec<Vec2> = unit_uvs().iter().map(|v| Vec2::new(v[0], v[1])).collect();
    assert_eq!(scene.meshes[1].uvs, want0);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn offset_rotation_and_scale_give_the_uvs_of_the_spec_matrix() {
    let d = dir("matrix");
    let quad = |k: usize| Quad {
        rect: rect(k),
        attrs: vec![("TEXCOORD_0", unit_uvs())],
        material: k,
    };
    let mats = vec![
        material(
            "brief",
            json!({ "baseColorTexture": { "index": 0, "extensions": brief_transform() } }),
        ),
        material(
            "example",
            json!({ "emissiveTexture": { "index": 0, "extensions": spec_example() } }),
        ),
        // Only an explicit identity: the uvs as they are.
        material(
            "identity",
            json!({ "baseColorTexture": { "index": 0, "extensions": transform([0.0, 0.0], 0.0, [1.0, 1.0]) },
                    "normalTexture": { "index": 0 } }),
        ),
    ];
    let path = write_doc(
        &d,
        &[quad(0), quad(1), quad(2)],
        mats,
        1,
        json!({ "extensionsUsed": ["KHR_texture_transform"],
                "extensionsRequired": ["KHR_texture_transform"] }),
    );
    let scene = load_gltf(&path).unwrap();
    // Required and implemented: not a word.
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // Corners (0,1), (1,1), (1,0), (0,0): u' = 2v + 0.5, v' = −2u.
    assert_uvs(
        &scene.meshes[0].uvs,
        &[[2.5, 0.0], [2.5, -2.0], [0.5, -2.0], [0.5, 0.0]],
        "offset (0.5, 0), rotation π/2, scale 2",
    );
    // u' = ½v, v' = 1 − ½u: inside u' ∈ [0, ½], v' ∈ [½, 1], the lower left
    // quadrant the README's example says.
    assert_uvs(
        &scene.meshes[1].uvs,
        &[[0.5, 1.0], [0.5, 0.5], [0.0, 0.5], [0.0, 1.0]],
        "the README's example",
    );
    let want: Vec<[f32; 2]> = unit_uvs().iter().map(|v| [v[0], v[1]]).collect();
    assert_uvs(&scene.meshes[2].uvs, &want, "identity");
    // The writer stores the baked uvs as TEXCOORD_0 (no extension): read
    // back, the same uvs.
    let out = d.join("out.gltf");
    stereocache::scene::write_gltf(&scene, &out).unwrap();
    let back = load_gltf(&out).unwrap();
    for (a, b) in scene.meshes.iter().zip(&back.meshes) {
        assert_eq!(a.uvs, b.uvs, "{}", a.name);
    }
    // The ray-cone lod reads the uv area per world area of a triangle from
    // the mesh uvs: ×4 under scale 2, ×¼ under scale ½ (the quads are 1 m²).
    for (m, ratio) in [(0, 4.0), (1, 0.25), (2, 1.0)] {
        let mesh = &scene.meshes[m];
        for t in 0..mesh.triangle_count() {
            let i = &mesh.indices[3 * t..3 * t + 3];
            let [a, b, c] = [0, 1, 2].map(|k| mesh.uvs[i[k] as usize]);
            let uv_area = (b - a).perp_dot(c - a).abs();
            let [p, q, r] = mesh.triangle(t);
            let area = (q - p).cross(r - p).length();
            assert!(
                (uv_area / area - ratio).abs() < 1e-5,
                "mesh {m} triangle {t}: uv area ratio {} not {ratio}",
                uv_area / area
            );
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn tangents_follow_the_transformed_uvs() {
    let d = dir("tangents");
    // Quad 0: no tangents, generated (MikkTSpace) from the transformed uvs;
    // quad 1: tangents supplied for the untransformed uvs: ∂P/∂u = +x, and
    // w = +1 since the bitangent w · N × T = +y points up the image (−v;
    // glTF's convention, that of mesh_ops::generate_tangents).
    let quads = [
        Quad {
            rect: rect(0),
            attrs: vec![("TEXCOORD_0", unit_uvs())],
            material: 0,
        },
        Quad {
            rect: rect(1),
            attrs: vec![
                ("TEXCOORD_0", unit_uvs()),
                ("TANGENT", vec![vec![1.0, 0.0, 0.0, 1.0]; 4]),
            ],
            material: 0,
        },
    ];
    let mats = vec![material(
        "bumpy",
        json!({ "baseColorTexture": { "index": 0, "extensions": brief_transform() },
                "normalTexture": { "index": 0, "extensions": brief_transform() } }),
    )];
    let path = write_doc(
        &d,
        &quads,
        mats,
        1,
        json!({ "extensionsUsed": ["KHR_texture_transform"] }),
    );
    let scene = load_gltf(&path).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // u' = 2v + 0.5 grows where v does, along −y; v' = −2u grows along −x,
    // so up the image (−v') is +x = w · (+z × −y) with w = +1: a rotation
    // keeps the handedness.
    let want = Vec4::new(0.0, -1.0, 0.0, 1.0);
    for (m, how) in [(0, "generated"), (1, "supplied")] {
        for t in &scene.meshes[m].tangents {
            assert!(
                (*t - want).abs().max_element() < 1e-5,
                "{how} tangent {t}, expected {want}"
            );
        }
        assert!(!scene.meshes[m].tangents.is_empty(), "{how}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// Two uv sets, and the normal texture under a transform of its own: the
/// channels are the base colour's (TEXCOORD_1 under the brief's transform)
/// and the other set's (TEXCOORD_0, the metallic-roughness texture's); the
/// normal texture (TEXCOORD_1, untransformed) reads channel 1 through a map,
/// and its tangents follow its own uvs (u along +x, w = +1), not channel
/// 1's (turned a quarter). Nothing is warned. (Before, the normal texture
/// took channel 2 and the metallic-roughness texture was warned.) The
/// writer gives it all back.
#[test]
fn two_uv_sets_leave_the_normal_texture_its_own_transform_through_a_map() {
    tangent_texture_through_a_map(
        "two-sets-normal-map",
        json!({ "normalTexture": { "index": 0, "texCoord": 1 } }),
        2,
        &[],
    );
}

/// The same with a clearcoat normal texture and no normal texture: the
/// vertex tangents serve the coat (gltf_import.rs), so they follow its
/// uvs through the map, and the writer stores them turned back by the
/// coat's transform. (Before session 38 the coat's texture never read
/// through a map: it read the base colour's uvs, warned.)
#[test]
fn a_clearcoat_normal_texture_reads_through_a_map_with_tangents_of_its_uvs() {
    tangent_texture_through_a_map(
        "two-sets-coat-normal-map",
        json!({ "extensions": { "KHR_materials_clearcoat": {
            "clearcoatFactor": 1.0,
            "clearcoatNormalTexture": { "index": 0, "texCoord": 1 }
        } } }),
        9,
        &["KHR_materials_clearcoat"],
    );
}

/// A quad whose material binds the base colour and emissive textures to
/// TEXCOORD_1 under the brief's transform, the metallic-roughness texture
/// to TEXCOORD_0, and `extra` (a texture that the vertex tangents serve,
/// slot `slot` of gltf_uv::SLOTS, on TEXCOORD_1 untransformed): `slot`
/// reads channel 1 through a map, the tangents follow its uvs, nothing is
/// warned, and the writer gives it all back.
fn tangent_texture_through_a_map(name: &str, extra: Value, slot: usize, extensions: &[&str]) {
    let d = dir(name);
    let quads = [Quad {
        rect: rect(0),
        attrs: vec![("TEXCOORD_0", unit_uvs()), ("TEXCOORD_1", unit_uvs())],
        material: 0,
    }];
    let mut slots = json!({
        "baseColorTexture": { "index": 0, "texCoord": 1, "extensions": brief_transform() },
        "emissiveTexture": { "index": 0, "texCoord": 1, "extensions": brief_transform() },
        "metallicRoughnessTexture": { "index": 0 }
    });
    for (k, v) in extra.as_object().unwrap() {
        slots[k] = v.clone();
    }
    let mats = vec![material(name, slots)];
    let mut used = vec!["KHR_texture_transform"];
    used.extend_from_slice(extensions);
    let path = write_doc(&d, &quads, mats, 1, json!({ "extensionsUsed": used }));
    let scene = load_gltf(&path).unwrap();
    assert!(scene.warnings.is_empty(), "{:#?}", scene.warnings);
    assert_uvs(
        &scene.meshes[0].uvs,
        &[[2.5, 0.0], [2.5, -2.0], [0.5, -2.0], [0.5, 0.0]],
        "base colour's choice",
    );
    assert_uvs(
        &scene.meshes[0].uvs2,
        &[[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]],
        "the second channel: TEXCOORD_0",
    );
    let m = &scene.materials[0];
    assert_eq!(
        m.second_uv_slots,
        1 << 1,
        "the metallic-roughness texture's channel"
    );
    let map = m.uv_affine[slot].expect("the slot reads channel 1 through a map");
    for (k, uv) in scene.meshes[0].uvs.iter().enumerate() {
        let want = Vec2::from_slice(&unit_uvs()[k]);
        assert!(
            (map.apply(*uv) - want).length() < UV_TOL,
            "vertex {k}: {}",
            map.apply(*uv)
        );
    }
    assert!(!scene.meshes[0].tangents.is_empty(), "tangents generated");
    for t in &scene.meshes[0].tangents {
        assert!(
            (t.truncate() - Vec3::X).length() < 1e-5 && t.w == 1.0,
            "tangent {t}"
        );
    }
    let out = d.join("written.gltf");
    stereocache::scene::write_gltf(&scene, &out).unwrap();
    let back = load_gltf(&out).unwrap();
    assert!(back.warnings.is_empty(), "{:#?}", back.warnings);
    assert_eq!(back.meshes[0].uvs, scene.meshes[0].uvs);
    assert_eq!(back.meshes[0].uvs2, scene.meshes[0].uvs2);
    assert_eq!(back.materials[0].second_uv_slots, 1 << 1);
    let back_map = back.materials[0].uv_affine[slot].expect("still mapped");
    for uv in &scene.meshes[0].uvs {
        assert!((back_map.apply(*uv) - map.apply(*uv)).length() < UV_TOL);
    }
    for (a, b) in back.meshes[0]
        .tangents
        .iter()
        .zip(&scene.meshes[0].tangents)
    {
        assert!(
            (*a - *b).length() < 1e-5,
            "tangent {a} written and read, {b} before"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// Three uv sets: the channels hold two of them (the base colour's
/// TEXCOORD_1 under the brief's transform, and the metallic-roughness
/// texture's TEXCOORD_0); a slot naming the third (the emissive texture's
/// TEXCOORD_2) reads the base colour's channel and is warned, once.
#[test]
fn a_third_uv_set_reads_the_base_colour_channel_and_warns_once() {
    let d = dir("disagree");
    let quads = [Quad {
        rect: rect(0),
        attrs: vec![
            ("TEXCOORD_0", unit_uvs()),
            ("TEXCOORD_1", unit_uvs()),
            ("TEXCOORD_2", unit_uvs()),
        ],
        material: 0,
    }];
    let mats = vec![material(
        "mixed",
        json!({
            "baseColorTexture": { "index": 0, "texCoord": 1, "extensions": brief_transform() },
            "emissiveTexture": { "index": 0, "texCoord": 2 },
            "metallicRoughnessTexture": { "index": 0 },
            "normalTexture": { "index": 0, "texCoord": 1 }
        }),
    )];
    let path = write_doc(
        &d,
        &quads,
        mats,
        1,
        json!({ "extensionsUsed": ["KHR_texture_transform"] }),
    );
    let scene = load_gltf(&path).unwrap();
    assert_eq!(scene.warnings.len(), 1, "{:#?}", scene.warnings);
    let w = &scene.warnings[0];
    for part in [
        path.display().to_string().as_str(),
        "material 0 'mixed'",
        "more than two different uv sets (texCoord)",
        "two uv channels (TEXCOORD_1, offset (0.5, 0), rotation 1.5707964, scale (2, 2) and \
         TEXCOORD_0, no transform)",
        "the others read the base colour texture's uvs, so the emissive texture \
         (TEXCOORD_2, no transform) reads the wrong uvs",
    ] {
        assert!(w.contains(part), "warning lacks '{part}': {w}");
    }
    assert!(
        !w.contains("the normal"),
        "it reads channel 1 through a map: {w}"
    );
    assert!(!w.contains("metallic"), "it has the second channel: {w}");
    let m = &scene.materials[0];
    assert_eq!(m.second_uv_slots, 1 << 1);
    assert!(m.uv_affine[2].is_some() && m.uv_affine[3].is_none());
    let _ = std::fs::remove_dir_all(&d);
}

/// A third `KHR_texture_transform` of a uv set that a channel holds needs no
/// channel of its own: the slot reads the channel through the map between
/// the two transforms (`Material::uv_affine`), without a warning, and the
/// writer gives it back as that slot's transform of the written channel.
/// A map that shears (non-uniform scale under a channel turned by other than
/// a quarter turn) cannot be written: one error naming material and slot.
#[test]
fn a_third_transform_of_a_channels_set_reads_it_through_a_map() {
    let d = dir("third-transform");
    let quads = [Quad {
        rect: rect(0),
        attrs: vec![("TEXCOORD_0", unit_uvs())],
        material: 0,
    }];
    let mats = vec![material(
        "three transforms",
        json!({
            "baseColorTexture": { "index": 0, "extensions": brief_transform() },
            "normalTexture": { "index": 0 },
            "emissiveTexture": { "index": 0, "extensions": spec_example() },
        }),
    )];
    let path = write_doc(
        &d,
        &quads,
        mats,
        1,
        json!({ "extensionsUsed": ["KHR_texture_transform"] }),
    );
    let scene = load_gltf(&path).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let m = &scene.materials[0];
    assert_eq!(m.second_uv_slots, 1 << 2, "the normal texture's channel");
    let a = m.uv_affine[3].expect("the emissive slot reads channel 1 through a map");
    assert_eq!(
        m.uv_affine.iter().filter(|a| a.is_some()).count(),
        1,
        "{:?}",
        m.uv_affine
    );
    // Applied to channel 1 (the brief's transform of TEXCOORD_0) it gives
    // the spec example's transform of TEXCOORD_0, by the formula written
    // apart from the importer's.
    for (k, uv) in unit_uvs().iter().enumerate() {
        let raw = Vec2::new(uv[0], uv[1]);
        let got = a.apply(scene.meshes[0].uvs[k]);
        let want = spec_uv(Vec2::new(0.0, 1.0), FRAC_PI_2, Vec2::splat(0.5), raw);
        assert!(
            (got - want).abs().max_element() < UV_TOL,
            "{raw}: {got} not {want}"
        );
    }
    // Written and read back: the slot's transform of the written channel,
    // the same map.
    let out = d.join("written.gltf");
    stereocache::scene::write_gltf(&scene, &out).unwrap();
    let back = load_gltf(&out).unwrap();
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    let b = back.materials[0].uv_affine[3].expect("read back through a map");
    assert!(
        (b.linear - a.linear)
            .abs()
            .to_cols_array()
            .iter()
            .all(|&x| x < UV_TOL)
            && (b.offset - a.offset).abs().max_element() < UV_TOL,
        "{b:?} not {a:?}"
    );
    // A shearing map is refused by the writer, before anything is written.
    let mut sheared = scene.clone();
    sheared.materials[0].uv_affine[3] = Some(stereocache::scene::UvAffine {
        linear: glam::Mat2::from_cols(Vec2::new(1.0, 0.0), Vec2::new(0.5, 1.0)),
        offset: Vec2::ZERO,
    });
    let refused = d.join("sheared.gltf");
    let e = stereocache::scene::write_gltf(&sheared, &refused)
        .unwrap_err()
        .to_string();
    for part in [
        "material 0 'three transforms'",
        "emissive texture",
        "shears",
    ] {
        assert!(e.contains(part), "error lacks '{part}': {e}");
    }
    assert!(!refused.exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_missing_uv_set_is_zeros_and_warned_and_bad_transforms_are_warned() {
    let d = dir("missing");
    let quads = [
        Quad {
            rect: rect(0),
            attrs: vec![("TEXCOORD_0", unit_uvs())],
            material: 0,
        },
        Quad {
            rect: rect(1),
            attrs: vec![("TEXCOORD_0", unit_uvs())],
            material: 1,
        },
    ];
    let mats = vec![
        material(
            "wants1",
            json!({ "baseColorTexture": { "index": 0, "texCoord": 1 } }),
        ),
        material(
            "bad",
            json!({ "baseColorTexture": { "index": 0, "extensions":
                { "KHR_texture_transform": { "scale": "big", "rotation": [1], "offset": [0.25, 0.0] } } } }),
        ),
    ];
    let path = write_doc(
        &d,
        &quads,
        mats,
        1,
        json!({ "extensionsUsed": ["KHR_texture_transform"] }),
    );
    let scene = load_gltf(&path).unwrap();
    assert_eq!(scene.warnings.len(), 2, "{:#?}", scene.warnings);
    let has = |parts: &[&str]| {
        scene
            .warnings
            .iter()
            .any(|w| parts.iter().all(|p| w.contains(p)))
    };
    assert!(
        has(&[
            "material 0 'wants1'",
            "TEXCOORD_1",
            "mesh 0 primitive 0",
            "zeros"
        ]),
        "{:#?}",
        scene.warnings
    );
    assert!(
        has(&[
            "material 1 'bad'",
            "base colour texture",
            "scale \"big\"",
            "rotation [1]",
            "default"
        ]),
        "{:#?}",
        scene.warnings
    );
    assert!(scene.meshes[0].uvs.iter().all(|&uv| uv == Vec2::ZERO));
    // The valid offset is kept, the bad fields take their defaults.
    assert_uvs(
        &scene.meshes[1].uvs,
        &[[0.25, 1.0], [1.25, 1.0], [1.25, 0.0], [0.25, 0.0]],
        "offset only",
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// uv' of a point by the formula of the module documentation, written here
/// apart from the importer's.
fn spec_uv(offset: Vec2, r: f32, scale: Vec2, uv: Vec2) -> Vec2 {
    let (s, c) = (r as f64).sin_cos();
    let (u, v) = (uv.x as f64 * scale.x as f64, uv.y as f64 * scale.y as f64);
    Vec2::new(
        (c * u + s * v + offset.x as f64) as f32,
        (-s * u + c * v + offset.y as f64) as f32,
    )
}

#[test]
fn a_transformed_texture_shows_the_texel_of_the_transformed_uv() {
    let ctx = context();
    let d = dir("gpu");
    let quad = |k: usize| Quad {
        rect: rect(k),
        attrs: vec![("TEXCOORD_0", unit_uvs())],
        material: k,
    };
    let transforms = [
        (Vec2::ZERO, 0.0, Vec2::ONE),
        (Vec2::new(0.5, 0.0), FRAC_PI_2, Vec2::splat(2.0)),
        (Vec2::new(0.0, 1.0), FRAC_PI_2, Vec2::splat(0.5)),
    ];
    let mats = transforms
        .iter()
        .enumerate()
        .map(|(k, (o, r, s))| {
            material(
                &format!("m{k}"),
                json!({ "baseColorTexture": { "index": 0, "extensions":
                    transform([o.x, o.y], *r, [s.x, s.y]) } }),
            )
        })
        .collect();
    let path = write_doc(
        &d,
        &[quad(0), quad(1), quad(2)],
        mats,
        1,
        json!({ "extensionsUsed": ["KHR_texture_transform"] }),
    );
    let scene = load_gltf(&path).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let texel = |uv: Vec2| -> Vec3 {
        // NEAREST + REPEAT on 2×2: texel ⌊2u⌋ mod 2, ⌊2v⌋ mod 2.
        let i = ((uv.x as f64 * 2.0).floor() as i64).rem_euclid(2);
        let j = ((uv.y as f64 * 2.0).floor() as i64).rem_euclid(2);
        let t = TEXELS[(j * 2 + i) as usize];
        Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32) / 255.0
    };
    // Pixels whose uv' lies this close to a texel edge may show either
    // texel: the sampler's sub-texel snapping (2^-bits of a texel) plus the
    // rebuilt hit's error (barycentrics to 2⁻²⁴ over a 3-unit span, and
    // the f32 position, ×2 texels per uv).
    let q = 0.5f32.powi(ctx.caps.sub_texel_precision_bits.max(4) as i32);
    let e = 2.0 * 16.0 * 3.0 / 16_777_216.0;
    let near_edge = |x: f32| {
        let t = x * 2.0;
        (t - t.round()).abs() < q + e
    };
    // 0 or 255 decodes from sRGB to exactly 0 or 1; 2⁻¹² is below the first step.
    let tol = 1.0 / 4096.0;
    let settings = RenderSettings {
        width: 192,
        height: 128,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    let cam = look_at_camera(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, 60.0, 1.5);
    let mut backends = vec![RtChoice::Software];
    if require(ctx.ray_query_enabled(), "ray queries") {
        backends.push(RtChoice::Query);
    }
    for rt in backends {
        let s = session(&ctx, scene.clone(), rt);
        let f = render(&s, "reference", cam, &settings);
        let mut checked = [0usize; 3];
        let mut differs = [0usize; 3];
        let mut seen = [[false; 4]; 3];
        for (e_i, eye) in f.eyes.iter().enumerate() {
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (k, p) = hit_point(&s.scene, *fh);
                let (x0, y0, x1, y1) = rect(k);
                // The quad's own uvs at p (u along +x, v along −y).
                let uv = Vec2::new((p.x - x0) / (x1 - x0), (y1 - p.y) / (y1 - y0));
                let (o, r, sc) = transforms[k];
                let uvt = spec_uv(o, r, sc, uv);
                if near_edge(uvt.x) || near_edge(uvt.y) || near_edge(uv.x) || near_edge(uv.y) {
                    continue;
                }
                let want = texel(uvt);
                let got = Vec3::from_slice(&eye.albedo[i][..3]);
                assert!(
                    (got - want).abs().max_element() <= tol,
                    "{rt:?}: eye {e_i} pixel {i} quad {k} uv {uv} → uv' {uvt}: albedo {got}, \
                     expected {want}"
                );
                checked[k] += 1;
                differs[k] += ((texel(uv) - want).abs().max_element() > 0.5) as usize;
                let ti = (want.x > 0.5) as usize + 2 * (want.z > 0.5) as usize;
                seen[k][ti] = true;
            }
        }
        eprintln!("{rt:?}: checked {checked:?}, differing from untransformed {differs:?}, texels seen {seen:?}");
        for (k, c) in checked.iter().enumerate() {
            assert!(*c > 1000, "{rt:?}: quad {k} has {c} checked pixels");
        }
        // The transforms change what most pixels show, so reading the
        // untransformed uvs would fail: quad 1 repeats the texture 4 times
        // rotated, quad 2 shows one texel (blue) where the plain quad shows four.
        for k in 1..3 {
            assert!(
                differs[k] * 2 > checked[k],
                "{rt:?}: quad {k}: {} of {}",
                differs[k],
                checked[k]
            );
        }
        assert_eq!(
            seen[0], [true; 4],
            "{rt:?}: the plain quad shows all four texels"
        );
        assert_eq!(seen[1], [true; 4], "{rt:?}: quad 1 shows all four texels");
        assert_eq!(
            seen[2].iter().filter(|&&s| s).count(),
            1,
            "{rt:?}: quad 2: {:?}",
            seen[2]
        );
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// The mesh (= quad) index and world position of a stored first hit
/// (Listing 1: barycentrics in 24 bits); nodes carry no transform.
fn hit_point(scene: &Scene, fh: [u32; 4]) -> (usize, Vec3) {
    let inst = &scene.instances[fh[3] as usize];
    let mesh = &scene.meshes[inst.mesh as usize];
    let (idx, w) = first_hit_weights(scene, fh);
    let p: Vec3 = (0..3).map(|k| mesh.positions[idx[k]] * w[k]).sum();
    (inst.mesh as usize, p)
}

/// A black, non-reflecting (specularFactor 0) emitter of emissive factor 1
/// with the given texture slots, on quad 0 with the given uv sets.
fn emitter_doc(d: &Path, attrs: Vec<(&'static str, Vec<Vec<f32>>)>, slots: Value) -> PathBuf {
    let quads = [Quad {
        rect: rect(0),
        attrs,
        material: 0,
    }];
    let mut m = material("emitter", slots);
    m["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.0, 0.0, 0.0, 1.0]);
    m["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    m["extensions"] = json!({ "KHR_materials_specular": { "specularFactor": 0.0 } });
    write_doc(
        d,
        &quads,
        vec![m],
        1,
        json!({ "extensionsUsed": ["KHR_texture_transform", "KHR_materials_specular"] }),
    )
}

/// Renders quad 0 of `scene` (an [`emitter_doc`]) head-on with one bounce
/// on both backends and checks that every pixel's radiance is exactly the
/// emissive texel at `want_uv(uv0)` (uv0: the quad's TEXCOORD_0 at the hit;
/// sRGB 0 and 255 decode to 0 and 1), and that on over a third of the quad
/// that texel differs from the one at `other_uv(uv0)` (what a wrong reading
/// would show).
fn assert_emission_reads(
    ctx: &std::sync::Arc<stereocache::gpu::GpuContext>,
    scene: &Scene,
    want_uv: impl Fn(Vec2) -> Vec2,
    other_uv: impl Fn(Vec2) -> Vec2,
) {
    let texel = |uv: Vec2| -> Vec3 {
        let i = ((uv.x as f64 * 2.0).floor() as i64).rem_euclid(2);
        let j = ((uv.y as f64 * 2.0).floor() as i64).rem_euclid(2);
        let t = TEXELS[(j * 2 + i) as usize];
        Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32) / 255.0
    };
    // Which uvs a slot reads is what is checked here, not the sampler's
    // precision at a texel edge (the transformed-texture test's business):
    // pixels within 1/64 of a texel of an edge are left out (llvmpipe
    // rounded one 0.0040 from an edge, beyond its reported 2^-8, to the
    // neighbour).
    let near_edge = |x: f32| {
        let t = x * 2.0;
        (t - t.round()).abs() < 1.0 / 64.0
    };
    let settings = RenderSettings {
        width: 96,
        height: 96,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    let (x0, y0, x1, y1) = rect(0);
    let c = Vec3::new(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0);
    let cam = look_at_camera(c + Vec3::new(0.0, 0.0, 1.5), c, 30.0, 1.0);
    let mut backends = vec![RtChoice::Software];
    if require(ctx.ray_query_enabled(), "ray queries") {
        backends.push(RtChoice::Query);
    }
    for rt in backends {
        let s = session(ctx, scene.clone(), rt);
        let f = render(&s, "reference", cam, &settings);
        let (mut checked, mut differs) = (0usize, 0usize);
        for eye in &f.eyes {
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (_, p) = hit_point(&s.scene, *fh);
                let uv0 = Vec2::new((p.x - x0) / (x1 - x0), (y1 - p.y) / (y1 - y0));
                let (uvt, uvo) = (want_uv(uv0), other_uv(uv0));
                if [uvt.x, uvt.y, uvo.x, uvo.y].into_iter().any(near_edge) {
                    continue;
                }
                let want = texel(uvt);
                let got = Vec3::from_slice(&eye.radiance[i][..3]);
                assert!(
                    (got - want).abs().max_element() <= 1.0 / 4096.0,
                    "{rt:?}: pixel {i} uv0 {uv0} → uv' {uvt}: radiance {got}, expected {want}"
                );
                assert_eq!(Vec3::from_slice(&eye.albedo[i][..3]), Vec3::ZERO);
                checked += 1;
                differs += ((texel(uvo) - want).abs().max_element() > 0.5) as usize;
            }
        }
        eprintln!("{rt:?}: checked {checked}, differing from the other reading {differs}");
        assert!(checked > 5000, "{rt:?}: {checked} pixels checked");
        assert!(differs * 3 > checked, "{rt:?}: {differs} of {checked}");
    }
    assert_no_validation_messages(ctx);
}

/// A texture on the second uv channel is sampled there: the emitter's base
/// colour texture reads TEXCOORD_0 as is and its emissive texture reads
/// TEXCOORD_1 under the brief's transform; every pixel's radiance is the
/// emissive texel at the transformed TEXCOORD_1, which differs from the
/// texel at the untransformed uvs on most of the quad — on both backends.
#[test]
fn an_emissive_texture_on_the_second_channel_shows_its_own_uvs() {
    let ctx = context();
    let d = dir("second-channel");
    // TEXCOORD_1 = TEXCOORD_0 mirrored in u, so a mix-up of the sets shows too.
    let mirrored: Vec<Vec<f32>> = unit_uvs()
        .into_iter()
        .map(|uv| vec![1.0 - uv[0], uv[1]])
        .collect();
    let path = emitter_doc(
        &d,
        vec![("TEXCOORD_0", unit_uvs()), ("TEXCOORD_1", mirrored)],
        json!({
            "baseColorTexture": { "index": 0 },
            "emissiveTexture": { "index": 0, "texCoord": 1, "extensions": brief_transform() },
        }),
    );
    let scene = load_gltf(&path).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(
        scene.materials[0].second_uv_slots,
        1 << 3,
        "the emissive slot"
    );
    assert_emission_reads(
        &ctx,
        &scene,
        |uv0| {
            let uv1 = Vec2::new(1.0 - uv0.x, uv0.y);
            spec_uv(Vec2::new(0.5, 0.0), FRAC_PI_2, Vec2::splat(2.0), uv1)
        },
        |uv0| uv0,
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A third transform of a channel's uv set is applied at shading time: the
/// emitter's base colour texture reads TEXCOORD_0 under the brief's
/// transform (channel 1), its metallic-roughness texture under an offset
/// (channel 2), and its emissive texture under a third, generic transform
/// (rotation 0.4, non-uniform scale), which reads channel 1 through the map
/// between the two. Every pixel's radiance is the emissive texel at the
/// third transform of TEXCOORD_0, which differs from the texel at channel
/// 1's uvs (what the emissive slot read before maps) on most of the quad —
/// on both backends.
#[test]
fn a_third_transform_is_applied_at_shading_time() {
    let ctx = context();
    let d = dir("third-transform-gpu");
    let (o, r, sc) = (Vec2::new(0.25, 0.5), 0.4, Vec2::new(1.5, 1.0));
    let path = emitter_doc(
        &d,
        vec![("TEXCOORD_0", unit_uvs())],
        json!({
            "baseColorTexture": { "index": 0, "extensions": brief_transform() },
            "metallicRoughnessTexture": { "index": 0, "extensions": transform([0.25, 0.0], 0.0, [1.0, 1.0]) },
            "emissiveTexture": { "index": 0, "extensions": transform(o.to_array(), r, sc.to_array()) },
        }),
    );
    let scene = load_gltf(&path).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.materials[0].second_uv_slots, 1 << 1);
    assert!(scene.materials[0].uv_affine[3].is_some());
    assert!(stereocache::scene::SceneFeatures::of(&scene).uv_affine);
    assert_emission_reads(
        &ctx,
        &scene,
        |uv0| spec_uv(o, r, sc, uv0),
        |uv0| spec_uv(Vec2::new(0.5, 0.0), FRAC_PI_2, Vec2::splat(2.0), uv0),
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// The emissive texture read through a uv map must light the scene as it
/// shows: next-event estimation evaluates an emitter's radiance apart from
/// material_at (lights.glsl `emitted_radiance`), and both must read the
/// mapped texel. The emitter's third transform maps the whole quad into the
/// red texel (offset 0.1, scale 0.3: uv' in [0.1, 0.4]²), while the uvs of
/// its channel (the base colour's transform of the brief) cover all four
/// texels. A diffuse floor lit by it alone (black environment) must have
/// the same mean by NEE alone and by BSDF sampling alone, per channel,
/// within 5 combined standard errors — and no green or blue. (Before the
/// map reached `emitted_radiance`, NEE lit the floor with the mixture of
/// all four texels.)
#[test]
fn a_mapped_emissive_texture_gives_the_same_light_to_both_samplers() {
    use stereocache::scene::generate::{add_material, add_mesh, grid};
    let ctx = context();
    let d = dir("mapped-emitter-light");
    let path = emitter_doc(
        &d,
        vec![("TEXCOORD_0", unit_uvs())],
        json!({
            "baseColorTexture": { "index": 0, "extensions": brief_transform() },
            "metallicRoughnessTexture": { "index": 0, "extensions": transform([0.25, 0.0], 0.0, [1.0, 1.0]) },
            "emissiveTexture": { "index": 0, "extensions": transform([0.1, 0.1], 0.0, [0.3, 0.3]) },
        }),
    );
    let mut scene = load_gltf(&path).unwrap();
    let _ = std::fs::remove_dir_all(&d);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert!(
        scene.materials[0].uv_affine[3].is_some(),
        "the emissive slot is mapped"
    );
    scene.environment = None;
    let floor = add_material(
        &mut scene,
        stereocache::scene::Material::diffuse("floor", Vec3::splat(0.8)),
    );
    let (x0, _, x1, _) = rect(0);
    let cx = 0.5 * (x0 + x1);
    add_mesh(
        &mut scene,
        grid(
            "floor",
            Vec3::new(cx - 3.0, -1.0, 3.0),
            Vec3::X * 6.0,
            Vec3::NEG_Z * 6.0,
            1,
            1,
            Vec2::ONE,
        ),
        floor,
        glam::Mat4::IDENTITY,
    );
    scene.validate().unwrap();
    let (w, h) = (48, 32);
    let cam = look_at_camera(
        Vec3::new(cx, 1.0, 4.0),
        Vec3::new(cx, -1.0, 0.5),
        50.0,
        w as f32 / h as f32,
    );
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        let (nee, _) = assert_light_samplers_agree(&s, floor, cam, w, h, &format!("{rt:?}"));
        assert!(nee[0].0 > 1e-3, "{rt:?}: the floor is dark: {nee:?}");
        // Only the red texel emits (the emitter's black base and the
        // diffuse floor add no other colour).
        assert_eq!(
            (nee[1].0, nee[2].0),
            (0.0, 0.0),
            "{rt:?}: NEE lights green or blue"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// A normal texture read through a uv map shades as on a channel of its
/// own. Scene A: base colour (TEXCOORD_0 under the brief's transform) and a
/// normal texture under a transform of its own (offset, rotation 0.3): the
/// normal texture has channel 2 and tangents from its uvs. Scene B: the same
/// plus an emissive texture on TEXCOORD_1, which takes channel 2: the normal
/// texture now reads channel 1 through a map, with MikkTSpace tangents of
/// the mapped uvs. The shading normals (`debug-normals`: the normal-mapped
/// normal at each pixel centre) must agree, on both backends, to f32
/// rounding of the map (10⁻⁴), except where a pixel straddles the texel
/// boundary at which the map's normal turns unusable (tangent-space z < 0:
/// the interpolated normal is kept), which float differences of ~10⁻⁶ in
/// uv can move: at most one pixel in a hundred.
#[test]
fn a_normal_texture_through_a_map_shades_as_on_its_own_channel() {
    let ctx = context();
    let d = dir("normal-through-map");
    let normal_slot = json!({ "index": 0, "extensions": transform([0.25, 0.1], 0.3, [1.0, 1.0]) });
    let build = |with_second_set: bool, tag: &str| {
        let mut slots = json!({
            "baseColorTexture": { "index": 0, "extensions": brief_transform() },
            "normalTexture": normal_slot.clone(),
        });
        let mut attrs = vec![("TEXCOORD_0", unit_uvs())];
        if with_second_set {
            slots["emissiveTexture"] = json!({ "index": 0, "texCoord": 1 });
            attrs.push(("TEXCOORD_1", unit_uvs()));
        }
        let quads = [Quad {
            rect: rect(0),
            attrs,
            material: 0,
        }];
        let dd = d.join(tag);
        std::fs::create_dir_all(&dd).unwrap();
        let path = write_doc(
            &dd,
            &quads,
            vec![material("bumpy", slots)],
            1,
            json!({ "extensionsUsed": ["KHR_texture_transform"] }),
        );
        let mut scene = load_gltf(&path).unwrap();
        assert!(scene.warnings.is_empty(), "{tag}: {:?}", scene.warnings);
        // Only the normals matter: no emission (the texture stays bound).
        scene.materials[0].emissive = Vec3::ZERO;
        scene
    };
    let own = build(false, "own");
    let mapped = build(true, "mapped");
    assert_eq!(own.materials[0].second_uv_slots, 1 << 2);
    assert!(own.materials[0].uv_affine[2].is_none());
    assert!(
        mapped.materials[0].uv_affine[2].is_some(),
        "the normal texture reads a map"
    );
    let (x0, y0, x1, y1) = rect(0);
    let c = Vec3::new(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0);
    let cam = look_at_camera(c + Vec3::new(0.0, 0.0, 1.5), c, 30.0, 1.0);
    let settings = RenderSettings {
        width: 64,
        height: 64,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    for rt in rt_backends(&ctx) {
        let a = render(
            &session(&ctx, own.clone(), rt),
            "debug-normals",
            cam,
            &settings,
        );
        let b = render(
            &session(&ctx, mapped.clone(), rt),
            "debug-normals",
            cam,
            &settings,
        );
        let (mut n, mut off, mut worst, mut tilted) = (0usize, 0usize, 0f32, 0usize);
        for (ea, eb) in a.eyes.iter().zip(&b.eyes) {
            for ((pa, pb), fh) in ea.radiance.iter().zip(&eb.radiance).zip(&ea.first_hit) {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (na, nb) = (Vec3::from_slice(&pa[..3]), Vec3::from_slice(&pb[..3]));
                let e = (na - nb).abs().max_element();
                n += 1;
                // 0.5·n + 0.5 of the geometric +z normal is (0.5, 0.5, 1).
                tilted += ((na - Vec3::new(0.5, 0.5, 1.0)).length() > 0.05) as usize;
                if e > 1e-4 {
                    off += 1;
                } else {
                    worst = worst.max(e);
                }
            }
        }
        eprintln!(
            "{rt:?}: {n} pixels, {tilted} normal-mapped away from the geometric normal, \
             {off} differ by > 1e-4, largest other difference {worst:e}"
        );
        assert!(
            n > 2000 && tilted > n / 4,
            "{rt:?}: {n} pixels, {tilted} tilted"
        );
        assert!(off * 100 <= n, "{rt:?}: {off} of {n} pixels differ");
    }
    let _ = std::fs::remove_dir_all(&d);
    assert_no_validation_messages(&ctx);
}

/// KHR_mesh_quantization, required as gltfpack writes it: a quad whose
/// positions are SHORT and uvs normalized UNSIGNED_SHORT loads, with uv =
/// value / 65535 and the positions as integers (until session 48 a file
/// that required the extension was refused, though the reader decodes it).
#[test]
fn quantized_attributes_load_when_the_extension_is_required() {
    let d = dir("quantized");
    let mut bin = Vec::new();
    // POSITION: SHORT VEC3, 4 vertices (8 bytes each with padding to 4).
    let pos: [[i16; 3]; 4] = [[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]];
    for p in pos {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
        bin.extend_from_slice(&[0, 0]);
    }
    // TEXCOORD_0: normalized UNSIGNED_SHORT VEC2.
    let uv_at = bin.len();
    let uvs: [[u16; 2]; 4] = [[0, 65535], [32768, 65535], [65535, 0], [0, 0]];
    for t in uvs {
        for c in t {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let idx_at = bin.len();
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let root = json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "scene": 0, "scenes": [{ "nodes": [0] }], "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "indices": 2 }] }],
        "accessors": [
            { "bufferView": 0, "componentType": 5122, "count": 4, "type": "VEC3",
              "min": [0, 0, 0], "max": [2, 2, 0] },
            { "bufferView": 1, "componentType": 5123, "normalized": true, "count": 4, "type": "VEC2" },
            { "bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR" }
        ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": uv_at, "byteStride": 8 },
            { "buffer": 0, "byteOffset": uv_at, "byteLength": idx_at - uv_at },
            { "buffer": 0, "byteOffset": idx_at, "byteLength": 12 }
        ],
        "buffers": [{ "byteLength": bin.len(), "uri": format!("data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)) }]
    });
    let path = d.join("quantized.gltf");
    std::fs::write(&path, serde_json::to_string_pretty(&root).unwrap()).unwrap();
    let scene = load_gltf(&path).unwrap_or_else(|e| panic!("quantized file refused: {e}"));
    let m = &scene.meshes[0];
    assert_eq!(m.positions[1], Vec3::new(2.0, 0.0, 0.0));
    assert_eq!(m.positions[2], Vec3::new(2.0, 2.0, 0.0));
    assert!(
        (m.uvs[1].x - 32768.0 / 65535.0).abs() < 1e-7,
        "{:?}",
        m.uvs[1]
    );
    assert_eq!(m.uvs[2], Vec2::new(1.0, 0.0));
    let _ = std::fs::remove_dir_all(&d);
}
