#version 460
// Jittered path-traced samples accumulated into `accum` (frame.misc.y samples
// per dispatch, numbered from sample_base so runs are reproducible). With
// fixed_jitter != 0 every sample goes through the sub-pixel position `jitter`
// (the Halton sequence of the taa method) instead of a random one.
#include "common/integrator.glsl"
#include "reference/bindings.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(push_constant) uniform Push { REFERENCE_TRACE_PUSH } pc;

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
#ifdef SC_MATERIAL_MEMO
    sc_memo_eye = eye;
#endif
    if (any(greaterThanEqual(px, size))) return;
    uint idx = (eye * size.y + px.y) * size.x + px.x;
    EyeGpu e = frame.eyes[eye];
    vec3 sum = vec3(0.0);
    RayCounts rays = RayCounts(0u, 0u);
    uint dropped = 0u;
    for (uint k = 0u; k < pc.sample_count; ++k) {
        uint sample_index = pc.sample_base + k;
        Rng rng = rng_init(frame.size_seed.z, frame.size_seed.w, eye, px.y * size.x + px.x, sample_index);
        vec2 jitter = rng_next2(rng);
        if (pc.fixed_jitter != 0u) jitter = pc.jitter;
        vec3 o = eye_ray_origin(e, vec2(px) + jitter);
        vec3 d = eye_ray_dir(e, vec2(px) + jitter);
        RtHit h;
        bool hit = rt_closest_hit(o, d, 0.0, 1e30, h);
        vec3 L = path_radiance(o, d, hit, h, hit ? eye_cone(e, h.t) : vec2(0.0), rng, rays);
        if (drop_non_finite(L)) dropped++;   // (integrator.glsl)
        sum += L;
    }
    accum[idx] += vec4(sum, float(pc.sample_count));
    atomicAdd(counters[C_REFERENCE_PRIMARY_RAYS], pc.sample_count);
    atomicAdd(counters[C_REFERENCE_BOUNCE_RAYS], rays.bounce);
    atomicAdd(counters[C_REFERENCE_SHADOW_RAYS], rays.shadow);
    if (dropped > 0u) atomicAdd(counters[C_REFERENCE_NONFINITE_SAMPLES], dropped);
}
