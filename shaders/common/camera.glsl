// Per-frame stereo camera (descriptor set 1, binding 0, written each frame by
// the host with vkCmdUpdateBuffer). Mirrors src/camera (EyeView) exactly:
// pixel (0,0) is the top-left corner, +y down; symmetric per-eye frustum.
#ifndef CAMERA_GLSL
#define CAMERA_GLSL
#include "interface/frame.glsl"
struct EyeGpu {
    vec4 pos_tanx;    // eye position, tan(yfov/2)·aspect
    vec4 right_tany;  // eye +X in world, tan(yfov/2)
    vec4 up;          // eye +Y in world
    vec4 fwd;         // eye −Z in world (viewing direction)
};
layout(set = SET_FRAME, binding = B_FRAME, std430) readonly buffer FrameBuf {
    EyeGpu eyes[2];
    EyeGpu prev_eyes[2];
    uvec4 size_seed;  // width, height, run seed, frame index
    uvec4 misc;       // sample base, samples this dispatch, flags, unused
} frame;

uvec2 frame_size() { return frame.size_seed.xy; }

// An orthographic eye (glTF `orthographic`, src/camera/stereo.rs
// `Projection`): up.w = 1, and pos_tanx.w, right_tany.w hold its half
// extents in metres (ymag·aspect, ymag) instead of tangents. Its rays are
// parallel, along fwd, from the pixel's point on the image plane.
bool eye_is_ortho(EyeGpu e) { return e.up.w != 0.0; }

// The length that the cache's relative tolerances (the retrace's ε0, §3.2;
// Eq. 2's ε1) multiply, for a hit at distance t: t itself from a
// perspective eye, whose pixel footprint and f32 resolution grow with t;
// for an orthographic eye the view's half height ymag. Its t runs from the
// camera's place along its axis, which moves nothing in the image, and its
// pixels keep their size (until session 57 the tolerances scaled with that
// t too: 1 km back, ε1·t = 5 m let a 0.5 m step pass Eq. 2 as flat). Past
// t = 1024·ymag it is t/1024, so that ε0 times it stays ≈ 16 ulps of t
// (f32 resolves t to 2⁻²⁴·t; a fixed ε0·ymag would fall below that and let
// a sample's own surface occlude it).
float eye_tolerance_scale(EyeGpu e, float t) {
    return eye_is_ortho(e) ? max(e.right_tany.w, t * (1.0 / 1024.0)) : t;
}

// Normalized device coordinates of continuous pixel coordinate `px`.
vec2 eye_ndc(vec2 px) {
    return vec2(2.0 * px.x / float(frame.size_seed.x) - 1.0, 1.0 - 2.0 * px.y / float(frame.size_seed.y));
}

// An orthographic eye's ray through `px` starts at the pixel's point on the
// image plane: its offset from the eye's position.
// CPU twin: EyeView::ray_origin_offset.
vec3 eye_plane_offset(EyeGpu e, vec2 px) {
    vec2 ndc = eye_ndc(px);
    return ndc.x * e.pos_tanx.w * e.right_tany.xyz + ndc.y * e.right_tany.w * e.up.xyz;
}

// World-space origin of the ray through `px`: the eye (perspective), the
// pixel's point on the image plane (orthographic).
vec3 eye_ray_origin(EyeGpu e, vec2 px) {
    if (!eye_is_ortho(e)) return e.pos_tanx.xyz;
    return e.pos_tanx.xyz + eye_plane_offset(e, px);
}

// World-space unit direction through continuous pixel coordinate `px`.
vec3 eye_ray_dir(EyeGpu e, vec2 px) {
    if (eye_is_ortho(e)) return e.fwd.xyz;
    vec2 ndc = eye_ndc(px);
    return normalize(e.fwd.xyz + ndc.x * e.pos_tanx.w * e.right_tany.xyz + ndc.y * e.right_tany.w * e.up.xyz);
}

// The eye ray that reaches world point p: its origin o, unit direction d and
// length t (p = o + t·d). Perspective: from the eye; orthographic: from p's
// foot on the image plane, along fwd.
void eye_ray_to(EyeGpu e, vec3 p, out vec3 o, out vec3 d, out float t) {
    if (eye_is_ortho(e)) {
        d = e.fwd.xyz;
        t = dot(p - e.pos_tanx.xyz, d);
        o = p - t * d;
        return;
    }
    o = e.pos_tanx.xyz;
    t = length(p - o);
    d = (p - o) / max(t, 1e-30);
}

