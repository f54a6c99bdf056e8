// Eq. 4's MSE-optimal blend parameter [PFJ23] for lerp(X, Y, β) (Eq. 3),
// from raw moments as Eq. 8 writes it, per channel: the stereo blend's
// (sample_cache/stereo_blend.comp: X the other eye) and the TAA's pfj23
// weights (taa/resolve.comp: X the history, Y the current frame). CPU twin:
// src/stereo/blend.rs `beta_prime`.
#ifndef SC_MSE_BLEND_GLSL
#define SC_MSE_BLEND_GLSL

// Eq. 8 with Eq. 4's denominator written as Var(X) + Var(Y) + Bias², each
// variance clamped at 0 (equal to μ2X + μ2Y − 2μ1Xμ1Y otherwise). Var(X)
// can come out negative where Dodgson's kernel has negative lobes (R > ½:
// −0.028 at the paper's R = 0.8): unclamped, a bright neighbour under a
// negative tap shrank the denominator and pushed β′ to 0 (all X). Where
// the denominator vanishes (X and Y agree exactly and neither varies) or is
// not finite, β′ = 1: Y is kept.
// The clamp is written as a selection: GLSL's max(NaN, 0) may return
// either operand, Rust's f32::max (the twin) returns 0, as this does.
vec3 mse_nonneg(vec3 v) { return mix(vec3(0.0), v, greaterThan(v, vec3(0.0))); }
vec3 beta_prime(vec3 m1x, vec3 m2x, vec3 m1y, vec3 m2y) {
    vec3 var_y = mse_nonneg(m2y - m1y * m1y);
    vec3 var_x = mse_nonneg(m2x - m1x * m1x);
    vec3 bias = m1x - m1y;
    vec3 denom = var_x + var_y + bias * bias;
    vec3 b;
    for (int c = 0; c < 3; ++c) {
        bool ok = denom[c] > 1e-12 && !isinf(denom[c]) && !isnan(denom[c]) && !isinf(var_y[c]) && !isnan(var_y[c]);
        b[c] = ok ? clamp(1.0 - var_y[c] / denom[c], 0.0, 1.0) : 1.0;
    }
    return b;
}

#endif
