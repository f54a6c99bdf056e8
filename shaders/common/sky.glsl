// What rays leaving the scene see: constant, Preetham sky (parameters from
// src/scene/preetham.rs), or an equirectangular map (row 0 at +Y, u = 0 at −Z
// turning towards +X). The sun disc is a light (lights.glsl), not part of the sky.
#ifndef SKY_GLSL
#define SKY_GLSL
#include "common/scene.glsl"

float perez(uint channel, float cos_theta, float gamma, float cos_gamma) {
    uint b = channel * 5u;
    float A = scene.perez[b], B = scene.perez[b + 1u], C = scene.perez[b + 2u], D = scene.perez[b + 3u], E = scene.perez[b + 4u];
    return (1.0 + A * exp(B / cos_theta)) * (1.0 + C * exp(D * gamma) + E * cos_gamma * cos_gamma);
}

vec3 preetham_sky(vec3 dir) {
    // Below the horizon the sky is evaluated at the horizon (continuous, finite).
    float cos_theta = max(dir.y, 0.01);
    vec3 sd = scene.sun_dir.xyz;
    float sun_theta = scene.sun_dir.w;
    float cos_gamma = clamp(dot(normalize(vec3(dir.x, max(dir.y, 0.01), dir.z)), sd), -1.0, 1.0);
    float gamma = acos(cos_gamma);
    float cos_st = cos(sun_theta);
    float Y = scene.zenith.x * perez(0u, cos_theta, gamma, cos_gamma) / perez(0u, 1.0, sun_theta, cos_st);
    float x = scene.zenith.y * perez(1u, cos_theta, gamma, cos_gamma) / perez(1u, 1.0, sun_theta, cos_st);
    float y = scene.zenith.z * perez(2u, cos_theta, gamma, cos_gamma) / perez(2u, 1.0, sun_theta, cos_st);
    // Yxy → XYZ → linear sRGB (D65).
    float X = y > 0.0 ? x * Y / y : 0.0;
    float Z = y > 0.0 ? (1.0 - x - y) * Y / y : 0.0;
    vec3 rgb = vec3(3.2404542 * X - 1.5371385 * Y - 0.4985314 * Z,
                    -0.9692660 * X + 1.8760108 * Y + 0.0415560 * Z,
                    0.0556434 * X - 0.2040259 * Y + 1.0572252 * Z);
    return max(rgb, vec3(0.0)) * scene.env_constant.w;
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
