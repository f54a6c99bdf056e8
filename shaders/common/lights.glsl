// Next-event estimation for punctual lights (KHR_lights_punctual), the sun
// (a directional light with an angular radius, sampled uniformly in its cone)
// and emissive triangles (picked by power with an alias table, then a point
// uniformly by area; src/scene/emitters.rs, src/scene/alias.rs).
#ifndef LIGHTS_GLSL
#define LIGHTS_GLSL
#include "common/rt.glsl"
#include "common/bsdf.glsl"
#include "common/material.glsl"

struct LightSample {
    vec3 wi;          // world direction towards the light
    float dist;       // distance to the light (1e30 for directional)
    vec3 L;           // incident radiance / pdf (includes 1/selection prob)
    float pdf;        // solid-angle pdf (0 = delta light, no MIS)
};

// Emissive triangles (src/rt/gpu_scene.rs `emitter_buffer`).
struct EmitterGpu {
    vec3 p0; float alias_prob;   // world vertices; alias table entry
    vec3 p1; uint alias;
    vec3 p2; float pdf_area;     // pick probability / area
    uvec4 ids;                   // instance, primitive, unused, unused
};
layout(set = SET_SCENE, binding = B_SCENE_EMITTERS, std430) readonly buffer Emitters { uvec4 emitter_header; EmitterGpu emitters[]; };

struct EmitterSample {
    vec3 wi;      // world direction towards the sampled point
    float dist;   // distance to it
    vec3 Le;      // radiance it emits towards the shading point
    float pdf;    // solid-angle pdf of wi (pick probability · area pdf · dist² / |cos θl|)
    vec3 p;       // the sampled point
    vec3 n;       // its unit geometric normal (either side)
    float extent; // largest |coordinate| of the triangle's vertices (offset_off_surface)
};

// Emitted radiance of emitter triangle `e` at barycentrics `bary`, seen along
// a ray of direction `dir` — exactly what material_at gives a hit there at
// mip 0 (secondary hits use mip 0): factor (× COLOR_0 where unlit) ×
// emissive texture (through its slot's uv map), nothing from
// the back of a single-sided material, nothing where the alpha mask cuts.
vec3 emitted_radiance(EmitterGpu e, vec2 bary, vec3 dir) {
    uint inst = e.ids.x, prim = e.ids.y;
    MaterialGpu g = materials[instance_material(inst)];
    // The front normal: e1 × e2 times instance_front_sign (glTF's
    // counter-clockwise front is in object space; surface_at).
    vec3 gn = cross(e.p1 - e.p0, e.p2 - e.p0) * instance_front_sign(inst);
    if (dot(gn, dir) >= 0.0 && g.tex1.z == 0) return vec3(0.0);
    if (!alpha_passes(inst, prim, bary)) return vec3(0.0);
    // The emission graph's output (1 where none is bound).
    vec3 ge = vec3(1.0);
#if defined(SC_MATERIAL_GRAPHS) && defined(SC_GRAPH_EMISSION)
    // The emission graph at the sampled point, as material_at evaluates it
    // there: through the memoization table where the caller set the light
    // sample's cone (sc_memo_cone, sample_emitter), else directly. Only
    // where the material binds one (an unbound emission output is 1), and
    // compiled only into scenes that have one (scene_shaders.rs).
    if (sc_material_binds_emission(instance_material(inst))) {
        Surface gs = surface_at(inst, prim, bary, dir);
#ifdef SC_MATERIAL_MEMO
        ge = sc_material_graphs_at(gs.material, gs.instance, gs.uv, gs.uv2, gs.uv2_per_uv, gs.p, gs.n, gs.tangent, gs.tangent_sign, 0.0, gs.memo_uv_per_width, 0.0).emission;
#else
        ge = sc_material_graphs(gs.material, gs.instance, gs.uv, gs.uv2, gs.uv2_per_uv, gs.p, gs.n, gs.tangent, gs.tangent_sign, 0.0).emission;
#endif
    }
#endif
    // A clearcoat over the emitter dims its emission by the coat's Fresnel
    // towards the viewer (material_with): evaluated there in full, at mip 0
    // as a secondary hit is, so light sampling and BSDF sampling see the
    // same radiance. Of the graphs only the emission is passed: the other
    // outputs do not reach the emission or the coat (the coat follows the
    // interpolated normal, or its own normal texture).
    if (SC_CLEARCOAT && g.coat.x > 0.0) {
        Surface cs = surface_at(inst, prim, bary, dir);
#ifdef SC_MATERIAL_GRAPHS
        ScGraphOutputs go = ScGraphOutputs(vec3(1.0), 1.0, 1.0, cs.n, ge, 0u);
#endif
        return material_with(cs, dir, 0.0 SC_GRAPH_OUTPUTS_PASS).emissive;
    }
    vec3 Le = g.emissive_metallic.rgb;
    if (SC_VERTEX_COLORS && g.tex1.w != 0) Le *= triangle_color(inst, prim, bary).rgb;   // unlit: × COLOR_0
    if (SC_TEXTURES && g.tex0.w >= 0) {
        vec2 uv = slot_on_second_uv(g.tex3.y, 3) ? triangle_uv2(inst, prim, bary) : triangle_uv(inst, prim, bary);
        Le *= sample_texture(g.tex0.w, slot_map_uv(g, 3, uv), 0.0).rgb;
    }
#if defined(SC_MATERIAL_GRAPHS) && defined(SC_GRAPH_EMISSION)
    Le = min(Le * ge, vec3(SC_MAX_EMISSION));   // as material_with
#endif
    return Le;
}

