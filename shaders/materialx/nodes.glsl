// MaterialX standard nodes used by generated material graphs
// (src/materials/codegen.rs), written from the MaterialX 1.39
// specification and the stdlib_ng.mtlx definitions; the same arithmetic as
// the CPU evaluator src/materials/eval.rs (operation order kept, `precise`
// so nothing is fused). Simple arithmetic is emitted inline by the code
// generator; these are the nodes with more than one operation.
#ifndef MATERIALX_NODES_GLSL
#define MATERIALX_NODES_GLSL
#include "materialx/noise.glsl"

// The surface point a graph is evaluated at (world space).
// footprint: the uv width the value stands for (image nodes' mip level; 0 = level 0).
// tangent_sign: glTF's handedness w (±1, already turned over on a back
// face, scene.glsl surface_at), so the bitangent is the mesh's own.
// World-space values, then the same point in the mesh's object space
// (MaterialX "object"/"model"; eval.rs Geom, ObjectFrame). uv is
// texture coordinate set 0, uv1 set 1, uv1_per_uv ∂uv1/∂uv on the surface.
struct MxGeom {
    vec2 uv; vec2 uv1; mat2 uv1_per_uv; vec3 position; vec3 normal; vec3 tangent; float tangent_sign; float footprint;
    vec3 position_object; vec3 normal_object; vec3 tangent_object; float tangent_sign_object;
};

// Uv set 1 where uv set 0 moves by d along the surface (heighttonormal's
// and an image texcoord's central differences; eval.rs shifted_input).
vec2 mx_uv1_at(MxGeom g, vec2 d) {
    precise vec2 r = g.uv1 + g.uv1_per_uv * d;
    return r;
}

vec3 mx_cross(vec3 a, vec3 b) {
    precise vec3 r = vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
    return r;
}

// glTF's bitangent cross(N, T)·w (eval.rs Geom::bitangent): a mirrored uv
// island (w = −1) or a back face gets the bitangent its normal texture expects.
vec3 mx_bitangent(MxGeom g) { return mx_cross(g.normal, g.tangent) * g.tangent_sign; }
vec3 mx_bitangent_object(MxGeom g) { return mx_cross(g.normal_object, g.tangent_object) * g.tangent_sign_object; }

float mx_dot(float a, float b) { precise float r = a * b; return r; }
float mx_dot(vec2 a, vec2 b) { precise float r = a.x * b.x + a.y * b.y; return r; }
float mx_dot(vec3 a, vec3 b) { precise float r = a.x * b.x + a.y * b.y + a.z * b.z; return r; }
float mx_dot(vec4 a, vec4 b) { precise float r = a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w; return r; }

// 1 at or above hi, 0 at or below lo, the Hermite cubic between (as eval.rs).
float mx_smoothstep1(float x, float lo, float hi) {
    if (x >= hi) return 1.0;
    if (x <= lo) return 0.0;
    precise float t = (x - lo) / (hi - lo);
    precise float r = t * t * (3.0 - 2.0 * t);
    return r;
}
float mx_smoothstep(float x, float lo, float hi) { return mx_smoothstep1(x, lo, hi); }
vec2 mx_smoothstep(vec2 x, vec2 lo, vec2 hi) { return vec2(mx_smoothstep1(x.x, lo.x, hi.x), mx_smoothstep1(x.y, lo.y, hi.y)); }
vec3 mx_smoothstep(vec3 x, vec3 lo, vec3 hi) { return vec3(mx_smoothstep(x.xy, lo.xy, hi.xy), mx_smoothstep1(x.z, lo.z, hi.z)); }
vec4 mx_smoothstep(vec4 x, vec4 lo, vec4 hi) { return vec4(mx_smoothstep(x.xyz, lo.xyz, hi.xyz), mx_smoothstep1(x.w, lo.w, hi.w)); }

// power with every case defined (eval.rs `power`; GLSL's pow is undefined
// for x < 0 and for x = 0, y <= 0): x^0 = 1, 0^y = 0 (y > 0) or +inf
// (y < 0), a negative base with an integer exponent the real power, with
// any other exponent 0 (as OSL's pow).
float mx_pow(float x, float y) {
    if (y == 0.0) return 1.0;
    if (x == 0.0) return y > 0.0 ? 0.0 : uintBitsToFloat(0x7f800000u);
    float a = pow(abs(x), y);
    if (x > 0.0 || isnan(x)) return a;
    if (y != floor(y)) return 0.0;
    precise float h = y * 0.5;
    return h == floor(h) ? a : -a;
}
vec2 mx_pow(vec2 x, vec2 y) { return vec2(mx_pow(x.x, y.x), mx_pow(x.y, y.y)); }
vec3 mx_pow(vec3 x, vec3 y) { return vec3(mx_pow(x.xy, y.xy), mx_pow(x.z, y.z)); }
vec4 mx_pow(vec4 x, vec4 y) { return vec4(mx_pow(x.xyz, y.xyz), mx_pow(x.w, y.w)); }

#define MX_PER_TYPE(T) \
    T mx_modulo(T a, T b) { precise T r = a - b * floor(a / b); return r; } \
    T mx_fract(T a) { precise T r = a - floor(a); return r; } \
    T mx_mix(T bg, T fg, T m) { precise T r = bg + (fg - bg) * m; return r; } \
    T mx_clamp(T x, T lo, T hi) { return min(max(x, lo), hi); } \
    T mx_normalize(T v) { float l = sqrt(mx_dot(v, v)); precise T r = v / l; return l > 0.0 ? r : v; }
MX_PER_TYPE(float)
MX_PER_TYPE(vec2)
MX_PER_TYPE(vec3)
MX_PER_TYPE(vec4)

