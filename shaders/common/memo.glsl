// Memoized material-graph outputs in rendering (Urbach 2023, thesis §5-6;
// issue 17): material_at looks a hit's graph outputs up in one global table
// keyed by (material, level of detail, texel of the hit's uv), shared by
// both eyes and every method's passes; a miss evaluates the graphs at the
// texel centre (nearest-neighbour with texel-centre snapping, the thesis's
// non-tiled variant) and stores them. Compiled only into the run-time
// shaders of a scene whose graphs are memoized (-DSC_MATERIAL_MEMO,
// src/materials/scene_shaders.rs); the table's buffers are then bindings of
// the scene's set 0 (src/rt/gpu_scene.rs, MemoGpu).
#ifndef COMMON_MEMO_GLSL
#define COMMON_MEMO_GLSL
layout(set = SET_SCENE, binding = B_SCENE_MEMO_KEYS, std430) coherent buffer MemoKeys { uint memo_keys[]; };
layout(set = SET_SCENE, binding = B_SCENE_MEMO_STAMPS, std430) coherent buffer MemoStamps { uint memo_stamps[]; };
layout(set = SET_SCENE, binding = B_SCENE_MEMO_VALUES, std430) coherent buffer MemoValues { uvec4 memo_values[]; };
// Parameters, then this frame's counters: src/materials/memo/state.rs.
layout(set = SET_SCENE, binding = B_SCENE_MEMO_STATE, std430) coherent buffer MemoState { uint memo_state[]; };
#include "memo/table.glsl"
#include "memo/lod.glsl"

const uint MEMO_S_NOW = 0u, MEMO_S_CAPACITY = 1u, MEMO_S_PROBE = 2u, MEMO_S_POLICY = 3u,
           MEMO_S_FLAGS = 4u, MEMO_S_BIAS = 5u, MEMO_S_TILE_SHIFT = 6u, MEMO_S_BILINEAR = 7u;
const uint MEMO_C_HITS = 8u, MEMO_C_MISSES = 9u, MEMO_C_FILLS = 10u, MEMO_C_EVICTIONS = 11u,
           MEMO_C_LOCK_FAILURES = 12u, MEMO_C_REFUSED = 13u, MEMO_C_BYPASSED = 14u,
           MEMO_C_SECOND_EYE_HITS = 15u, MEMO_C_SECOND_EYE_MISSES = 16u, MEMO_C_COOPERATIVE_FILLS = 17u;

// The eye of the pass's current work item (0 left, 1 right, 2 unknown),
// set by each hit-shading pass where it knows it. Both eyes render in one
// dispatch with the eye in z, so the right eye's work groups run after the
// left eye's: the right eye is the second eye, and its hit rate measures
// what it reuses of the first eye's fills (thesis: the cache is
// view-independent, so the second eye shares it).
uint sc_memo_eye = 2u;

// The ray-cone width at a secondary hit of path_radiance (thesis eqs.
// 2.10-2.11, grown along the path); < 0 where the caller has none: then
// secondary hits are evaluated directly.
float sc_memo_cone = -1.0;

// The cone of light samples taken from the current path vertex: width
// sc_memo_nee_w (< 0: none, evaluate directly) grown by sc_memo_nee_spread
// per unit distance to the sampled point (integrator.glsl sets them around
// next-event estimation; lights.glsl sample_emitter reads them).
float sc_memo_nee_w = -1.0;
float sc_memo_nee_spread = 0.0;

