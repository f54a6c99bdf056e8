#version 460
// Final colour = demodulation factor (the material's albedo under uniform
// light, as update.comp divides by it: common/demodulation.glsl) × cell radiance + first-hit emission (the
// environment for misses); debug views: voxel id, level of detail, cell
// samples / max_samples, lookup status.
#include "hash_table/table.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

const uint VIEWS = 4u;

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
    vec3 c;
    vec4 rec = vec4(0.0);
    if (st == ST_MISS) {
        c = fallback[pm].rgb;
    } else {
        EyeGpu e = frame.eyes[eye];
        vec4 ray = pix_ray[pm];
        uvec4 ph = pix_hit[pm];
        Surface s = surface_at(ph.w, ph.z, uintBitsToFloat(ph.xy), ray.xyz);
        ShadingMaterial m = material_at(s, ray.xyz, eye_cone(e, ray.w).x);
        vec3 Le = SC_EMISSIVE ? m.emissive : vec3(0.0);
        rec = st == ST_FAILED ? fallback[pm] : cells[cell.x];
        c = demodulation_factor(m) * rec.rgb + Le;   // the factor update.comp divided by
    }
    color[pm] = vec4(c, 1.0);
    if (hc_debug()) {
        uint n2 = 2u * npix();
        bool hit = st != ST_MISS;
        int level = hc_meta_level(cell.w);
        debug_out[pm] = vec4(hit ? hc_hue(pcg_hash(cell.z)) : vec3(0.0), 1.0);
        debug_out[n2 + pm] = vec4(hit ? vec3(fract(float(level + 32) * 0.137), float(level + 32) / 64.0, 0.5) : vec3(0.0), 1.0);
        debug_out[2u * n2 + pm] = vec4(vec3(hit ? rec.w / float(pc.max_samples) : 0.0), 1.0);
        vec3 sc = st == ST_FOUND ? vec3(0.0, 1.0, 0.0) : st == ST_RESERVED ? vec3(0.0, 0.0, 1.0)
                : st == ST_EVICTED ? vec3(1.0, 0.0, 0.0) : st == ST_FAILED ? vec3(1.0, 1.0, 0.0) : vec3(0.0);
        debug_out[3u * n2 + pm] = vec4(sc * (((cell.y & 16u) != 0u) ? 1.0 : 0.5), 1.0);
    }
}
