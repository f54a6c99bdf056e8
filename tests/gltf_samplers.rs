//! glTF samplers (issue 18): wrap modes (REPEAT, CLAMP_TO_EDGE,
//! MIRRORED_REPEAT) and filters (magFilter, minFilter with and without
//! mipmaps) on both ray backends, read through the albedo output (the base
//! colour at the pixel-centre hit, factor 1, so the texture sample itself).
//!
//! The oracle is the Vulkan sampling rule (texel selection and wrapping of
//! the spec's "Texel Coordinate Systems" / "Wrapping Operation"), evaluated on
//! the CPU at each pixel's hit point rebuilt from its stored first hit; the
//! oracle itself is checked against the glTF statements (clamp shows the edge
//! texel, mirrored u = 1.25 reads u = 0.75, repeat u = 1.25 reads u = 0.25).
//! Texels are 0 or 255 per channel, which sRGB decodes to exactly 0 and 1.

mod common;
use base64::Engine;
use common::*;
use glam::{Vec2, Vec3};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use stereocache::camera::StereoCamera;
use stereocache::methods::RenderSettings;
use stereocache::rt::gpu_scene::TextureSlots;
use stereocache::rt::RtChoice;
use stereocache::scene::{Filter, Scene, TextureSampler, Wrap};

const NEAREST: u32 = 9728;
const LINEAR: u32 = 9729;
const NEAREST_MIPMAP_NEAREST: u32 = 9984;
const REPEAT: u32 = 10497;
const CLAMP: u32 = 33071;
const MIRROR: u32 = 33648;

/// The 2×2 magnification image, row 0 first (glTF v = 0 is the image's top):
/// red, green / blue, white.
const MAG_TEXELS: [[u8; 4]; 4] = [
    [255, 0, 0, 255],
    [0, 255, 0, 255],
    [0, 0, 255, 255],
    [255, 255, 255, 255],
];

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("gltf_samplers-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn png_data_uri(w: u32, h: u32, rgba: Vec<u8>) -> String {
    let img = image::RgbaImage::from_raw(w, h, rgba).unwrap();
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png)
    )
}

/// Quad k of `n` in a 3-column grid of 1 m squares (0.1 m apart) in the
/// z = 0 plane facing +z: (x0, y0, x1, y1).
fn quad_rect(k: usize, n: usize) -> (f32, f32, f32, f32) {
    let rows = n.div_ceil(3);
    let cx = (k % 3) as f32 * 1.1 - 1.1;
    let cy = ((rows - 1) as f32 * 0.5 - (k / 3) as f32) * 1.1;
    (cx - 0.5, cy - 0.5, cx + 0.5, cy + 0.5)
}

