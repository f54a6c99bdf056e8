#version 460
// Shading: one sample per pixel and frame, round robin over the pixel's
// occupied cells (frame index mod count, like the sample cache's uniform
// shading). One path through the stored first hit with the shared
// integrator, accumulated as the sample cache accumulates (`--accumulation`:
// the running mean by default; common/accumulation.glsl), so both baselines
// of Fig. 10 average alike; the record holds the radiance itself, not
// demodulated, as the sample cache's since session 58 (its shade.comp says
// why that is the same colour; reconstruct.comp evaluates no material per
// sample).
#include "isrt/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
#ifdef SC_MATERIAL_MEMO
    sc_memo_eye = eye;
#endif
    if (any(greaterThanEqual(px, frame_size()))) return;
    uint occupied = 0u;
    for (uint k = 0u; k < M * M; ++k) {
        if (first_hit_valid(fh_cur[cell_index(eye, px * M + uvec2(k % M, k / M))])) occupied |= 1u << k;
    }
    uint n = bitCount(occupied);
    if (n == 0u) return;
    uint pick = frame.size_seed.w % n;
    for (uint i = 0u; i < pick; ++i) occupied &= occupied - 1u;
    uint k = uint(findLSB(occupied));
    uint idx = cell_index(eye, px * M + uvec2(k % M, k / M));
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
    Rng rng = rng_init(frame.size_seed.z, frame.size_seed.w, eye, px.y * frame_size().x + px.x, 0x15A70002u + k);
    RayCounts rays = RayCounts(0u, 0u);
    ShadingMaterial m;
    vec3 L = path_radiance_first(o, d, true, h, eye_cone(e, t), rng, rays, m);
    if (drop_non_finite(L)) atomicAdd(counters[C_ISRT_NONFINITE_SAMPLES], 1u);   // (integrator.glsl)
    // The sample cache's accumulation (common/accumulation.glsl): until
    // session 50 always appendix C's α_min floor wherever the BSDF has a
    // specular lobe, whatever `--accumulation` said.
    rad_cur[idx] = accumulate_record(rad_cur[idx], L, accumulation_floor(pc.accum_mode, pc.fixed_alpha, m));
    atomicAdd(counters[C_ISRT_SHADED], 1u);
    atomicAdd(counters[C_ISRT_BOUNCE_RAYS], rays.bounce);
    atomicAdd(counters[C_ISRT_SHADOW_RAYS], rays.shadow);
}
