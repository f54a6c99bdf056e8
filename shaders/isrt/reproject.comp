#version 460
// Forward reprojection: one thread per cell of the previous frame. A sample
// lands in the cell its new sub-pixel position falls into; the reservation is
// a 64-bit atomicMin on (view depth | source cell), so the closest sample wins
// and ties go to the lower source index (independent of thread order).
#include "isrt/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 g = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    uvec2 gs = grid_size();
    if (any(greaterThanEqual(g, gs))) return;
    uint src = cell_index(eye, g);
    uvec4 fh = fh_prev[src];
    // A background sample (first_hit.glsl) reprojects as a direction at
    // infinity: through the point one unit along it from the new eye
    // (camera.glsl background_offset), with view depth ∞ in the
    // claim, so any surface sample wins its cell.
    bool bg = first_hit_is_background(fh);
    if (!first_hit_valid(fh) && !bg) return;
    vec2 q;
    float vd;
    vec2 size = vec2(frame_size());
    EyeGpu e = frame.eyes[eye];
    vec3 offset = vec3(0.0);   // from e's position
    if (!bg) {
        vec3 wp, ng;
        hit_position_and_normal(fh, wp, ng);
        offset = wp - e.pos_tanx.xyz;
        // Seen from behind on a single-sided triangle, the sample is not
        // what the eye sees (eye rays pass through the face:
        // first_hit.glsl first_hit_culled): dropped, so the cell is traced
        // anew, as for a sample that left the view.
        if (first_hit_culled(fh, ng, eye_is_ortho(e) ? e.fwd.xyz : offset)) {
            atomicAdd(counters[C_ISRT_BACKFACING], 1u);
            return;
        }
    }
    bool on_screen = bg ? background_target(e, frame.prev_eyes[eye], vec2(g / M) + isrt_background_place(fh, g), background_direction(fh), q)
                        : project_offset_to_eye(e, offset, q, vd);
    if (!on_screen || any(lessThan(q, vec2(0.0))) ||
        any(greaterThanEqual(q, size))) {
        atomicAdd(counters[C_ISRT_OFFSCREEN], 1u);
        return;
    }
    uvec2 t = min(uvec2(q * float(M)), gs - 1u);
    uint local = src - eye * cells_per_eye();
    if (bg) vd = uintBitsToFloat(0x7F800000u);
    atomicMin(claim[cell_index(eye, t)], (uint64_t(floatBitsToUint(vd)) << 32) | uint64_t(local));
    atomicAdd(counters[C_ISRT_REPROJECTED], 1u);
}
