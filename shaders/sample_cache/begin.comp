#version 460
// Frame start: this frame's importance bounds become the previous frame's,
// and the histogram, shade- and retrace-list lengths and counters are reset.
#include "sample_cache/common.glsl"
layout(local_size_x = 64) in;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < 2u) {
        state[i] = state[4u + i];
        state[2u + i] = state[6u + i];
        state[4u + i] = 0xFFFFFFFFu;
        state[6u + i] = 0u;
    }
    if (i == 0u) {
        state[8] = 0u;
        state[9] = 0u;
        state[14] = 0u;
    }
    if (i < 4u) state[10u + i] = 0u;   // shade_select.comp's per-eye pixel counts
    if (i < 2u) state[16u + i] = 0u;   // and its covered pixels
    if (i < 2u * HIST_M) hist[i] = 0u;
    if (i < 32u) counters[i] = 0u;
}
