// Level of detail and texel snapping of the memoization cache (Urbach 2023,
// thesis §2.2 and §5.3.2). CPU twin: src/materials/memo/lod.rs.
// A level m is a texel density of 2^m texels per unit of uv (eq. 5.1), with
// no minimum or maximum size: every level covers the whole uv plane.
#ifndef MEMO_LOD_GLSL
#define MEMO_LOD_GLSL

const int MEMO_MIN_LEVEL = -8, MEMO_MAX_LEVEL = 22;

// Eqs. 2.13-2.16 and 5.2-5.4: the shorter uv derivative of a ray cone's
// footprint, per unit of cone width, for a hit along `dir` on a triangle
// of world edges e1, e2 and uv edges d1, d2 (vertex 1 and 2 minus vertex
// 0). The footprint is the ellipse the cone cuts from the triangle's
// plane (normal n): its vertex direction h1 = ProjectOnPlane(d, n)
// (eq. 2.13), its co-vertex direction h2 = n x h1 (eq. 2.14), at the
// distances r / |ProjectOnPlane(h1, d)| = r / |cos theta| and
// r / |ProjectOnPlane(h2, d)| = r from the hit (eqs. 2.15-2.16, h1 and h2
// unit vectors, so h2 is across the ray). The uvs at P1 and P2 come from
// barycentric interpolation: uv moves by J a for a step a in the plane,
// J = d1 (grad b)^T + d2 (grad c)^T with grad b = (e2 x N) / |N|^2,
// grad c = (N x e1) / |N|^2, N = e1 x e2. r is the cone's width w (the
// caller multiplies): a step across one pixel's cone is what a
// rasteriser's screen-space derivative measures (eqs. 5.2-5.3), so on a
// uniformly scaled uv map the level is the isotropic one, w sqrt(uv area /
// world area). Head-on (h1 = 0) the footprint is a circle: its axes are
// taken along e1 and n x e1. 0 for a degenerate triangle or uv map (the
// finest level).
float memo_uv_per_width(vec3 dir, vec3 e1, vec3 e2, vec2 d1, vec2 d2) {
    vec3 N = cross(e1, e2);
    float nn = dot(N, N);
    if (!(nn > 0.0)) return 0.0;
    vec3 gb = cross(e2, N) / nn, gc = cross(N, e1) / nn;
    vec3 n = N * inversesqrt(nn);
    vec3 d = normalize(dir);
    float c = dot(d, n);
    vec3 h1 = d - c * n;
    float s2 = dot(h1, h1);
    h1 = s2 > 1e-12 ? h1 * inversesqrt(s2) : normalize(e1);
    vec3 h2 = cross(n, h1);
    vec2 j1 = d1 * dot(h1, gb) + d2 * dot(h1, gc);
    vec2 j2 = d1 * dot(h2, gb) + d2 * dot(h2, gc);
    return min(length(j1) / max(abs(c), 1e-6), length(j2));
}

// Eq. 5.5: m = round(log2(1 / l_min) + bias) with l_min = |cone_width| *
// uv_per_width (memo_uv_per_width; the thesis writes log2 of the texel
// density 1 / l_min; a cone focused by a concave mirror past its focus has
// a negative width, eq. 2.12). No cone (w = 0): the finest level.
int memo_level(float cone_width, float uv_per_width, float bias) {
    float l = abs(cone_width) * max(uv_per_width, 0.0);
    if (!(l > 0.0)) return MEMO_MAX_LEVEL;
    // Clamped as a float first: l may be +inf (eq. 2.12's |n.d| floor of
    // 1e-6 at grazing curved bounces overflows f32 in a few bounces), and
    // int(-inf) is undefined in SPIR-V (Rust's `as i32` saturates).
    return int(clamp(floor(-log2(l) + bias + 0.5), float(MEMO_MIN_LEVEL), float(MEMO_MAX_LEVEL)));
}

// Whether level m's texel grid holds uv exactly: |2^m u|, |2^m v| < 2^23,
// where x + 0.5 and floor are exact in f32 (at 2^23 and above an odd x +
// 0.5 ties to the even neighbour, a whole texel off, and from 2^30 the
// clamp below sends every uv to one texel). Lookups whose uv does not fit
// (far-out uvs at a fine level, e.g. level 22 on a triangle of one uv)
// evaluate directly (common/memo.glsl memo_call; lod.rs `fits`). NaN does
// not fit.
bool memo_fits(vec2 uv, int level) {
    vec2 x = abs(ldexp(uv, ivec2(level)));
    // Per component: max(NaN, y) may return y (GLSL.std.450 FMax), which
    // let a NaN uv through; a comparison with NaN is false.
    return all(lessThan(x, vec2(8388608.0)));
}

// Eqs. 5.6-5.7: the nearest texel centre, (û, v̂) = round(2^m (u, v))
// (halves round up; ldexp is exact, so the same on every device and the
// CPU), clamped into int range; exact where memo_fits.
ivec2 memo_quantise(vec2 uv, int level) {
    vec2 x = clamp(ldexp(uv, ivec2(level)) + 0.5, vec2(-1073741824.0), vec2(1073741760.0));
    return ivec2(floor(x));
}

