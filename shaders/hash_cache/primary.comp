#version 460
// Jittered 1 spp first hits; the hit's voxel (level of detail from distance,
// optionally incidence; jittered by up to half a voxel each way in the
// tangent plane) is
// looked up or reserved. The first thread to touch an entry this frame
// becomes its updater (winner). Also writes the per-pixel outputs (of the
// jittered hit) and, for TAA only (push flag bit 3: the method's TAA or
// `--taa-output`'s; without one the ray is neither traced nor counted), the
// view depth and first hit of a second, unjittered ray through the pixel
// centre (as `taa`'s, reference/primary.comp):
// TAA's reprojection and history rejection (taa/resolve.comp) then compare
// the same surface point frame to frame. With the jittered hit's depth and
// ids, a static view of the hairball rejected ≈ 30 % of its pixels as
// disoccluded (a new jitter often lands on another strand or the sky).
#include "hash_table/table.glsl"
#include "interface/hash_cache.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(set = SET_HASH_CACHE, binding = B_HASH_CACHE_TAA_DEPTH, std430) writeonly buffer TaaDepth { float taa_depth[]; };   // pixel-centre view depth, 0 = miss
layout(set = SET_HASH_CACHE, binding = B_HASH_CACHE_TAA_FH, std430) writeonly buffer TaaFh { uvec4 taa_fh[]; };          // pixel-centre first hit

// The pixel centre's first hit for TAA (one primary ray, counted).
void write_centre_hit(EyeGpu e, uvec2 px, uint pm) {
    vec3 o = eye_ray_origin(e, vec2(px) + 0.5);
    vec3 d = eye_ray_dir(e, vec2(px) + 0.5);
    RtHit h;
    bool hit = rt_closest_hit(o, d, 0.0, 1e30, h);
    atomicAdd(counters[C_HT_PRIMARY], 1u);
    if (!hit) {
        taa_depth[pm] = 0.0;
        taa_fh[pm] = uvec4(0u, 0u, 0u, NO_HIT);
        return;
    }
    Surface s = surface_at(h.instance, h.prim, h.bary, d);
    taa_depth[pm] = eye_hit_depth(e, d, h.t);
    taa_fh[pm] = encode_first_hit(h.bary, h.instance, h.prim, s.material);
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
    EyeGpu e = frame.eyes[eye];
    Rng r = rng_init(frame.size_seed.z, pc.now, eye, pixel, 0x4A5C0001u);
    if (hc_centre_hits()) write_centre_hit(e, px, pm);
    vec2 at = vec2(px) + rng_next2(r);
    vec3 o = eye_ray_origin(e, at);
    vec3 d = eye_ray_dir(e, at);
    RtHit h;
    bool hit = rt_closest_hit(o, d, 0.0, 1e30, h);
    atomicAdd(counters[C_HT_PRIMARY], 1u);
    if (!hit) {
        RayCounts rays = RayCounts(0u, 0u);
        Rng rr = r;
        vec3 L = path_radiance(o, d, false, h, vec2(0.0), rr, rays);   // environment and sun: no rays
        if (drop_non_finite(L)) atomicAdd(counters[C_HT_NONFINITE_SAMPLES], 1u);   // (integrator.glsl)
        pix_ray[pm] = vec4(d, -1.0);
        pix_hit[pm] = uvec4(0u, 0u, 0u, NO_HIT);
        pix_cell[pm] = uvec4(NO_CELL, ST_MISS, 0u, 0u);
        fallback[pm] = vec4(L, 1.0);
        position[pm] = vec4(d, 0.0);
        out_depth[pm] = 0.0;
        out_fh[pm] = uvec4(0u, 0u, 0u, NO_HIT);
        out_albedo[pm] = vec4(0.0);
        atomicAdd(counters[C_HT_MISSES], 1u);
        return;
    }
    float cone = eye_cone(e, h.t).x;
    Surface s = surface_at(h.instance, h.prim, h.bary, d);
    ShadingMaterial m = material_at(s, d, cone);
    vec3 p = o + h.t * d;
    pix_ray[pm] = vec4(d, h.t);
    pix_hit[pm] = uvec4(floatBitsToUint(h.bary), h.prim, h.instance);
    position[pm] = vec4(p, 1.0);
    out_depth[pm] = view_depth(e, p);
    out_fh[pm] = encode_first_hit(h.bary, h.instance, h.prim, s.material);
    out_albedo[pm] = vec4(m.base, 1.0);

    int level = hc_level(h.t, d, s.ng, e);
    float voxel = exp2(float(level));
    vec3 tu, tv;
    hc_tangents(s.ng, tu, tv);
    vec2 j = rng_next2(r) - 0.5;
    vec3 pj = p + voxel * (j.x * tu + j.y * tv);
    ivec3 coord;
    uint meta;
    hc_key(pj, s.ng, level, coord, meta);
    uint hsh = hc_index_hash(coord, meta);
    uint chk = hc_checksum(coord, meta);
    uint slot;
    bool winner;
    uint st = hc_find_or_insert(hsh, hc_meta_local(meta), chk, slot, winner);
    pix_cell[pm] = uvec4(slot, st | (winner ? 16u : 0u), chk, meta);
    atomicAdd(counters[C_HT_FOUND + st], 1u);
}
