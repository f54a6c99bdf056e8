#version 460
// Test kernel: H0, H1, the 8 probe slots of each input key and the texel
// (lod.glsl) of a uv made from its bits, compared bit for bit with
// src/materials/memo/table.rs and lod.rs (tests/memo.rs).
#include "interface/memo_hash_test.glsl"
layout(local_size_x = 64) in;
layout(set = SET_MEMO_HASH_TEST, binding = B_MEMO_HASH_TEST_KEYS, std430) readonly buffer Keys { uvec4 keys[]; };   // graph, level, qu, qv
layout(set = SET_MEMO_HASH_TEST, binding = B_MEMO_HASH_TEST_OUTS, std430) writeonly buffer Out { uint outs[]; };   // 12 words per key
layout(push_constant) uniform Push { MEMO_HASH_TEST_PUSH } pc;
#define MEMO_HASHES_ONLY
#include "memo/table.glsl"
#include "memo/lod.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    uvec4 k = keys[i];
    ivec2 q = ivec2(k.zw);
    uint h0 = memo_h0(k.x, int(k.y), q);
    outs[12u * i] = h0;
    outs[12u * i + 1u] = memo_h1(k.x, int(k.y), q);
    for (uint p = 0u; p < 8u; ++p) outs[12u * i + 2u + p] = memo_slot(h0, p, pc.capacity, pc.probe);
    vec2 uv = vec2(q >> 12) * (1.0 / 1024.0);
    ivec2 t = memo_quantise(uv, clamp(int(k.y), MEMO_MIN_LEVEL, MEMO_MAX_LEVEL));
    outs[12u * i + 10u] = uint(t.x);
    outs[12u * i + 11u] = uint(t.y);
}
