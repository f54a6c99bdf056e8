//! glTF geometry import (issue 18): triangle strips and fans, MikkTSpace
//! tangents, default morph-target weights and EXT_mesh_gpu_instancing.
//! Every file is written by the test (JSON with one base64 data-URI buffer);
//! CPU only, fast.

mod common;
use common::world_triangles;
use glam::{Mat4, Quat, Vec3, Vec4};
use serde_json::{json, Value};
use std::path::PathBuf;
use stereocache::scene::{load_gltf, Scene};

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stereocache-geom-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// One binary buffer with a bufferView and an accessor per array.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

fn components(ty: &str) -> usize {
    match ty {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        _ => panic!("{ty}"),
    }
}

impl Builder {
    fn view(&mut self, bytes: &[u8]) -> usize {
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}));
        self.views.len() - 1
    }

    /// A float accessor of type `ty`, with min/max (glTF requires them for POSITION).
    fn floats(&mut self, data: &[f32], ty: &str) -> usize {
        let n = components(ty);
        assert_eq!(data.len() % n, 0);
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let (mut min, mut max) = (vec![f32::INFINITY; n], vec![f32::NEG_INFINITY; n]);
        for e in data.chunks_exact(n) {
            for k in 0..n {
                if e[k].is_finite() {
                    min[k] = min[k].min(e[k]);
                    max[k] = max[k].max(e[k]);
                }
            }
        }
        let mut acc = json!({
            "bufferView": view, "componentType": 5126, "count": data.len() / n, "type": ty,
        });
        if min.iter().all(|m| m.is_finite()) {
            acc["min"] = json!(min);
            acc["max"] = json!(max);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    fn vec3(&mut self, v: &[Vec3]) -> usize {
        let flat: Vec<f32> = v.iter().flat_map(|p| p.to_array()).collect();
        self.floats(&flat, "VEC3")
    }

    fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }

    /// A normalized signed-short accessor (value = i16 / 32767).
    fn normalized_shorts(&mut self, data: &[i16], ty: &str) -> usize {
        let n = components(ty);
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5122, "normalized": true,
            "count": data.len() / n, "type": ty,
        }));
        self.accessors.len() - 1
    }

    /// A VEC3 float accessor of `count` zeros except `values` at `at` (sparse, no bufferView).
    fn sparse_vec3(&mut self, count: usize, at: &[u32], values: &[Vec3]) -> usize {
        let ib: Vec<u8> = at.iter().flat_map(|i| i.to_le_bytes()).collect();
        let vb: Vec<u8> = values
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(|f| f.to_le_bytes())
            .collect();
        let (iv, vv) = (self.view(&ib), self.view(&vb));
        self.accessors.push(json!({
            "componentType": 5126, "count": count, "type": "VEC3",
            "sparse": {
                "count": at.len(),
                "indices": {"bufferView": iv, "componentType": 5125},
                "values": {"bufferView": vv},
            },
        }));
        self.accessors.len() - 1
    }

    /// Adds buffers/bufferViews/accessors to `root`, writes it and loads it.
    fn load(self, root: Value, tag: &str) -> Result<Scene, String> {
        let path = self.write(root, tag);
        load_gltf(&path).map_err(|e| e.to_string())
    }

    fn write(self, mut root: Value, tag: &str) -> PathBuf {
        use base64::Engine as _;
        let b64 = base64::engine::general_purpose::STANDARD.encode(&self.bin);
        root["asset"] = json!({"version": "2.0"});
        root["buffers"] = json!([{
            "byteLength": self.bin.len(),
            "uri": format!("data:application/octet-stream;base64,{b64}"),
        }]);
        root["bufferViews"] = json!(self.views);
        root["accessors"] = json!(self.accessors);
        let path = temp_dir(tag).join(format!("{tag}.gltf"));
        std::fs::write(&path, serde_json::to_vec_pretty(&root).unwrap()).unwrap();
        path
    }
}

// ---------------------------------------------------------------- strips and fans

