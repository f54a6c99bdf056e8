//! Textures as RGBA8 mip chains, built on the CPU at load time.

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TextureEncoding {
    /// Colour data (base colour, emissive): sampled through an sRGB format.
    Srgb,
    /// Non-colour data (normals, metallic-roughness, transmission).
    Linear,
}

#[derive(Clone, Debug)]
pub struct Texture {
    pub name: String,
    pub encoding: TextureEncoding,
    pub width: u32,
    pub height: u32,
    /// Level 0 first; each level RGBA8, tightly packed, halving down to 1×1.
    pub mips: Vec<Vec<u8>>,
}

impl Texture {
    /// Builds the full mip chain from a level-0 RGBA8 image with a 2×2 box filter
    /// (in linear space for sRGB data so that averages are physically right).
    pub fn with_mips(
        name: String,
        encoding: TextureEncoding,
        width: u32,
        height: u32,
        level0: Vec<u8>,
    ) -> Self {
        assert_eq!(level0.len(), (width * height * 4) as usize, "level 0 size");
        let mut mips = vec![level0];
        let (mut w, mut h) = (width, height);
        let to_lin = |c: u8| -> f32 {
            let c = c as f32 / 255.0;
            match encoding {
                TextureEncoding::Srgb => {
                    if c <= 0.04045 {
                        c / 12.92
                    } else {
                        ((c + 0.055) / 1.055).powf(2.4)
                    }
                }
                TextureEncoding::Linear => c,
            }
        };
        let from_lin = |v: f32| -> u8 {
            let v = v.clamp(0.0, 1.0);
            let e = match encoding {
                TextureEncoding::Srgb => {
                    if v <= 0.0031308 {
                        v * 12.92
                    } else {
                        1.055 * v.powf(1.0 / 2.4) - 0.055
                    }
                }
                TextureEncoding::Linear => v,
            };
            (e * 255.0 + 0.5) as u8
        };
        while w > 1 || h > 1 {
            let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
            let prev = mips.last().unwrap();
            let mut next = vec![0u8; (nw * nh * 4) as usize];
            for y in 0..nh {
                for x in 0..nw {
                    for c in 0..4 {
                        let mut acc = 0.0;
                        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            let sx = (2 * x + dx).min(w - 1);
                            let sy = (2 * y + dy).min(h - 1);
                            let v = prev[((sy * w + sx) * 4 + c) as usize];
                            // Alpha is always linear.
                            acc += if c == 3 { v as f32 / 255.0 } else { to_lin(v) };
                        }
                        acc *= 0.25;
                        next[((y * nw + x) * 4 + c) as usize] = if c == 3 {
                            (acc.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
                        } else {
                            from_lin(acc)
                        };
                    }
                }
            }
            mips.push(next);
            w = nw;
            h = nh;
        }
        Texture {
            name,
            encoding,
            width,
            height,
            mips,
        }
    }

    pub fn mip_levels(&self) -> u32 {
        self.mips.len() as u32
    }
}

/// How a texture coordinate outside [0, 1] is mapped back into the image
/// (glTF `sampler.wrapS` / `wrapT`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Wrap {
    /// GL `REPEAT` (10497): the image tiles.
    Repeat,
    /// GL `CLAMP_TO_EDGE` (33071): the edge texel continues.
    ClampToEdge,
    /// GL `MIRRORED_REPEAT` (33648): every other tile is mirrored.
    MirroredRepeat,
}

/// Texel filter (within a mip level, or between levels).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Filter {
    Nearest,
    Linear,
}

/// A glTF sampler as a texture reference uses it. The default is what the
/// Khronos sample viewer uses when a texture has no sampler or a sampler
/// leaves a field out: repeat in both directions, LINEAR magnification and
/// LINEAR_MIPMAP_LINEAR (trilinear) minification.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TextureSampler {
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    pub mag_filter: Filter,
    /// The filter within a level when minified.
    pub min_filter: Filter,
    /// The filter between mip levels; `None`: the texture is not mipmapped
    /// (glTF minFilter NEAREST or LINEAR) and only level 0 is sampled.
    pub mipmap: Option<Filter>,
}

