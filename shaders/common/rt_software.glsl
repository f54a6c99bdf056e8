// Software backend: traversal of obvhs's compressed wide BVH8 (CWBVH, Ylitie,
// Karras & Laine, HPG 2017) from storage buffers: over all triangles in world
// space (flattened), or two-level (SC_TWO_LEVEL, cw_traverse_two_level). Node layout = obvhs::cwbvh::CwBvhNode (80 bytes = 5 × uvec4):
//   n0 = (p.x, p.y, p.z, e0 | e1 << 8 | e2 << 16 | imask << 24)
//   n1 = (child_base_idx, primitive_base_idx, child_meta[0..4], child_meta[4..8])
//   n2 = (qlo_x[0..4], qlo_x[4..8], qhi_x[0..4], qhi_x[4..8])
//   n3 = same for y, n4 = same for z
// Leaf triangles are stored in BVH order: tri_verts[3k..3k+3] = their
// vertices (v0, v1, v2), and tri_ref[k] = (instance, primitive) for leaf
// slot k.
#include "interface/scene.glsl"
layout(set = SET_SCENE, binding = B_SCENE_BVH_NODES, std430) readonly buffer BvhNodes { uvec4 bvh_nodes[]; };
layout(set = SET_SCENE, binding = B_SCENE_BVH_TRI_REF, std430) readonly buffer BvhTriRef { uvec2 tri_ref[]; };
layout(set = SET_SCENE, binding = B_SCENE_BVH_TRI_VERTS, std430) readonly buffer BvhTriVerts { vec4 tri_verts[]; };

const uint CWBVH_STACK_SIZE = 32u;

uint cw_byte(uvec2 w, uint i) { return ((i < 4u ? w.x : w.y) >> ((i & 3u) * 8u)) & 0xFFu; }

// Watertight ray/triangle test (Woop, Benthin & Wald 2013, "Watertight
// Ray/Triangle Intersection", JCGT 2(1)). CPU twin, operation for operation:
// WatertightRay in src/rt/bvh.rs. `precise` keeps the compiler from fusing
// or reordering: a shared edge is watertight only if both triangles round
// the same products (an FMA would round one of them less).
//
// Per ray (wt_ray): kz = the axis of the largest |d_i| (ties: the higher
// axis), kx, ky the next two cyclically, swapped when d[kz] < 0 so the
// projected triangle keeps its winding; S = (d[kx]/d[kz], d[ky]/d[kz],
// 1/d[kz]), the x and y parts as d[k]·(1/d[kz]) (one reciprocal on both
// sides). The shear takes the ray to the origin along +z.
struct WtRay {
    vec3 o;
    uvec3 k;  // (kx, ky, kz)
    vec3 s;   // (Sx, Sy, Sz)
};

float wt_comp(vec3 v, uint i) { return i == 0u ? v.x : (i == 1u ? v.y : v.z); }

WtRay wt_ray(vec3 o, vec3 d) {
    vec3 a = abs(d);
    uint kz = a.x > a.y ? (a.x > a.z ? 0u : 2u) : (a.y > a.z ? 1u : 2u);
    uint kx = kz == 2u ? 0u : kz + 1u;
    uint ky = kx == 2u ? 0u : kx + 1u;
    precise float dz = wt_comp(d, kz);
    if (dz < 0.0) {
        uint swp = kx;
        kx = ky;
        ky = swp;
    }
    precise float sz = 1.0 / dz;
    precise float sx = wt_comp(d, kx) * sz;
    precise float sy = wt_comp(d, ky) * sz;
    WtRay r;
    r.o = o;
    r.k = uvec3(kx, ky, kz);
    r.s = vec3(sx, sy, sz);
    return r;
}