/// glTF-Sample-Assets MeshPrimitiveModes: a regular hexagon around vertex 0
/// (vertex k at 60°·(k − 1) − 30°), one mesh per mode with that model's
/// indices; each triangle mode covers the hexagon with counter-clockwise
/// (+Z facing) triangles, with and without an index accessor.
#[test]
fn strips_and_fans_become_counter_clockwise_triangle_lists() {
    let hexagon: Vec<Vec3> = std::iter::once(Vec3::ZERO)
        .chain((1..=6).map(|k| {
            let a = (60.0 * (k - 1) as f32 - 30.0).to_radians();
            Vec3::new(a.cos(), a.sin(), 0.0)
        }))
        .collect();
    let mut b = Builder::default();
    let pos = b.vec3(&hexagon);
    let cases: [(&str, u32, &[u32], usize); 4] = [
        (
            "list",
            4,
            &[0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5, 0, 5, 6, 0, 6, 1],
            6,
        ),
        ("strip", 5, &[2, 3, 1, 4, 6, 5], 4),
        ("fan", 6, &[0, 1, 2, 3, 4, 5, 6, 1], 6),
        ("points", 0, &[0, 1, 2, 3, 4, 5, 6], 0),
    ];
    let mut meshes = Vec::new();
    for (name, mode, idx, _) in cases {
        // Indexed, and the same vertices written out in index order, unindexed.
        let indexed = b.indices(idx);
        let unrolled: Vec<Vec3> = idx.iter().map(|&i| hexagon[i as usize]).collect();
        let flat = b.vec3(&unrolled);
        meshes.push(json!({"name": format!("{name} indexed"), "primitives": [
            {"attributes": {"POSITION": pos}, "indices": indexed, "mode": mode}]}));
        meshes.push(json!({"name": format!("{name} unindexed"), "primitives": [
            {"attributes": {"POSITION": flat}, "mode": mode}]}));
    }
    let nodes: Vec<Value> = (0..meshes.len()).map(|m| json!({"mesh": m})).collect();
    let root = json!({
        "scene": 0, "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes, "meshes": meshes,
    });
    let s = b.load(root, "modes").unwrap();
    let hexagon_area = 1.5 * 3f32.sqrt();
    for (name, _, _, tris) in &cases[..3] {
        for variant in ["indexed", "unindexed"] {
            let label = format!("{name} {variant}");
            let m = s.meshes.iter().find(|m| m.name == label).unwrap();
            assert_eq!(m.triangle_count(), *tris, "{label}");
            let mut area = 0.0;
            for t in 0..m.triangle_count() {
                let [a, b, c] = m.triangle(t);
                let z = (b - a).cross(c - a).z;
                assert!(z > 0.0, "{label}: triangle {t} is clockwise");
                area += z / 2.0;
            }
            // Sum of 4 or 6 triangle areas of O(1): a few ulps.
            assert!((area - hexagon_area).abs() < 1e-5, "{label}: area {area}");
            for &i in &m.indices {
                assert!((m.normals[i as usize] - Vec3::Z).length() < 1e-6, "{label}");
            }
        }
    }
    assert!(!s.meshes.iter().any(|m| m.name.starts_with("points")));
    let w: Vec<&String> = s.warnings.iter().filter(|w| w.contains("mode")).collect();
    assert_eq!(w.len(), 2, "{:?}", s.warnings);
    assert!(
        w.iter()
            .all(|w| w.contains("Points") && w.contains("skipped")),
        "{w:?}"
    );
}

// ---------------------------------------------------------------- tangents

