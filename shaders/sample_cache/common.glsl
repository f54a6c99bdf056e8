// The screen-space sample cache (Philippi, Jensen & Frisvad, EGSR 2025):
// per eye, N slots per pixel held as N layers; a 32-bit mask per pixel with
// occupancy bits o_s (0..N−1) and visibility bits v_s (N..2N−1). Per slot:
// the 128-bit first hit (Listing 1) and a radiance record (running mean of
// the sample's radiance, not demodulated (shade.comp says why), effective
// sample count c_s) with the sample's distance from the eye (slot_depth). Descriptor set 1 below:
// bindings, push constants, counter slots and specialization-constant ids
// from src/interface/sample_cache.rs (the generated interface/sample_cache.glsl);
// src/methods/sample_cache/ owns the buffers and the pass order.
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_ARB_gpu_shader_int64 : require
#ifdef SUBGROUP_OPS
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#endif
#include "interface/sample_cache.glsl"
#include "common/integrator.glsl"
#include "common/packing.glsl"
#include "common/camera.glsl"
#include "common/first_hit.glsl"
#include "common/demodulation.glsl"
#include "common/accumulation.glsl"

layout(constant_id = SPEC_SAMPLE_CACHE_SLOTS) const uint N_SLOTS = 12;
layout(constant_id = SPEC_SAMPLE_CACHE_RETRACE) const uint RETRACE_MODE = 2;   // 0 single, 1 multi, 2 adaptive
layout(constant_id = SPEC_SAMPLE_CACHE_SHADING) const uint SHADING_MODE = 0;   // 0 uniform, 1 adaptive
layout(constant_id = SPEC_SAMPLE_CACHE_ACCUM) const uint ACCUM_MODE = 0;     // 0 running mean, 1 fixed α floor for every sample (§5.2), 2 appendix C's α_min for specular lobes
// false: visibility only (the `hybrid` method) — the radiance records are
// neither read nor written (their buffers are placeholders), and the
// importance histogram is not counted.
layout(constant_id = SPEC_SAMPLE_CACHE_SHADING_STORAGE) const bool SHADING_STORAGE = true;
const uint HIST_M = 13;                                 // histogram buckets (§3.5)

layout(push_constant) uniform Push { SAMPLE_CACHE_PUSH } pc;   // src/interface/sample_cache.rs (PUSH)

layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_MASK_PREV, std430) buffer MaskPrev { uint mask_prev[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_MASK_CUR, std430) buffer MaskCur { uint mask_cur[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_FH_PREV, std430) buffer FhPrev { uvec4 fh_prev[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_FH_CUR, std430) buffer FhCur { uvec4 fh_cur[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_RAD_PREV, std430) buffer RadPrev { vec4 rad_prev[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_RAD_CUR, std430) buffer RadCur { vec4 rad_cur[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_DEPTH_MIN, std430) buffer DepthMin { uint64_t depth_min[]; };  // t_min bits << 32 | Δn bits
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_DEPTH_MAX, std430) buffer DepthMax { uint depth_max[]; };      // t_max bits
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_HIST, std430) buffer Hist { uint hist[]; };               // [eye][HIST_M]
// state: [0..2) w_min prev, [2..4) w_max prev, [4..6) w_min next, [6..8) w_max next, [8] shade-list length
// (adaptive shading; 0 under uniform shading, which has no list),
// [9] retrace-list length (surface samples), [10..12) unshaded pixels, [12..14) base-rate pixels
// (shade_select.comp phase 0), [14] retrace-list length (background samples), [15] unused,
// [16..18) pixels with a visible surface sample (shade_select.comp phase 0: adaptive shading's budget)
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_STATE, std430) buffer State { uint state[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_SHADE_LIST, std430) buffer ShadeList { uint shade_list[]; };   // eye << 31 | slot << 26 | pixel
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_TARGET_SRC, std430) buffer TargetSrc { uint target_src[]; };   // two-pass: v << 31 | (source slot·npix + pixel + 1), reproject.comp
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_OUT_COLOR, std430) buffer OutColor { vec4 out_color[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_OUT_M1, std430) buffer OutM1 { vec4 out_m1[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_OUT_M2, std430) buffer OutM2 { vec4 out_m2[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_OUT_DEPTH, std430) buffer OutDepth { float out_depth[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_OUT_FH, std430) buffer OutFh { uvec4 out_fh[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_OUT_ALBEDO, std430) buffer OutAlbedo { vec4 out_albedo[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_COUNTERS, std430) buffer Counters { uint counters[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_PIXEL_ACTION, std430) buffer PixelAction { uvec4 pixel_action[]; }; // select.comp → trace.comp: trace bits, add count, purge slot + 1, flags; then (adaptive shading) shade_select.comp phase 0 → 1: packed buckets (xy), shadeable visible bits, round robin | flags
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_PIXEL_STATS, std430) buffer PixelStats { uvec4 pixel_stats[]; };   // traced bits, shaded count, fresh, unused
// [eye][slot][pixel]: the sample's distance t from this frame's eye
// (eye_ray_to), written where the sample is placed — reprojection (both
// variants) and new samples (trace.comp) — and read by reconstruct.comp, so
// that finding a pixel's closest visible sample fetches no vertices. Part of
// the shading payload: written and read only with SHADING_STORAGE.
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_SLOT_DEPTH, std430) buffer SlotDepth { float slot_depth[]; };
// Retracing (§3.4) as a compacted list: select.comp appends the slots to
// retrace (eye << 31 | slot << 26 | pixel), retrace.comp traces them with
// every lane busy and records per pixel in retrace_found, which trace.comp
// applies: bit s = slot s found visible (an invisible surface sample: the
// closest hit within ε0 of it; a background sample: no hit at all); bit
// N + s = a closer hit was found (the sample is occluded; for a sample
// visible already the only answer its occlusion query can give). Neither bit: the ray found no hit near the
// stored one (precision at triangle edges) and the slot keeps its
// visibility, as §3.2 sets v_s = 0 only "if a closer hit is encountered".
// The list holds the surface samples' entries from the front (state[9] of
// them) and the background samples' from the back (state[14]), so that the
// lanes of a SIMD group trace rays of one kind: a background sample's
// occlusion query runs to infinity, a surface sample's ends at the sample,
// and a group that mixes them waits for its longest ray.
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_RETRACE_LIST, std430) buffer RetraceList { uint retrace_list[]; };
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_RETRACE_FOUND, std430) buffer RetraceFound { uint retrace_found[]; };  // [eye][pixel]
// VkDispatchIndirectCommand per list: [0..3) retrace, [4..7) shade (indirect_args.comp).
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_INDIRECT_ARGS, std430) buffer IndirectArgs { uint indirect_args[]; };
// Global atomics, one per subgroup where subgroup operations are compiled in
// (the `.subgroup` build of the shaders marked `// variant: SUBGROUP_OPS`,
// chosen when the device supports subgroup arithmetic and ballot), else one
// per invocation. The subgroup forms combine whichever invocations call
// together, in divergent code too, provided those invocations stay
// together through `list_reserve`'s elect branch to its broadcast: the
// reconvergence at the end of a structured `if` that current drivers
// provide, which the Vulkan spec promises only with
// VK_KHR_shader_maximal_reconvergence (not required here; an audit's note,
// session 57). Without it a lane could broadcast another group's base.

// counters[c] += v.
void count_add(uint c, uint v) {
#ifdef SUBGROUP_OPS
    uint total = subgroupAdd(v);
    if (subgroupElect() && total != 0u) atomicAdd(counters[c], total);
#else
    if (v != 0u) atomicAdd(counters[c], v);
#endif
}

// Reserves n consecutive entries of the list whose length is state[len] and
// returns the first (meaningless when n = 0).
uint list_reserve(uint len, uint n) {
#ifdef SUBGROUP_OPS
    uint total = subgroupAdd(n);
    uint base = 0u;
    if (subgroupElect() && total != 0u) base = atomicAdd(state[len], total);
    return subgroupBroadcastFirst(base) + subgroupExclusiveAdd(n);
#else
    return n != 0u ? atomicAdd(state[len], n) : 0u;
#endif
}

// Slot-list entries (shade and retrace lists).
uint list_entry(uint eye, uint slot, uint pixel) { return (eye << 31) | (slot << 26) | pixel; }
void list_decode(uint code, out uint eye, out uint slot, out uint pixel) {
    eye = code >> 31;
    slot = (code >> 26) & 31u;
    pixel = code & 0x3FFFFFFu;
}

// Counter slots: the generated C_SAMPLE_CACHE_* (SampleCacheCounter in
// src/interface/sample_cache.rs, which names them in reports), under the
// short names the shaders use.
const uint C_RETRACE_RAYS = C_SAMPLE_CACHE_RETRACE_RAYS, C_NEW_RAYS = C_SAMPLE_CACHE_NEW_RAYS,
           C_BOUNCE_RAYS = C_SAMPLE_CACHE_BOUNCE_RAYS, C_SHADOW_RAYS = C_SAMPLE_CACHE_SHADOW_RAYS,
           C_HOLES = C_SAMPLE_CACHE_HOLES, C_ADDED = C_SAMPLE_CACHE_ADDED, C_PURGED = C_SAMPLE_CACHE_PURGED,
           C_REPROJECTED = C_SAMPLE_CACHE_REPROJECTED, C_REPROJECT_FULL = C_SAMPLE_CACHE_REPROJECT_FULL,
           C_OFFSCREEN = C_SAMPLE_CACHE_OFFSCREEN, C_SHADED = C_SAMPLE_CACHE_SHADED,
           C_REPLACED = C_SAMPLE_CACHE_REPLACED, C_EDGE_PIXELS = C_SAMPLE_CACHE_EDGE_PIXELS,
           C_VISIBLE = C_SAMPLE_CACHE_VISIBLE, C_BG_RAYS = C_SAMPLE_CACHE_BG_RAYS,
           C_REPROJECTED_VISIBLE = C_SAMPLE_CACHE_REPROJECTED_VISIBLE,
           C_REPROJECTED_BACKGROUND = C_SAMPLE_CACHE_REPROJECTED_BACKGROUND,
           C_RETRACE_BACKGROUND = C_SAMPLE_CACHE_RETRACE_BACKGROUND,
           C_RETRACE_OCCLUSION = C_SAMPLE_CACHE_RETRACE_OCCLUSION,
           C_RETRACE_OCCLUDED = C_SAMPLE_CACHE_RETRACE_OCCLUDED,
           C_REPROJECTED_BACKFACING = C_SAMPLE_CACHE_REPROJECTED_BACKFACING,
           C_NONFINITE_SAMPLES = C_SAMPLE_CACHE_NONFINITE_SAMPLES;

uint npix() { return frame.size_seed.x * frame.size_seed.y; }
uint slot_index(uint eye, uint s, uint pixel) { return (eye * N_SLOTS + s) * npix() + pixel; }
uint full_bits() { return N_SLOTS >= 32u ? 0xFFFFFFFFu : (1u << N_SLOTS) - 1u; }
uint occ_bits(uint m) { return m & full_bits(); }
uint vis_bits(uint m) { return (m >> N_SLOTS) & full_bits(); }

// Retrace list (see RetraceList): its length, and its i-th entry's index
// (surface entries first, then the background entries from the back).
uint retrace_list_capacity() { return 2u * N_SLOTS * npix(); }
uint retrace_list_length() { return state[9] + state[14]; }
uint retrace_list_index(uint i) {
    uint n_surface = state[9];
    return i < n_surface ? i : retrace_list_capacity() - 1u - (i - n_surface);
}

// Background samples (first_hit.glsl): slot s of `pixel` holds one.
bool slot_is_background(uint eye, uint s, uint pixel) {
    return first_hit_is_background(fh_cur[slot_index(eye, s, pixel)]);
}

// The slots of `bits` that hold surface samples (not background ones): the
// samples that shading and the surface outputs use.
uint surface_slots(uint eye, uint pixel, uint bits) {
    uint out_bits = bits, b = bits;
    while (b != 0u) {
        uint s = uint(findLSB(b));
        b &= b - 1u;
        if (slot_is_background(eye, s, pixel)) out_bits &= ~(1u << s);
    }
    return out_bits;
}

// Radiance of a background sample (§3.3): the environment and sun discs
// seen in its direction, as the reference sees them through a missing ray.
vec3 background_radiance(vec3 d) {
    return environment(d) + sun_radiance(d);
}

// Index of the k-th set bit of `bits` (k < bitCount(bits)).
uint nth_set_bit(uint bits, uint k) {
    for (uint i = 0u; i < k; ++i) bits &= bits - 1u;
    return uint(findLSB(bits));
}

// The length of a pixel's diagonal on the image plane: at distance 1 in
// tangent units (perspective), in metres (orthographic).
float pixel_diagonal(EyeGpu e) {
    vec2 pix = vec2(2.0 * e.pos_tanx.w / float(frame.size_seed.x), 2.0 * e.right_tany.w / float(frame.size_seed.y));
    return length(pix);
}

// cos φ and sin φ of the angle φ subtended by a pixel's diagonal (Eq. 1):
// φ = atan(L) for the diagonal's tangent-plane length L, so
// cos φ = 1/√(1 + L²) and sin φ = L/√(1 + L²).
// CPU twin: src/methods/sample_cache/heuristics.rs `pixel_diagonal_cos_sin`.
vec2 pixel_diagonal_cos_sin(EyeGpu e) {
    float l = pixel_diagonal(e);
    float inv = inversesqrt(1.0 + l * l);
    return vec2(inv, l * inv);
}

// Eq. 1: Δn = t_s |1 − cos θ / cos(θ − φ)|, θ clamped to [0, π/2] so the
// denominator stays ≥ cos(π/2 − φ) = sin φ > 0: finite up to grazing angles.
// Without trigonometry: cos(θ − φ) = cos θ cos φ + sin θ sin φ with
// sin θ = √((1 − cos θ)(1 + cos θ)) ≥ 0 on [0, π/2].
// CPU twin: src/methods/sample_cache/heuristics.rs `normal_slope`.
float normal_slope(float t, float cos_theta, vec2 cs_phi) {
    float c = clamp(cos_theta, 0.0, 1.0);
    float sin_theta = sqrt((1.0 - c) * (1.0 + c));
    return t * abs(1.0 - c / (c * cs_phi.x + sin_theta * cs_phi.y));
}

// Eq. 1 for an orthographic eye's parallel rays: its limit as t → ∞ with
// t·tan φ held at the pixel diagonal's length L on the image plane,
// Δn = L tan θ, unbounded (Eq. 1's cap Δn = t at θ = π/2 grows without
// bound in that limit; capping at the orthographic t, the distance from the
// camera's arbitrary place, made steep surfaces edges near and flat far).
// CPU twin: src/methods/sample_cache/heuristics.rs `normal_slope_parallel`.
float normal_slope_parallel(float cos_theta, float diag) {
    float c = clamp(cos_theta, 0.0, 1.0);
    float sin_theta = sqrt((1.0 - c) * (1.0 + c));
    return c > 0.0 ? diag * sin_theta / c : uintBitsToFloat(0x7F800000u);   // edge-on: ∞
}

// Eq. 2: true when the depths are consistent with one flat surface,
// t_max < t_min + 2Δn + tol with tol = ε1 · eye_tolerance_scale(e, t_min +
// 2Δn) (camera.glsl): a perspective eye's (1 + ε1)(t_min + 2Δn), an
// orthographic eye's ε1 times its view's half height.
// CPU twin: heuristics.rs `depths_consistent`, `tolerance_scale`.
bool depths_consistent(float t_min, float slope, float t_max, float tol) {
    return t_max < t_min + 2.0 * slope + tol;
}

// §3.5: importance w = (1 + c_s)^−1 into HIST_M logarithmic buckets between
// the previous frame's w_min and w_max. CPU twin: `importance_bucket`.
uint importance_bucket(float w, float w_min, float w_max) {
    if (!(w_max > w_min) || !(w_min > 0.0)) return HIST_M - 1u;
    float x = log(w / w_min) / log(w_max / w_min);
    return uint(clamp(floor(x * float(HIST_M)), 0.0, float(HIST_M - 1u)));
}

// Bucket bounds of this frame from the previous frame's extremes (defaults
// before the first frame: the full range of 16-bit counts).
void importance_bounds(uint eye, out float w_min, out float w_max) {
    uint lo = state[eye], hi = state[2u + eye];
    w_min = lo == 0xFFFFFFFFu ? 1.0 / (1.0 + C_MAX) : uintBitsToFloat(lo);
    w_max = hi == 0u ? 1.0 : uintBitsToFloat(hi);
}

float importance(float c) { return 1.0 / (1.0 + c); }

// --- Demodulation (§3.3): common/demodulation.glsl (the unshaded fallback of
// reconstruct.comp; records hold radiance as shaded) ------------------------

// --- Accumulation (appendix C, §5.2, Eq. 5): common/accumulation.glsl -------

// Block-sparse pattern of §3.4/§3.5: one pixel per 4×4 block, rotating each
// frame: over any 16 consecutive frames every pixel of a block is its base
// pixel exactly once (the order a 4×4 Bayer matrix's ranks, so consecutive
// base pixels lie apart; each block and eye starts at its own hashed
// offset, so the blocks do not step in lockstep). Until session 44 a hash of
// the frame chose it afresh each frame, which left gaps of up to 149 frames
// (35 % over 16) between a pixel's visits. Blocks cut by the right or bottom
// border (width or height not a multiple of 4) rotate over their n pixels
// inside the image in row order, each every n frames, so they too get their
// base pixel every frame. CPU twin: heuristics.rs `is_sparse_base_pixel`.
//
// `visit` counts the block's cycles, (frame + offset) / n, so it grows by
// one from one visit of a pixel to its next: the caller picks the slot to
// retrace (select.comp) or shade (shade_select.comp) at a base visit as
// visit mod n_occ, which walks the pixel's samples round robin over its
// visits. Until session 49 both took frame mod n_occ, which at visits n
// frames apart repeats whenever n_occ divides n (n_occ = 1, 2, 4, 8 of a
// full block; 6 and 12 reached only some slots): with the default four
// samples a still view retraced the same sample of a pixel at every visit
// and never found the others occluded (an audit's finding).
const uint BAYER4[16] = uint[16](0u, 8u, 2u, 10u, 12u, 4u, 14u, 6u, 3u, 11u, 1u, 9u, 15u, 7u, 13u, 5u);
bool sparse_base_pixel(uvec2 px, uint frame_index, uint eye, out uint visit) {
    uvec2 block = px / 4u;
    uvec2 extent = min(frame_size() - block * 4u, uvec2(4u));
    uint n = extent.x * extent.y;
    uint offset = pcg_hash(block.x * 73856093u ^ block.y * 19349663u ^ eye * 83492791u);
    uint local = (px.x & 3u) + extent.x * (px.y & 3u);
    uint rank = n == 16u ? BAYER4[local] : local;
    visit = (frame_index + offset) / n;
    return rank == (frame_index + offset) % n;
}
bool is_sparse_base_pixel(uvec2 px, uint frame_index, uint eye) {
    uint visit;
    return sparse_base_pixel(px, frame_index, eye, visit);
}