// The uv width of a texel of level m, 2^-m: the footprint its value stands
// for (image nodes in graphs read the matching mip level).
float memo_texel_width(int level) { return ldexp(1.0, -level); }

// The uv of a texel centre: where the graph is evaluated on a miss
// (texel-centre snapping), at most 2^-(m+1) from the hit's uv per axis.
vec2 memo_snapped_uv(ivec2 q, int level) { return ldexp(vec2(q), ivec2(-level)); }

// Eqs. 2.10-2.11: the cone past a GGX surface of roughness alpha (GGX's
// alpha): width w + spread * t at the next hit; the surface adds
// beta_r = 2 sqrt(alpha^2 / (2 - 2 alpha^2)) to the spread (to the
// roughness blur's, memo_cone_at below).
float memo_cone_width(float width, float spread, float t) { return width + spread * t; }
float memo_roughness_spread(float alpha) {
    float a2 = min(alpha * alpha, 0.999);
    return 2.0 * sqrt(a2 / (2.0 - 2.0 * a2));
}

// Eq. 2.12's k: the curvature of a triangle with smooth vertex normals
// (world positions p, world normals n, all on one side; normalised here),
// from the normal's turn along its edges: along the edge from p_i to p_j
// the normal curvature is about (n_j - n_i).(p_j - p_i) / |p_j - p_i|^2,
// exactly 1/R on a sphere of radius R whose vertex normals are p/R (either
// side: the sign is the normals'), 0 on a flat triangle; positive where the
// normals diverge (convex towards them). The isotropic k is the mean over
// the three edges (a cylinder's triangles give a value between its 0 and
// 1/R). The thesis names k without saying how it is found; this estimate
// is ours (docs/MATERIALS.md, "Curvature").
float memo_edge_curvature(vec3 pi, vec3 pj, vec3 ni, vec3 nj) {
    vec3 e = pj - pi;
    float ee = dot(e, e);
    return ee > 0.0 ? dot(nj - ni, e) / ee : 0.0;
}
float memo_triangle_curvature(vec3 pa, vec3 pb, vec3 pc, vec3 na, vec3 nb, vec3 nc) {
    vec3 l = vec3(dot(na, na), dot(nb, nb), dot(nc, nc));
    if (!all(greaterThan(l, vec3(0.0)))) return 0.0;   // no smooth normals
    na *= inversesqrt(l.x);
    nb *= inversesqrt(l.y);
    nc *= inversesqrt(l.z);
    float k = (memo_edge_curvature(pa, pb, na, nb) + memo_edge_curvature(pb, pc, nb, nc) +
               memo_edge_curvature(pc, pa, nc, na)) / 3.0;
    return abs(k) < 1e30 ? k : 0.0;
}

// Eq. 2.12: beta_c = -2 k w / (n.d), the spread a reflection off a surface
// of curvature k (towards the normal n, which faces the incoming ray d, so
// n.d < 0) adds to a cone of width w: a convex mirror (k > 0) widens it, a
// concave one narrows it (a negative spread focuses: the width may pass
// through 0 and change sign, memo_level takes its magnitude). This is the
// spread in the plane of incidence, where the footprint is w / |cos theta|
// long; across it a reflection turns the rays by 2 k w |cos theta| (the cone
// stays isotropic, as the thesis's is). |n.d| is kept off 0 as
// memo_uv_per_width keeps it.
float memo_curvature_spread(float k, float width, float n_dot_d) {
    return 2.0 * k * width / max(abs(n_dot_d), 1e-6);
}

// The cone in two parts. The thesis sums the spreads (alpha + beta_r +
// beta_c), so a concave surface's negative beta_c can cancel the spread
// its own or an earlier surface's roughness added and focus the whole cone
// through zero width; past a rough bounce (beta_r up to ~45 rad for GGX
// alpha 1, a width of tens of metres at the next hit) a concave facet's
// beta_c = -2 k w / (n.d) is of that size too, and hits near the focus take
// the finest level (a fresh key nearly every time: session 51's bisect,
// docs/PERFORMANCE.md). Roughness is a statistical spread (eq. 2.11: the
// width of the GGX lobe each point of the footprint scatters into), not a
// pencil of rays that a later mirror can refocus; curvature turns the
// geometric pencil. So the cone is kept as the geometric pencil (signed
// width w, spread s: the eye's, turned by eq. 2.12 at each reflection, which
// may focus it) plus the roughness blur (width b >= 0 grown by the sum of
// the surfaces' beta_r), and its width at distance t is
// |w + s t| + b + beta t. Along mirrors (beta_r = 0) this is the thesis's
// cone exactly; past one rough surface without curvature it is the
// thesis's w + (s + beta_r) t wherever the pencil has not focused.
// Elsewhere it is never narrower than the blur (coarser levels than the
// summed cone; the snapping error stays within the blur's footprint).
// A deviation from the thesis (docs/MATERIALS.md "Curvature").
float memo_cone_at(float w, float s, float blur_w, float blur_s, float t) {
    return abs(w + s * t) + blur_w + blur_s * t;
}
#endif
