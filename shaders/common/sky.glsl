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

vec3 environment(vec3 dir) {
    if (SC_ENV_KIND == 1u) return scene.env_constant.rgb;
    if (SC_ENV_KIND == 2u) return preetham_sky(dir);
    if (SC_ENV_KIND == 3u) {
        float u = atan(dir.x, -dir.z) * (0.5 * INV_PI);
        u = u < 0.0 ? u + 1.0 : u;
        float v = acos(clamp(dir.y, -1.0, 1.0)) * INV_PI;
        return textureLod(env_map, vec2(u, v), 0.0).rgb * scene.env_constant.w;
    }
    return vec3(0.0);
}
#endif
