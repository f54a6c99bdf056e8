//! SPIR-V compiled by build.rs from `shaders/` (glslc, Vulkan 1.2 target).
//! A shader that traces rays exists twice: `<name>.query` (VK_KHR_ray_query)
//! and `<name>.software` (CWBVH traversal from storage buffers).
#![deny(clippy::undocumented_unsafe_blocks)]

include!(concat!(env!("OUT_DIR"), "/shaders.rs"));

/// SPIR-V of a compiled shader by name (e.g. `reference/trace.software`).
pub fn spirv(name: &str) -> Option<&'static [u8]> {
    SHADERS.iter().find(|(n, _)| *n == name).map(|(_, b)| *b)
}
