#version 460
// Test kernel of the SPIR-V reflection (tests/shader_interface.rs): dst = 2 src
// over the first `sized.length()` elements, counting them in `count`. The
// qualifiers are left off on purpose: the reflection reads what the shader
// does, not what it says (`dst` and `count` are plain `buffer`s).
#include "interface/reflect_test.glsl"
layout(local_size_x = 64) in;
layout(set = SET_REFLECT_TEST, binding = B_REFLECT_TEST_SRC, std430) buffer Src { uint src[]; };
layout(set = SET_REFLECT_TEST, binding = B_REFLECT_TEST_DST, std430) buffer Dst { uint dst[]; };
layout(set = SET_REFLECT_TEST, binding = B_REFLECT_TEST_COUNT, std430) buffer Count { uint count; };
layout(set = SET_REFLECT_TEST, binding = B_REFLECT_TEST_SIZED, std430) readonly buffer Sized { uint sized[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < uint(sized.length())) {
        dst[i] = 2u * src[i];
        atomicAdd(count, 1u);
    }
}
