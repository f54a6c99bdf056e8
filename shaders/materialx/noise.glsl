// MaterialX noise nodes (noise2d, noise3d, fractal3d, cellnoise2d/3d,
// worleynoise2d/3d), written from the specification's definitions. The same
// code as src/materials/noise.rs operation for operation (see its docs for
// the exact variant: PCG lattice hash, Perlin 2002 gradients and quintic
// fade, jittered one-point-per-cell Worley); every temporary is `precise`
// so no multiply-add is fused and CPU and GPU agree to float rounding.
#ifndef MATERIALX_NOISE_GLSL
#define MATERIALX_NOISE_GLSL

uint mx_pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

uint mx_hash2(ivec2 i, uint c) { return mx_pcg(uint(i.x) + mx_pcg(uint(i.y) + mx_pcg(c))); }
uint mx_hash3(ivec3 i, uint c) { return mx_pcg(uint(i.x) + mx_pcg(uint(i.y) + mx_pcg(uint(i.z) + mx_pcg(c)))); }

float mx_unit(uint h) { return float(h >> 8u) * (1.0 / 16777216.0); }

float mx_fade(float t) {
    precise float r = t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    return r;
}

float mx_lerp(float a, float b, float t) {
    precise float r = a + t * (b - a);
    return r;
}

float mx_grad2(uint h, float x, float y) {
    precise float r;
    switch (h & 7u) {
        case 0u: r = x + y; break;
        case 1u: r = -x + y; break;
        case 2u: r = x - y; break;
        case 3u: r = -x - y; break;
        case 4u: r = x; break;
        case 5u: r = -x; break;
        case 6u: r = y; break;
        default: r = -y; break;
    }
    return r;
}

float mx_grad3(uint h, float x, float y, float z) {
    precise float r;
    switch (h & 15u) {
        case 0u: case 12u: r = x + y; break;
        case 1u: case 14u: r = -x + y; break;
        case 2u: r = x - y; break;
        case 3u: r = -x - y; break;
        case 4u: r = x + z; break;
        case 5u: r = -x + z; break;
        case 6u: r = x - z; break;
        case 7u: r = -x - z; break;
        case 8u: r = y + z; break;
        case 9u: case 13u: r = -y + z; break;
        case 10u: r = y - z; break;
        default: r = -y - z; break;
    }
    return r;
}

float mx_perlin2(vec2 p, uint c) {
    vec2 f = floor(p);
    ivec2 i = ivec2(f);
    precise vec2 x = p - f;
    precise vec2 x1 = x - 1.0;
    float n00 = mx_grad2(mx_hash2(i, c), x.x, x.y);
    float n10 = mx_grad2(mx_hash2(i + ivec2(1, 0), c), x1.x, x.y);
    float n01 = mx_grad2(mx_hash2(i + ivec2(0, 1), c), x.x, x1.y);
    float n11 = mx_grad2(mx_hash2(i + ivec2(1, 1), c), x1.x, x1.y);
    float u = mx_fade(x.x), v = mx_fade(x.y);
    return mx_lerp(mx_lerp(n00, n10, u), mx_lerp(n01, n11, u), v);
}

float mx_perlin3(vec3 p, uint c) {
    vec3 f = floor(p);
    ivec3 i = ivec3(f);
    precise vec3 x = p - f;
    precise vec3 x1 = x - 1.0;
    float n000 = mx_grad3(mx_hash3(i, c), x.x, x.y, x.z);
    float n100 = mx_grad3(mx_hash3(i + ivec3(1, 0, 0), c), x1.x, x.y, x.z);
    float n010 = mx_grad3(mx_hash3(i + ivec3(0, 1, 0), c), x.x, x1.y, x.z);
    float n110 = mx_grad3(mx_hash3(i + ivec3(1, 1, 0), c), x1.x, x1.y, x.z);
    float n001 = mx_grad3(mx_hash3(i + ivec3(0, 0, 1), c), x.x, x.y, x1.z);
    float n101 = mx_grad3(mx_hash3(i + ivec3(1, 0, 1), c), x1.x, x.y, x1.z);
    float n011 = mx_grad3(mx_hash3(i + ivec3(0, 1, 1), c), x.x, x1.y, x1.z);
    float n111 = mx_grad3(mx_hash3(i + ivec3(1, 1, 1), c), x1.x, x1.y, x1.z);
    float u = mx_fade(x.x), v = mx_fade(x.y), w = mx_fade(x.z);
    float a = mx_lerp(mx_lerp(n000, n100, u), mx_lerp(n010, n110, u), v);
    float b = mx_lerp(mx_lerp(n001, n101, u), mx_lerp(n011, n111, u), v);
    return mx_lerp(a, b, w);
}

