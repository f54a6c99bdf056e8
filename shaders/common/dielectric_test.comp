#version 460
// Test kernel: bsdf.glsl dielectric_sample_world for given world-space inputs,
// compared with Snell's law, Fresnel and a CPU twin in tests/dielectric.rs.
#include "common/bsdf.glsl"
#include "interface/dielectric.glsl"
layout(local_size_x = 64) in;
// Per case: (n.xyz, front), (d.xyz, ior), (u.xyz, roughness).
layout(set = SET_DIELECTRIC, binding = B_DIELECTRIC_CASES, std430) readonly buffer Cases { vec4 cases[]; };
// Per case: (wi.xyz, ok), (weight.xyz, delta).
layout(set = SET_DIELECTRIC, binding = B_DIELECTRIC_OUTS, std430) writeonly buffer Outs { vec4 outs[]; };
layout(push_constant) uniform Push { DIELECTRIC_PUSH } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    vec4 a = cases[3u * i], b = cases[3u * i + 1u], c = cases[3u * i + 2u];
    ShadingMaterial m;
    m.base = vec3(1.0);
    m.metallic = 0.0;
    m.roughness = c.w;
    m.transmission = 1.0;
    m.ior = b.w;
    m.specular = 1.0;
    m.emissive = vec3(0.0);
    m.specular_color = vec3(1.0);
    m.clearcoat = 0.0;
    m.clearcoat_roughness = 0.0;
    m.coat_n = a.xyz;
    m.thin = false;
    vec3 wi, w;
    bool delta;
    bool ok = dielectric_sample_world(m, a.xyz, a.w > 0.5, b.xyz, c.xyz, wi, w, delta);
    outs[2u * i] = vec4(wi, ok ? 1.0 : 0.0);
    outs[2u * i + 1u] = vec4(ok ? w : vec3(0.0), delta ? 1.0 : 0.0);
}
