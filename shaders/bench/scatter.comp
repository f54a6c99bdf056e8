#version 460
// The paper's "simple reprojection" baseline for `bench sample-cache`: one
// first hit per pixel forward-projected into the new view with a plain store
// (no slots, no atomics, no visibility).
#include "common/scene.glsl"
#include "common/packing.glsl"
#include "common/camera.glsl"
#include "interface/bench_scatter.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(set = SET_BENCH_SCATTER, binding = B_BENCH_SCATTER_SRC, std430) readonly buffer Src { uvec4 src[]; };
layout(set = SET_BENCH_SCATTER, binding = B_BENCH_SCATTER_DST, std430) writeonly buffer Dst { uvec4 dst[]; };

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint npix = size.x * size.y;
    uvec4 fh = src[eye * npix + px.y * size.x + px.x];
    if (!first_hit_valid(fh)) return;
    vec2 b = first_hit_bary(fh);
    uvec3 vi = triangle_indices(fh.w, fh.z);
    vec3 w = vec3(1.0 - b.x - b.y, b.x, b.y);
    vec3 p = w.x * vertices[vi.x].pos_u.xyz + w.y * vertices[vi.y].pos_u.xyz + w.z * vertices[vi.z].pos_u.xyz;
    p = (instances[fh.w].object_to_world * vec4(p, 1.0)).xyz;
    EyeGpu e = frame.eyes[eye];
    vec2 q;
    float vd;
    if (!project_to_eye(e, p, q, vd)) return;
    if (any(lessThan(q, vec2(0.0))) || any(greaterThanEqual(q, vec2(size)))) return;
    uvec2 qi = uvec2(q);
    dst[eye * npix + qi.y * size.x + qi.x] = fh;
}
