// The media a path travels in (KHR_materials_volume): a small stack of the
// volumes (instances whose material has a volume) it has refracted into,
// innermost (most recently entered) on top, as in Schmidt & Budge, "Simple
// Nested Dielectrics in Ray Traced Images" (2002), which the extension's
// specification points to for tracking the index of refraction through
// nested and overlapping objects. glTF has no priorities, so the volume
// entered last wins where volumes overlap:
//  - refracting into a volume's front pushes it; the interface's index of
//    refraction is the ratio of the volume's to the enclosing medium's (the
//    top before the push; vacuum, 1, below the stack);
//  - refracting out through the back of the volume on top pops it; the
//    ratio is that of the medium below it to the volume's;
//  - a boundary with the same medium on both sides is no interface, and
//    the ray goes on unchanged (a "false" intersection in Schmidt &
//    Budge's words; media_pass): the back of a volume in the stack but not
//    on top (the ray is inside a volume entered later, which fills that
//    place), the front of a volume of the top's own material, and the back
//    of the top when the volume below it has the same material (touching
//    or overlapping pieces of one glass);
//  - a back face of a volume that is not in the stack at all (a camera
//    inside a volume, an open mesh) is an exit into the top medium.
// Volumes are told apart by instance, so two objects of one material are
// two volumes. Beer–Lambert absorption is the top medium's. Liquid in a
// glass modelled the usual way — the liquid's surface a little inside the
// glass wall — then refracts glass→liquid at the liquid's surface and
// liquid→glass on the far side, each with the ratio of the two indices. At
// most MEDIA_MAX volumes nest; entering one more forgets the outermost.
#ifndef MEDIA_GLSL
#define MEDIA_GLSL
#include "common/scene.glsl"

const uint MEDIA_MAX = 4u;
const uint MEDIA_NONE = 0xFFFFFFFFu;

struct Media {
    uint volume[MEDIA_MAX];   // instance indices, [0, n) used, n − 1 on top
    uint n;
};

Media media_vacuum() {
    Media s;
    for (uint i = 0u; i < MEDIA_MAX; ++i) s.volume[i] = MEDIA_NONE;
    s.n = 0u;
    return s;
}

// The material of the volume at stack depth i from the top (0 = the top);
// the caller keeps i < s.n.
uint media_material(Media s, uint i) { return instance_material(s.volume[s.n - 1u - i]); }

// Index of refraction of the medium at stack depth i from the top; 1
// (vacuum) below the stack. KHR_materials_ior's ior 0 (imported as is,
// gltf_import.rs) counts as 1 for the media around a boundary.
float media_ior(Media s, uint i) {
    float n = i < s.n ? materials[media_material(s, i)].params.z : 1.0;
    return n >= 1.0 ? n : 1.0;
}

// Absorption σ_a of the medium the path is in (0 in vacuum).
vec3 media_sigma_a(Media s) {
    return s.n > 0u ? materials[media_material(s, 0u)].attenuation.rgb : vec3(0.0);
}

// Position of a volume (instance) in the stack from the bottom, or MEDIA_NONE.
uint media_find(Media s, uint inst) {
    uint at = MEDIA_NONE;
    for (uint i = 0u; i < s.n; ++i)
        if (s.volume[i] == inst) at = i;
    return at;
}

// The index of refraction on the other side of the boundary of volume
// `inst` that a ray meets (front: arriving from outside), relative to which
// its own index acts: entering, the medium the ray is in; leaving the top,
// the one below it; leaving a volume not in the stack, the top.
float media_outside_ior(Media s, uint inst, bool front) {
    if (front || s.n == 0u) return media_ior(s, 0u);
    return media_find(s, inst) == s.n - 1u ? media_ior(s, 1u) : media_ior(s, 0u);
}

// Whether the boundary of `inst` met from its `front` side or back is no
// interface (the same medium on both sides; see the list above). Only
// volumes are ever in the stack, so a match by instance or by a stacked
// volume's material implies `inst` is a volume.
bool media_false_interface(Media s, uint inst, bool front) {
    if (s.n == 0u) return false;
    uint material = instance_material(inst);
    if (front) return media_material(s, 0u) == material;
    uint at = media_find(s, inst);
    if (at == MEDIA_NONE) return false;
    if (at != s.n - 1u) return true;
    return s.n >= 2u && media_material(s, 1u) == material;
}

void media_remove(inout Media s, uint inst) {
    uint at = media_find(s, inst);
    if (at == MEDIA_NONE) return;
    for (uint i = at; i + 1u < s.n; ++i) s.volume[i] = s.volume[i + 1u];
    s.n--;
    s.volume[s.n] = MEDIA_NONE;
}

void media_push(inout Media s, uint inst) {
    if (s.n == MEDIA_MAX) {
        for (uint i = 0u; i + 1u < MEDIA_MAX; ++i) s.volume[i] = s.volume[i + 1u];
        s.n--;
    }
    s.volume[s.n] = inst;
    s.n++;
}

// The ray crossed the boundary of volume `inst`, refracted or passed
// through (front: into it).
void media_cross(inout Media s, uint inst, bool front) {
    if (front) media_push(s, inst);
    else media_remove(s, inst);
}
#endif
