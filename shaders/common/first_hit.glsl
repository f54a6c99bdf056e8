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

// Whether a stored first hit (geometric normal ng as hit_position_and_normal
// returns it: the world-space winding's) is seen from behind along the eye
// ray direction d on a triangle that culls back faces (glTF doubleSided
// false, no volume: MaterialGpu.extra.z). Eye rays pass through such a
// triangle (rt_software.glsl `culled`, whose sign for world-space
// triangles is instance_front_sign; rt_query.glsl), so the sample
// cannot be what the eye sees. A cache that kept it visible once the view
// moved behind the surface drew the back face for good: retrace rays pass
// through it too and find neither it nor an occluder.
bool first_hit_culled(uvec4 fh, vec3 ng, vec3 d) {
    if (!SC_BACKFACE_CULLING || materials[instance_material(fh.w)].extra.z == 0.0) return false;
    return dot(ng, d) * instance_front_sign(fh.w) > 0.0;
}

// Motion of a stored first hit's surface point over the last frame (motion
// vectors; appendix D: the instance ID fetches the transforms): the world
// position the same object-space point had under the previous frame's
// instance transform minus the one it has now. Exactly zero for an instance
// that did not move (both products are the same float operations on equal
// matrices), so static points keep camera-only reprojection bit for bit.
vec3 hit_motion(uvec4 fh) {
    vec2 b = first_hit_bary(fh);
    uvec3 vi = triangle_indices(fh.w, fh.z);
    vec3 w = vec3(1.0 - b.x - b.y, b.x, b.y);
    vec4 p = vec4(w.x * vertices[vi.x].pos_u.xyz + w.y * vertices[vi.y].pos_u.xyz + w.z * vertices[vi.z].pos_u.xyz, 1.0);
    return (instances[fh.w].prev_object_to_world * p).xyz - (instances[fh.w].object_to_world * p).xyz;
}

// Background samples (§3.3: "the environment is evaluated where the stored
// samples represent the rendered background"). A new-sample ray that misses
// the scene is a sample too: its record keeps the no-hit marker of Listing 1's
// encoding (w = NO_HIT, so first_hit_valid() is false and no pass mistakes it
// for a surface) and stores the ray's world direction instead of a triangle:
// x, y = the direction's octahedral coordinates as float bits (full float
// precision), z = BACKGROUND_TAG in the high 16 bits and the ray's position
// in its pixel in the low 16 (8 bits per axis: an orthographic eye's
// background rays share one direction, and their retrace and reprojection
// start from that position). Such a sample lies at infinity: it
// reprojects as a direction, its radiance is the environment's in that
// direction, and it is visible while a ray in that direction hits nothing.
// CPU twin: src/methods/sample_cache/background.rs.
const uint BACKGROUND_TAG = 0x42470000u;   // "BG"

bool first_hit_is_background(uvec4 fh) { return fh.w == NO_HIT && (fh.z & 0xFFFF0000u) == BACKGROUND_TAG; }

vec2 bg_sign_not_zero(vec2 v) { return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }

// The background record fh with its place in the pixel set to `sub` (the
// fractional part of where reprojection put it, clamped into the pixel):
// an orthographic eye's background sample moves with the eye's translation
// by its place in the pixel (camera.glsl background_offset), so it must
// carry its new place, not the one it was traced at in another pixel
// (before session 49 it kept the old one: an eye sliding 0.3 pixels a
// frame left its samples behind or ran them ahead, whole pixels at a time;
// tests/orthographic.rs). In a perspective eye the place only records
// where the direction now projects.
uvec4 background_at(uvec4 fh, vec2 sub) {
    uvec2 q = uvec2(clamp(sub * 256.0, vec2(0.0), vec2(255.0)));
    return uvec4(fh.xy, BACKGROUND_TAG | (q.x << 8) | q.y, fh.w);
}

// The record of a background ray in direction d through the point `sub` ∈
// [0, 1)² of its pixel.
uvec4 encode_background(vec3 d, vec2 sub) {
    vec3 n = d / (abs(d.x) + abs(d.y) + abs(d.z));
    vec2 p = n.z >= 0.0 ? n.xy : (1.0 - abs(n.yx)) * bg_sign_not_zero(n.xy);
    return background_at(uvec4(floatBitsToUint(p.x), floatBitsToUint(p.y), 0u, NO_HIT), sub);
}

// Where in its pixel a background sample's ray went (its 1/256 cell's centre).
vec2 background_subpixel(uvec4 fh) { return (vec2((fh.z >> 8) & 255u, fh.z & 255u) + 0.5) / 256.0; }

// Unit world direction of a background sample.
vec3 background_direction(uvec4 fh) {
    vec2 p = vec2(uintBitsToFloat(fh.x), uintBitsToFloat(fh.y));
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    if (n.z < 0.0) n.xy = (1.0 - abs(n.yx)) * bg_sign_not_zero(n.xy);
    return normalize(n);
}
#endif
