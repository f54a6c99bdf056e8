#version 460
// `--isrt-retrace one`: isrt in the sample-cache paper's Fig. 10
// configuration ("we omit adaptive sampling here and only trace one sample
// per pixel"). One thread per pixel: of the pixel's M × M cells, one sample
// (surface or background) is retraced per frame, round robin by frame index
// over the occupied cells as shade.comp picks (isrt_retrace, common.glsl:
// kept, or replaced by the closer hit its ray finds); the
// others are kept unchecked, hence the edge artefacts during movement the
// paper reports. Then empty cells get new samples (isrt_new_sample), in a
// cyclic order from a random cell, only until the pixel holds `n_target`
// samples (the density target; 0 = every empty cell).
#include "isrt/common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    uint eye = gl_GlobalInvocationID.z;
    if (any(greaterThanEqual(px, frame_size()))) return;
    EyeGpu e = frame.eyes[eye];
    const uint CELLS = M * M;
    uint occupied = 0u;
    for (uint k = 0u; k < CELLS; ++k) {
        uvec4 fh = fh_cur[cell_index(eye, px * M + uvec2(k % M, k / M))];
        if (first_hit_valid(fh) || first_hit_is_background(fh)) occupied |= 1u << k;
    }
    uint n = bitCount(occupied);
    if (n > 0u) {
        uint pick = frame.size_seed.w % n;
        uint rest = occupied;
        for (uint i = 0u; i < pick; ++i) rest &= rest - 1u;
        uint k = uint(findLSB(rest));
        uint idx = cell_index(eye, px * M + uvec2(k % M, k / M));
        // Kept, or replaced by the closer hit its ray finds: the cell stays
        // occupied either way.
        isrt_retrace(idx, e, px * M + uvec2(k % M, k / M));
        // The samples not retraced this frame, counted as they are.
        for (uint j = 0u; j < CELLS; ++j) {
            if (j == k || (occupied & (1u << j)) == 0u) continue;
            uvec4 fh = fh_cur[cell_index(eye, px * M + uvec2(j % M, j / M))];
            atomicAdd(counters[first_hit_is_background(fh) ? C_ISRT_BACKGROUND : C_ISRT_SAMPLES], 1u);
        }
    }
    uint target = pc.n_target == 0u ? CELLS : min(pc.n_target, CELLS);
    Rng r = rng_init(frame.size_seed.z, frame.size_seed.w, eye, px.y * frame_size().x + px.x, 0x15A70100u);   // (not shade.comp's 0x15A70002 + cell)
    uint start = min(uint(rng_next(r) * float(CELLS)), CELLS - 1u);
    for (uint j = 0u; j < CELLS && n < target; ++j) {
        uint k = (start + j) % CELLS;
        if ((occupied & (1u << k)) != 0u) continue;
        uvec2 g = px * M + uvec2(k % M, k / M);
        isrt_new_sample(cell_index(eye, g), eye, g, e);
        n += 1u;
    }
}
