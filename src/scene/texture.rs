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
