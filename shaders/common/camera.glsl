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

// World-space unit direction through continuous pixel coordinate `px`.
vec3 eye_ray_dir(EyeGpu e, vec2 px) {
    vec2 ndc = vec2(2.0 * px.x / float(frame.size_seed.x) - 1.0, 1.0 - 2.0 * px.y / float(frame.size_seed.y));
    return normalize(e.fwd.xyz + ndc.x * e.pos_tanx.w * e.right_tany.xyz + ndc.y * e.right_tany.w * e.up.xyz);
}

// Pixel-space spread angle of one pixel (ray cone, Akenine-Möller et al. 2019).
float eye_pixel_spread(EyeGpu e) { return 2.0 * e.right_tany.w / float(frame.size_seed.y); }

// Distance along the viewing axis (what depth buffers store).
float view_depth(EyeGpu e, vec3 p) { return dot(p - e.pos_tanx.xyz, e.fwd.xyz); }

// Projects a world point into an eye: continuous pixel coordinates and
// distance along the view axis; false when behind the eye.
bool project_to_eye(EyeGpu e, vec3 p, out vec2 px, out float vd) {
    vec3 d = p - e.pos_tanx.xyz;
    vd = dot(d, e.fwd.xyz);
    if (!(vd > 0.0)) return false;
    float x = dot(d, e.right_tany.xyz) / (vd * e.pos_tanx.w);
    float y = dot(d, e.up.xyz) / (vd * e.right_tany.w);
    px = vec2(0.5 * (x + 1.0) * float(frame.size_seed.x), 0.5 * (1.0 - y) * float(frame.size_seed.y));
    return all(equal(px, px));
}
#endif
