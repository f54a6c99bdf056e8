// The media a path travels in (KHR_materials_volume): a small stack of the
// volumes it has refracted into, innermost (most recently entered) on top,
// as in Schmidt & Budge, "Simple Nested Dielectrics in Ray Traced Images"
// (2002), which the extension's specification points to for tracking the
// index of refraction through nested and overlapping objects. glTF has no
// priorities, so the volume entered last wins where volumes overlap:
//  - refracting into a volume's front pushes it; the interface's index of
//    refraction is the ratio of the volume's to the enclosing medium's (the
//    top before the push; vacuum, 1, below the stack);
//  - refracting out through the back of the volume on top pops it; the
//    ratio is that of the medium below it to the volume's;
//  - meeting the back of a volume that is in the stack but not on top is no
//    interface (the ray is inside a volume entered later, which fills that
//    place): the volume is removed and the ray goes on unchanged — a
//    "false" intersection in Schmidt & Budge's words;
//  - a back face of a volume that is not in the stack at all (a camera
//    inside a volume, an open mesh) is an exit into the top medium.
// Beer–Lambert absorption is the top medium's. Liquid in a glass modelled
// the usual way — the liquid's surface a little inside the glass wall —
// then refracts glass→liquid at the liquid's surface and liquid→glass on
// the far side, each with the ratio of the two indices. At most
// MEDIA_MAX volumes nest; entering one more forgets the outermost.
#ifndef MEDIA_GLSL
#define MEDIA_GLSL
#include "common/scene.glsl"

const uint MEDIA_MAX = 4u;
const uint MEDIA_NONE = 0xFFFFFFFFu;

struct Media {
    uint volume[MEDIA_MAX];   // material indices, [0, n) used, n − 1 on top
    uint n;
};

Media media_vacuum() {
    Media s;
    for (uint i = 0u; i < MEDIA_MAX; ++i) s.volume[i] = MEDIA_NONE;
    s.n = 0u;
    return s;
}

// Whether a material bounds a volume (transmissive, not thin-walled).
bool media_is_volume(uint material) {
    MaterialGpu g = materials[material];
    return SC_TRANSMISSION && g.params.y > 0.0 && g.attenuation.w <= 0.5;
}

// Index of refraction of the medium at stack depth i from the top (0 = the
// top); 1 (vacuum) below the stack. KHR_materials_ior's ior 0 (imported as
// is, gltf_import.rs) counts as 1 here, so no interface divides by it.
float media_ior(Media s, uint i) {
    float n = i < s.n ? materials[s.volume[s.n - 1u - i]].params.z : 1.0;
    return n >= 1.0 ? n : 1.0;
}

// Absorption σ_a of the medium the path is in (0 in vacuum).
vec3 media_sigma_a(Media s) {
    return s.n > 0u ? materials[s.volume[s.n - 1u]].attenuation.rgb : vec3(0.0);
}

// Position of a volume in the stack (from the bottom), or MEDIA_NONE.
uint media_find(Media s, uint material) {
    uint at = MEDIA_NONE;
    for (uint i = 0u; i < s.n; ++i)
        if (s.volume[i] == material) at = i;   // the innermost copy
    return at;
}

// The index of refraction on the other side of the boundary of `material`
// that a ray meets (front: arriving from outside), relative to which its
// own index acts: entering, the medium the ray is in; leaving the top, the
// one below it; leaving a volume not in the stack, the top.
float media_outside_ior(Media s, uint material, bool front) {
    if (front) return media_ior(s, 0u);
    return media_find(s, material) == s.n - 1u && s.n > 0u ? media_ior(s, 1u) : media_ior(s, 0u);
}

// A back face of a volume inside the stack but below its top: no interface.
bool media_false_interface(Media s, uint material, bool front) {
    if (front || s.n < 2u) return false;
    uint at = media_find(s, material);
    return at != MEDIA_NONE && at != s.n - 1u;
}

void media_remove(inout Media s, uint material) {
    uint at = media_find(s, material);
    if (at == MEDIA_NONE) return;
    for (uint i = at; i + 1u < s.n; ++i) s.volume[i] = s.volume[i + 1u];
    s.n--;
    s.volume[s.n] = MEDIA_NONE;
}

// The ray refracted through the boundary of `material` (front: into it).
void media_cross(inout Media s, uint material, bool front) {
    if (!front) {
        media_remove(s, material);
        return;
    }
    if (s.n == MEDIA_MAX) {
        for (uint i = 0u; i + 1u < MEDIA_MAX; ++i) s.volume[i] = s.volume[i + 1u];
        s.n--;
    }
    s.volume[s.n] = material;
    s.n++;
}
#endif
