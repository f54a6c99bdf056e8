// Interactive stable ray tracing (Dal Corso et al. 2017), the layout the
// sample-cache paper compares against in Fig. 10: per eye a super-resolution
// grid of (W·M) × (H·M) cells, M × M per pixel; a sample's sub-pixel position
// fixes its cell. Per cell: the 128-bit first hit (Listing 1; w = NO_HIT marks
// an empty cell, or with z = BACKGROUND_TAG a background sample: a sample
// whose ray missed the scene, stored as its direction, first_hit.glsl) and a radiance record (the radiance,
// not demodulated, accumulated as the sample cache's, common/accumulation.glsl, and its
// effective count). Everything is double-buffered (previous / current frame).
// Descriptor set 1 below; src/methods/isrt/ owns the buffers and the passes.
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_ARB_gpu_shader_int64 : require
#include "interface/isrt.glsl"
#include "common/integrator.glsl"
#include "common/packing.glsl"
#include "common/camera.glsl"
#include "common/first_hit.glsl"
#include "common/demodulation.glsl"
#include "common/accumulation.glsl"

layout(constant_id = SPEC_ISRT_M) const uint M = 3;   // cells per pixel side

layout(push_constant) uniform Push { ISRT_PUSH } pc;   // eps0: retrace tolerance, relative to the hit distance (orthographic: to the view's half height); n_target: trace_pixel.comp's density target

layout(set = SET_ISRT, binding = B_ISRT_FH_PREV, std430) buffer FhPrev { uvec4 fh_prev[]; };
layout(set = SET_ISRT, binding = B_ISRT_FH_CUR, std430) buffer FhCur { uvec4 fh_cur[]; };
layout(set = SET_ISRT, binding = B_ISRT_RAD_PREV, std430) buffer RadPrev { vec4 rad_prev[]; };
layout(set = SET_ISRT, binding = B_ISRT_RAD_CUR, std430) buffer RadCur { vec4 rad_cur[]; };
// Reservation per cell: view depth bits << 32 | source cell (within the eye); the closer sample wins.
layout(set = SET_ISRT, binding = B_ISRT_CLAIM, std430) buffer Claim { uint64_t claim[]; };
layout(set = SET_ISRT, binding = B_ISRT_OUT_COLOR, std430) buffer OutColor { vec4 out_color[]; };
layout(set = SET_ISRT, binding = B_ISRT_OUT_DEPTH, std430) buffer OutDepth { float out_depth[]; };
layout(set = SET_ISRT, binding = B_ISRT_OUT_FH, std430) buffer OutFh { uvec4 out_fh[]; };
layout(set = SET_ISRT, binding = B_ISRT_OUT_ALBEDO, std430) buffer OutAlbedo { vec4 out_albedo[]; };
layout(set = SET_ISRT, binding = B_ISRT_COUNTERS, std430) buffer Counters { uint counters[]; };

// Counter slots: C_ISRT_* (src/interface/isrt.rs, IsrtCounter).

uvec2 grid_size() { return frame_size() * M; }
uint cells_per_eye() { uvec2 g = grid_size(); return g.x * g.y; }
uint cell_index(uint eye, uvec2 g) { return eye * cells_per_eye() + g.y * grid_size().x + g.x; }
uint pixel_index(uint eye, uvec2 px) { return (eye * frame_size().y + px.y) * frame_size().x + px.x; }

// Where in its pixel the background sample of grid cell g lies: its stored
// place (first_hit.glsl, the centre of its 1/256-pixel step) clamped into
// the cell, 0.01 of a cell inside its edges (the step's half width is 0.006
// of a cell at M = 3). For M = 3 the cell edges 1/3 and 2/3 fall inside a
// step whose centre lies in the neighbouring cell: until session 56 an
// orthographic eye's background sample so placed (0.5 % of them) moved to
// that cell in a still view, dropping a sample and costing a new ray a
// frame (an audit's finding; tests/orthographic.rs). A sample's cell is
// fixed by its place, so its place stays in its cell.
vec2 isrt_background_place(uvec4 fh, uvec2 g) {
    vec2 k = vec2(g % M);
    vec2 in_cell = clamp(background_subpixel(fh) * float(M) - k, vec2(0.01), vec2(0.99));
    return (k + in_cell) / float(M);
}

// Retraces the sample of cell `idx` from the eye (trace.comp's rule, after
// the sample cache's retrace): a surface sample is kept when the closest hit
// lies within ε0·t of it or the ray finds neither (precision at triangle
// edges), a background sample while its direction hits nothing. Otherwise
// the ray has found a closer surface on its way, through the sample's own
// place in the cell (grid cell g; a surface sample's ray goes to its stored
// hit, a background sample's through its place): Dal Corso et
// al.'s updated hit point, which the cell takes as its new sample with a
// fresh radiance record, at no further ray. (Until session 52 the cell was
// emptied and refilled by a second ray through a random point of it: a ray
// more per sample lost, and a new place; an audit's finding.) Counts the
// ray and the outcome.
void isrt_retrace(uint idx, EyeGpu e, uvec2 g) {
    uvec4 fh = fh_cur[idx];
    vec3 o, d;
    float t = 1e30;
    bool bg = first_hit_is_background(fh);
    if (bg) {
        // (Orthographic: from the ray's own place in the pixel.)
        d = background_direction(fh);
        o = eye_ray_origin(e, vec2(g / M) + isrt_background_place(fh, g));
    } else {
        eye_ray_to(e, hit_position(fh), o, d, t);
    }
    RtHit h;
    float tol = pc.eps0 * eye_tolerance_scale(e, t);   // ε0·t (orthographic: ε0·ymag)
    bool hit = rt_closest_hit(o, d, 0.0, bg ? 1e30 : t + 2.0 * tol, h);
    atomicAdd(counters[C_ISRT_RETRACE_RAYS], 1u);
    if (!hit || (!bg && h.t >= t - tol)) {
        atomicAdd(counters[bg ? C_ISRT_BACKGROUND : C_ISRT_SAMPLES], 1u);
        return;
    }
    fh_cur[idx] = encode_first_hit(h.bary, h.instance, h.prim, instance_material(h.instance));
    rad_cur[idx] = vec4(0.0);
    atomicAdd(counters[C_ISRT_RETRACE_REPLACED], 1u);
    atomicAdd(counters[C_ISRT_SAMPLES], 1u);
}

// A new sample in cell `idx` (grid position g of eye `eye`) through a
// uniformly random point of the cell; a miss stores a background sample.
void isrt_new_sample(uint idx, uint eye, uvec2 g, EyeGpu e) {
    Rng r = rng_init(frame.size_seed.z, frame.size_seed.w, eye, g.y * grid_size().x + g.x, 0x15A70001u);
    vec2 sub = (vec2(g) + rng_next2(r)) / float(M);
    vec3 d = eye_ray_dir(e, sub);
    RtHit h;
    bool hit = rt_closest_hit(eye_ray_origin(e, sub), d, 0.0, 1e30, h);
    atomicAdd(counters[C_ISRT_NEW_RAYS], 1u);
    if (hit) {
        fh_cur[idx] = encode_first_hit(h.bary, h.instance, h.prim, instance_material(h.instance));
        atomicAdd(counters[C_ISRT_NEW_HITS], 1u);
        atomicAdd(counters[C_ISRT_SAMPLES], 1u);
    } else {
        fh_cur[idx] = encode_background(d, fract(sub));
        atomicAdd(counters[C_ISRT_BACKGROUND], 1u);
    }
    rad_cur[idx] = vec4(0.0);
}
