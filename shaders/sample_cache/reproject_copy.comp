#version 460
// Second step of the two-pass reprojection (§3.1's race-free variant): per
// target slot, copy the sample whose key won reproject.comp's atomicMax —
// a visible source over an invisible one, independent of thread order —
// and rebuild the pixel's mask from the winning keys, so each slot's data,
// visibility and occupancy come from the same source sample.
#include "sample_cache/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint pixel = px.y * size.x + px.x;
    uint pm = eye * npix() + pixel;
    uint occ = occ_bits(mask_cur[pm]);
    uint m = 0u;
    while (occ != 0u) {
        uint s = uint(findLSB(occ));
        occ &= occ - 1u;
        uint dst = slot_index(eye, s, pixel);
        uint key = target_src[dst];
        if (key == 0u) continue;   // (every successful reservation writes a key)
        uint local = (key & 0x7FFFFFFFu) - 1u;   // s·npix + source pixel
        uint src = eye * N_SLOTS * npix() + local;
        uvec4 fh = fh_prev[src];
        if (first_hit_is_background(fh)) {
            // Its new place in the pixel (first_hit.glsl background_at),
            // from the projection pass 1 made (camera.glsl
            // background_target), relative to this pixel and clamped into
            // it should the recomputed q differ by an ulp.
            uint sp = local % npix();
            vec2 at = vec2(sp % size.x, sp / size.x) + background_subpixel(fh);
            vec2 q;
            background_target(frame.eyes[eye], frame.prev_eyes[eye], at, background_direction(fh), q);
            fh = background_at(fh, q - vec2(px));
        }
        fh_cur[dst] = fh;
        if (SHADING_STORAGE) {
            rad_cur[dst] = rad_prev[src];
            vec3 o, d;
            float t = uintBitsToFloat(0x7F800000u);   // a background sample: ∞
            if (!first_hit_is_background(fh)) eye_ray_to(frame.eyes[eye], hit_position(fh), o, d, t);
            slot_depth[dst] = t;
        }
        m |= (1u << s) | ((key >> 31) << (s + N_SLOTS));
    }
    mask_cur[pm] = m;
}
