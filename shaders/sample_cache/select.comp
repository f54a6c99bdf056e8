#version 460
// variant: SUBGROUP_OPS
// §3.2 step 1–2 decisions, from the reprojected cache (read only, so the
// result does not depend on thread order): which slots to retrace
// (single / multi / adaptive, §3.4), how many samples to add, which to purge;
// the slots to retrace are appended to retrace_list.
#include "sample_cache/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint pixel = px.y * size.x + px.x;
    uint pm = eye * npix() + pixel;
    uint m = mask_cur[pm];
    uint occ = occ_bits(m), vis = vis_bits(m);
    uint frame_index = frame.size_seed.w;

    // 3×3 neighbourhood: visible-sample density and the farthest sample. Per
    // appendix A, t_min and Δn are this pixel's own closest sample: every
    // neighbour sample lies within 2φ of it, so on a flat surface the
    // neighbourhood's t_max stays below t_min + 2Δn (Eq. 2).
    uint vis_sum = 0u, count = 0u;
    uint64_t own = depth_min[pm];
    bool has_own = own != 0xFFFFFFFFFFFFFFFFul;
    float t_min = has_own ? uintBitsToFloat(uint(own >> 32)) : 0.0;
    float slope = has_own ? uintBitsToFloat(uint(own & 0xFFFFFFFFul)) : 0.0;
    float t_max = 0.0;
    float t_near = uintBitsToFloat(0x7F800000u);   // closest sample in the 3×3 neighbourhood
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = ivec2(px) + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, ivec2(size)))) continue;
            uint qm = eye * npix() + uint(q.y) * size.x + uint(q.x);
            vis_sum += bitCount(vis_bits(mask_cur[qm]));
            count++;
            t_max = max(t_max, uintBitsToFloat(depth_max[qm]));
            uint64_t q_min = depth_min[qm];   // unset: no visible surface sample there
            if (q_min != 0xFFFFFFFFFFFFFFFFul) t_near = min(t_near, uintBitsToFloat(uint(q_min >> 32)));
        }
    }
    float density = float(vis_sum) / float(max(count, 1u));

    uint trace = 0u;
    uint n_occ = bitCount(occ);
    bool edge = false;
    if (n_occ > 0u) {
        uint round_robin = nth_set_bit(occ, frame_index % n_occ);
        if (RETRACE_MODE == 0u) {
            trace = 1u << round_robin;
        } else if (RETRACE_MODE == 1u) {
            trace = occ;
        } else {
            // A pixel whose visible samples are all background (t_min = ∞:
            // depth_min unset, reproject.comp) passes Eq. 2 trivially
            // (nothing lies beyond infinity; IEEE's ∞ < ∞ would flag every
            // sky pixel). Where a neighbour holds a surface sample (the sky
            // side of a silhouette) it retraces one slot per frame, round
            // robin, instead of waiting for the base rate: geometry moving
            // in from that neighbour would otherwise leave its background
            // samples visible for up to 16 frames (a covered pixel showing
            // sky). (Retracing all its slots there: 83 083 instead of
            // 75 418 retrace rays per frame in `bench sample-cache` on the
            // hairball.) Away from silhouettes sky pixels keep the base rate.
            bool sky_side = !has_own && vis != 0u && !isinf(t_near);
            float tol = pc.eps1 * eye_tolerance_scale(frame.eyes[eye], t_min + 2.0 * slope);
            edge = has_own && !depths_consistent(t_min, slope, t_max, tol);
            uint visit;
            if (edge) trace = occ;
            else if (sky_side) trace = 1u << round_robin;
            else if (sparse_base_pixel(px, frame_index, eye, visit)) trace = 1u << nth_set_bit(occ, visit % n_occ);
        }
    }

    // Density control (§3.2): add towards n_target, or purge one sample at
    // random. Background samples count like any other (they are visible
    // samples). Besides the 3×3 mean the pixel's own count decides (issue
    // 12): a pixel below low = n_target − δ is refilled to low whatever its
    // neighbourhood's mean, and the purge takes no pixel at or below low. A
    // pixel's count then never crosses low in either direction by these
    // rules, so refill and purge cannot undo each other, and every pixel
    // holds at least low samples one frame after it fell below (room =
    // N − n_vis never limits it; a retrace that finds some of its samples
    // occluded in that frame can). Until session 57 the refill waited for a mean of at
    // most n_target and the purge went down to one sample: after motion
    // had piled samples unevenly, a pixel with 2 samples among neighbours
    // with 6 was purged to 1 and then sat at a mean of 4.56, in the band,
    // for good (an audit's simulation; a pixel with 11 samples beside one
    // with 1 kept both there). The refill adds at most low samples, so
    // neighbours refilling in one frame can lift a mean past n_target + δ,
    // which the purge trims one sample a frame from the pixels above low.
    uint add = 0u, purge = 0u;
    uint n_vis = bitCount(vis);
    uint low = pc.n_target - min(pc.delta, pc.n_target);
    uint room = bitCount(~occ & full_bits()) + bitCount(occ & ~vis);
    if (density < float(low) && n_vis < pc.n_target) {
        add = min(pc.n_target - n_vis, room);
    } else if (n_vis < low) {
        add = min(low - n_vis, room);
    } else if (density > float(pc.n_target + pc.delta) && n_vis > low) {
        Rng r = rng_init(frame.size_seed.z, frame_index, eye, pixel, 0x5EED0001u);
        purge = nth_set_bit(vis, min(uint(rng_next(r) * float(n_vis)), n_vis - 1u)) + 1u;
        trace &= ~(1u << (purge - 1u));
    }
    pixel_action[pm] = uvec4(trace, add, purge, edge ? 1u : 0u);
    // The slots to retrace go to the compacted list (one reservation per
    // pixel and kind): surface samples from the front, background samples
    // from the back (RetraceList in common.glsl).
    retrace_found[pm] = 0u;
    uint trace_bg = 0u, b = trace;
    while (b != 0u) {
        uint s = uint(findLSB(b));
        b &= b - 1u;
        if (slot_is_background(eye, s, pixel)) trace_bg |= 1u << s;
    }
    uint trace_surface = trace & ~trace_bg;
    uint i = list_reserve(9u, bitCount(trace_surface));
    while (trace_surface != 0u) {
        uint s = uint(findLSB(trace_surface));
        trace_surface &= trace_surface - 1u;
        retrace_list[i++] = list_entry(eye, s, pixel);
    }
    uint j = list_reserve(14u, bitCount(trace_bg));
    while (trace_bg != 0u) {
        uint s = uint(findLSB(trace_bg));
        trace_bg &= trace_bg - 1u;
        retrace_list[retrace_list_capacity() - 1u - j++] = list_entry(eye, s, pixel);
    }
}
