#version 460
// Hybrid, last pass (after hash_table/update.comp). Visible background
// samples (the sample cache's rays that missed the scene, first_hit.glsl)
// show the environment in their directions; depth, first hit, albedo and the
// TAA position are those of the pixel's closest visible surface sample (a
// pixel without one shows the environment: the mean over its background
// samples, or through its centre without any). The colour:
//  * per-pixel lookups (default; paper §4/§5.1, "three lookups per pixel
//    (one for shading, two for reconstruction)"): the pixel's surface sample
//    of this frame (hy_pixel_sample, the same as reserve.comp's) looks up
//    (find only) its point, voxel-jittered at level L's scale, at the hash
//    cache's level L and at the parent L + 1 (both keyed at that one point)
//    ("the hit voxel and its parent one level-of-detail above"); its colour
//    = demodulation factor × the mean of the levels that hold radiance +
//    emission (the pixel's own path where its reservation failed; emission
//    alone where neither level holds radiance). The pixel's colour mixes it
//    with the environment of its visible background samples by coverage,
//    n_surf : n_bg (no lookup for those). TAA integrates the samples.
//  * per-sample lookups (the variant before issue 15): every visible sample
//    finds both levels of its unjittered point; its colour as above (the
//    updated sample falls back on its own path when its reservation failed;
//    a sample with no level holding radiance does not contribute); pixel
//    colour = mean over the contributing samples and the background samples,
//    so a partly covered pixel shows its coverage.
#include "hybrid/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

// Per-pixel lookups: colour of the pixel's surface sample `sl` of this
// frame, mixed with its background samples' by coverage.
void resolve_per_pixel(uint eye, uint pixel, uint pm, uint vis, vec3 bg_sum, float n_bg, EyeGpu e) {
    vec2 j;
    uint sl = hy_pixel_sample(eye, pixel, vis, j);
    uvec4 fh = fh_cur[hy_slot_index(eye, sl, pixel)];
    vec3 wp = hit_position(fh), o, d;
    float t;
    eye_ray_to(e, wp, o, d, t);
    Surface s = surface_at(fh.w, fh.z, first_hit_bary(fh), d);
    ShadingMaterial m = material_at(s, d, eye_cone(e, t).x);
    int level = hc_level(t, d, s.ng, e);
    vec3 acc = vec3(0.0);
    bool got[2] = bool[2](false, false);
    // One point, jittered at the fine level's scale, keys both levels: the
    // L + 1 voxel is then the parent of the L voxel (floor(p / 2^(L+1)) =
    // floor(floor(p / 2^L) / 2)), the one reserve.comp updates.
    vec3 pj = hy_jittered(wp, s.ng, level, j);
    for (int k = 0; k < 2; ++k) {
        uint h, local_offset, chk, slot;
        hy_key(pj, s.ng, level + k, h, local_offset, chk);
        if (hy_find(h, local_offset, chk, slot)) {
            vec4 cl = cells[slot];
            if (cl.w > 0.0) { acc += cl.rgb; got[k] = true; }
        }
    }
    float levels = float(got[0]) + float(got[1]);
    uint which = got[0] && got[1] ? C_HY_BOTH : got[0] ? C_HY_FINE_ONLY : got[1] ? C_HY_COARSE_ONLY : C_HY_NO_LEVEL;
    atomicAdd(counters[which], 1u);
    atomicAdd(counters[C_HY_LOOKED_UP], 1u);
    if (levels == 0.0 && (pix_cell[pm].y & 15u) == ST_FAILED) { acc = fallback[pm].rgb; levels = 1.0; }
    vec3 Le = SC_EMISSIVE ? m.emissive : vec3(0.0);
    vec3 c = demodulation_factor(m) * (levels > 0.0 ? acc / levels : vec3(0.0)) + Le;
    // Coverage: the surface sample stands for the pixel's n_surf visible
    // surface samples, each background sample for itself.
    float n_surf = float(bitCount(vis));
    color[pm] = vec4((n_surf * c + bg_sum) / (n_surf + n_bg), 1.0);
    // Outputs of the closest visible surface sample.
    float best_t = 3.4e38;
    uvec4 best_fh = uvec4(0u, 0u, 0u, NO_HIT);
    vec3 best_p = vec3(0.0);
    uint bits = vis;
    while (bits != 0u) {
        uint b = uint(findLSB(bits));
        bits &= bits - 1u;
        uvec4 f = fh_cur[hy_slot_index(eye, b, pixel)];
        vec3 wp = hit_position(f), o, d;
        float t;
        eye_ray_to(e, wp, o, d, t);
        if (t < best_t) { best_t = t; best_fh = f; best_p = wp; }
    }
    vec3 bo, bd;
    eye_ray_to(e, best_p, bo, bd, best_t);
    Surface bs = surface_at(best_fh.w, best_fh.z, first_hit_bary(best_fh), bd);
    ShadingMaterial bm = material_at(bs, bd, eye_cone(e, best_t).x);
    position[pm] = vec4(best_p, 1.0);
    out_depth[pm] = view_depth(e, best_p);
    out_fh[pm] = best_fh;
    out_albedo[pm] = vec4(bm.base, 1.0);
}

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
#ifdef SC_MATERIAL_MEMO
    sc_memo_eye = eye;
