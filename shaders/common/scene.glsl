// Scene data (descriptor set 0), shared by every method. Layouts mirror
// src/rt/gpu_scene.rs (std430).
#ifndef SCENE_GLSL
#define SCENE_GLSL
#extension GL_EXT_nonuniform_qualifier : require
#include "common/features.glsl"
#include "common/random.glsl"

struct Vertex { vec4 pos_u; vec4 normal_v; vec4 tangent; };
struct MeshInfo { uint vertex_offset; uint index_offset; uint material; uint triangle_count; };
// prev_object_to_world: the previous frame's object_to_world (motion vectors;
// read only where SC_ANIMATED, equal to object_to_world for a static scene).
struct InstanceInfo { mat4 object_to_world; mat4 normal_to_world; uvec4 mesh_pad; mat4 prev_object_to_world; };
struct MaterialGpu {
    vec4 base_color;
    vec4 emissive_metallic;   // emissive rgb (× strength), metallic
    vec4 params;              // roughness, transmission, ior, alpha cutoff
    ivec4 tex0;               // base colour, metallic-roughness, normal, emissive (-1 = none)
    ivec4 tex1;               // transmission, alpha mode (0 opaque, 1 mask, 2 blend), double sided, unlit (emission × COLOR_0)
    vec4 extra;               // normal scale, specular factor (KHR_materials_specular), culls back faces (1: single-sided, no volume), unused
    vec4 specular_color;      // KHR_materials_specular colour factor rgb, unused
    vec4 coat;                // KHR_materials_clearcoat factor, roughness, normal scale, unused
    vec4 attenuation;         // KHR_materials_volume σ_a rgb (per world unit, 0 = none), thin-walled (1: transmission without a volume)
    ivec4 tex2;               // clearcoat (R), clearcoat roughness (G), clearcoat normal, specular (A)
    ivec4 tex3;               // specular colour (RGB), slots on the second uv channel (bits), slots read through uv_affine (bits), unused
    vec4 uv_affine[20];       // slot k: rows 2k, 2k+1 = (m00, m01, o0, 0), (m10, m11, o1, 0) of uv' = m·uv + o (material.glsl slot_texture)
};
struct LightGpu {
    vec4 radiant_kind;        // rgb, kind (0 point, 1 spot, 2 directional)
    vec4 position_range;      // xyz, range (0 = infinite)
    vec4 direction;           // xyz = travel direction, w = 1 − cos(angular radius) for the sun (0 = delta; gpu_scene.rs)
    vec4 cone;                // cos inner, cos outer, unused, unused
};
struct SceneParams {
    vec4 env_constant;        // rgb, env scale
    vec4 sun_dir;             // xyz towards the sun (sky), w = sun theta
    vec4 zenith;              // Y, x, y (Preetham), unused
    float perez[16];          // A..E for Y, x, y (15 values)
    uvec4 counts;             // light count, env map width, env map height, instance count
};

layout(set = SET_SCENE, binding = B_SCENE_VERTICES, std430) readonly buffer Vertices { Vertex vertices[]; };
layout(set = SET_SCENE, binding = B_SCENE_INDICES, std430) readonly buffer Indices { uint indices[]; };
layout(set = SET_SCENE, binding = B_SCENE_MESHES, std430) readonly buffer Meshes { MeshInfo meshes[]; };
layout(set = SET_SCENE, binding = B_SCENE_INSTANCES, std430) readonly buffer Instances { InstanceInfo instances[]; };
layout(set = SET_SCENE, binding = B_SCENE_MATERIALS, std430) readonly buffer Materials { MaterialGpu materials[]; };
layout(set = SET_SCENE, binding = B_SCENE_LIGHTS, std430) readonly buffer Lights { LightGpu lights[]; };
layout(set = SET_SCENE, binding = B_SCENE_PARAMS, std430) readonly buffer Params { SceneParams scene; };
layout(set = SET_SCENE, binding = B_SCENE_TEXTURES) uniform sampler2D textures[SC_TEXTURE_COUNT];
layout(set = SET_SCENE, binding = B_SCENE_ENV_MAP) uniform sampler2D env_map;
// Linear RGBA vertex colours parallel to `vertices` (read only where SC_VERTEX_COLORS).
layout(set = SET_SCENE, binding = B_SCENE_COLORS, std430) readonly buffer Colors { vec4 colors[]; };
// The second uv channel parallel to `vertices` (read only where SC_SECOND_UV).
layout(set = SET_SCENE, binding = B_SCENE_UVS2, std430) readonly buffer Uvs2 { vec2 uvs2[]; };

