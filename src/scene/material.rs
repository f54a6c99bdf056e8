//! glTF metallic-roughness materials with the extensions stereocache supports
//! (emissive strength, transmission, ior).

use super::texture::TextureSampler;
use glam::{Vec3, Vec4};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlphaMode {
    Opaque,
    /// Alpha-tested against `Material::alpha_cutoff`.
    Mask,
    /// Rendered as Mask with cutoff 0.5 (a path tracer has no sorted blending); warned at load.
    Blend,
}

/// A texture binding: index into `Scene::textures` (the uv set is always 0)
/// and the sampler it is read with (glTF `texture.sampler`). Two references
/// to one texture with different samplers share the image; the GPU scene
/// gives each (texture, sampler) pair its own descriptor slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    pub texture: u32,
    pub sampler: TextureSampler,
}

impl TextureRef {
    /// `texture` read with the default sampler (repeat, trilinear).
    pub fn new(texture: u32) -> TextureRef {
        TextureRef {
            texture,
            sampler: TextureSampler::default(),
        }
    }
}

#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    /// Linear RGBA base colour factor.
    pub base_color: Vec4,
    /// sRGB-encoded texture, multiplied with `base_color`.
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    pub roughness: f32,
    /// Linear texture: G = roughness, B = metallic (glTF convention).
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Tangent-space normal map (linear).
    pub normal_texture: Option<TextureRef>,
    pub normal_scale: f32,
    /// Linear emitted radiance factor, already multiplied by KHR_materials_emissive_strength.
    pub emissive: Vec3,
    /// sRGB-encoded emissive texture.
    pub emissive_texture: Option<TextureRef>,
    pub alpha_mode: AlphaMode,
    pub alpha_cutoff: f32,
    pub double_sided: bool,
    /// KHR_materials_transmission factor (0 = opaque surface, 1 = fully transmissive dielectric).
    pub transmission: f32,
    /// Linear texture, R = transmission.
    pub transmission_texture: Option<TextureRef>,
    /// KHR_materials_ior (glTF default 1.5).
    pub ior: f32,
    /// KHR_materials_specular `specularFactor` (default 1): scales the dielectric
    /// Fresnel layer; 0 leaves a pure Lambertian diffuse (furnace tests).
    pub specular: f32,
}

impl Default for Material {
    fn default() -> Self {
        // glTF 2.0 default material.
        Material {
            name: "default".into(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            double_sided: false,
            transmission: 0.0,
            transmission_texture: None,
            ior: 1.5,
            specular: 1.0,
        }
    }
}

impl Material {
    /// A plain diffuse (Lambert) material of the given linear colour.
    pub fn diffuse(name: &str, color: Vec3) -> Self {
        Material {
            name: name.into(),
            base_color: color.extend(1.0),
            metallic: 0.0,
            roughness: 1.0,
            ..Default::default()
        }
    }

    pub fn texture_refs(&self) -> impl Iterator<Item = TextureRef> + '_ {
        [
            self.base_color_texture,
            self.metallic_roughness_texture,
            self.normal_texture,
            self.emissive_texture,
            self.transmission_texture,
        ]
        .into_iter()
        .flatten()
    }

    /// Whether the BSDF has a specular lobe (metal, transmission, or a
    /// dielectric specular layer), i.e. the appearance depends on the view
    /// direction beyond Lambert: appendix C's α_min clamp applies to such
    /// materials (shaders/sample_cache/common.glsl `has_specular_lobe`).
    pub fn is_view_dependent(&self) -> bool {
        self.metallic > 0.0
            || self.specular > 0.0
            || self.transmission > 0.0
            || self.metallic_roughness_texture.is_some()
    }
}