#endif
    if (any(greaterThanEqual(px, size))) return;
    uint pixel = px.y * size.x + px.x;
    uint pm = eye * npix() + pixel;
    uint all_vis = hy_vis_bits(mask_cur[pm]);
    uint vis = hy_surface_bits(eye, pixel, all_vis);
    EyeGpu e = frame.eyes[eye];
    // Background samples: sum of their environment radiance and count.
    vec3 bg_sum = vec3(0.0);
    float n_bg = 0.0;
    uint bg_bits = all_vis & ~vis;
    while (bg_bits != 0u) {
        uint sl = uint(findLSB(bg_bits));
        bg_bits &= bg_bits - 1u;
        vec3 db = background_direction(fh_cur[hy_slot_index(eye, sl, pixel)]);
        bg_sum += environment(db) + sun_radiance(db);
        n_bg += 1.0;
    }
    if (vis == 0u) {
        vec3 d = eye_ray_dir(e, vec2(px) + 0.5);
        color[pm] = vec4(n_bg > 0.0 ? bg_sum / n_bg : environment(d) + sun_radiance(d), 1.0);
        position[pm] = vec4(d, 0.0);
        out_depth[pm] = 0.0;
        out_fh[pm] = uvec4(0u, 0u, 0u, NO_HIT);
        out_albedo[pm] = vec4(0.0);
        return;
    }
    if (n_bg > 0.0) atomicAdd(counters[C_HY_SILHOUETTE], 1u);
    if (!PER_SAMPLE) {
        resolve_per_pixel(eye, pixel, pm, vis, bg_sum, n_bg, e);
        return;
    }
    uint upd_slot = hy_update_slot(vis);
    bool upd_failed = (pix_cell[pm].y & 15u) == ST_FAILED;
    vec3 sum = vec3(0.0);
    float contributing = 0.0;
    uint n_both = 0u, n_fine = 0u, n_coarse = 0u, n_none = 0u;
    float best_t = 3.4e38;
    uvec4 best_fh = uvec4(0u, 0u, 0u, NO_HIT);
    vec3 best_albedo = vec3(0.0), best_p = vec3(0.0);
    uint bits = vis;
    while (bits != 0u) {
        uint sl = uint(findLSB(bits));
        bits &= bits - 1u;
        uvec4 fh = fh_cur[hy_slot_index(eye, sl, pixel)];
        vec3 wp = hit_position(fh), o, d;
        float t;
        eye_ray_to(e, wp, o, d, t);
        Surface s = surface_at(fh.w, fh.z, first_hit_bary(fh), d);
        ShadingMaterial m = material_at(s, d, eye_cone(e, t).x);
        if (t < best_t) { best_t = t; best_fh = fh; best_albedo = m.base; best_p = wp; }
        int level = hc_level(t, d, s.ng, e);
        vec3 acc = vec3(0.0);
        bool got[2] = bool[2](false, false);
        for (int k = 0; k < 2; ++k) {
            uint h, local_offset, chk, slot;
            hy_key(wp, s.ng, level + k, h, local_offset, chk);
            if (hy_find(h, local_offset, chk, slot)) {
                vec4 c = cells[slot];
                if (c.w > 0.0) { acc += c.rgb; got[k] = true; }
            }
        }
        float levels = float(got[0]) + float(got[1]);
        if (got[0] && got[1]) n_both++;
        else if (got[0]) n_fine++;
        else if (got[1]) n_coarse++;
        else n_none++;
        if (levels == 0.0 && sl == upd_slot && upd_failed) { acc = fallback[pm].rgb; levels = 1.0; }
        if (levels > 0.0) {
            vec3 Le = SC_EMISSIVE ? m.emissive : vec3(0.0);
            sum += demodulation_factor(m) * (acc / levels) + Le;
            contributing += 1.0;
        }
    }
    color[pm] = vec4(contributing + n_bg > 0.0 ? (sum + bg_sum) / (contributing + n_bg) : vec3(0.0), 1.0);
    position[pm] = vec4(best_p, 1.0);
    out_depth[pm] = view_depth(e, best_p);
    out_fh[pm] = best_fh;
    out_albedo[pm] = vec4(best_albedo, 1.0);
    atomicAdd(counters[C_HY_LOOKED_UP], bitCount(vis));
    if (n_both > 0u) atomicAdd(counters[C_HY_BOTH], n_both);
    if (n_fine > 0u) atomicAdd(counters[C_HY_FINE_ONLY], n_fine);
    if (n_coarse > 0u) atomicAdd(counters[C_HY_COARSE_ONLY], n_coarse);
    if (n_none > 0u) atomicAdd(counters[C_HY_NO_LEVEL], n_none);
}
