#version 460
// Test kernel: common/packing.glsl's first-hit encoding of each input
// (barycentrics as float bits, material, primitive; the instance is the
// lane's index) and its decoding, compared with the quantisation's known
// bounds in tests/stability.rs.
#include "interface/packing_test.glsl"
#include "common/packing.glsl"
layout(local_size_x = 64) in;
layout(set = SET_PACKING_TEST, binding = B_PACKING_TEST_KEYS, std430) readonly buffer Keys { uvec4 keys[]; };   // bits(u), bits(v), material, primitive
layout(set = SET_PACKING_TEST, binding = B_PACKING_TEST_OUTS, std430) writeonly buffer Out { uint outs[]; };    // 8 words per input
layout(push_constant) uniform Push { PACKING_TEST_PUSH } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    uvec4 k = keys[i];
    uvec4 fh = encode_first_hit(uintBitsToFloat(k.xy), i, k.w, k.z);
    for (uint j = 0u; j < 4u; ++j) outs[8u * i + j] = fh[j];
    vec2 b = first_hit_bary(fh);
    outs[8u * i + 4u] = floatBitsToUint(b.x);
    outs[8u * i + 5u] = floatBitsToUint(b.y);
    outs[8u * i + 6u] = first_hit_material(fh);
    outs[8u * i + 7u] = first_hit_valid(fh) ? 1u : 0u;
}
