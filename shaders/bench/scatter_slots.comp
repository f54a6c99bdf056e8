#version 460
// Second baseline for `bench sample-cache`: every occupied slot of a
// sample-cache snapshot forward-projected into the new view, its 32-byte
// payload (first hit and radiance record) stored into the same layer of the
// target pixel with a plain store. The reprojection's sample count, vertex
// fetches and memory traffic, without slot reservation (atomicOr),
// visibility or depth bounds: one-pass reprojection / this = the cost of
// Listing 2's bookkeeping alone.
#include "common/scene.glsl"
#include "common/packing.glsl"
#include "common/camera.glsl"
#include "common/first_hit.glsl"
#include "interface/bench_scatter_slots.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(push_constant) uniform Push { BENCH_SCATTER_SLOTS_PUSH } pc;
layout(set = SET_BENCH_SCATTER_SLOTS, binding = B_BENCH_SCATTER_SLOTS_MASKS, std430) readonly buffer Masks { uint masks[]; };      // [eye][pixel]
layout(set = SET_BENCH_SCATTER_SLOTS, binding = B_BENCH_SCATTER_SLOTS_SRC_FH, std430) readonly buffer SrcFh { uvec4 src_fh[]; };    // [eye][slot][pixel]
layout(set = SET_BENCH_SCATTER_SLOTS, binding = B_BENCH_SCATTER_SLOTS_SRC_RAD, std430) readonly buffer SrcRad { vec4 src_rad[]; };
layout(set = SET_BENCH_SCATTER_SLOTS, binding = B_BENCH_SCATTER_SLOTS_DST_FH, std430) writeonly buffer DstFh { uvec4 dst_fh[]; };
layout(set = SET_BENCH_SCATTER_SLOTS, binding = B_BENCH_SCATTER_SLOTS_DST_RAD, std430) writeonly buffer DstRad { vec4 dst_rad[]; };

void main() {
    uvec2 size = frame_size();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, size))) return;
    uint npix = size.x * size.y;
    uint pixel = px.y * size.x + px.x;
    uint occ = masks[eye * npix + pixel] & ((1u << pc.slots) - 1u);
    EyeGpu e = frame.eyes[eye];
    while (occ != 0u) {
        uint s = uint(findLSB(occ));
        occ &= occ - 1u;
        uint src = (eye * pc.slots + s) * npix + pixel;
        uvec4 fh = src_fh[src];
        if (!first_hit_valid(fh)) continue;   // background samples: no position
        vec2 q;
        float vd;
        if (!project_to_eye(e, hit_position(fh), q, vd) || any(lessThan(q, vec2(0.0))) || any(greaterThanEqual(q, vec2(size)))) continue;
        uvec2 qi = uvec2(q);
        uint dst = (eye * pc.slots + s) * npix + qi.y * size.x + qi.x;
        dst_fh[dst] = fh;
        dst_rad[dst] = src_rad[src];
    }
}