const float PI = 3.14159265358979323846;
const float INV_PI = 0.31830988618379067154;

uint instance_material(uint inst) { return meshes[instances[inst].mesh_pad.x].material; }

// −1 where the instance's transform mirrors (negative determinant), else 1:
// glTF's counter-clockwise front is in object space, so the world-space
// e1 × e2 of a mirrored instance's triangle points to its back.
float instance_front_sign(uint inst) { return instances[inst].mesh_pad.w != 0u ? -1.0 : 1.0; }

uvec3 triangle_indices(uint inst, uint prim) {
    MeshInfo m = meshes[instances[inst].mesh_pad.x];
    uint base = m.index_offset + 3u * prim;
    return uvec3(indices[base], indices[base + 1u], indices[base + 2u]) + m.vertex_offset;
}

vec4 sample_texture(int tex, vec2 uv, float lod) {
    return textureLod(textures[nonuniformEXT(tex)], uv, lod);
}

// Texture coordinates at barycentrics `bary` of a triangle.
vec2 triangle_uv(uint inst, uint prim, vec2 bary) {
    uvec3 vi = triangle_indices(inst, prim);
    vec3 w = vec3(1.0 - bary.x - bary.y, bary.x, bary.y);
    return w.x * vec2(vertices[vi.x].pos_u.w, vertices[vi.x].normal_v.w)
         + w.y * vec2(vertices[vi.y].pos_u.w, vertices[vi.y].normal_v.w)
         + w.z * vec2(vertices[vi.z].pos_u.w, vertices[vi.z].normal_v.w);
}

// Vertex v's second-channel uv: zero past the buffer (a scene without a
// second channel binds one stand-in, which the all-features build reads too).
vec2 vertex_uv2(uint v) { return v < uint(uvs2.length()) ? uvs2[v] : vec2(0.0); }

// The second-channel uv at barycentrics `bary` of a triangle.
vec2 triangle_uv2(uint inst, uint prim, vec2 bary) {
    uvec3 vi = triangle_indices(inst, prim);
    vec3 w = vec3(1.0 - bary.x - bary.y, bary.x, bary.y);
    return w.x * vertex_uv2(vi.x) + w.y * vertex_uv2(vi.y) + w.z * vertex_uv2(vi.z);
}

// The uv a material's texture slot reads at barycentrics `bary`: the
// second channel where the slot's bit is set in MaterialGpu.tex3.y
// (slots as gltf_uv::SLOTS: 0 base colour, 1 metallic-roughness, 2 normal,
// 3 emissive, 4 transmission, 5 specular, 6 specular colour, 7 clearcoat,
// 8 clearcoat roughness, 9 clearcoat normal).
bool slot_on_second_uv(int mask, int slot) { return SC_SECOND_UV && ((mask >> slot) & 1) != 0; }

// Whether slot `slot` reads its channel through the affine map between the
// channel's KHR_texture_transform and its own (bit in MaterialGpu.tex3.z,
// gltf_uv.rs UvAffine), and the uv it then reads at channel uv `uv`. Every
// reader of a slot's texture goes through here: material_at and the
// emitters' light sampling (lights.glsl) must read the same texel.
bool slot_mapped(MaterialGpu g, int slot) { return SC_UV_AFFINE && ((uint(g.tex3.z) >> uint(slot)) & 1u) != 0u; }
vec2 slot_map_uv(MaterialGpu g, int slot, vec2 uv) {
    if (!slot_mapped(g, slot)) return uv;
    vec4 r0 = g.uv_affine[2 * slot], r1 = g.uv_affine[2 * slot + 1];
    return vec2(dot(r0.xy, uv) + r0.z, dot(r1.xy, uv) + r1.z);
}