// Against a stored triangle (v0, v1, v2), each vertex taken to ray space on
// its own, so a vertex two triangles share lands on the same point in both
// (until session 48 the vertices were read as v0 + e1 and v0 + e2, an ulp
// off the neighbour's for some triangles). Returns t along the ray's own
// (unnormalised) direction, or -1; bary = weights of vertices 1 and 2; the
// caller tests t > tmin && t < h.t.
// Edge functions U (v1→v2), V (v2→v0), W (v0→v1): the neighbour across an
// edge evaluates it from the same two points with the operands swapped,
// which gives exactly the negated value, so both never reject a ray for it.
// The paper recomputes an edge value of exactly 0 in double precision (not
// on every device); here 0 counts as inside in both triangles: both report
// the hit and the closer is kept, so no ray falls through an edge, and a
// value rounded to 0 can only add a hit within rounding of the edge.
float intersect_triangle(WtRay r, vec3 v0, vec3 v1, vec3 v2, out vec2 bary) {
    bary = vec2(0.0);
    precise vec3 a = v0 - r.o;
    precise vec3 b = v1 - r.o;
    precise vec3 c = v2 - r.o;
    float akx = wt_comp(a, r.k.x), aky = wt_comp(a, r.k.y), akz = wt_comp(a, r.k.z);
    float bkx = wt_comp(b, r.k.x), bky = wt_comp(b, r.k.y), bkz = wt_comp(b, r.k.z);
    float ckx = wt_comp(c, r.k.x), cky = wt_comp(c, r.k.y), ckz = wt_comp(c, r.k.z);
    precise float ax = akx - r.s.x * akz;
    precise float ay = aky - r.s.y * akz;
    precise float bx = bkx - r.s.x * bkz;
    precise float by = bky - r.s.y * bkz;
    precise float cx = ckx - r.s.x * ckz;
    precise float cy = cky - r.s.y * ckz;
    precise float u = cx * by - cy * bx;
    precise float v = ax * cy - ay * cx;
    precise float w = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return -1.0;
    precise float det = u + v + w;
    if (det == 0.0) return -1.0;
    precise float az = r.s.z * akz;
    precise float bz = r.s.z * bkz;
    precise float cz = r.s.z * ckz;
    precise float t = u * az + v * bz + w * cz;
    precise float inv = 1.0 / det;
    precise float bu = v * inv;
    precise float bv = w * inv;
    bary = vec2(bu, bv);
    precise float th = t * inv;
    return th;
}

// Back-face culling (glTF doubleSided false): v0.w is 0, or for a culling
// material the sign that makes w·((v1 − v0) × (v2 − v0)) the front normal (src/rt/bvh.rs:
// the instance determinant's sign for world-space triangles; 1 in a BLAS,
// whose object space is where glTF's counter-clockwise front is defined).
// The ray passes through a triangle it meets from behind. CPU twin: bvh.rs
// `closest_hit`.
bool culled(vec4 v0, vec3 v1, vec3 v2, vec3 d) {
    return SC_BACKFACE_CULLING && dot(cross(v1 - v0.xyz, v2 - v0.xyz), d) * v0.w > 0.0;
}

// Child hit mask of one node for the ray: bits 24..31 = internal children
// (slot order permuted by octant), bits 0..23 = leaf triangles (unary counts).
uint cw_intersect_node(uint node, vec3 o, vec3 inv_d, uint oct_inv4, float tmin, float tmax) {
    uvec4 n0 = bvh_nodes[5u * node + 0u];
    uvec4 n1 = bvh_nodes[5u * node + 1u];
    uvec4 n2 = bvh_nodes[5u * node + 2u];
    uvec4 n3 = bvh_nodes[5u * node + 3u];
    uvec4 n4 = bvh_nodes[5u * node + 4u];
    vec3 p = uintBitsToFloat(n0.xyz);
    vec3 ext = vec3(uintBitsToFloat((n0.w & 0xFFu) << 23), uintBitsToFloat(((n0.w >> 8) & 0xFFu) << 23),
                    uintBitsToFloat(((n0.w >> 16) & 0xFFu) << 23));
    vec3 adj_inv = ext * inv_d;
    vec3 adj_o = (p - o) * inv_d;
    // Conservative slabs (Ize 2013, "Robust BVH Ray Traversal", JCGT 2(2)):
    // t0 and t1 below round at most about six times relative to
    // |q·ext/d| + |(p − o)/d| ≤ 255·|adj_inv| + |adj_o| (q ≤ 255), so each
    // slab is widened by 2^-20 (16 units in the last place) of that bound.
    // Without it a ray aimed at a vertex on a child box's plane could leave
    // the box by rounding before it entered it and miss the triangle there.
    // CPU twin: src/rt/bvh.rs `intersect_node`.
    vec3 pad = (255.0 * abs(adj_inv) + abs(adj_o)) * (1.0 / 1048576.0);
    vec3 adj_lo = adj_o - pad, adj_hi = adj_o + pad;
    bvec3 neg = lessThan(inv_d, vec3(0.0));
    uint oct = oct_inv4 & 0xFFu;
    uint hit_mask = 0u;
    for (uint i = 0u; i < 8u; ++i) {
        uint meta = cw_byte(n1.zw, i);
        if (meta == 0u) continue;
        vec3 lo = vec3(cw_byte(n2.xy, i), cw_byte(n3.xy, i), cw_byte(n4.xy, i));
        vec3 hi = vec3(cw_byte(n2.zw, i), cw_byte(n3.zw, i), cw_byte(n4.zw, i));
        vec3 qmin = mix(lo, hi, neg);
        vec3 qmax = mix(hi, lo, neg);
        vec3 t0 = qmin * adj_inv + adj_lo;
        vec3 t1 = qmax * adj_inv + adj_hi;
        float tn = max(max(t0.x, t0.y), max(t0.z, tmin));
        float tf = min(min(t1.x, t1.y), min(t1.z, tmax));
        if (tn <= tf) {
            bool inner = (meta & 0x18u) == 0x18u;
            uint child_bits = meta >> 5;
            uint bit_index = (meta ^ (inner ? oct : 0u)) & 0x1Fu;
            hit_mask |= child_bits << bit_index;
        }
    }
    return hit_mask;
}