fn png_data_uri() -> String {
    use base64::Engine as _;
    let img = image::RgbImage::from_pixel(1, 1, image::Rgb([128, 128, 255]));
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .unwrap();
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// A normal-mapped unit quad in z = 0 facing +Z; `mirror` flips u.
/// `tangents`: a TANGENT accessor to ship.
fn quad_file(mirror: bool, tangents: Option<&[f32]>, tag: &str) -> Scene {
    let mut b = Builder::default();
    let p = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    // glTF uv: u along +X, v = 0 at the image top, so v runs down = along −Y.
    let mut uv = [0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
    if mirror {
        for k in (0..8).step_by(2) {
            uv[k] = 1.0 - uv[k];
        }
    }
    let mut attributes = json!({
        "POSITION": b.vec3(&p),
        "NORMAL": b.vec3(&[Vec3::Z; 4]),
        "TEXCOORD_0": b.floats(&uv, "VEC2"),
    });
    if let Some(t) = tangents {
        attributes["TANGENT"] = json!(b.floats(t, "VEC4"));
    }
    let idx = b.indices(&[0, 1, 2, 0, 2, 3]);
    let root = json!({
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": idx, "material": 0}]}],
        "materials": [{"normalTexture": {"index": 0}, "doubleSided": true}],
        "textures": [{"source": 0}],
        "images": [{"uri": png_data_uri()}],
    });
    let s = b.load(root, tag).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(s.materials[0].normal_texture.is_some());
    s
}

/// The bitangent the shader builds: material.glsl B = cross(N, T) × sign(w).
fn bitangent(n: Vec3, t: Vec4) -> Vec3 {
    n.cross(t.truncate()) * if t.w < 0.0 { -1.0 } else { 1.0 }
}

#[test]
fn generated_tangents_follow_u_and_the_bitangent_points_up_the_image() {
    let s = quad_file(false, None, "tangent-quad");
    let m = &s.meshes[0];
    assert_eq!(m.tangents.len(), 4);
    for (t, n) in m.tangents.iter().zip(&m.normals) {
        // Tangent = dP/du = +X. glTF's normal-texture green channel points
        // up the image (−v, here +Y), which is what tangents Blender exports
        // give for an unmirrored map: w = +1.
        assert!((t.truncate() - Vec3::X).length() < 1e-6, "{t}");
        assert_eq!(t.w, 1.0);
        assert!((bitangent(*n, *t) - Vec3::Y).length() < 1e-6);
    }
}

#[test]
fn mirrored_u_negates_tangent_and_w() {
    let s = quad_file(true, None, "tangent-mirror");
    for (t, n) in s.meshes[0].tangents.iter().zip(&s.meshes[0].normals) {
        assert!((t.truncate() + Vec3::X).length() < 1e-6, "{t}");
        assert_eq!(t.w, -1.0);
        assert!((bitangent(*n, *t) - Vec3::Y).length() < 1e-6);
    }
}

#[test]
fn supplied_tangents_are_kept_untouched() {
    // Deliberately not what MikkTSpace would give (and not unit length):
    // the file's values arrive bit for bit.
    let t = [
        0.0, 0.6, 0.0, -1.0, 0.0, 0.7, 0.1, -1.0, 0.3, 0.9, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0,
    ];
    let s = quad_file(false, Some(&t), "tangent-supplied");
    let got: Vec<f32> = s.meshes[0]
        .tangents
        .iter()
        .flat_map(|v| v.to_array())
        .collect();
    assert_eq!(got.len(), t.len());
    for (a, b) in got.iter().zip(&t) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
}

/// glTF §3.7.2.1: "When normals are not specified, client implementations
/// MUST calculate flat normals and the provided tangents (if present) MUST
/// be ignored." A quad folded 90° along its shared edge (two triangles,
/// four shared vertices), without NORMAL, with supplied tangents and a
/// normal texture: every triangle corner's normal is its own face's (+Z
/// and +Y), exactly, not the shared edge's 45° average; the supplied
/// tangents (deliberately wrong) are replaced by MikkTSpace's, which
/// follow u on both faces.
#[test]
fn missing_normals_are_flat_and_supplied_tangents_are_ignored() {
    let mut b = Builder::default();
    let p = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, -1.0),
        Vec3::new(0.0, 1.0, -1.0),
    ];
    let uv = [0.0, 1.0, 1.0, 1.0, 1.0, 0.5, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0];
    let wrong_tangents = [0.0f32, 0.0, 1.0, -1.0].repeat(6);
    let attributes = json!({
        "POSITION": b.vec3(&p),
        "TEXCOORD_0": b.floats(&uv, "VEC2"),
        "TANGENT": b.floats(&wrong_tangents, "VEC4"),
    });
    // Face z = 0 (normal +Z): 0 1 2, 0 2 3; face y = 1 (normal +Y): 3 2 4, 3 4 5.
    let idx = b.indices(&[0, 1, 2, 0, 2, 3, 3, 2, 4, 3, 4, 5]);
    let root = json!({
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": idx, "material": 0}]}],
        "materials": [{"normalTexture": {"index": 0}}],
        "textures": [{"source": 0}],
        "images": [{"uri": png_data_uri()}],
    });
    let s = b.load(root, "flat-normals").unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.meshes[0];
    assert_eq!(m.indices.len(), 12);
    for (c, &v) in m.indices.iter().enumerate() {
        let v = v as usize;
        let face = if c < 6 { Vec3::Z } else { Vec3::Y };
        assert_eq!(m.normals[v], face, "corner {c}: normal {}", m.normals[v]);
        // Each face's corners hold that face's positions (the fold's edge
        // vertices 2 and 3 appear once per face).
        let want = p[[0, 1, 2, 0, 2, 3, 3, 2, 4, 3, 4, 5][c]];
        assert_eq!(m.positions[v], want, "corner {c}");
        // MikkTSpace's tangent: u runs along +X on both faces.
        let t = m.tangents[v];
        assert!(
            (t.truncate() - Vec3::X).length() < 1e-6,
            "corner {c}: tangent {t}"
        );
        assert_eq!(t.w, 1.0, "corner {c}");
    }
}

