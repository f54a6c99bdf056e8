// First hits in 128 bits (paper Listing 1, with the 24-bit reading of the issue):
// x = 24-bit barycentric u | material bits 0..7 << 24
// y = 24-bit barycentric v | material bits 8..15 << 24
// z = primitive index, w = instance index; w = NO_HIT marks a miss.
#ifndef PACKING_GLSL
#define PACKING_GLSL
const uint NO_HIT = 0xFFFFFFFFu;
const float BARY_SCALE = 16777215.0; // 2^24 - 1

uvec4 encode_first_hit(vec2 bary, uint instance, uint prim, uint mat) {
    uvec2 b = uvec2(round(clamp(bary, 0.0, 1.0) * BARY_SCALE));
    return uvec4((b.x & 0xFFFFFFu) | ((mat & 0xFFu) << 24),
                 (b.y & 0xFFFFFFu) | ((mat & 0xFF00u) << 16),
                 prim, instance);
}

vec2 first_hit_bary(uvec4 fh) { return vec2(fh.x & 0xFFFFFFu, fh.y & 0xFFFFFFu) / BARY_SCALE; }
uint first_hit_material(uvec4 fh) { return (fh.x >> 24) | ((fh.y >> 24) << 8); }
bool first_hit_valid(uvec4 fh) { return fh.w != NO_HIT; }
#endif