// The 12 record words: base colour, metallic, roughness, normal, emission, mask.
void memo_pack(ScGraphOutputs o, out uvec4 r0, out uvec4 r1, out uvec4 r2) {
    r0 = uvec4(floatBitsToUint(o.base_color), floatBitsToUint(o.metallic));
    r1 = uvec4(floatBitsToUint(o.roughness), floatBitsToUint(o.normal));
    r2 = uvec4(floatBitsToUint(o.emission), o.mask);
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
    o.mask = r2.w;
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

// A tiled hit in slot `sl`: LRU's stamp and the counters.
void memo_count_hit(uint sl, uint policy, uint now) {
    if (policy == MEMO_LRU && memo_stamps[memo_stamp_at(sl)] != now) memo_stamps[memo_stamp_at(sl)] = now;
    atomicAdd(memo_state[MEMO_C_HITS], 1u);
    if (sc_memo_eye == 1u) atomicAdd(memo_state[MEMO_C_SECOND_EYE_HITS], 1u);
}

// A tiled miss: counted, then the victim of h1's window locked for the
// fill (the table's memo_victim and memo_lock). Returns the locked slot, or
// MEMO_NONE when the key is present already (`present`) or no entry could
// be locked: the lane then evaluates for itself and stores nothing.
void memo_count_miss() {
    atomicAdd(memo_state[MEMO_C_MISSES], 1u);
    if (sc_memo_eye == 1u) atomicAdd(memo_state[MEMO_C_SECOND_EYE_MISSES], 1u);
}
uint memo_lock_victim(uint h0, uint h1, uint cap, uint probe, uint policy, uint now,
                      out uint seen, out bool present) {
    uint victim = memo_victim(h0, h1, cap, probe, policy, now, seen, present);
    if (present || victim == MEMO_NONE || !memo_lock(victim, seen)) return MEMO_NONE;
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
        atomicAdd(memo_state[seen == MEMO_EMPTY ? MEMO_C_FILLS : MEMO_C_EVICTIONS], 1u);
    } else if (!present) {
        atomicAdd(memo_state[MEMO_C_LOCK_FAILURES], 1u);
    }
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
// shuffle (-DSC_MEMO_SUBGROUP, scene_shaders.rs). Every lane that looked a
// tile up calls it, hit or miss (`need`: this lane's tile was missing), so
// lanes that hit still evaluate texels. Each round: the lowest requesting
// lane leads (ballot); it broadcasts its tile (material key, level, tile
// position) and locks a victim entry; the active lanes evaluate the tile's
// e² texels, lane of rank r texel r, r + n, … (n active lanes); each writes
// its texels under the leader's lock; the lanes that requested this tile
// read the texels they need (`want[0..cnt)`) from the lanes that evaluated
// them (shuffle, thesis step 8: also when no lock was obtained); after a
// buffer barrier the leader unlocks and counts. Deviation: one tile per
// round (the thesis pairs tiles of one material when two fit a 32-lane
// wave; lavapipe's subgroups have 8 lanes, fewer than a 4×4 tile's texels).
void memo_fill_cooperative(bool need, uint key, int level, ivec2 tq, uint shift, uint e,
                           uint want[4], uint cnt, vec3 p, vec3 n, vec3 t,
                           uint cap, uint probe, uint policy, uint now, inout ScGraphOutputs c[4]) {
    if (need) memo_count_miss();
    // A subgroup whose lanes all hit (the common case) pays one ballot.
    uvec4 req = subgroupBallot(need);
    if (all(equal(req, uvec4(0u)))) return;
    uvec4 act = subgroupBallot(true);
    uint n_act = subgroupBallotBitCount(act);
    uint rank = subgroupBallotExclusiveBitCount(act);
    for (;;) {
        if (all(equal(req, uvec4(0u)))) break;
        uint leader = subgroupBallotFindLSB(req);
        bool lead = gl_SubgroupInvocationID == leader;
        uint l_key = subgroupShuffle(key, leader);
        int l_level = subgroupShuffle(level, leader);
        ivec2 l_tq = subgroupShuffle(tq, leader);
        bool mine = need && key == l_key && level == l_level && all(equal(tq, l_tq));
        uint l_h1 = memo_h1(l_key, l_level, l_tq);
        uint seen = 0u;
        bool present = false;
        uint victim = MEMO_NONE;
        if (lead) victim = memo_lock_victim(memo_h0(l_key, l_level, l_tq), l_h1, cap, probe, policy, now, seen, present);
        victim = subgroupShuffle(victim, leader);
        uint l_mat = l_key & 0x07FFFFFFu;
        uvec4 g0[4], g1[4], g2[4];
        for (uint base = 0u; base < e * e; base += n_act) {
            uint k = base + rank;
            uvec4 r0 = uvec4(0u), r1 = uvec4(0u), r2 = uvec4(0u);
            if (k < e * e) {
                ivec2 tk = (l_tq << int(shift)) + ivec2(int(k % e), int(k / e));
                ScGraphOutputs v = sc_material_graphs(l_mat, memo_snapped_uv(tk, l_level), p, n, t, memo_texel_width(l_level));
                memo_pack(v, r0, r1, r2);
                if (victim != MEMO_NONE) memo_write_texel(MEMO_RECORD * (victim * e * e + k), r0, r1, r2);
            }
            for (uint j = 0u; j < cnt; ++j) {
                bool here = mine && want[j] >= base && want[j] < base + n_act;
                uint src = memo_nth_lane(act, here ? want[j] - base : 0u);
                uvec4 a0 = subgroupShuffle(r0, src), a1 = subgroupShuffle(r1, src), a2 = subgroupShuffle(r2, src);
                if (here) { g0[j] = a0; g1[j] = a1; g2[j] = a2; }
            }
        }
        // Every lane's records are written (and visible) before the key returns.
        memoryBarrierBuffer();
        subgroupBallot(true);
        if (lead) {
            memo_end_fill(victim, l_h1, now, seen, present);
            atomicAdd(memo_state[MEMO_C_COOPERATIVE_FILLS], 1u);
        }
        if (mine) {
            for (uint j = 0u; j < cnt; ++j) c[j] = memo_unpack(g0[j], g1[j], g2[j], n);
            need = false;
        }
        req = subgroupBallot(need);
    }
}
#endif

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

// The graph outputs at a hit, through the cache where this kind of hit is
// memoized (primary: the caller's cone_width > 0; secondary: path_radiance's
// sc_memo_cone ≥ 0) and the material's graphs read only the uv, else
// evaluated at the hit. `footprint`: the uv width a direct evaluation
// stands for (material.glsl graph_footprint); a texel of level m stands
// for 2^-m.
//
// The variants (thesis §5.3):
// - non-tiled (one texel an entry): texel q's outputs from the table, or
//   evaluated at its centre and stored on a miss; the value returned is the
//   one stored, so a hit and a miss of one texel shade alike;
// - non-tiled bilinear: the four texel centres around X = 2^m uv, each
//   looked up (a hit or a fill), blended;
// - tiled (s×s texels an entry, nearest texel): the key is the tile's; a
//   hit reads its one texel between the two key reads; a miss locks a
//   victim entry and evaluates the whole tile at its texel centres (the
//   plain fill: one lane, s² evaluations; or the subgroup's lanes together,
//   memo_fill_cooperative) and stores it under the lock;
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
// unrolled either.
ScGraphOutputs sc_material_graphs_at(uint material, vec2 uv, vec3 p, vec3 n, vec3 t,
                                     float cone_width, float uv_area_ratio, float footprint) {
    uint flags = memo_state[MEMO_S_FLAGS];
    bool primary = cone_width > 0.0;
    bool use = primary ? (flags & 1u) != 0u : ((flags & 2u) != 0u && sc_memo_cone >= 0.0);
    uint variant = MEMO_V_DIRECT;
    uint shift = memo_state[MEMO_S_TILE_SHIFT];
    if (use) {
        if (sc_material_memoizable(material)) {
            bool bilinear = memo_state[MEMO_S_BILINEAR] != 0u;
            variant = shift > 0u ? (bilinear ? MEMO_V_TILE_BILINEAR : MEMO_V_TILE)
                                 : (bilinear ? MEMO_V_TEXELS : MEMO_V_TEXEL);
        } else {
            atomicAdd(memo_state[MEMO_C_BYPASSED], 1u);
        }
    }
    bool tiled = variant == MEMO_V_TILE || variant == MEMO_V_TILE_BILINEAR;
    bool bilinear = variant == MEMO_V_TEXELS || variant == MEMO_V_TILE_BILINEAR;
    uint corners = bilinear ? 4u : 1u;
    // Corner k of the bilinear footprint: q0 + ko[k] (c00, c10, c01, c11).
    uvec2 ko[4] = uvec2[4](uvec2(0u, 0u), uvec2(1u, 0u), uvec2(0u, 1u), uvec2(1u, 1u));
    ScGraphOutputs c[4];
    uint count = 1u;      // evaluations this call makes (unmemoized: one, at the hit)
    int level = 0;
    ivec2 q = ivec2(0);   // the nearest texel, or the bilinear footprint's q0
    vec2 f = vec2(0.0);   // the bilinear weights
    uint cap = 0u, probe = 0u, policy = 0u, now = 0u;
    uint missing = 0u;    // non-tiled: the corners to fill
    ivec2 tq = ivec2(0), o = ivec2(0);   // tiled: the tile, and q's texel in it
    uint e = 1u, h1 = 0u, victim = MEMO_NONE, seen = 0u;
    bool present = false;
    if (variant != MEMO_V_DIRECT) {
        float w = primary ? cone_width : sc_memo_cone;
        level = memo_level(w, uv_area_ratio, uintBitsToFloat(memo_state[MEMO_S_BIAS]));
        cap = memo_state[MEMO_S_CAPACITY];
        probe = memo_state[MEMO_S_PROBE];
        policy = memo_state[MEMO_S_POLICY];
        now = memo_state[MEMO_S_NOW];
        if (bilinear) {
            vec2 x = ldexp(uv, ivec2(level));
            vec2 fl = floor(clamp(x, vec2(-1073741824.0), vec2(1073741760.0)));
            f = x - fl;
            q = ivec2(fl);
        } else {
            q = memo_quantise(uv, level);
        }
    }
    if (variant == MEMO_V_TEXEL || variant == MEMO_V_TEXELS) {
        for (uint k = 0u; k < corners; ++k) {
            ivec2 qk = q + ivec2(ko[k]);
            uvec4 r0, r1, r2;
            bool torn;
            if (memo_find(memo_h0(material, level, qk), memo_h1(material, level, qk), cap, probe, true,
                          policy, now, r0, r1, r2, torn) != MEMO_NONE) {
                atomicAdd(memo_state[MEMO_C_HITS], 1u);
                if (sc_memo_eye == 1u) atomicAdd(memo_state[MEMO_C_SECOND_EYE_HITS], 1u);
                c[k] = memo_unpack(r0, r1, r2, n);
            } else {
                atomicAdd(memo_state[MEMO_C_MISSES], 1u);
                if (sc_memo_eye == 1u) atomicAdd(memo_state[MEMO_C_SECOND_EYE_MISSES], 1u);
                if (torn) atomicAdd(memo_state[MEMO_C_REFUSED], 1u);
                missing |= 1u << k;
            }
        }
        count = uint(bitCount(missing));
    } else if (tiled) {
        uint s = 1u << shift;
        e = bilinear ? s + 1u : s;
        tq = q >> int(shift);                          // floor division by s (arithmetic shift)
        o = q - (tq << int(shift));                    // q's texel within the tile, in [0, s)
        // Tiles, texels and bilinear tiles never share a key.
        uint key = material | (shift << 28) | (bilinear ? 1u << 27 : 0u);
        uint h0 = memo_h0(key, level, tq);
        h1 = memo_h1(key, level, tq);
        uint want[4];
        for (uint k = 0u; k < 4u; ++k) want[k] = (uint(o.y) + ko[k].y) * e + uint(o.x) + ko[k].x;
        bool found = false;
        for (uint i = 0u; i < probe; ++i) {
            uint sl = memo_slot(h0, i, cap, probe);
            if (memo_keys[sl] != h1) continue;
            uint v0 = memo_version(sl);
            for (uint k = 0u; k < corners; ++k) {
                uvec4 r0, r1, r2;
                memo_read_texel(MEMO_RECORD * (sl * e * e + want[k]), r0, r1, r2);
                c[k] = memo_unpack(r0, r1, r2, n);
            }
            if (memo_validate(sl, h1, v0, true)) {
                memo_count_hit(sl, policy, now);
                found = true;
            } else {
                atomicAdd(memo_state[MEMO_C_REFUSED], 1u);
            }
            break;
        }
#ifdef SC_MEMO_SUBGROUP
        memo_fill_cooperative(!found, key, level, tq, shift, e, want, corners, p, n, t,
                              cap, probe, policy, now, c);
        count = 0u;
#else
        if (!found) victim = memo_begin_fill(h0, h1, cap, probe, policy, now, seen, present);
        count = found ? 0u : e * e;
#endif
    }
    // The evaluations: k-th missing corner (non-tiled), texel k of the tile
    // (tiled), or the hit itself.
    for (uint k = 0u; k < count; ++k) {
        vec2 at = uv;
        float fp = footprint;
        uint j = 0u;
        ivec2 tk = ivec2(0);
        if (variant == MEMO_V_TEXEL || variant == MEMO_V_TEXELS) {
            j = uint(findLSB(missing));
            missing &= missing - 1u;
            tk = q + ivec2(ko[j]);
        } else if (tiled) {
            tk = (tq << int(shift)) + ivec2(int(k % e), int(k / e));
        }
        if (variant != MEMO_V_DIRECT) {
            at = memo_snapped_uv(tk, level);
            fp = memo_texel_width(level);
        }
        ScGraphOutputs v = sc_material_graphs(material, at, p, n, t, fp);
        if (variant == MEMO_V_DIRECT) {
            c[0] = v;
            continue;
        }
        uvec4 r0, r1, r2;
        memo_pack(v, r0, r1, r2);
        if (tiled) {
            if (victim != MEMO_NONE) memo_write_texel(MEMO_RECORD * (victim * e * e + k), r0, r1, r2);
            // The texels this call reads: q's (nearest), or the 2×2 from q0.
            ivec2 d = ivec2(int(k % e), int(k / e)) - o;
            if (all(greaterThanEqual(d, ivec2(0))) && all(lessThanEqual(d, ivec2(bilinear ? 1 : 0))))
                c[uint(d.y) * 2u + uint(d.x)] = memo_unpack(r0, r1, r2, n);
        } else {
            uint res = memo_insert(memo_h0(material, level, tk), memo_h1(material, level, tk), cap, probe,
                                   policy, now, r0, r1, r2);
            if (res == MEMO_FILLED) atomicAdd(memo_state[MEMO_C_FILLS], 1u);
            else if (res == MEMO_EVICTED) atomicAdd(memo_state[MEMO_C_EVICTIONS], 1u);
            else if (res == MEMO_LOCK_FAILED) atomicAdd(memo_state[MEMO_C_LOCK_FAILURES], 1u);
            // The value returned is the one stored.
            c[j] = memo_unpack(r0, r1, r2, n);
        }
    }
    if (tiled && count > 0u) memo_end_fill(victim, h1, now, seen, present);
    if (bilinear) return memo_lerp(memo_lerp(c[0], c[1], f.x), memo_lerp(c[2], c[3], f.x), f.y);
    return c[0];
}
#endif