// ---------------------------------------------------------------- morph targets

/// Triangle (0,0,0), (1,0,0), (0,1,0), normals +Z; target 0 moves vertex 2 by
/// (0,0,2) and tilts its normal by (0,2,−1); target 1 (sparse, no bufferView)
/// moves vertex 1 by (4,0,0).
fn morph_root(b: &mut Builder, mesh_weights: Option<&[f32]>, nodes: Value) -> Value {
    let pos = b.vec3(&[Vec3::ZERO, Vec3::X, Vec3::Y]);
    let nrm = b.vec3(&[Vec3::Z; 3]);
    let d_pos = b.vec3(&[Vec3::ZERO, Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0)]);
    let d_nrm = b.vec3(&[Vec3::ZERO, Vec3::ZERO, Vec3::new(0.0, 2.0, -1.0)]);
    let d_sparse = b.sparse_vec3(3, &[1], &[Vec3::new(4.0, 0.0, 0.0)]);
    let mut mesh = json!({"name": "morphing", "primitives": [{
        "attributes": {"POSITION": pos, "NORMAL": nrm},
        "targets": [{"POSITION": d_pos, "NORMAL": d_nrm}, {"POSITION": d_sparse}],
    }]});
    if let Some(w) = mesh_weights {
        mesh["weights"] = json!(w);
    }
    let n = nodes.as_array().unwrap().len();
    json!({
        "scene": 0, "scenes": [{"nodes": (0..n).collect::<Vec<_>>()}],
        "nodes": nodes, "meshes": [mesh],
    })
}

fn instance_mesh<'a>(s: &'a Scene, node: &str) -> &'a stereocache::scene::Mesh {
    let i = s.instances.iter().find(|i| i.name == node).unwrap();
    &s.meshes[i.mesh as usize]
}

#[test]
fn default_morph_weights_shape_the_still_and_node_weights_override_them() {
    let mut b = Builder::default();
    let nodes = json!([
        {"name": "default", "mesh": 0},
        {"name": "also default", "mesh": 0, "translation": [5.0, 0.0, 0.0]},
        {"name": "override", "mesh": 0, "weights": [1.0, 0.25]},
        {"name": "rest", "mesh": 0, "weights": [0.0, 0.0]},
    ]);
    let root = morph_root(&mut b, Some(&[0.5, 0.0]), nodes);
    let s = b.load(root, "morph").unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // Three distinct weight sets → three meshes; the two default nodes share one.
    assert_eq!(s.meshes.len(), 3);
    assert_eq!(
        s.instances[0].mesh, s.instances[1].mesh,
        "same weights, same mesh"
    );
    let d = instance_mesh(&s, "default");
    // Weight 0.5: vertex 2 halfway, (0, 1, 1); vertex 1 untouched (weight 0).
    assert_eq!(
        d.positions,
        vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 1.0)]
    );
    // Normal (0,0,1) + 0.5·(0,2,−1) = (0, 1, 0.5), renormalised.
    let want = Vec3::new(0.0, 1.0, 0.5).normalize();
    assert!((d.normals[2] - want).length() < 1e-6, "{}", d.normals[2]);
    assert!((d.normals[0] - Vec3::Z).length() < 1e-6);
    let o = instance_mesh(&s, "override");
    // node.weights [1, 0.25]: vertex 2 fully moved, vertex 1 by a quarter of
    // the sparse target's (4,0,0).
    assert_eq!(
        o.positions,
        vec![
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 2.0)
        ]
    );
    let want = Vec3::new(0.0, 2.0, 0.0).normalize();
    assert!((o.normals[2] - want).length() < 1e-6, "{}", o.normals[2]);
    let r = instance_mesh(&s, "rest");
    assert_eq!(r.positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
}

