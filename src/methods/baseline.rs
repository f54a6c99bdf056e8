//! `naive` and `supersample`: path tracing without reuse, the baselines of the
//! paper's comparisons. Both are the `reference` path tracer under another
//! name (same shaders, same integrator, same seeds), so the only difference
//! from the reference is the sample count:
//!
//! * `naive`: 1 spp, jittered at random within the pixel; the jitter and the
//!   paths are keyed by the frame index, so they change every frame.
//! * `supersample`: `--spp N` samples per pixel per frame, no reuse.

use super::{Reference, RenderSettings};
use crate::gpu::{GpuContext, GpuResult};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use std::sync::Arc;

/// 1 spp jittered path tracing (`settings.spp` is ignored).
pub fn naive(
    ctx: &Arc<GpuContext>,
    scene: &Arc<SceneGpu>,
    env: &Option<Environment>,
    settings: &RenderSettings,
) -> GpuResult<Reference> {
    let s = RenderSettings {
        spp: 1,
        ..settings.clone()
    };
    Reference::with_name("naive", ctx, scene, env, &s)
}

/// `settings.spp` jittered samples per pixel per frame.
pub fn supersample(
    ctx: &Arc<GpuContext>,
    scene: &Arc<SceneGpu>,
    env: &Option<Environment>,
    settings: &RenderSettings,
) -> GpuResult<Reference> {
    Reference::with_name("supersample", ctx, scene, env, settings)
}
