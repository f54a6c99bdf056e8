// Memoized material-graph outputs in rendering (Urbach 2023, thesis §5-6;
// issue 17): material_at looks a hit's graph outputs up in one global table
// keyed by (material, level of detail, texel of the hit's uv), shared by
// both eyes and every method's passes; a miss evaluates the graphs at the
// texel centres and stores them (the thesis's non-tiled, tiled and
// bilinear variants: sc_material_graphs_at below). Compiled only into the run-time
// shaders of a scene whose graphs are memoized (-DSC_MATERIAL_MEMO,
// src/materials/scene_shaders.rs); the table's buffers are then bindings of
// the scene's set 0 (src/rt/gpu_scene.rs, MemoGpu).
#ifndef COMMON_MEMO_GLSL
#define COMMON_MEMO_GLSL
layout(set = SET_SCENE, binding = B_SCENE_MEMO_KEYS, std430) coherent buffer MemoKeys { uint memo_keys[]; };
#ifdef SC_MEMO_CLOCK_COUNTER
// The access clock (--memo-clock counter; memo/table.glsl): the 64-bit
// counter, then two 64-bit words per entry (stamp, version).
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#define MEMO_CLOCK_COUNTER
layout(set = SET_SCENE, binding = B_SCENE_MEMO_STAMPS, std430) coherent buffer MemoStamps { uint64_t memo_clock; uint64_t memo_times[]; };
#else
layout(set = SET_SCENE, binding = B_SCENE_MEMO_STAMPS, std430) coherent buffer MemoStamps { uint memo_stamps[]; };
#endif
layout(set = SET_SCENE, binding = B_SCENE_MEMO_VALUES, std430) coherent buffer MemoValues { uvec4 memo_values[]; };
// Parameters, then this frame's counters: src/materials/memo/state.rs.
layout(set = SET_SCENE, binding = B_SCENE_MEMO_STATE, std430) coherent buffer MemoState { uint memo_state[]; };
#include "memo/table.glsl"
#include "memo/lod.glsl"

const uint MEMO_S_NOW = 0u, MEMO_S_CAPACITY = 1u, MEMO_S_PROBE = 2u, MEMO_S_POLICY = 3u,
           MEMO_S_FLAGS = 4u, MEMO_S_BIAS = 5u, MEMO_S_TILE_SHIFT = 6u, MEMO_S_BILINEAR = 7u;
const uint MEMO_C_HITS = 8u, MEMO_C_MISSES = 9u, MEMO_C_FILLS = 10u, MEMO_C_EVICTIONS = 11u,
           MEMO_C_LOCK_FAILURES = 12u, MEMO_C_REFUSED = 13u, MEMO_C_BYPASSED = 14u,
           MEMO_C_SECOND_EYE_HITS = 15u, MEMO_C_SECOND_EYE_MISSES = 16u, MEMO_C_COOPERATIVE_FILLS = 17u,
           MEMO_C_WINDOW_FULL = 18u, MEMO_C_OTHER_EYE_HITS = 19u;
// Each counter's high word (its carries) sits MEMO_C_COUNT words after it:
// one frame of a long render (the reference's samples are chunked inside
// one frame) counts past 2^32 lookups at 1080p stereo from ~1,036 spp.
const uint MEMO_C_COUNT = 12u;

// Counter c plus one, carried into its high word on the wrap (the add that
// returns 2^32 − 1 is the one that wrapped; read after the frame, so the
// pair is consistent).
void memo_add(uint c) {
    if (atomicAdd(memo_state[c], 1u) == 0xFFFFFFFFu) atomicAdd(memo_state[c + MEMO_C_COUNT], 1u);
}

// The eye of the pass's current work item (0 left, 1 right, 2 unknown),
// set by each hit-shading pass where it knows it. Both eyes render in one
// dispatch with the eye in z; where the right eye's work groups run after
// the left eye's (llvmpipe; Vulkan does not order them) its hit rate
// measures what it reuses of the first eye's fills (thesis: the cache is
// view-independent, so the second eye shares it). The reuse between the
// eyes in any order is counted by the fill tags below.
uint sc_memo_eye = 2u;

