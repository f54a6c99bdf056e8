//! SPIR-V compiled by build.rs from `shaders/` (glslc, Vulkan 1.2 target).
//! A shader that traces rays exists twice: `<name>.query` (VK_KHR_ray_query)
//! and `<name>.software` (CWBVH traversal from storage buffers).
//! The sources, the interface headers and each variant's defines are embedded
//! too, so a scene can recompile the shaders that shade hits with its own
//! code (material graphs, src/materials/scene_shaders.rs): [`lookup`] asks
//! such a [`ShaderOverride`] first and falls back to the build-time SPIR-V.
#![deny(clippy::undocumented_unsafe_blocks)]

include!(concat!(env!("OUT_DIR"), "/shaders.rs"));

/// SPIR-V of a compiled shader by name (e.g. `reference/trace.software`).
pub fn spirv(name: &str) -> Option<&'static [u8]> {
    SHADERS.iter().find(|(n, _)| *n == name).map(|(_, b)| *b)
}

/// The source file (under `shaders/`) and glslc defines of variant `name`.
pub fn variant(name: &str) -> Option<(&'static str, &'static [&'static str])> {
    VARIANTS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, s, d)| (*s, *d))
}

/// Text of an embedded shader source or include (`common/scene.glsl`,
/// `interface/reference.glsl`, ...).
pub fn source(path: &str) -> Option<&'static str> {
    SOURCES
        .iter()
        .chain(HEADERS)
        .find(|(n, _)| *n == path)
        .map(|(_, t)| *t)
}

/// Run-time replacements of build-time shaders (a scene's material graphs).
pub trait ShaderOverride: Send + Sync + std::fmt::Debug {
    /// `None`: this variant is not replaced (use the build-time SPIR-V);
    /// `Some(Err)`: it is, and compiling it failed.
    fn spirv(&self, name: &str) -> Option<Result<&'static [u8], String>>;
}

/// SPIR-V of `name`: the override's where it replaces the shader, else the
/// build-time one. `Ok(None)` = no such shader.
pub fn lookup(
    name: &str,
    over: Option<&dyn ShaderOverride>,
) -> Result<Option<&'static [u8]>, String> {
    if let Some(o) = over {
        if let Some(r) = o.spirv(name) {
            return r.map(Some);
        }
    }
    Ok(spirv(name))
}
