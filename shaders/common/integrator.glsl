// The path tracer every method shares (same bounces, Russian roulette, lights
// and seeds), so method differences come from the method alone.
// Next-event estimation (NEE) at every non-delta vertex for: punctual lights
// and the sun (one light picked uniformly); emissive triangles (one picked by
// power, a point uniformly by area, lights.glsl); the equirectangular map
// (piecewise-constant importance sampling, sky.glsl). The sun disc, emissive
// triangles and the map are also reached by BSDF sampling; both strategies are
// combined by multiple importance sampling with the power heuristic (Veach
// 1997, §9.2.2): a BSDF-sampled ray that hits an emitter or escapes to the map
// after a non-delta vertex is weighted by p_bsdf² / (p_bsdf² + p_light²), with
// p_light the light-sampling density of that direction, and the NEE sample by
// the complement, so nothing is counted twice. A transmissive material's
// dielectric branch samples lights too where it has a density (rough glass,
// reflection and transmission, and a clearcoat over glass; bsdf.glsl
// dielectric_eval). After a delta event (smooth glass, the camera) there is
// no NEE and the emission counts in full.
// SC_LIGHT_STRATEGY (features.glsl) can switch emitters and the map to NEE
// only or BSDF only (each alone is unbiased too; tests compare the three).
// Constant and Preetham skies are left to BSDF sampling (cosine sampling is
// already proportional to a constant sky; the sun is the sky's bright part).
//
// KHR_materials_volume: a path that refracts into a volume boundary carries
// the volume's absorption σ_a until it refracts out again; every segment
// inside (to the next hit, to a light sampled from inside, or out to the sky)
// is attenuated by Beer–Lambert exp(−σ_a·t). Volumes nest and overlap
// (media.glsl, after Schmidt & Budge 2002): the path keeps a stack of the
// volumes it is in, the innermost's σ_a applies, each interface refracts
// with the ratio of the indices on its two sides, and the back face of an
// enclosing volume met inside a later-entered one is passed through.
//
// Random numbers: the BSDF / Russian-roulette / punctual-light numbers come
// from the bounce's stream `r` and are drawn whether or not lights are
// compiled in, so that stream does not depend on the specialization constants.
// Emitter and map sampling draw from a separate stream `rl` forked off `r`
// without advancing it (also drawn in full either way): images of scenes
// without emissive triangles or maps are bit for bit those of the integrator
// before it had area-light NEE.
#ifndef INTEGRATOR_GLSL
#define INTEGRATOR_GLSL
#include "common/rt.glsl"
#include "common/random.glsl"
#include "common/material.glsl"
#include "common/lights.glsl"
#include "common/sky.glsl"
#include "common/media.glsl"
#include "common/packing.glsl"

struct RayCounts { uint bounce; uint shadow; };

// MIS weight of emission a path vertex sees directly (camera ray or
// BSDF-sampled ray after a vertex with sampling pdf `pdf_prev`).
float emitter_mis_weight(RtHit h, vec3 d, bool specular_prev, float pdf_prev) {
    if (specular_prev || SC_LIGHT_STRATEGY == LIGHT_STRATEGY_BSDF) return 1.0;
    float pl = emitter_pdf(h.instance, h.prim, d, h.t);
    if (SC_LIGHT_STRATEGY == LIGHT_STRATEGY_NEE) return pl > 0.0 ? 0.0 : 1.0;
    return pl > 0.0 ? power_heuristic(pdf_prev, pl) : 1.0;
}

// The same for the environment map seen by an escaping ray.
float env_mis_weight(vec3 d, bool specular_prev, float pdf_prev) {
    if (SC_ENV_KIND != 3u || specular_prev || SC_LIGHT_STRATEGY == LIGHT_STRATEGY_BSDF) return 1.0;
    float pe = env_pdf(d);
    if (SC_LIGHT_STRATEGY == LIGHT_STRATEGY_NEE) return pe > 0.0 ? 0.0 : 1.0;
    return pe > 0.0 ? power_heuristic(pdf_prev, pe) : 1.0;
}