// Each record's mask word (ScGraphOutputs.mask: which outputs the graphs
// bind, bits 0-5) carries above MEMO_MASK_BITS the tag of its fill: the
// filling lane's eye (bits 6-7: 0, 1, or 2 unknown) and the frame counter's
// low 24 bits (bits 8-31). A hit on a record the other eye filled in this
// frame is counted (MEMO_C_OTHER_EYE_HITS): the reuse between the eyes
// that the view-independent cache exists for, whatever order the device
// runs the eyes' work groups in (the second-eye counters above rely on
// llvmpipe's order). Frames 2^24 apart (52 h at 90 Hz) share a tag.
const uint MEMO_MASK_BITS = 63u;
uint memo_fill_tag() { return ((memo_state[MEMO_S_NOW] & 0xFFFFFFu) << 8) | (min(sc_memo_eye, 2u) << 6); }
// A hit on the record whose mask word is `w`: counted as the other eye's
// fill when both eyes are known, differ, and the fill is of this frame.
void memo_count_other_eye(uint w, uint now) {
    uint eye = (w >> 6) & 3u;
    if (sc_memo_eye < 2u && eye < 2u && eye != sc_memo_eye && (w >> 8) == (now & 0xFFFFFFu))
        memo_add(MEMO_C_OTHER_EYE_HITS);
}

// The ray-cone width at a secondary hit of path_radiance (thesis eqs.
// 2.10-2.12, grown along the path; its magnitude); < 0 where the caller has none: then
// secondary hits are evaluated directly.
float sc_memo_cone = -1.0;

// The cone of light samples taken from the current path vertex (if
// sc_memo_nee; else they are evaluated directly): the geometric pencil's
// signed width sc_memo_nee_w grown by sc_memo_nee_spread per unit distance
// to the sampled point, plus the roughness blur's width sc_memo_nee_blur_w
// grown by sc_memo_nee_blur_spread (memo_cone_at; integrator.glsl sets
// them around next-event estimation; lights.glsl sample_emitter reads them).
bool sc_memo_nee = false;
float sc_memo_nee_w = 0.0;
float sc_memo_nee_spread = 0.0;
float sc_memo_nee_blur_w = 0.0;
float sc_memo_nee_blur_spread = 0.0;

// The 12 record words: base colour, metallic, roughness, normal, emission, mask.
// `tag`: memo_fill_tag() of the lane that stores (of the round's leader in
// a cooperative fill, so a tile's texels carry one tag).
void memo_pack(ScGraphOutputs o, uint tag, out uvec4 r0, out uvec4 r1, out uvec4 r2) {
    r0 = uvec4(floatBitsToUint(o.base_color), floatBitsToUint(o.metallic));
    r1 = uvec4(floatBitsToUint(o.roughness), floatBitsToUint(o.normal));
    r2 = uvec4(floatBitsToUint(o.emission), (o.mask & MEMO_MASK_BITS) | tag);
}
// An unbound normal is the hit's own (the generated function's default),
// never the one stored with another hit.
ScGraphOutputs memo_unpack(uvec4 r0, uvec4 r1, uvec4 r2, vec3 normal) {
    ScGraphOutputs o;
    o.base_color = uintBitsToFloat(r0.xyz);
    o.metallic = uintBitsToFloat(r0.w);
    o.roughness = uintBitsToFloat(r1.x);
    o.normal = uintBitsToFloat(r1.yzw);
    o.emission = uintBitsToFloat(r2.xyz);
    o.mask = r2.w & MEMO_MASK_BITS;
    if ((o.mask & 40u) == 0u) o.normal = normal;
    return o;
}

// Texel k of a tiled entry e×e texels wide (e = s, or s + 1 with the
// bilinear overlap) in slot `sl` is the record at MEMO_RECORD·(sl·e² + k);
// non-tiled entries (e = 1) are table.glsl's layout.
void memo_read_texel(uint b, out uvec4 r0, out uvec4 r1, out uvec4 r2) {
    memoryBarrierBuffer();
    r0 = memo_values[b]; r1 = memo_values[b + 1u]; r2 = memo_values[b + 2u];
    memoryBarrierBuffer();
}
void memo_write_texel(uint b, uvec4 r0, uvec4 r1, uvec4 r2) {
    memo_values[b] = r0; memo_values[b + 1u] = r1; memo_values[b + 2u] = r2;
}

