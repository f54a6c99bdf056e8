#version 460
// Temporal antialiasing of the hash cache's output (Yang, Liu & Salvi 2020),
// self-contained (own descriptor set, src/methods/hash_cache/taa.rs) so another
// method can reuse it. Per pixel: reproject the current first hit (or, for a
// miss, its direction) into the previous frame's eye; bilinear history from
// the taps whose stored view depth agrees (relative 5 %, misses with misses);
// clamp the history to mean ± γσ of the 3×3 current neighbourhood in YCoCg;
// blend with weight 1/(n+1) floored at α_min (n = history length, kept in w).
#include "common/camera.glsl"
#include "interface/hash_taa.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(set = SET_HASH_TAA, binding = B_HASH_TAA_COLOR_IN, std430) readonly buffer ColorIn { vec4 color_in[]; };
layout(set = SET_HASH_TAA, binding = B_HASH_TAA_POSITION_IN, std430) readonly buffer PositionIn { vec4 position_in[]; };  // w = 1 hit point, w = 0 direction
layout(set = SET_HASH_TAA, binding = B_HASH_TAA_DEPTH_IN, std430) readonly buffer DepthIn { float depth_in[]; };      // view depth, 0 = miss
layout(set = SET_HASH_TAA, binding = B_HASH_TAA_HIST_PREV, std430) readonly buffer HistPrev { vec4 hist_prev[]; };     // rgb, history length
layout(set = SET_HASH_TAA, binding = B_HASH_TAA_HIST_CUR, std430) writeonly buffer HistCur { vec4 hist_cur[]; };
layout(set = SET_HASH_TAA, binding = B_HASH_TAA_HDEPTH_PREV, std430) readonly buffer HDepthPrev { float hdepth_prev[]; };
layout(set = SET_HASH_TAA, binding = B_HASH_TAA_HDEPTH_CUR, std430) writeonly buffer HDepthCur { float hdepth_cur[]; };
// alpha_min, gamma, depth_tolerance, reset (1: ignore the history, first frame)
layout(push_constant) uniform Push { HASH_TAA_PUSH } pc;

vec3 rgb_to_ycocg(vec3 c) {
    return vec3(0.25 * c.r + 0.5 * c.g + 0.25 * c.b, 0.5 * c.r - 0.5 * c.b, -0.25 * c.r + 0.5 * c.g - 0.25 * c.b);
}
vec3 ycocg_to_rgb(vec3 c) { return vec3(c.x + c.y - c.z, c.x + c.z, c.x - c.y - c.z); }

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint n = size.x * size.y;
    uint base = eye * n;
    uint pm = base + px.y * size.x + px.x;
    vec3 cur = color_in[pm].rgb;
    hdepth_cur[pm] = depth_in[pm];

    // Neighbourhood statistics (YCoCg).
    vec3 m1 = vec3(0.0), m2 = vec3(0.0);
    float k = 0.0;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = ivec2(px) + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, ivec2(size)))) continue;
            vec3 y = rgb_to_ycocg(color_in[base + uint(q.y) * size.x + uint(q.x)].rgb);
            m1 += y;
            m2 += y * y;
            k += 1.0;
        }
    m1 /= k;
    vec3 sigma = sqrt(max(m2 / k - m1 * m1, vec3(0.0)));

    // Reprojection into the previous frame's eye.
    EyeGpu pe = frame.prev_eyes[eye];
    vec4 pos = position_in[pm];
    vec3 dir = pos.w > 0.0 ? pos.xyz - pe.pos_tanx.xyz : pos.xyz;
    float vd = dot(dir, pe.fwd.xyz);
    vec4 hist = vec4(0.0);
    float wsum = 0.0;
    if (pc.reset == 0u && vd > 0.0) {
        vec2 ndc = vec2(dot(dir, pe.right_tany.xyz) / (vd * pe.pos_tanx.w), dot(dir, pe.up.xyz) / (vd * pe.right_tany.w));
        vec2 q = vec2(0.5 * (ndc.x + 1.0) * float(size.x), 0.5 * (1.0 - ndc.y) * float(size.y)) - 0.5;
        ivec2 q0 = ivec2(floor(q));
        vec2 f = q - vec2(q0);
        for (int t = 0; t < 4; ++t) {
            ivec2 o = ivec2(t & 1, t >> 1);
            ivec2 qq = q0 + o;
            if (any(lessThan(qq, ivec2(0))) || any(greaterThanEqual(qq, ivec2(size)))) continue;
            uint qi = base + uint(qq.y) * size.x + uint(qq.x);
            float hd = hdepth_prev[qi];
            bool ok = pos.w > 0.0 ? hd > 0.0 && abs(hd - vd) <= pc.depth_tolerance * vd : hd == 0.0;
            if (!ok) continue;
            float w = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y);
            hist += w * hist_prev[qi];
            wsum += w;
        }
    }
    vec4 outv;
    if (wsum > 1e-4) {
        hist /= wsum;
        vec3 hy = clamp(rgb_to_ycocg(hist.rgb), m1 - pc.gamma * sigma, m1 + pc.gamma * sigma);
        float len = min(hist.w + 1.0, 1.0 / pc.alpha_min);
        outv = vec4(mix(ycocg_to_rgb(hy), cur, 1.0 / len), len);
    } else {
        outv = vec4(cur, 1.0);
    }
    hist_cur[pm] = vec4(max(outv.rgb, vec3(0.0)), outv.w);
}
