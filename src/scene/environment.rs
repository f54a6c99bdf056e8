//! What rays that leave the scene see: a constant colour, an analytic sky with
//! a sun, or an equirectangular map.

use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SkyModel {
    /// Preetham et al. 1999 daylight sky, parametrised by turbidity.
    Preetham { turbidity: f32 },
}

#[derive(Clone, Debug)]
pub enum Environment {
    /// Uniform radiance from every direction (furnace tests, studio look).
    Constant(Vec3),
    /// Analytic sky; the sun itself is a `LightKind::Directional` light in `Scene::lights`.
    Sky {
        model: SkyModel,
        /// Unit direction *towards* the sun (the sun light's `direction` is its negation).
        sun_direction: Vec3,
        /// Multiplies the model's radiance (Preetham: kcd/m²) into renderer units.
        scale: f32,
    },
    /// Equirectangular radiance map, linear RGB f32, row 0 at +Y (top), u = 0 at −Z going towards +X
    /// (exact lookup formula in `env_map`).
    Map {
        name: String,
        width: u32,
        height: u32,
        texels: Vec<[f32; 3]>,
        scale: f32,
    },
}