// A hit's counters (`w`: the record's mask word, with its fill tag).
void memo_count_hit_counters(uint w, uint now) {
    memo_add(MEMO_C_HITS);
    if (sc_memo_eye == 1u) memo_add(MEMO_C_SECOND_EYE_HITS);
    memo_count_other_eye(w, now);
}
// A tiled hit in slot `sl` (`w`: a texel's mask word): LRU's stamp and the
// counters.
void memo_count_hit(uint sl, uint policy, uint now, uint w) {
    if (policy == MEMO_LRU) memo_touch(sl, now);
    memo_count_hit_counters(w, now);
}

// A tiled miss is counted (memo_count_miss), then the victim of h1's
// window locked for the fill (memo_lock_victim: the table's memo_victim and
// memo_lock). memo_begin_fill does both; it returns the locked slot, or
// MEMO_NONE when the key is present already (`present`), no entry could be
// locked (`seen` = MEMO_LOCK) or, without eviction, the window is full
// (`seen` = MEMO_EMPTY): the lane then evaluates for itself and stores
// nothing.
void memo_count_miss() {
    memo_add(MEMO_C_MISSES);
    if (sc_memo_eye == 1u) memo_add(MEMO_C_SECOND_EYE_MISSES);
}
uint memo_lock_victim(uint h0, uint h1, uint cap, uint probe, uint policy, uint now,
                      out uint seen, out bool present) {
    uint victim = memo_victim(h0, h1, cap, probe, policy, now, seen, present);
    if (present || victim == MEMO_NONE) return MEMO_NONE;
    if (!memo_lock(victim, seen)) { seen = MEMO_LOCK; return MEMO_NONE; }
    memoryBarrierBuffer();
    return victim;
}
uint memo_begin_fill(uint h0, uint h1, uint cap, uint probe, uint policy, uint now,
                     out uint seen, out bool present) {
    memo_count_miss();
    return memo_lock_victim(h0, h1, cap, probe, policy, now, seen, present);
}

// After the records are written: unlock (stamp, then the key) and count.
void memo_end_fill(uint victim, uint h1, uint now, uint seen, bool present) {
    if (victim != MEMO_NONE) {
        memo_unlock(victim, h1, now);
        memo_add(seen == MEMO_EMPTY ? MEMO_C_FILLS : MEMO_C_EVICTIONS);
    } else if (!present) {
        memo_add(seen == MEMO_LOCK ? MEMO_C_LOCK_FAILURES : MEMO_C_WINDOW_FULL);
    }
}

ScGraphOutputs memo_lerp(ScGraphOutputs a, ScGraphOutputs b, float f) {
    ScGraphOutputs o = a;
    o.base_color = mix(a.base_color, b.base_color, f);
    o.metallic = mix(a.metallic, b.metallic, f);
    o.roughness = mix(a.roughness, b.roughness, f);
    o.normal = mix(a.normal, b.normal, f);
    o.emission = mix(a.emission, b.emission, f);
    return o;
}

// The variants of one call (the table's state: --memo-tile, --memo-bilinear).
const uint MEMO_V_DIRECT = 0u,          // not memoized here: evaluated at the hit
           MEMO_V_TEXEL = 1u,           // non-tiled: the nearest texel, centre-snapped
           MEMO_V_TEXELS = 2u,          // non-tiled bilinear: four texels, four lookups
           MEMO_V_TILE = 3u,            // tiled: s×s texels an entry, the nearest texel
           MEMO_V_TILE_BILINEAR = 4u;   // tiled bilinear: (s+1)² texels an entry

// Corner k of a bilinear footprint: q0 + MEMO_CORNER[k] (c00, c10, c01, c11).
const uvec2 MEMO_CORNER[4] = uvec2[4](uvec2(0u, 0u), uvec2(1u, 0u), uvec2(0u, 1u), uvec2(1u, 1u));

// One call of sc_material_graphs_at: its lookups' results and what is
// left to evaluate.
struct MemoCall {
    uint variant;
    bool tiled, bilinear;
    uint corners;         // texels the result reads: 1, or 4 (bilinear)
    int level;
    ivec2 q;              // the nearest texel, or the bilinear footprint's q0
    vec2 f;               // the bilinear weights
    uint cap, probe, policy, now, shift;
    uint count;           // evaluations left (unmemoized: one, at the hit)
    uint missing;         // non-tiled: the corners to fill, a bit each
    ivec2 tq, o;          // tiled: the tile, and q's texel in it
    uint e;               // tiled: texels an entry edge (s, or s + 1 bilinear)
    uint h1, victim, seen;   // tiled: the tile key's H1, the locked entry
    bool present;
    uint key;             // tiled: the tile's key (material, tile size, bilinear)
    bool need;            // tiled, cooperative fill: the tile was missing
};

