#version 460
// Temporal antialiasing resolve (Yang, Liu & Salvi 2020, "A Survey of
// Temporal Antialiasing Techniques"), the project's one TAA (`taa`, the TAA
// of `hash-cache` and `hybrid`, and `--taa-output` on any method), one
// thread per pixel and eye:
//  1. reprojection (§4.1): the pixel centre's world point, rebuilt from the
//     current view depth (a miss: its direction), projected into the previous
//     eye pose gives the history position q; on a moving instance (SC_ANIMATED)
//     the point is first moved back by its object motion (first_hit.glsl
//     hit_motion: previous minus current instance transform of the first
//     hit's object-space point), so q is where that surface point was;
//  2. history rejection (§4.2): q off-screen, or no bilinear tap around q whose
//     previous first hit and depth agree with the point (both misses, or both
//     hits at the expected previous view depth) → disocclusion, history dropped;
//  3. history fetch: Catmull-Rom over the 4×4 texels around q (Karis 2014;
//     the survey's §4.1: a bicubic history keeps the repeated resampling
//     from blurring a moving image; taps beyond the image clamped to its
//     edge) where all 16 taps are consistent (flag bit 5, `--taa-history catmull-rom`, the default
//     since session 49); else, and with `--taa-history bilinear`, bilinear
//     over the consistent taps of the 2×2 only, renormalised (per-tap
//     validity as in SVGF's reprojection). The history length n is the
//     bilinear one either way;
//  4. variance clipping (§4.2, Salvi 2016): the history is clipped towards
//     the mean of a YCoCg AABB μ ± γσ of the current 3×3 neighbourhood;
//  5. blend (§3) of the (clipped) history h and the current frame c,
//     result = mix(h, c, α): `pfj23` (weights 2) α = β′ of
//     Eq. 4 per channel, the MSE-optimal weight of Philippi et al. 2023
//     ("leverages variance to compute per pixel blending weights for both
//     temporal and stereoscopic rendering"), with the moments of X = the
//     history and Y = the current frame estimated from 3×3 neighbourhoods
//     (the history's around q in the previous output, the current frame's
//     around the pixel, both clamped at the image border), as the paper
//     describes PFJ23's stereo estimate (§3.6); `count` (1, the default)
//     α = max(1/(n+1), α_min) with the per-pixel history length n (Eq. 4 for
//     an unbiased history of n frames); `fixed` (0) α.
// Set 1 below; src/methods/taa/pass.rs (TaaPass) owns the buffers.
#include "interface/taa.glsl"
#include "common/camera.glsl"
#include "common/packing.glsl"
#include "common/first_hit.glsl"
#include "common/mse_blend.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant) uniform Push { TAA_RESOLVE_PUSH } pc;   // src/interface/taa.rs

layout(set = SET_TAA, binding = B_TAA_IN_COLOR, std430) readonly buffer InColor { vec4 in_color[]; };     // rgb radiance (w ignored), or a sample sum (flag bit 3)
layout(set = SET_TAA, binding = B_TAA_IN_DEPTH, std430) readonly buffer InDepth { float in_depth[]; };    // view depth, 0 = miss
layout(set = SET_TAA, binding = B_TAA_IN_FH, std430) readonly buffer InFh { uvec4 in_fh[]; };          // pixel-centre first hits
layout(set = SET_TAA, binding = B_TAA_HIST_PREV, std430) readonly buffer HistPrev { vec4 hist_prev[]; };   // rgb, history length n
layout(set = SET_TAA, binding = B_TAA_HIST_CUR, std430) writeonly buffer HistCur { vec4 hist_cur[]; };
layout(set = SET_TAA, binding = B_TAA_PREV_DEPTH, std430) readonly buffer PrevDepth { float prev_depth[]; };
layout(set = SET_TAA, binding = B_TAA_PREV_FH, std430) readonly buffer PrevFh { uvec4 prev_fh[]; };
layout(set = SET_TAA, binding = B_TAA_COUNTERS, std430) buffer Counters { uint counters[]; };

// Counter slots: C_TAA_* (src/interface/taa.rs, TaaCounter).
const float N_MAX = 255.0;            // history lengths saturate here
const float TOL_SAME_INSTANCE = 0.1;  // relative depth tolerance when the tap saw the same instance
const float TOL_OTHER = 0.01;         // ... and when it saw another one
// "History used": not a counter slot. (It used to be 0, which is
// C_TAA_OFFSCREEN's slot, so an off-screen pixel blended an all-zero history
// and was never counted as off-screen.)
const uint HISTORY_USED = 0xFFFFFFFFu;

