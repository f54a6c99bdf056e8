#version 460
// Workgroup counts for the passes that run over a compacted list
// (VkDispatchIndirectCommand, 64 invocations per group): ARGS_LIST 0 = the
// retrace list (retrace_list_length()) into indirect_args[0..3), 1 = the shade list
// (state[8]) into indirect_args[4..7). Capped at 65535 groups, the smallest
// maxComputeWorkGroupCount[0] Vulkan allows; the list passes stride over
// the rest.
#include "sample_cache/common.glsl"
layout(constant_id = SPEC_SAMPLE_CACHE_ARGS_LIST) const uint ARGS_LIST = 0u;
layout(local_size_x = 1) in;

void main() {
    uint count = ARGS_LIST == 0u ? retrace_list_length() : state[8];
    uint at = ARGS_LIST * 4u;
    indirect_args[at] = min((count + 63u) / 64u, 65535u);
    indirect_args[at + 1u] = 1u;
    indirect_args[at + 2u] = 1u;
}
