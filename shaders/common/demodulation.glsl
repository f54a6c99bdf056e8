#ifndef DEMODULATION_GLSL
#define DEMODULATION_GLSL
// Demodulation of a cached first hit's radiance: the hash cache's and
// hybrid's records (hash_table/update.comp, hash_cache/resolve.comp and
// hybrid/resolve.comp, which until session 43 multiplied back by the
// unfloored base colour, so a black-base dielectric's reflection vanished
// there), and the sample cache's adaptive-shading fallback, where a pixel
// borrows its neighbours' radiance (sample_cache/reconstruct.comp). The
// sample cache's and isrt's own records hold radiance as shaded since
// session 58 (sample_cache/shade.comp: for one surface point the two are
// the same colour).
// A demodulated record holds L_s with the first hit's emission removed and the
// rest divided by the material's demodulation factor (floored at 1e-3
// against division by zero); reconstruction multiplies by the same factor
// and adds the emission back, so a black-base emitter comes back exactly
// (issue 12 item 7). The emission is the first hit's `m.emissive`, exactly
// the term path_radiance adds at the first hit (weight 1: a camera ray).
//
// The factor is the material's albedo under uniform light, view-independent
// (the sample's own value must be the same in every frame it is shaded):
// a metal's base colour (its F0), a dielectric's base colour under its
// Fresnel layer of normal reflectance F0 (dielectric_f0: ior, specular,
// specular colour), base + F0 (1 − base), mixed by metallic. In a uniform
// environment every opaque material's record is then about the incident
// radiance, whatever its colour. That matters where one record is read by
// samples of other materials (the hash cache's voxels and the Hybrid's, the
// adaptive-shading fallback's neighbours): until session 52 the factor was
// the base colour alone, so a black-base dielectric's specular radiance was
// stored ×1000 (0.016 / 10⁻³ under a 0.4 environment) and a white Lambert
// pixel reading the same voxel showed it (an audit's worked example: 11×
// too bright where a quarter of a voxel's updates came from the black
// side; tests/hash_cache.rs `materials_sharing_a_voxel_keep_their_own_brightness`).
// Per-sample records (sample cache, isrt) are exact with any factor.
vec3 demodulation_factor(ShadingMaterial m) {
    vec3 dielectric = m.base + dielectric_f0(m) * (1.0 - m.base);
    return max(mix(dielectric, m.base, m.metallic), vec3(1e-3));
}
vec3 demodulate(vec3 L, ShadingMaterial m) { return (L - m.emissive) / demodulation_factor(m); }
#endif
