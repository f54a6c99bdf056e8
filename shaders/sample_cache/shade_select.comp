#version 460
// variant: SUBGROUP_OPS
// §3.5: adaptive shading's choice of the samples to shade, compacted into
// shade_list (uniform shading needs no choice: shade.comp shades each
// pixel's round-robin sample itself). One sample per
// 4×4 block as the base rate, plus samples by importance w = (1 + c_s)^−1:
// walking the histogram from the most important bucket down until the
// requested rate is reached; buckets above the threshold are all shaded, the
// one that straddles it by a weighted coin toss.
//
// Adaptive shading runs this shader twice (SELECT_PHASE):
// 0 (`shade.count`) counts this frame's shading candidates — every visible
//   sample after primary tracing, so the samples trace.comp created or
//   replaced this frame are in — into the importance histogram, and the
//   frame's w_min / w_max (used for the next frame's bucket bounds, §3.5);
// 1 (`shade.select`) chooses the threshold from that histogram and selects.
// The paper counts the histogram during reprojection; counted there it
// misses the new samples (frame 0: all of them) and keeps samples that
// retracing then finds occluded, so the threshold missed the requested rate
// by exactly those (3.8× at frame 0; issue 12 item 3). Counting after
// tracing makes the histogram hold exactly the samples this pass chooses from.
//
// Unshaded pixels (visible samples, none shaded yet, e.g. just disoccluded):
// within the rate they come first — their round-robin sample is shaded with
// probability p_u = min(1, budget left after the base rate / their count),
// before the histogram walk spends what remains on the other samples. All
// of those samples have c_s = 0, i.e. the top importance, so this only breaks
// the tie inside the top bucket in favour of covering pixels. Where the rate
// cannot cover all of them (p_u < 1: frame 0 or a large disocclusion at a
// rate below one path per pixel) the rest stay unshaded this frame and
// reconstruct.comp fills them from their neighbours rather than drawing them
// black: holding the requested rate is the point of adaptive shading.
#include "sample_cache/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(constant_id = SPEC_SAMPLE_CACHE_SELECT_PHASE) const uint SELECT_PHASE = 1u;

// state[] entries written by phase 0 (reset by begin.comp), per eye.
const uint S_UNSHADED = 10u;   // non-base pixels whose visible samples are all unshaded
const uint S_BASE = 12u;       // base-rate pixels with a visible sample
const uint S_COVERED = 16u;    // pixels with a visible surface sample (what uniform shading shades)

void push_shade(uint eye, uint slot, uint pixel) {
    uint i = list_reserve(8u, 1u);
    shade_list[i] = list_entry(eye, slot, pixel);
}

// state[i] += v (one atomic per subgroup with subgroup operations).
void state_add(uint i, uint v) {
#ifdef SUBGROUP_OPS
    uint total = subgroupAdd(v);
    if (subgroupElect() && total != 0u) atomicAdd(state[i], total);
#else
    if (v != 0u) atomicAdd(state[i], v);
#endif
}

// The workgroup's share of the importance histogram (§3.5), counted with
// shared-memory atomics and added to the global histogram once per bucket
// and workgroup at the end of phase 0.
shared uint wg_hist[HIST_M];

// The frame's importance extremes (the next frame's bucket bounds).
void bounds_add(uint eye, float w_min, float w_max) {
#ifdef SUBGROUP_OPS
    w_min = subgroupMin(w_min);
    w_max = subgroupMax(w_max);
    if (subgroupElect() && w_min <= w_max) {
        atomicMin(state[4u + eye], floatBitsToUint(w_min));
        atomicMax(state[6u + eye], floatBitsToUint(w_max));
    }
#else
    if (w_min <= w_max) {
        atomicMin(state[4u + eye], floatBitsToUint(w_min));
        atomicMax(state[6u + eye], floatBitsToUint(w_max));
    }
#endif
}

uint slot_bucket(uvec2 buckets, uint s) { return ((s < 8u ? buckets.x : buckets.y) >> (4u * (s & 7u))) & 15u; }

