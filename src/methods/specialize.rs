//! Which build of a method's pipelines to make: the specialization constants
//! from the scene's features (`SceneGpu::spec_constants`), every feature for
//! the all-features build, plus the features `RenderSettings::extra_features`
//! compiles in on top — the benchmark of issue 6 (`stereocache bench
//! specialization`) uses that to price one feature's code at a time.

use super::RenderSettings;
use crate::gpu::SpecConstants;
use crate::rt::gpu_scene::spec_id;
use crate::rt::SceneGpu;
use crate::scene::Environment;

impl RenderSettings {
    /// The scene-feature specialization constants (spec ids 0..11 of
    /// shaders/common/features.glsl) for pipelines of `scene` under these settings.
    pub fn spec_constants(&self, scene: &SceneGpu, env: &Option<Environment>) -> SpecConstants {
        let mut s = scene.spec_constants(env, self.max_bounces, self.all_features);
        let x = &self.extra_features;
        for (id, on) in [
            (spec_id::TEXTURES, x.textures),
            (spec_id::NORMAL_MAPS, x.normal_maps),
            (spec_id::ALPHA_MASK, x.alpha_mask),
            (spec_id::TRANSMISSION, x.transmission),
            (spec_id::EMISSIVE, x.emissive_triangles),
            (spec_id::PUNCTUAL, x.punctual_lights),
            (spec_id::DIRECTIONAL, x.directional_lights),
            (spec_id::VIEW_DEPENDENT, x.view_dependent),
            (spec_id::VERTEX_COLORS, x.vertex_colors),
            (spec_id::CLEARCOAT, x.clearcoat),
            (spec_id::BACKFACE_CULLING, x.backface_culling),
            (spec_id::SECOND_UV, x.second_uv),
            (spec_id::UV_AFFINE, x.uv_affine),
        ] {
            if on {
                s.flag(id, true);
            }
        }
        s.set(spec_id::LIGHT_STRATEGY, self.light_sampling as u32);
        s
    }
}

/// How emissive triangles and environment maps are sampled (spec constant
/// `SC_LIGHT_STRATEGY`, shaders/common/features.glsl). `Mis` is the renderer;
/// the other two are its two strategies alone — each unbiased, so tests check
/// that all three agree in expectation, and `Bsdf` is exactly the integrator
/// before it had area-light NEE (the benchmark's "before").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum LightSampling {
    /// Next-event estimation and BSDF sampling, power-heuristic MIS.
    #[default]
    Mis = 0,
    /// Next-event estimation only (BSDF-sampled hits on lights count 0).
    Nee = 1,
    /// BSDF sampling only (no light sampling of emitters or the map).
    Bsdf = 2,
}