// rotate2d with the sine and cosine of the angle (counter-clockwise).
vec2 mx_rotate_sc(vec2 p, vec2 sc) {
    precise vec2 r = vec2(p.x * sc.y - p.y * sc.x, p.x * sc.x + p.y * sc.y);
    return r;
}

vec2 mx_sincos_deg(float deg) {
    float r = radians(deg);
    return vec2(sin(r), cos(r));
}

// place2d (NG_place2d_vector2): order 0 = SRT, 1 = TRS.
vec2 mx_place2d(vec2 t, vec2 pivot, vec2 scale, vec2 sc, vec2 offset, int order) {
    precise vec2 sp = t - pivot;
    precise vec2 r;
    if (order == 0) {
        vec2 q = mx_rotate_sc(sp / scale, sc);
        r = q - offset + pivot;
    } else {
        vec2 q = mx_rotate_sc(sp - offset, sc);
        r = q / scale + pivot;
    }
    return r;
}

// checkerboard (NG_checkerboard_color3).
vec3 mx_checkerboard(vec3 c1, vec3 c2, vec2 tiling, vec2 offset, vec2 t) {
    precise float fx = floor(t.x * tiling.x - offset.x);
    precise float fy = floor(t.y * tiling.y - offset.y);
    float m = mx_modulo(fx + fy, 2.0);
    return mx_mix(c2, c1, vec3(m));
}

// RGB <-> HSV, hexcone model (Smith 1978), hue in [0, 1).
vec3 mx_rgb_to_hsv(vec3 c) {
    float mx = max(max(c.r, c.g), c.b);
    float mn = min(min(c.r, c.g), c.b);
    precise float d = mx - mn;
    float s = mx > 0.0 ? d / mx : 0.0;
    precise float h = 0.0;
    if (d > 0.0) {
        if (c.r >= mx) h = (c.g - c.b) / d;
        else if (c.g >= mx) h = 2.0 + (c.b - c.r) / d;
        else h = 4.0 + (c.r - c.g) / d;
        h /= 6.0;
        if (h < 0.0) h += 1.0;
    }
    return vec3(h, s, mx);
}

// Grey below saturation 0.0001 (eval.rs HSV_GREY_SATURATION, as MaterialX's
// hsvtorgb); saturation above 1 is not clamped.
vec3 mx_hsv_to_rgb(vec3 c) {
    float s = c.y, v = c.z;
    if (s < 0.0001) return vec3(v);
    precise float h = c.x - floor(c.x);
    if (h >= 1.0) h = 0.0;   // x just below 0 rounds to 1 (eval.rs hsv_to_rgb)
    precise float h6 = h * 6.0;
    float sector = floor(h6);
    precise float f = h6 - sector;
    precise float p = v * (1.0 - s);
    precise float q = v * (1.0 - s * f);
    precise float t = v * (1.0 - s * (1.0 - f));
    switch (int(sector)) {
        case 0: return vec3(v, t, p);
        case 1: return vec3(q, v, p);
        case 2: return vec3(p, v, t);
        case 3: return vec3(p, q, v);
        case 4: return vec3(t, p, v);
        default: return vec3(v, p, q);
    }
}

vec3 mx_hsvadjust(vec3 c, vec3 amount) {
    vec3 hsv = mx_rgb_to_hsv(c);
    precise vec3 a = vec3(hsv.x + amount.x, hsv.y * amount.y, hsv.z * amount.z);
    return mx_hsv_to_rgb(a);
}

float mx_luminance(vec3 c, vec3 k) { precise float l = c.r * k.r + c.g * k.g + c.b * k.b; return l; }

// normalmap: `t` a tangent-space normal encoded in [0, 1], scaled on x and y.
// An all-zero input is the unperturbed normal (tangent-space (0, 0, 1)), as MaterialX.
vec3 mx_normalmap(vec3 t, vec2 scale, vec3 n, vec3 tg, vec3 bt) {
    precise vec3 m = vec3((t.x * 2.0 - 1.0) * scale.x, (t.y * 2.0 - 1.0) * scale.y, t.z * 2.0 - 1.0);
    if (t.x == 0.0 && t.y == 0.0 && t.z == 0.0) m = vec3(0.0, 0.0, 1.0);
    precise vec3 s = vec3(tg.x * m.x + bt.x * m.y + n.x * m.z,
                          tg.y * m.x + bt.y * m.y + n.y * m.z,
                          tg.z * m.x + bt.z * m.y + n.z * m.z);
    return mx_normalize(s);
}

// heighttonormal (eval.rs height_normal): MaterialX's construction with
// derivatives in uv, from the height at uv ± step·x̂, uv ± step·ŷ and the
// texcoord's derivatives along u (tdu) and v (tdv); the height gradient
// scaled by scale/16 (MaterialX's Sobel parity factor); n.z turned
// positive (mirrored texcoords), (0, 0, 1) where the frame is degenerate.
const float MX_HEIGHT_STEP = 1.0 / 1024.0;
const float MX_HEIGHT_SOBEL_SCALE = 1.0 / 16.0;
vec3 mx_height_normal(float hu1, float hu0, float hv1, float hv0, float scale, vec2 tdu, vec2 tdv) {
    const float inv = 1.0 / (2.0 * MX_HEIGHT_STEP);
    precise float hu = (hu1 - hu0) * inv * scale * MX_HEIGHT_SOBEL_SCALE;
    precise float hv = (hv1 - hv0) * inv * scale * MX_HEIGHT_SOBEL_SCALE;
    vec3 n = mx_cross(vec3(tdu, hu), vec3(tdv, hv));
    if (mx_dot(n, n) < 1e-16) n = vec3(0.0, 0.0, 1.0);
    else if (n.z < 0.0) n = -n;
    n = mx_normalize(n);
    precise vec3 r = n * 0.5 + 0.5;
    return r;
}
#endif