void select_pixel(uvec2 px, uint eye) {
    uvec2 size = frame_size();
    uint pixel = px.y * size.x + px.x;
    uint pm = eye * npix() + pixel;
    uint frame_index = frame.size_seed.w;
    uint vis, round_robin;
    bool base, unshaded;
    uvec2 buckets = uvec2(0u);
    if (SELECT_PHASE == 0u) {
        vis = surface_slots(eye, pixel, vis_bits(mask_cur[pm]));
        uint n = bitCount(vis);
        // A base pixel shades round robin over its visits (common.glsl
        // sparse_base_pixel), an unshaded one over frames.
        uint visit;
        base = n > 0u && sparse_base_pixel(px, frame_index, eye, visit);
        round_robin = n > 0u ? nth_set_bit(vis, (base ? visit : frame_index) % n) : 0u;
        float w_lo, w_hi;
        importance_bounds(eye, w_lo, w_hi);
        // One read of each visible sample's record: which are shaded, their
        // buckets (4 bits per slot, M = 13 ≤ 16) and the importance extremes.
        uint shaded_bits = 0u;
        float f_min = 1.0, f_max = 0.0;
        uint bits = vis;
        while (bits != 0u) {
            uint s = uint(findLSB(bits));
            bits &= bits - 1u;
            float c = rad_cur[slot_index(eye, s, pixel)].w;
            if (c > 0.0) shaded_bits |= 1u << s;
            float w = importance(c);
            f_min = min(f_min, w);
            f_max = max(f_max, w);
            uint b = importance_bucket(w, w_lo, w_hi);
            if (s < 8u) buckets.x |= b << (4u * s); else buckets.y |= b << (4u * (s - 8u));
        }
        unshaded = n > 0u && !base && shaded_bits == 0u;
        // Phase 1 reads this analysis back instead of the cache. pixel_action
        // (select.comp's decisions) has been consumed by trace.comp by now.
        pixel_action[pm] = uvec4(buckets, vis, round_robin | (base ? 0x100u : 0u) | (unshaded ? 0x200u : 0u));
        // The round-robin sample of base and unshaded pixels is chosen
        // outside the histogram (it is not counted in it).
        uint first = (base || unshaded) ? 1u << round_robin : 0u;
        state_add(S_BASE + eye, base ? 1u : 0u);
        state_add(S_UNSHADED + eye, unshaded ? 1u : 0u);
        state_add(S_COVERED + eye, n > 0u ? 1u : 0u);
        bits = vis & ~first;
        while (bits != 0u) {
            uint s = uint(findLSB(bits));
            bits &= bits - 1u;
            atomicAdd(wg_hist[slot_bucket(buckets, s)], 1u);
        }
        bounds_add(eye, f_min, f_max);
        return;
    }
    uvec4 a = pixel_action[pm];
    buckets = a.xy;
    vis = a.z;
    round_robin = a.w & 31u;
    base = (a.w & 0x100u) != 0u;
    unshaded = (a.w & 0x200u) != 0u;
    uint n = bitCount(vis);
    uint first = (base || unshaded) ? 1u << round_robin : 0u;

    // Budget per eye, spent on the base rate, then the unshaded pixels, then
    // the histogram's most important samples: rate × the pixels uniform
    // shading would shade (one path per pixel with a visible surface
    // sample), so that `--shading-rate 0.7` is Fig. 14's "70 % of the
    // shading rate used for uniform shading". Until session 50 it was
    // rate × all pixels, background included: on a view with much sky 0.7
    // shaded about as much as uniform (an audit of the experiments).
    float budget = pc.shading_rate * float(state[S_COVERED + eye]);
    float left = max(budget - float(state[S_BASE + eye]), 0.0);
    float n_unshaded = float(state[S_UNSHADED + eye]);
    float p_unshaded = n_unshaded > 0.0 ? min(left / n_unshaded, 1.0) : 0.0;
    float requested = max(left - n_unshaded, 0.0);
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
    if (n == 0u) return;
    Rng r = rng_init(frame.size_seed.z, frame_index, eye, pixel, 0x5EED0003u);
    float coin_unshaded = rng_next(r);
    if (base || (unshaded && coin_unshaded < p_unshaded)) push_shade(eye, round_robin, pixel);
    uint bits = vis & ~first;
    while (bits != 0u) {
        uint s = uint(findLSB(bits));
        bits &= bits - 1u;
        float coin = rng_next(r);
        uint b = slot_bucket(buckets, s);
        bool take = straddle < 0 || int(b) > straddle || (int(b) == straddle && coin < p_straddle);
        if (take) push_shade(eye, s, pixel);
    }
}

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    bool inside = all(lessThan(px, frame_size()));
    if (SELECT_PHASE == 1u) {   // (a specialization constant: uniform)
        if (inside) select_pixel(px, eye);
        return;
    }
    uint lid = gl_LocalInvocationIndex;
    if (lid < HIST_M) wg_hist[lid] = 0u;
    barrier();
    if (inside) select_pixel(px, eye);
    barrier();
    if (lid < HIST_M && wg_hist[lid] != 0u) atomicAdd(hist[eye * HIST_M + lid], wg_hist[lid]);
}
