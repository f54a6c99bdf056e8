// Accumulation of a stored sample's shadings (appendix C, §5.2; its
// effective count c_s is what Eq. 5–6 weigh by),
// shared by the sample cache (sample_cache/shade.comp) and isrt
// (isrt/shade.comp), so both baselines of Fig. 10 average alike. CPU twins:
// src/methods/sample_cache/heuristics.rs.
#ifndef ACCUMULATION_GLSL
#define ACCUMULATION_GLSL

const float C_MAX = 65535.0;   // effective sample counts saturate here

// True when the sample's BSDF has a specular (GGX or dielectric) lobe: a
// metal, a transmissive dielectric, or an opaque dielectric with a specular
// layer (KHR_materials_specular factor > 0; glTF's default is 1). Only pure
// Lambert materials (metallic 0, specular 0, no transmission) lack one.
bool has_specular_lobe(ShadingMaterial m) {
    return m.transmission > 0.0 || (SC_VIEW_DEPENDENT && (m.metallic > 0.0 || m.specular > 0.0 || m.clearcoat > 0.0));
}

// The GGX roughness of the sharpest specular lobe: the base's, or the
// clearcoat's where it is smoother (appendix C's α_GGX for a coated surface).
float specular_roughness(ShadingMaterial m) {
    return SC_CLEARCOAT && m.clearcoat > 0.0 ? min(m.roughness, m.clearcoat_roughness) : m.roughness;
}

// Appendix C: α_min = (1 − α_GGX)·0.5 + α_GGX·0.1, α_GGX the BSDF's GGX
// roughness (bsdf.glsl ggx_alpha). CPU twin: heuristics.rs `alpha_min`.
float alpha_min(float a_ggx) { return (1.0 - a_ggx) * 0.5 + a_ggx * 0.1; }

// One exponential-average step (Yang et al. 2009): x' = (1 − α)x + αL. The
// effective sample count c = σ²/Var(x) follows Var(x') = (1 − α)²Var(x) +
// α²σ², i.e. c' = 1 / ((1 − α)²/c + α²): α = 1/(c + 1) (running mean) gives
// c' = c + 1 exactly, a constant α tends to (2 − α)/α. This c is what Eq. 5–6
// weight by and what the importance (1 + c)^−1 reads. CPU twin: heuristics.rs
// `accumulated_count`.
float accumulated_count(float c, float alpha) {
    if (!(c > 0.0) || alpha >= 1.0) return 1.0;
    float k = 1.0 - alpha;
    return min(1.0 / (k * k / c + alpha * alpha), C_MAX);
}

// A record (rgb: radiance, or demodulated radiance in the hash cache's
// tables; effective count c) after one more shading `demod`: the running mean's blend factor 1/(c + 1), floored at
// `alpha_floor` (appendix C's alpha_floor_of, `--accumulation fixed:A`'s A,
// or 0); the count follows the factor (accumulated_count) once floored.
// CPU twin: heuristics.rs `accumulate`.
vec4 accumulate_record(vec4 rec, vec3 demod, float alpha_floor) {
    float c = rec.w;
    float alpha = 1.0 / (c + 1.0);   // running mean
    bool clamped = alpha < alpha_floor;
    if (clamped) alpha = alpha_floor;
    float c_next = clamped ? accumulated_count(c, alpha) : min(c + 1.0, C_MAX);
    return vec4(mix(rec.rgb, demod, alpha), c_next);
}

// Appendix C's floor for a sample of material m: α_min of its sharpest
// specular lobe's GGX α where it has one, else 0 (a plain running mean).
float alpha_floor_of(ShadingMaterial m) {
    return has_specular_lobe(m) ? alpha_min(ggx_alpha(specular_roughness(m))) : 0.0;
}

// The blend factor's floor of `--accumulation` (src/methods/sample_cache/
// settings.rs `Accumulation::mode`): 0 `mean`, none (the running mean, §4–5);
// 1 `fixed:A`, A for every sample (§5.2); 2 `alpha-min`, appendix C's
// alpha_floor_of(m).
float accumulation_floor(uint mode, float fixed_alpha, ShadingMaterial m) {
    return mode == 1u ? fixed_alpha : mode == 2u ? alpha_floor_of(m) : 0.0;
}
#endif