float mx_fractal3(vec3 p, uint c, int octaves, float lacunarity, float diminish) {
    precise float sum = 0.0;
    precise float amp = 1.0;
    precise vec3 q = p;
    for (int k = 0; k < octaves; ++k) {
        sum += amp * mx_perlin3(q, c);
        amp *= diminish;
        q = q * lacunarity;
    }
    return sum;
}

float mx_cell2(vec2 p, uint c) { return mx_unit(mx_hash2(ivec2(floor(p)), c)); }
float mx_cell3(vec3 p, uint c) { return mx_unit(mx_hash3(ivec3(floor(p)), c)); }

// The three smallest squared distances and the nearest cell.
struct MxNearest3 { vec3 d; ivec3 cell; };

void mx_insert(inout MxNearest3 b, float d, ivec3 cell) {
    if (d < b.d.x) { b.d = vec3(d, b.d.x, b.d.y); b.cell = cell; }
    else if (d < b.d.y) { b.d = vec3(b.d.x, d, b.d.y); }
    else if (d < b.d.z) { b.d.z = d; }
}

vec4 mx_worley_result(MxNearest3 b, int style, int n, bool two_d) {
    vec4 r = vec4(0.0);
    for (int c = 0; c < n; ++c)
        r[c] = style == 1
            ? (two_d ? mx_unit(mx_hash2(b.cell.xy, uint(c))) : mx_unit(mx_hash3(b.cell, uint(c))))
            : sqrt(b.d[c]);
    return r;
}

const float MX_HUGE = 3.402823466e38;

vec4 mx_worley2(vec2 p, float jitter, int style, int n) {
    vec2 f = floor(p);
    ivec2 i = ivec2(f);
    precise vec2 x = p - f;
    MxNearest3 b = MxNearest3(vec3(MX_HUGE), ivec3(0));
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 c = i + ivec2(dx, dy);
            precise float fpx = float(dx) + 0.5 + jitter * (mx_unit(mx_hash2(c, 1u)) - 0.5);
            precise float fpy = float(dy) + 0.5 + jitter * (mx_unit(mx_hash2(c, 2u)) - 0.5);
            precise float ddx = fpx - x.x, ddy = fpy - x.y;
            precise float d = ddx * ddx + ddy * ddy;
            mx_insert(b, d, ivec3(c, 0));
        }
    return mx_worley_result(b, style, n, true);
}

vec4 mx_worley3(vec3 p, float jitter, int style, int n) {
    vec3 f = floor(p);
    ivec3 i = ivec3(f);
    precise vec3 x = p - f;
    MxNearest3 b = MxNearest3(vec3(MX_HUGE), ivec3(0));
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                ivec3 c = i + ivec3(dx, dy, dz);
                precise float fpx = float(dx) + 0.5 + jitter * (mx_unit(mx_hash3(c, 1u)) - 0.5);
                precise float fpy = float(dy) + 0.5 + jitter * (mx_unit(mx_hash3(c, 2u)) - 0.5);
                precise float fpz = float(dz) + 0.5 + jitter * (mx_unit(mx_hash3(c, 3u)) - 0.5);
                precise float ddx = fpx - x.x, ddy = fpy - x.y, ddz = fpz - x.z;
                precise float d = ddx * ddx + ddy * ddy + ddz * ddz;
                mx_insert(b, d, c);
            }
    return mx_worley_result(b, style, n, false);
}
#endif