/// A glTF with one quad per entry of `samplers` (None: a texture without
/// sampler), each with its own material whose base colour texture reads
/// image 0 through that sampler; uv spans `uv_lo..uv_hi` in both directions
/// (u along +x, v along −y). One image, one glTF texture per quad.
fn write_quads(
    d: &Path,
    image_uri: &str,
    samplers: &[Option<Value>],
    uv_lo: f32,
    uv_hi: f32,
) -> PathBuf {
    let n = samplers.len();
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    let mut push = |bin: &mut Vec<u8>, bytes: Vec<u8>| {
        let offset = bin.len();
        bin.extend_from_slice(&bytes);
        views.push(json!({ "buffer": 0, "byteOffset": offset, "byteLength": bytes.len() }));
        views.len() - 1
    };
    for k in 0..n {
        let (x0, y0, x1, y1) = quad_rect(k, n);
        let pos = [[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]];
        let uv = [
            [uv_lo, uv_hi],
            [uv_hi, uv_hi],
            [uv_hi, uv_lo],
            [uv_lo, uv_lo],
        ];
        let f = |v: &[[f32; 3]]| v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let vp = push(&mut bin, f(&pos));
        let vn = push(&mut bin, f(&[[0.0, 0.0, 1.0]; 4]));
        let vt = push(
            &mut bin,
            uv.iter()
                .flatten()
                .flat_map(|x: &f32| x.to_le_bytes())
                .collect(),
        );
        let vi = push(
            &mut bin,
            [0u16, 1, 2, 0, 2, 3]
                .iter()
                .flat_map(|i| i.to_le_bytes())
                .collect(),
        );
        let a = accessors.len();
        accessors.push(
            json!({ "bufferView": vp, "componentType": 5126, "count": 4, "type": "VEC3",
            "min": [x0, y0, 0.0], "max": [x1, y1, 0.0] }),
        );
        accessors
            .push(json!({ "bufferView": vn, "componentType": 5126, "count": 4, "type": "VEC3" }));
        accessors
            .push(json!({ "bufferView": vt, "componentType": 5126, "count": 4, "type": "VEC2" }));
        accessors
            .push(json!({ "bufferView": vi, "componentType": 5123, "count": 6, "type": "SCALAR" }));
        meshes.push(json!({ "primitives": [{
            "attributes": { "POSITION": a, "NORMAL": a + 1, "TEXCOORD_0": a + 2 },
            "indices": a + 3, "material": k }] }));
        nodes.push(json!({ "mesh": k }));
    }
    let mut gltf_samplers = Vec::new();
    let textures: Vec<Value> = samplers
        .iter()
        .enumerate()
        .map(|(k, s)| match s {
            Some(s) => {
                gltf_samplers.push(s.clone());
                json!({ "name": format!("tex{k}"), "source": 0, "sampler": gltf_samplers.len() - 1 })
            }
            None => json!({ "name": format!("tex{k}"), "source": 0 }),
        })
        .collect();
    let materials: Vec<Value> = (0..n)
        .map(|k| {
            // Double-sided (the quads are seen from the front anyway).
            json!({ "name": format!("m{k}"), "doubleSided": true, "pbrMetallicRoughness": {
                "baseColorTexture": { "index": k }, "metallicFactor": 0.0, "roughnessFactor": 1.0 } })
        })
        .collect();
    let mut root = json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": (0..n).collect::<Vec<_>>() }],
        "nodes": nodes, "meshes": meshes, "materials": materials, "textures": textures,
        "images": [{ "uri": image_uri }],
        "accessors": accessors, "bufferViews": views,
        "buffers": [{ "byteLength": bin.len(), "uri": format!("data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)) }],
    });
    if !gltf_samplers.is_empty() {
        root["samplers"] = json!(gltf_samplers);
    }
    let path = d.join("quads.gltf");
    std::fs::write(&path, serde_json::to_string_pretty(&root).unwrap()).unwrap();
    path
}

/// A camera 2 m in front of the grid of `n` quads, seeing all of them.
fn camera(n: usize) -> StereoCamera {
    let rows = n.div_ceil(3) as f32;
    look_at_camera(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, 30.0 * rows, 1.5)
}

/// Vulkan's wrapping of an integer texel coordinate into 0..n.
fn wrap(i: i64, n: i64, w: Wrap) -> i64 {
    match w {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let t = i.rem_euclid(2 * n) - n;
            let mirror = if t >= 0 { t } else { -(1 + t) };
            (n - 1) - mirror
        }
    }
}

/// An RGBA8 image with 0/255 channels, as linear colours (exact sRGB decode).
struct Image {
    w: u32,
    h: u32,
    texels: Vec<[u8; 4]>,
}