// Vertex v's colour: white past the buffer (a scene without colours binds
// one white stand-in, which the all-features build reads too).
vec4 vertex_color(uint v) { return v < uint(colors.length()) ? colors[v] : vec4(1.0); }

// The vertex colour (COLOR_0) at barycentrics `bary`; white without.
vec4 triangle_color(uint inst, uint prim, vec2 bary) {
    if (!SC_VERTEX_COLORS) return vec4(1.0);
    uvec3 vi = triangle_indices(inst, prim);
    vec3 w = vec3(1.0 - bary.x - bary.y, bary.x, bary.y);
    return w.x * vertex_color(vi.x) + w.y * vertex_color(vi.y) + w.z * vertex_color(vi.z);
}

// Alpha modes (MaterialGpu.tex1.y): 0 opaque, 1 MASK, 2 BLEND.
const int ALPHA_OPAQUE = 0;
const int ALPHA_MASK = 1;
const int ALPHA_BLEND = 2;

// The alpha of a material at a point: base colour factor × COLOR_0 × texture (mip 0).
float surface_alpha(MaterialGpu m, uint inst, uint prim, vec2 bary) {
    float a = m.base_color.a * triangle_color(inst, prim, bary).a;
    if (SC_TEXTURES && m.tex0.x >= 0) {
        vec2 uv = triangle_uv(inst, prim, bary);
        a *= sample_texture(m.tex0.x, uv, 0.0).a;
    }
    return a;
}

// BLEND as stochastic coverage, a screen door fixed on the surface: each
// triangle is cut into 2^16 × 2^16 barycentric cells, and a cell is solid
// when a hash of (instance, triangle, cell) falls below the alpha there. A
// ray finds the surface with probability alpha (over the hash), so paths
// average to the alpha blend (alpha·surface + (1 − alpha)·behind) without
// sorting; the cells are far below a pixel's footprint on any triangle of
// realistic size. Being fixed on the surface, the door is the same for every
// ray that crosses a point: camera rays, shadow rays, light sampling of a
// blended emitter, and the sample cache's retrace of a sample seen through
// it (a per-ray coin would hide such a sample again with probability alpha
// at each retrace, and bias the pixel towards the surface).
float coverage_coin(uint inst, uint prim, vec2 bary) {
    uvec2 cell = uvec2(clamp(bary, 0.0, 1.0) * 65536.0);
    uint h = pcg_hash(inst * 0x9E3779B9u ^ 0x626C656Eu);
    h = pcg_hash(h ^ prim);
    h = pcg_hash(h ^ (cell.x | (cell.y << 16)));
    h = pcg_hash(h ^ (cell.y >> 16) ^ (cell.x >> 16) * 0x85EBCA6Bu);
    return float(h >> 8) * (1.0 / 16777216.0);
}

// Alpha test used by both ray backends: MASK keeps alpha ≥ cutoff; BLEND
// keeps the solid cells of its screen door (coverage_coin).
bool alpha_passes(uint inst, uint prim, vec2 bary) {
    if (!SC_ALPHA_MASK) return true;
    MaterialGpu m = materials[instance_material(inst)];
    if (m.tex1.y == ALPHA_OPAQUE) return true;
    float a = surface_alpha(m, inst, prim, bary);
    if (m.tex1.y == ALPHA_BLEND) return coverage_coin(inst, prim, bary) < a;
    return a >= m.params.w;
}

#ifdef SC_MATERIAL_MEMO
#include "memo/lod.glsl"
#endif