// The variant of a hit (primary: the caller's cone_width > 0; secondary:
// path_radiance's sc_memo_cone ≥ 0; memoized only where the material's
// graphs read the uv alone, else counted bypassed), its level of detail,
// texel and the table's parameters.
MemoCall memo_call(uint material, vec2 uv, float cone_width, float uv_per_width) {
    MemoCall c;
    uint flags = memo_state[MEMO_S_FLAGS];
    bool primary = cone_width > 0.0;
    bool use = primary ? (flags & 1u) != 0u : ((flags & 2u) != 0u && sc_memo_cone >= 0.0);
    c.shift = memo_state[MEMO_S_TILE_SHIFT];
    c.variant = MEMO_V_DIRECT;
    if (use) {
        if (sc_material_memoizable(material)) {
            bool bilinear = memo_state[MEMO_S_BILINEAR] != 0u;
            c.variant = c.shift > 0u ? (bilinear ? MEMO_V_TILE_BILINEAR : MEMO_V_TILE)
                                     : (bilinear ? MEMO_V_TEXELS : MEMO_V_TEXEL);
        } else {
            memo_add(MEMO_C_BYPASSED);
        }
    }
    c.tiled = c.variant == MEMO_V_TILE || c.variant == MEMO_V_TILE_BILINEAR;
    c.bilinear = c.variant == MEMO_V_TEXELS || c.variant == MEMO_V_TILE_BILINEAR;
    c.corners = c.bilinear ? 4u : 1u;
    c.count = 1u;
    c.level = 0;
    c.q = ivec2(0);
    c.f = vec2(0.0);
    c.cap = 0u; c.probe = 0u; c.policy = 0u; c.now = 0u;
    c.missing = 0u;
    c.tq = ivec2(0); c.o = ivec2(0);
    c.e = 1u;
    c.h1 = 0u; c.victim = MEMO_NONE; c.seen = 0u;
    c.present = false;
    c.key = 0u;
    c.need = false;
    if (c.variant == MEMO_V_DIRECT) return c;
    float w = primary ? cone_width : sc_memo_cone;
    c.level = memo_level(w, uv_per_width, uintBitsToFloat(memo_state[MEMO_S_BIAS]));
    if (!memo_fits(uv, c.level)) {
        // Level m's grid cannot hold this uv (lod.glsl memo_fits): the
        // graph is evaluated at the hit, as for a material that is not
        // memoizable, and counted with those.
        memo_add(MEMO_C_BYPASSED);
        c.variant = MEMO_V_DIRECT;
        c.tiled = false;
        c.bilinear = false;
        c.corners = 1u;
        c.level = 0;
        return c;
    }
    c.cap = memo_state[MEMO_S_CAPACITY];
    c.probe = memo_state[MEMO_S_PROBE];
    c.policy = memo_state[MEMO_S_POLICY];
    c.now = memo_state[MEMO_S_NOW];
    if (c.bilinear) {
        // In texel space X = 2^m uv the centres are the integers.
        vec2 x = ldexp(uv, ivec2(c.level));
        vec2 fl = floor(clamp(x, vec2(-1073741824.0), vec2(1073741760.0)));
        c.f = x - fl;
        c.q = ivec2(fl);
    } else {
        c.q = memo_quantise(uv, c.level);
    }
    return c;
}

