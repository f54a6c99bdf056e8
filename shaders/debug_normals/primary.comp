#version 460
// debug-normals: one pixel-centre primary ray per pixel and eye; colour =
// 0.5·n + 0.5 of the world-space shading normal at the first hit (the normal
// the integrator shades with: interpolated, normal-mapped, on the side the ray
// arrives from, the geometric normal where it faces away from the ray; see
// path_radiance in common/integrator.glsl); black for a miss (no unit normal
// maps to black, so misses cannot be mistaken for hits). First-hit ids
// (Listing 1), view depth and albedo as reference/primary.comp writes them.
#include "common/integrator.glsl"
#include "common/packing.glsl"
#include "interface/debug_normals.glsl"
#include "common/camera.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(set = SET_DEBUG_NORMALS, binding = B_DEBUG_NORMALS_COLOR, std430) writeonly buffer Color { vec4 color[]; };        // 0.5·n + 0.5, alpha 1
layout(set = SET_DEBUG_NORMALS, binding = B_DEBUG_NORMALS_FIRST_HIT, std430) writeonly buffer FirstHits { uvec4 first_hit[]; }; // Listing 1 encoding
layout(set = SET_DEBUG_NORMALS, binding = B_DEBUG_NORMALS_DEPTH, std430) writeonly buffer Depth { float depth[]; };       // view depth, 0 = no hit
layout(set = SET_DEBUG_NORMALS, binding = B_DEBUG_NORMALS_ALBEDO, std430) writeonly buffer Albedo { vec4 albedo[]; };
layout(set = SET_DEBUG_NORMALS, binding = B_DEBUG_NORMALS_COUNTERS, std430) buffer Counters { uint counters[]; };      // DebugNormalsCounter slots

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
    atomicAdd(counters[C_DEBUG_NORMALS_PRIMARY_RAYS], 1u);
    if (hit) {
        Surface s = surface_at(h.instance, h.prim, h.bary, d);
        ShadingMaterial m = material_at(s, d, eye_cone(e, h.t).x);
        if (dot(s.n, d) >= 0.0) s.n = s.ng;
        uint mat = instance_material(h.instance);
        color[idx] = vec4(0.5 * s.n + 0.5, 1.0);
        first_hit[idx] = encode_first_hit(h.bary, h.instance, h.prim, mat);
        depth[idx] = eye_hit_depth(e, d, h.t);
        albedo[idx] = vec4(m.base, 1.0);
    } else {
        color[idx] = vec4(0.0, 0.0, 0.0, 1.0);
        first_hit[idx] = uvec4(0u, 0u, 0u, NO_HIT);
        depth[idx] = 0.0;
        albedo[idx] = vec4(0.0);
    }
}
