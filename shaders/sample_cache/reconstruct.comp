#version 460
// §3.3 reconstruction: the pixel colour is the mean over its visible,
// already shaded samples of their radiance and its visible
// background samples (first_hit.glsl) of the environment in their
// directions, each kind weighted by its share of the pixel's visible samples,
// so a partly covered pixel shows its coverage; a pixel without visible
// samples shows the environment. A record holds its sample's radiance as
// shaded, not demodulated (shade.comp): the paper's demodulation factor
// of a sample is its fixed surface point's, so factor × demodulated mean +
// emission is the mean of the radiance itself, and this pass evaluates no
// material per sample (until session 58 it evaluated each visible sample's
// surface and material to remodulate). A pixel whose visible surface samples are
// all still unshaded (adaptive shading when the frame's rate cannot cover
// every such pixel: frame 0 or a disocclusion at a rate below one path per
// pixel) falls back to its neighbours' demodulated radiance, remodulated
// with its own samples' materials (`unshaded_fallback`), instead of black.
// Also writes the raw moments of
// Eq. 5–6 for stereo blending, the depth / first hit / albedo of the closest
// visible sample, and the debug views.
#include "sample_cache/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_DEBUG, std430) buffer Debug { vec4 debug_views[]; };   // [view][eye][pixel], 4 views
// The debug views are written only when requested (they are 64 B per pixel of
// stores that nothing reads otherwise).
layout(constant_id = SPEC_SAMPLE_CACHE_DEBUG_VIEWS) const bool DEBUG_VIEWS = false;

// The material of surface sample `fh` (at world position wp) seen by eye e.
ShadingMaterial sample_material(EyeGpu e, uvec4 fh, vec3 wp) {
    vec3 o, d;
    float t;
    eye_ray_to(e, wp, o, d, t);
    return stored_hit_material(fh, d, eye_cone(e, t).x);
}

