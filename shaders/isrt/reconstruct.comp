#version 460
// Reconstruction: the pixel's surface samples (visible = occupied, since
// a sample found behind a closer hit is replaced by it) stand for their share
// n_surf / (n_surf + n_bg) of the pixel with the mean radiance of those
// already shaded (records hold it as shaded, not demodulated: shade.comp),
// its background samples
// (first_hit.glsl) for theirs with the environment in their directions, so
// a partly covered pixel shows its coverage while some of its surface
// samples are not shaded yet (as the sample cache's reconstruct.comp; until
// session 48 the colour was (Σ shaded + Σ background) / (shaded + n_bg),
// which gave the background the unshaded samples' share: frame 0 of a
// silhouette pixel of 5 surface cells, one shaded, and 4 sky cells showed
// 4/5 sky instead of 4/9). shade.comp shades one surface sample of every
// pixel that has one before this pass runs, so a pixel with surface samples
// has a shaded one. Depth, first hit and albedo are the closest surface
// sample's. A pixel without samples shows the environment through its
// centre.
#include "isrt/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
#ifdef SC_MATERIAL_MEMO
    sc_memo_eye = eye;
#endif
    if (any(greaterThanEqual(px, frame_size()))) return;
    uint pm = pixel_index(eye, px);
    EyeGpu e = frame.eyes[eye];
    vec3 sum = vec3(0.0);
    float shaded = 0.0, samples = 0.0;
    float best_t = 3.4e38;
    uvec4 best_fh = uvec4(0u, 0u, 0u, NO_HIT);
    vec3 best_p = vec3(0.0);
    vec3 bg_sum = vec3(0.0);
    float n_bg = 0.0;
    for (uint k = 0u; k < M * M; ++k) {
        uint idx = cell_index(eye, px * M + uvec2(k % M, k / M));
        uvec4 fh = fh_cur[idx];
        if (first_hit_is_background(fh)) {
            vec3 db = background_direction(fh);
            bg_sum += environment(db) + sun_radiance(db);
            n_bg += 1.0;
            continue;
        }
        if (!first_hit_valid(fh)) continue;
        samples += 1.0;
        vec3 wp = hit_position(fh), o, d;
        float t;
        eye_ray_to(e, wp, o, d, t);
        if (t < best_t) { best_t = t; best_fh = fh; best_p = wp; }
        vec4 rec = rad_cur[idx];
        if (rec.w > 0.0) {
            sum += rec.rgb;
            shaded += 1.0;
        }
    }
    if (samples == 0.0 && n_bg > 0.0) {
        // Background samples only.
        out_color[pm] = vec4(bg_sum / n_bg, 0.0);
        out_depth[pm] = 0.0;
        out_fh[pm] = uvec4(0u, 0u, 0u, NO_HIT);
        out_albedo[pm] = vec4(0.0);
    } else if (samples == 0.0) {
        vec3 d = eye_ray_dir(e, vec2(px) + 0.5);
        out_color[pm] = vec4(environment(d) + sun_radiance(d), 0.0);
        out_depth[pm] = 0.0;
        out_fh[pm] = uvec4(0u, 0u, 0u, NO_HIT);
        out_albedo[pm] = vec4(0.0);
    } else {
        vec3 surf_mean = shaded > 0.0 ? sum / shaded : vec3(0.0);
        out_color[pm] = vec4((samples * surf_mean + bg_sum) / (samples + n_bg), samples);
        out_depth[pm] = view_depth(e, best_p);
        out_fh[pm] = best_fh;
        // The closest sample's base colour: its material, evaluated once.
        vec3 o, d;
        float t;
        eye_ray_to(e, best_p, o, d, t);
        out_albedo[pm] = vec4(stored_hit_material(best_fh, d, eye_cone(e, t).x).base, 1.0);
    }
}
