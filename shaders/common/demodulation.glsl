#ifndef DEMODULATION_GLSL
#define DEMODULATION_GLSL
// Demodulation of a cached first hit's radiance (the sample cache's and
// isrt's radiance records; the hash cache and hybrid do the same in
// hash_table/update.comp, hash_cache/resolve.comp and hybrid/resolve.comp,
// which until session 43 multiplied back by the unfloored base colour, so a
// black-base dielectric's reflection vanished there).
// A radiance record holds L_s with the first hit's emission removed and the
// rest divided by the base colour (floored at 1e-3 against division by zero);
// reconstruction multiplies by the same floored factor and adds the emission
// back, so a black-base emitter (and anything else a black base does not
// multiply, e.g. a dielectric's specular layer) comes back exactly (issue 12
// item 7). The emission is the first hit's `m.emissive`, exactly the term
// path_radiance adds at the first hit (weight 1: a camera ray).
vec3 demodulation_factor(ShadingMaterial m) { return max(m.base, vec3(1e-3)); }
vec3 demodulate(vec3 L, ShadingMaterial m) { return (L - m.emissive) / demodulation_factor(m); }
vec3 remodulate(vec3 demod, ShadingMaterial m) { return demodulation_factor(m) * demod + m.emissive; }
#endif