// Everything a shading point needs, rebuilt from (instance, primitive, barycentrics).
struct Surface {
    vec3 p;        // world position
    vec3 ng;       // geometric normal, facing the incoming ray
    vec3 n;        // shading normal (interpolated, normal-mapped), same side as ng
    vec2 uv;
    vec2 uv2;      // second uv channel (zero without one)
    uint material;
    uint instance; // the hit instance (material graphs' object space)
    bool front;    // the ray hit the side the winding order calls front
    float extent;  // largest |coordinate| of the triangle's world vertices (surface_offset)
    float uv_area_ratio; // texture-space area / world area of the triangle (ray-cone LOD)
    float uv2_area_ratio; // the same for the second uv channel
    // ∂uv2/∂uv on the triangle (columns: along u, along v): material
    // graphs move their second uv set with the first in central
    // differences (scene_shaders.rs); zero where either is degenerate,
    // and in builds without graphs.
    mat2 uv2_per_uv;
    // The memoization cache's level of detail (memo/lod.glsl
    // memo_uv_per_width): the shorter uv derivative of a ray cone's
    // footprint along this ray per unit of cone width (thesis eqs.
    // 2.13-2.16, 5.2-5.4); 0 in shaders without the cache.
    float memo_uv_per_width;
    // Eq. 2.12's curvature k of the hit triangle (memo/lod.glsl
    // memo_triangle_curvature), signed towards n (so positive where the
    // surface is convex towards the incoming ray); 0 in shaders without the
    // cache.
    float memo_curvature;
    vec3 tangent;
    float tangent_sign;
    vec4 color;    // vertex colour (COLOR_0), white without
    // The clearcoat normal texture's own tangent frame (xyz, sign) where it
    // reads other uvs than the vertex tangents belong to (the normal
    // texture's: another channel, or either of them through a uv map): the
    // triangle's, from the gradients of the uvs it reads; w = 0 where the
    // vertex tangents serve, xyz = 0 for a degenerate mapping.
    vec4 coat_tangent;
};

// Tangent (direction of increasing u) and handedness w of a triangle with
// world edges e1, e2 and uv edges d1, d2, against normal n; xyz = 0 where
// the uvs are degenerate. w as the glTF tangents (mesh_ops.rs, MikkTSpace
// on glTF's v-down uvs): cross(n, t)·w points towards decreasing v.
vec4 triangle_tangent(vec3 e1, vec3 e2, vec2 d1, vec2 d2, vec3 n) {
    float det = d1.x * d2.y - d2.x * d1.y;
    if (det == 0.0) return vec4(0.0, 0.0, 0.0, 1.0);
    vec3 t = (e1 * d2.y - e2 * d1.y) / det;
    vec3 b = (e2 * d1.x - e1 * d2.x) / det;   // towards increasing v
    return vec4(t, dot(cross(n, t), b) < 0.0 ? 1.0 : -1.0);
}

