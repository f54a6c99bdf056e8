//! CPU twin of `shaders/memo/lod.glsl`: the memo cache's level of detail
//! from a ray cone (thesis eqs. 5.1–5.5), the nearest texel centre (eqs.
//! 5.6–5.7, texel-centre snapping) and the cone's growth past a hit (eqs.
//! 2.10–2.11). See the shader for the reasoning; the formulas are the same,
//! in f32.

pub const MIN_LEVEL: i32 = -8;
pub const MAX_LEVEL: i32 = 22;

/// m = round(log2(1 / l_min) + bias), l_min = w · sqrt(uv area / world area).
pub fn level(cone_width: f32, uv_area_ratio: f32, bias: f32) -> i32 {
    let l = cone_width * uv_area_ratio.max(0.0).sqrt();
    if l.is_nan() || l <= 0.0 {
        return MAX_LEVEL;
    }
    ((-l.log2() + bias + 0.5).floor() as i32).clamp(MIN_LEVEL, MAX_LEVEL)
}

/// 2^level exactly (GLSL `ldexp`), for the levels in use.
fn pow2(level: i32) -> f32 {
    f32::from_bits(((level.clamp(-126, 127) + 127) as u32) << 23)
}

/// (û, v̂) = round(2^m (u, v)), halves up, clamped into int range.
pub fn quantise(uv: [f32; 2], level: i32) -> [i32; 2] {
    let s = pow2(level);
    uv.map(|x| {
        (x * s + 0.5)
            .clamp(-1_073_741_824.0, 1_073_741_760.0)
            .floor() as i32
    })
}

/// The uv of texel centre `q` at `level`.
pub fn snapped_uv(q: [i32; 2], level: i32) -> [f32; 2] {
    let s = pow2(-level);
    q.map(|x| x as f32 * s)
}

/// Eq. 2.10: the cone width at distance t.
pub fn cone_width(width: f32, spread: f32, t: f32) -> f32 {
    width + spread * t
}

/// Eq. 2.11: β_r of GGX alpha `alpha`.
pub fn roughness_spread(alpha: f32) -> f32 {
    let a2 = (alpha * alpha).min(0.999);
    2.0 * (a2 / (2.0 - 2.0 * a2)).sqrt()
}
