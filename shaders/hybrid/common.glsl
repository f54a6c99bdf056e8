// Hybrid (paper §4): the sample cache without shading storage supplies the
// visible first hits of every pixel; their radiance comes from the hash
// cache's table, looked up at the hash cache's level of detail L and at its
// parent L + 1. Descriptor set 1 = the hash table's bindings 0..13 and push
// constants (hash_table/table.glsl, so its update.comp and count.comp run
// unchanged on this set) + the sample cache's current mask and first hits.
// src/methods/hybrid/ owns the buffers and the pass order.
#include "hash_table/table.glsl"
#include "interface/hybrid.glsl"
#include "common/first_hit.glsl"

layout(constant_id = SPEC_HYBRID_N_SLOTS) const uint N_SLOTS = 12;   // the sample cache's slot count
// Lookups (HybridLookups, src/methods/hybrid/config.rs): false = per pixel,
// the paper's three (§4, §5.1: one for shading, two for reconstruction, with
// voxel jitter); true = per sample, every visible sample at both levels
// without jitter (the variant before issue 15).
layout(constant_id = SPEC_HYBRID_PER_SAMPLE) const bool PER_SAMPLE = false;
layout(set = SET_HYBRID, binding = B_HYBRID_MASK_CUR, std430) readonly buffer MaskCur { uint mask_cur[]; };   // [eye][pixel]
layout(set = SET_HYBRID, binding = B_HYBRID_FH_CUR, std430) readonly buffer FhCur { uvec4 fh_cur[]; };      // [eye][slot][pixel]

// Counter slots: the table's C_HT_*, then C_HY_* (src/interface/hybrid.rs, HybridCounter).

uint hy_vis_bits(uint m) {
    uint full = N_SLOTS >= 32u ? 0xFFFFFFFFu : (1u << N_SLOTS) - 1u;
    return (m >> N_SLOTS) & full;
}
uint hy_slot_index(uint eye, uint s, uint pixel) { return (eye * N_SLOTS + s) * npix() + pixel; }

// The slots of `bits` that hold surface samples, not background ones (a
// sample whose ray missed the scene, first_hit.glsl): only those look up
// or update the table.
uint hy_surface_bits(uint eye, uint pixel, uint bits) {
    uint out_bits = bits, b = bits;
    while (b != 0u) {
        uint s = uint(findLSB(b));
        b &= b - 1u;
        if (first_hit_is_background(fh_cur[hy_slot_index(eye, s, pixel)])) out_bits &= ~(1u << s);
    }
    return out_bits;
}

// Index of the k-th set bit of `bits` (k < bitCount(bits)).
uint hy_nth_set_bit(uint bits, uint k) {
    for (uint i = 0u; i < k; ++i) bits &= bits - 1u;
    return uint(findLSB(bits));
}

// The sample that updates the table this frame: round robin over the
// pixel's visible surface samples by frame index (`vis` ≠ 0).
uint hy_update_slot(uint vis) { return hy_nth_set_bit(vis, frame.size_seed.w % bitCount(vis)); }

// Index hash, offset in the tile and checksum of the voxel holding p at
// `level` (p as given: per-sample lookups use no voxel jitter, per-pixel
// lookups pass hy_jittered's point).
void hy_key(vec3 p, vec3 ng, int level, out uint h, out uint local_offset, out uint chk) {
    ivec3 coord;
    uint meta;
    hc_key(p, ng, level, coord, meta);
    h = hc_index_hash(coord, meta);
    local_offset = hc_meta_local(meta);
    chk = hc_checksum(coord, meta);
}

// Per-pixel lookups (paper §4): the pixel's surface sample this frame,
// drawn uniformly from its visible surface samples `vis` (≠ 0), and the
// voxel jitter j ∈ [-1/2, 1/2)². Reserve and resolve draw the same values.
// Background samples need no lookup: resolve.comp mixes the environment in
// by the pixel's coverage, as the sample cache does (§3.3), so a
// silhouette against the sky is antialiased in every frame, without TAA
// (§6: "the Hybrid method delivers a good picture without it"). Until
// session 56 the draw included them, so such a pixel showed the surface or
// the environment in turn, like a 1 spp frame (an audit's finding).
uint hy_pixel_sample(uint eye, uint pixel, uint vis, out vec2 j) {
    Rng r = rng_init(frame.size_seed.z, pc.now, eye, pixel, 0x4B1D0002u);
    uint n = uint(bitCount(vis));
    uint k = min(uint(rng_next(r) * float(n)), n - 1u);
    j = rng_next2(r) - 0.5;
    return hy_nth_set_bit(vis, k);
}

// Voxel jitter as in HashCache (hash_cache/primary.comp, [BFK18]): p moved
// by j voxels of `level` in the tangent plane of ng. Reserve and resolve
// jitter at the fine level L and key L and L + 1 at the same point.
vec3 hy_jittered(vec3 p, vec3 ng, int level, vec2 j) {
    vec3 tu, tv;
    hc_tangents(ng, tu, tv);
    return p + exp2(float(level)) * (j.x * tu + j.y * tv);
}

// Finds the key within the probe window without inserting; refreshes the
// entry's last access so entries that are only read stay alive.
bool hy_find(uint h, uint local_offset, uint c, out uint slot) {
    slot = NO_CELL;
    for (uint i = 0u; i < pc.max_probe; ++i) {
        uint s = hc_probe_slot(h, local_offset, hc_tiles(), i, pc.capacity);
        uint64_t w = hc_key(s);
        if (hc_chk(w) == c) {
            if (hc_touch(s, c, w) < 0) return false;
            slot = s;
            return true;
        }
    }
    return false;
}
