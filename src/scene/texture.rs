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
    /// Builds the full mip chain from a level-0 RGBA8 image with a box filter
    /// over each texel's exact footprint, in linear space for sRGB data so
    /// that averages are physically right. Level l + 1 has ⌊w/2⌋ × ⌊h/2⌋
    /// texels (at least 1, as Vulkan sizes levels); where a size is odd, a
    /// texel covers 2.5 (or 3, for 3 → 1) source texels along it, the edge
    /// ones in part (`footprint_weights`), so no texel of a level is dropped
    /// and every level keeps level 0's mean (to 8-bit rounding). Each level is
    /// filtered from the one above kept in f32, not from its 8-bit storage, so
    /// rounding does not accumulate down the chain. The colour channels are
    /// not weighted by alpha: a texture is shared by every slot that reads its
    /// image in this encoding, and alpha means coverage in glTF's base colour
    /// but is ignored by the emissive slot and holds sheen roughness in
    /// KHR_materials_sheen's colour texture.
    pub fn with_mips(
        name: String,
        encoding: TextureEncoding,
        width: u32,
        height: u32,
        level0: Vec<u8>,
    ) -> Self {
        assert_eq!(level0.len(), (width * height * 4) as usize, "level 0 size");
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
        // 256-entry decode table (alpha is always linear).
        let lut: Vec<f32> = (0..=255u8).map(to_lin).collect();
        let mut cur: Vec<f32> = level0
            .chunks_exact(4)
            .flat_map(|t| {
                [
                    lut[t[0] as usize],
                    lut[t[1] as usize],
                    lut[t[2] as usize],
                    t[3] as f32 / 255.0,
                ]
            })
            .collect();
        let mut mips = vec![level0];
        let (mut w, mut h) = (width, height);
        while w > 1 || h > 1 {
            let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
            let wx = footprint_weights(w, nw);
            let wy = footprint_weights(h, nh);
            let mut next = vec![0f32; (nw * nh * 4) as usize];
            for (y, ys) in wy.iter().enumerate() {
                for (x, xs) in wx.iter().enumerate() {
                    let mut acc = [0f32; 4];
                    for &(sy, fy) in ys {
                        for &(sx, fx) in xs {
                            let i = ((sy * w + sx) * 4) as usize;
                            for (c, a) in acc.iter_mut().enumerate() {
                                *a += fy * fx * cur[i + c];
                            }
                        }
                    }
                    let o = (y * nw as usize + x) * 4;
                    next[o..o + 4].copy_from_slice(&acc);
                }
            }
            mips.push(
                next.chunks_exact(4)
                    .flat_map(|t| {
                        [
                            from_lin(t[0]),
                            from_lin(t[1]),
                            from_lin(t[2]),
                            (t[3].clamp(0.0, 1.0) * 255.0 + 0.5) as u8,
                        ]
                    })
                    .collect(),
            );
            cur = next;
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

/// The box filter of one axis from `n` texels down to `m` (m = ⌊n/2⌋ or 1):
/// output texel i covers source texels [i·n/m, (i+1)·n/m), each weighted by
/// the length of its overlap over n/m, so the weights of a texel sum to 1 and
/// every source texel's weights sum to m/n (the mean is kept). Even n gives
/// the plain 2-tap ½, ½.
fn footprint_weights(n: u32, m: u32) -> Vec<Vec<(u32, f32)>> {
    (0..m)
        .map(|i| {
            // Footprint in units of source texels, as exact rationals over m.
            let (lo, hi) = (i as u64 * n as u64, (i as u64 + 1) * n as u64);
            let first = (lo / m as u64) as u32;
            let last = hi.div_ceil(m as u64) as u32; // exclusive
            (first..last)
                .map(|s| {
                    let a = (s as u64 * m as u64).max(lo);
                    let b = ((s as u64 + 1) * m as u64).min(hi);
                    (s, (b - a) as f32 / n as f32)
                })
                .collect()
        })
        .collect()
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

#[cfg(test)]
mod tests {
    use super::*;

    fn linear(w: u32, h: u32, mut f: impl FnMut(u32, u32) -> [u8; 4]) -> Texture {
        let mut data = Vec::new();
        for y in 0..h {
            for x in 0..w {
                data.extend(f(x, y));
            }
        }
        Texture::with_mips("t".into(), TextureEncoding::Linear, w, h, data)
    }

    #[test]
    fn odd_sizes_keep_every_texel() {
        // 3×3 → 1×1 covers all nine texels: one white texel in the corner
        // the old 2×2 box never read gives 255/9 = 28.3, not 0.
        let t = linear(3, 3, |x, y| {
            if (x, y) == (2, 2) {
                [255; 4]
            } else {
                [0, 0, 0, 0]
            }
        });
        assert_eq!(t.mips.len(), 2);
        assert_eq!(t.mips[1], vec![28; 4]);
        // 5 → 2: texel 0 covers 0, 1 and half of 2.
        let t = linear(5, 1, |x, _| [[0, 0, 200, 0, 0][x as usize], 0, 0, 255]);
        assert_eq!(t.mips[1][0], 40); // 200 · 0.5 / 2.5
        assert_eq!(t.mips[1][4], 40);
    }

    #[test]
    fn every_level_keeps_the_mean_of_level_zero() {
        // A pseudo-random 37×23 image (odd and prime sizes all the way down).
        let mut s = 12345u32;
        let t = linear(37, 23, |_, _| {
            let mut c = [0u8; 4];
            for v in &mut c {
                s = s.wrapping_mul(1664525).wrapping_add(1013904223);
                *v = (s >> 24) as u8;
            }
            c
        });
        let mean = |level: &Vec<u8>, c: usize| {
            let v: Vec<f64> = level.chunks_exact(4).map(|t| t[c] as f64).collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        assert_eq!(t.mips.len(), 6); // 37×23, 18×11, 9×5, 4×2, 2×1, 1×1
        for c in 0..4 {
            let m0 = mean(&t.mips[0], c);
            for (l, level) in t.mips.iter().enumerate() {
                // Each level is the f32 filter of the one above, so its mean
                // is level 0's up to the storage's rounding (±0.5 per texel).
                let m = mean(level, c);
                assert!(
                    (m - m0).abs() <= 0.5 + 1e-3,
                    "level {l} channel {c}: mean {m} against {m0}"
                );
            }
        }
    }

    #[test]
    fn srgb_levels_average_in_linear_space() {
        // Black and white → linear 0.5 → sRGB 0.7354 · 255 = 187.5 → 188.
        let data = [0, 0, 0, 255, 255, 255, 255, 255].to_vec();
        let t = Texture::with_mips("t".into(), TextureEncoding::Srgb, 2, 1, data);
        assert_eq!(t.mips[1], vec![188, 188, 188, 255]);
    }
}