impl Default for TextureSampler {
    fn default() -> Self {
        TextureSampler {
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            mag_filter: Filter::Linear,
            min_filter: Filter::Linear,
            mipmap: Some(Filter::Linear),
        }
    }
}

/// The GL enum values glTF samplers use (glTF 2.0 §5.26).
pub mod gl {
    pub const NEAREST: u32 = 9728;
    pub const LINEAR: u32 = 9729;
    pub const NEAREST_MIPMAP_NEAREST: u32 = 9984;
    pub const LINEAR_MIPMAP_NEAREST: u32 = 9985;
    pub const NEAREST_MIPMAP_LINEAR: u32 = 9986;
    pub const LINEAR_MIPMAP_LINEAR: u32 = 9987;
    pub const REPEAT: u32 = 10497;
    pub const CLAMP_TO_EDGE: u32 = 33071;
    pub const MIRRORED_REPEAT: u32 = 33648;
}

impl Wrap {
    /// From a glTF `wrapS`/`wrapT` value; `None` for a value glTF does not define.
    pub fn from_gl(v: u32) -> Option<Wrap> {
        match v {
            gl::REPEAT => Some(Wrap::Repeat),
            gl::CLAMP_TO_EDGE => Some(Wrap::ClampToEdge),
            gl::MIRRORED_REPEAT => Some(Wrap::MirroredRepeat),
            _ => None,
        }
    }

    pub fn to_gl(self) -> u32 {
        match self {
            Wrap::Repeat => gl::REPEAT,
            Wrap::ClampToEdge => gl::CLAMP_TO_EDGE,
            Wrap::MirroredRepeat => gl::MIRRORED_REPEAT,
        }
    }
}

impl Filter {
    /// From a glTF `magFilter` value; `None` for a value glTF does not define.
    pub fn from_gl_mag(v: u32) -> Option<Filter> {
        match v {
            gl::NEAREST => Some(Filter::Nearest),
            gl::LINEAR => Some(Filter::Linear),
            _ => None,
        }
    }
}

impl TextureSampler {
    /// (filter within a level, filter between levels) of a glTF `minFilter`
    /// value; `None` for a value glTF does not define.
    pub fn min_from_gl(v: u32) -> Option<(Filter, Option<Filter>)> {
        use Filter::{Linear, Nearest};
        match v {
            gl::NEAREST => Some((Nearest, None)),
            gl::LINEAR => Some((Linear, None)),
            gl::NEAREST_MIPMAP_NEAREST => Some((Nearest, Some(Nearest))),
            gl::LINEAR_MIPMAP_NEAREST => Some((Linear, Some(Nearest))),
            gl::NEAREST_MIPMAP_LINEAR => Some((Nearest, Some(Linear))),
            gl::LINEAR_MIPMAP_LINEAR => Some((Linear, Some(Linear))),
            _ => None,
        }
    }

    /// The glTF `minFilter` value of this sampler.
    pub fn min_to_gl(&self) -> u32 {
        use Filter::{Linear, Nearest};
        match (self.min_filter, self.mipmap) {
            (Nearest, None) => gl::NEAREST,
            (Linear, None) => gl::LINEAR,
            (Nearest, Some(Nearest)) => gl::NEAREST_MIPMAP_NEAREST,
            (Linear, Some(Nearest)) => gl::LINEAR_MIPMAP_NEAREST,
            (Nearest, Some(Linear)) => gl::NEAREST_MIPMAP_LINEAR,
            (Linear, Some(Linear)) => gl::LINEAR_MIPMAP_LINEAR,
        }
    }

    /// The glTF `magFilter` value of this sampler.
    pub fn mag_to_gl(&self) -> u32 {
        match self.mag_filter {
            Filter::Nearest => gl::NEAREST,
            Filter::Linear => gl::LINEAR,
        }
    }

    /// The glTF sampler object of this sampler (all four fields written).
    pub fn to_gltf_json(&self) -> serde_json::Value {
        serde_json::json!({
            "magFilter": self.mag_to_gl(),
            "minFilter": self.min_to_gl(),
            "wrapS": self.wrap_s.to_gl(),
            "wrapT": self.wrap_t.to_gl(),
        })
    }
}