// Issue 12 item 3 (adaptive shading): the mean demodulated radiance of the
// shaded visible samples nearest to `px` — the ring of Chebyshev radius r =
// 1, 2, ... up to 4 that first holds any, each weighted by its effective
// count; each record's radiance divided by its own sample's demodulation
// factor after its emission is taken off (common/demodulation.glsl) — or
// false when none lies within 4 pixels. shade_select.comp shades
// one sample of every 4×4 block (the base rate) and gives unshaded pixels
// priority within the rate, so a covered block has a shaded sample within
// radius 3 (its base pixel) unless the block's base pixel sees background.
// Surface detail stays the pixel's own: the caller remodulates with its own
// samples' base colour and emission.
bool unshaded_fallback(uint eye, ivec2 px, ivec2 size, out vec3 demod) {
    demod = vec3(0.0);
    if (!SHADING_STORAGE) return false;   // --payload none: no radiance records
    EyeGpu e = frame.eyes[eye];
    for (int r = 1; r <= 4; ++r) {
        vec3 sum = vec3(0.0);
        float wsum = 0.0;
        for (int dy = -r; dy <= r; ++dy) {
            for (int dx = -r; dx <= r; ++dx) {
                if (max(abs(dx), abs(dy)) != r) continue;
                ivec2 q = px + ivec2(dx, dy);
                if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
                uint qp = uint(q.y) * uint(size.x) + uint(q.x);
                uint bits = vis_bits(mask_cur[eye * npix() + qp]);
                while (bits != 0u) {
                    uint s = uint(findLSB(bits));
                    bits &= bits - 1u;
                    uint idx = slot_index(eye, s, qp);
                    vec4 rec = rad_cur[idx];
                    uvec4 fh = fh_cur[idx];
                    // (A surface sample's record: the one-pass race can leave
                    // a shaded record under a background first hit, whose
                    // material does not exist.)
                    if (rec.w > 0.0 && first_hit_valid(fh)) {
                        sum += rec.w * demodulate(rec.rgb, sample_material(e, fh, hit_position(fh)));
                        wsum += rec.w;
                    }
                }
            }
        }
        if (wsum > 0.0) { demod = sum / wsum; return true; }
    }
    demod = vec3(0.0);
    return false;
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
    uint m = mask_cur[pm];
    uint vis = vis_bits(m);
    EyeGpu e = frame.eyes[eye];

    vec3 sum = vec3(0.0), m1 = vec3(0.0), m2 = vec3(0.0);
    float shaded = 0.0, c_total = 0.0;
    float best_t = 3.4e38;
    uvec4 best_fh = uvec4(0u, 0u, 0u, NO_HIT);
    // Background samples: sum and sum of squares of their radiance, count.
    vec3 bg_sum = vec3(0.0), bg_sum2 = vec3(0.0);
    float n_bg = 0.0;
    uint bits = vis;
    while (bits != 0u) {
        uint s = uint(findLSB(bits));
        bits &= bits - 1u;
        uint idx = slot_index(eye, s, pixel);
        uvec4 fh = fh_cur[idx];
        if (first_hit_is_background(fh)) {
            // Kept in its record since it was traced (trace.comp): a read
            // instead of a sky evaluation per sample and frame.
            vec3 Lb = SHADING_STORAGE ? rad_cur[idx].rgb : background_radiance(background_direction(fh));
            bg_sum += Lb;
            bg_sum2 += Lb * Lb;
            n_bg += 1.0;
            continue;
        }
        // Its distance from the eye as placed (slot_depth); without the
        // shading payload from its position.
        // (∞ under a surface first hit: one-pass reprojection's documented
        // race let two reservations write the slot, a background sample's
        // distance landing beside a surface sample's first hit; recomputed
        // so the pixel keeps its closest surface sample.)
        float t = SHADING_STORAGE ? slot_depth[idx] : uintBitsToFloat(0x7F800000u);
        if (isinf(t)) {
            vec3 o, d;
            eye_ray_to(e, hit_position(fh), o, d, t);
        }
        // (--payload none: no radiance record; every sample counts as unshaded.)
        vec4 rec = SHADING_STORAGE ? rad_cur[idx] : vec4(0.0);
        if (t < best_t) { best_t = t; best_fh = fh; }
        if (rec.w > 0.0) {
            vec3 L = rec.rgb;   // the sample's radiance, emission included (issue 12 item 7)
            sum += L;
            shaded += 1.0;
            m1 += rec.w * L;          // Eq. 5, weighted by effective sample counts (Eq. 6)
            m2 += rec.w * L * L;
            c_total += rec.w;
        }
    }
    // Background samples in the mean (exact radiance, not accumulated): each
    // counts as one sample in the colour and, in the moments (Eq. 5–6), with
    // weight c_total / n_surf (1 without a shaded sample), so surface and
    // background weigh n_surf : n_bg in μ1 as in the colour even while some
    // visible surface samples are unshaded (until session 43 the weight was
    // c_total / shaded, which overweighted the background there: a spurious
    // Bias² against X).
    float n_surf = float(bitCount(vis)) - n_bg;
    float c_bg = shaded > 0.0 ? c_total / n_surf : 1.0;
    m1 += c_bg * bg_sum;
    m2 += c_bg * bg_sum2;
    c_total += c_bg * n_bg;
    bool surface = best_t < 3.4e38;   // some visible surface sample
    // Moments estimated from the pixel's own samples: not where the surface
    // part's colour is borrowed from the neighbours (no shaded surface
    // sample), nor without samples (c_total = 0).
    bool estimated = c_total > 0.0 && (shaded > 0.0 || n_surf == 0.0);
    vec3 color;
    if (vis == 0u) {
        // Background: what the pixel-centre camera ray sees (sky and sun disc).
        vec3 d = eye_ray_dir(e, vec2(px) + 0.5);
        color = environment(d) + sun_radiance(d);
        m1 = color;
        m2 = color * color;
        out_depth[pm] = 0.0;
        out_fh[pm] = uvec4(0u, 0u, 0u, NO_HIT);
        out_albedo[pm] = vec4(0.0);
    } else {
        // Coverage (issue 12 item 1): the visible surface samples stand for
        // their share n_surf / (n_surf + n_bg) of the pixel with the mean of
        // those already shaded, the background samples for theirs with the
        // environment, so a pixel whose surface samples are not all shaded
        // yet keeps its coverage.
        vec3 surf_mean = vec3(0.0);
        if (shaded > 0.0) {
            surf_mean = sum / shaded;
        } else if (n_surf > 0.0) {
            // Issue 12 item 3: no visible surface sample shaded yet. The mean
            // of (own factor × neighbours' demodulated radiance + own emission) over the own
            // visible surface samples; without a shaded neighbour either,
            // their own emission remains.
            vec3 factor_sum = vec3(0.0), emission_sum = vec3(0.0);
            uint own = vis;
            while (own != 0u) {
                uint s = uint(findLSB(own));
                own &= own - 1u;
                uvec4 fh = fh_cur[slot_index(eye, s, pixel)];
                if (first_hit_is_background(fh)) continue;
                ShadingMaterial mat = sample_material(e, fh, hit_position(fh));
                factor_sum += demodulation_factor(mat);
                emission_sum += mat.emissive;
            }
            vec3 demod;
            unshaded_fallback(eye, ivec2(px), ivec2(size), demod);
            surf_mean = (factor_sum * demod + emission_sum) / n_surf;
        }
        color = (n_surf * surf_mean + bg_sum) / (n_surf + n_bg);
        // No shaded sample behind the surface part (its colour borrowed from
        // the neighbours): no spread to estimate, σ² = 0 around the colour,
        // not the background's moments alone.
        m1 = estimated ? m1 / c_total : color;
        m2 = estimated ? m2 / c_total : color * color;
        // Depth, first hit and albedo of the closest visible surface sample;
        // background only: as for a pixel without samples.
        vec3 best_p = surface ? hit_position(best_fh) : vec3(0.0);
        out_depth[pm] = surface ? view_depth(e, best_p) : 0.0;
        out_fh[pm] = best_fh;
        out_albedo[pm] = surface ? vec4(sample_material(e, best_fh, best_p).base, 1.0) : vec4(0.0);
    }
    out_color[pm] = vec4(color, c_total);
    // out_m1.w: the moments' effective count, 0 where they are not
    // estimated (the colour borrowed from the neighbours, σ² = 0 by fiat
    // above): the stereo blend then does not take it for a noise-free X.
    // out_m2.w: the visible background samples the moments hold (the pixel
    // without samples: 1, its centre ray's sky); the blend takes no
    // neighbour's moments that mix in the sky (stereo_blend.comp).
    out_m1[pm] = vec4(m1, estimated ? c_total : 0.0);
    out_m2[pm] = vec4(m2, vis == 0u ? 1.0 : n_bg);

    if (!DEBUG_VIEWS) return;
    uvec4 st = pixel_stats[pm];
    uint n2 = 2u * npix();
    float inv_n = 1.0 / float(N_SLOTS);
    // trace mask (Fig. 4): grey = traced slots, red tint = edge pixel; samples per pixel;
    // shaded samples this frame (Fig. 5); layer occupancy.
    debug_views[0u * n2 + pm] = vec4(vec3(float(bitCount(st.x)) * inv_n) + vec3(st.w != 0u ? 0.5 : 0.0, 0.0, 0.0), 1.0);
    debug_views[1u * n2 + pm] = vec4(vec3(float(bitCount(vis)) * inv_n), 1.0);
    debug_views[2u * n2 + pm] = vec4(vec3(float(st.y) * 0.25), 1.0);
    debug_views[3u * n2 + pm] = vec4(vec3(float(bitCount(occ_bits(m))) * inv_n), 1.0);
}
