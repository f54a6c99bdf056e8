#version 460
// Second step of the two-pass reprojection: copy every reserved slot's data
// from the address written by the first step (race-free variant of §3.1).
#include "sample_cache/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint pixel = px.y * size.x + px.x;
    uint occ = occ_bits(mask_cur[eye * npix() + pixel]);
    while (occ != 0u) {
        uint s = uint(findLSB(occ));
        occ &= occ - 1u;
        uint dst = slot_index(eye, s, pixel);
        uint src = target_src[dst];
        if (src != 0u) {
            fh_cur[dst] = fh_prev[src - 1u];
            if (SHADING_STORAGE) rad_cur[dst] = rad_prev[src - 1u];
        }
    }
}
