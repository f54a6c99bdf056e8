// The MaterialX image node (issue 17; src/materials/image.rs is its CPU twin
// and says what each input does). `slot` indexes the scene's texture array
// (common/scene.glsl declares `textures` before the scene's graphs), whose
// sampler holds the address modes and filters; `t` is MaterialX's texture
// coordinate (origin at the image's lower-left corner), `footprint` the uv
// width the value stands for times the coordinate's scale, `const_u/v` the
// `constant` address mode: `dflt` outside [0, 1] on that axis.
vec4 mx_image(int slot, vec2 t, float footprint, bool const_u, bool const_v, vec4 dflt) {
    if ((const_u && !(t.x >= 0.0 && t.x <= 1.0)) || (const_v && !(t.y >= 0.0 && t.y <= 1.0))) return dflt;
    vec2 size = vec2(textureSize(textures[nonuniformEXT(slot)], 0));
    // log2(footprint · sqrt(w·h)); a footprint of 0 reads level 0 (λ = −∞ clamps there).
    float lambda = footprint > 0.0 ? log2(footprint * sqrt(size.x * size.y)) : -128.0;
    return textureLod(textures[nonuniformEXT(slot)], vec2(t.x, 1.0 - t.y), lambda);
}

// √|det J| of the texture coordinate's Jacobian in uv from central
// differences at ±step (the values at uv ± step·x̂, uv ± step·ŷ).
float mx_texcoord_scale(vec2 tu1, vec2 tu0, vec2 tv1, vec2 tv0, float step) {
    precise vec2 du = (tu1 - tu0) / (2.0 * step);
    precise vec2 dv = (tv1 - tv0) / (2.0 * step);
    precise float det = du.x * dv.y - du.y * dv.x;
    return sqrt(abs(det));
}