// Beer–Lambert transmittance over distance t in a medium of absorption σ_a
// (0 outside any volume: then exactly 1, the caller skips it).
vec3 medium_transmittance(vec3 sigma_a, float t) { return exp(-sigma_a * t); }
bool in_medium(vec3 sigma_a) { return SC_TRANSMISSION && any(greaterThan(sigma_a, vec3(0.0))); }

// A vertex next-event estimation samples lights at: the opaque BSDF (frame f
// around the shading normal facing the ray), or the dielectric branch of a
// transmissive material: the clearcoat over it (share wc = coat_weight,
// frame f; outside only) and the rough dielectric (frame fg around the
// outward normal; mi: the interface's relative index, as sampled).
struct NeeVertex {
    bool glass;
    ShadingMaterial m;    // coat_in_frame(·, f) applied
    ShadingMaterial mi;   // glass: the dielectric with the relative index
    Frame f;
    Frame fg;
    vec3 wo;              // −d in frame f
    vec3 wo_g;            // −d in frame fg
    float wc;             // glass: the coat's share (0 without one or from behind)
    bool diel_delta;      // glass: a smooth dielectric (a delta lobe: no density)
    vec3 sigma_other;     // absorption on the surface's other side (glass)
    float ior_other;      // index of refraction of the medium there (glass; media.glsl)
};

NeeVertex opaque_vertex(ShadingMaterial m, Frame f, vec3 wo, vec3 sigma_a, float ior) {
    return NeeVertex(false, m, m, f, f, wo, wo, 0.0, true, sigma_a, ior);
}

// f·|cos θi| of the vertex's BSDF towards world direction wi, and the density
// with which the vertex's BSDF sampling draws wi (0 where it cannot). The
// glass branch is the mixture its sampler draws from: wc·coat + (1 − wc)·
// rough dielectric (reflection on the ray's side, transmission below; a
// direction whose shading side disagrees with its geometric side gets 0).
vec3 vertex_eval(NeeVertex v, Surface s, vec3 wi, out float pdf) {
    pdf = 0.0;
    bool above = dot(wi, s.ng) > 0.0;
    if (!v.glass) return above ? opaque_eval(v.m, v.wo, to_local(v.f, wi), pdf) : vec3(0.0);
    vec3 fc = vec3(0.0);
    if (v.wc > 0.0 && above) {
        float pc;
        fc += vec3(coat_eval(v.m, v.wo, to_local(v.f, wi), pc));
        pdf += v.wc * pc;
    }
    vec3 wi_g = to_local(v.fg, wi);
    if (!v.diel_delta && ((wi_g.z > 0.0) == (v.wo_g.z > 0.0)) == above) {
        float pd;
        fc += (1.0 - v.wc) * dielectric_eval(v.mi, v.wo_g, wi_g, pd);
        pdf += (1.0 - v.wc) * pd;
    }
    return fc;
}

// Whether a light sample at distance `dist` along wi is unoccluded (the
// shadow ray leaves on wi's side of the surface), and the absorption of the
// medium it crosses (the other side's for a glass vertex's transmission).
bool nee_unoccluded(Surface s, vec3 wi, float dist) {
    return !rt_occluded(surface_offset(s, dot(wi, s.ng) > 0.0 ? s.ng : -s.ng), wi, 0.0, dist);
}