// Non-tiled lookups, one per corner: a hit's record goes to out4[k], a
// miss is left to the evaluation loop (bit k of `missing`). All four
// corners are looked up before any is filled (the former code filled each
// before looking the next up): where two corners' probe windows overlap,
// a fill may now evict a corner already read, so the counters can differ
// in rare cases; the values cannot.
void memo_lookup_texels(inout MemoCall c, uint material, vec3 n, inout ScGraphOutputs out4[4]) {
    for (uint k = 0u; k < c.corners; ++k) {
        ivec2 qk = c.q + ivec2(MEMO_CORNER[k]);
        uvec4 r0, r1, r2;
        bool torn;
        if (memo_find(memo_h0(material, c.level, qk), memo_h1(material, c.level, qk), c.cap, c.probe, true,
                      c.policy, c.now, r0, r1, r2, torn) != MEMO_NONE) {
            memo_count_hit_counters(r2.w, c.now);   // (memo_find stamped it for LRU)
            out4[k] = memo_unpack(r0, r1, r2, n);
        } else {
            memo_count_miss();
            if (torn) memo_add(MEMO_C_REFUSED);
            c.missing |= 1u << k;
        }
    }
    c.count = uint(bitCount(c.missing));
}

// The record index in a tile of the texel corner k reads.
uint memo_tile_texel(MemoCall c, uint k) {
    return (uint(c.o.y) + MEMO_CORNER[k].y) * c.e + uint(c.o.x) + MEMO_CORNER[k].x;
}

// A tiled lookup: the tile's key; a hit reads the texels it needs between
// the two key reads. A miss locks a victim for the evaluation loop (the
// plain fill), or is marked `need` for the subgroup's rounds (MemoRound).
void memo_lookup_tile(inout MemoCall c, uint material, vec3 n, inout ScGraphOutputs out4[4]) {
    uint s = 1u << c.shift;
    c.e = c.bilinear ? s + 1u : s;
    c.tq = c.q >> int(c.shift);                    // floor division by s (arithmetic shift)
    c.o = c.q - (c.tq << int(c.shift));            // q's texel within the tile, in [0, s)
    // Tiles, texels and bilinear tiles never share a key.
    uint key = material | (c.shift << 28) | (c.bilinear ? 1u << 27 : 0u);
    uint h0 = memo_h0(key, c.level, c.tq);
    c.h1 = memo_h1(key, c.level, c.tq);
    bool found = false;
    for (uint i = 0u; i < c.probe; ++i) {
        uint sl = memo_slot(h0, i, c.cap, c.probe);
        if (memo_keys[sl] != c.h1) continue;
        uint v0 = memo_version(sl);
        uint w = 0u;   // the mask word of a texel read (one fill wrote them all)
        for (uint k = 0u; k < c.corners; ++k) {
            uvec4 r0, r1, r2;
            memo_read_texel(MEMO_RECORD * (sl * c.e * c.e + memo_tile_texel(c, k)), r0, r1, r2);
            out4[k] = memo_unpack(r0, r1, r2, n);
            w = r2.w;
        }
        if (memo_validate(sl, c.h1, v0, true)) {
            memo_count_hit(sl, c.policy, c.now, w);
            found = true;
        } else {
            memo_add(MEMO_C_REFUSED);
        }
        break;
    }
#ifdef SC_MEMO_SUBGROUP
    // Filled by the subgroup's rounds (memo_round_begin).
    c.key = key;
    c.need = !found;
    c.count = 0u;
#else
    if (!found) c.victim = memo_begin_fill(h0, c.h1, c.cap, c.probe, c.policy, c.now, c.seen, c.present);
    // Without a locked entry (every one in the window locked, or the tile
    // arrived since the lookup) nothing is stored: only the texels this call
    // reads are evaluated (memo_fill_texel), not the whole tile.
    c.count = found ? 0u : (c.victim != MEMO_NONE ? c.e * c.e : c.corners);
#endif
}

#ifdef SC_MEMO_SUBGROUP
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
// The lane of the j-th set bit of ballot `act`.
uint memo_nth_lane(uvec4 act, uint j) {
    for (uint w = 0u; w < 4u; ++w) {
        uint c = uint(bitCount(act[w]));
        if (j < c) {
            uint m = act[w];
            for (uint k = 0u; k < j; ++k) m &= m - 1u;   // clear the lowest j set bits
            return 32u * w + uint(findLSB(m));
        }
        j -= c;
    }
    return 0u;
}

