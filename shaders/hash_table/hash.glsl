// Keys, hashes and the probe sequence of the hash cache. Pure functions, no
// bindings: the method's passes and hash_test.comp both include this file.
// CPU twin, bit for bit: src/methods/hash_table/hash.rs (see its notes).
//   key   = (ivec3 voxel or tile coordinates, uint meta)
//   meta  = level + 32 (bits 0-5) | major axis 0..5, 7 = none (6-8)
//         | offset in the 4x4 tile (9-12) | tiles on (13)
//   index = pcg(x + pcg(y + pcg(z + pcg(meta without the tile offset))))
//   check = xxhash32 chained the same way, 0 mapped to 1 (0 = empty entry)
#ifndef HASH_CACHE_HASH_GLSL
#define HASH_CACHE_HASH_GLSL
#include "common/random.glsl"

const uint HC_TILE_ENTRIES = 16u;
const uint HC_NO_AXIS = 7u;
const int HC_LEVEL_BIAS = 32;

uint hc_xxhash32(uint p) {
    const uint P2 = 2246822519u, P3 = 3266489917u, P4 = 668265263u, P5 = 374761393u;
    uint h = p + P5;
    h = P4 * ((h << 17) | (h >> 15));
    h = P2 * (h ^ (h >> 15));
    h = P3 * (h ^ (h >> 13));
    return h ^ (h >> 16);
}

uint hc_pack_meta(int level, uint axis, uint local_offset, bool tiles) {
    return uint(clamp(level + HC_LEVEL_BIAS, 0, 63)) | ((axis & 7u) << 6) | ((local_offset & 15u) << 9)
         | (tiles ? 1u << 13 : 0u);
}
uint hc_meta_local(uint meta) { return (meta >> 9) & 15u; }
bool hc_meta_tiles(uint meta) { return ((meta >> 13) & 1u) == 1u; }
int hc_meta_level(uint meta) { return int(meta & 63u) - HC_LEVEL_BIAS; }

// The voxel's offset within its tile (bits 9-12) stays out of the index
// hash, so the 16 voxels of a tile share one probe sequence and sit side by
// side in one 16-entry tile (§4: "the voxels are stored in spatially
// coherent 2D tiles"); the checksum keeps the whole meta.
uint hc_index_hash(ivec3 c, uint meta) {
    uvec3 u = uvec3(c);
    return pcg_hash(u.x + pcg_hash(u.y + pcg_hash(u.z + pcg_hash(meta & ~(15u << 9)))));
}

uint hc_checksum(ivec3 c, uint meta) {
    uvec3 u = uvec3(c);
    uint h = hc_xxhash32(u.x + hc_xxhash32(u.y + hc_xxhash32(u.z + hc_xxhash32(meta))));
    return max(h, 1u);
}

// Slot of the i-th probe (linear probing over entries, or over 16-entry tiles
// keeping the voxel's offset within the tile). i < capacity, so no overflow.
uint hc_probe_slot(uint h, uint local_offset, bool tiles, uint i, uint capacity) {
    if (tiles) {
        uint n = capacity / HC_TILE_ENTRIES;
        uint t = h % n;
        t = t + i >= n ? t + i - n : t + i;
        return t * HC_TILE_ENTRIES + local_offset;
    }
    uint s = h % capacity;
    return s + i >= capacity ? s + i - capacity : s + i;
}
#endif
