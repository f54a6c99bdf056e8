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
    uint src = eye * cells_per_eye() + uint(c & 0xFFFFFFFFul);
    fh_cur[dst] = fh_prev[src];
    rad_cur[dst] = rad_prev[src];
    atomicAdd(counters[C_ISRT_KEPT], 1u);
}