Surface surface_at(uint inst, uint prim, vec2 bary, vec3 ray_dir) {
    Surface s;
    InstanceInfo I = instances[inst];
    uvec3 vi = triangle_indices(inst, prim);
    Vertex a = vertices[vi.x], b = vertices[vi.y], c = vertices[vi.z];
    vec3 w = vec3(1.0 - bary.x - bary.y, bary.x, bary.y);
    vec3 pa = (I.object_to_world * vec4(a.pos_u.xyz, 1.0)).xyz;
    vec3 pb = (I.object_to_world * vec4(b.pos_u.xyz, 1.0)).xyz;
    vec3 pc = (I.object_to_world * vec4(c.pos_u.xyz, 1.0)).xyz;
    s.p = w.x * pa + w.y * pb + w.z * pc;
    vec3 va = max(abs(pa), max(abs(pb), abs(pc)));
    s.extent = max(va.x, max(va.y, va.z));
    vec3 e1 = pb - pa, e2 = pc - pa;
    vec3 gn = cross(e1, e2);
    float area2 = length(gn);
    gn = area2 > 0.0 ? gn / area2 : vec3(0.0, 1.0, 0.0);
    vec3 n = w.x * a.normal_v.xyz + w.y * b.normal_v.xyz + w.z * c.normal_v.xyz;
    n = mat3(I.normal_to_world) * n;
    float nl = length(n);
    n = nl > 1e-20 ? n / nl : gn;
    s.uv = w.x * vec2(a.pos_u.w, a.normal_v.w) + w.y * vec2(b.pos_u.w, b.normal_v.w) + w.z * vec2(c.pos_u.w, c.normal_v.w);
    vec2 duv1 = vec2(b.pos_u.w, b.normal_v.w) - vec2(a.pos_u.w, a.normal_v.w);
    vec2 duv2 = vec2(c.pos_u.w, c.normal_v.w) - vec2(a.pos_u.w, a.normal_v.w);
    float uv_area2 = abs(duv1.x * duv2.y - duv1.y * duv2.x);
    s.uv_area_ratio = area2 > 0.0 ? uv_area2 / area2 : 0.0;
#ifdef SC_MATERIAL_MEMO
    s.memo_uv_per_width = memo_uv_per_width(ray_dir, e1, e2, duv1, duv2);
    s.memo_curvature = memo_triangle_curvature(pa, pb, pc, mat3(I.normal_to_world) * a.normal_v.xyz,
        mat3(I.normal_to_world) * b.normal_v.xyz, mat3(I.normal_to_world) * c.normal_v.xyz);
#else
    s.memo_uv_per_width = 0.0;
    s.memo_curvature = 0.0;
#endif
    s.uv2 = vec2(0.0);
    s.uv2_area_ratio = 0.0;
    s.uv2_per_uv = mat2(0.0);
    s.material = meshes[I.mesh_pad.x].material;
    s.instance = inst;
    s.coat_tangent = vec4(0.0);
    vec2 d1 = vec2(0.0), d2 = vec2(0.0);   // the second channel's uv edges
    if (SC_SECOND_UV) {
        vec2 ta = vertex_uv2(vi.x), tb = vertex_uv2(vi.y), tc = vertex_uv2(vi.z);
        s.uv2 = w.x * ta + w.y * tb + w.z * tc;
        d1 = tb - ta;
        d2 = tc - ta;
        s.uv2_area_ratio = area2 > 0.0 ? abs(d1.x * d2.y - d1.y * d2.x) / area2 : 0.0;
#ifdef SC_MATERIAL_GRAPHS
        // [d1 d2] = J·[duv1 duv2] on the triangle's plane. Only material
        // graphs read it (scene_shaders.rs), so other builds skip it.
        float det_uv = duv1.x * duv2.y - duv1.y * duv2.x;
        if (det_uv != 0.0) s.uv2_per_uv = mat2(d1, d2) * inverse(mat2(duv1, duv2));
#endif
    }
    if (SC_CLEARCOAT && (SC_SECOND_UV || SC_UV_AFFINE)) {
        // The vertex tangents belong to the normal texture's uvs (its
        // channel, read through its map or not), else to the clearcoat
        // normal texture's (gltf_import.rs). With both textures, the coat's
        // frame is its own where its uvs differ from the normal texture's
        // by more than an offset: another channel, or another linear part
        // of the slots' maps (gltf_uv.rs UvAffine; none = the identity).
        // The map's linear part takes the channel's uv edges to the
        // mapped ones.
        MaterialGpu g = materials[s.material];
        bool coat_second = slot_on_second_uv(g.tex3.y, 9);
        mat2 coat_map = slot_mapped(g, 9) ? mat2(g.uv_affine[18].x, g.uv_affine[19].x, g.uv_affine[18].y, g.uv_affine[19].y) : mat2(1.0);
        mat2 normal_map = slot_mapped(g, 2) ? mat2(g.uv_affine[4].x, g.uv_affine[5].x, g.uv_affine[4].y, g.uv_affine[5].y) : mat2(1.0);
        if (g.tex2.z >= 0 && g.tex0.z >= 0
            && (coat_second != slot_on_second_uv(g.tex3.y, 2) || coat_map != normal_map)) {
            vec2 c1 = coat_second ? d1 : duv1, c2 = coat_second ? d2 : duv2;
            s.coat_tangent = triangle_tangent(e1, e2, coat_map * c1, coat_map * c2, n);
        }
    }
    // glTF's front is counter-clockwise in object space: the world-space
    // e1 × e2 is the front normal times instance_front_sign (a mirroring
    // node keeps its faces' sides). ng then faces the ray either way (it
    // did not on mirrored instances before session 37: their paths ended
    // at every hit, black but for emission).
    gn *= instance_front_sign(inst);
    s.front = dot(gn, ray_dir) < 0.0;
    if (!s.front) gn = -gn;
    vec4 t = w.x * a.tangent + w.y * b.tangent + w.z * c.tangent;
    s.tangent = mat3(I.object_to_world) * t.xyz;
    // The bitangent is cross(n, t)·w (glTF) in object space; a mirroring
    // transform turns the cross product of the transformed vectors over, so
    // the world-space sign carries the instance's front sign too.
    s.tangent_sign = (t.w < 0.0 ? -1.0 : 1.0) * instance_front_sign(inst);
    if (dot(n, gn) < 0.0) {
        // Seen from the other side the whole tangent frame turns over, as
        // the glTF sample viewer's does for a back face: normal, tangent
        // and bitangent negated (B = cross(n, t)·w needs w negated too), so
        // a mapped normal is the front's negated, not its mirror image
        // through the surface (tests/material_extensions.rs
        // `normal_maps_seen_from_behind_are_the_front_normal_negated`).
        n = -n;
        s.tangent = -s.tangent;
        s.tangent_sign = -s.tangent_sign;
        s.coat_tangent = -s.coat_tangent;   // xyz and its sign w alike
        s.memo_curvature = -s.memo_curvature;   // k is the vertex normals' side's
    }
    s.ng = gn;
    s.n = n;
    s.color = SC_VERTEX_COLORS ? w.x * vertex_color(vi.x) + w.y * vertex_color(vi.y) + w.z * vertex_color(vi.z) : vec4(1.0);
    return s;
}

