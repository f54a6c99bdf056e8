#version 460
// One secondary path per updated cell: the thread that touched the cell first
// this frame traces path_radiance from its jittered first hit (the shared
// integrator, as sample_cache/shade.comp does), removes the first hit's
// emission, demodulates (common/demodulation.glsl) and folds the result into the
// cell's running mean (count capped at max_samples; a freshly reserved or
// evicted cell starts over). Pixels without a cell (probe failure) trace
// their own path into `fallback`.
#include "hash_table/table.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
#ifdef SC_MATERIAL_MEMO
    sc_memo_eye = eye;
#endif
    if (any(greaterThanEqual(px, size))) return;
    uint pixel = px.y * size.x + px.x;
    uint pm = eye * npix() + pixel;
    uvec4 cell = pix_cell[pm];
    uint st = cell.y & 15u;
    bool winner = (cell.y & 16u) != 0u;
    if (st == ST_MISS || (st != ST_FAILED && !winner)) return;
    EyeGpu e = frame.eyes[eye];
    vec4 ray = pix_ray[pm];
    uvec4 ph = pix_hit[pm];
    RtHit h;
    h.t = ray.w;
    h.bary = uintBitsToFloat(ph.xy);
    h.prim = ph.z;
    h.instance = ph.w;
    vec3 d = ray.xyz;
    Surface s = surface_at(h.instance, h.prim, h.bary, d);
    vec3 o = s.p - h.t * d;   // the ray's origin (path_radiance takes the first hit from h)
    vec2 cone = eye_cone(e, h.t);
    Rng rng = rng_init(frame.size_seed.z, pc.now, eye, pixel, 0x4A5C0002u);
    RayCounts rays = RayCounts(0u, 0u);
    ShadingMaterial m;
    vec3 L = path_radiance_first(o, d, true, h, cone, rng, rays, m);
    if (drop_non_finite(L)) atomicAdd(counters[C_HT_NONFINITE_SAMPLES], 1u);   // (integrator.glsl)
    vec3 Le = SC_EMISSIVE ? m.emissive : vec3(0.0);
    vec3 demod = max(L - Le, vec3(0.0)) / demodulation_factor(m);
    if (st == ST_FAILED) {
        fallback[pm] = vec4(demod, 1.0);
        atomicAdd(counters[C_HT_FALLBACK], 1u);
    } else {
        vec4 c = st == ST_FOUND ? cells[cell.x] : vec4(0.0);
        float n = min(c.w + 1.0, float(pc.max_samples));
        cells[cell.x] = vec4(mix(c.rgb, demod, 1.0 / n), n);
        atomicAdd(counters[C_HT_UPDATES], 1u);
    }
    atomicAdd(counters[C_HT_BOUNCE], rays.bounce);
    atomicAdd(counters[C_HT_SHADOW], rays.shadow);
}