// The subgroup-cooperative tile fill (thesis §5.4.3, Fig. 5.2), for the
// tiled variants; compiled in where the device has subgroup ballot and
// shuffle (-DSC_MEMO_SUBGROUP, scene_shaders.rs). Every lane that calls
// sc_material_graphs_at takes part, whatever its own variant (a lane whose
// tile was missing has `need`). Each round: the lowest requesting lane
// leads (ballot); it broadcasts its tile (material key, level, tile
// position) and locks a victim entry; the active lanes evaluate the tile's
// e² texels, lane of rank r texel r, r + n, … (n active lanes), in the one
// evaluation loop of sc_material_graphs_at; each writes its texels under
// the leader's lock; the lanes that requested this tile read the texels
// they need (memo_tile_texel) from the lanes that evaluated them (shuffle,
// thesis step 8: also when no lock was obtained); after a buffer barrier
// the leader unlocks and counts. Rounds run until no lane needs a tile,
// before any lane's own evaluations. Deviation: one tile per round (the
// thesis pairs tiles of one material when two fit a 32-lane wave;
// lavapipe's subgroups have 8 lanes, fewer than a 4×4 tile's texels).
struct MemoRound {
    bool running;         // a round is under way (the same in every lane)
    uvec4 act;            // the lanes taking part
    uint n_act, rank;
    uint e, corners;      // the table's texels an entry edge, texels a lookup reads
    bool lead, mine;      // this lane leads; this lane requested the round's tile
    uint mat, h1;
    int level;
    ivec2 tq;
    uint victim, seen;    // the locked entry (the leader's, broadcast)
    bool present;
    uint tag;             // the leader's fill tag (memo_fill_tag), broadcast: a
                          // subgroup may mix both eyes' lanes (a shade list)
    uint base;            // the round's first texel of this step
};

// Starts the next round, or ends the rounds (`running` false) when no lane
// needs a tile.
void memo_round_next(inout MemoRound r, MemoCall c) {
    uvec4 req = subgroupBallot(c.need);
    r.running = any(notEqual(req, uvec4(0u)));
    if (!r.running) return;
    uint leader = subgroupBallotFindLSB(req);
    r.lead = gl_SubgroupInvocationID == leader;
    uint key = subgroupShuffle(c.key, leader);
    r.tag = subgroupShuffle(memo_fill_tag(), leader);
    r.level = subgroupShuffle(c.level, leader);
    r.tq = subgroupShuffle(c.tq, leader);
    r.mine = c.need && c.key == key && c.level == r.level && all(equal(c.tq, r.tq));
    r.h1 = memo_h1(key, r.level, r.tq);
    r.seen = 0u;
    r.present = false;
    uint victim = MEMO_NONE;
    if (r.lead)
        victim = memo_lock_victim(memo_h0(key, r.level, r.tq), r.h1, c.cap, c.probe, c.policy, c.now, r.seen,
                                  r.present);
    r.victim = subgroupShuffle(victim, leader);
    r.mat = key & 0x07FFFFFFu;
    r.base = 0u;
}

MemoRound memo_round_begin(MemoCall c) {
    MemoRound r;
    if (c.need) memo_count_miss();
    r.act = subgroupBallot(true);
    r.n_act = subgroupBallotBitCount(r.act);
    r.rank = subgroupBallotExclusiveBitCount(r.act);
    // From the table's state, so the same in every lane whatever its variant.
    bool bilinear = memo_state[MEMO_S_BILINEAR] != 0u;
    uint s = 1u << c.shift;
    r.e = bilinear ? s + 1u : s;
    r.corners = bilinear ? 4u : 1u;
    r.lead = false;
    r.mine = false;
    memo_round_next(r, c);
    return r;
}

// This lane's texel of the round's current step: whether it has one, and
// where it is evaluated.
bool memo_round_texel(MemoRound r, uint shift, out vec2 at) {
    uint k = r.base + r.rank;
    at = memo_snapped_uv((r.tq << int(shift)) + ivec2(int(k % r.e), int(k / r.e)), r.level);
    return k < r.e * r.e;
}