// Pixel-space spread angle of one pixel (ray cone, Akenine-Möller et al.
// 2019); 0 for an orthographic eye's parallel rays.
float eye_pixel_spread(EyeGpu e) { return eye_is_ortho(e) ? 0.0 : 2.0 * e.right_tany.w / float(frame.size_seed.y); }

// The ray cone of an eye ray at distance t: (width, spread angle). A
// perspective cone starts as a point at the eye; an orthographic one has
// one pixel's height 2·ymag/h at every distance.
vec2 eye_cone(EyeGpu e, float t) {
    if (eye_is_ortho(e)) return vec2(2.0 * e.right_tany.w / float(frame.size_seed.y), 0.0);
    float spread = eye_pixel_spread(e);
    return vec2(t * spread, spread);
}

// Distance along the viewing axis (what depth buffers store).
float view_depth(EyeGpu e, vec3 p) { return dot(p - e.pos_tanx.xyz, e.fwd.xyz); }

// view_depth of the hit at distance t along the eye ray (o, d): o is the eye
// or lies on its image plane, so it is t·d's component along fwd.
float eye_hit_depth(EyeGpu e, vec3 d, float t) { return dot(t * d, e.fwd.xyz); }

// Projects the point at offset d from an eye's position into the eye:
// continuous pixel coordinates and distance along the view axis; false when
// behind the eye (behind its image plane, orthographic). Parallel
// projection divides by no depth. CPU twin: EyeView::project_offset.
bool project_offset_to_eye(EyeGpu e, vec3 d, out vec2 px, out float vd) {
    vd = dot(d, e.fwd.xyz);
    if (!(vd > 0.0)) return false;
    float x = dot(d, e.right_tany.xyz), y = dot(d, e.up.xyz);
    if (eye_is_ortho(e)) {
        x /= e.pos_tanx.w;
        y /= e.right_tany.w;
    } else {
        x /= vd * e.pos_tanx.w;
        y /= vd * e.right_tany.w;
    }
    px = vec2(0.5 * (x + 1.0) * float(frame.size_seed.x), 0.5 * (1.0 - y) * float(frame.size_seed.y));
    return all(equal(px, px));
}

// project_offset_to_eye of the world point p.
bool project_to_eye(EyeGpu e, vec3 p, out vec2 px, out float vd) {
    return project_offset_to_eye(e, p - e.pos_tanx.xyz, px, vd);
}

// The point a background sample (direction d at infinity, traced through
// continuous pixel `at` of eye `pe`) is reprojected through into eye `e`,
// as an offset from e's position (project_offset_to_eye): d, one unit along
// it from e's eye, so only the view rotation moves it. An orthographic eye
// sees infinity along its fwd only: the sample stays while the view
// direction holds (to the f32 precision of its encoded direction:
// 1 − d·fwd < 1e-6, ≈ 0.08°) as the line along d from its place on pe's
// image plane, which moves with the eye's translation like any point (its
// own pixel while the eye holds still); false once the view has turned.
// CPU twin: metrics/covisibility.rs `project_into` (a miss).
bool background_offset(EyeGpu e, EyeGpu pe, vec2 at, vec3 d, out vec3 offset) {
    offset = d;
    if (!eye_is_ortho(e)) return true;
    if (dot(d, e.fwd.xyz) < 1.0 - 1e-6) return false;
    offset += (pe.pos_tanx.xyz - e.pos_tanx.xyz) + eye_plane_offset(pe, at);
    return true;
}
// Where a background sample (direction d, traced through continuous pixel
// `at` of eye pe) lands in eye e: continuous pixel q (background_offset,
// then project_offset_to_eye); false when it leaves the view (orthographic
// turn, or behind). Pass 1 of a reprojection chooses the target with it, and
// a later pass that copies the sample recomputes q to update the sample's
// place in its new pixel (first_hit.glsl background_at).
bool background_target(EyeGpu e, EyeGpu pe, vec2 at, vec3 d, out vec2 q) {
    vec3 offset;
    float vd;
    q = vec2(-1.0);
    return background_offset(e, pe, at, d, offset) && project_offset_to_eye(e, offset, q, vd);
}
#endif