vec3 safe_inverse(vec3 d) {
    const float tiny = 1e-30;
    return vec3(1.0) / vec3(abs(d.x) > tiny ? d.x : (d.x < 0.0 ? -tiny : tiny),
                            abs(d.y) > tiny ? d.y : (d.y < 0.0 ? -tiny : tiny),
                            abs(d.z) > tiny ? d.z : (d.z < 0.0 ? -tiny : tiny));
}

// The ray's octant, inverted, in every byte (child slot order of a node).
uint cw_octant_inv4(vec3 d) {
    return (d.x < 0.0 ? 0u : 0x04040404u) | (d.y < 0.0 ? 0u : 0x02020202u) | (d.z < 0.0 ? 0u : 0x01010101u);
}

// any_hit = true returns at the first accepted triangle (shadow rays).
bool cw_traverse(vec3 o, vec3 d, float tmin, float tmax, bool any_hit, out RtHit h) {
    h.t = tmax;
    h.instance = 0xFFFFFFFFu;
    h.prim = 0u;
    h.bary = vec2(0.0);
    vec3 inv_d = safe_inverse(d);
    uint oct_inv4 = cw_octant_inv4(d);
    WtRay wr = wt_ray(o, d);
    uvec2 stack[CWBVH_STACK_SIZE];
    uint sp = 0u;
    uvec2 current = uvec2(0u, 0x80000000u);
    uvec2 prims = uvec2(0u);
    bool found = false;
    for (;;) {
        while (prims.y != 0u) {
            uint local = uint(findMSB(prims.y));
            prims.y &= ~(1u << local);
            uint k = prims.x + local;
            vec2 bary;
            vec4 v0 = tri_verts[3u * k];
            vec3 v1 = tri_verts[3u * k + 1u].xyz, v2 = tri_verts[3u * k + 2u].xyz;
            float t = intersect_triangle(wr, v0.xyz, v1, v2, bary);
            if (t > tmin && t < h.t && !culled(v0, v1, v2, d)) {
                uvec2 ref = tri_ref[k];
                if (alpha_passes(ref.x, ref.y, bary)) {
                    h.t = t;
                    h.instance = ref.x;
                    h.prim = ref.y;
                    h.bary = bary;
                    found = true;
                    if (any_hit) return true;
                }
            }
        }
        if ((current.y & 0xFF000000u) != 0u) {
            uint hits_imask = current.y;
            uint child_offset = uint(findMSB(hits_imask));
            uint child_base = current.x;
            current.y &= ~(1u << child_offset);
            if ((current.y & 0xFF000000u) != 0u) {
                if (sp < CWBVH_STACK_SIZE) stack[sp++] = current;
            }
            uint slot = (child_offset - 24u) ^ (oct_inv4 & 0xFFu);
            uint relative = bitCount(hits_imask & ~(0xFFFFFFFFu << slot));
            uint node = child_base + relative;
            uint hit_mask = cw_intersect_node(node, o, inv_d, oct_inv4, tmin, h.t);
            uvec4 n0 = bvh_nodes[5u * node];
            uvec4 n1 = bvh_nodes[5u * node + 1u];
            current = uvec2(n1.x, (hit_mask & 0xFF000000u) | (n0.w >> 24));
            prims = uvec2(n1.y, hit_mask & 0x00FFFFFFu);
        } else {
            current = uvec2(0u);
        }
        if (prims.y == 0u && (current.y & 0xFF000000u) == 0u) {
            if (sp == 0u) break;
            current = stack[--sp];
        }
    }
    return found;
}

