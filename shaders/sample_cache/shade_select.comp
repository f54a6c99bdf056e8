#version 460
// variant: SUBGROUP_OPS
// §3.3/§3.5: choose the samples to shade and compact them into shade_list.
// Uniform: one visible sample per pixel, round robin. Adaptive: one sample per
// 4×4 block as the base rate, plus samples by importance w = (1 + c_s)^−1:
// walking the histogram (counted during reprojection) from the most
// important bucket down until the requested rate is reached; buckets above the
// threshold are all shaded, the one that straddles it by a weighted coin toss.
#include "sample_cache/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void push_shade(uint eye, uint slot, uint pixel) {
    uint i = list_reserve(8u, 1u);
    shade_list[i] = list_entry(eye, slot, pixel);
}

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint pixel = px.y * size.x + px.x;
    // Only surface samples are shaded (background samples: reconstruct.comp).
    uint vis = surface_slots(eye, pixel, vis_bits(mask_cur[eye * npix() + pixel]));
    uint n = bitCount(vis);
    if (n == 0u) return;
    uint frame_index = frame.size_seed.w;
    uint round_robin = nth_set_bit(vis, frame_index % n);
    if (SHADING_MODE == 0u) {
        push_shade(eye, round_robin, pixel);
        return;
    }
    // Adaptive: base rate.
    bool base = is_sparse_base_pixel(px, frame_index, eye);
    if (base) push_shade(eye, round_robin, pixel);
    // Threshold from the histogram: requested count beyond the base rate.
    float requested = max(pc.shading_rate * float(npix()) - float(npix()) / 16.0, 0.0);
    float above = 0.0;
    int straddle = -1;
    float p_straddle = 0.0;
    for (int b = int(HIST_M) - 1; b >= 0; --b) {
        float c = float(hist[eye * HIST_M + uint(b)]);
        if (above + c >= requested) {
            straddle = b;
            p_straddle = c > 0.0 ? (requested - above) / c : 0.0;
            break;
        }
        above += c;
    }
    float w_lo, w_hi;
    importance_bounds(eye, w_lo, w_hi);
    Rng r = rng_init(frame.size_seed.z, frame_index, eye, pixel, 0x5EED0003u);
    uint bits = vis;
    while (bits != 0u) {
        uint s = uint(findLSB(bits));
        bits &= bits - 1u;
        float coin = rng_next(r);
        if (base && s == round_robin) continue;
        uint b = importance_bucket(importance(rad_cur[slot_index(eye, s, pixel)].w), w_lo, w_hi);
        bool take = straddle < 0 || int(b) > straddle || (int(b) == straddle && coin < p_straddle);
        if (take) push_shade(eye, s, pixel);
    }
}
