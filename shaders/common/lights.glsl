// Next-event estimation for punctual lights (KHR_lights_punctual) and the sun
// (a directional light with an angular radius, sampled uniformly in its cone).
#ifndef LIGHTS_GLSL
#define LIGHTS_GLSL
#include "common/rt.glsl"
#include "common/bsdf.glsl"

struct LightSample {
    vec3 wi;          // world direction towards the light
    float dist;       // distance to the light (1e30 for directional)
    vec3 L;           // incident radiance / pdf (includes 1/selection prob)
    float pdf;        // solid-angle pdf (0 = delta light, no MIS)
};

float power_heuristic(float a, float b) {
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0 ? a2 / (a2 + b2) : 0.0;
}

// Picks one light uniformly and samples it.
bool sample_light(vec3 p, vec2 u, float u_pick, out LightSample ls) {
    uint count = scene.counts.x;
    ls.pdf = 0.0;
    ls.L = vec3(0.0);
    if (count == 0u) return false;
    uint li = min(uint(u_pick * float(count)), count - 1u);
    LightGpu l = lights[li];
    uint kind = uint(l.radiant_kind.w);
    float sel = float(count);
    if (kind == 2u) {
        if (!SC_DIRECTIONAL) return false;
        vec3 to_sun = -l.direction.xyz;
        float cos_max = l.direction.w;
        ls.dist = 1e30;
        if (cos_max >= 1.0) {
            ls.wi = to_sun;
            ls.L = l.radiant_kind.rgb * sel;
            ls.pdf = 0.0;
            return true;
        }
        // Uniform cone sampling; radiance of the disc = E / Ω, pdf = 1 / Ω → L/pdf = E.
        float cos_t = 1.0 - u.x * (1.0 - cos_max);
        float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
        float phi = 2.0 * PI * u.y;
        Frame f = frame_from(to_sun);
        ls.wi = to_world(f, vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t));
        float omega = 2.0 * PI * (1.0 - cos_max);
        ls.pdf = 1.0 / (omega * sel);
        ls.L = l.radiant_kind.rgb * sel;
        return true;
    }
    if (!SC_PUNCTUAL) return false;
    vec3 d = l.position_range.xyz - p;
    float dist2 = dot(d, d);
    if (dist2 <= 0.0) return false;
    float dist = sqrt(dist2);
    ls.wi = d / dist;
    ls.dist = dist;
    float atten = 1.0 / dist2;
    float range = l.position_range.w;
    if (range > 0.0) {
        float r = dist / range;
        atten *= clamp(1.0 - r * r * r * r, 0.0, 1.0) * clamp(1.0 - r * r * r * r, 0.0, 1.0);
    }
    if (kind == 1u) {
        float cd = dot(-ls.wi, l.direction.xyz);
        float ci = l.cone.x, co = l.cone.y;
        atten *= clamp((cd - co) / max(ci - co, 1e-4), 0.0, 1.0);
        atten *= atten > 0.0 ? 1.0 : 0.0;
    }
    ls.L = l.radiant_kind.rgb * atten * sel;
    ls.pdf = 0.0;
    return atten > 0.0;
}

// Radiance of sun discs seen along `dir` and the light-sampling pdf of that
// direction (for MIS of BSDF-sampled rays that escape the scene).
vec3 sun_radiance(vec3 dir, out float light_pdf) {
    light_pdf = 0.0;
    vec3 L = vec3(0.0);
    if (!SC_DIRECTIONAL) return L;
    uint count = scene.counts.x;
    for (uint i = 0u; i < count; ++i) {
        LightGpu l = lights[i];
        if (uint(l.radiant_kind.w) != 2u || l.direction.w >= 1.0) continue;
        if (dot(dir, -l.direction.xyz) >= l.direction.w) {
            float omega = 2.0 * PI * (1.0 - l.direction.w);
            L += l.radiant_kind.rgb / omega;
            light_pdf += 1.0 / (omega * float(count));
        }
    }
    return L;
}
#endif