impl Image {
    fn texel(&self, x: i64, y: i64) -> Vec3 {
        let t = self.texels[(y as u32 * self.w + x as u32) as usize];
        Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32) / 255.0
    }

    /// Level 0 sampled at `uv` with `filter` and the sampler's wrap modes
    /// (the Vulkan rule: nearest i = ⌊u·w⌋; linear i0 = ⌊u·w − ½⌋ and the
    /// fraction as weight; each integer coordinate wrapped).
    fn sample(&self, uv: Vec2, filter: Filter, s: &TextureSampler) -> Vec3 {
        let (w, h) = (self.w as i64, self.h as i64);
        let (u, v) = (uv.x as f64 * w as f64, uv.y as f64 * h as f64);
        match filter {
            Filter::Nearest => self.texel(
                wrap(u.floor() as i64, w, s.wrap_s),
                wrap(v.floor() as i64, h, s.wrap_t),
            ),
            Filter::Linear => {
                let (a, b) = (u - 0.5, v - 0.5);
                let (i0, j0) = (a.floor() as i64, b.floor() as i64);
                let (al, be) = ((a - a.floor()) as f32, (b - b.floor()) as f32);
                let t = |di: i64, dj: i64| {
                    self.texel(wrap(i0 + di, w, s.wrap_s), wrap(j0 + dj, h, s.wrap_t))
                };
                (1.0 - al) * (1.0 - be) * t(0, 0)
                    + al * (1.0 - be) * t(1, 0)
                    + (1.0 - al) * be * t(0, 1)
                    + al * be * t(1, 1)
            }
        }
    }
}

fn mag_image() -> Image {
    Image {
        w: 2,
        h: 2,
        texels: MAG_TEXELS.to_vec(),
    }
}

#[test]
fn the_oracle_follows_the_gltf_wrap_rules() {
    let img = mag_image();
    let s = |ws: Wrap, wt: Wrap| TextureSampler {
        wrap_s: ws,
        wrap_t: wt,
        mag_filter: Filter::Nearest,
        ..Default::default()
    };
    let at =
        |u: f32, v: f32, smp: &TextureSampler| img.sample(Vec2::new(u, v), Filter::Nearest, smp);
    let (rep, clamp, mirror) = (Wrap::Repeat, Wrap::ClampToEdge, Wrap::MirroredRepeat);
    // REPEAT at u = 1.25 shows the texel of u = 0.25; MIRRORED_REPEAT that of 0.75.
    assert_eq!(at(1.25, 0.25, &s(rep, rep)), at(0.25, 0.25, &s(rep, rep)));
    assert_eq!(
        at(1.25, 0.25, &s(mirror, rep)),
        at(0.75, 0.25, &s(rep, rep))
    );
    assert_eq!(
        at(-0.25, 0.25, &s(mirror, rep)),
        at(0.25, 0.25, &s(rep, rep))
    );
    assert_eq!(at(-0.25, 0.25, &s(rep, rep)), at(0.75, 0.25, &s(rep, rep)));
    // CLAMP_TO_EDGE outside [0, 1] shows the edge texel (also in t).
    for u in [-0.9, -0.25, 1.25, 1.9] {
        let edge = if u < 0.0 { 0.25 } else { 0.75 };
        assert_eq!(at(u, 0.25, &s(clamp, rep)), at(edge, 0.25, &s(rep, rep)));
        assert_eq!(at(0.25, u, &s(rep, clamp)), at(0.25, edge, &s(rep, rep)));
    }
    // The four texels differ, so these comparisons can fail.
    assert_ne!(at(0.25, 0.25, &s(rep, rep)), at(0.75, 0.25, &s(rep, rep)));
    assert_ne!(at(0.25, 0.25, &s(rep, rep)), at(0.25, 0.75, &s(rep, rep)));
    // Bilinear a quarter texel right of texel 0's centre: ¾ texel 0 + ¼ texel 1.
    let lin = img.sample(Vec2::new(0.375, 0.25), Filter::Linear, &s(rep, rep));
    let want = 0.75 * img.texel(0, 0) + 0.25 * img.texel(1, 0);
    assert!((lin - want).abs().max_element() < 1e-6, "{lin} vs {want}");
}

/// Rebuilds the uv of a stored first hit (Listing 1: bary in 24 bits).
fn hit_uv(scene: &Scene, fh: [u32; 4]) -> (u32, Vec2) {
    let mesh = &scene.meshes[scene.instances[fh[3] as usize].mesh as usize];
    let (idx, w) = first_hit_weights(scene, fh);
    let uv: Vec2 = (0..3).map(|k| mesh.uvs[idx[k]] * w[k]).sum();
    (mesh.material, uv)
}

