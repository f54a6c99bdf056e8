#version 460
// variant: SUBGROUP_OPS
// Shades samples: one path per sample from the eye through its stored first
// hit (the integrator every method shares), accumulated as an exponential
// average whose effective count c_s the record carries
// (common/accumulation.glsl `accumulate_record`). The blend factor is the running mean's
// 1/(c_s + 1) (ACCUM_MODE 0, the default: §4–5's radiance cache), floored
// at the fixed α of `--accumulation fixed:A` for every sample (ACCUM_MODE 1,
// §5.2's α = 0.1) or at appendix C's α_min = (1 − α_GGX)·0.5 + α_GGX·0.1 for
// every sample whose BSDF has a specular lobe (ACCUM_MODE 2,
// `--accumulation alpha-min`). Flooring rather than replacing keeps the start exact: the first
// shading of a sample (c_s = 0) takes its path as is, and the average only
// becomes exponential once 1/(c_s + 1) falls below the floor.
//
// The record holds the radiance itself, not demodulated. The paper stores
// it demodulated and multiplies the albedo back in reconstruction ("the
// radiance can be stored demodulated", §3.3); a sample is one fixed surface
// point, whose demodulation factor and emission do not change, so factor ×
// the mean of (L − emission) / factor + emission is the mean of L: the
// same colour (up to the texture filter's level of detail, taken at
// shading time), without a surface and material evaluation per visible
// sample and frame in reconstruct.comp (until session 58; the Cornell
// frame 1.61 → 1.53 times the 1 spp frame's on llvmpipe, docs/PERFORMANCE.md
// "Session 58"). Where a pixel
// borrows its neighbours' radiance (reconstruct.comp `unshaded_fallback`)
// it demodulates their records by their own materials there.
//
// Which samples (§3.3, §3.5):
// - uniform shading (SHADING_MODE 0, the paper's default: "one sample for
//   each pixel in a round-robin fashion"): one invocation per pixel (x the
//   pixel, y the eye) shades the pixel's visible surface sample number
//   frame mod n (`uniform_shading_slot`). Until session 58 a selection pass
//   (shade_select.comp) wrote those samples into a compacted list first and
//   this pass ran over the list: the same samples (the images are
//   bit-identical), but a pass more, and a dearer shade pass; on llvmpipe
//   the Cornell frame went from 1.72 to 1.61 times the 1 spp frame's
//   (docs/PERFORMANCE.md "Session 58").
// - adaptive shading (SHADING_MODE 1): the compacted list shade_select.comp
//   fills, over its length (indirect dispatch).
#include "sample_cache/common.glsl"
layout(local_size_x = 64) in;

// The sample uniform shading shades in `pixel` of `eye` this frame: its
// visible surface samples round robin by frame index; N_SLOTS where it has
// none (background samples are not shaded).
uint uniform_shading_slot(uint eye, uint pixel) {
    uint vis = surface_slots(eye, pixel, vis_bits(mask_cur[eye * npix() + pixel]));
    uint n = bitCount(vis);
    return n == 0u ? N_SLOTS : nth_set_bit(vis, frame.size_seed.w % n);
}

// Shades sample `slot` of `pixel` in `eye`; true when its path came out
// non-finite (dropped, integrator.glsl).
bool shade_sample(uint eye, uint slot, uint pixel, inout RayCounts rays) {
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
    bool dropped = drop_non_finite(L);
    rad_cur[idx] = accumulate_record(rad_cur[idx], L, accumulation_floor(ACCUM_MODE, pc.fixed_alpha, m));
    atomicAdd(pixel_stats[eye * npix() + pixel].y, 1u);
    return dropped;
}

void main() {
    uint shaded = 0u, dropped = 0u;
    RayCounts rays = RayCounts(0u, 0u);
    // Grid-stride either way: the dispatch is capped at 65535 groups.
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    if (SHADING_MODE == 0u) {
        uint eye = gl_GlobalInvocationID.y;
        for (uint pixel = gl_GlobalInvocationID.x; pixel < npix(); pixel += stride) {
            uint slot = uniform_shading_slot(eye, pixel);
            if (slot == N_SLOTS) continue;
            if (shade_sample(eye, slot, pixel, rays)) dropped++;
            shaded++;
        }
    } else {
        // The list's length: the indirect dispatch covers it (indirect_args.comp),
        // not its capacity of (N + 1) entries per pixel, whose mostly empty
        // workgroups cost time on CPU drivers (issue 6).
        uint count = state[8];
        for (uint i = gl_GlobalInvocationID.x; i < count; i += stride) {
            uint eye, slot, pixel;
            list_decode(shade_list[i], eye, slot, pixel);
            if (shade_sample(eye, slot, pixel, rays)) dropped++;
            shaded++;
        }
    }
    count_add(C_SHADED, shaded);
    count_add(C_NONFINITE_SAMPLES, dropped);
    count_add(C_BOUNCE_RAYS, rays.bounce);
    count_add(C_SHADOW_RAYS, rays.shadow);
}
