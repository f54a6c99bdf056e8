//! The noise functions of the MaterialX standard nodes (`noise2d`, `noise3d`,
//! `fractal3d`, `cellnoise2d/3d`, `worleynoise2d/3d`), written from the
//! specification's definitions, on the CPU. `shaders/materialx/noise.glsl`
//! is the same code in GLSL, operation for operation (additions and
//! multiplications in the same order, no fused multiply-add on either side:
//! the GLSL is `precise`), so the two agree to float rounding.
//!
//! The exact variant (the specification fixes the kind, not the bits):
//! * **Lattice hash**: PCG-RXS-M-XS (Jarzynski & Olano 2020, as
//!   `pcg_hash` in shaders/common/random.glsl) chained over the integer
//!   cell coordinates and a channel number c, `pcg(x + pcg(y + pcg(c)))` in
//!   2D and `pcg(x + pcg(y + pcg(z + pcg(c))))` in 3D (wrapping u32).
//! * **Perlin gradient noise** (Perlin 2002, "Improving noise"): quintic fade
//!   6t⁵ − 15t⁴ + 10t³; 3D gradients Perlin's 12 cube-edge directions
//!   (hash & 15, four repeated); 2D gradients (±1, ±1), (±1, 0), (0, ±1)
//!   (hash & 7). Range about [−1, 1], zero-centred, 0 at lattice points.
//!   Channel c of an n-channel noise uses hash channel c.
//! * **fractal3d**: Σ_{i<octaves} diminishⁱ · noise3d(p · lacunarityⁱ), times amplitude.
//! * **Cell noise**: the hash of the cell floor(p) (channel 0), its top 24 bits / 2²⁴, in [0, 1).
//! * **Worley noise**: one feature point per cell, at cell + 0.5 + jitter·(r − 0.5)
//!   per axis (r from hash channels 1, 2, 3, as cell noise); the nearest three
//!   over the 3×3 (3×3×3) neighbourhood; style 0 returns the distances F1, F2, F3
//!   (as many as the output has channels), style 1 the cell noise of the
//!   nearest feature's cell (channels 0, 1, 2).

/// PCG-RXS-M-XS 32-bit hash (shaders/common/random.glsl `pcg_hash`).
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

pub fn hash2(x: i32, y: i32, c: u32) -> u32 {
    pcg((x as u32).wrapping_add(pcg((y as u32).wrapping_add(pcg(c)))))
}

pub fn hash3(x: i32, y: i32, z: i32, c: u32) -> u32 {
    pcg((x as u32).wrapping_add(pcg(
        (y as u32).wrapping_add(pcg((z as u32).wrapping_add(pcg(c))))
    )))
}

/// Top 24 bits of a hash as a float in [0, 1) (exact).
pub fn unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + t * (b - a)
}

fn grad2(h: u32, x: f32, y: f32) -> f32 {
    match h & 7 {
        0 => x + y,
        1 => -x + y,
        2 => x - y,
        3 => -x - y,
        4 => x,
        5 => -x,
        6 => y,
        _ => -y,
    }
}

fn grad3(h: u32, x: f32, y: f32, z: f32) -> f32 {
    match h & 15 {
        0 | 12 => x + y,
        1 | 14 => -x + y,
        2 => x - y,
        3 => -x - y,
        4 => x + z,
        5 => -x + z,
        6 => x - z,
        7 => -x - z,
        8 => y + z,
        9 | 13 => -y + z,
        10 => y - z,
        _ => -y - z,
    }
}

/// 2D Perlin noise, channel `c`.
pub fn perlin2(p: [f32; 2], c: u32) -> f32 {
    let (fx, fy) = (p[0].floor(), p[1].floor());
    let (ix, iy) = (fx as i32, fy as i32);
    let (x, y) = (p[0] - fx, p[1] - fy);
    let (x1, y1) = (x - 1.0, y - 1.0);
    let n00 = grad2(hash2(ix, iy, c), x, y);
    let n10 = grad2(hash2(ix.wrapping_add(1), iy, c), x1, y);
    let n01 = grad2(hash2(ix, iy.wrapping_add(1), c), x, y1);
    let n11 = grad2(hash2(ix.wrapping_add(1), iy.wrapping_add(1), c), x1, y1);
    let (u, v) = (fade(x), fade(y));
    lerp(lerp(n00, n10, u), lerp(n01, n11, u), v)
}