// After the step's evaluation `v` (where `evaluated`): writes it under the
// leader's lock, hands the requesting lanes the texels they read, and ends
// the round after its last texel.
void memo_round_step(inout MemoRound r, inout MemoCall c, bool evaluated, ScGraphOutputs v, vec3 n,
                     inout ScGraphOutputs out4[4]) {
    uint k = r.base + r.rank;
    uvec4 r0 = uvec4(0u), r1 = uvec4(0u), r2 = uvec4(0u);
    if (evaluated) {
        memo_pack(v, r.tag, r0, r1, r2);
        if (r.victim != MEMO_NONE) memo_write_texel(MEMO_RECORD * (r.victim * r.e * r.e + k), r0, r1, r2);
    }
    for (uint j = 0u; j < r.corners; ++j) {
        uint want = memo_tile_texel(c, j);
        bool here = r.mine && want >= r.base && want < r.base + r.n_act;
        uint src = memo_nth_lane(r.act, here ? want - r.base : 0u);
        uvec4 a0 = subgroupShuffle(r0, src), a1 = subgroupShuffle(r1, src), a2 = subgroupShuffle(r2, src);
        if (here) out4[j] = memo_unpack(a0, a1, a2, n);
    }
    r.base += r.n_act;
    if (r.base < r.e * r.e) return;
    // Every lane's records are written (and visible) before the key returns.
    memoryBarrierBuffer();
    subgroupBallot(true);
    if (r.lead) {
        memo_end_fill(r.victim, r.h1, c.now, r.seen, r.present);
        memo_add(MEMO_C_COOPERATIVE_FILLS);
    }
    if (r.mine) c.need = false;
    memo_round_next(r, c);
}
#endif

// The tile index of the k-th evaluation of a tiled miss: k, or where no
// entry was locked (nothing is stored) the k-th texel the call reads.
uint memo_fill_texel(MemoCall c, uint k) {
    return c.tiled && c.victim == MEMO_NONE ? memo_tile_texel(c, k) : k;
}

// Where the k-th evaluation happens: the hit itself (unmemoized), the next
// missing corner (non-tiled: taken off `missing`, so the loop must call this
// once for k = 0, 1, … in order; its index in `corner`), or texel k of the
// tile, at the texel's centre.
vec2 memo_evaluation_uv(inout MemoCall c, uint k, vec2 uv, out ivec2 texel, out uint corner) {
    corner = 0u;
    texel = ivec2(0);
    if (c.variant == MEMO_V_DIRECT) return uv;
    if (c.tiled) {
        texel = (c.tq << int(c.shift)) + ivec2(int(k % c.e), int(k / c.e));
    } else {
        corner = uint(findLSB(c.missing));
        c.missing &= c.missing - 1u;
        texel = c.q + ivec2(MEMO_CORNER[corner]);
    }
    return memo_snapped_uv(texel, c.level);
}

// Stores the k-th evaluation `v` and keeps what the result reads: into
// the tile under the lock, or inserted as its own texel (the value kept is
// the one stored, so a hit and a miss of one texel shade alike).
void memo_store(MemoCall c, uint material, uint k, ivec2 texel, uint corner, ScGraphOutputs v, vec3 n,
                inout ScGraphOutputs out4[4]) {
    uvec4 r0, r1, r2;
    memo_pack(v, memo_fill_tag(), r0, r1, r2);
    if (c.tiled) {
        if (c.victim != MEMO_NONE) memo_write_texel(MEMO_RECORD * (c.victim * c.e * c.e + k), r0, r1, r2);
        // The texels this call reads: q's (nearest), or the 2×2 from q0.
        ivec2 d = ivec2(int(k % c.e), int(k / c.e)) - c.o;
        if (all(greaterThanEqual(d, ivec2(0))) && all(lessThanEqual(d, ivec2(c.bilinear ? 1 : 0))))
            out4[uint(d.y) * 2u + uint(d.x)] = memo_unpack(r0, r1, r2, n);
        return;
    }
    uint res = memo_insert(memo_h0(material, c.level, texel), memo_h1(material, c.level, texel), c.cap,
                           c.probe, c.policy, c.now, r0, r1, r2);
    if (res == MEMO_FILLED) memo_add(MEMO_C_FILLS);
    else if (res == MEMO_EVICTED) memo_add(MEMO_C_EVICTIONS);
    else if (res == MEMO_LOCK_FAILED) memo_add(MEMO_C_LOCK_FAILURES);
    else if (res == MEMO_WINDOW_FULL) memo_add(MEMO_C_WINDOW_FULL);
    out4[corner] = memo_unpack(r0, r1, r2, n);
}