// Picks an emitter triangle by power (alias table: the column from the 32
// random bits `pick`, ⌊pick·count / 2^32⌋, the coin u.x) and a point on it
// uniformly by area (u.yz: Turk's square-root mapping, pbrt-v4
// SampleUniformTriangle). The alias method needs a uniform column (Walker
// 1977): until session 49 it came from a 24-bit float, ⌊u·count⌋, which
// favours some columns by up to 1/⌊2^24/count⌋ (±1 % at 10^6 emitter
// triangles, several % beyond; an audit's count). CPU twin:
// scene/alias.rs `AliasTable::sample`.
bool sample_emitter(vec3 p, uint pick, vec3 u, out EmitterSample es) {
    es.pdf = 0.0;
    es.Le = vec3(0.0);
    uint count = emitter_header.x;
    if (count == 0u) return false;
    uint i, lsb;
    umulExtended(pick, count, i, lsb);   // i = ⌊pick·count / 2^32⌋ < count
    if (u.x >= emitters[i].alias_prob) i = emitters[i].alias;
    EmitterGpu e = emitters[i];
    float su = sqrt(u.y);
    vec2 bary = vec2(su * (1.0 - u.z), su * u.z);   // weights of p1, p2
    vec3 q = (1.0 - bary.x - bary.y) * e.p0 + bary.x * e.p1 + bary.y * e.p2;
    vec3 d = q - p;
    float dist2 = dot(d, d);
    if (!(dist2 > 0.0)) return false;
    es.dist = sqrt(dist2);
    es.wi = d / es.dist;
    vec3 gn = cross(e.p1 - e.p0, e.p2 - e.p0);
    float gl = length(gn);
    if (!(gl > 0.0)) return false;
    float cos_l = abs(dot(gn / gl, es.wi));
    if (cos_l <= 0.0) return false;
    es.pdf = e.pdf_area * dist2 / cos_l;
    es.p = q;
    es.n = gn / gl;
    vec3 va = max(abs(e.p0), max(abs(e.p1), abs(e.p2)));
    es.extent = max(va.x, max(va.y, va.z));
#ifdef SC_MATERIAL_MEMO
    // The sampled point's memoization cone (integrator.glsl sets the
    // vertex's pencil and blur; none: the graph is evaluated directly).
    sc_memo_cone = sc_memo_nee ? memo_cone_at(sc_memo_nee_w, sc_memo_nee_spread, sc_memo_nee_blur_w,
                                              sc_memo_nee_blur_spread, es.dist)
                               : -1.0;
#endif
    es.Le = emitted_radiance(e, bary, es.wi);
#ifdef SC_MATERIAL_MEMO
    sc_memo_cone = -1.0;
#endif
    return es.pdf > 0.0 && any(greaterThan(es.Le, vec3(0.0)));
}

// Solid-angle pdf with which sample_emitter would pick the point a ray from
// distance `t` along unit direction `dir` hit on (instance, prim) — the
// light-sampling pdf in the MIS weight of a BSDF-sampled emitter hit.
float emitter_pdf(uint inst, uint prim, vec3 dir, float t) {
    uint first = instances[inst].mesh_pad.y;
    if (first == 0u || emitter_header.x == 0u) return 0.0;
    EmitterGpu e = emitters[first - 1u + prim];
    vec3 gn = cross(e.p1 - e.p0, e.p2 - e.p0);
    float gl = length(gn);
    if (!(gl > 0.0)) return 0.0;
    float cos_l = abs(dot(gn / gl, dir));
    return cos_l > 0.0 ? e.pdf_area * t * t / cos_l : 0.0;
}

