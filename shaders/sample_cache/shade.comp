#version 460
// variant: SUBGROUP_OPS
// Shades the compacted samples: one path per sample from the eye through its
// stored first hit (the integrator every method shares), demodulated
// (common.glsl `demodulate`: emission kept apart) and accumulated as an
// exponential average whose effective count c_s the record carries
// (common/accumulation.glsl `accumulate_record`). The blend factor is the running mean's
// 1/(c_s + 1) (ACCUM_MODE 0, the default: §4–5's radiance cache), floored
// at the fixed α of `--accumulation fixed:A` for every sample (ACCUM_MODE 1,
// §5.2's α = 0.1) or at appendix C's α_min = (1 − α_GGX)·0.5 + α_GGX·0.1 for
// every sample whose BSDF has a specular lobe (ACCUM_MODE 2,
// `--accumulation alpha-min`). Flooring rather than replacing keeps the start exact: the first
// shading of a sample (c_s = 0) takes its path as is, and the average only
// becomes exponential once 1/(c_s + 1) falls below the floor.
#include "sample_cache/common.glsl"
layout(local_size_x = 64) in;

void main() {
    // Grid-stride over the list: the indirect dispatch covers the list's
    // length (indirect_args.comp, up to the device's workgroup-count limit),
    // not its capacity of (N + 1) entries per pixel, whose mostly empty
    // workgroups cost time on CPU drivers (issue 6).
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint count = state[8];
    uint shaded = 0u, dropped = 0u;
    RayCounts rays = RayCounts(0u, 0u);
    for (uint i = gl_GlobalInvocationID.x; i < count; i += stride) {
        uint code = shade_list[i];
        uint eye, slot, pixel;
        list_decode(code, eye, slot, pixel);
#ifdef SC_MATERIAL_MEMO
        sc_memo_eye = eye;
#endif
        uint idx = slot_index(eye, slot, pixel);
        uvec4 fh = fh_cur[idx];
        EyeGpu e = frame.eyes[eye];
        vec3 o, d;
        float t;
        eye_ray_to(e, hit_position(fh), o, d, t);
        RtHit h;
        h.t = t;
        h.instance = fh.w;
        h.prim = fh.z;
        h.bary = first_hit_bary(fh);
        Rng rng = rng_init(frame.size_seed.z, frame.size_seed.w, eye, pixel, 0x10000u + slot);
        ShadingMaterial m;
        vec3 L = path_radiance_first(o, d, true, h, eye_cone(e, t), rng, rays, m);
        if (drop_non_finite(L)) dropped++;   // (integrator.glsl)
        vec3 demod = demodulate(L, m);

        rad_cur[idx] = accumulate_record(rad_cur[idx], demod, accumulation_floor(ACCUM_MODE, pc.fixed_alpha, m));
        atomicAdd(pixel_stats[eye * npix() + pixel].y, 1u);
        shaded++;
    }
    count_add(C_SHADED, shaded);
    count_add(C_NONFINITE_SAMPLES, dropped);
    count_add(C_BOUNCE_RAYS, rays.bounce);
    count_add(C_SHADOW_RAYS, rays.shadow);
}
