#version 460
// Test kernel: index hash, checksum and the first 16 probe slots of each
// input key, compared bit for bit with src/methods/hash_table/hash.rs.
#include "hash_table/hash.glsl"
#include "interface/hash_test.glsl"
layout(local_size_x = 64) in;
layout(set = SET_HASH_TEST, binding = B_HASH_TEST_KEYS, std430) readonly buffer Keys { ivec4 keys[]; };   // x, y, z, meta
layout(set = SET_HASH_TEST, binding = B_HASH_TEST_OUTS, std430) writeonly buffer Out { uint outs[]; };    // 18 words per key
layout(push_constant) uniform Push { HASH_TEST_PUSH } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    ivec4 k = keys[i];
    uint meta = uint(k.w);
    uint h = hc_index_hash(k.xyz, meta);
    outs[18u * i] = h;
    outs[18u * i + 1u] = hc_checksum(k.xyz, meta);
    for (uint p = 0u; p < 16u; ++p)
        outs[18u * i + 2u + p] = hc_probe_slot(h, hc_meta_local(meta), hc_meta_tiles(meta), p, pc.capacity);
}
