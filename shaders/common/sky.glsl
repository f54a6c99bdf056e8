// What rays leaving the scene see: constant, Preetham sky (parameters from
// src/scene/preetham.rs), or an equirectangular map (row 0 at +Y, u = 0 at −Z
// turning towards +X). The sun disc is a light (lights.glsl), not part of the sky.
#ifndef SKY_GLSL
#define SKY_GLSL
#include "common/scene.glsl"

// Exactly src/scene/preetham.rs: perez(), above_horizon(), preetham_radiance().
float perez(uint channel, float cos_theta, float gamma) {
    uint b = channel * 5u;
    float A = scene.perez[b], B = scene.perez[b + 1u], C = scene.perez[b + 2u], D = scene.perez[b + 3u], E = scene.perez[b + 4u];
    float cg = cos(gamma);
    return (1.0 + A * exp(B / cos_theta)) * (1.0 + C * exp(D * gamma) + E * cg * cg);
}

const float PREETHAM_MIN_COS_THETA = 1.0e-3;
const float PREETHAM_HORIZON_BLEND = 0.05;
const float PREETHAM_GROUND_ALBEDO = 0.3;

vec3 preetham_above_horizon(vec3 dir) {
    float cos_theta = max(dir.y, PREETHAM_MIN_COS_THETA);
    float gamma = acos(clamp(dot(dir, scene.sun_dir.xyz), -1.0, 1.0));
    float st = scene.sun_dir.w;
    float Y = scene.zenith.x * perez(0u, cos_theta, gamma) / perez(0u, 1.0, st);
    float x = scene.zenith.y * perez(1u, cos_theta, gamma) / perez(1u, 1.0, st);
    float y = max(scene.zenith.z * perez(2u, cos_theta, gamma) / perez(2u, 1.0, st), 1e-4);
    float X = x / y * Y;
    float Z = (1.0 - x - y) / y * Y;
    vec3 rgb = vec3(3.2404542 * X - 1.5371385 * Y - 0.4985314 * Z,
                    -0.969266 * X + 1.8760108 * Y + 0.041556 * Z,
                    0.0556434 * X - 0.2040259 * Y + 1.0572252 * Z);
    return max(rgb * scene.env_constant.w, vec3(0.0));
}

vec3 preetham_sky(vec3 dir) {
    if (dir.y >= 0.0) return preetham_above_horizon(dir);
    vec3 ground = PREETHAM_GROUND_ALBEDO * preetham_above_horizon(vec3(0.0, 1.0, 0.0));
    float t = min(-dir.y / PREETHAM_HORIZON_BLEND, 1.0);
    if (t >= 1.0) return ground;
    vec3 horizon = normalize(vec3(dir.x, 0.0, dir.z));
    return mix(preetham_above_horizon(horizon), ground, t);
}

// (u, v) of a unit direction on the equirectangular map: u = atan2(x, −z)/2π
// in [0, 1), v = θ/π with θ the angle from +Y. θ comes from atan2 of the
// direction's horizontal length and its y, not acos(y): in f32, acos(y)
// near a pole is exact to only ~2.4·10⁻⁴ rad (y = cos θ rounds to 1 for
// θ < 3.5·10⁻⁴), which gave a direction near the zenith v = 0 and so a
// zero map pdf (env_pdf) for a map lit there.
vec2 equirect_uv(vec3 dir) {
    float u = atan(dir.x, -dir.z) * (0.5 * INV_PI);
    u = u < 0.0 ? u + 1.0 : u;
    return vec2(u, atan(length(dir.xz), dir.y) * INV_PI);
}

vec3 environment(vec3 dir) {
    if (SC_ENV_KIND == 1u) return scene.env_constant.rgb;
    if (SC_ENV_KIND == 2u) return preetham_sky(dir);
    if (SC_ENV_KIND == 3u) {
        return textureLod(env_map, equirect_uv(dir), 0.0).rgb * scene.env_constant.w;
    }
    return vec3(0.0);
}

// Importance sampling of the equirectangular map (SC_ENV_KIND 3): the
// piecewise-constant distribution of src/scene/env_distribution.rs, with
// header (width, height; width 0 = none), the marginal CDF over rows (h + 1
// floats) and each row's conditional CDF over columns (w + 1 floats).
layout(set = SET_SCENE, binding = B_SCENE_ENV_DISTRIBUTION, std430) readonly buffer EnvDistribution { uvec4 env_header; float env_cdf[]; };

// Largest index k in [first, first + n) with env_cdf[k] <= x (env_cdf[first] = 0).
uint env_cdf_find(uint first, uint n, float x) {
    uint lo = 0u, hi = n - 1u;   // invariant: env_cdf[first + lo] <= x
    while (lo < hi) {
        uint mid = (lo + hi + 1u) >> 1;
        if (env_cdf[first + mid] <= x) lo = mid; else hi = mid - 1u;
    }
    return lo;
}

// The density env_sample has for the unit direction `dir` (MIS of rays that escape):
// p(u, v) / (2π² sin θ), sin θ the direction's horizontal length (exact
// near the poles, unlike sin(π·v)).
float env_pdf(vec3 dir) {
    if (SC_ENV_KIND != 3u) return 0.0;
    uint w = env_header.x, h = env_header.y;
    if (w == 0u) return 0.0;
    vec2 uv = equirect_uv(dir);
    uint x = min(uint(uv.x * float(w)), w - 1u), y = min(uint(uv.y * float(h)), h - 1u);
    float pm = env_cdf[y + 1u] - env_cdf[y];
    uint row = h + 1u + y * (w + 1u);
    float pc = env_cdf[row + x + 1u] - env_cdf[row + x];
    float sin_t = length(dir.xz);
    return sin_t > 0.0 ? pm * float(h) * pc * float(w) / (2.0 * PI * PI * sin_t) : 0.0;
}

// Samples a direction from the map's distribution (row by the marginal, then
// column by that row's conditional, uniform within the texel).
bool env_sample(vec2 r, out vec3 dir, out float pdf) {
    pdf = 0.0;
    dir = vec3(0.0, 1.0, 0.0);
    uint w = env_header.x, h = env_header.y;
    if (SC_ENV_KIND != 3u || w == 0u) return false;
    uint y = min(env_cdf_find(0u, h + 1u, r.y), h - 1u);
    float c0 = env_cdf[y], c1 = env_cdf[y + 1u];
    float v = (float(y) + clamp((r.y - c0) / max(c1 - c0, 1e-30), 0.0, 1.0)) / float(h);
    uint row = h + 1u + y * (w + 1u);
    uint x = min(env_cdf_find(row, w + 1u, r.x), w - 1u);
    float d0 = env_cdf[row + x], d1 = env_cdf[row + x + 1u];
    float u = (float(x) + clamp((r.x - d0) / max(d1 - d0, 1e-30), 0.0, 1.0)) / float(w);
    u = min(u, 1.0 - 1e-7);
    v = clamp(v, 1e-7, 1.0 - 1e-7);
    // Direction of (u, v): inverse of environment()'s lookup (env_map.rs equirect_direction).
    float phi = 2.0 * PI * u, theta = PI * v;
    float st = sin(theta);
    dir = vec3(st * sin(phi), cos(theta), -st * cos(phi));
    pdf = (c1 - c0) * float(h) * (d1 - d0) * float(w) / (2.0 * PI * PI * st);
    return pdf > 0.0;
}
#endif
