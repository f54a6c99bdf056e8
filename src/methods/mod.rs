//! Rendering methods. Every method implements [`Method`] and produces the same
//! [`StereoFrame`], so replay, compare, metrics and reports never special-case one.

pub mod args;
pub mod baseline;
pub mod config;
pub mod debug_normals;
pub mod frame;
mod frame_loop;
pub mod hash_cache;
pub mod hash_table;
pub mod hybrid;
pub mod isrt;
pub mod outputs;
pub mod reference;
pub mod registry;
pub mod sample_cache;
mod specialize;
pub mod taa;

pub use args::MethodArgs;
pub use config::{MethodOptions, NoOptions};
pub use debug_normals::DebugNormals;
pub use frame::{EyeImage, FrameInput, FrameParams, FrameStats, RayCounts, StereoFrame};
pub use hash_cache::{HashCache, HashCacheSettings};
pub use hybrid::{Hybrid, HybridConfig};
pub use isrt::{Isrt, IsrtSettings};
pub use outputs::{Color, CounterOutput, FrameOutputs, PixelOutputs, RaySlots};
pub use reference::Reference;
pub use registry::{MethodConfig, MethodKind};
pub use sample_cache::{SampleCache, SampleCacheSettings};
pub use specialize::LightSampling;
pub use taa::{halton_jitter, Taa, TaaHistory, TaaOnOutput, TaaPass, TaaSettings, TaaWeights};

use crate::gpu::{GpuContext, GpuResult, Recorder};
use std::sync::Arc;

/// Settings every method shares, so differences come from the method alone.
/// A method's own options are its [`MethodConfig`] (src/methods/config.rs).
#[derive(Clone, Debug, serde::Serialize)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel per frame (reference, supersample).
    pub spp: u32,
    /// Maximum scattering events per path (pbrt's maxdepth: 1 = direct light only).
    pub max_bounces: u32,
    /// Run seed of the counter-based random numbers.
    pub seed: u32,
    /// Compile every feature in, ignoring what the scene uses (the unspecialized build).
    pub all_features: bool,
    /// Features compiled in on top of the scene's own (benchmarks: what one
    /// feature's code costs a scene that does not use it).
    pub extra_features: crate::scene::SceneFeatures,
    /// Record every pass, also those that provably have nothing to do for this
    /// scene and these settings (the build issue 6's skipping is checked against).
    pub all_passes: bool,
    /// Use the subgroup-operation builds of the shaders that have one, where
    /// the device supports subgroup arithmetic and ballot (default); false
    /// forces the plain builds (benchmarks and tests compare the two).
    pub subgroup_ops: bool,
    /// Sampling of emissive triangles and environment maps (default MIS).
    pub light_sampling: LightSampling,
    /// `--taa-output`: every method's image goes through the one TAA
    /// ([`TaaOnOutput`], with these options: the `--taa-*` ones) unless it
    /// already ends in it (the paper's Fig. 12, "TAA on top of all methods").
    pub taa_output: Option<TaaSettings>,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 64,
            height: 64,
            spp: 16,
            max_bounces: 3,
            seed: 1,
            all_features: false,
            extra_features: Default::default(),
            all_passes: false,
            subgroup_ops: true,
            light_sampling: LightSampling::Mis,
            taa_output: None,
        }
    }
}

/// A rendering method. It records its passes for a frame into a
/// [`Recorder`] and says which buffers are its outputs and counters
/// ([`FrameOutputs`]); the provided [`Method::render_frame`] is the frame
/// loop every method shares (src/methods/frame_loop.rs: one batched
/// readback, one submit-and-wait, timestamps, frame statistics).
pub trait Method {
    /// The method's name on the command line (`reference`, `sample-cache`, ...).
    fn name(&self) -> &'static str;
    /// GPU memory held by the method's own buffers (not the scene's).
    fn memory_bytes(&self) -> u64;

    /// The device the method renders on.
    fn context(&self) -> &Arc<GpuContext>;

    /// Records this frame's passes into `rec` and returns what the frame
    /// loop reads back. Everything the passes reference is borrowed from
    /// `self` for `'a`, the recorder's lifetime.
    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        frame: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>>;

    /// Whether the image the method shows is already the output of the one
    /// TAA ([`TaaPass`]): `--taa-output` then leaves the method as it is.
    fn resolves_with_taa(&self) -> bool {
        false
    }

    /// Renders both eyes of one frame: the shared frame loop.
    fn render_frame(&mut self, frame: &FrameInput) -> GpuResult<StereoFrame> {
        frame_loop::render(self, frame)
    }
}
