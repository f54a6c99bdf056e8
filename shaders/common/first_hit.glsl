// A stored first hit (Listing 1) back in world space: position and
// geometric normal with the current frame's instance transforms (appendix D).
// Shared by the methods that keep first hits across frames (sample cache, isrt).
#ifndef FIRST_HIT_GLSL
#define FIRST_HIT_GLSL
#include "common/scene.glsl"
#include "common/packing.glsl"

vec3 hit_position(uvec4 fh) {
    vec2 b = first_hit_bary(fh);
    uvec3 vi = triangle_indices(fh.w, fh.z);
    mat4 M = instances[fh.w].object_to_world;
    vec3 w = vec3(1.0 - b.x - b.y, b.x, b.y);
    vec3 p = w.x * vertices[vi.x].pos_u.xyz + w.y * vertices[vi.y].pos_u.xyz + w.z * vertices[vi.z].pos_u.xyz;
    return (M * vec4(p, 1.0)).xyz;
}

// Position (as hit_position) and unit geometric normal together, fetching the
// triangle's vertices and instance transform once.
void hit_position_and_normal(uvec4 fh, out vec3 p, out vec3 ng) {
    vec2 b = first_hit_bary(fh);
    uvec3 vi = triangle_indices(fh.w, fh.z);
    mat4 M = instances[fh.w].object_to_world;
    vec3 va = vertices[vi.x].pos_u.xyz, vb = vertices[vi.y].pos_u.xyz, vc = vertices[vi.z].pos_u.xyz;
    vec3 w = vec3(1.0 - b.x - b.y, b.x, b.y);
    p = (M * vec4(w.x * va + w.y * vb + w.z * vc, 1.0)).xyz;
    vec3 a = (M * vec4(va, 1.0)).xyz;
    vec3 n = cross((M * vec4(vb, 1.0)).xyz - a, (M * vec4(vc, 1.0)).xyz - a);
    float l = length(n);
    ng = l > 0.0 ? n / l : vec3(0.0, 1.0, 0.0);
}
#endif