vec3 rgb_to_ycocg(vec3 c) {
    return vec3(0.25 * c.r + 0.5 * c.g + 0.25 * c.b, 0.5 * c.r - 0.5 * c.b, -0.25 * c.r + 0.5 * c.g - 0.25 * c.b);
}
vec3 ycocg_to_rgb(vec3 c) {
    float t = c.x - c.z;
    return vec3(t + c.y, c.x + c.z, t - c.y);
}

// Clips h towards the box centre mu (half extents ext) along the segment h → mu.
vec3 clip_towards_mean(vec3 h, vec3 mu, vec3 ext, out bool clipped) {
    vec3 d = h - mu;
    vec3 a = abs(d) / max(ext, vec3(1e-7));
    float m = max(a.x, max(a.y, a.z));
    clipped = m > 1.0;
    return clipped ? mu + d / m : h;
}

vec3 sanitize(vec3 c) { return (any(isnan(c)) || any(isinf(c))) ? vec3(0.0) : max(c, vec3(0.0)); }

// The input radiance of entry i: rgb, or (flag bit 3, `Color::SampleSum`)
// rgb / w with 0 where w = 0.
vec3 input_color(uint i) {
    vec4 v = in_color[i];
    if ((pc.flags & 8u) != 0u) return v.w > 0.0 ? sanitize(v.rgb / v.w) : vec3(0.0);
    return sanitize(v.rgb);
}