/// 3D Perlin noise, channel `c`.
pub fn perlin3(p: [f32; 3], c: u32) -> f32 {
    let f = [p[0].floor(), p[1].floor(), p[2].floor()];
    let i = [f[0] as i32, f[1] as i32, f[2] as i32];
    let (x, y, z) = (p[0] - f[0], p[1] - f[1], p[2] - f[2]);
    let (x1, y1, z1) = (x - 1.0, y - 1.0, z - 1.0);
    let h = |dx: i32, dy: i32, dz: i32| {
        hash3(
            i[0].wrapping_add(dx),
            i[1].wrapping_add(dy),
            i[2].wrapping_add(dz),
            c,
        )
    };
    let n000 = grad3(h(0, 0, 0), x, y, z);
    let n100 = grad3(h(1, 0, 0), x1, y, z);
    let n010 = grad3(h(0, 1, 0), x, y1, z);
    let n110 = grad3(h(1, 1, 0), x1, y1, z);
    let n001 = grad3(h(0, 0, 1), x, y, z1);
    let n101 = grad3(h(1, 0, 1), x1, y, z1);
    let n011 = grad3(h(0, 1, 1), x, y1, z1);
    let n111 = grad3(h(1, 1, 1), x1, y1, z1);
    let (u, v, w) = (fade(x), fade(y), fade(z));
    let a = lerp(lerp(n000, n100, u), lerp(n010, n110, u), v);
    let b = lerp(lerp(n001, n101, u), lerp(n011, n111, u), v);
    lerp(a, b, w)
}

/// Sum of `octaves` octaves of 3D Perlin noise, channel `c`.
pub fn fractal3(p: [f32; 3], c: u32, octaves: i32, lacunarity: f32, diminish: f32) -> f32 {
    let mut sum = 0.0f32;
    let mut amp = 1.0f32;
    let mut q = p;
    for _ in 0..octaves {
        sum += amp * perlin3(q, c);
        amp *= diminish;
        q = [q[0] * lacunarity, q[1] * lacunarity, q[2] * lacunarity];
    }
    sum
}

pub fn cell2(p: [f32; 2], c: u32) -> f32 {
    unit(hash2(p[0].floor() as i32, p[1].floor() as i32, c))
}

pub fn cell3(p: [f32; 3], c: u32) -> f32 {
    unit(hash3(
        p[0].floor() as i32,
        p[1].floor() as i32,
        p[2].floor() as i32,
        c,
    ))
}

/// Keeps the three smallest squared distances (and the nearest cell).
struct Nearest3 {
    d: [f32; 3],
    cell: [i32; 3],
}

impl Nearest3 {
    fn new() -> Self {
        Nearest3 {
            d: [f32::MAX; 3],
            cell: [0; 3],
        }
    }
    fn insert(&mut self, d: f32, cell: [i32; 3]) {
        if d < self.d[0] {
            self.d = [d, self.d[0], self.d[1]];
            self.cell = cell;
        } else if d < self.d[1] {
            self.d = [self.d[0], d, self.d[1]];
        } else if d < self.d[2] {
            self.d[2] = d;
        }
    }
    fn result(&self, style: i32, n: usize, dims: usize) -> [f32; 4] {
        let mut out = [0.0; 4];
        for (c, o) in out.iter_mut().enumerate().take(n) {
            *o = if style == 1 {
                if dims == 2 {
                    unit(hash2(self.cell[0], self.cell[1], c as u32))
                } else {
                    unit(hash3(self.cell[0], self.cell[1], self.cell[2], c as u32))
                }
            } else {
                self.d[c].sqrt()
            };
        }
        out
    }
}

