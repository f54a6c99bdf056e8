// Materials: glTF metallic-roughness as Lambert + GGX, mixed by metallic
// between the dielectric (the diffuse under its Fresnel layer, scaled by
// 1 − F_dielectric(n·wo)) and the metal, and smooth/rough dielectrics for
// KHR_materials_transmission (Walter et al. 2007). All in a local frame
// with the shading normal at +Z; wo points away from the surface.
// KHR_materials_specular tints and scales the dielectric Fresnel layer;
// KHR_materials_clearcoat adds a GGX coat (ior 1.5, own roughness and
// normal) over the base, layered as the extension's fresnel_coat says:
// f = clearcoat·Fc(|nc·wo|)·f_ggx + (1 − clearcoat·Fc(|nc·wo|))·f_base,
// f_ggx the coat's microfacet BRDF without a Fresnel factor of its own.
#ifndef BSDF_GLSL
#define BSDF_GLSL
#include "common/scene.glsl"

struct Frame { vec3 t; vec3 b; vec3 n; };

Frame frame_from(vec3 n) {
    // Duff et al. 2017, "Building an Orthonormal Basis, Revisited".
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    return Frame(vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x), vec3(b, s + n.y * n.y * a, -n.y), n);
}
vec3 to_local(Frame f, vec3 v) { return vec3(dot(v, f.t), dot(v, f.b), dot(v, f.n)); }
vec3 to_world(Frame f, vec3 v) { return v.x * f.t + v.y * f.b + v.z * f.n; }

struct ShadingMaterial {
    vec3 base;
    float metallic;
    float roughness;
    float transmission;
    float ior;
    float specular;   // KHR_materials_specular factor: F90 of the dielectric layer
    vec3 emissive;
    vec3 specular_color;      // KHR_materials_specular colour: tints the dielectric F0
    float clearcoat;          // KHR_materials_clearcoat factor (0 = no coat)
    float clearcoat_roughness;
    // The coat's normal: world space out of material_at; the integrator
    // re-expresses it in the shading frame (coat_in_frame) before the BSDF
    // functions below read it.
    vec3 coat_n;
    // Transmission without a volume (glTF's default): an infinitely thin
    // sheet, passed straight through (dielectric_sample).
    bool thin;
};

float ggx_alpha(float roughness) { return max(roughness * roughness, 1e-3); }

