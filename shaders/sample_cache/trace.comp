#version 460
// variant: SUBGROUP_OPS
// §3.2 step 3: apply the retrace results (retrace.comp), purge,
// add new samples through random points in the pixel (into a free slot or
// over an invisible one), and keep at least one visible sample: a pixel left
// without one gets a fresh sample (over the last one that failed, if any).
// A new-sample ray that misses the scene stores a background sample (§3.3,
// first_hit.glsl), so every new ray leaves a visible sample.
#include "sample_cache/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

// Traces a new sample through a random point of the pixel into `slot`: its
// first hit, or a background sample when the ray misses the scene. Returns
// true when it hit geometry.
bool new_sample(EyeGpu e, uvec2 px, uint eye, uint pixel, uint slot, inout Rng r, inout uint m) {
    vec2 at = vec2(px) + rng_next2(r);
    vec3 o = eye_ray_origin(e, at);
    vec3 d = eye_ray_dir(e, at);
    RtHit h;
    bool hit = rt_closest_hit(o, d, 0.0, 1e30, h);
    uint o_bit = 1u << slot, v_bit = 1u << (slot + N_SLOTS);
    uint idx = slot_index(eye, slot, pixel);
    uvec4 fh = hit ? encode_first_hit(h.bary, h.instance, h.prim, instance_material(h.instance)) : encode_background(d, at - vec2(px));
    fh_cur[idx] = fh;
    // A background sample's record holds the environment's radiance in its
    // stored direction (what reconstruct.comp would evaluate every frame:
    // the sky and the lights' discs are fixed for a run, gpu_scene.rs), with
    // count 0, so no pass takes it for a shaded surface sample.
    if (SHADING_STORAGE) {
        rad_cur[idx] = hit ? vec4(0.0) : vec4(background_radiance(background_direction(fh)), 0.0);
        // Its distance as reprojection and reconstruction compute it (from
        // the stored point, not the ray's t: the same float operations).
        vec3 so, sd;
        float t = uintBitsToFloat(0x7F800000u);
        if (hit) eye_ray_to(e, hit_position(fh), so, sd, t);
        slot_depth[idx] = t;
    }
    m |= o_bit | v_bit;
    return hit;
}

// A slot for a new sample: free first, then invisible, else -1.
int slot_for_new(uint m) {
    uint free_slots = ~occ_bits(m) & full_bits();
    if (free_slots != 0u) return findLSB(free_slots);
    uint invisible = occ_bits(m) & ~vis_bits(m);
    if (invisible != 0u) return findLSB(invisible);
    return -1;
}

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint pixel = px.y * size.x + px.x;
    uint pm = eye * npix() + pixel;
    uvec4 action = pixel_action[pm];
    uint m = mask_cur[pm];
    EyeGpu e = frame.eyes[eye];
    Rng r = rng_init(frame.size_seed.z, frame.size_seed.w, eye, pixel, 0x5EED0002u);
    uint new_rays = 0u, added = 0u, holes = 0u, replaced = 0u, bg_rays = 0u;

    if (action.z != 0u) {
        uint s = action.z - 1u;
        m &= ~((1u << s) | (1u << (s + N_SLOTS)));
    }
    uint vis_before = vis_bits(m);
    // Retrace results (retrace.comp): traced slots found visible keep or get
    // their visibility bit, those behind a closer hit lose it, the others
    // (no hit near the stored one) keep theirs; the last one (highest slot)
    // that was visible and was occluded takes the fresh sample if none stays
    // visible.
    uint traced = action.x & occ_bits(m);
    uint rf = retrace_found[pm];
    uint found = rf & traced;
    uint occluded = (rf >> N_SLOTS) & traced & ~found;
    uint failed = occluded & vis_before;
    int last_failed = failed != 0u ? findMSB(failed) : -1;
    m = (m & ~(occluded << N_SLOTS)) | (found << N_SLOTS);

    // Add samples towards the target density; a ray that misses adds a
    // background sample. (The earlier early stop at the first miss kept
    // sky pixels at one ray per frame but froze partly covered pixels at one
    // sample and dropped the sky's share of their coverage; with background
    // samples stored, a sky pixel fills its slots once and then costs only
    // the base-rate retrace.)
    for (uint k = 0u; k < action.y; ++k) {
        int s = slot_for_new(m);
        if (s < 0) break;
        if (new_sample(e, px, eye, pixel, uint(s), r, m)) new_rays++;
        else bg_rays++;
        added++;
    }

    // Keep at least one visible sample.
    if (vis_bits(m) == 0u) {
        int s = last_failed >= 0 ? last_failed : slot_for_new(m);
        if (s < 0) s = 0;
        bool had = vis_before != 0u;
        if (new_sample(e, px, eye, pixel, uint(s), r, m)) new_rays++;
        else bg_rays++;
        if (had) replaced++; else holes++;
    }
    mask_cur[pm] = m;
    pixel_stats[pm] = uvec4(action.x, 0u, added + holes + replaced, action.w);
    // Statistics (count_add: no atomic for a zero, or one per subgroup).
    count_add(C_NEW_RAYS, new_rays);
    count_add(C_BG_RAYS, bg_rays);
    count_add(C_ADDED, added);
    count_add(C_HOLES, holes);
    count_add(C_REPLACED, replaced);
    count_add(C_PURGED, action.z != 0u ? 1u : 0u);
    count_add(C_EDGE_PIXELS, action.w);
    count_add(C_VISIBLE, bitCount(vis_bits(m)));
}
