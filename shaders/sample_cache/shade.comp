#version 460
// variant: SUBGROUP_OPS
// Shades the compacted samples: one path per sample from the eye through its
// stored first hit (the integrator every method shares), demodulated by the
// first hit's base colour and accumulated as a running mean. View-dependent
// materials clamp the blend factor to α_min = (1 − α_GGX)·0.5 + α_GGX·0.1
// (appendix C), or use a fixed α (ACCUM_MODE 1).
#include "sample_cache/common.glsl"
layout(local_size_x = 64) in;

bool view_dependent(ShadingMaterial m) { return m.metallic > 0.5 || m.transmission > 0.0; }

void main() {
    // Grid-stride over the list: the indirect dispatch covers the list's
    // length (indirect_args.comp, up to the device's workgroup-count limit),
    // not its capacity of (N + 1) entries per pixel, whose mostly empty
    // workgroups cost time on CPU drivers (issue 6).
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint count = state[8];
    uint shaded = 0u;
    RayCounts rays = RayCounts(0u, 0u);
    for (uint i = gl_GlobalInvocationID.x; i < count; i += stride) {
        uint code = shade_list[i];
        uint eye, slot, pixel;
        list_decode(code, eye, slot, pixel);
        uint idx = slot_index(eye, slot, pixel);
        uvec4 fh = fh_cur[idx];
        EyeGpu e = frame.eyes[eye];
        vec3 o = e.pos_tanx.xyz;
        vec3 wp = hit_position(fh);
        float t = length(wp - o);
        vec3 d = (wp - o) / max(t, 1e-30);
        RtHit h;
        h.t = t;
        h.instance = fh.w;
        h.prim = fh.z;
        h.bary = first_hit_bary(fh);
        Rng rng = rng_init(frame.size_seed.z, frame.size_seed.w, eye, pixel, 0x10000u + slot);
        vec3 L = path_radiance(o, d, true, h, t * eye_pixel_spread(e), rng, rays);
        if (any(isnan(L)) || any(isinf(L))) L = vec3(0.0);
        Surface s = surface_at(h.instance, h.prim, h.bary, d);
        ShadingMaterial m = material_at(s, d, t * eye_pixel_spread(e));
        vec3 demod = L / max(m.base, vec3(1e-3));

        vec4 rec = rad_cur[idx];
        float c = min(rec.w + 1.0, C_MAX);
        float alpha = 1.0 / c;
        if (view_dependent(m)) {
            float a_ggx = m.roughness * m.roughness;
            float a_min = ACCUM_MODE == 1u ? pc.fixed_alpha : (1.0 - a_ggx) * 0.5 + a_ggx * 0.1;
            if (alpha < a_min) {
                alpha = a_min;
                c = 1.0 / a_min;   // effective sample count of the clamped blend
            }
        }
        rad_cur[idx] = vec4(mix(rec.rgb, demod, alpha), c);
        atomicAdd(pixel_stats[eye * npix() + pixel].y, 1u);
        shaded++;
    }
    count_add(C_SHADED, shaded);
    count_add(C_BOUNCE_RAYS, rays.bounce);
    count_add(C_SHADOW_RAYS, rays.shadow);
}
