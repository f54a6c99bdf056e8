// Material evaluation at a surface: textures (with a ray-cone mip level) and normal maps.
#ifndef MATERIAL_GLSL
#define MATERIAL_GLSL
#include "common/bsdf.glsl"

// Mip level from a ray cone of width `cone_width` at the hit (Akenine-Möller
// et al. 2019, Eq. 34), for a texture read through uvs of `uv_area_ratio`.
float texture_lod_at(int tex, float uv_area_ratio, float cone_width, float cos_incidence) {
    if (cone_width <= 0.0 || uv_area_ratio <= 0.0) return 0.0;
    vec2 size = vec2(textureSize(textures[nonuniformEXT(tex)], 0));
    float lambda = 0.5 * log2(uv_area_ratio * size.x * size.y) + log2(cone_width / max(abs(cos_incidence), 1e-3));
    return max(lambda, 0.0);
}
// The uv width a ray cone's footprint covers (the ellipse's isotropic
// stand-in texture_lod_at uses): what a material graph's image nodes filter
// over (src/materials/image.rs); 0 without a cone (level 0).
float graph_footprint(float uv_area_ratio, float cone_width, float cos_incidence) {
    if (cone_width <= 0.0 || uv_area_ratio <= 0.0) return 0.0;
    return cone_width / max(abs(cos_incidence), 1e-3) * sqrt(uv_area_ratio);
}
float texture_lod(int tex, Surface s, float cone_width, float cos_incidence) {
    return texture_lod_at(tex, s.uv_area_ratio, cone_width, cos_incidence);
}

// Texture `tex` of material slot `slot` (scene.glsl slot_on_second_uv) at the
// hit, filtered for the ray cone; `lod0` samples mip 0.
vec4 slot_texture(MaterialGpu g, int slot, int tex, Surface s, float cone_width, float cos_incidence, bool lod0) {
    bool second = slot_on_second_uv(g.tex3.y, slot);
    vec2 uv = second ? s.uv2 : s.uv;
    float area = second ? s.uv2_area_ratio : s.uv_area_ratio;
    // A slot whose (uv set, transform) is neither channel's reads its
    // channel through the map between the two transforms (gltf_uv.rs
    // UvAffine); texture area scales by |det m|.
    if (slot_mapped(g, slot)) {
        uv = slot_map_uv(g, slot, uv);
        vec4 r0 = g.uv_affine[2 * slot], r1 = g.uv_affine[2 * slot + 1];
        area *= abs(r0.x * r1.y - r0.y * r1.x);
    }
    float lod = lod0 ? 0.0 : texture_lod_at(tex, area, cone_width, cos_incidence);
    return sample_texture(tex, uv, lod);
}

// A tangent-space normal `tn` (components in [−1, 1], xy scaled by
// `scale`, glTF normalTexture.scale) in the surface's tangent frame;
// not normalized.
vec3 tangent_space_normal(Surface s, vec3 tn, float scale) {
    tn.xy *= scale;
    vec3 T = normalize(s.tangent - s.n * dot(s.n, s.tangent));
    vec3 B = cross(s.n, T) * s.tangent_sign;
    return tn.x * T + tn.y * B + tn.z * s.n;
}
// Whether a mapped normal may be used: finite, on the visible side of the geometry.
bool mapped_normal_usable(Surface s, vec3 n) { return dot(n, s.ng) > 0.0 && all(equal(n, n)); }

