#version 460
// §3.6 stereo blending. For each pixel of eye Y, the point on the ray
// through its centre at the closest visible sample's view depth is
// projected into the other eye X (below); where X sees the same point
// (depth agreement within 1 %), the final colour is lerp(X, Y, β′) (Eq. 3)
// with β′ from Eq. 8. Moments: the cache's per-pixel μ1, μ2 (Eq. 5–6,
// `moments` mode) or 3×3 neighbourhood estimates from the colours
// (`neighbourhood`, Philippi et al. 2023). Y's moments are blurred over 3×3
// with neighbour weight 1 − R; X's moments are resampled with Dodgson's
// quadratic kernel of parameter R (§5.2: R controls how much the moments are
// blurred). X's colour itself is taken from the pixel q falls in (nearest),
// without that blur: at R = 0 the kernel spans 3×3 pixels, and blending
// with X's Dodgson-blurred colour blurred the image (issue 12 item 5).
// Nearest rather than bilinear: any interpolation at the fractional
// disparity low-passes X (a half-pixel bilinear averages two pixels), and on
// a noise-free textured plane bilinear X halved the blended image's CPBD at
// R = 0 while nearest kept it within noise of the unblended image
// (tests/sample_cache_shading.rs); nearest's price is a misregistration of
// X by at most half a pixel (Y's pixel centre is reprojected, below), which
// β′ (the bias term) limits at edges.
// A single-sample pixel: Eq. 5 over one sample gives μ2 = μ1², i.e. σ² = 0
// (Eq. 7): the estimator cannot tell a one-sample pixel from a noise-free
// one, a limitation of the paper's we keep rather than invent a variance.
// As Y at R = 1 that gives β′ = 1 (Y kept, though it is the noisiest
// pixel; at R < 1 its neighbours' moments enter its estimate); as X it
// counts as noise-free, softened only where Dodgson's taps mix in its
// neighbours' moments (off a pixel centre, at any R) and, for Y, by the 3×3
// blur at R < 1 (docs/ARCHITECTURE.md "Stereo blending").
// CPU twin of the math: src/stereo/blend.rs.
#include "sample_cache/common.glsl"
#include "common/mse_blend.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(set = SET_SAMPLE_CACHE, binding = B_SAMPLE_CACHE_OUT_BLENDED, std430) buffer OutBlended { vec4 out_blended[]; };

float dodgson(float s, float r) {
    float a = abs(s);
    if (a <= 0.5) return -2.0 * r * a * a + 0.5 * (r + 1.0);
    if (a <= 1.5) return r * a * a - (2.0 * r + 0.5) * a + 0.75 * (r + 1.0);
    return 0.0;
}

// Whether pixel t of `eye` may lend its moments to a neighbour's estimate
// (Y's 3×3 blur, X's Dodgson taps): it shows a surface and no sky (depth
// > 0 and no visible background sample, reconstruct.comp's out_m2.w) and
// holds moments of its own (count > 0: not a colour borrowed from its
// neighbours). Without this guard the sky beside a silhouette inflated
// σ_Y² at R < 1 and, the blurred μ1 moving with it, left the bias term
// small: a noise-free dark pixel next to a bright sky was blended about
// half with X's partly-sky pixel (0.1 came out 0.21 beside a sky of 1;
// session 57, an audit's scenario). A first guard that still let partly
// covered neighbours lend their sky-laden moments left ≈ 0.23 where the
// silhouette cut a pixel (a review's model; tests/stereo_blend.rs
// `stereo_blending_leaves_no_halo_against_the_sky` has both cases). Taps
// on another surface are still averaged in, as in the paper's R blur.
bool moment_tap(uint eye, ivec2 t) {
    uint i = eye * npix() + uint(t.y) * frame_size().x + uint(t.x);
    return out_depth[i] > 0.0 && out_m1[i].w > 0.0 && out_m2[i].w == 0.0;
}

// The cache's moments of pixel q of `eye` (Eq. 5–6).
void moments_at(uint eye, uvec2 q, out vec3 m1, out vec3 m2) {
    uint i = eye * npix() + q.y * frame_size().x + q.x;
    m1 = out_m1[i].rgb;
    m2 = out_m2[i].rgb;
}

