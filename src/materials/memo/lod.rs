//! CPU twin of `shaders/memo/lod.glsl`: the memo cache's level of detail
//! from a ray cone's anisotropic footprint (thesis eqs. 2.13–2.16,
//! 5.1–5.5), the nearest texel centre (eqs. 5.6–5.7, texel-centre
//! snapping) and the cone's growth past a hit (eqs. 2.10–2.12, the
//! curvature k of eq. 2.12 estimated from a triangle's vertex normals;
//! the geometric pencil and the roughness blur kept apart, `cone_at`). See
//! the shader for the reasoning; the formulas are the same, in f32.

use glam::{Vec2, Vec3};

pub const MIN_LEVEL: i32 = -8;
pub const MAX_LEVEL: i32 = 22;

/// Eqs. 2.13–2.16 and 5.2–5.4: the shorter uv derivative of a ray cone's
/// footprint per unit of cone width, for a hit along `dir` on a triangle of
/// world edges `e1`, `e2` and uv edges `d1`, `d2` (vertex 1 and 2 minus
/// vertex 0): min(|J ĥ1| / |cos θ|, |J ĥ2|), ĥ1 the ray's direction projected
/// on the plane, ĥ2 = n × ĥ1, J the barycentric uv map's derivative. 0 for a
/// degenerate triangle or uv map. The shader's reasoning is in
/// `shaders/memo/lod.glsl` (`memo_uv_per_width`); the operations are the
/// same, in f32.
pub fn uv_per_width(dir: Vec3, e1: Vec3, e2: Vec3, d1: Vec2, d2: Vec2) -> f32 {
    let n_ = e1.cross(e2);
    let nn = n_.dot(n_);
    if nn.is_nan() || nn <= 0.0 {
        return 0.0;
    }
    let gb = e2.cross(n_) / nn;
    let gc = n_.cross(e1) / nn;
    let n = n_ * nn.sqrt().recip();
    let d = dir.normalize();
    let c = d.dot(n);
    let h1 = d - c * n;
    let s2 = h1.dot(h1);
    let h1 = if s2 > 1e-12 {
        h1 * s2.sqrt().recip()
    } else {
        e1.normalize()
    };
    let h2 = n.cross(h1);
    let j1 = d1 * h1.dot(gb) + d2 * h1.dot(gc);
    let j2 = d1 * h2.dot(gb) + d2 * h2.dot(gc);
    (j1.length() / c.abs().max(1e-6)).min(j2.length())
}

/// Eq. 5.5: m = round(log2(1 / l_min) + bias), l_min = |w| · `uv_per_width`
/// (a cone focused past a concave mirror's focus has a negative width).
pub fn level(cone_width: f32, uv_per_width: f32, bias: f32) -> i32 {
    let l = cone_width.abs() * uv_per_width.max(0.0);
    if l.is_nan() || l <= 0.0 {
        return MAX_LEVEL;
    }
    ((-l.log2() + bias + 0.5).floor() as i32).clamp(MIN_LEVEL, MAX_LEVEL)
}

/// 2^level exactly (GLSL `ldexp`), for the levels in use.
fn pow2(level: i32) -> f32 {
    f32::from_bits(((level.clamp(-126, 127) + 127) as u32) << 23)
}

/// Whether level `level`'s texel grid holds `uv` exactly (lod.glsl
/// `memo_fits`): |2^m u|, |2^m v| < 2^23, where `quantise` rounds exactly.
/// Lookups whose uv does not fit are evaluated directly (counted as
/// bypassed). NaN does not fit.
pub fn fits(uv: [f32; 2], level: i32) -> bool {
    let s = pow2(level);
    uv.iter().all(|x| (x * s).abs() < 8_388_608.0)
}

/// (û, v̂) = round(2^m (u, v)), halves up, clamped into int range; exact
/// where [`fits`].
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

/// Eq. 2.12's k of a triangle with smooth vertex normals: the mean over its
/// edges of (n_j − n_i)·(p_j − p_i) / |p_j − p_i|² (world positions, world
/// normals, normalised here; 0 if one is zero); 1/R on a sphere of radius R with normals p/R, 0 where flat.
/// The estimate is ours (the thesis names k only); see
/// `memo_triangle_curvature` in `shaders/memo/lod.glsl`.
pub fn triangle_curvature(p: [Vec3; 3], n: [Vec3; 3]) -> f32 {
    let l = n.map(|v| v.dot(v));
    if !l.iter().all(|&x| x > 0.0) {
        return 0.0;
    }
    let n = [0, 1, 2].map(|i| n[i] * l[i].sqrt().recip());
    let edge = |i: usize, j: usize| {
        let e = p[j] - p[i];
        let ee = e.dot(e);
        if ee > 0.0 {
            (n[j] - n[i]).dot(e) / ee
        } else {
            0.0
        }
    };
    let k = (edge(0, 1) + edge(1, 2) + edge(2, 0)) / 3.0;
    if k.abs() < 1e30 {
        k
    } else {
        0.0
    }
}

/// Eq. 2.12: β_c = −2 k w / (n·d) with n facing the incoming ray (n·d < 0),
/// |n·d| kept off 0 as `uv_per_width` keeps it: the spread of a reflected
/// cone of width w in the plane of incidence.
pub fn curvature_spread(k: f32, width: f32, n_dot_d: f32) -> f32 {
    2.0 * k * width / n_dot_d.abs().max(1e-6)
}

/// The cone's width at distance `t` past a vertex, kept in two parts
/// (`memo_cone_at` in `shaders/memo/lod.glsl`, which gives the reasoning):
/// the geometric pencil (signed width `w`, spread `s`: the eye's, turned by
/// eq. 2.12 at reflections; it may focus through 0) and the roughness blur
/// (width `blur_w` ≥ 0, spread `blur_s`: the sum of the surfaces' eq. 2.11
/// β_r, never focused): |w + s·t| + blur_w + blur_s·t. The thesis sums the
/// two spreads; keeping them apart is ours (docs/MATERIALS.md "Curvature").
pub fn cone_at(w: f32, s: f32, blur_w: f32, blur_s: f32, t: f32) -> f32 {
    (w + s * t).abs() + blur_w + blur_s * t
}
