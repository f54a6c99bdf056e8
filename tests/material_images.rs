//! The MaterialX `image` node in material graphs (issue 17;
//! src/materials/image.rs, shaders/materialx/image.glsl).
//!
//! Known answers: the CPU evaluator against texel values written into small
//! PNGs (texel centres, midpoints, MaterialX's lower-left origin, the four
//! address modes, sRGB decoding, mip levels from the footprint and the
//! texture coordinate's scale); the GPU against the CPU evaluator at every
//! pixel-centre hit of two image-mapped quads (the albedo output), on both
//! ray backends, with a tolerance from the device's sub-texel precision.
//! Bad image inputs give one error naming the file, graph and node.

mod common;
use common::*;
use glam::{Mat4, Vec2, Vec3};
use std::path::{Path, PathBuf};
use stereocache::camera::StereoCamera;
use stereocache::materials::{eval, Document, Geom, Graph};
use stereocache::methods::RenderSettings;
use stereocache::rt::RtChoice;
use stereocache::scene::generate::{add_material, add_mesh, grid, look_at};
use stereocache::scene::{Material, Scene};

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("material_images-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write_png(path: &Path, w: u32, h: u32, rgba: Vec<u8>) {
    image::RgbaImage::from_raw(w, h, rgba)
        .unwrap()
        .save(path)
        .unwrap();
}

/// The 4×2 test image, row 0 (the image's top) first: texel (i, j) has
/// rgb = 10·(12j + 3i + 1, +2, +3), alpha 255.
fn texel_4x2(i: usize, j: usize) -> [u8; 3] {
    let b = (12 * j + 3 * i + 1) as u8 * 10;
    [b, b + 10, b + 20]
}

fn write_4x2(d: &Path) {
    let mut px = Vec::new();
    for j in 0..2 {
        for i in 0..4 {
            px.extend_from_slice(&texel_4x2(i, j));
            px.push(255);
        }
    }
    write_png(&d.join("four_by_two.png"), 4, 2, px);
}

/// A 4×4 image whose 2×2 blocks average (in linear values) to 60, 200 (top
/// row of blocks) and 20, 100 (bottom): level 1 is exactly those, level 2
/// their mean 95. Grey (r = g = b).
fn write_4x4(d: &Path) {
    let rows: [[u8; 4]; 4] = [
        [0, 40, 200, 240],
        [80, 120, 160, 200],
        [20, 20, 100, 100],
        [20, 20, 100, 100],
    ];
    let mut px = Vec::new();
    for r in rows {
        for v in r {
            px.extend_from_slice(&[v, v, v, 255]);
        }
    }
    write_png(&d.join("four_by_four.png"), 4, 4, px);
}

/// A one-image graph: `<image>` of type `ty` reading `file` with the extra
/// `inputs` (XML), its texcoord from `texcoord` (an input line or ""),
/// after the nodes `pre`; output `base_color`.
fn image_doc(file_attrs: &str, ty: &str, inputs: &str, pre: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="g">
    {pre}
    <image name="img" type="{ty}">
      <input name="file" type="filename" {file_attrs} />
      {inputs}
    </image>
    <output name="base_color" type="{ty}" nodename="img" />
  </nodegraph>
</materialx>
"#
    )
}

fn build(d: &Path, text: &str) -> Result<Graph, String> {
    let file = d.join("g.mtlx").display().to_string();
    let doc = Document::parse(&file, text).map_err(|e| e.to_string())?;
    Graph::build(&doc, "g", &[]).map_err(|e| e.to_string())
}

fn at(g: &Graph, uv: [f32; 2], footprint: f32) -> [f32; 4] {
    eval::evaluate(
        g,
        &Geom {
            uv,
            footprint,
            ..Default::default()
        },
    )[0]
    .v
}

fn lin(t: [u8; 3]) -> [f32; 3] {
    t.map(|c| c as f32 / 255.0)
}

