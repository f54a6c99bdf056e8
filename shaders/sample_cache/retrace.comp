#version 460
// variant: SUBGROUP_OPS
// §3.2 step 3, first half: retrace the slots select.comp listed, with rays
// from the eye (an orthographic eye: from the image plane) to the stored hit; a sample is visible when the closest hit
// lies within ε0·t of it and occluded when a closer hit is found; a ray that
// finds neither leaves the slot's visibility as it was (trace.comp). For a
// sample that is visible already only "occluded" changes anything, so it
// gets an occlusion query that ends at the first hit before t − ε0·t (the
// same answer; an invisible one needs the closest hit to become visible). A
// background sample is retraced along its direction: visible when the ray
// hits nothing, occluded otherwise. Run over the compacted list so every lane traces
// (per pixel, only edge and base-rate pixels retrace under adaptive
// retracing, and a per-pixel dispatch left most lanes idle, issue 6).
#include "sample_cache/common.glsl"
layout(local_size_x = 64) in;

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint count = retrace_list_length();
    uint rays = 0u, bg_rays = 0u, occlusion_rays = 0u, occluded = 0u;
    for (uint i = gl_GlobalInvocationID.x; i < count; i += stride) {
        uint eye, s, pixel;
        list_decode(retrace_list[retrace_list_index(i)], eye, s, pixel);
        EyeGpu e = frame.eyes[eye];
        uvec4 fh = fh_cur[slot_index(eye, s, pixel)];
        RtHit h;
        uint bit = 0u;
        if (first_hit_is_background(fh)) {
            // Any hit occludes it: an occlusion query suffices.
            // (Orthographic: from the ray's own place in the pixel.)
            vec2 at = vec2(pixel % frame_size().x, pixel / frame_size().x) + background_subpixel(fh);
            bit = rt_occluded(eye_ray_origin(e, at), background_direction(fh), 0.0, 1e30) ? 1u << (s + N_SLOTS) : 1u << s;
            bg_rays++;
        } else {
            vec3 o, d;
            float t;
            eye_ray_to(e, hit_position(fh), o, d, t);
            float tol = pc.eps0 * eye_tolerance_scale(e, t);   // ε0·t (orthographic: ε0·ymag)
            bool was_visible = ((mask_cur[eye * npix() + pixel] >> (s + N_SLOTS)) & 1u) != 0u;
            if (was_visible) {
                occlusion_rays++;
                // A visible sample keeps its bit whether the ray finds it
                // (within ε0) or nothing near it; only a closer hit changes
                // it. The closest-hit rule below marks it occluded exactly
                // when some hit lies before t − ε0·t, so an occlusion query
                // (first hit ends it) over [0, t − ε0·t) gives the same
                // answer and stops at the first occluder.
                if (rt_occluded(o, d, 0.0, t - tol)) bit = 1u << (s + N_SLOTS);
            } else if (rt_closest_hit(o, d, 0.0, t + 2.0 * tol, h)) {
                // An invisible sample becomes visible again when the closest
                // hit is within ε0·t of it: that needs the closest hit.
                if (abs(h.t - t) <= tol) bit = 1u << s;
                else if (h.t < t) bit = 1u << (s + N_SLOTS);
            }
        }
        rays++;
        if ((bit >> N_SLOTS) != 0u) occluded++;
        if (bit != 0u) atomicOr(retrace_found[eye * npix() + pixel], bit);
    }
    count_add(C_RETRACE_RAYS, rays);
    count_add(C_RETRACE_BACKGROUND, bg_rays);
    count_add(C_RETRACE_OCCLUSION, occlusion_rays);
    count_add(C_RETRACE_OCCLUDED, occluded);
}