// Whether the segment from the surface to point x on an emitter (unit
// geometric normal nl, vertices within `extent` of the origin) is
// unoccluded, both ends offset off their surfaces by the same rule
// (offset_off_surface: the larger of Wächter–Binder's offset and 64 ulps of
// the triangle's largest vertex coordinate), and the segment ends 2⁻¹⁶ of
// its length short, so neither surface is hit. (Until session 44 the
// shadow ray left the shading point's offset along wi towards a distance
// measured from the point itself, shortened by 10⁻⁴ of it: where the
// offset, 256 ulps of |p|, outgrew that — an emitter 3 m above a floor at
// y = 16 — every light sample ended on the emitter and was lost. Until
// session 50 the emitter's end had offset_ray alone, a few ulps of |x|
// where the sampled point's error is ulps of the vertices (a tilted 1 km
// emitter through the origin lost 28 % of its samples to itself), and the
// segment ran its full length, whose rounding is ulps of `len` (an emitter
// 0.05 m off a coordinate plane seen from 50 m lost 13 %: an audit's f32
// simulation).)
bool nee_unoccluded_to(Surface s, vec3 wi, vec3 x, vec3 nl, float extent) {
    vec3 o = surface_offset(s, dot(wi, s.ng) > 0.0 ? s.ng : -s.ng);
    vec3 d = offset_off_surface(x, dot(nl, wi) < 0.0 ? nl : -nl, extent) - o;
    float len = length(d);
    return len > 0.0 && !rt_occluded(o, d / len, 0.0, len * (1.0 - 1.0 / 65536.0));
}
vec3 nee_sigma(NeeVertex v, Surface s, vec3 wi, vec3 sigma_a) {
    return dot(wi, s.ng) > 0.0 ? sigma_a : v.sigma_other;
}
// The index of refraction of the medium a shadow ray along wi travels in.
float nee_ior(NeeVertex v, Surface s, vec3 wi, float ior) { return dot(wi, s.ng) > 0.0 ? ior : v.ior_other; }

// Shading normal facing away from the ray d (interpolated or mapped normals
// at grazing hits: s.ng faces the ray, s.n only shares its hemisphere): wo.z
// ≤ 0 would end every path there black, so such a hit is shaded with the
// geometric normal (issue 12). The clearcoat's normal (the interpolated one,
// or its own normal texture's) gets the same fallback: its lobe sampled
// around a normal facing away ended the coat's share of the paths there
// (tests/material_extensions.rs
// `clearcoat_normals_facing_away_fall_back_to_the_geometric_normal`).
void normals_facing_the_ray(inout Surface s, inout ShadingMaterial m, vec3 d) {
    if (dot(s.n, d) >= 0.0) s.n = s.ng;
    if (SC_CLEARCOAT && m.clearcoat > 0.0 && dot(m.coat_n, d) >= 0.0) m.coat_n = s.ng;
}

// What a smooth thin-walled transmissive surface passes straight on along
// d, in expectation over path_radiance's choices at it for a path arriving
// along d (the glass share m.transmission; from the front the coat's share
// wc = coat_weight, which only reflects; the dielectric's smooth branch
// reflecting with p_reflect (dielectric_layer) and transmitting the rest
// undeviated, tinted by the base colour: bsdf.glsl dielectric_sample), so
// m.transmission·(1 − wc)·(1 − p_reflect)·base; 0 for any other surface
// (opaque, rough, or a volume's boundary, which refracts). `ior` is the
// medium's around it (the thin sheet's relative index, as
// media_outside_ior gives it for a surface not in the stack).
vec3 thin_sheet_transmittance(Surface q, ShadingMaterial m, vec3 d, float ior) {
    if (!SC_TRANSMISSION || !m.thin || !(m.transmission > 0.0) || !dielectric_delta(m)) return vec3(0.0);
    normals_facing_the_ray(q, m, d);   // as path_radiance does
    Frame f = frame_from(q.n);
    m = coat_in_frame(m, f);
    float wc = q.front ? coat_weight(m, to_local(f, -d)) : 0.0;
    ShadingMaterial mi = m;
    mi.ior /= ior;
    vec3 Fr;
    float p_reflect = dielectric_layer(mi, abs(dot(q.n, d)), mi.ior, Fr);
    return m.transmission * (1.0 - wc) * (1.0 - p_reflect) * m.base;
}

