#version 460
// variant: SUBGROUP_OPS
// §3.1 forward reprojection with slot reservation by atomicOr (Listing 2).
// One thread per source pixel walks its occupied slots. One-pass (default)
// writes the sample data right after a successful reservation; two-pass
// (TWO_PASS) writes only the source address, copied by reproject_copy.comp.
// Successful visible samples update the per-pixel t_min/Δn (64-bit atomicMin)
// and t_max (atomicMax).
#include "sample_cache/common.glsl"
layout(constant_id = SPEC_SAMPLE_CACHE_TWO_PASS) const bool TWO_PASS = false;
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

// Listing 2's choose_target_slot: a free slot, else (visible samples only)
// an occupied but invisible one whose visibility bit we race for.
int choose_target_slot(bool vis, uint m) {
    uint free_slots = ~occ_bits(m) & full_bits();
    if (free_slots != 0u) return findLSB(free_slots);
    if (vis) {
        uint invisible = occ_bits(m) & ~vis_bits(m);
        if (invisible != 0u) return findLSB(invisible);
    }
    return -1;
}

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint pixel = px.y * size.x + px.x;
    uint m_src = mask_prev[eye * npix() + pixel];
    uint occ = occ_bits(m_src);
    if (occ == 0u) return;
    EyeGpu e = frame.eyes[eye];
    vec2 cs_phi = pixel_diagonal_cos_sin(e);
    bool ortho = eye_is_ortho(e);
    float diag = pixel_diagonal(e);
    uint reprojected = 0u, reprojected_visible = 0u, full = 0u, offscreen = 0u, reprojected_bg = 0u, backfacing = 0u;
    while (occ != 0u) {
        uint s = uint(findLSB(occ));
        occ &= occ - 1u;
        uint src = slot_index(eye, s, pixel);
        uvec4 fh = fh_prev[src];
        vec3 wp, ng;
        // Background sample (§3.3): a direction at infinity, projected
        // through the point one unit along it from the new eye (only the
        // view rotation moves it; an orthographic eye drops it once the
        // view turns: camera.glsl background_offset); its distance is t = ∞
        // (below).
        bool bg = first_hit_is_background(fh);
        vec3 offset = vec3(0.0);   // a surface sample's, from e's position
        vec2 q;
        bool on_screen;
        vec3 d;          // a surface sample's eye ray and distance from
        float t = 0.0;   // the new eye (below: Eq. 1, slot_depth)
        if (bg) {
            on_screen = background_target(e, frame.prev_eyes[eye], vec2(px) + background_subpixel(fh), background_direction(fh), q);
        } else {
            hit_position_and_normal(fh, wp, ng);
            offset = wp - e.pos_tanx.xyz;
            float vd;
            on_screen = project_offset_to_eye(e, offset, q, vd);
        }
        if (!on_screen || any(lessThan(q, vec2(0.0))) || any(greaterThanEqual(q, vec2(size)))) {
            offscreen++;
            continue;
        }
        uvec2 qi = uvec2(q);
        uint target = qi.y * size.x + qi.x;
        uint tm = eye * npix() + target;
        bool vis = ((m_src >> (N_SLOTS + s)) & 1u) != 0u;
        // A surface sample the new eye sees from behind on a single-sided
        // triangle goes on invisible: eye rays pass through the face there
        // (first_hit.glsl first_hit_culled), so it cannot be what the pixel
        // shows, and its retrace could never say so (the ray passes through
        // it and finds nothing closer). Invisible, it frees the pixel's
        // count for new samples (select.comp) and becomes visible again by
        // a retrace once the front faces the eye.
        if (vis && !bg && first_hit_culled(fh, ng, ortho ? e.fwd.xyz : offset)) {
            vis = false;
            backfacing++;
        }
        uint m = mask_cur[tm];
        int slot = -1;
        for (uint attempt = 0u; attempt < 2u * N_SLOTS + 1u; ++attempt) {
            int i = choose_target_slot(vis, m);
            if (i < 0) break;
            uint o_bit = 1u << uint(i);
            uint v_bit = 1u << (uint(i) + N_SLOTS);
            uint s_val = o_bit | (vis ? v_bit : 0u);
            uint old = atomicOr(mask_cur[tm], s_val);
            bool success = (old & o_bit) == 0u;
            if (vis && !success) success = (old & v_bit) == 0u;
            m = old | s_val;
            if (success) { slot = i; break; }
        }
        if (slot < 0) { full++; continue; }
        uint dst = slot_index(eye, uint(slot), target);
        if (TWO_PASS) {
            // §3.1's race-free variant, pass 1: the slot's source is the
            // atomicMax of key = v << 31 | (s·npix + pixel + 1) over the
            // reservations that succeeded on it. Listing 2 lets at most one
            // invisible reservation (on a free slot) and one visible one (on
            // a free or invisible slot) succeed per slot, so the visible
            // source wins whatever order the threads ran in, and
            // reproject_copy.comp copies the data with the visibility and
            // occupancy the key carries: an invisible sample's data can never
            // sit under a visible bit. (s·npix + pixel + 1 ≤ 16·2^26 < 2^31:
            // the source is in the same eye.)
            atomicMax(target_src[dst], (vis ? 0x80000000u : 0u) | (s * npix() + pixel + 1u));
        } else {
            // A background sample carries its new place in the pixel
            // (first_hit.glsl background_at).
            fh_cur[dst] = bg ? background_at(fh, q - vec2(qi)) : fh;
            if (SHADING_STORAGE) rad_cur[dst] = rad_prev[src];
        }
        vec3 o;
        if (!bg && (vis || (SHADING_STORAGE && !TWO_PASS))) eye_ray_to(e, wp, o, d, t);
        // Its distance for reconstruct.comp (two-pass: reproject_copy.comp).
        if (SHADING_STORAGE && !TWO_PASS) slot_depth[dst] = bg ? uintBitsToFloat(0x7F800000u) : t;
        reprojected++;
        if (vis) {
            reprojected_visible++;
            if (bg) {
                // Background samples (t = ∞) only raise t_max to ∞, so a
                // pixel whose neighbourhood mixes surface and background
                // fails Eq. 2 (a silhouette); t_min stays the closest surface
                // sample's (unset: only background, select.comp). One atomic
                // per pixel, not per sample, where t_max is ∞ already; they
                // carry no radiance record to shade.
                reprojected_bg++;
                if (depth_max[tm] != 0x7F800000u) atomicMax(depth_max[tm], 0x7F800000u);
            } else {
                float cos_theta = abs(dot(ng, d));
                float slope = ortho ? normal_slope_parallel(cos_theta, diag) : normal_slope(t, cos_theta, cs_phi);
                atomicMin(depth_min[tm], (uint64_t(floatBitsToUint(t)) << 32) | uint64_t(floatBitsToUint(slope)));
                atomicMax(depth_max[tm], floatBitsToUint(t));
            }
            // (The importance histogram of §3.5 is counted after tracing, by
            // shade_select.comp phase 0, so that it holds this frame's new
            // samples too: issue 12 item 3; background samples are never
            // shaded and stay out of it.)
        }
    }
    count_add(C_REPROJECTED, reprojected);
    count_add(C_REPROJECTED_VISIBLE, reprojected_visible);
    count_add(C_REPROJECTED_BACKGROUND, reprojected_bg);
    count_add(C_REPROJECT_FULL, full);
    count_add(C_OFFSCREEN, offscreen);
    count_add(C_REPROJECTED_BACKFACING, backfacing);
}
