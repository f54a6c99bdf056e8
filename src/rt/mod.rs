//! Ray-tracing structures and the choice of backend: for the software path an
//! obvhs CWBVH over all triangles in world space (flattened, static scenes)
//! or a CWBVH per mesh + one over the instances (two-level, scenes that
//! move; `BvhLayout`), BLAS per mesh + TLAS for ray queries
//! (docs/ARCHITECTURE.md explains the choice).

pub mod bvh;
pub mod gpu_scene;
pub mod memo;
pub mod origin;
pub mod two_level;

pub use bvh::{CpuHit, SoftwareBvh, TRAVERSAL_STACK_SIZE};
pub use gpu_scene::{BvhLayout, SceneGpu};
pub use memo::MemoGpu;
pub use two_level::TwoLevelBvh;

use crate::gpu::GpuContext;
use std::str::FromStr;

/// The ray backend a pipeline is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RtBackend {
    /// VK_KHR_ray_query against a TLAS.
    Query,
    /// obvhs CWBVH traversed in GLSL from storage buffers.
    Software,
}

impl RtBackend {
    /// Suffix of the shader variant compiled for this backend.
    pub fn shader_suffix(self) -> &'static str {
        match self {
            RtBackend::Query => "query",
            RtBackend::Software => "software",
        }
    }
}

impl std::fmt::Display for RtBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.shader_suffix())
    }
}

/// `--rt auto|query|software`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum RtChoice {
    /// Hardware ray queries when the device has them (not on CPU drivers),
    /// else software.
    #[default]
    Auto,
    Query,
    Software,
}

impl FromStr for RtChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(RtChoice::Auto),
            "query" => Ok(RtChoice::Query),
            "software" => Ok(RtChoice::Software),
            other => Err(format!(
                "unknown ray backend '{other}' (expected auto, query or software)"
            )),
        }
    }
}

impl RtChoice {
    /// Resolves the choice on a device; asking for `query` where the device has
    /// no ray queries is an error that says what to use instead.
    pub fn resolve(self, ctx: &GpuContext) -> Result<RtBackend, String> {
        match self {
            // A CPU driver's ray queries are software as well, and our CWBVH
            // traversal beats lavapipe's (0.20–0.78× the time per ray,
            // docs/PERFORMANCE.md): auto takes ray queries only on GPUs.
            RtChoice::Auto => Ok(if ctx.ray_query_enabled() && !ctx.is_cpu_device() {
                RtBackend::Query
            } else {
                RtBackend::Software
            }),
            RtChoice::Software => Ok(RtBackend::Software),
            RtChoice::Query if ctx.ray_query_enabled() => Ok(RtBackend::Query),
            RtChoice::Query => Err(format!(
                "device '{}' has no ray queries; use --rt software or --rt auto",
                ctx.caps.name
            )),
        }
    }
}