// A delta light's shadow ray from the vertex along wi over `dist`: 1 where
// unoccluded, and through up to `sheets` smooth thin-walled transmissive
// surfaces (a glTF window: KHR_materials_transmission without a volume,
// roughness < 0.02) the product of what each passes straight on
// (thin_sheet_transmittance); 0 at any other surface or one sheet more.
// A delta light cannot be reached by BSDF sampling, so until session 54 a
// point, spot or delta directional light behind such a window lit nothing
// through it; an area emitter, the map and the sun's disc are reached
// through it by BSDF sampling and their light samples still stop there (no
// estimate counts twice). `sheets` is the bounces the path has left after
// this light sample (path_radiance spends one on each sheet), so the light
// is counted exactly where a path through the same sheets to a small
// emitter would be. A thin sheet bounds no volume: the medium, its index
// `ior`, is the same along the whole ray. Each ray past a sheet counts as
// a shadow ray of its own.
vec3 nee_delta_transmittance(Surface s, vec3 wi, float dist, float ior, uint sheets, inout RayCounts rays) {
    vec3 o = surface_offset(s, dot(wi, s.ng) > 0.0 ? s.ng : -s.ng);
    if (!SC_TRANSMISSION) return rt_occluded(o, wi, 0.0, dist) ? vec3(0.0) : vec3(1.0);
    vec3 T = vec3(1.0);
    float tmax = dist;
    for (uint k = 0u;; ++k) {
        RtHit h;
        if (!rt_closest_hit(o, wi, 0.0, tmax, h)) return T;
        if (k >= sheets) return vec3(0.0);
        // Not thin-walled or not transmissive by its factors (no texture
        // makes it so): stopped, without evaluating the material.
        uint material = instance_material(h.instance);
        MaterialGpu g = materials[material];
        if (!(g.attenuation.w > 0.5) || !(g.params.y > 0.0)) return vec3(0.0);
        Surface q = surface_at(h.instance, h.prim, h.bary, wi);
#ifdef SC_MATERIAL_GRAPHS
        // A sheet whose material binds graphs stops the ray, as every sheet
        // did before: its graphs are not evaluated here (the scene's graph
        // switch inlined once more per shader does not compile for the
        // procedural-heavy Sponza: material.glsl material_with). The others
        // are evaluated by material_with with no graph outputs (mask 0).
        if (sc_material_binds_graphs(material)) return vec3(0.0);
        ScGraphOutputs go = ScGraphOutputs(vec3(1.0), 1.0, 1.0, q.n, vec3(1.0), 0u);
#endif
        ShadingMaterial m = material_with(q, wi, 0.0 SC_GRAPH_OUTPUTS_PASS);
        T *= thin_sheet_transmittance(q, m, wi, ior);
        if (!any(greaterThan(T, vec3(0.0)))) return vec3(0.0);
        tmax -= h.t;
        o = surface_offset(q, -q.ng);   // q.ng faces the ray: the far side
        rays.shadow++;
    }
}

// Punctual lights and the sun: one light picked uniformly, weighted against
// BSDF sampling by the power heuristic where it has a density (the sun's
// discs), in full where it is a delta light (whose shadow ray passes smooth
// thin sheets: nee_delta_transmittance, with `sheets` and the medium's
// index `ior` on the vertex's side).
vec3 nee_punctual(Surface s, NeeVertex v, vec2 u_light, float u_pick, vec3 sigma_a, float ior, uint sheets,
                  inout RayCounts rays) {
    LightSample ls;
    if (!(SC_DIRECTIONAL || SC_PUNCTUAL) || !sample_light(s.p, u_light, u_pick, ls)) return vec3(0.0);
    float pdf_b;
    vec3 fc = vertex_eval(v, s, ls.wi, pdf_b);
    if (!any(greaterThan(fc, vec3(0.0)))) return vec3(0.0);
    rays.shadow++;
    vec3 T = vec3(1.0);
    if (ls.pdf > 0.0) {
        if (!nee_unoccluded(s, ls.wi, ls.dist * (1.0 - 1e-4))) return vec3(0.0);
    } else {
        T = nee_delta_transmittance(s, ls.wi, ls.dist * (1.0 - 1e-4), nee_ior(v, s, ls.wi, ior), sheets, rays);
        if (!any(greaterThan(T, vec3(0.0)))) return vec3(0.0);
    }
    float w = ls.pdf > 0.0 ? power_heuristic(ls.pdf, pdf_b) : 1.0;
    vec3 c = T * fc * ls.L * w;
    vec3 sg = nee_sigma(v, s, ls.wi, sigma_a);
    return in_medium(sg) ? c * medium_transmittance(sg, ls.dist) : c;
}