#[test]
fn weight_count_mismatch_warns_and_animated_weights_warn_once_naming_the_animation() {
    let mut b = Builder::default();
    // Two nodes show the mesh: its weight problem is still one warning.
    let nodes = json!([{"name": "n", "mesh": 0}, {"name": "m", "mesh": 0}]);
    let mut root = morph_root(&mut b, Some(&[0.5]), nodes);
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let values = b.floats(&[0.0, 0.0, 1.0, 1.0], "SCALAR");
    root["animations"] = json!([{
        "name": "wiggle",
        "samplers": [{"input": times, "output": values}],
        "channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}],
    }]);
    let s = b.load(root, "morph-warn").unwrap();
    let w = s.warnings.join("\n");
    assert_eq!(s.warnings.len(), 2, "{w}");
    assert!(w.contains("1 morph weights for 2 morph targets"), "{w}");
    let anim: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("'wiggle'"))
        .collect();
    assert_eq!(anim.len(), 1, "{w}");
    assert!(anim[0].contains("morph-target weights"), "{w}");
    // The still keeps the default weights: vertex 2 halfway.
    assert_eq!(s.meshes[0].positions[2], Vec3::new(0.0, 1.0, 1.0));
}

#[test]
fn tangent_targets_move_supplied_tangents_and_keep_w() {
    // A triangle shipping normals +Z and tangents (1,0,0,−1) (tangents
    // count only with normals: glTF ignores them otherwise); target 0 adds
    // (0,1,0) to vertex 0's, default weight 1: (1,1,0)/√2, w still −1.
    let mut b = Builder::default();
    let pos = b.vec3(&[Vec3::ZERO, Vec3::X, Vec3::Y]);
    let nrm = b.vec3(&[Vec3::Z; 3]);
    let tan = b.floats(&[1.0, 0.0, 0.0, -1.0].repeat(3), "VEC4");
    let d_tan = b.vec3(&[Vec3::Y, Vec3::ZERO, Vec3::ZERO]);
    let root = json!({
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"weights": [1.0], "primitives": [{
            "attributes": {"POSITION": pos, "NORMAL": nrm, "TANGENT": tan},
            "targets": [{"TANGENT": d_tan}],
        }]}],
    });
    let s = b.load(root, "morph-tangent").unwrap();
    let t = &s.meshes[0].tangents;
    let want = Vec3::new(1.0, 1.0, 0.0).normalize().extend(-1.0);
    assert!((t[0] - want).length() < 1e-6, "{}", t[0]);
    assert_eq!(t[1], Vec4::new(1.0, 0.0, 0.0, -1.0));
}

// ---------------------------------------------------------------- EXT_mesh_gpu_instancing

const NODE_T: [f32; 3] = [0.0, 1.0, 0.0];

fn instance_trs() -> [(Vec3, Quat, Vec3); 3] {
    [
        (Vec3::ZERO, Quat::IDENTITY, Vec3::ONE),
        (
            Vec3::new(2.0, 0.0, 0.0),
            Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            Vec3::ONE,
        ),
        (Vec3::new(4.0, 0.0, -1.0), Quat::IDENTITY, Vec3::splat(2.0)),
    ]
}

