#version 460
// variant: SUBGROUP_OPS
// §3.2 step 3, first half: retrace the slots select.comp listed, with rays
// from the eye to the stored hit; a sample is visible when the closest hit
// lies within ε0·t of it and occluded when a closer hit is found; a ray that
// finds neither leaves the slot's visibility as it was (trace.comp). A
// background sample is retraced along its direction: visible when the ray
// hits nothing, occluded otherwise. Run over the compacted list so every lane traces
// (per pixel, only edge and base-rate pixels retrace under adaptive
// retracing, and a per-pixel dispatch left most lanes idle, issue 6).
#include "sample_cache/common.glsl"
layout(local_size_x = 64) in;

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint count = state[9];
    uint rays = 0u;
    for (uint i = gl_GlobalInvocationID.x; i < count; i += stride) {
        uint eye, s, pixel;
        list_decode(retrace_list[i], eye, s, pixel);
        vec3 o = frame.eyes[eye].pos_tanx.xyz;
        uvec4 fh = fh_cur[slot_index(eye, s, pixel)];
        RtHit h;
        uint bit = 0u;
        if (first_hit_is_background(fh)) {
            // Any hit occludes it: an occlusion query suffices.
            bit = rt_occluded(o, background_direction(fh), 0.0, 1e30) ? 1u << (s + N_SLOTS) : 1u << s;
        } else {
            vec3 d = hit_position(fh) - o;
            float t = length(d);
            d /= max(t, 1e-30);
            if (rt_closest_hit(o, d, 0.0, t * (1.0 + 2.0 * pc.eps0), h)) {
                if (abs(h.t - t) <= pc.eps0 * t) bit = 1u << s;
                else if (h.t < t) bit = 1u << (s + N_SLOTS);
            }
        }
        rays++;
        if (bit != 0u) atomicOr(retrace_found[eye * npix() + pixel], bit);
    }
    count_add(C_RETRACE_RAYS, rays);
}