// Light-sampling estimates (before the path throughput) at a non-delta
// vertex: one emissive-triangle sample and one map sample, each weighted
// against BSDF sampling by the power heuristic.
vec3 nee_area_lights(Surface s, NeeVertex v, uint pick_emitter, vec3 u_emitter, vec2 u_env, vec3 sigma_a, inout RayCounts rays) {
    vec3 L = vec3(0.0);
    if (SC_LIGHT_STRATEGY == LIGHT_STRATEGY_BSDF) return L;
    if (SC_EMISSIVE) {
        EmitterSample es;
        if (sample_emitter(s.p, pick_emitter, u_emitter, es)) {
            float pdf_b;
            vec3 fc = vertex_eval(v, s, es.wi, pdf_b);
            if (any(greaterThan(fc, vec3(0.0)))) {
                rays.shadow++;
                if (nee_unoccluded_to(s, es.wi, es.p, es.n, es.extent)) {
                    float w = SC_LIGHT_STRATEGY == LIGHT_STRATEGY_NEE ? 1.0 : power_heuristic(es.pdf, pdf_b);
                    vec3 c = fc * es.Le * (w / es.pdf);
                    vec3 sg = nee_sigma(v, s, es.wi, sigma_a);
                    if (in_medium(sg)) c *= medium_transmittance(sg, es.dist);
                    L += c;
                }
            }
        }
    }
    if (SC_ENV_KIND == 3u) {
        vec3 wi;
        float pdf_e;
        if (env_sample(u_env, wi, pdf_e)) {
            float pdf_b;
            vec3 fc = vertex_eval(v, s, wi, pdf_b);
            if (any(greaterThan(fc, vec3(0.0)))) {
                rays.shadow++;
                if (nee_unoccluded(s, wi, 1e30)) {
                    float w = SC_LIGHT_STRATEGY == LIGHT_STRATEGY_NEE ? 1.0 : power_heuristic(pdf_e, pdf_b);
                    vec3 c = fc * environment(wi) * (w / pdf_e);
                    vec3 sg = nee_sigma(v, s, wi, sigma_a);
                    if (in_medium(sg)) c *= medium_transmittance(sg, 1e30);
                    L += c;
                }
            }
        }
    }
    return L;
}

