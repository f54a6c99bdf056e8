// The path tracer every method shares (same bounces, Russian roulette, lights
// and seeds), so method differences come from the method alone.
// NEE for the sun and punctual lights with MIS against BSDF sampling for the
// sun disc; emissive triangles and the sky are reached by BSDF sampling.
#ifndef INTEGRATOR_GLSL
#define INTEGRATOR_GLSL
#include "common/rt.glsl"
#include "common/random.glsl"
#include "common/material.glsl"
#include "common/lights.glsl"
#include "common/sky.glsl"

struct RayCounts { uint bounce; uint shadow; };

// Radiance towards the origin of ray (o, d) whose closest hit is `h` (`hit` =
// false for a miss). `cone_width` is the ray-cone width at the hit, used for
// texture filtering at the first hit; later hits use mip 0 plus growth.
vec3 path_radiance(vec3 o, vec3 d, bool hit, RtHit h, float cone_width, inout Rng rng, inout RayCounts rays) {
    vec3 L = vec3(0.0);
    vec3 beta = vec3(1.0);
    bool specular_prev = true;   // camera rays and delta events see the sun disc directly
    float pdf_prev = 0.0;
    float cone = cone_width;
    for (uint bounce = 0u;; ++bounce) {
        if (!hit) {
            L += beta * environment(d);
            float lp;
            vec3 sun = sun_radiance(d, lp);
            if (any(greaterThan(sun, vec3(0.0)))) L += beta * sun * (specular_prev ? 1.0 : power_heuristic(pdf_prev, lp));
            break;
        }
        Surface s = surface_at(h.instance, h.prim, h.bary, d);
        ShadingMaterial m = material_at(s, d, cone);
        // Shading normal facing away from the ray (interpolated or mapped
        // normals at grazing hits: s.ng faces the ray, s.n only shares its
        // hemisphere): wo.z ≤ 0 below would end every path here black, so
        // shade such a hit with the geometric normal (issue 12).
        if (dot(s.n, d) >= 0.0) s.n = s.ng;
        if (SC_EMISSIVE) L += beta * m.emissive;
        if (bounce >= SC_MAX_BOUNCES) break;

        Frame f = frame_from(s.n);
        vec3 wo = to_local(f, -d);
        Rng r = rng_fork(rng, bounce);
        vec3 wi_world;
        if (SC_TRANSMISSION && m.transmission > 0.0 && rng_next(r) < m.transmission) {
            // Dielectric component (chosen with probability = its mixture weight).
            // The BSDF works in a frame around the *outward* normal (s.n faces
            // the ray, so it is flipped on back-face hits): wo.z < 0 means the
            // ray arrives from inside, and wi comes back in that same frame.
            Frame fg = frame_from(s.front ? s.n : -s.n);
            vec3 wi, w;
            bool delta;
            if (!dielectric_sample(m, to_local(fg, -d), vec3(rng_next2(r), rng_next(r)), wi, w, delta)) break;
            wi_world = to_world(fg, wi);
            beta *= w;
            specular_prev = true;
            pdf_prev = 0.0;
        } else {
            if (wo.z <= 0.0) break;
            // Next-event estimation. Its random numbers are drawn whether or
            // not lights are compiled in, so the stream (and the image) does
            // not depend on the specialization constants.
            vec2 u_light = rng_next2(r);
            float u_pick = rng_next(r);
            LightSample ls;
            if ((SC_DIRECTIONAL || SC_PUNCTUAL) && sample_light(s.p, u_light, u_pick, ls) && dot(ls.wi, s.ng) > 0.0) {
                float pdf_b;
                vec3 fc = opaque_eval(m, wo, to_local(f, ls.wi), pdf_b);
                if (any(greaterThan(fc, vec3(0.0)))) {
                    rays.shadow++;
                    vec3 so = offset_ray(s.p, s.ng);
                    if (!rt_occluded(so, ls.wi, 0.0, ls.dist * (1.0 - 1e-4))) {
                        float w = ls.pdf > 0.0 ? power_heuristic(ls.pdf, pdf_b) : 1.0;
                        L += beta * fc * ls.L * w;
                    }
                }
            }
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
        o = offset_ray(s.p, dot(wi_world, s.ng) > 0.0 ? s.ng : -s.ng);
        cone = 0.0;  // secondary hits sample mip 0 (no cone model past the first hit)
        d = wi_world;
        rays.bounce++;
        hit = rt_closest_hit(o, d, 0.0, 1e30, h);
    }
    return L;
}

// Base colour at a first hit, for demodulation and the albedo output.
vec3 first_hit_albedo(RtHit h, vec3 d, float cone_width) {
    Surface s = surface_at(h.instance, h.prim, h.bary, d);
    ShadingMaterial m = material_at(s, d, cone_width);
    return m.base;
}
#endif
