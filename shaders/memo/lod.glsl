// Level of detail and texel snapping of the memoization cache (Urbach 2023,
// thesis §2.2 and §5.3.2). CPU twin: src/materials/memo/lod.rs.
// A level m is a texel density of 2^m texels per unit of uv (eq. 5.1), with
// no minimum or maximum size: every level covers the whole uv plane.
#ifndef MEMO_LOD_GLSL
#define MEMO_LOD_GLSL

const int MEMO_MIN_LEVEL = -8, MEMO_MAX_LEVEL = 22;

// Eqs. 5.2-5.5: m = round(log2(1 / l_min) + bias), l_min the shorter uv
// derivative of the cone's footprint. The footprint ellipse's co-vertex
// (eq. 2.16) lies across the ray, so the shorter axis has the cone's width
// w whatever the incidence; its uv length is w * sqrt(uv_area_ratio) (the
// triangle's uv-to-world area ratio: an isotropic stand-in for the
// barycentric interpolation at P1, P2). No cone (w = 0): the finest level.
int memo_level(float cone_width, float uv_area_ratio, float bias) {
    float l = cone_width * sqrt(max(uv_area_ratio, 0.0));
    if (!(l > 0.0)) return MEMO_MAX_LEVEL;
    return clamp(int(floor(-log2(l) + bias + 0.5)), MEMO_MIN_LEVEL, MEMO_MAX_LEVEL);
}

// Eqs. 5.6-5.7: the nearest texel centre, (û, v̂) = round(2^m (u, v))
// (halves round up; ldexp is exact, so the same on every device and the
// CPU), clamped into int range.
ivec2 memo_quantise(vec2 uv, int level) {
    vec2 x = clamp(ldexp(uv, ivec2(level)) + 0.5, vec2(-1073741824.0), vec2(1073741760.0));
    return ivec2(floor(x));
}

// The uv width of a texel of level m, 2^-m: the footprint its value stands
// for (image nodes in graphs read the matching mip level).
float memo_texel_width(int level) { return ldexp(1.0, -level); }

// The uv of a texel centre: where the graph is evaluated on a miss
// (texel-centre snapping), at most 2^-(m+1) from the hit's uv per axis.
vec2 memo_snapped_uv(ivec2 q, int level) { return ldexp(vec2(q), ivec2(-level)); }

// Eqs. 2.10-2.11: the cone past a GGX surface of roughness alpha (GGX's
// alpha): width w + spread * t at the next hit, spread grown by
// beta_r = 2 sqrt(alpha^2 / (2 - 2 alpha^2)). The curvature term (eq. 2.12)
// is left out: the scene stores no curvature.
float memo_cone_width(float width, float spread, float t) { return width + spread * t; }
float memo_roughness_spread(float alpha) {
    float a2 = min(alpha * alpha, 0.999);
    return 2.0 * sqrt(a2 / (2.0 - 2.0 * a2));
}
#endif