/// An exactly decoded 0 or 255 differs from 0 or 1 by less than the first
/// sRGB step (1/255/12.92 = 3.0·10⁻⁴): 2⁻¹².
const DECODE_TOL: f32 = 1.0 / 4096.0;

/// Per quad: pixels compared, pixels whose expected colour differs from
/// what repeat wrapping would give, pixels with a blended channel, and the
/// largest |albedo − expected| (printed: the measured error).
#[derive(Default, Debug, Clone, Copy)]
struct Tally {
    checked: usize,
    not_repeat: usize,
    blended: usize,
    max_err: f32,
}

/// Renders `scene` with `method` on `rt` and compares every hit pixel's
/// albedo with `expect(material, uv)` → Some((colour, tolerance, colour
/// under repeat wrapping)) or None to skip the pixel.
fn check_albedo(
    ctx: &std::sync::Arc<stereocache::gpu::GpuContext>,
    scene: &Scene,
    rt: RtChoice,
    method: &str,
    cam: StereoCamera,
    expect: &dyn Fn(u32, Vec2) -> Option<(Vec3, f32, Vec3)>,
) -> Vec<Tally> {
    let settings = RenderSettings {
        width: 192,
        height: 128,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    let s = session(ctx, scene.clone(), rt);
    let f = render(&s, method, cam, &settings);
    let mut tally = vec![Tally::default(); scene.materials.len()];
    for (e, eye) in f.eyes.iter().enumerate() {
        for (i, fh) in eye.first_hit.iter().enumerate() {
            if fh[3] == u32::MAX {
                continue;
            }
            let (mat, uv) = hit_uv(&s.scene, *fh);
            let Some((want, tol, repeat)) = expect(mat, uv) else {
                continue;
            };
            let got = Vec3::from_slice(&eye.albedo[i][..3]);
            assert!(
                (got - want).abs().max_element() <= tol,
                "{rt:?} {method}: eye {e} pixel {i} (material {mat}, uv {uv}): albedo {got}, \
                 expected {want} (tolerance {tol})"
            );
            let t = &mut tally[mat as usize];
            t.checked += 1;
            t.max_err = t.max_err.max((got - want).abs().max_element());
            t.not_repeat += ((want - repeat).abs().max_element() > 0.5) as usize;
            t.blended += want.to_array().iter().any(|c| *c > 0.1 && *c < 0.9) as usize;
        }
    }
    tally
}

#[test]
fn wrap_modes_and_magnification_filters_sample_as_the_sampler_says() {
    let ctx = context();
    let d = dir("mag");
    let img = mag_image();
    let uri = png_data_uri(2, 2, MAG_TEXELS.concat());
    let gl = |mag: u32, s: u32, t: u32| json!({ "magFilter": mag, "wrapS": s, "wrapT": t });
    let samplers = [
        None,
        Some(gl(NEAREST, CLAMP, MIRROR)),
        Some(gl(NEAREST, MIRROR, REPEAT)),
        Some(
            json!({ "magFilter": NEAREST, "minFilter": NEAREST, "wrapS": REPEAT, "wrapT": CLAMP }),
        ),
        Some(gl(LINEAR, CLAMP, MIRROR)),
        // Every field left out: the default sampler, as a texture without one.
        Some(json!({ "name": "empty" })),
    ];
    let path = write_quads(&d, &uri, &samplers, -1.0, 2.0);
    let scene = stereocache::scene::load_gltf(&path).expect("loads");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(
        scene.textures.len(),
        1,
        "one image, decoded and uploaded once"
    );
    let sampler_of: Vec<TextureSampler> = scene
        .materials
        .iter()
        .map(|m| m.base_color_texture.expect("textured").sampler)
        .collect();
    let nearest = |s: Wrap, t: Wrap| TextureSampler {
        wrap_s: s,
        wrap_t: t,
        mag_filter: Filter::Nearest,
        ..Default::default()
    };
    use Wrap::{ClampToEdge, MirroredRepeat, Repeat};
    assert_eq!(
        sampler_of,
        [
            TextureSampler::default(),
            nearest(ClampToEdge, MirroredRepeat),
            nearest(MirroredRepeat, Repeat),
            TextureSampler {
                min_filter: Filter::Nearest,
                mipmap: None,
                ..nearest(Repeat, ClampToEdge)
            },
            TextureSampler {
                mag_filter: Filter::Linear,
                ..nearest(ClampToEdge, MirroredRepeat)
            },
            TextureSampler::default(),
        ]
    );
    // One slot per distinct (image, sampler) pair: 5 of them, 5 Vulkan samplers.
    assert_eq!(TextureSlots::of(&scene).pairs.len(), 5);

    let q = 0.5f32.powi(ctx.caps.sub_texel_precision_bits.max(4) as i32);
    // uv of a rebuilt hit: barycentrics to 2⁻²⁴ times the 3-unit uv span,
    // twice, plus the GPU's f32 interpolation (a few ulp of |uv| ≤ 2):
    // under 16·2⁻²⁴·3 uv, in texels ×2.
    let e = 2.0 * 16.0 * 3.0 / 16_777_216.0;
    let expect = |mat: u32, uv: Vec2| -> Option<(Vec3, f32, Vec3)> {
        let s = sampler_of[mat as usize];
        let rep = TextureSampler {
            wrap_s: Repeat,
            wrap_t: Repeat,
            ..s
        };
        // Magnified everywhere (ray-cone lod clamps to 0): the mag filter.
        match s.mag_filter {
            Filter::Nearest => {
                // An implementation may snap the coordinate to 2^-bits of a
                // texel: skip pixels that close to a texel edge.
                let near_edge = |x: f32| {
                    let t = x * 2.0;
                    (t - t.round()).abs() < q + e
                };
                if near_edge(uv.x) || near_edge(uv.y) {
                    return None;
                }
                Some((
                    img.sample(uv, Filter::Nearest, &s),
                    DECODE_TOL,
                    img.sample(uv, Filter::Nearest, &rep),
                ))
            }
            // Weights exact to 2^-bits per axis (colour slope ≤ 1 per weight).
            Filter::Linear => Some((
                img.sample(uv, Filter::Linear, &s),
                2.0 * q + 2.0 * e + DECODE_TOL,
                img.sample(uv, Filter::Linear, &rep),
            )),
        }
    };
    for rt in rt_backends(&ctx) {
        for method in ["reference", "debug-normals"] {
            let s = session(&ctx, scene.clone(), rt);
            assert_eq!(s.scene_gpu.texture_slots(), 5, "{rt:?}");
            assert_eq!(s.scene_gpu.texture_sampler_count(), 5, "{rt:?}");
            drop(s);
            let tally = check_albedo(&ctx, &scene, rt, method, camera(6), &expect);
            eprintln!("{rt:?} {method}: {tally:?}");
            for (k, t) in tally.iter().enumerate() {
                assert!(t.checked > 1000, "{rt:?} {method}: quad {k}: {t:?}");
                let wraps = sampler_of[k].wrap_s != Repeat || sampler_of[k].wrap_t != Repeat;
                // 2/3 of each axis lies outside [0, 1], and half of that
                // reads another texel than repeat would (clamp in one axis
                // alone: 1/3 of the quad; measured 1962 of 5886 pixels):
                // those pixels fail if the sampler is read as repeat.
                assert!(
                    !wraps || t.not_repeat * 5 > t.checked,
                    "{rt:?} {method}: quad {k} does not test its wrap mode: {t:?}"
                );
                let linear = sampler_of[k].mag_filter == Filter::Linear;
                assert!(
                    !linear || t.blended * 4 > t.checked,
                    "{rt:?} {method}: quad {k} does not test blending: {t:?}"
                );
            }
        }
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

/// The sRGB decode of an 8-bit value.
fn srgb_decode(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn min_filters_without_mipmaps_sample_level_0_only() {
    let ctx = context();
    let d = dir("min");
    // 64×64 one-texel black/white checker, uv 0..8 over each 1 m quad:
    // 512 texels over ~55 pixels, a ray-cone lod of about 3.
    let n = 64u32;
    let texels: Vec<[u8; 4]> = (0..n * n)
        .map(|i| {
            let c = if (i % n + i / n) % 2 == 0 { 255 } else { 0 };
            [c, c, c, 255]
        })
        .collect();
    let img = Image {
        w: n,
        h: n,
        texels: texels.clone(),
    };
    let uri = png_data_uri(n, n, texels.concat());
    let samplers = [
        None,
        Some(json!({ "minFilter": NEAREST })),
        Some(json!({ "minFilter": LINEAR })),
        Some(json!({ "minFilter": NEAREST_MIPMAP_NEAREST })),
    ];
    let path = write_quads(&d, &uri, &samplers, 0.0, 8.0);
    let scene = stereocache::scene::load_gltf(&path).expect("loads");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let t = &scene.textures[0];
    // Every level above 0 is one grey (the linear mean ½, encoded): the value
    // any mipmapped minification at lod ≥ 1 returns.
    let grey = t.mips[1][0];
    assert!(
        t.mips[1..]
            .iter()
            .all(|l| l.chunks(4).all(|p| p[..3] == [grey; 3])),
        "mip levels are uniform"
    );
    let grey = srgb_decode(grey);
    // The GPU's decode of that 8-bit value: within half its step to the next.
    let grey_tol = 0.5 * (srgb_decode(t.mips[1][0] + 1) - grey);
    let sampler_of: Vec<TextureSampler> = scene
        .materials
        .iter()
        .map(|m| m.base_color_texture.unwrap().sampler)
        .collect();
    assert_eq!(sampler_of[1].mipmap, None);
    assert_eq!(sampler_of[2].mipmap, None);
    assert_eq!(sampler_of[3].mipmap, Some(Filter::Nearest));
    let q = 0.5f32.powi(ctx.caps.sub_texel_precision_bits.max(4) as i32);
    // uv error as above over an 8-unit span, in texels ×64.
    let e = 64.0 * 16.0 * 8.0 / 16_777_216.0;
    let expect = |mat: u32, uv: Vec2| -> Option<(Vec3, f32, Vec3)> {
        let s = sampler_of[mat as usize];
        match (s.mipmap, s.min_filter) {
            (Some(_), _) => Some((Vec3::splat(grey), grey_tol, Vec3::splat(grey))),
            // Level 0, nearest: a texel, black or white, whatever the point.
            (None, Filter::Nearest) => {
                let want = img.sample(uv, Filter::Nearest, &s);
                let near_edge = |x: f32| {
                    let t = x * n as f32;
                    (t - t.round()).abs() < q + e
                };
                if near_edge(uv.x) || near_edge(uv.y) {
                    // Either neighbour: still pure black or white.
                    return Some((want, 1.0 + DECODE_TOL, want));
                }
                Some((want, DECODE_TOL, want))
            }
            (None, Filter::Linear) => {
                let want = img.sample(uv, Filter::Linear, &s);
                Some((want, 2.0 * q + 2.0 * e + DECODE_TOL, want))
            }
        }
    };
    for rt in rt_backends(&ctx) {
        let s = session(&ctx, scene.clone(), rt);
        let settings = RenderSettings {
            width: 192,
            height: 128,
            spp: 1,
            max_bounces: 1,
            ..Default::default()
        };
        let f = render(&s, "reference", camera(4), &settings);
        // Level 0 nearest: every hit pixel pure black or pure white, both seen.
        let (mut black, mut white, mut total) = (0, 0, 0);
        for eye in &f.eyes {
            for (i, fh) in eye.first_hit.iter().enumerate() {
                if fh[3] == u32::MAX || hit_uv(&s.scene, *fh).0 != 1 {
                    continue;
                }
                let a = Vec3::from_slice(&eye.albedo[i][..3]);
                total += 1;
                if a.max_element() <= DECODE_TOL {
                    black += 1;
                } else if a.min_element() >= 1.0 - DECODE_TOL {
                    white += 1;
                } else {
                    panic!("{rt:?}: minFilter NEAREST pixel {i}: {a}, not a level-0 texel");
                }
            }
        }
        assert!(
            total > 1000 && black * 5 > total && white * 5 > total,
            "{rt:?}: black {black}, white {white} of {total}"
        );
        drop(s);
        let tally = check_albedo(&ctx, &scene, rt, "reference", camera(4), &expect);
        eprintln!("{rt:?}: {tally:?}");
        for (k, t) in tally.iter().enumerate() {
            assert!(t.checked > 1000, "{rt:?}: quad {k}: {t:?}");
        }
    }
    assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn invalid_sampler_values_warn_once_and_use_the_defaults() {
    let d = dir("invalid");
    let uri = png_data_uri(2, 2, MAG_TEXELS.concat());
    let samplers = [
        Some(json!({ "magFilter": 9987, "minFilter": "LINEAR", "wrapS": 12345, "wrapT": CLAMP })),
        Some(json!({ "magFilter": 9728.0, "wrapS": MIRROR })),
    ];
    let path = write_quads(&d, &uri, &samplers, 0.0, 1.0);
    let scene = stereocache::scene::load_gltf(&path).expect("loads despite bad sampler values");
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    let w = &scene.warnings[0];
    for part in [
        path.display().to_string().as_str(),
        "sampler 0",
        "texture 0 'tex0'",
        "magFilter 9987",
        "LINEAR (9729) is used",
        "minFilter \"LINEAR\"",
        "LINEAR_MIPMAP_LINEAR (9987) is used",
        "wrapS 12345",
        "REPEAT (10497) is used",
    ] {
        assert!(w.contains(part), "warning lacks '{part}': {w}");
    }
    assert!(!w.contains("wrapT"), "wrapT was valid: {w}");
    let s0 = scene.materials[0].base_color_texture.unwrap().sampler;
    assert_eq!(
        s0,
        TextureSampler {
            wrap_t: Wrap::ClampToEdge,
            ..Default::default()
        },
        "the bad fields take their defaults, the valid one is kept"
    );
    // A whole-number float is read as the integer (no warning).
    let s1 = scene.materials[1].base_color_texture.unwrap().sampler;
    assert_eq!(
        s1,
        TextureSampler {
            mag_filter: Filter::Nearest,
            wrap_s: Wrap::MirroredRepeat,
            ..Default::default()
        }
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn samplers_survive_the_gltf_writer_and_defaults_bind_as_before() {
    let d = dir("roundtrip");
    let uri = png_data_uri(2, 2, MAG_TEXELS.concat());
    let samplers = [
        None,
        Some(
            json!({ "magFilter": NEAREST, "minFilter": NEAREST, "wrapS": CLAMP, "wrapT": MIRROR }),
        ),
        Some(json!({ "minFilter": 9985, "wrapT": CLAMP })),
        None,
    ];
    let path = write_quads(&d, &uri, &samplers, 0.0, 1.0);
    let a = stereocache::scene::load_gltf(&path).unwrap();
    let out = d.join("out.gltf");
    stereocache::scene::write_gltf(&a, &out).unwrap();
    let b = stereocache::scene::load_gltf(&out).unwrap();
    assert_eq!(b.textures.len(), 1, "still one image");
    let refs = |s: &Scene| -> Vec<_> { s.materials.iter().map(|m| m.base_color_texture).collect() };
    assert_eq!(refs(&a), refs(&b));
    assert_eq!(TextureSlots::of(&b).pairs.len(), 3);
    // All-default scenes: slot i is texture i (the images as before).
    let plane = stereocache::scene::generate("plane").unwrap();
    let slots = TextureSlots::of(&plane);
    assert_eq!(
        slots.pairs,
        (0..plane.textures.len() as u32)
            .map(|i| (i, TextureSampler::default()))
            .collect::<Vec<_>>()
    );
    let _ = std::fs::remove_dir_all(&d);
}