// Neighbourhood baseline (Philippi et al. 2023): moments of the colours in
// the 3×3 box around pixel c of `eye`.
void box_moments(uint eye, ivec2 c, out vec3 m1, out vec3 m2) {
    uvec2 size = frame_size();
    m1 = vec3(0.0);
    m2 = vec3(0.0);
    float n = 0.0;
    for (int j = -1; j <= 1; ++j) {
        for (int i = -1; i <= 1; ++i) {
            ivec2 t = c + ivec2(i, j);
            if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, ivec2(size)))) continue;
            vec3 col = out_color[eye * npix() + uint(t.y) * size.x + uint(t.x)].rgb;
            m1 += col;
            m2 += col * col;
            n += 1.0;
        }
    }
    m1 /= n;
    m2 /= n;
}

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint pm = eye * npix() + px.y * size.x + px.x;
    vec3 y_color = out_color[pm].rgb;
    out_blended[pm] = vec4(y_color, 1.0);
    uvec4 fh = out_fh[pm];
    if (!first_hit_valid(fh)) return;                      // background: left unblended
    uint other = 1u - eye;
    EyeGpu ex = frame.eyes[other];
    EyeGpu ey = frame.eyes[eye];
    // The point reprojected: on the ray through Y's pixel centre, at the
    // closest visible sample's view depth (§3.6: the closest sample "gives
    // a more stable depth value"). Y's colour stands for the whole pixel, so
    // its centre is what X's pixel must match: the sample's own position
    // lies anywhere in the pixel and, with X's nearest pixel, misregistered
    // X by up to a whole pixel (on average a third); from the centre it is
    // at most half a pixel.
    vec2 yc = vec2(px) + 0.5;
    vec3 yd = eye_ray_dir(ey, yc);
    vec3 wp = eye_ray_origin(ey, yc) + yd * (view_depth(ey, hit_position(fh)) / dot(yd, ey.fwd.xyz));
    vec2 q;
    float vd;
    if (!project_to_eye(ex, wp, q, vd)) return;
    if (any(lessThan(q, vec2(0.0))) || any(greaterThanEqual(q, vec2(size)))) return;
    uvec2 qi = uvec2(q);
    float dx = out_depth[other * npix() + qi.y * size.x + qi.x];
    if (!(dx > 0.0) || abs(dx - vd) > 0.01 * vd) return;   // no co-visible counterpart
    // X's colour has no shaded sample of its own (adaptive shading at a
    // disocclusion: reconstruct.comp borrowed it from its neighbours and
    // wrote its moments with σ² = 0 and count 0). Eq. 4 would take such an
    // X for noise-free and give it most of the weight (σ_Y² = 0.04, Bias =
    // 0.05: 94 %), so Y is kept.
    if (!(out_m1[other * npix() + qi.y * size.x + qi.x].w > 0.0)) return;

    float r = clamp(pc.sharpness, 0.0, 1.0);
    // X's moments: Dodgson resampling around q (taps within 1.5 pixels).
    vec3 m1x = vec3(0.0), m2x = vec3(0.0);
    if (pc.blend_mode == 1u) {
        float wsum = 0.0;
        ivec2 base = ivec2(floor(q - 0.5));
        for (int j = -1; j <= 2; ++j) {
            for (int i = -1; i <= 2; ++i) {
                ivec2 t = base + ivec2(i, j);
                if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, ivec2(size)))) continue;
                vec2 s = q - (vec2(t) + 0.5);
                float w = dodgson(s.x, r) * dodgson(s.y, r);
                // q's own pixel (whose colour is X's) always lends its
                // moments, as Y's centre does; its neighbours only where
                // `moment_tap` allows.
                if (w == 0.0 || (t != ivec2(qi) && !moment_tap(other, t))) continue;
                vec3 a1, a2;
                moments_at(other, uvec2(t), a1, a2);
                m1x += w * a1;
                m2x += w * a2;
                wsum += w;
            }
        }
        if (!(wsum > 1e-6)) return;
        m1x /= wsum;
        m2x /= wsum;
    }
    // X's colour: the pixel q falls in (nearest, no blur).
    vec3 cx = out_color[other * npix() + qi.y * size.x + qi.x].rgb;

    vec3 m1y = vec3(0.0), m2y = vec3(0.0);
    if (pc.blend_mode == 2u) {
        box_moments(other, ivec2(qi), m1x, m2x);
        box_moments(eye, ivec2(px), m1y, m2y);
    } else {
        // Y: 3×3 blur of the moments with neighbour weight 1 − R, centre weight 1.
        float wy = 0.0;
        for (int j = -1; j <= 1; ++j) {
            for (int i = -1; i <= 1; ++i) {
                ivec2 t = ivec2(px) + ivec2(i, j);
                if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, ivec2(size)))) continue;
                bool centre = i == 0 && j == 0;
                float w = centre ? 1.0 : 1.0 - r;
                if (w == 0.0 || (!centre && !moment_tap(eye, t))) continue;
                vec3 a1, a2;
                moments_at(eye, uvec2(t), a1, a2);
                m1y += w * a1;
                m2y += w * a2;
                wy += w;
            }
        }
        m1y /= wy;
        m2y /= wy;
    }
    vec3 b = beta_prime(m1x, m2x, m1y, m2y);
    vec3 blended = (1.0 - b) * cx + b * y_color;
    if (all(equal(blended, blended)) && !any(isinf(blended))) out_blended[pm] = vec4(blended, 1.0);
}
