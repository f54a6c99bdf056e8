//! The MaterialX `image` node (issue 17): an image file read by a graph,
//! bound as one more texture of the scene's texture array, and its CPU twin
//! of Vulkan's texel filtering (the oracle of the GPU path).
//!
//! Semantics (MaterialX 1.39 `ND_image_*`, written from the standard
//! library's nodedefs and specification):
//! * `file` is relative to the document (`fileprefix` in scope prepended);
//!   `colorspace` `srgb_texture` decodes sRGB, `lin_rec709` (or none: the
//!   working space) reads the values as they are; other spaces are errors.
//! * The texture coordinate's origin is the image's **lower-left** corner
//!   (MaterialX's convention; image rows are stored top first, so v is
//!   flipped: MaterialX's own GLSL does the same, `mx_transform_uv_vflip`).
//! * Address modes `periodic` / `clamp` / `mirror` are the sampler's
//!   REPEAT / CLAMP_TO_EDGE / MIRRORED_REPEAT; `constant` returns `default`
//!   for a coordinate outside [0, 1] on that axis and clamps inside it (the
//!   half-texel band inside the border blends edge texels, not the default).
//! * `filtertype` `closest` is nearest texel and nearest mip level, `linear`
//!   trilinear; `cubic` falls back to linear with a warning.
//! * The output is the first 1–4 channels of the RGBA texel (a float image
//!   of an RGB file reads red).
//! * Level of detail: a graph is evaluated for a uv footprint (`Geom::footprint`,
//!   the width in uv the value stands for: the ray cone's at a hit, a memo
//!   texel's size 2^-m when the memoization cache fills); the image's level
//!   is log2(footprint · s · √(w·h)), s the texture coordinate's scale
//!   against the uv (√|det J| of its Jacobian by central differences, 1
//!   when the texcoord is the uv). Footprint 0 reads level 0.
//! * Not supported (errors): `layer` other than empty, frame ranges (image
//!   sequences), 16-bit/float precision (images are read as RGBA8).

use crate::scene::{Filter, Texture, TextureEncoding, TextureSampler, Wrap};
use std::path::PathBuf;
use std::sync::Arc;

/// One image node of a graph.
#[derive(Clone)]
pub struct GraphImage {
    /// Index of the node in `Graph::nodes`.
    pub node: usize,
    /// The filename as the document gives it (with its fileprefix).
    pub file: String,
    /// Where it was read from.
    pub path: PathBuf,
    pub texture: Arc<Texture>,
    pub sampler: TextureSampler,
    /// `constant` address mode on u, v: the default outside [0, 1].
    pub constant: [bool; 2],
}

impl std::fmt::Debug for GraphImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GraphImage")
            .field("node", &self.node)
            .field("file", &self.file)
            .field("size", &(self.texture.width, self.texture.height))
            .field("sampler", &self.sampler)
            .field("constant", &self.constant)
            .finish()
    }
}

/// The uniform settings of an image node, checked.
pub struct ImageSettings {
    pub sampler: TextureSampler,
    pub constant: [bool; 2],
    pub encoding: TextureEncoding,
    /// A fallback taken (printed as a warning by the loader).
    pub warning: Option<String>,
}

fn address(axis: &str, mode: &str) -> Result<(Wrap, bool), String> {
    Ok(match mode {
        "periodic" | "" => (Wrap::Repeat, false),
        "clamp" => (Wrap::ClampToEdge, false),
        "mirror" => (Wrap::MirroredRepeat, false),
        "constant" => (Wrap::ClampToEdge, true),
        m => {
            return Err(format!(
                "input `{axis}addressmode` is `{m}`; constant, clamp, periodic or mirror"
            ))
        }
    })
}