// Radiance towards the origin of ray (o, d) whose closest hit is `h` (`hit` =
// false for a miss). `eye_cone` is the camera ray's cone at the hit (width,
// spread angle: camera.glsl eye_cone; 0 for a miss): the width is used for
// texture filtering at the first hit; later hits use mip 0 plus growth.
// `first` is the material evaluated at the first hit (undefined for a
// miss): the caching passes use it (the hash cache's demodulation, the
// accumulation floor of appendix C) instead of evaluating it again (an
// evaluation per shaded sample, and with memoization a second lookup of
// the same texel). Every path evaluates it: the first hit cannot
// be a false interface (the path starts in vacuum, an empty media stack:
// media.glsl media_false_interface).
vec3 path_radiance_first(vec3 o, vec3 d, bool hit, RtHit h, vec2 eye_cone, inout Rng rng, inout RayCounts rays,
                         out ShadingMaterial first) {
    float cone_width = eye_cone.x;
    vec3 L = vec3(0.0);
    vec3 beta = vec3(1.0);
    bool specular_prev = true;   // camera rays and delta events see the sun disc directly
    float pdf_prev = 0.0;
    float cone = cone_width;
    Media media = media_vacuum();   // the volumes the ray is in (media.glsl)
    vec3 sigma_a = vec3(0.0);    // absorption of the innermost, media_sigma_a(media)
#ifdef SC_MATERIAL_MEMO
    // The memoization cache's cone past the first hit (thesis eqs.
    // 2.10-2.12; memo/lod.glsl "The cone in two parts"): the geometric
    // pencil (signed width memo_w, spread memo_spread: the eye's, turned by
    // each reflection's curvature, eq. 2.12; a concave mirror may focus it
    // through 0) and the roughness blur (width memo_blur_w ≥ 0, spread
    // memo_blur_spread: the sum of the surfaces' β_r, eq. 2.11, never
    // focused). The width at a hit is |memo_w| + memo_blur_w; the texture
    // filtering's `cone` stays 0 there.
    float memo_w = cone_width;
    // (A perspective cone's spread is its width over the distance;
    // an orthographic one's is 0: parallel rays.)
    float memo_spread = hit && h.t > 0.0 && eye_cone.y > 0.0 ? cone_width / h.t : 0.0;
    float memo_blur_w = 0.0;
    float memo_blur_spread = 0.0;
#endif
    for (uint bounce = 0u;;) {
        // Beer–Lambert over this segment (a ray escaping an open mesh from
        // inside travels on forever: absorbed wherever σ_a > 0).
        if (in_medium(sigma_a)) beta *= medium_transmittance(sigma_a, hit ? h.t : 1e30);
        if (!hit) {
            L += beta * environment(d) * env_mis_weight(d, specular_prev, pdf_prev);
            L += beta * sun_radiance_mis(d, pdf_prev, specular_prev);
            break;
        }
        Surface s = surface_at(h.instance, h.prim, h.bary, d);
#ifdef SC_MATERIAL_MEMO
        if (bounce > 0u) {
            memo_w += memo_spread * h.t;
            memo_blur_w += memo_blur_spread * h.t;
        }
#endif
        if (SC_TRANSMISSION && media_false_interface(media, h.instance, s.front)) {
            // A boundary with the same medium on both sides (media.glsl):
            // no interface; the ray goes on, no bounce spent. What it
            // reaches is seen as through a delta event: a light sample
            // from the last vertex is stopped by this surface (shadow rays
            // do not pass transmissive ones), so the emission counts in
            // full (and emitter_pdf's distance from here would be wrong).
            media_cross(media, h.instance, s.front);
            o = surface_offset(s, -s.ng);
            specular_prev = true;
            pdf_prev = 0.0;
            rays.bounce++;
            hit = rt_closest_hit(o, d, 0.0, 1e30, h);
            continue;
        }
#ifdef SC_MATERIAL_MEMO
        sc_memo_cone = bounce > 0u && cone_width > 0.0 ? abs(memo_w) + memo_blur_w : -1.0;
#endif
        ShadingMaterial m = material_at(s, d, cone);
        if (bounce == 0u) first = m;   // (no false interface before it)
#ifdef SC_MATERIAL_MEMO
        sc_memo_cone = -1.0;
        // Eq. 2.11: the roughness blur grows by this surface's β_r.
        memo_blur_spread += memo_roughness_spread(m.roughness * m.roughness);
        // Eq. 2.12 at this hit, on the geometric pencil (width memo_w),
        // added below where the path reflects (light samples and
        // reflected bounces); a transmitted ray gets none (exact for a
        // thin-walled sheet; a refracting boundary's lens term is not
        // modelled).
        float memo_beta_c = memo_curvature_spread(s.memo_curvature, memo_w, dot(s.ng, d));
#endif
        normals_facing_the_ray(s, m, d);
        if (SC_EMISSIVE && any(greaterThan(m.emissive, vec3(0.0))))
            L += beta * m.emissive * emitter_mis_weight(h, d, specular_prev, pdf_prev);
        if (bounce >= SC_MAX_BOUNCES) break;

        Frame f = frame_from(s.n);
        vec3 wo = to_local(f, -d);
        m = coat_in_frame(m, f);
        Rng r = rng_fork(rng, bounce);
        Rng rl = rng_fork(r, 0x4C696768u);   // light-sampling stream (does not advance r)
        vec3 wi_world;
        // The vertex: the dielectric component of a transmissive material
        // (chosen with probability = its mixture weight; frames in
        // bsdf.glsl dielectric_sample_world) or the opaque BSDF. A
        // clearcoat over glass (outside only) reflects its share wc =
        // coat_weight, picked with that probability; the rest goes to the
        // dielectric below unweighted ((1 − wc)/(1 − wc) = 1). The
        // interface's index is relative to the medium on its other side
        // (media.glsl; 1 in vacuum: the plain ior).
        bool glass = SC_TRANSMISSION && m.transmission > 0.0 && rng_next(r) < m.transmission;
        NeeVertex v;
        // Next-event estimation where the vertex has a density: every
        // opaque vertex; a rough dielectric (reflection and transmission)
        // or a coat over glass (until session 43 rough glass was treated
        // as a delta event, so point, spot and directional lights never
        // reached it). An opaque vertex draws its punctual-light numbers
        // from r whether or not lights are compiled in, so the stream (and
        // the image) does not depend on the specialization constants; a
        // glass vertex draws them from the light stream rl, so its BSDF's
        // draws from r (and a smooth glass's images) are those of before
        // it had light sampling. Emissive triangles and the map always
        // draw from rl, in full.
        bool nee;
        vec2 u_light = vec2(0.0);
        float u_pick = 0.0;
        if (glass) {
            float wc = s.front ? coat_weight(m, wo) : 0.0;
            ShadingMaterial mi = m;
            mi.ior /= media_outside_ior(media, h.instance, s.front);
            Frame fg = frame_from(s.front ? s.n : -s.n);
            v = NeeVertex(true, m, mi, f, fg, wo, to_local(fg, -d), wc, dielectric_delta(mi), sigma_a, media_ior(media, 0u));
            if (!m.thin) {
                Media across = media;
                media_cross(across, h.instance, s.front);
                v.sigma_other = media_sigma_a(across);
                v.ior_other = media_ior(across, 0u);
            }
            nee = wc > 0.0 || !v.diel_delta;
            if (nee) {
                u_light = rng_next2(rl);
                u_pick = rng_next(rl);
            }
        } else {
            if (wo.z <= 0.0) break;
            u_light = rng_next2(r);
            u_pick = rng_next(r);
            v = opaque_vertex(m, f, wo, sigma_a, media_ior(media, 0u));
            nee = true;
        }
        if (nee) {
            uint pick_emitter = rng_next_u32(rl);
            vec3 u_emitter = vec3(rng_next(rl), rng_next2(rl));
            vec2 u_env = rng_next2(rl);
            L += beta * nee_punctual(s, v, u_light, u_pick, sigma_a, media_ior(media, 0u), SC_MAX_BOUNCES - 1u - bounce, rays);
#ifdef SC_MATERIAL_MEMO
            // Light samples are secondary hits of this path too: their
            // cone is the one a BSDF-sampled ray reaching the same point
            // would have (|memo_w + memo_spread · distance| + the blur's width
            // there, as the next
            // bounce grows it), so both strategies see the same memoized
            // emission (lights.glsl sample_emitter).
            sc_memo_nee = cone_width > 0.0;
            sc_memo_nee_w = memo_w;
            sc_memo_nee_spread = memo_spread + memo_beta_c;
            sc_memo_nee_blur_w = memo_blur_w;
            sc_memo_nee_blur_spread = memo_blur_spread;
#endif
            L += beta * nee_area_lights(s, v, pick_emitter, u_emitter, u_env, sigma_a, rays);
#ifdef SC_MATERIAL_MEMO
            sc_memo_nee = false;
#endif
        }
        if (glass) {
            bool delta;
            if (v.wc > 0.0 && rng_next(r) < v.wc) {
                vec3 wi;
                float ratio;
                if (!coat_sample(m, wo, rng_next2(r), wi, ratio)) break;
                wi_world = to_world(f, wi);
                if (dot(wi_world, s.ng) <= 0.0) break;
                beta *= ratio;
                delta = false;
            } else {
                vec3 w;
                if (!dielectric_sample_world(v.mi, s.n, s.front, d, vec3(rng_next2(r), rng_next(r)), wi_world, w, delta)) break;
                beta *= w;
                // Refraction crosses the boundary: into the material's
                // volume from the front, out of it from the back (a
                // thin-walled sheet bounds no volume).
                if (dot(wi_world, s.ng) < 0.0 && !m.thin) {
                    media_cross(media, h.instance, s.front);
                    sigma_a = media_sigma_a(media);
                }
            }
            // MIS against the light samples above: the mixture's density
            // in the sampled direction. A delta event, or a direction light
            // sampling cannot produce (density 0: shading and geometric
            // sides disagree), sees emission in full.
            pdf_prev = 0.0;
            if (!delta) vertex_eval(v, s, wi_world, pdf_prev);
            specular_prev = pdf_prev <= 0.0;
        } else {
            vec3 wi, w;
            float pdf;
            if (!opaque_sample(m, wo, vec3(rng_next2(r), rng_next(r)), wi, w, pdf)) break;
            wi_world = to_world(f, wi);
            if (dot(wi_world, s.ng) <= 0.0) break;
            beta *= w;
            specular_prev = false;
            pdf_prev = pdf;
        }
        // Russian roulette from the second bounce on.
        if (bounce >= 1u) {
            float q = clamp(max(beta.r, max(beta.g, beta.b)), 0.05, 1.0);
            if (rng_next(r) >= q) break;
            beta /= q;
        }
        if (!all(lessThan(beta, vec3(1e30))) || any(isnan(beta))) break;
#ifdef SC_MATERIAL_MEMO
        if (dot(wi_world, s.ng) > 0.0) memo_spread += memo_beta_c;   // a reflection (eq. 2.12)
#endif
        o = surface_offset(s, dot(wi_world, s.ng) > 0.0 ? s.ng : -s.ng);
        cone = 0.0;  // secondary hits sample mip 0 (no cone model past the first hit)
        d = wi_world;
        rays.bounce++;
        ++bounce;
        hit = rt_closest_hit(o, d, 0.0, 1e30, h);
    }
    return L;
}