// The graph outputs at a hit, through the cache where this kind of hit is
// memoized and the material's graphs read only the uv, else evaluated at
// the hit. `footprint`: the uv width a direct evaluation stands for
// (material.glsl graph_footprint); a texel of level m stands for 2^-m.
//
// The variants (thesis §5.3):
// - non-tiled (one texel an entry): texel q's outputs from the table, or
//   evaluated at its centre and stored on a miss;
// - non-tiled bilinear: the four texel centres around X = 2^m uv, each
//   looked up (a hit or a fill), blended;
// - tiled (s×s texels an entry, nearest texel): the key is the tile's; a
//   hit reads its one texel between the two key reads; a miss locks a
//   victim entry and evaluates the whole tile at its texel centres (the
//   plain fill: one lane, s² evaluations; or the subgroup's lanes together,
//   MemoRound) and stores it under the lock;
// - tiled bilinear (tiles with a one-texel overlap): the footprint is
//   texels q0 = floor(X) and q0 + 1, in the tile of q0, whose (s+1)²
//   records cover its s² texels and the next tile's first row and column;
//   a hit reads the four records between the two key reads, a miss fills
//   the (s+1)² centres.
//
// First every lookup, then one loop over the texels to evaluate (or the
// hit itself, unmemoized): the graph switch, tens of nodes per graph, is
// compiled in once per call site whatever the variant (a switch inlined
// for each variant and corner made the heavy library's shaders too large
// to compile), and the trip count is known only at run time, so it is not
// unrolled either. The subgroup-cooperative fill (-DSC_MEMO_SUBGROUP)
// evaluates its rounds' texels in the same loop, before the lane's own
// evaluations: one copy per call site in that build too (a second copy in
// the rounds made the procedural-heavy Sponza's path tracer exceed
// SPIR-V's id bound in glslc's optimizer).
ScGraphOutputs sc_material_graphs_at(uint material, uint instance, vec2 uv, vec2 uv2, mat2 uv2_per_uv, vec3 p, vec3 n, vec3 t, float ts,
                                     float cone_width, float uv_per_width, float footprint) {
    MemoCall c = memo_call(material, uv, cone_width, uv_per_width);
    ScGraphOutputs out4[4];
    if (c.variant == MEMO_V_TEXEL || c.variant == MEMO_V_TEXELS) memo_lookup_texels(c, material, n, out4);
    else if (c.tiled) memo_lookup_tile(c, material, n, out4);
#ifdef SC_MEMO_SUBGROUP
    MemoRound r = memo_round_begin(c);
#endif
    for (uint k = 0u;;) {
#ifdef SC_MEMO_SUBGROUP
        bool round = r.running;   // the same in every lane
#else
        const bool round = false;
#endif
        if (!round && k >= c.count) break;
        uint mat = material;
        vec2 at;
        float fp;
        ivec2 texel = ivec2(0);
        uint corner = 0u;
        bool evaluate = true;
#ifdef SC_MEMO_SUBGROUP
        if (round) {
            evaluate = memo_round_texel(r, c.shift, at);
            mat = r.mat;
            fp = memo_texel_width(r.level);
        } else
#endif
        {
            at = memo_evaluation_uv(c, memo_fill_texel(c, k), uv, texel, corner);
            fp = c.variant == MEMO_V_DIRECT ? footprint : memo_texel_width(c.level);
        }
        ScGraphOutputs v = ScGraphOutputs(vec3(0.0), 0.0, 0.0, vec3(0.0), vec3(0.0), 0u);
        // uv2 is the lane's own: memoizable materials read neither the
        // second channel nor set 1 (scene_shaders.rs), the others are
        // evaluated at their own uv (MEMO_V_DIRECT).
        if (evaluate) v = sc_material_graphs(mat, instance, at, uv2, uv2_per_uv, p, n, t, ts, fp);
#ifdef SC_MEMO_SUBGROUP
        if (round) {
            memo_round_step(r, c, evaluate, v, n, out4);
        } else
#endif
        {
            if (c.variant == MEMO_V_DIRECT) out4[0] = v;
            else memo_store(c, material, memo_fill_texel(c, k), texel, corner, v, n, out4);
            ++k;
        }
    }
    if (c.tiled && c.count > 0u) memo_end_fill(c.victim, c.h1, c.now, c.seen, c.present);
    if (c.bilinear) return memo_lerp(memo_lerp(out4[0], out4[1], c.f.x), memo_lerp(out4[2], out4[3], c.f.x), c.f.y);
    return out4[0];
}
#endif
