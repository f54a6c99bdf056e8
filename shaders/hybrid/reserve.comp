#version 460
// Hybrid, first pass: per pixel one visible sample of the sample cache and
// one of its two levels — the hash cache's level L or the parent L + 1,
// chosen by a coin toss ("the update randomly updates one of the two
// levels", §4) — is looked up or reserved in the table (the pixel's one
// lookup for shading); the first toucher of an entry this frame becomes its
// updater. The sample: per-pixel lookups (default) the pixel's surface sample
// of this frame (hy_pixel_sample), its point
// voxel-jittered at level L's scale whichever level it updates (so the L + 1
// voxel is the parent of the L voxel, as in resolve.comp); per-sample lookups round robin over the surface samples
// (hy_update_slot), unjittered. Writes pix_hit / pix_ray / pix_cell in the
// hash cache's format, so hash_table/update.comp then traces the secondary
// path unchanged.
#include "hybrid/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint pixel = px.y * size.x + px.x;
    uint pm = eye * npix() + pixel;
    uint all_vis = hy_vis_bits(mask_cur[pm]);
    uint vis = hy_surface_bits(eye, pixel, all_vis);
    if (vis == 0u) {
        pix_cell[pm] = uvec4(NO_CELL, ST_MISS, 0u, 0u);
        atomicAdd(counters[C_HT_MISSES], 1u);
        return;
    }
    uint sl;
    vec2 j = vec2(0.0);
    if (PER_SAMPLE) {
        sl = hy_update_slot(vis);
    } else {
        sl = hy_pixel_sample(eye, pixel, vis, j);
    }
    uvec4 fh = fh_cur[hy_slot_index(eye, sl, pixel)];
    EyeGpu e = frame.eyes[eye];
    vec3 wp = hit_position(fh), o, d;
    float t;
    eye_ray_to(e, wp, o, d, t);
    vec2 bary = first_hit_bary(fh);
    Surface s = surface_at(fh.w, fh.z, bary, d);
    Rng r = rng_init(frame.size_seed.z, pc.now, eye, pixel, 0x4B1D0001u);
    bool coarse = rng_next(r) < 0.5;
    int fine = hc_level(t, d, s.ng, e);
    int level = fine + (coarse ? 1 : 0);
    // Both levels key the point jittered at the fine level's scale, as the
    // resolve does, so the L + 1 voxel updated is the parent of the L voxel.
    uint h, local_offset, chk;
    hy_key(PER_SAMPLE ? wp : hy_jittered(wp, s.ng, fine, j), s.ng, level, h, local_offset, chk);
    uint slot;
    bool winner;
    uint st = hc_find_or_insert(h, local_offset, chk, slot, winner);
    pix_hit[pm] = uvec4(floatBitsToUint(bary), fh.z, fh.w);
    pix_ray[pm] = vec4(d, t);
    pix_cell[pm] = uvec4(slot, st | (winner ? 16u : 0u), chk, hc_pack_meta(level, HC_NO_AXIS, local_offset, hc_tiles()));
    atomicAdd(counters[C_HT_FOUND + st], 1u);
    atomicAdd(counters[coarse ? C_HY_UPD_COARSE : C_HY_UPD_FINE], 1u);
}