// material_with takes the material graphs' outputs from its caller
// (material_at evaluates them): light sampling's clearcoat branch
// (lights.glsl emitted_radiance) passes only the emission graph's, so the
// scene's whole graph switch is not inlined a further time there (with it
// the procedural-heavy Sponza's path tracer exceeded SPIR-V's id bound
// and glslc's optimizer crashed, plain and cooperative builds alike).
#ifdef SC_MATERIAL_GRAPHS
#define SC_GRAPH_OUTPUTS_ARG , ScGraphOutputs go
#define SC_GRAPH_OUTPUTS_PASS , go
#else
#define SC_GRAPH_OUTPUTS_ARG
#define SC_GRAPH_OUTPUTS_PASS
#endif
ShadingMaterial material_with(inout Surface s, vec3 ray_dir, float cone_width SC_GRAPH_OUTPUTS_ARG) {
    MaterialGpu g = materials[s.material];
    ShadingMaterial m;
    // glTF: COLOR_0 multiplies the base colour factor (and texture).
    m.base = g.base_color.rgb * s.color.rgb;
    m.metallic = g.emissive_metallic.w;
    m.roughness = g.params.x;
    m.transmission = SC_TRANSMISSION ? g.params.y : 0.0;
    m.ior = g.params.z;
    m.specular = g.extra.y;
    m.emissive = SC_EMISSIVE ? g.emissive_metallic.rgb : vec3(0.0);
    // KHR_materials_unlit (tex1.w): the emission is the base colour, which
    // COLOR_0 multiplies (gltf_import.rs unlit); emitted_radiance does the same.
    if (SC_EMISSIVE && SC_VERTEX_COLORS && g.tex1.w != 0) m.emissive *= s.color.rgb;
    m.specular_color = g.specular_color.rgb;
    m.clearcoat = SC_CLEARCOAT ? g.coat.x : 0.0;
    m.clearcoat_roughness = g.coat.y;
    // The coat follows the interpolated normal, not the base's normal map
    // (KHR_materials_clearcoat), unless it has a normal texture of its own.
    m.coat_n = s.n;
    m.thin = SC_TRANSMISSION && g.attenuation.w > 0.5;
    float cos_i = dot(s.ng, -ray_dir);
#ifdef SC_MATERIAL_GRAPHS
    // Bound graph outputs multiply the factors in place of the textures
    // (whose indices are -1 then); unbound outputs are 1 (binding.rs).
    m.base *= go.base_color;
    m.metallic *= go.metallic;
    m.roughness *= go.roughness;
    // Both at most SC_MAX_EMISSION (scene_shaders.rs): their product may not be.
    m.emissive = min(m.emissive * go.emission, vec3(SC_MAX_EMISSION));
#endif
    if (SC_TEXTURES) {
        if (g.tex0.x >= 0) m.base *= slot_texture(g, 0, g.tex0.x, s, cone_width, cos_i, false).rgb;
        if (g.tex0.y >= 0) {
            vec4 mr = slot_texture(g, 1, g.tex0.y, s, cone_width, cos_i, false);
            m.roughness *= mr.g;
            m.metallic *= mr.b;
        }
        if (SC_EMISSIVE && g.tex0.w >= 0) m.emissive *= slot_texture(g, 3, g.tex0.w, s, cone_width, cos_i, false).rgb;
        if (SC_TRANSMISSION && g.tex1.x >= 0) m.transmission *= slot_texture(g, 4, g.tex1.x, s, cone_width, cos_i, true).r;
        // KHR_materials_specular: A of the specular texture, RGB of the colour texture.
        if (g.tex2.w >= 0) m.specular *= slot_texture(g, 5, g.tex2.w, s, cone_width, cos_i, false).a;
        if (g.tex3.x >= 0) m.specular_color *= slot_texture(g, 6, g.tex3.x, s, cone_width, cos_i, false).rgb;
        if (SC_CLEARCOAT && m.clearcoat > 0.0) {
            if (g.tex2.x >= 0) m.clearcoat *= slot_texture(g, 7, g.tex2.x, s, cone_width, cos_i, false).r;
            if (g.tex2.y >= 0) m.clearcoat_roughness *= slot_texture(g, 8, g.tex2.y, s, cone_width, cos_i, false).g;
            // In its own channel's tangent frame (surface_at coat_tangent).
            Surface sc = s;
            if (s.coat_tangent.w != 0.0) {
                sc.tangent = s.coat_tangent.xyz;
                sc.tangent_sign = s.coat_tangent.w;
            }
            if (SC_NORMAL_MAPS && g.tex2.z >= 0 && dot(sc.tangent, sc.tangent) > 0.0) {
                vec3 tn = slot_texture(g, 9, g.tex2.z, s, cone_width, cos_i, false).xyz * 2.0 - 1.0;
                vec3 n = normalize(tangent_space_normal(sc, tn, g.coat.z));
                if (mapped_normal_usable(s, n)) m.coat_n = n;
            }
        }
        if (SC_NORMAL_MAPS && g.tex0.z >= 0 && dot(s.tangent, s.tangent) > 0.0) {
            vec3 tn = slot_texture(g, 2, g.tex0.z, s, cone_width, cos_i, false).xyz * 2.0 - 1.0;
            vec3 n = normalize(tangent_space_normal(s, tn, g.extra.x));
            if (mapped_normal_usable(s, n)) s.n = n;
        }
    }
#ifdef SC_MATERIAL_GRAPHS
    // A world-space normal output replaces the shading normal; a
    // tangent-space one (KHR_texture_procedurals normalTexture) is applied
    // like a normal texture. Either only where it stays on the visible side.
    if ((go.mask & 40u) != 0u) {
        vec3 n = go.normal;
        if ((go.mask & 32u) != 0u)
            n = dot(s.tangent, s.tangent) > 0.0 ? tangent_space_normal(s, go.normal * 2.0 - 1.0, g.extra.x) : s.n;
        n = normalize(n);
        if (mapped_normal_usable(s, n)) s.n = n;
    }
#endif
    // Emission only from the front of single-sided emitters.
    if (!s.front && g.tex1.z == 0) m.emissive = vec3(0.0);
    m.roughness = clamp(m.roughness, 0.0, 1.0);
    m.metallic = clamp(m.metallic, 0.0, 1.0);
    m.clearcoat = clamp(m.clearcoat, 0.0, 1.0);
    m.clearcoat_roughness = clamp(m.clearcoat_roughness, 0.0, 1.0);
    m.transmission = clamp(m.transmission, 0.0, 1.0);
    // KHR_materials_transmission sits inside glTF's mix(dielectric, metal,
    // metallic): the dielectric's base is mix(diffuse, btdf, transmission),
    // so the material is t(1 − m)·glass + (1 − m)(1 − t)·opaque dielectric
    // + m·metal ("for a material with metallicFactor = 1.0, the value of
    // transmissionFactor doesn't matter"). The integrator takes the glass
    // branch with probability `transmission` and the opaque BSDF
    // ((1 − metallic)·dielectric + metallic·metal) otherwise, so both are
    // rewritten: transmission' = t(1 − m), metallic' = m / (1 − t'), which
    // gives the opaque dielectric (1 − m)(1 − t) and the metal m exactly.
    // (Until session 44 metallic was ignored there: a metal with
    // transmission 1 rendered as clear glass.)
    if (m.transmission > 0.0 && m.metallic > 0.0) {
        float t = m.transmission * (1.0 - m.metallic);
        m.metallic = t < 1.0 ? min(m.metallic / (1.0 - t), 1.0) : 0.0;
        m.transmission = t;
    }
    // KHR_materials_clearcoat layers the coat over the emission too:
    // emission·(1 − clearcoat·Fc(|n_c·v|)) towards the viewer v = −ray_dir
    // (the extension's coated_emission; a coat normal facing away falls
    // back to the geometric normal, as the integrator shades it). Every
    // method's first-hit emission and light sampling (lights.glsl
    // emitted_radiance) read it from here.
    if (SC_CLEARCOAT && SC_EMISSIVE && m.clearcoat > 0.0) {
        vec3 nc = dot(m.coat_n, ray_dir) >= 0.0 ? s.ng : m.coat_n;
        m.emissive *= 1.0 - m.clearcoat * coat_fresnel(abs(dot(nc, ray_dir)));
    }
    return m;
}

// The material at a hit: its graphs evaluated (where the scene has them),
// then material_with.
ShadingMaterial material_at(inout Surface s, vec3 ray_dir, float cone_width) {
#ifdef SC_MATERIAL_GRAPHS
    float fp = graph_footprint(s.uv_area_ratio, cone_width, dot(s.ng, -ray_dir));
#ifdef SC_MATERIAL_MEMO
    ScGraphOutputs go = sc_material_graphs_at(s.material, s.instance, s.uv, s.uv2, s.uv2_per_uv, s.p, s.n, s.tangent, s.tangent_sign, cone_width, s.memo_uv_per_width, fp);
#else
    ScGraphOutputs go = sc_material_graphs(s.material, s.instance, s.uv, s.uv2, s.uv2_per_uv, s.p, s.n, s.tangent, s.tangent_sign, fp);
#endif
#endif
    return material_with(s, ray_dir, cone_width SC_GRAPH_OUTPUTS_PASS);
}
#endif