/// One triangle mesh; node 0 carries it with EXT_mesh_gpu_instancing
/// (`attributes` built by `attrs`), or, `as_nodes`, three child nodes with the
/// same TRS instead.
fn instancing_file(
    tag: &str,
    as_nodes: bool,
    attrs: impl FnOnce(&mut Builder) -> Value,
) -> Result<Scene, String> {
    let mut b = Builder::default();
    let pos = b.vec3(&[Vec3::ZERO, Vec3::X, Vec3::Y]);
    let meshes = json!([{"primitives": [{"attributes": {"POSITION": pos}}]}]);
    let root = if as_nodes {
        let mut nodes =
            vec![json!({"name": "parent", "translation": NODE_T, "children": [1, 2, 3]})];
        for (t, r, s) in instance_trs() {
            nodes.push(json!({
                "mesh": 0, "translation": t.to_array(), "rotation": r.to_array(),
                "scale": s.to_array(),
            }));
        }
        json!({"scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes, "meshes": meshes})
    } else {
        let attributes = attrs(&mut b);
        json!({
            "extensionsUsed": ["EXT_mesh_gpu_instancing"],
            "extensionsRequired": ["EXT_mesh_gpu_instancing"],
            "scene": 0, "scenes": [{"nodes": [0]}],
            "nodes": [{
                "name": "forest", "mesh": 0, "translation": NODE_T,
                "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attributes}},
            }],
            "meshes": meshes,
        })
    };
    b.load(root, tag)
}

fn trs_attributes(b: &mut Builder) -> Value {
    let trs = instance_trs();
    let t: Vec<f32> = trs.iter().flat_map(|x| x.0.to_array()).collect();
    let r: Vec<f32> = trs.iter().flat_map(|x| x.1.to_array()).collect();
    let s: Vec<f32> = trs.iter().flat_map(|x| x.2.to_array()).collect();
    json!({
        "TRANSLATION": b.floats(&t, "VEC3"),
        "ROTATION": b.floats(&r, "VEC4"),
        "SCALE": b.floats(&s, "VEC3"),
        "_ID": b.floats(&[0.0, 1.0, 2.0], "SCALAR"),
    })
}

#[test]
fn gpu_instancing_gives_one_instance_per_element_sharing_the_mesh() {
    let s = instancing_file("instancing", false, trs_attributes).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.instances.len(), 3);
    let node = Mat4::from_translation(Vec3::from(NODE_T));
    for (inst, (t, r, sc)) in s.instances.iter().zip(instance_trs()) {
        assert_eq!(inst.mesh, 0);
        assert_eq!(inst.name, "forest");
        let want = node * Mat4::from_scale_rotation_translation(sc, r, t);
        // The importer renormalises the quaternion (an ulp or so) and entries
        // are ≤ 4: 1e-5 is a few ulps.
        assert!(
            inst.transform.abs_diff_eq(want, 1e-5),
            "{} vs {want}",
            inst.transform
        );
    }
    // Instance 1 (90° about Z, then +2 X, then the node's +1 Y) maps the
    // triangle's (1,0,0) to (2,2,0); instance 2 (scale 2) its (0,1,0) to (4,3,−1).
    let tris = world_triangles(&s);
    assert!((tris[1][1] - Vec3::new(2.0, 2.0, 0.0)).length() < 1e-5);
    assert!((tris[2][2] - Vec3::new(4.0, 3.0, -1.0)).length() < 1e-5);
    // The same scene written with three nodes: the same world triangles
    // (the gltf crate composes the nodes' matrices its own way: a few ulps).
    let nodes = instancing_file("instancing-nodes", true, |_| json!({})).unwrap();
    assert_eq!(nodes.meshes.len(), 1);
    let other = world_triangles(&nodes);
    assert_eq!(tris.len(), other.len());
    for (a, b) in tris.iter().zip(&other) {
        for k in 0..3 {
            assert!((a[k] - b[k]).length() < 1e-5, "{a:?} vs {b:?}");
        }
    }
}

#[test]
fn gpu_instancing_attributes_are_each_optional() {
    let s = instancing_file(
        "instancing-t",
        false,
        |b| json!({"TRANSLATION": b.floats(&[0.0, 0.0, 0.0, 3.0, 0.0, 0.0], "VEC3")}),
    )
    .unwrap();
    assert_eq!(s.instances.len(), 2);
    let want = Mat4::from_translation(Vec3::new(3.0, 1.0, 0.0));
    assert!(s.instances[1].transform.abs_diff_eq(want, 1e-6));
}

#[test]
fn gpu_instancing_reads_normalized_short_rotations_and_warns_on_unknown_attributes() {
    // 90° about Z as normalized shorts: (0, 0, 23170, 23170) / 32767 =
    // 0.70711 each, renormalised by the importer.
    let s = instancing_file("instancing-shorts", false, |b| {
        json!({
            "ROTATION": b.normalized_shorts(&[0, 0, 0, 32767, 0, 0, 23170, 23170], "VEC4"),
            "COLOR": b.floats(&[1.0, 0.0, 0.0, 1.0, 0.0, 0.0], "VEC3"),
        })
    })
    .unwrap();
    assert_eq!(s.instances.len(), 2);
    let want = Mat4::from_translation(Vec3::from(NODE_T))
        * Mat4::from_quat(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2));
    // Quantisation: 23170/32767 is within 1.5e-5 of √½ and both components
    // err alike, so the renormalised quaternion is exact to ~1e-6.
    assert!(
        s.instances[1].transform.abs_diff_eq(want, 1e-5),
        "{}",
        s.instances[1].transform
    );
    let w = s.warnings.join("\n");
    assert_eq!(s.warnings.len(), 1, "{w}");
    assert!(w.contains("node 0 'forest'") && w.contains("COLOR"), "{w}");
}