float ggx_d(vec3 m, float a) {
    if (m.z <= 0.0) return 0.0;
    float a2 = a * a;
    float c2 = m.z * m.z;
    float d = c2 * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

float smith_lambda(vec3 w, float a) {
    float c2 = w.z * w.z;
    if (c2 <= 0.0) return 1e30;
    float t2 = max(1.0 - c2, 0.0) / c2;
    return 0.5 * (-1.0 + sqrt(1.0 + a * a * t2));
}
float smith_g1(vec3 w, float a) { return 1.0 / (1.0 + smith_lambda(w, a)); }
float smith_g2(vec3 wo, vec3 wi, float a) { return 1.0 / (1.0 + smith_lambda(wo, a) + smith_lambda(wi, a)); }

// Visible-normal sampling by spherical caps (Dupuy & Benyoub 2023); wo.z > 0.
vec3 sample_vndf(vec3 wo, float a, vec2 u) {
    vec3 wh = normalize(vec3(wo.xy * a, wo.z));
    float phi = 2.0 * PI * u.x;
    float z = (1.0 - u.y) * (1.0 + wh.z) - wh.z;
    float st = sqrt(clamp(1.0 - z * z, 0.0, 1.0));
    vec3 h = vec3(st * cos(phi), st * sin(phi), z) + wh;
    return normalize(vec3(h.xy * a, max(h.z, 1e-7)));
}

vec3 fresnel_schlick(vec3 f0, vec3 f90, float c) {
    float m = clamp(1.0 - c, 0.0, 1.0);
    float m5 = m * m * m * m * m;
    return f0 + (f90 - f0) * m5;
}

// Exact dielectric Fresnel reflectance; eta = n_t / n_i; cos_i > 0. eta = 0
// is KHR_materials_ior's ior 0, an infinite index whose Fresnel "MUST
// evaluate to 1.0 independently of the view or light direction": 1 (at
// cos_i = 1 the quotient below is 0/0, NaN, which until session 48 gave a
// NaN reflectance and refraction direction there).
float fresnel_dielectric(float cos_i, float eta) {
    float s2 = max(0.0, 1.0 - cos_i * cos_i) / (eta * eta);
    if (!(s2 < 1.0)) return 1.0;
    float cos_t = sqrt(1.0 - s2);
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

// glTF metallic-roughness Fresnel: dielectric F0 from the ior (scaled by the
// specular factor, which is also the dielectric F90), metal F0 = base colour.
// KHR_materials_specular: dielectric F0 = min(F0(ior)·specularColor, 1)·specular.
vec3 dielectric_f0(ShadingMaterial m) {
    float r = (m.ior - 1.0) / (m.ior + 1.0);
    return min(vec3(r * r) * m.specular_color, vec3(1.0)) * m.specular;
}
vec3 opaque_f0(ShadingMaterial m) { return mix(dielectric_f0(m), m.base, m.metallic); }
vec3 opaque_f90(ShadingMaterial m) { return vec3(mix(m.specular, 1.0, m.metallic)); }
vec3 opaque_fresnel(ShadingMaterial m, float c) { return fresnel_schlick(opaque_f0(m), opaque_f90(m), c); }

// ---- KHR_materials_clearcoat ----
// The coat is a dielectric of ior 1.5 (F0 = 0.04, the extension's fixed
// value) with GGX roughness clearcoat_roughness around coat_n (shading frame).
const float COAT_F0 = 0.04;
float coat_fresnel(float c) { return fresnel_schlick(vec3(COAT_F0), vec3(1.0), c).x; }

ShadingMaterial coat_in_frame(ShadingMaterial m, Frame f) {
    if (SC_CLEARCOAT && m.clearcoat > 0.0) m.coat_n = normalize(to_local(f, m.coat_n));
    return m;
}

// clearcoat·Fc(|nc·wo|): the share of the coat layer seen from wo; the base
// below is weighted by one minus it, the coat's GGX lobe by it (the
// extension's fresnel_coat).
float coat_weight(ShadingMaterial m, vec3 wo) {
    if (!SC_CLEARCOAT || m.clearcoat <= 0.0) return 0.0;
    return m.clearcoat * coat_fresnel(abs(dot(m.coat_n, wo)));
}

// The coat lobe's f·cos θi, clearcoat·Fc(nc·wo) times the microfacet GGX
// lobe (no Fresnel at the half vector: KHR_materials_clearcoat weighs the
// whole layer by Fc of the view, so what the base loses the coat reflects,
// up to the lobe's single-scattering loss), and its VNDF sampling pdf; wo,
// wi in the shading frame. (Until session 42 the lobe carried Fc(wi·h),
// which at grazing views reflected less than the base gave up: a white
// Lambert base under a roughness-0.5 coat seen at cos θ = 0.2 returned
// 0.77 of a white furnace where the extension's model returns 0.95.)
float coat_eval(ShadingMaterial m, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    Frame fc = frame_from(m.coat_n);
    vec3 o = to_local(fc, wo), i = to_local(fc, wi);
    if (o.z <= 0.0 || i.z <= 0.0) return 0.0;
    float a = ggx_alpha(m.clearcoat_roughness);
    vec3 h = normalize(o + i);
    float D = ggx_d(h, a);
    pdf = smith_g1(o, a) * D / (4.0 * o.z);
    return m.clearcoat * coat_fresnel(o.z) * D * smith_g2(o, i, a) / (4.0 * o.z);
}

// Samples the coat's visible normals; `ratio` = the sample's coat
// reflectance over coat_weight (G2/G1; 1 for a smooth coat).
bool coat_sample(ShadingMaterial m, vec3 wo, vec2 u, out vec3 wi, out float ratio) {
    ratio = 0.0;
    wi = vec3(0.0);
    Frame fc = frame_from(m.coat_n);
    vec3 o = to_local(fc, wo);
    if (o.z <= 0.0) return false;
    float a = ggx_alpha(m.clearcoat_roughness);
    vec3 h = sample_vndf(o, a, u);
    vec3 i = reflect(-o, h);
    if (i.z <= 0.0) return false;
    wi = to_world(fc, i);
    ratio = smith_g2(o, i, a) / smith_g1(o, a);
    return true;
}

float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

// Probability of sampling the coat lobe: its share of the reflectance
// estimate (coat weight against the attenuated base's Fresnel and albedo),
// kept in [0.1, 0.9] so neither part is starved; 0 without a coat.
float coat_prob(ShadingMaterial m, vec3 wo) {
    float wc = coat_weight(m, wo);
    if (wc <= 0.0) return 0.0;
    float rb = (1.0 - wc) * (luminance(opaque_fresnel(m, max(wo.z, 0.0))) + (1.0 - m.metallic) * luminance(m.base));
    return clamp(wc / max(wc + rb, 1e-6), 0.1, 0.9);
}

// Probability of sampling the specular lobe of the opaque BSDF.
float opaque_spec_prob(ShadingMaterial m, vec3 wo) {
    if (!SC_VIEW_DEPENDENT) return 0.0;   // no material has a specular lobe
    vec3 F = opaque_fresnel(m, wo.z);
    float lf = dot(F, vec3(0.2126, 0.7152, 0.0722));
    if (m.metallic >= 1.0) return 1.0;
    if (m.metallic <= 0.0 && m.specular <= 0.0) return 0.0;   // pure Lambert
    return clamp(mix(lf, 1.0, m.metallic), 0.1, 0.9);
}

// f(wo, wi)·|cos θi| and the sampling pdf of the base below the coat (both local).
vec3 base_eval(ShadingMaterial m, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    if (!SC_VIEW_DEPENDENT) {
        // Lambert: metallic = 0 and F = 0 (F0 = F90 = 0), so the general
        // expression below reduces to exactly this (the GGX lobe times 0).
        pdf = wi.z * INV_PI;
        return m.base * INV_PI * wi.z;
    }
    float a = ggx_alpha(m.roughness);
    vec3 h = normalize(wo + wi);
    vec3 F = opaque_fresnel(m, dot(wi, h));
    float D = ggx_d(h, a);
    vec3 spec = F * D * smith_g2(wo, wi, a) / (4.0 * wo.z);   // × cos θi cancels 1/cos θi
    // glTF's mix(dielectric, metal, metallic): the diffuse is the
    // dielectric's, under the dielectric's Fresnel layer (F0 from the ior
    // and KHR_materials_specular, F90 = specular), not the metallic-mixed F
    // (which Appendix B's simplified implementation uses, and which made a
    // half-metal's diffuse 29 % darker; tests/conformance.rs).
    // KHR_materials_specular's fresnel_mix weighs the diffuse by one minus
    // the largest channel of the (tinted) dielectric Fresnel, so a tinted
    // specular colour does not tint the diffuse (until session 44 each
    // channel had its own 1 − F: a specular-glossiness conversion with
    // specularColor (0.9, 0.6, 0.2) let 4× and 8× the green and blue
    // diffuse through).
    vec3 fd = fresnel_schlick(dielectric_f0(m), vec3(m.specular), wo.z);
    vec3 diff = (1.0 - m.metallic) * m.base * INV_PI * wi.z * (1.0 - max(fd.r, max(fd.g, fd.b)));
    float ps = opaque_spec_prob(m, wo);
    float pdf_spec = smith_g1(wo, a) * D / (4.0 * wo.z);
    pdf = ps * pdf_spec + (1.0 - ps) * wi.z * INV_PI;
    return spec + diff;
}

// f(wo, wi)·|cos θi| and the sampling pdf of the opaque BSDF (both local):
// the base, and over it the clearcoat where there is one.
vec3 opaque_eval(ShadingMaterial m, vec3 wo, vec3 wi, out float pdf) {
    vec3 f = base_eval(m, wo, wi, pdf);
    if (SC_CLEARCOAT && SC_VIEW_DEPENDENT && m.clearcoat > 0.0) {
        float pc = coat_prob(m, wo);
        float pdf_c;
        float fc = coat_eval(m, wo, wi, pdf_c);
        f = f * (1.0 - coat_weight(m, wo)) + vec3(fc);
        pdf = pc * pdf_c + (1.0 - pc) * pdf;
    }
    return f;
}

vec3 cosine_hemisphere(vec2 u) {
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
}

// Samples the opaque BSDF; returns false when the sample is below the surface.
// The coat is picked first (probability coat_prob, from the lobe number
// u.z, which is then rescaled for the base's choice: unchanged without a coat).
// One-sample MIS over the lobes: the weight is f over opaque_eval's mixture
// pdf, in which the base's lobes have density 0 below the shading horizon,
// so a base sample there must end (weight 0), coat or no coat. Only the
// coat, whose normal may differ from the shading normal (a normal-mapped
// base), reaches directions below it; before session 42 a base sample
// there went on with the coat's f over the coat's pdf alone, which
// overstated a coated normal-mapped metal's albedo by up to 8 %
// (tests/material_extensions.rs
// `coated_normal_mapped_bsdf_sampling_agrees_with_light_sampling`).
bool opaque_sample(ShadingMaterial m, vec3 wo, vec3 u, out vec3 wi, out vec3 weight, out float pdf) {
    float a = ggx_alpha(m.roughness);
    float pc = SC_CLEARCOAT && SC_VIEW_DEPENDENT ? coat_prob(m, wo) : 0.0;
    float ps = opaque_spec_prob(m, wo);
    if (u.z < pc) {
        float ratio;
        if (!coat_sample(m, wo, u.xy, wi, ratio)) { weight = vec3(0.0); pdf = 0.0; return false; }
    } else {
        float uz = pc > 0.0 ? (u.z - pc) / (1.0 - pc) : u.z;
        if (uz < ps) {
            vec3 h = sample_vndf(wo, a, u.xy);
            wi = reflect(-wo, h);
        } else {
            wi = cosine_hemisphere(u.xy);
        }
        if (wi.z <= 0.0) { weight = vec3(0.0); pdf = 0.0; return false; }
    }
    vec3 fc = opaque_eval(m, wo, wi, pdf);
    weight = pdf > 0.0 ? fc / pdf : vec3(0.0);
    return pdf > 0.0;
}

// The dielectric's Fresnel layer at microfacet cosine c (eta = n_t / n_i):
// returns the probability of reflection, `Fr` the reflected layer.
// KHR_materials_specular on the dielectric (its fresnel_mix): the reflected
// layer is specular·Fr with Fr's F0 tinted, min(F0(ior)·specularColor, 1),
// and F90 = 1; the transmitted base keeps 1 − specular·max(Fr). Fr follows
// the exact Fresnel's shape between its F0 and 1 (total internal reflection
// stays total). Reflection is picked with probability max(Fr) (weights
// Fr/max(Fr) and 1); without the extension's values exactly the plain
// dielectric (Fr = F, picked with probability F).
float dielectric_layer(ShadingMaterial m, float c, float eta, out vec3 Fr) {
    float F = fresnel_dielectric(c, eta);
    Fr = vec3(F);
    if (F < 1.0 && (m.specular != 1.0 || m.specular_color != vec3(1.0))) {
        float r = (m.ior - 1.0) / (m.ior + 1.0);
        float f0 = r * r;
        vec3 f0t = min(vec3(f0) * m.specular_color, vec3(1.0));
        float shape = clamp((F - f0) / max(1.0 - f0, 1e-6), 0.0, 1.0);
        Fr = m.specular * (f0t + (1.0 - f0t) * shape);
        return max(Fr.r, max(Fr.g, Fr.b));
    }
    return F;
}

// Whether the dielectric scatters only into delta directions: smooth (below
// roughness 0.02), or a volume boundary of relative index exactly 1 (the
// same medium on both sides, KHR_materials_ior 1.0): there every
// microfacet refracts wi = −wo and Fresnel reflects nothing, so the rough
// lobe collapses to straight transmission (its half vector −normalize(wo
// + wi) was the zero vector: a NaN density that dropped the emission
// seen through it).
bool dielectric_delta(ShadingMaterial m) { return m.roughness < 0.02 || (!m.thin && m.ior == 1.0); }

// Samples the dielectric BSDF (smooth below roughness 0.02, else rough GGX).
// wo may be on either side (wo.z < 0 = inside); `weight` = f·|cos|/pdf.
// `delta` reports a specular event (no light sampling possible).
// Thin-walled (m.thin, KHR_materials_transmission without a volume): both
// sides face air; the light refracted in at one face leaves the parallel
// other face undeviated, so the transmitted direction is the reflected one
// mirrored through the surface (−wo for a smooth sheet; the rough sheet's
// lobe is its reflection lobe turned over), chosen with 1 − F of the ior.
bool dielectric_sample(ShadingMaterial m, vec3 wo, vec3 u, out vec3 wi, out vec3 weight, out bool delta) {
    bool entering = wo.z > 0.0;
    float eta = entering || m.thin ? m.ior : 1.0 / m.ior;   // n_t / n_i
    vec3 wo_up = entering ? wo : -wo;               // work in the hemisphere of wo
    delta = dielectric_delta(m);
    vec3 h;
    float a = ggx_alpha(m.roughness);
    if (delta) h = vec3(0.0, 0.0, 1.0);
    else h = sample_vndf(wo_up, a, u.xy);
    float c = dot(wo_up, h);
    vec3 Fr;
    float p_reflect = dielectric_layer(m, c, eta, Fr);
    vec3 wi_up;
    bool refracted = false;
    if (u.z < p_reflect) {
        wi_up = reflect(-wo_up, h);
        if (wi_up.z <= 0.0) { weight = vec3(0.0); return false; }
    } else if (m.thin) {
        wi_up = reflect(-wo_up, h);
        if (wi_up.z <= 0.0) { weight = vec3(0.0); return false; }
        wi_up.z = -wi_up.z;
        refracted = true;
    } else {
        wi_up = refract(-wo_up, h, 1.0 / eta);
        if (dot(wi_up, wi_up) == 0.0 || wi_up.z >= 0.0) { weight = vec3(0.0); return false; }
        refracted = true;
    }
    // VNDF sampling with Fresnel-chosen lobes: weight = G2 / G1(wo).
    weight = delta ? vec3(1.0) : vec3(smith_g2(wo_up, vec3(wi_up.xy, abs(wi_up.z)), a) / smith_g1(wo_up, a));
    if (refracted) weight *= m.base;   // glTF: transmission is tinted by the base colour
    else if (Fr != vec3(p_reflect)) weight *= Fr / p_reflect;   // the tinted layer (dielectric_layer)
    wi = entering ? wi_up : -wi_up;
    return true;
}

// The rough dielectric's f·|cos θi| for the pair (wo, wi) and the density
// with which dielectric_sample draws wi (solid angle), in the same frame
// around the outward normal (either side); 0 for a smooth one (delta).
// Derived from the sampler, so light sampling and BSDF sampling combine by
// MIS exactly: VNDF density G1(wo)·(wo·h)·D(h)/wo.z of the half vector h,
// times the lobe's probability (p_reflect or 1 − p_reflect) and the
// Jacobian of the map h → wi:
// * reflection, h = normalize(wo + wi): 1/(4 wo·h), so
//   f·cos = Fr·G2·D/(4 wo.z), pdf = p_reflect·G1·D/(4 wo.z) (Walter et al.
//   2007, eq. 20, with the Fresnel layer above);
// * refraction (eta = n_t/n_i), h = −normalize(wo + eta·wi):
//   eta²|wi·h| / (wo·h + eta·wi·h)² (Walter et al. eq. 17), so
//   f·cos = base·(1 − p_reflect)·G2·D·(wo·h)·J/wo.z, pdf the same with G1
//   and without the base (the BTDF of eq. 21 as the sampler weighs it:
//   radiance is not scaled by eta², as in dielectric_sample);
// * thin-walled transmission: the reflection lobe mirrored through the
//   surface, f·cos = base·(1 − p_reflect)·G2·D/(4 wo.z).
// G2 takes |wi.z|, as the sampler's weight G2/G1 does.
vec3 dielectric_eval(ShadingMaterial m, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    if (dielectric_delta(m)) return vec3(0.0);
    bool entering = wo.z > 0.0;
    float eta = entering || m.thin ? m.ior : 1.0 / m.ior;   // n_t / n_i
    vec3 wo_up = entering ? wo : -wo;
    vec3 wi_up = entering ? wi : -wi;
    if (wo_up.z <= 0.0 || wi_up.z == 0.0) return vec3(0.0);
    float a = ggx_alpha(m.roughness);
    bool same_side = wi_up.z > 0.0;
    bool mirrored = same_side || m.thin;
    vec3 wr = vec3(wi_up.xy, abs(wi_up.z));      // the reflection lobe's direction
    vec3 h = mirrored ? normalize(wo_up + wr) : -normalize(wo_up + eta * wi_up);
    if (h.z < 0.0) h = -h;
    float c = dot(wo_up, h);
    if (c <= 0.0) return vec3(0.0);
    vec3 Fr;
    float p_reflect = dielectric_layer(m, c, eta, Fr);
    float D = ggx_d(h, a);
    float g1 = smith_g1(wo_up, a), g2 = smith_g2(wo_up, wr, a);
    float jac;   // density of wi per density of h (times wo.z / (wo·h))
    if (mirrored) {
        if (dot(wr, h) <= 0.0) return vec3(0.0);
        jac = 1.0 / (4.0 * c);
    } else {
        float ci = dot(wi_up, h);
        if (ci >= 0.0) return vec3(0.0);
        float denom = c + eta * ci;
        jac = eta * eta * abs(ci) / (denom * denom);
    }
    float dens = D * c / wo_up.z * jac;   // D·(wo·h)/wo.z times the Jacobian
    if (same_side) {
        pdf = p_reflect * g1 * dens;
        return Fr * g2 * dens;
    }
    pdf = (1.0 - p_reflect) * g1 * dens;
    return m.base * (1.0 - p_reflect) * g2 * dens;
}

// dielectric_sample in world space, as the integrator calls it: `n` = shading
// normal on the side the ray `d` arrives from (Surface.n), `front` = the ray
// hit the outside (Surface.front). The BSDF works in a frame around the
// *outward* normal, so wo.z < 0 for a ray arriving from inside, and the
// sampled wi comes back in that same frame — it must not be flipped again on
// back-face hits (issue 13: doing so sent every ray leaving glass back inside;
// tests/dielectric.rs checks this function against Snell's law).
bool dielectric_sample_world(ShadingMaterial m, vec3 n, bool front, vec3 d, vec3 u, out vec3 wi_world, out vec3 weight, out bool delta) {
    Frame fg = frame_from(front ? n : -n);
    vec3 wi;
    wi_world = vec3(0.0);
    if (!dielectric_sample(m, to_local(fg, -d), u, wi, weight, delta)) return false;
    wi_world = to_world(fg, wi);
    return true;
}
#endif
