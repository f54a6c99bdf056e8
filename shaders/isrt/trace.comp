#version 460
// `--isrt-retrace every` (default): every sample is retraced every frame
// (isrt_retrace, common.glsl): a ray from the eye to the stored hit, as in
// the sample cache's retrace (sample_cache/retrace.comp): kept when the
// closest hit lies within ε0·t of it, kept when the ray finds neither (no
// hit near the stored one: precision at triangle edges; §3.2 of the
// sample-cache paper drops a sample only behind a closer hit), replaced by
// the closer hit it finds (Dal Corso et al.'s updated hit point). A
// background sample (first_hit.glsl) is retraced along its direction and
// kept while that ray hits nothing, else replaced by what it hits. Every
// cell left empty by the reprojection is then filled with a new sample
// through a uniformly random point of that cell; a miss stores a background
// sample, which the reconstruction counts with the environment's radiance
// (the cell's share of the pixel's coverage).
#include "isrt/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 g = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(g, grid_size()))) return;
    uint idx = cell_index(eye, g);
    EyeGpu e = frame.eyes[eye];
    uvec4 fh = fh_cur[idx];
    if (first_hit_is_background(fh) || first_hit_valid(fh)) {
        isrt_retrace(idx, e, g);
        return;
    }
    isrt_new_sample(idx, eye, g, e);
}