fn expect_instancing_error(tag: &str, attrs: impl FnOnce(&mut Builder) -> Value, phrase: &str) {
    let e = instancing_file(tag, false, attrs).unwrap_err();
    assert!(
        e.contains(&format!("{tag}.gltf")),
        "{tag}: names no file: {e}"
    );
    assert!(e.contains("node 0 'forest'"), "{tag}: names no node: {e}");
    assert!(e.contains(phrase), "{tag}: expected '{phrase}' in: {e}");
    assert!(!e.contains('\n'), "{tag}: {e}");
}

#[test]
fn malformed_gpu_instancing_is_an_error_naming_node_and_attribute() {
    expect_instancing_error(
        "inst-count",
        |b| {
            json!({
                "TRANSLATION": b.floats(&[0.0; 9], "VEC3"),
                "SCALE": b.floats(&[1.0; 6], "VEC3"),
            })
        },
        "different counts (TRANSLATION 3, SCALE 2)",
    );
    expect_instancing_error(
        "inst-type",
        |b| json!({"TRANSLATION": b.floats(&[0.0; 8], "VEC4")}),
        "TRANSLATION",
    );
    expect_instancing_error(
        "inst-nan",
        |b| json!({"SCALE": b.floats(&[1.0, f32::NAN, 1.0], "VEC3")}),
        "SCALE of instance 0 is not finite",
    );
    expect_instancing_error(
        "inst-zero-quat",
        |b| json!({"ROTATION": b.floats(&[0.0; 4], "VEC4")}),
        "ROTATION of instance 0 is not a unit quaternion",
    );
    expect_instancing_error(
        "inst-dangling",
        |_| json!({"TRANSLATION": 99}),
        "attribute TRANSLATION refers to accessor 99",
    );
}

#[test]
fn animated_instanced_node_keeps_each_instance_offset() {
    let mut b = Builder::default();
    let pos = b.vec3(&[Vec3::ZERO, Vec3::X, Vec3::Y]);
    let t = b.floats(&[0.0, 0.0, 0.0, 3.0, 0.0, 0.0], "VEC3");
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let values = b.floats(&[0.0, 0.0, 0.0, 0.0, 10.0, 0.0], "VEC3");
    let root = json!({
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{
            "name": "forest", "mesh": 0,
            "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": t}}},
        }],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
        "animations": [{
            "name": "rise",
            "samplers": [{"input": times, "output": values}],
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
        }],
    });
    let s = b.load(root, "instancing-animated").unwrap();
    let a = s.animation.as_ref().unwrap();
    let rest: Vec<Mat4> = s.instances.iter().map(|i| i.transform).collect();
    // Linear at t = 0.5: node at (0, 5, 0); instance 1 offset (3, 0, 0).
    let posed = a.instance_transforms(0.5, &rest);
    assert!(posed[0].abs_diff_eq(Mat4::from_translation(Vec3::new(0.0, 5.0, 0.0)), 1e-6));
    assert!(posed[1].abs_diff_eq(Mat4::from_translation(Vec3::new(3.0, 5.0, 0.0)), 1e-6));
}