/// Checks an image node's string inputs (by name).
pub fn settings(get: impl Fn(&str) -> String) -> Result<ImageSettings, String> {
    let layer = get("layer");
    if !layer.is_empty() {
        return Err(format!(
            "input `layer` is `{layer}`: image layers are not supported"
        ));
    }
    let frames = get("framerange");
    if !frames.is_empty() {
        return Err(format!(
            "input `framerange` is `{frames}`: image sequences are not supported"
        ));
    }
    let (wrap_s, cu) = address("u", &get("uaddressmode"))?;
    let (wrap_t, cv) = address("v", &get("vaddressmode"))?;
    let mut warning = None;
    let (filter, mipmap) = match get("filtertype").as_str() {
        "linear" | "" => (Filter::Linear, Filter::Linear),
        "closest" => (Filter::Nearest, Filter::Nearest),
        "cubic" => {
            warning = Some("filtertype `cubic` is read as `linear` (trilinear)".to_string());
            (Filter::Linear, Filter::Linear)
        }
        f => {
            return Err(format!(
                "input `filtertype` is `{f}`; closest, linear or cubic"
            ))
        }
    };
    let encoding = match get("colorspace").as_str() {
        "srgb_texture" => TextureEncoding::Srgb,
        "" | "lin_rec709" => TextureEncoding::Linear,
        c => {
            return Err(format!(
                "input `file`: colorspace `{c}` is not supported (srgb_texture or lin_rec709)"
            ))
        }
    };
    Ok(ImageSettings {
        sampler: TextureSampler {
            wrap_s,
            wrap_t,
            mag_filter: filter,
            min_filter: filter,
            mipmap: Some(mipmap),
        },
        constant: [cu, cv],
        encoding,
        warning,
    })
}

/// Reads image file `path` as an RGBA8 texture with its mip chain.
pub fn read(path: &std::path::Path, encoding: TextureEncoding) -> Result<Texture, String> {
    // A regular file only (crate::input): a FIFO or device named as an
    // image would block or be read until memory runs out.
    let bytes = crate::input::read(path)
        .map_err(|e| format!("cannot read image `{}` ({e})", path.display()))?;
    let img = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot read image `{}` ({e})", path.display()))?
        .decode()
        .map_err(|e| format!("cannot read image `{}` ({e})", path.display()))?;
    let rgba = img.to_rgba8();
    let (w, h) = rgba.dimensions();
    if w == 0 || h == 0 {
        return Err(format!("image `{}` is empty", path.display()));
    }
    Ok(Texture::with_mips(
        path.display().to_string(),
        encoding,
        w,
        h,
        rgba.into_raw(),
    ))
}

/// Level of detail of a footprint `footprint` (uv width times the texture
/// coordinate's scale) in `t`: log2(footprint · √(w·h)); −∞ for 0.
pub fn lod(t: &Texture, footprint: f32) -> f32 {
    if footprint > 0.0 {
        (footprint * ((t.width as f32) * (t.height as f32)).sqrt()).log2()
    } else {
        f32::NEG_INFINITY
    }
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Vulkan's wrapping of an integer texel coordinate (the specification's "Wrapping Operation").
fn wrap(i: i64, size: i64, w: Wrap) -> i64 {
    match w {
        Wrap::Repeat => i.rem_euclid(size),
        Wrap::ClampToEdge => i.clamp(0, size - 1),
        Wrap::MirroredRepeat => {
            let mirror = |n: i64| if n >= 0 { n } else { -(1 + n) };
            (size - 1) - mirror(i.rem_euclid(2 * size) - size)
        }
    }
}

fn texel(t: &Texture, level: usize, x: i64, y: i64) -> [f32; 4] {
    let w = (t.width >> level).max(1) as usize;
    let b = (y as usize * w + x as usize) * 4;
    let px = &t.mips[level][b..b + 4];
    let mut r = [0.0; 4];
    for c in 0..4 {
        let v = px[c] as f32 / 255.0;
        r[c] = if c < 3 && t.encoding == TextureEncoding::Srgb {
            srgb_to_linear(v)
        } else {
            v
        };
    }
    r
}