// Does the previous frame's tap (first hit, depth) show the current point,
// whose view depth in the previous eye is `vd` (a miss: hit = false)?
bool tap_consistent(bool hit, uvec4 fh, float vd, uvec4 pfh, float pdepth) {
    if (!hit) return !first_hit_valid(pfh);
    if (!first_hit_valid(pfh)) return false;
    float tol = pfh.w == fh.w ? TOL_SAME_INSTANCE : TOL_OTHER;
    return abs(pdepth - vd) <= tol * vd;
}

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint base = eye * size.x * size.y;
    uint idx = base + px.y * size.x + px.x;
    vec3 c = input_color(idx);

    // 3×3 neighbourhood moments in YCoCg (clamped at the image border), and
    // in RGB for the pfj23 weights.
    vec3 m1 = vec3(0.0), m2 = vec3(0.0), m1y = vec3(0.0), m2y = vec3(0.0);
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = clamp(ivec2(px) + ivec2(dx, dy), ivec2(0), ivec2(size) - 1);
            vec3 rgb = input_color(base + uint(q.y) * size.x + uint(q.x));
            vec3 y = rgb_to_ycocg(rgb);
            m1 += y;
            m2 += y * y;
            m1y += rgb;
            m2y += rgb * rgb;
        }
    }
    vec3 mu = m1 / 9.0;
    vec3 sigma = sqrt(max(m2 / 9.0 - mu * mu, vec3(0.0)));
    m1y /= 9.0;
    m2y /= 9.0;

    // Reprojection of the pixel centre into the previous eye.
    EyeGpu e = frame.eyes[eye];
    EyeGpu pe = frame.prev_eyes[eye];
    vec3 d = eye_ray_dir(e, vec2(px) + 0.5);
    uvec4 fh = in_fh[idx];
    bool hit = first_hit_valid(fh);
    vec2 q;
    float vd;
    bool on_screen;
    if (hit) {
        vec3 p = e.pos_tanx.xyz + d * (in_depth[idx] / dot(d, e.fwd.xyz));
        if (eye_is_ortho(e)) p += eye_plane_offset(e, vec2(px) + 0.5);   // its ray's origin
        if (SC_ANIMATED && (pc.flags & 16u) != 0u) p += hit_motion(fh);
        on_screen = project_to_eye(pe, p, q, vd);
    } else {
        // A direction: rotation only (camera.glsl; an orthographic eye has
        // no history for it once the view has turned).
        vec3 off;
        on_screen = background_offset(pe, e, vec2(px) + 0.5, d, off) && project_offset_to_eye(pe, off, q, vd);
    }
    on_screen = on_screen && all(greaterThanEqual(q, vec2(0.0))) && all(lessThan(q, vec2(size)));

    uint reason = HISTORY_USED;   // else the C_TAA_* slot that rejected it
    vec4 hist = vec4(0.0);
    if ((pc.flags & 1u) == 0u) {
        reason = C_TAA_NO_HISTORY;
    } else if (!on_screen) {
        reason = C_TAA_OFFSCREEN;
    } else {
        vec2 f = q - 0.5;
        ivec2 b = ivec2(floor(f));
        vec2 t = f - vec2(b);
        float wsum = 0.0;
        for (int k = 0; k < 4; ++k) {
            ivec2 tp = b + ivec2(k & 1, k >> 1);
            if (any(lessThan(tp, ivec2(0))) || any(greaterThanEqual(tp, ivec2(size)))) continue;
            float w = ((k & 1) != 0 ? t.x : 1.0 - t.x) * ((k >> 1) != 0 ? t.y : 1.0 - t.y);
            uint pi = base + uint(tp.y) * size.x + uint(tp.x);
            if ((pc.flags & 2u) != 0u && !tap_consistent(hit, fh, vd, prev_fh[pi], prev_depth[pi])) continue;
            hist += w * hist_prev[pi];
            wsum += w;
        }
        if (wsum > 1e-4) hist /= wsum;
        else reason = C_TAA_DISOCCLUDED;
        if (reason == HISTORY_USED && (pc.flags & 32u) != 0u) {
            // Catmull-Rom weights of the taps at b − 1 … b + 2 for the
            // fraction t (they sum to 1 and interpolate: t = 0 gives the
            // texel b alone, so a still view reads its history exactly).
            vec2 w0 = t * (-0.5 + t * (1.0 - 0.5 * t));
            vec2 w1 = 1.0 + t * t * (-2.5 + 1.5 * t);
            vec2 w2 = t * (0.5 + t * (2.0 - 1.5 * t));
            vec2 w3 = t * t * (-0.5 + 0.5 * t);
            // Taps beyond the image read its edge (clamp-to-edge
            // addressing, as a texture's), so the border pixels keep the
            // filter (where a tap's weight is 0, as along an axis the view
            // did not move, the clamped tap changes nothing).
            vec3 cr = vec3(0.0);
            bool all_taps = true;
            for (int k = 0; k < 16 && all_taps; ++k) {
                ivec2 o = ivec2(k & 3, k >> 2);
                ivec2 tp = clamp(b - 1 + o, ivec2(0), ivec2(size) - 1);
                uint pi = base + uint(tp.y) * size.x + uint(tp.x);
                if ((pc.flags & 2u) != 0u && !tap_consistent(hit, fh, vd, prev_fh[pi], prev_depth[pi])) {
                    all_taps = false;
                    break;
                }
                float wx = o.x == 0 ? w0.x : o.x == 1 ? w1.x : o.x == 2 ? w2.x : w3.x;
                float wy = o.y == 0 ? w0.y : o.y == 1 ? w1.y : o.y == 2 ? w2.y : w3.y;
                cr += wx * wy * hist_prev[pi].rgb;
            }
            if (all_taps) hist.rgb = cr;
        }
    }

    vec3 result;
    float n;
    if (reason != HISTORY_USED) {
        result = c;
        n = 1.0;
        atomicAdd(counters[reason], 1u);
    } else {
        bool clipped = false;
        vec3 h = hist.rgb;
        if ((pc.flags & 4u) != 0u) h = ycocg_to_rgb(clip_towards_mean(rgb_to_ycocg(h), mu, pc.gamma * sigma, clipped));
        float n_prev = hist.w;
        vec3 alpha = vec3(pc.weights == 1u ? max(1.0 / (n_prev + 1.0), pc.alpha) : pc.alpha);
        if (pc.weights == 2u) {
            // X's moments: the previous output's 3×3 box around the pixel
            // q falls in (its rgb; clamped at the border like Y's).
            ivec2 qc = ivec2(floor(q));
            vec3 m1x = vec3(0.0), m2x = vec3(0.0);
            for (int dy = -1; dy <= 1; ++dy) {
                for (int dx = -1; dx <= 1; ++dx) {
                    ivec2 t = clamp(qc + ivec2(dx, dy), ivec2(0), ivec2(size) - 1);
                    vec3 x = hist_prev[base + uint(t.y) * size.x + uint(t.x)].rgb;
                    m1x += x;
                    m2x += x * x;
                }
            }
            alpha = beta_prime(m1x / 9.0, m2x / 9.0, m1y, m2y);
        }
        result = mix(max(h, vec3(0.0)), c, alpha);
        n = min(n_prev + 1.0, N_MAX);
        atomicAdd(counters[C_TAA_ACCEPTED], 1u);
        if (clipped) atomicAdd(counters[C_TAA_CLIPPED], 1u);
    }
    atomicAdd(counters[C_TAA_HISTORY_SUM], uint(n));
    hist_cur[idx] = vec4(result, n);
}
