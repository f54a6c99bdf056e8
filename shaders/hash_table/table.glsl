// The hash-grid radiance cache (paper §4, after Roth et al. 2020, GI-1.0 and
// Gautron 2021): open addressing with linear probing over a table of
// `capacity` entries, each a 64-bit word (checksum << 32 | last access frame)
// and an RGBA32F record (demodulated radiance running mean, sample count):
// 24 bytes per entry. Descriptor set 1 below (bindings 0..13; a method may
// add its own after 13). src/methods/hash_table/ owns the buffers and the
// table's passes (update.comp, count.comp); hash_cache/ and hybrid/ add the
// passes that fill the per-pixel requests and resolve the image.
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_KHR_memory_scope_semantics : require
#include "common/integrator.glsl"
#include "common/packing.glsl"
#include "common/demodulation.glsl"
#include "common/camera.glsl"
#include "hash_table/hash.glsl"

#include "interface/hash_table.glsl"

// capacity, max_probe, stale (entries older than this many frames may be
// overwritten), flags (bit 0 tiles, bit 1 distance-normal LoD, bit 2 debug
// views, bit 3 pixel-centre hits for TAA), lod_scale (voxel edge / pixel footprint before quantization),
// max_samples (running-mean count cap), now (the method's frame counter mod
// 2^32, starts at 1): src/interface/hash_table.rs.
layout(push_constant) uniform Push { HASH_TABLE_PUSH } pc;

layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_KEYS, std430) coherent buffer Keys { uint64_t keys[]; };
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_CELLS, std430) buffer Cells { vec4 cells[]; };          // demodulated mean rgb, count
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_PIX_HIT, std430) buffer PixHit { uvec4 pix_hit[]; };      // bary bits x, y, prim, instance
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_PIX_RAY, std430) buffer PixRay { vec4 pix_ray[]; };       // jittered direction, t (< 0: miss)
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_PIX_CELL, std430) buffer PixCell { uvec4 pix_cell[]; };    // slot, status | winner << 4, checksum, meta
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_FALLBACK, std430) buffer Fallback { vec4 fallback[]; };    // miss: environment; no cell: own path
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_COLOR, std430) buffer Color { vec4 color[]; };          // resolved colour before TAA
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_OUT_DEPTH, std430) buffer OutDepth { float out_depth[]; };
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_OUT_FH, std430) buffer OutFh { uvec4 out_fh[]; };
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_OUT_ALBEDO, std430) buffer OutAlbedo { vec4 out_albedo[]; };
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_POSITION, std430) buffer Position { vec4 position[]; };   // hit point, w = 1; miss: direction, w = 0
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_COUNTERS, std430) buffer Counters { uint counters[]; };
layout(set = SET_HASH_TABLE, binding = B_HASH_TABLE_DEBUG, std430) buffer Debug { vec4 debug_out[]; };     // [view][eye][pixel]

// Counter slots: C_HT_* (src/interface/hash_table.rs, TableCounter).
const uint ST_FOUND = 0u, ST_RESERVED = 1u, ST_EVICTED = 2u, ST_FAILED = 3u, ST_MISS = 4u;
const uint NO_CELL = 0xFFFFFFFFu;

bool hc_tiles() { return (pc.flags & 1u) != 0u; }
bool hc_lod_normal() { return (pc.flags & 2u) != 0u; }
bool hc_debug() { return (pc.flags & 4u) != 0u; }
bool hc_centre_hits() { return (pc.flags & 8u) != 0u; }
uint npix() { return frame.size_seed.x * frame.size_seed.y; }

// An entry's key word, read atomically (relaxed, device scope): other lanes
// compare-and-swap it in the same dispatch, and a plain load beside those
// is a data race under the Vulkan memory model (it compiles to the same
// load on x86; the SPIR-V is OpAtomicLoad, no memory-model capability).
uint64_t hc_key(uint s) {
    return atomicLoad(keys[s], gl_ScopeDevice, gl_StorageSemanticsBuffer, gl_SemanticsRelaxed);
}

uint64_t hc_pack(uint c, uint f) { return (uint64_t(c) << 32) | uint64_t(f); }
uint hc_chk(uint64_t w) { return uint(w >> 32); }
uint hc_frame(uint64_t w) { return uint(w & 0xFFFFFFFFul); }
// Wrapping age: exact while real ages stay below 2^32 frames.
bool hc_replaceable(uint64_t w) { return hc_chk(w) == 0u || pc.now - hc_frame(w) > pc.stale; }

// Touches an entry seen holding checksum c (word w). Returns 1 when this
// thread stamped the frame (first toucher this frame: the entry's updater),
// 0 when another thread already did, -1 when the entry went to another key.
int hc_touch(uint s, uint c, uint64_t w) {
    for (uint k = 0u; k < 16u; ++k) {
        if (hc_chk(w) != c) return -1;
        if (hc_frame(w) == pc.now) return 0;
        uint64_t prev = atomicCompSwap(keys[s], w, hc_pack(c, pc.now));
        if (prev == w) return 1;
        w = prev;
    }
    return -1;
}