float power_heuristic(float a, float b) {
    // Computed as 1 / (1 + (b/a)²), so a pdf beyond √FLT_MAX (a light
    // sample in an emitter's plane, a near-mirror at a grazing angle) gives
    // the limit instead of ∞/∞ = NaN, which dropped the whole path's sample
    // (pbrt-v4 PowerHeuristic returns 1 for an infinite a²).
    if (!(a > 0.0)) return 0.0;
    if (isinf(a)) return isinf(b) ? 0.5 : 1.0;
    float r = b / a;
    float w = 1.0 / (1.0 + r * r);
    return isnan(w) ? 0.0 : w;   // b NaN: no weight, as before
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
        float one_minus_cos = l.direction.w;   // 1 − cos r, exact (gpu_scene.rs)
        ls.dist = 1e30;
        if (!(one_minus_cos > 0.0)) {
            ls.wi = to_sun;
            ls.L = l.radiant_kind.rgb * sel;
            ls.pdf = 0.0;
            return true;
        }
        // Uniform cone sampling; radiance of the disc = E / Ω, pdf = 1 / Ω → L/pdf = E.
        // cos θ = 1 − h with h uniform in [0, 1 − cos r], and sin θ from h
        // (√(h (2 − h))), so small discs keep their precision: 1 − u (1 − cos r)
        // in f32 has only ~181 values for the default sun's r = 0.00465.
        float hh = u.x * one_minus_cos;
        float cos_t = 1.0 - hh;
        float sin_t = sqrt(max(0.0, hh * (2.0 - hh)));
        float phi = 2.0 * PI * u.y;
        Frame f = frame_from(to_sun);
        ls.wi = to_world(f, vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t));
        float omega = 2.0 * PI * one_minus_cos;
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
    // KHR_lights_punctual's recommended (informative) falloffs, as its
    // README writes them: the range window max(min(1 − (d/range)⁴, 1), 0)
    // on the inverse square, and a spot's
    // a = saturate((cos θ − cos outer) / max(0.001, cos inner − cos outer)),
    // squared (none outside the outer cone; full inside the inner one,
    // unless the two are within 0.001 in cos θ, when the ramp is that wide).
    float range = l.position_range.w;
    if (range > 0.0) {
        float r = dist / range;
        atten *= clamp(1.0 - r * r * r * r, 0.0, 1.0);
    }
    if (kind == 1u) {
        float cd = dot(-ls.wi, l.direction.xyz);
        float ci = l.cone.x, co = l.cone.y;
        float a = clamp((cd - co) / max(ci - co, 0.001), 0.0, 1.0);
        atten *= a * a;
    }
    ls.L = l.radiant_kind.rgb * atten * sel;
    ls.pdf = 0.0;
    return atten > 0.0;
}

// The sun discs seen along `dir` by a BSDF-sampled ray that escaped, each
// weighted against its own light sample (power heuristic of the BSDF's
// pdf_prev and that disc's light-sampling pdf; full weight after a delta
// event), so that where discs overlap every disc's two strategies still
// weigh 1 together: the NEE sample of disc i carries its own pdf only.
// (Weighting the discs' summed radiance by their summed pdf, as before
// session 42, lost light where discs overlap: two coincident discs up to a
// third of it in glossy highlights, tests/lights.rs
// `overlapping_sun_discs_add_up`.)
vec3 sun_radiance_mis(vec3 dir, float pdf_prev, bool specular_prev) {
    vec3 L = vec3(0.0);
    if (!SC_DIRECTIONAL) return L;
    uint count = scene.counts.x;
    for (uint i = 0u; i < count; ++i) {
        LightGpu l = lights[i];
        float one_minus_cos = l.direction.w;
        if (uint(l.radiant_kind.w) != 2u || !(one_minus_cos > 0.0)) continue;
        // Inside the cap: |dir − to_sun|² = 2 (1 − cos θ) ≤ 2 (1 − cos r),
        // the chord rather than the dot product, which near 1 resolves cos θ
        // only to 6·10⁻⁸ (1/180 of the default sun's 1 − cos r).
        vec3 chord = dir + l.direction.xyz;
        if (dot(chord, chord) <= 2.0 * one_minus_cos) {
            float omega = 2.0 * PI * one_minus_cos;
            float w = specular_prev ? 1.0 : power_heuristic(pdf_prev, 1.0 / (omega * float(count)));
            L += l.radiant_kind.rgb / omega * w;
        }
    }
    return L;
}

// Radiance of the sun discs seen along `dir` in full (camera rays and the
// caches' background samples: no light sample to weigh against).
vec3 sun_radiance(vec3 dir) { return sun_radiance_mis(dir, 0.0, true); }
#endif