vec3 path_radiance(vec3 o, vec3 d, bool hit, RtHit h, vec2 eye_cone, inout Rng rng, inout RayCounts rays) {
    ShadingMaterial first;
    return path_radiance_first(o, d, hit, h, eye_cone, rng, rays, first);
}

// Every pass that traces paths drops one whose radiance came out ∞ or NaN:
// it is replaced by black (one bad path must not poison a pixel's mean or a
// cache's record) and the caller counts it (`non_finite_samples`, a path
// tracer bug the image alone would hide). True when L was replaced.
bool drop_non_finite(inout vec3 L) {
    if (!(any(isnan(L)) || any(isinf(L)))) return false;
    L = vec3(0.0);
    return true;
}

// Base colour at a first hit, for demodulation and the albedo output.
vec3 first_hit_albedo(RtHit h, vec3 d, float cone_width) {
    Surface s = surface_at(h.instance, h.prim, h.bary, d);
    ShadingMaterial m = material_at(s, d, cone_width);
    return m.base;
}

// The material of a stored first hit (Listing 1: the caches' slots) seen
// along `d` by a pixel's cone of width `cone_width` there.
ShadingMaterial stored_hit_material(uvec4 fh, vec3 d, float cone_width) {
    Surface s = surface_at(fh.w, fh.z, first_hit_bary(fh), d);
    return material_at(s, d, cone_width);
}
#endif