// Offsets a ray origin off a surface so it does not re-hit it
// (Wächter & Binder, Ray Tracing Gems ch. 6).
vec3 offset_ray(vec3 p, vec3 n) {
    const float origin = 1.0 / 32.0, float_scale = 1.0 / 65536.0, int_scale = 256.0;
    ivec3 of_i = ivec3(int_scale * n);
    vec3 p_i = vec3(intBitsToFloat(floatBitsToInt(p.x) + ((p.x < 0.0) ? -of_i.x : of_i.x)),
                    intBitsToFloat(floatBitsToInt(p.y) + ((p.y < 0.0) ? -of_i.y : of_i.y)),
                    intBitsToFloat(floatBitsToInt(p.z) + ((p.z < 0.0) ? -of_i.z : of_i.z)));
    return vec3(abs(p.x) < origin ? p.x + float_scale * n.x : p_i.x,
                abs(p.y) < origin ? p.y + float_scale * n.y : p_i.y,
                abs(p.z) < origin ? p.z + float_scale * n.z : p_i.z);
}

// offset_ray for a surface point: the Wächter–Binder offset of p, or, where
// it is smaller, 64 ulps of the triangle's largest vertex coordinate along
// n. The rounding error of p (the barycentric interpolation of the
// vertices: a few ulps of them; the hit's t) grows with the vertices, not
// with p: a large triangle passing near the origin (the render origin sits
// at the scene's centre) re-hit itself from offset_ray(p) alone (a tilted
// quad of 2 km: a fifth of the bounce rays, tests/furnace.rs
// `a_large_plane_near_the_origin_does_not_shadow_itself`). The offset is
// 7.6·10⁻⁶ of the vertex coordinates (0.08 mm for a scene within 10 m of
// its origin), small against any geometry's features.
vec3 offset_off_surface(vec3 p, vec3 n, float extent) {
    vec3 o = offset_ray(p, n);
    float e = extent * (64.0 / 8388608.0);
    vec3 d = o - p;
    return dot(d, d) >= e * e ? o : p + n * e;
}
vec3 surface_offset(Surface s, vec3 n) { return offset_off_surface(s.p, n, s.extent); }

// A scene's material graphs (issue 17): generated at scene load and compiled
// in only for scenes that have them (src/materials/scene_shaders.rs).
#ifdef SC_MATERIAL_GRAPHS
#include "materialx/scene_graphs.glsl"
#ifdef SC_MATERIAL_MEMO
#include "common/memo.glsl"
#endif
#endif
#endif