// Finds the key (h, local, c) within the probe window, else inserts it into
// the first empty or stale entry by compare-and-swap. Threads inserting the
// same key meet at the same first candidate, so a key is never stored twice
// in one window (argument in docs/ARCHITECTURE.md). Returns ST_*.
uint hc_find_or_insert(uint h, uint local_offset, uint c, out uint slot, out bool winner) {
    bool tiles = hc_tiles();
    slot = NO_CELL;
    winner = false;
    for (uint attempt = 0u; attempt < 4u; ++attempt) {
        bool restart = false;
        for (uint i = 0u; i < pc.max_probe; ++i) {
            uint s = hc_probe_slot(h, local_offset, tiles, i, pc.capacity);
            uint64_t w = hc_key(s);
            if (hc_chk(w) == c) {
                int t = hc_touch(s, c, w);
                if (t >= 0) { slot = s; winner = t == 1; return ST_FOUND; }
                restart = true;
                break;
            }
        }
        if (restart) continue;
        for (uint i = 0u; i < pc.max_probe && !restart; ++i) {
            uint s = hc_probe_slot(h, local_offset, tiles, i, pc.capacity);
            uint64_t w = hc_key(s);
            for (uint k = 0u;; ++k) {
                if (k == 16u) return ST_FAILED;   // contended beyond reason: give up, never skip
                if (hc_chk(w) == c) {
                    int t = hc_touch(s, c, w);
                    if (t >= 0) { slot = s; winner = t == 1; return ST_FOUND; }
                    restart = true;
                    break;
                }
                if (!hc_replaceable(w)) break;      // live entry of another key: next probe
                uint64_t prev = atomicCompSwap(keys[s], w, hc_pack(c, pc.now));
                if (prev == w) {
                    slot = s;
                    winner = true;
                    return hc_chk(w) == 0u ? ST_RESERVED : ST_EVICTED;
                }
                w = prev;
            }
        }
        if (!restart) break;
    }
    return ST_FAILED;
}

// Level of detail: voxel edge 2^level ≤ footprint, the footprint across the
// eye ray d of the pixel it passes through, at the hit distance t, ×
// lod_scale (paper §4: voxels smaller than a pixel). A perspective eye's
// pixel off the axis by φ (cos φ = d·fwd) subtends the centre pixel's spread
// × cos²φ along the radius and × cos φ across it (a planar image): the
// smaller, cos²φ, is taken, so voxels are smaller than a pixel over the
// whole image. An orthographic eye's pixels are all one size. With
// distance-normal LoD the footprint is divided by |cos θ| ≥ 1/16. d must be
// the eye ray's direction (every caller passes it), not a bounce's.
int hc_level(float t, vec3 d, vec3 ng, EyeGpu e) {
    float footprint = eye_cone(e, t).x * pc.lod_scale;
    if (!eye_is_ortho(e)) {
        float c = dot(d, e.fwd.xyz);
        footprint *= c * c;
    }
    if (hc_lod_normal()) footprint /= max(abs(dot(d, ng)), 1.0 / 16.0);
    return clamp(int(floor(log2(max(footprint, 1e-30)))), -24, 23);   // 60 nm .. 8 km
}

// Key of the (jittered) point p with geometric normal ng at `level`: the
// voxel and ng's signed major axis, so the two faces of a thin surface
// (ng faces the ray) never share an entry (as GI-1.0's and Gautron's keys
// hold the normal). Until session 52 the non-tiled key held no axis, and a
// double-sided sheet's underside, seen at the top's level, read the lit
// top's entries (an audit's finding; tests/hash_cache.rs
// `the_two_faces_of_a_sheet_keep_apart_entries`).
// Tiles: 4x4 voxels in the plane across that axis, the voxel's coordinate
// along it dropped within its tile.
void hc_key(vec3 p, vec3 ng, int level, out ivec3 coord, out uint meta) {
    // Clamped so the float → int conversion stays defined far from the origin.
    ivec3 v = ivec3(clamp(floor(p * exp2(float(-level))), vec3(-1073741824.0), vec3(1073741760.0)));
    vec3 a = abs(ng);
    uint axis = a.x >= a.y && a.x >= a.z ? 0u : (a.y >= a.z ? 1u : 2u);
    uint sgn = ng[axis] < 0.0 ? 1u : 0u;
    if (!hc_tiles()) {
        coord = v;
        meta = hc_pack_meta(level, 2u * axis + sgn, 0u, false);
        return;
    }
    uint u = (axis + 1u) % 3u, w = (axis + 2u) % 3u;
    uint local_offset = uint(v[u] & 3) + 4u * uint(v[w] & 3);
    coord = v >> 2;   // arithmetic shift: floor division by 4
    meta = hc_pack_meta(level, 2u * axis + sgn, local_offset, true);
}

// An orthonormal pair across n (Duff et al. 2017).
void hc_tangents(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

vec3 hc_hue(uint h) {
    return vec3(float(h & 255u), float((h >> 8) & 255u), float((h >> 16) & 255u)) / 255.0;
}