fn srgb(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn close(got: [f32; 4], want: [f32; 3], tol: f32, what: &str) {
    for c in 0..3 {
        assert!(
            (got[c] - want[c]).abs() <= tol,
            "{what}: got {got:?}, want {want:?}"
        );
    }
}

/// How far a GPU's sRGB decode of the code whose exact decode is `v` may
/// be off: less than half the step to the next code, so that it still
/// identifies its code (llvmpipe's decode is an approximation: 7.5·10⁻⁴ off
/// at code 130, where the half step is 1.9·10⁻³). Exact values (0, 1 and
/// the default's) are codes 0 and 255: half the first step, 1.5·10⁻⁴.
fn decode_tol(v: f32) -> f32 {
    let code = (0..=255u8)
        .min_by(|a, b| (srgb(*a) - v).abs().total_cmp(&(srgb(*b) - v).abs()))
        .unwrap();
    let next = if code == 255 {
        srgb(254)
    } else {
        srgb(code + 1)
    };
    0.5 * (next - srgb(code)).abs() + 1e-6
}

/// f32 arithmetic of a bilinear blend of values ≤ 1: a few ulp.
const F32_TOL: f32 = 4.0 * f32::EPSILON;

#[test]
fn the_cpu_image_node_reads_the_texels_the_file_holds() {
    let d = dir("cpu");
    write_4x2(&d);
    let f = r#"value="four_by_two.png""#;
    let closest = r#"<input name="filtertype" type="string" value="closest" />"#;
    let g = build(&d, &image_doc(f, "color3", closest, "")).unwrap();
    // MaterialX's origin is the image's lower-left corner: v < 0.5 reads row 1.
    for j in 0..2 {
        for i in 0..4 {
            let uv = [(i as f32 + 0.5) / 4.0, 1.0 - (j as f32 + 0.5) / 2.0];
            close(
                at(&g, uv, 0.0),
                lin(texel_4x2(i, j)),
                0.0,
                &format!("texel ({i}, {j})"),
            );
        }
    }
    // Linear: the midpoint of two texel centres is their mean; periodic at u = 0
    // blends the row's last and first texels.
    let g = build(&d, &image_doc(f, "color3", "", "")).unwrap();
    let mean = |a: [u8; 3], b: [u8; 3]| [0, 1, 2].map(|c| (a[c] as f32 + b[c] as f32) / 510.0);
    close(
        at(&g, [0.25, 0.25], 0.0),
        mean(texel_4x2(0, 1), texel_4x2(1, 1)),
        F32_TOL,
        "midpoint",
    );
    close(
        at(&g, [0.0, 0.75], 0.0),
        mean(texel_4x2(3, 0), texel_4x2(0, 0)),
        F32_TOL,
        "periodic seam",
    );
    // Address modes (closest, so each reads one texel).
    let modes = |u: &str, v: &str| {
        format!(
            r#"{closest}<input name="uaddressmode" type="string" value="{u}" /><input name="vaddressmode" type="string" value="{v}" /><input name="default" type="color3" value="0.5, 0.25, 0.125" />"#
        )
    };
    let g = build(&d, &image_doc(f, "color3", &modes("clamp", "clamp"), "")).unwrap();
    close(
        at(&g, [1.3, 0.75], 0.0),
        lin(texel_4x2(3, 0)),
        0.0,
        "clamp u",
    );
    close(
        at(&g, [-0.4, -0.5], 0.0),
        lin(texel_4x2(0, 1)),
        0.0,
        "clamp u, v",
    );
    let g = build(
        &d,
        &image_doc(f, "color3", &modes("mirror", "periodic"), ""),
    )
    .unwrap();
    close(
        at(&g, [1.125, 0.75], 0.0),
        lin(texel_4x2(3, 0)),
        0.0,
        "mirror u = 1.125 reads 0.875",
    );
    close(
        at(&g, [0.375, 1.25], 0.0),
        lin(texel_4x2(1, 1)),
        0.0,
        "periodic v = 1.25 reads 0.25",
    );
    let g = build(
        &d,
        &image_doc(f, "color3", &modes("periodic", "mirror"), ""),
    )
    .unwrap();
    close(
        at(&g, [1.125, 0.75], 0.0),
        lin(texel_4x2(0, 0)),
        0.0,
        "periodic u = 1.125 reads 0.125",
    );
    close(
        at(&g, [0.125, -0.25], 0.0),
        lin(texel_4x2(0, 1)),
        0.0,
        "mirror v = -0.25 reads 0.25",
    );
    let g = build(&d, &image_doc(f, "color3", &modes("constant", "clamp"), "")).unwrap();
    close(
        at(&g, [1.2, 0.75], 0.0),
        [0.5, 0.25, 0.125],
        0.0,
        "constant outside",
    );
    close(
        at(&g, [0.125, 0.75], 0.0),
        lin(texel_4x2(0, 0)),
        0.0,
        "constant inside",
    );
    close(
        at(&g, [0.125, 1.5], 0.0),
        lin(texel_4x2(0, 0)),
        0.0,
        "clamp v beside constant u",
    );
    // sRGB files decode per texel.
    let fs = r#"value="four_by_two.png" colorspace="srgb_texture""#;
    let g = build(&d, &image_doc(fs, "color3", closest, "")).unwrap();
    close(
        at(&g, [0.125, 0.25], 0.0),
        texel_4x2(0, 1).map(srgb),
        1e-7,
        "sRGB",
    );
    // A colorspace on the document is inherited.
    let text = image_doc(f, "color3", closest, "").replace(
        r#"<materialx version="1.39">"#,
        r#"<materialx version="1.39" colorspace="srgb_texture">"#,
    );
    let g = build(&d, &text).unwrap();
    close(
        at(&g, [0.125, 0.25], 0.0),
        texel_4x2(0, 1).map(srgb),
        1e-7,
        "inherited sRGB",
    );
    // A float image reads the first channel.
    let g = build(&d, &image_doc(f, "float", closest, "")).unwrap();
    assert_eq!(
        at(&g, [0.125, 0.25], 0.0)[0],
        texel_4x2(0, 1)[0] as f32 / 255.0
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn the_footprint_and_the_texcoord_scale_pick_the_mip_level() {
    let d = dir("lod");
    write_4x4(&d);
    let f = r#"value="four_by_four.png""#;
    let g = build(&d, &image_doc(f, "color3", "", "")).unwrap();
    let grey = |v: f32| [v / 255.0; 3];
    // The top-left level-1 texel's centre: level 0 (footprint 0) blends the
    // four texels around it (mean 60 too), level 1 reads 60, level 2 the mean 95.
    let c = [0.25, 0.75];
    close(
        at(&g, c, 0.0),
        grey(60.0),
        F32_TOL,
        "level 0 at the block corner",
    );
    close(
        at(&g, c, 0.5),
        grey(60.0),
        F32_TOL,
        "footprint 1/2: level 1",
    );
    close(at(&g, c, 1.0), grey(95.0), F32_TOL, "footprint 1: level 2");
    close(at(&g, c, 8.0), grey(95.0), F32_TOL, "beyond the last level");
    // λ = 1.5: halfway between levels 1 and 2.
    close(
        at(&g, c, 0.5 * 2f32.sqrt()),
        grey(77.5),
        1e-6,
        "trilinear λ = 1.5",
    );
    // The texture coordinate's scale: texcoord = 2·uv (place2d scale ½)
    // doubles the footprint. Closest filter, at the top-left texel's
    // centre t = (1/8, 7/8): level 0 reads 0, level 1 reads 60.
    let closest = r#"<input name="filtertype" type="string" value="closest" />
      <input name="texcoord" type="vector2" nodename="tc" />"#;
    let pre = r#"<texcoord name="uv" type="vector2" />
    <place2d name="tc" type="vector2"><input name="texcoord" type="vector2" nodename="uv" /><input name="scale" type="vector2" value="0.5, 0.5" /></place2d>"#;
    let g = build(&d, &image_doc(f, "color3", closest, pre)).unwrap();
    let uv = [0.0625, 0.4375];
    close(
        at(&g, uv, 0.0),
        grey(0.0),
        0.0,
        "scaled texcoord, footprint 0",
    );
    close(
        at(&g, uv, 0.125),
        grey(0.0),
        0.0,
        "λ = log2(1/8 · 2 · 4) = 0",
    );
    close(
        at(&g, uv, 0.25),
        grey(60.0),
        0.0,
        "λ = log2(1/4 · 2 · 4) = 1",
    );
    // Without the scale, 1/4 would be level 0 (the footprint alone).
    let plain = build(
        &d,
        &image_doc(
            f,
            "color3",
            r#"<input name="filtertype" type="string" value="closest" />"#,
            "",
        ),
    )
    .unwrap();
    close(
        at(&plain, [0.125, 0.875], 0.25),
        grey(0.0),
        0.0,
        "unscaled: level 0",
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_image_inputs_error_clearly() {
    let d = dir("errors");
    write_4x2(&d);
    let f = r#"value="four_by_two.png""#;
    // A file that cannot be read (missing, empty name, not an image): the
    // node gives its `default` input, as MaterialX specifies ("a default
    // value to use if the file reference can not be resolved") and its
    // renderer does, with one warning naming the file, graph and node
    // (until session 51 a load error).
    std::fs::write(d.join("not_an_image.png"), b"plain text").unwrap();
    let default = r#"<input name="default" type="color3" value="0.2, 0.4, 0.6" />"#;
    for (what, file, needle) in [
        ("missing file", r#"value="nowhere.png""#, "nowhere.png"),
        ("empty file", r#"value="""#, "input `file` is empty"),
        (
            "not an image",
            r#"value="not_an_image.png""#,
            "not_an_image.png",
        ),
    ] {
        let g = build(&d, &image_doc(file, "color3", default, ""))
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(g.warnings.len(), 1, "{what}: {:?}", g.warnings);
        let w = &g.warnings[0];
        assert!(
            w.contains(needle)
                && w.contains("g.mtlx")
                && w.contains("graph `g`")
                && w.contains("node `img`")
                && w.contains("default"),
            "{what}: {w}"
        );
        let v = at(&g, [0.3, 0.7], 0.0);
        assert_eq!(&v[..3], &[0.2, 0.4, 0.6], "{what}: the default input");
        assert!(g.images.is_empty(), "{what}: no image to bind");
        // Without a default input: the nodedef's, 0.
        let g = build(&d, &image_doc(file, "color3", "", "")).unwrap();
        assert_eq!(
            &at(&g, [0.3, 0.7], 0.0)[..3],
            &[0.0; 3],
            "{what}: the nodedef's default"
        );
    }
    let cases: [(&str, String, &str); 4] = [
        (
            "layer",
            image_doc(
                f,
                "color3",
                r#"<input name="layer" type="string" value="diffuse" />"#,
                "",
            ),
            "layers are not supported",
        ),
        (
            "address mode",
            image_doc(
                f,
                "color3",
                r#"<input name="uaddressmode" type="string" value="wrap" />"#,
                "",
            ),
            "uaddressmode` is `wrap`",
        ),
        (
            "colour space",
            image_doc(
                r#"value="four_by_two.png" colorspace="acescg""#,
                "color3",
                "",
                "",
            ),
            "colorspace `acescg`",
        ),
        (
            "frames",
            image_doc(
                f,
                "color3",
                r#"<input name="framerange" type="string" value="1-10" />"#,
                "",
            ),
            "image sequences are not supported",
        ),
    ];
    for (what, text, needle) in cases {
        let e = build(&d, &text).expect_err(what);
        assert!(e.contains(needle), "{what}: {e}");
        assert!(
            e.contains("g.mtlx") && e.contains("graph `g`") && e.contains("node `img`"),
            "{what}: {e}"
        );
        assert_eq!(e.lines().count(), 1, "{what}: one line: {e}");
    }
    // cubic: the documented fallback, with a warning naming the node.
    let g = build(
        &d,
        &image_doc(
            f,
            "color3",
            r#"<input name="filtertype" type="string" value="cubic" />"#,
            "",
        ),
    )
    .unwrap();
    assert_eq!(g.warnings.len(), 1);
    assert!(
        g.warnings[0].contains("node `img`") && g.warnings[0].contains("cubic"),
        "{:?}",
        g.warnings
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// Two 1 m quads in the XZ plane facing +Y (uv 0..1 each), written as glTF,
/// each material bound to an image graph through `extras.materialx`:
/// material 0 linear, u clamp / v mirror; material 1 closest, sRGB, u
/// periodic / v constant (default magenta); both read texcoord 3·uv − 1
/// (so two thirds of each axis lie outside [0, 1]).
fn image_quads(d: &Path) -> PathBuf {
    write_4x2(d);
    let mut s = Scene {
        source: "test:image-quads".into(),
        ..Default::default()
    };
    for (k, x0) in [-1.05f32, 0.05].into_iter().enumerate() {
        let m = add_material(&mut s, Material::diffuse(&format!("m{k}"), Vec3::ONE));
        let g = grid(
            "quad",
            Vec3::new(x0, 0.0, 0.5),
            Vec3::X,
            Vec3::NEG_Z,
            1,
            1,
            Vec2::ONE,
        );
        add_mesh(&mut s, g, m, Mat4::IDENTITY);
    }
    s.validate().unwrap();
    let path = d.join("quads.gltf");
    stereocache::scene::write_gltf(&s, &path).unwrap();
    let pre = r#"<texcoord name="uv" type="vector2" />
    <multiply name="s" type="vector2"><input name="in1" type="vector2" nodename="uv" /><input name="in2" type="float" value="3.0" /></multiply>
    <subtract name="tc" type="vector2"><input name="in1" type="vector2" nodename="s" /><input name="in2" type="float" value="1.0" /></subtract>"#;
    let tc = r#"<input name="texcoord" type="vector2" nodename="tc" />"#;
    let docs = [
        image_doc(
            r#"value="images/four_by_two.png""#,
            "color3",
            &format!(
                r#"{tc}<input name="uaddressmode" type="string" value="clamp" /><input name="vaddressmode" type="string" value="mirror" />"#
            ),
            pre,
        ),
        image_doc(
            r#"value="images/four_by_two.png" colorspace="srgb_texture""#,
            "color3",
            &format!(
                r#"{tc}<input name="filtertype" type="string" value="closest" /><input name="vaddressmode" type="string" value="constant" /><input name="default" type="color3" value="1, 0, 1" />"#
            ),
            pre,
        ),
    ];
    std::fs::create_dir_all(d.join("images")).unwrap();
    std::fs::rename(d.join("four_by_two.png"), d.join("images/four_by_two.png")).unwrap();
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    for (k, text) in docs.iter().enumerate() {
        std::fs::write(d.join(format!("img{k}.mtlx")), text).unwrap();
        j["materials"][k]["extras"] =
            serde_json::json!({ "materialx": { "file": format!("img{k}.mtlx"), "graph": "g" } });
    }
    std::fs::write(&path, serde_json::to_string_pretty(&j).unwrap()).unwrap();
    path
}

fn top_camera() -> StereoCamera {
    let c = look_at(
        "top",
        Vec3::new(0.0, 2.2, 0.0),
        Vec3::ZERO,
        Vec3::NEG_Z,
        60.0,
    );
    StereoCamera::from_scene_camera(c.transform, c.yfov, 40.0 / 24.0)
}

/// The uv of a stored first hit, rebuilt on the CPU (barycentrics in 24 bits).
fn hit_uv(scene: &Scene, fh: [u32; 4]) -> (u32, Vec2) {
    let inst = &scene.instances[fh[3] as usize];
    let mesh = &scene.meshes[inst.mesh as usize];
    let (idx, w) = first_hit_weights(scene, fh);
    let uv: Vec2 = (0..3).map(|k| mesh.uvs[idx[k]] * w[k]).sum();
    (mesh.material, uv)
}

#[test]
fn image_graphs_render_the_cpu_evaluators_texels() {
    let ctx = context();
    let d = dir("render");
    let path = image_quads(&d);
    let scene = stereocache::scene::load_gltf(&path).expect("image graphs load");
    assert_eq!(scene.graphs.images().count(), 2);
    let settings = RenderSettings {
        width: 80,
        height: 48,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    // Tolerances. The quads' uv spans 1 m and the texcoord 3 units: a pixel's
    // cone (≤ 2.2 m · 2 tan 30° / 48 ≈ 0.053 m, ≤ 0.16 texcoord units at
    // the steepest incidence here) is under a texel (1/4 or 1/2), so every
    // lookup is magnified (λ < 0) and the footprint does not enter. Linear:
    // the weights are exact to q = 2^-subTexelPrecisionBits per axis (texel
    // spread ≤ 1: 2q); the rebuilt uv is off by ≤ 2⁻²⁴ · 16 per coordinate,
    // 3·4·that in texels. Closest: pixels within q + e of a texel edge may
    // read either neighbour (an implementation may snap to 2^-bits of a
    // texel): compared against both.
    let q = 0.5f32.powi(ctx.caps.sub_texel_precision_bits.max(4) as i32);
    let e = 3.0 * 4.0 * 16.0 / 16_777_216.0;
    for rt in [RtChoice::Software, RtChoice::Query] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let s = session(&ctx, scene.clone(), rt);
        let f = render(&s, "reference", top_camera(), &settings);
        let mut checked = [0usize; 2];
        let mut outside = [0usize; 2];
        for eye in &f.eyes {
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (mat, uv) = hit_uv(&s.scene, *fh);
                let g = &s.scene.graphs.graphs[s.scene.graphs.of_material(mat)[0].graph];
                let got = Vec3::from_slice(&eye.albedo[i][..3]);
                // The graph sees the mesh's uv with v up (eval::graph_uv).
                let cpu =
                    |uv: Vec2| Vec3::from_slice(&at(g, eval::graph_uv(uv.to_array()), 0.0)[..3]);
                let want = cpu(uv);
                let tc = Vec2::from(eval::graph_uv(uv.to_array())) * 3.0 - 1.0;
                outside[mat as usize] +=
                    (tc.x < 0.0 || tc.x > 1.0 || tc.y < 0.0 || tc.y > 1.0) as usize;
                let ok = if mat == 0 {
                    (got - want).abs().max_element() <= 2.0 * q + 2.0 * e + 1e-6
                } else {
                    // Either side of a nearby texel edge (texels 1/4 × 1/2 in t = 3uv − 1),
                    // each decoded from sRGB to within half the step to the next code.
                    let d = (q + e) / 3.0 * Vec2::new(0.25, 0.5);
                    [
                        Vec2::ZERO,
                        Vec2::new(d.x, 0.0),
                        Vec2::new(-d.x, 0.0),
                        Vec2::new(0.0, d.y),
                        Vec2::new(0.0, -d.y),
                    ]
                    .iter()
                    .any(|o| {
                        let w = cpu(uv + *o);
                        (0..3).all(|c| (got[c] - w[c]).abs() <= decode_tol(w[c]))
                    })
                };
                assert!(
                    ok,
                    "{rt:?}: material {mat} pixel {i} (uv {uv}): GPU {got}, CPU {want}"
                );
                checked[mat as usize] += 1;
            }
        }
        // Both quads seen, most of them through the wrap modes.
        for m in 0..2 {
            assert!(checked[m] > 400, "{rt:?}: material {m}: {checked:?}");
            assert!(
                outside[m] * 2 > checked[m],
                "{rt:?}: material {m} outside [0,1]: {outside:?} of {checked:?}"
            );
        }
    }
    assert_no_validation_messages(&ctx);

    // Written back with the scene: the image is copied beside the document.
    let out = dir("render-export");
    stereocache::scene::write_gltf(&scene, &out.join("again.gltf")).unwrap();
    assert_eq!(
        std::fs::read(out.join("images/four_by_two.png")).unwrap(),
        std::fs::read(d.join("images/four_by_two.png")).unwrap()
    );
    let again = stereocache::scene::load_gltf(&out.join("again.gltf")).expect("reloads");
    assert_eq!(again.graphs.images().count(), 2);
    let _ = std::fs::remove_dir_all(&d);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn texture_procedurals_read_image_files_beside_the_gltf() {
    let d = dir("khr");
    write_4x2(&d);
    let pj = serde_json::json!({
        "name": "k", "nodetype": "nodegraph", "type": "color3",
        "nodes": [ { "name": "img", "nodetype": "image", "type": "color3", "inputs": [
            { "name": "file", "nodetype": "input", "type": "filename", "value": "four_by_two.png" },
            { "name": "filtertype", "nodetype": "input", "type": "string", "value": "closest" } ] } ],
        "outputs": [ { "name": "out", "nodetype": "output", "type": "color3", "node": 0 } ]
    });
    let gltf = d.join("scene.gltf").display().to_string();
    let g = stereocache::materials::binding::procedural_graph(&gltf, 0, &pj).expect("loads");
    close(
        at(&g, [0.125, 0.25], 0.0),
        lin(texel_4x2(0, 1)),
        0.0,
        "KHR image",
    );
    // A glTF texture index instead of a file: one clear error.
    let mut bad = pj.clone();
    bad["nodes"][0]["inputs"][0] = serde_json::json!(
        { "name": "file", "nodetype": "input", "type": "filename", "texture": 0 });
    let e = stereocache::materials::binding::procedural_graph(&gltf, 0, &bad)
        .expect_err("texture index")
        .to_string();
    assert!(
        e.contains("glTF texture") && e.contains("node `img`"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// Image nodes read through the memoization table (`--memo primary`): a
/// memoized texel of level m holds the graph evaluated at the texel's
/// centre for the footprint 2^-m, which the image turns into a mip level
/// (×3, the texture coordinate's scale). A 64×64 image of checkers (whose
/// mips differ from level 0) read trilinearly through texcoord 3·uv − 1
/// puts those levels at λ ≈ 3–4 here, so the footprint passed through the
/// table decides the value.
/// Known answer: the CPU evaluator at the snapped uv with that footprint.
/// Tolerance: bilinear weights to q = 2^-subTexelPrecisionBits per axis
/// (2q), the blend of two levels snapped to 2^-mipmapPrecisionBits (values
/// in [0, 1]), f32 rounding 10⁻⁶.
#[test]
fn image_graphs_read_through_the_memo_table_at_texel_centres() {
    use stereocache::materials::memo::{lod, MemoHits, MemoSettings};
    let ctx = context();
    let d = dir("memo");
    let mut px = Vec::new();
    for y in 0..64u32 {
        for x in 0..64u32 {
            // Red: a one-texel checker (0/255; its mips are grey), green: a ramp,
            // blue: a 4-texel checker — so every level reads differently.
            let r = if (x + y) % 2 == 0 { 255 } else { 0 };
            let b = if (x / 4 + y / 4) % 2 == 0 { 255 } else { 0 };
            px.extend_from_slice(&[r, (y * 4) as u8, b, 255]);
        }
    }
    write_png(&d.join("ramp.png"), 64, 64, px);
    let mut s = Scene {
        source: "test:image-memo".into(),
        ..Default::default()
    };
    let mut m = Material::diffuse("ramp", Vec3::ONE);
    let pre = r#"<texcoord name="uv" type="vector2" />
    <multiply name="s" type="vector2"><input name="in1" type="vector2" nodename="uv" /><input name="in2" type="float" value="3.0" /></multiply>
    <subtract name="tc" type="vector2"><input name="in1" type="vector2" nodename="s" /><input name="in2" type="float" value="1.0" /></subtract>"#;
    let text = image_doc(
        r#"value="ramp.png""#,
        "color3",
        r#"<input name="texcoord" type="vector2" nodename="tc" />"#,
        pre,
    );
    let file = d.join("g.mtlx").display().to_string();
    s.graphs
        .attach_mtlx(0, &mut m, &file, &text)
        .expect("binds");
    let mat = add_material(&mut s, m);
    let g = grid(
        "quad",
        Vec3::new(-0.5, 0.0, 0.5),
        Vec3::X,
        Vec3::NEG_Z,
        1,
        1,
        Vec2::ONE,
    );
    add_mesh(&mut s, g, mat, Mat4::IDENTITY);
    s.validate().unwrap();
    s.graphs.memo = MemoSettings {
        hits: MemoHits::Primary,
        ..Default::default()
    };
    let (w, h) = (40u32, 24u32);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    let camera = top_camera();
    let q = 0.5f32.powi(ctx.caps.sub_texel_precision_bits.max(4) as i32);
    let qm = 0.5f32.powi(ctx.caps.mipmap_precision_bits.max(4) as i32);
    let tol = 2.0 * q + qm + 1e-6;
    for rt in [RtChoice::Software, RtChoice::Query] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let sess = session(&ctx, s.clone(), rt);
        let f = render(&sess, "reference", camera, &settings);
        let c = sess.scene_gpu.memo.as_ref().unwrap().counters().unwrap();
        assert!(c.hits + c.misses > 0 && c.bypassed == 0, "{rt:?}: {c:?}");
        let graph = &sess.scene.graphs.graphs[0];
        let (mut checked, mut lambdas) = (0usize, Vec::new());
        for (e, eye) in f.eyes.iter().enumerate() {
            let view = camera.eyes()[e];
            let spread = 2.0 * view.tan_half_fov().y / h as f32;
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (_, uv) = hit_uv(&sess.scene, *fh);
                let pxc = Vec2::new((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
                let dir = view.ray_direction(pxc, glam::UVec2::new(w, h));
                let t = -view.position.y / dir.y;
                let cone = t * spread;
                // The level (and, within 2^-20 of a texel edge, the texel)
                // the GPU may have chosen from its own f32 cone and uv.
                let mut levels = vec![lod::level(cone, 1.0, 0.0)];
                for k in [0.999f32, 1.001] {
                    let l = lod::level(cone * k, 1.0, 0.0);
                    if !levels.contains(&l) {
                        levels.push(l);
                    }
                }
                let got = Vec3::from_slice(&eye.albedo[i][..3]);
                let eps = 2.0f32.powi(-20);
                let ok = levels.iter().any(|&m| {
                    [-eps, 0.0, eps].iter().any(|du| {
                        [-eps, 0.0, eps].iter().any(|dv| {
                            let qq = lod::quantise([uv.x + du, uv.y + dv], m);
                            let at = lod::snapped_uv(qq, m);
                            let want = Vec3::from_slice(
                                &super_at(graph, eval::graph_uv(at), 2f32.powi(-m))[..3],
                            );
                            (got - want).abs().max_element() <= tol
                        })
                    })
                });
                let m0 = levels[0];
                lambdas.push((2f32.powi(-m0) * 3.0 * 64.0).log2());
                assert!(
                    ok,
                    "{rt:?}: eye {e} pixel {i} (uv {uv}, level {m0}): GPU {got}"
                );
                checked += 1;
            }
        }
        // The 1 m quad covers about 9.4 × 9.4 pixels an eye at 2.2 m.
        assert!(checked > 150, "{rt:?}: {checked}");
        // The footprint mattered: the levels read lie between mips, above 0.
        let lo = lambdas.iter().cloned().fold(f32::INFINITY, f32::min);
        assert!(lo > 1.0, "{rt:?}: image levels from {lo}");
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// [`at`] under another name (the memo test's closure shadows it).
fn super_at(g: &Graph, uv: [f32; 2], footprint: f32) -> [f32; 4] {
    at(g, uv, footprint)
}

/// glTF uvs reach graphs with v flipped: MaterialX's texture space has v up
/// (origin at the image's lower left) and MaterialX's own glTF loader flips
/// incoming v. Three quads whose glTF uv (0, 0) corner is the image's top
/// left (`grid`: v = 0 at origin + ev, −z, the top camera's up): a graph
/// outputting texcoord shows (u, 1 − v) — (0, 1), MaterialX's top left, at
/// the top-left corner — and an image node shows its file upright, exactly
/// as the glTF baseColorTexture of the same file does (top row red, bottom
/// row green). Before the fix the texcoord read (0, 0) there and the image
/// node showed the file upside down.
#[test]
fn graphs_see_gltf_uvs_with_v_up_and_images_stay_upright() {
    let ctx = context();
    let d = dir("vflip");
    // 1×2: the top row red, the bottom row green.
    let px = vec![255, 0, 0, 255, 0, 255, 0, 255];
    write_png(&d.join("updown.png"), 1, 2, px.clone());
    let mut s = Scene {
        source: "test:vflip".into(),
        ..Default::default()
    };
    s.textures.push(stereocache::scene::Texture::with_mips(
        "updown".into(),
        stereocache::scene::TextureEncoding::Srgb,
        1,
        2,
        px,
    ));
    let mats = [
        Material::diffuse("texcoord", Vec3::ONE),
        Material::diffuse("image", Vec3::ONE),
        Material {
            base_color_texture: Some(stereocache::scene::TextureRef::new(0)),
            ..Material::diffuse("texture", Vec3::ONE)
        },
    ];
    let x0s = [-1.6f32, -0.5, 0.6];
    for (m, x0) in mats.into_iter().zip(x0s) {
        let m = add_material(&mut s, m);
        let g = grid(
            "quad",
            Vec3::new(x0, 0.0, 0.5),
            Vec3::X,
            Vec3::NEG_Z,
            1,
            1,
            Vec2::ONE,
        );
        add_mesh(&mut s, g, m, Mat4::IDENTITY);
    }
    s.validate().unwrap();
    let path = d.join("vflip.gltf");
    stereocache::scene::write_gltf(&s, &path).unwrap();
    std::fs::write(
        d.join("texcoord.mtlx"),
        r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="g">
    <texcoord name="t" type="vector3" />
    <convert name="c" type="color3"><input name="in" type="vector3" nodename="t" /></convert>
    <output name="base_color" type="color3" nodename="c" />
  </nodegraph>
</materialx>
"#,
    )
    .unwrap();
    std::fs::write(
        d.join("image.mtlx"),
        image_doc(
            r#"value="updown.png" colorspace="srgb_texture""#,
            "color3",
            r#"<input name="filtertype" type="string" value="closest" />"#,
            "",
        ),
    )
    .unwrap();
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    for (k, f) in ["texcoord.mtlx", "image.mtlx"].iter().enumerate() {
        j["materials"][k]["extras"] =
            serde_json::json!({ "materialx": { "file": f, "graph": "g" } });
    }
    std::fs::write(&path, serde_json::to_string_pretty(&j).unwrap()).unwrap();
    let scene = stereocache::scene::load_gltf(&path).expect("v-flip scene loads");
    // The glTF uv (0, 0) corner is at −x, −z: the image's top left.
    for inst in &scene.instances {
        let m = &scene.meshes[inst.mesh as usize];
        let k = m.uvs.iter().position(|uv| *uv == Vec2::ZERO).unwrap();
        let p = inst.transform.transform_point3(m.positions[k]);
        assert_eq!(p.z, -0.5, "uv (0, 0) at {p}");
        assert_eq!(p.x, x0s[m.material as usize], "uv (0, 0) at {p}");
    }
    let settings = RenderSettings {
        width: 80,
        height: 48,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    for rt in [RtChoice::Software, RtChoice::Query] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let s = session(&ctx, scene.clone(), rt);
        let f = render(&s, "reference", top_camera(), &settings);
        let w = f.width as usize;
        let mut rows = [[0usize; 2]; 3];
        for eye in &f.eyes {
            // Material 0's hit nearest the image's top-left corner.
            let mut corner: Option<(usize, Vec2, Vec3)> = None;
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX {
                    continue;
                }
                let (mat, uv) = hit_uv(&s.scene, *fh);
                let got = Vec3::from_slice(&eye.albedo[i][..3]);
                if mat == 0 {
                    let want = Vec3::new(uv.x, 1.0 - uv.y, 0.0);
                    assert!(
                        (got - want).abs().max_element() <= 1e-4,
                        "{rt:?}: pixel {i} (uv {uv}): texcoord {got}, want {want}"
                    );
                    let d = i % w + i / w;
                    if corner.is_none_or(|c| d < c.0) {
                        corner = Some((d, uv, got));
                    }
                    continue;
                }
                // Images: the top row (glTF v < ½) red, the bottom green
                // (the glTF texture filters linearly and wraps: by at least
                // 0.2 away from the middle and the wrap seam).
                let row = if uv.y > 0.05 && uv.y < 0.45 {
                    0
                } else if uv.y > 0.55 && uv.y < 0.95 {
                    1
                } else {
                    continue;
                };
                let (hi, lo) = if row == 0 {
                    (got.x, got.y)
                } else {
                    (got.y, got.x)
                };
                assert!(
                    hi > lo + 0.15 && got.z < 1e-3,
                    "{rt:?}: material {mat} pixel {i} (uv {uv}): {got}, want {}",
                    ["red", "green"][row]
                );
                rows[mat as usize][row] += 1;
            }
            let (_, uv, tc) = corner.expect("material 0 is seen");
            assert!(
                uv.max_element() < 0.15 && tc.x < 0.15 && tc.y > 0.85,
                "{rt:?}: top-left hit: uv {uv}, texcoord {tc} (MaterialX's top left is (0, 1))"
            );
        }
        for (m, r) in rows.iter().enumerate().skip(1) {
            assert!(
                r.iter().all(|&n| n > 100),
                "{rt:?}: material {m} rows {r:?}"
            );
        }
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}