/// Filters level `level` at normalised (s, t) (t from the image's top).
fn filter_level(
    t: &Texture,
    s: &TextureSampler,
    level: usize,
    st: [f32; 2],
    f: Filter,
) -> [f32; 4] {
    let w = (t.width >> level).max(1) as i64;
    let h = (t.height >> level).max(1) as i64;
    let (u, v) = (st[0] * w as f32, st[1] * h as f32);
    match f {
        Filter::Nearest => {
            let x = wrap(u.floor() as i64, w, s.wrap_s);
            let y = wrap(v.floor() as i64, h, s.wrap_t);
            texel(t, level, x, y)
        }
        Filter::Linear => {
            let (u, v) = (u - 0.5, v - 0.5);
            let (i0, j0) = (u.floor() as i64, v.floor() as i64);
            let (a, b) = (u - u.floor(), v - v.floor());
            let x = [wrap(i0, w, s.wrap_s), wrap(i0 + 1, w, s.wrap_s)];
            let y = [wrap(j0, h, s.wrap_t), wrap(j0 + 1, h, s.wrap_t)];
            let mut r = [0.0; 4];
            let t00 = texel(t, level, x[0], y[0]);
            let t10 = texel(t, level, x[1], y[0]);
            let t01 = texel(t, level, x[0], y[1]);
            let t11 = texel(t, level, x[1], y[1]);
            for c in 0..4 {
                r[c] = (1.0 - a) * (1.0 - b) * t00[c]
                    + a * (1.0 - b) * t10[c]
                    + (1.0 - a) * b * t01[c]
                    + a * b * t11[c];
            }
            r
        }
    }
}

/// `textureLod` of texture `t` through sampler `s` at normalised
/// coordinates `st` (origin top-left, as the GPU's) and level `lambda`:
/// Vulkan's texel filtering (magnification for λ ≤ 0, mip selection by the
/// mipmap mode) in f32, with sRGB decoded per texel before filtering.
pub fn sample(t: &Texture, s: &TextureSampler, st: [f32; 2], lambda: f32) -> [f32; 4] {
    let q = t.mips.len() - 1;
    // λ ≤ 0 (or NaN): magnification at level 0.
    if lambda.is_nan() || lambda <= 0.0 {
        return filter_level(t, s, 0, st, s.mag_filter);
    }
    match s.mipmap {
        None => filter_level(t, s, 0, st, s.min_filter),
        Some(Filter::Nearest) => {
            let d = ((lambda + 0.5).ceil() - 1.0).clamp(0.0, q as f32) as usize;
            filter_level(t, s, d, st, s.min_filter)
        }
        Some(Filter::Linear) => {
            let lambda = lambda.min(q as f32);
            let d_hi = lambda.floor() as usize;
            let d_lo = (d_hi + 1).min(q);
            let delta = lambda - lambda.floor();
            let a = filter_level(t, s, d_hi, st, s.min_filter);
            if delta == 0.0 {
                return a;
            }
            let b = filter_level(t, s, d_lo, st, s.min_filter);
            let mut r = [0.0; 4];
            for c in 0..4 {
                r[c] = (1.0 - delta) * a[c] + delta * b[c];
            }
            r
        }
    }
}

/// The image node's value at texture coordinate `tc` (MaterialX's, origin
/// bottom-left) for footprint `footprint` (already scaled to the texture
/// coordinate): `default` where a `constant` axis leaves [0, 1].
pub fn evaluate(im: &GraphImage, tc: [f32; 2], footprint: f32, default: [f32; 4]) -> [f32; 4] {
    for (constant, x) in im.constant.iter().zip(tc) {
        if *constant && !(0.0..=1.0).contains(&x) {
            return default;
        }
    }
    let t = &im.texture;
    sample(t, &im.sampler, [tc[0], 1.0 - tc[1]], lod(t, footprint))
}

/// GLSL of the node (the scene's graphs include it; the run-time shaders
/// declare the `textures` array before it, shaders/common/scene.glsl).
pub const GLSL: &str = include_str!("../../shaders/materialx/image.glsl");
