#version 460
// Resolves the reservations: one thread per cell of the current frame copies
// the winning sample (first hit and radiance record) or marks the cell empty.
#include "isrt/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 g = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(g, grid_size()))) return;
    uint dst = cell_index(eye, g);
    uint64_t c = claim[dst];
    if (c == 0xFFFFFFFFFFFFFFFFul) {
        fh_cur[dst] = uvec4(0u, 0u, 0u, NO_HIT);
        rad_cur[dst] = vec4(0.0);
        return;
    }
    uint local = uint(c & 0xFFFFFFFFul);
    uint src = eye * cells_per_eye() + local;
    uvec4 fh = fh_prev[src];
    if (first_hit_is_background(fh)) {
        // Its new place in its new pixel (first_hit.glsl background_at),
        // from the projection reproject.comp made (camera.glsl
        // background_target), clamped into the pixel should the recomputed
        // q differ by an ulp.
        uvec2 sg = uvec2(local % grid_size().x, local / grid_size().x);
        vec2 q;
        background_target(frame.eyes[eye], frame.prev_eyes[eye], vec2(sg / M) + isrt_background_place(fh, sg), background_direction(fh), q);
        fh = background_at(fh, q - vec2(g / M));
    }
    fh_cur[dst] = fh;
    rad_cur[dst] = rad_prev[src];
    atomicAdd(counters[C_ISRT_KEPT], 1u);
}
