#version 460
// Every sample is retraced every frame: a ray from the eye to the stored hit,
// as in the sample cache's retrace (sample_cache/retrace.comp): kept when the
// closest hit lies within ε0·t of it, dropped when a closer hit is found,
// kept when the ray finds neither (no hit near the stored one: precision at
// triangle edges; §3.2 of the sample-cache paper drops a sample only behind
// a closer hit). A background sample (first_hit.glsl) is retraced along its
// direction and kept while that ray hits nothing. Every empty cell is then
// filled with a new sample through a uniformly random point of that cell; a
// miss stores a background sample, which the reconstruction counts with the
// environment's radiance (the cell's share of the pixel's coverage).
#include "isrt/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 g = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(g, grid_size()))) return;
    uint idx = cell_index(eye, g);
    EyeGpu e = frame.eyes[eye];
    vec3 o = e.pos_tanx.xyz;
    uvec4 fh = fh_cur[idx];
    if (first_hit_is_background(fh)) {
        atomicAdd(counters[C_ISRT_RETRACE_RAYS], 1u);
        if (!rt_occluded(o, background_direction(fh), 0.0, 1e30)) {
            atomicAdd(counters[C_ISRT_BACKGROUND], 1u);
            return;
        }
        atomicAdd(counters[C_ISRT_RETRACE_LOST], 1u);
    } else if (first_hit_valid(fh)) {
        vec3 wp = hit_position(fh);
        vec3 d = wp - o;
        float t = length(d);
        d /= max(t, 1e-30);
        RtHit h;
        bool hit = rt_closest_hit(o, d, 0.0, t * (1.0 + 2.0 * pc.eps0), h);
        atomicAdd(counters[C_ISRT_RETRACE_RAYS], 1u);
        if (!hit || h.t >= t - pc.eps0 * t) {
            atomicAdd(counters[C_ISRT_SAMPLES], 1u);
            return;
        }
        atomicAdd(counters[C_ISRT_RETRACE_LOST], 1u);
    }
    Rng r = rng_init(frame.size_seed.z, frame.size_seed.w, eye, g.y * grid_size().x + g.x, 0x15A70001u);
    vec2 sub = (vec2(g) + rng_next2(r)) / float(M);
    vec3 d = eye_ray_dir(e, sub);
    RtHit h;
    bool hit = rt_closest_hit(o, d, 0.0, 1e30, h);
    atomicAdd(counters[C_ISRT_NEW_RAYS], 1u);
    if (hit) {
        fh_cur[idx] = encode_first_hit(h.bary, h.instance, h.prim, instance_material(h.instance));
        atomicAdd(counters[C_ISRT_NEW_HITS], 1u);
        atomicAdd(counters[C_ISRT_SAMPLES], 1u);
    } else {
        fh_cur[idx] = encode_background(d);
        atomicAdd(counters[C_ISRT_BACKGROUND], 1u);
    }
    rad_cur[idx] = vec4(0.0);
}
