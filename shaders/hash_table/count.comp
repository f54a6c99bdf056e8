#version 460
// Live entries (touched within the last `stale` frames) for the counters.
#include "hash_table/table.glsl"
layout(local_size_x = 256) in;
shared uint live;

void main() {
    if (gl_LocalInvocationIndex == 0u) live = 0u;
    barrier();
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 256u + gl_GlobalInvocationID.x;  // 2D grid of groups
    if (i < pc.capacity && !hc_replaceable(keys[i])) atomicAdd(live, 1u);
    barrier();
    if (gl_LocalInvocationIndex == 0u && live > 0u) atomicAdd(counters[C_HT_LIVE], live);
}
