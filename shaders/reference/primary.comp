#version 460
// Pixel-centre primary rays: first-hit ids (Listing 1), view depth, albedo,
// for a TAA's reprojection and the frame's outputs; trace.comp traces the
// path's own (jittered) first hit. Counted apart (CENTRE_RAYS): part of the
// method's cost only where a TAA reads them (src/methods/reference.rs).
#include "common/integrator.glsl"
#include "common/packing.glsl"
#include "reference/bindings.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
#ifdef SC_MATERIAL_MEMO
    sc_memo_eye = eye;
#endif
    if (any(greaterThanEqual(px, size))) return;
    uint idx = (eye * size.y + px.y) * size.x + px.x;
    EyeGpu e = frame.eyes[eye];
    vec3 o = eye_ray_origin(e, vec2(px) + 0.5);
    vec3 d = eye_ray_dir(e, vec2(px) + 0.5);
    RtHit h;
    bool hit = rt_closest_hit(o, d, 0.0, 1e30, h);
    atomicAdd(counters[C_REFERENCE_CENTRE_RAYS], 1u);
    if (hit) {
        uint mat = instance_material(h.instance);
        first_hit[idx] = encode_first_hit(h.bary, h.instance, h.prim, mat);
        depth[idx] = eye_hit_depth(e, d, h.t);
        albedo[idx] = vec4(first_hit_albedo(h, d, eye_cone(e, h.t).x), 1.0);
    } else {
        first_hit[idx] = uvec4(0u, 0u, 0u, NO_HIT);
        depth[idx] = 0.0;
        albedo[idx] = vec4(0.0);
    }
}
