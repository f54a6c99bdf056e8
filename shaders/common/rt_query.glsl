// Ray-query backend: hardware (or driver) traversal of the TLAS/BLAS built by
// src/gpu/accel.rs. Alpha-masked geometry is non-opaque and alpha-tested here.
#extension GL_EXT_ray_query : require
#include "interface/scene.glsl"
layout(set = SET_SCENE, binding = B_SCENE_TLAS) uniform accelerationStructureEXT tlas;

// Back-face culling (glTF doubleSided false): instances whose material does
// not cull carry TRIANGLE_FACING_CULL_DISABLE, the others counter-clockwise
// front faces in object space (Vulkan decides facing in the BLAS's space, so
// a mirrored instance keeps glTF's rule; src/gpu/accel.rs `facing_flags`).
uint cull_flags() { return SC_BACKFACE_CULLING ? gl_RayFlagsCullBackFacingTrianglesEXT : gl_RayFlagsNoneEXT; }

bool rt_closest_hit(vec3 o, vec3 d, float tmin, float tmax, out RtHit h) {
    rayQueryEXT rq;
    rayQueryInitializeEXT(rq, tlas, cull_flags(), 0xFFu, o, tmin, d, tmax);
    while (rayQueryProceedEXT(rq)) {
        if (rayQueryGetIntersectionTypeEXT(rq, false) == gl_RayQueryCandidateIntersectionTriangleEXT) {
            uint inst = uint(rayQueryGetIntersectionInstanceCustomIndexEXT(rq, false));
            uint prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(rq, false));
            vec2 bary = rayQueryGetIntersectionBarycentricsEXT(rq, false);
            if (alpha_passes(inst, prim, bary)) rayQueryConfirmIntersectionEXT(rq);
        }
    }
    h.t = tmax;
    h.instance = 0xFFFFFFFFu;
    h.prim = 0u;
    h.bary = vec2(0.0);
    if (rayQueryGetIntersectionTypeEXT(rq, true) != gl_RayQueryCommittedIntersectionTriangleEXT) return false;
    h.t = rayQueryGetIntersectionTEXT(rq, true);
    h.instance = uint(rayQueryGetIntersectionInstanceCustomIndexEXT(rq, true));
    h.prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(rq, true));
    h.bary = rayQueryGetIntersectionBarycentricsEXT(rq, true);
    return true;
}

bool rt_occluded(vec3 o, vec3 d, float tmin, float tmax) {
    rayQueryEXT rq;
    rayQueryInitializeEXT(rq, tlas, gl_RayFlagsTerminateOnFirstHitEXT | cull_flags(), 0xFFu, o, tmin, d, tmax);
    while (rayQueryProceedEXT(rq)) {
        if (rayQueryGetIntersectionTypeEXT(rq, false) == gl_RayQueryCandidateIntersectionTriangleEXT) {
            uint inst = uint(rayQueryGetIntersectionInstanceCustomIndexEXT(rq, false));
            uint prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(rq, false));
            vec2 bary = rayQueryGetIntersectionBarycentricsEXT(rq, false);
            if (alpha_passes(inst, prim, bary)) rayQueryConfirmIntersectionEXT(rq);
        }
    }
    return rayQueryGetIntersectionTypeEXT(rq, true) == gl_RayQueryCommittedIntersectionTriangleEXT;
}