// Two-level traversal (src/rt/two_level.rs): the TLAS (root node 0) over
// instance boxes in world space; at an instance leaf k, tri_ref[k] =
// (instance, BLAS root) and tri_verts[3k..3k+3] = the rows of its
// object-from-world matrix. The ray is taken to object space (direction not
// normalized, so t is the same parameter in both spaces), the BLAS is walked
// on the same stack above the TLAS entries, then the TLAS state and the
// world ray are restored. Stack need: TLAS depth + 1 + BLAS depth (checked on
// the CPU against CWBVH_STACK_SIZE).
bool cw_traverse_two_level(vec3 wo, vec3 wd, float tmin, float tmax, bool any_hit, out RtHit h) {
    h.t = tmax;
    h.instance = 0xFFFFFFFFu;
    h.prim = 0u;
    h.bary = vec2(0.0);
    vec3 w_inv_d = safe_inverse(wd);
    uint w_oct = cw_octant_inv4(wd);
    vec3 o = wo;
    vec3 d = wd;
    vec3 inv_d = w_inv_d;
    uint oct_inv4 = w_oct;
    // The triangle test's per-ray constants, for the object-space ray of the
    // BLAS being walked (set at its instance leaf; TLAS leaves are boxes).
    WtRay wr;
    uvec2 stack[CWBVH_STACK_SIZE];
    uint sp = 0u;
    uvec2 current = uvec2(0u, 0x80000000u);
    uvec2 prims = uvec2(0u);
    bool found = false;
    // The TLAS state saved while a BLAS is walked.
    bool in_blas = false;
    uint inst = 0u;
    uint tlas_sp = 0u;
    uvec2 tlas_current = uvec2(0u);
    uvec2 tlas_prims = uvec2(0u);
    for (;;) {
        while (prims.y != 0u) {
            uint local = uint(findMSB(prims.y));
            prims.y &= ~(1u << local);
            uint k = prims.x + local;
            if (in_blas) {
                vec2 bary;
                vec4 v0 = tri_verts[3u * k];
                vec3 v1 = tri_verts[3u * k + 1u].xyz, v2 = tri_verts[3u * k + 2u].xyz;
                float t = intersect_triangle(wr, v0.xyz, v1, v2, bary);
                if (t > tmin && t < h.t && !culled(v0, v1, v2, d)) {
                    uint prim = tri_ref[k].y;
                    if (alpha_passes(inst, prim, bary)) {
                        h.t = t;
                        h.instance = inst;
                        h.prim = prim;
                        h.bary = bary;
                        found = true;
                        if (any_hit) return true;
                    }
                }
            } else {
                uvec2 ref = tri_ref[k];
                vec4 r0 = tri_verts[3u * k];
                vec4 r1 = tri_verts[3u * k + 1u];
                vec4 r2 = tri_verts[3u * k + 2u];
                o = vec3(dot(r0.xyz, wo) + r0.w, dot(r1.xyz, wo) + r1.w, dot(r2.xyz, wo) + r2.w);
                d = vec3(dot(r0.xyz, wd), dot(r1.xyz, wd), dot(r2.xyz, wd));
                inv_d = safe_inverse(d);
                oct_inv4 = cw_octant_inv4(d);
                wr = wt_ray(o, d);
                tlas_current = current;
                tlas_prims = prims;
                tlas_sp = sp;
                inst = ref.x;
                current = uvec2(ref.y, 0x80000000u);
                prims = uvec2(0u);
                in_blas = true;
                break;
            }
        }
        if ((current.y & 0xFF000000u) != 0u) {
            // The descent of cw_traverse, inlined (a function would copy the stack).
            uint hits_imask = current.y;
            uint child_offset = uint(findMSB(hits_imask));
            uint child_base = current.x;
            current.y &= ~(1u << child_offset);
            if ((current.y & 0xFF000000u) != 0u) {
                if (sp < CWBVH_STACK_SIZE) stack[sp++] = current;
            }
            uint slot = (child_offset - 24u) ^ (oct_inv4 & 0xFFu);
            uint relative = bitCount(hits_imask & ~(0xFFFFFFFFu << slot));
            uint node = child_base + relative;
            uint hit_mask = cw_intersect_node(node, o, inv_d, oct_inv4, tmin, h.t);
            uvec4 n0 = bvh_nodes[5u * node];
            uvec4 n1 = bvh_nodes[5u * node + 1u];
            current = uvec2(n1.x, (hit_mask & 0xFF000000u) | (n0.w >> 24));
            prims = uvec2(n1.y, hit_mask & 0x00FFFFFFu);
        } else {
            current = uvec2(0u);
        }
        if (prims.y == 0u && (current.y & 0xFF000000u) == 0u) {
            if (in_blas && sp == tlas_sp) {
                in_blas = false;
                o = wo;
                d = wd;
                inv_d = w_inv_d;
                oct_inv4 = w_oct;
                current = tlas_current;
                prims = tlas_prims;
                continue;
            }
            if (sp == 0u) break;
            current = stack[--sp];
        }
    }
    return found;
}

bool rt_closest_hit(vec3 o, vec3 d, float tmin, float tmax, out RtHit h) {
    if (SC_TWO_LEVEL) return cw_traverse_two_level(o, d, tmin, tmax, false, h);
    return cw_traverse(o, d, tmin, tmax, false, h);
}

bool rt_occluded(vec3 o, vec3 d, float tmin, float tmax) {
    RtHit h;
    if (SC_TWO_LEVEL) return cw_traverse_two_level(o, d, tmin, tmax, true, h);
    return cw_traverse(o, d, tmin, tmax, true, h);
}