// ---------------------------------------------------------------- vertex colours

/// COLOR_0 as the glTF specification allows it: float VEC3 (alpha 1), float
/// VEC4, normalized unsigned byte and short VEC4 (value = i / 255, i / 65535);
/// a wrong element count is one error naming the attribute; the glTF writer
/// keeps the colours through a round trip.
#[test]
fn color_0_in_every_allowed_encoding_and_through_the_writer() {
    let pos = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let want3 = [
        Vec4::new(0.25, 0.5, 1.0, 1.0),
        Vec4::new(1.0, 0.0, 0.125, 1.0),
        Vec4::new(0.0, 0.75, 0.5, 1.0),
    ];
    let unorm = |bytes: Vec<u8>, ct: u32, n: usize, b: &mut Builder| -> usize {
        let view = b.view(&bytes);
        b.accessors.push(json!({
            "bufferView": view, "componentType": ct, "normalized": true, "count": n, "type": "VEC4",
        }));
        b.accessors.len() - 1
    };
    let u8s: [u8; 12] = [0, 51, 102, 255, 255, 0, 17, 128, 34, 68, 136, 0];
    let u16s: [u16; 12] = [
        0, 13107, 26214, 65535, 65535, 0, 4369, 32768, 8738, 17476, 34952, 0,
    ];
    for (tag, want) in [
        ("vec3", want3.to_vec()),
        (
            "vec4",
            want3
                .iter()
                .map(|c| c.truncate().extend(0.5))
                .collect::<Vec<_>>(),
        ),
        (
            "u8",
            u8s.chunks(4)
                .map(|c| Vec4::new(c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32) / 255.0)
                .collect(),
        ),
        (
            "u16",
            u16s.chunks(4)
                .map(|c| Vec4::new(c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32) / 65535.0)
                .collect(),
        ),
    ] {
        let mut b = Builder::default();
        let p = b.vec3(&pos);
        let c = match tag {
            "vec3" => b.floats(
                &want
                    .iter()
                    .flat_map(|c| c.truncate().to_array())
                    .collect::<Vec<_>>(),
                "VEC3",
            ),
            "vec4" => b.floats(
                &want.iter().flat_map(|c| c.to_array()).collect::<Vec<_>>(),
                "VEC4",
            ),
            "u8" => unorm(u8s.to_vec(), 5121, 3, &mut b),
            _ => unorm(
                u16s.iter().flat_map(|x| x.to_le_bytes()).collect(),
                5123,
                3,
                &mut b,
            ),
        };
        let root = json!({
            "meshes": [{"primitives": [{"attributes": {"POSITION": p, "COLOR_0": c}}]}],
            "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0
        });
        let s = b.load(root, &format!("color-{tag}")).unwrap();
        assert!(
            s.warnings.iter().all(|w| !w.contains("COLOR")),
            "{tag}: {:?}",
            s.warnings
        );
        let got = &s.meshes[0].colors;
        assert_eq!(got.len(), 3, "{tag}");
        for (g, w) in got.iter().zip(&want) {
            // Exact for floats; one rounding of i / (2^k − 1) for the integers.
            assert!((*g - *w).abs().max_element() <= 1e-7, "{tag}: {g} vs {w}");
        }
        // Through the writer and back.
        let d = temp_dir(&format!("color-rt-{tag}"));
        let path = d.join("rt.gltf");
        stereocache::scene::write_gltf(&s, &path).unwrap();
        let back = load_gltf(&path).unwrap();
        assert_eq!(&back.meshes[0].colors, got, "{tag}: round trip");
    }
    // Two colours for three positions.
    let mut b = Builder::default();
    let p = b.vec3(&pos);
    let c = b.floats(&[1.0; 6], "VEC3");
    let root = json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": p, "COLOR_0": c}}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0
    });
    let e = b.load(root, "color-short").unwrap_err();
    assert!(
        e.contains("COLOR_0 has 2 elements but POSITION has 3") && !e.contains('\n'),
        "{e}"
    );
}
