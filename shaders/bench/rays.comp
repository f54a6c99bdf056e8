#version 460
// `stereocache bench rays`: mode 0 traces pixel-centre primary rays and keeps
// their hits; mode 1 traces one cosine-distributed (diffuse-bounce) ray from
// each kept hit. Each mode is its own pass, so the timestamps give rays/s.
#include "common/rt.glsl"
#include "common/random.glsl"
#include "common/bsdf.glsl"
#include "common/camera.glsl"
#include "interface/bench_rays.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(set = SET_BENCH_RAYS, binding = B_BENCH_RAYS_HITS, std430) buffer Hits { vec4 hits[]; };        // position, 1 = hit
layout(set = SET_BENCH_RAYS, binding = B_BENCH_RAYS_NORMALS, std430) buffer Normals { vec4 normals[]; };
layout(set = SET_BENCH_RAYS, binding = B_BENCH_RAYS_COUNTERS, std430) buffer Counters { uint counters[]; }; // BenchRaysCounter
layout(push_constant) uniform Push { BENCH_RAYS_PUSH } pc;

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint idx = (eye * size.y + px.y) * size.x + px.x;
    EyeGpu e = frame.eyes[eye];
    if (pc.mode == 0u) {
        vec3 d = eye_ray_dir(e, vec2(px) + 0.5);
        RtHit h;
        bool hit = rt_closest_hit(eye_ray_origin(e, vec2(px) + 0.5), d, 0.0, 1e30, h);
        if (hit) {
            Surface s = surface_at(h.instance, h.prim, h.bary, d);
            hits[idx] = vec4(s.p, 1.0);
            normals[idx] = vec4(s.ng, 0.0);
        } else {
            hits[idx] = vec4(0.0);
        }
        atomicAdd(counters[C_BENCH_RAYS_PRIMARY_RAYS], 1u);
    } else {
        vec4 p = hits[idx];
        if (p.w == 0.0) return;
        vec3 n = normals[idx].xyz;
        Rng rng = rng_init(frame.size_seed.z, frame.size_seed.w, eye, px.y * size.x + px.x, 0u);
        vec3 d = to_world(frame_from(n), cosine_hemisphere(rng_next2(rng)));
        RtHit h;
        bool hit = rt_closest_hit(offset_ray(p.xyz, n), d, 0.0, 1e30, h);
        atomicAdd(counters[C_BENCH_RAYS_BOUNCE_RAYS], 1u);
        if (hit) atomicAdd(counters[C_BENCH_RAYS_HITS], 1u);
    }
}