/// Worley noise in 2D: `n` channels (1..3).
pub fn worley2(p: [f32; 2], jitter: f32, style: i32, n: usize) -> [f32; 4] {
    let (fx, fy) = (p[0].floor(), p[1].floor());
    let (ix, iy) = (fx as i32, fy as i32);
    let (x, y) = (p[0] - fx, p[1] - fy);
    let mut best = Nearest3::new();
    for dy in -1..=1 {
        for dx in -1..=1 {
            let (cx, cy) = (ix.wrapping_add(dx), iy.wrapping_add(dy));
            let fpx = dx as f32 + 0.5 + jitter * (unit(hash2(cx, cy, 1)) - 0.5);
            let fpy = dy as f32 + 0.5 + jitter * (unit(hash2(cx, cy, 2)) - 0.5);
            let (ddx, ddy) = (fpx - x, fpy - y);
            best.insert(ddx * ddx + ddy * ddy, [cx, cy, 0]);
        }
    }
    best.result(style, n, 2)
}

/// Worley noise in 3D: `n` channels (1..3).
pub fn worley3(p: [f32; 3], jitter: f32, style: i32, n: usize) -> [f32; 4] {
    let f = [p[0].floor(), p[1].floor(), p[2].floor()];
    let i = [f[0] as i32, f[1] as i32, f[2] as i32];
    let (x, y, z) = (p[0] - f[0], p[1] - f[1], p[2] - f[2]);
    let mut best = Nearest3::new();
    for dz in -1..=1 {
        for dy in -1..=1 {
            for dx in -1..=1 {
                let c = [
                    i[0].wrapping_add(dx),
                    i[1].wrapping_add(dy),
                    i[2].wrapping_add(dz),
                ];
                let fpx = dx as f32 + 0.5 + jitter * (unit(hash3(c[0], c[1], c[2], 1)) - 0.5);
                let fpy = dy as f32 + 0.5 + jitter * (unit(hash3(c[0], c[1], c[2], 2)) - 0.5);
                let fpz = dz as f32 + 0.5 + jitter * (unit(hash3(c[0], c[1], c[2], 3)) - 0.5);
                let (ddx, ddy, ddz) = (fpx - x, fpy - y, fpz - z);
                best.insert(ddx * ddx + ddy * ddy + ddz * ddz, c);
            }
        }
    }
    best.result(style, n, 3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perlin_is_zero_at_lattice_points_and_bounded() {
        for i in -4..4 {
            for j in -4..4 {
                assert_eq!(perlin2([i as f32, j as f32], 0), 0.0);
                assert_eq!(perlin3([i as f32, j as f32, 3.0], 1), 0.0);
            }
        }
        let mut max = 0.0f32;
        for k in 0..20000 {
            let p = [
                k as f32 * 0.0137,
                (k % 97) as f32 * 0.0731,
                (k % 13) as f32 * 0.311,
            ];
            max = max
                .max(perlin3(p, 0).abs())
                .max(perlin2([p[0], p[1]], 0).abs());
        }
        // 3D: |Σ| over the trilinear blend of dots of ±1-component gradients
        // with offsets in [-1,1]^3 is at most 2 at a corner weight of 1 (Perlin 2002).
        assert!(max <= 2.0 && max > 0.3, "{max}");
    }

    #[test]
    fn cellnoise_is_constant_per_cell_and_in_unit_range() {
        let a = cell2([3.25, -1.5], 0);
        assert_eq!(a, cell2([3.75, -1.01], 0));
        assert!((0.0..1.0).contains(&a));
        assert_ne!(a, cell2([4.25, -1.5], 0));
    }

    #[test]
    fn worley_f1_le_f2_le_f3_and_zero_at_a_feature_point() {
        for k in 0..500 {
            let p = [k as f32 * 0.173, k as f32 * 0.071];
            let w = worley2(p, 1.0, 0, 3);
            assert!(w[0] <= w[1] && w[1] <= w[2], "{w:?}");
        }
        // Jitter 0: the feature point is the cell centre.
        assert_eq!(worley2([2.5, 7.5], 0.0, 0, 1)[0], 0.0);
        assert_eq!(worley3([2.5, 7.5, -0.5], 0.0, 0, 1)[0], 0.0);
    }
}
