//! glTF metallic-roughness materials with the extensions stereocache supports
//! (emissive strength, transmission, ior, specular, clearcoat, volume).

use super::gltf_uv::{UvAffine, SLOT_COUNT};
use super::texture::TextureSampler;
use glam::{Vec3, Vec4};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlphaMode {
    Opaque,
    /// Alpha-tested against `Material::alpha_cutoff`.
    Mask,
    /// Stochastic coverage: a ray finds the surface with probability alpha
    /// (a screen door of fine cells fixed on the surface, scene.glsl
    /// `coverage_coin`), so paths average to the alpha blend.
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
    /// KHR_materials_specular `specularTexture` (linear, A channel): multiplies `specular`.
    pub specular_texture: Option<TextureRef>,
    /// KHR_materials_specular `specularColorFactor` (linear, default 1): tints
    /// the dielectric F0 (F0 = min(F0(ior)·colour, 1)·specular).
    pub specular_color: Vec3,
    /// sRGB-encoded texture (RGB), multiplied with `specular_color`.
    pub specular_color_texture: Option<TextureRef>,
    /// KHR_materials_clearcoat (factor 0 = no coat).
    pub clearcoat: Clearcoat,
    /// Bit k set: texture slot k (`gltf_uv::SLOTS` order: base colour,
    /// metallic-roughness, normal, emissive, transmission, specular, specular
    /// colour, clearcoat, clearcoat roughness, clearcoat normal) reads the
    /// meshes' second uv channel (`Mesh::uvs2`), else `Mesh::uvs`.
    pub second_uv_slots: u32,
    /// Per texture slot (`gltf_uv::SLOTS` order): the map its uvs take from
    /// the channel it reads, where its (uv set, `KHR_texture_transform`) is
    /// neither channel's (a third choice of a channel's set; `gltf_uv`
    /// `choose`); applied at shading time (`MaterialGpu::uv_affine`).
    pub uv_affine: [Option<UvAffine>; SLOT_COUNT],
    /// KHR_materials_volume with a thickness > 0 on a transmissive material
    /// (the extension needs transmission; without it the import leaves
    /// `None`, so an opaque single-sided material keeps culling back
    /// faces): the surface bounds a
    /// homogeneous (absorbing) volume, refracting at the boundary with the
    /// ior and attenuating inside by Beer–Lambert. `None` (glTF's default):
    /// a transmissive surface is thin-walled — an infinitely thin sheet that
    /// light passes straight through (no net refraction) or reflects off.
    pub volume: Option<Volume>,
    /// KHR_materials_unlit: the surface is an emitter of its base colour
    /// (moved to `emissive`, gltf_import.rs `unlit`), which COLOR_0
    /// multiplies as it does any base colour (`MaterialGpu.tex1.w`); the
    /// glTF writer gives it back as an unlit material.
    pub unlit: bool,
}

/// KHR_materials_clearcoat: a GGX dielectric coat (ior 1.5) over the base
/// material, with its own roughness and normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clearcoat {
    /// `clearcoatFactor` (0 = no coat).
    pub factor: f32,
    /// Linear texture, R = coat factor (multiplied with `factor`).
    pub texture: Option<TextureRef>,
    /// `clearcoatRoughnessFactor`.
    pub roughness: f32,
    /// Linear texture, G = coat roughness (multiplied with `roughness`).
    pub roughness_texture: Option<TextureRef>,
    /// Tangent-space normal map of the coat (linear); without one the coat
    /// follows the interpolated normal, not the base's normal map (the
    /// extension's rule).
    pub normal_texture: Option<TextureRef>,
    pub normal_scale: f32,
}

impl Default for Clearcoat {
    fn default() -> Self {
        Clearcoat {
            factor: 0.0,
            texture: None,
            roughness: 0.0,
            roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
        }
    }
}

/// KHR_materials_volume: the medium inside a closed transmissive mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Volume {
    /// `attenuationColor`: the colour white light turns into after
    /// `attenuation_distance` inside the medium.
    pub attenuation_color: Vec3,
    /// `attenuationDistance` in world units (+∞ = no absorption).
    pub attenuation_distance: f32,
}

impl Volume {
    /// A volume boundary that absorbs nothing (solid clear glass).
    pub const CLEAR: Volume = Volume {
        attenuation_color: Vec3::ONE,
        attenuation_distance: f32::INFINITY,
    };

    /// The absorption coefficient σ_a = −ln(colour) / distance per world
    /// unit (the extension's definition): transmittance over a path of
    /// length t inside is exp(−σ_a·t). A zero colour channel absorbs
    /// everything; it is clamped to 1e30 (finite for the GPU).
    pub fn sigma_a(&self) -> Vec3 {
        let d = self.attenuation_distance;
        if d.is_nan() || d <= 0.0 || !d.is_finite() {
            return Vec3::ZERO;
        }
        Vec3::from_array(self.attenuation_color.to_array().map(|c| {
            if c >= 1.0 {
                0.0
            } else if c > 0.0 {
                (-c.ln() / d).min(1e30)
            } else {
                1e30
            }
        }))
    }
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
            specular_texture: None,
            specular_color: Vec3::ONE,
            specular_color_texture: None,
            clearcoat: Clearcoat::default(),
            second_uv_slots: 0,
            uv_affine: [None; SLOT_COUNT],
            volume: None,
            unlit: false,
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

    /// Whether rays meeting this material's triangles from behind pass
    /// through (glTF: "when doubleSided is false, back-face culling is
    /// enabled"). Volume boundaries never cull (KHR_materials_volume: "the
    /// doubleSided property has no effect on volume boundaries"): a ray
    /// inside must find the way out.
    pub fn culls_back_faces(&self) -> bool {
        !self.double_sided && self.volume.is_none()
    }

    /// A transmissive surface without a volume: a thin sheet (see `volume`).
    pub fn is_thin_walled(&self) -> bool {
        (self.transmission > 0.0 || self.transmission_texture.is_some()) && self.volume.is_none()
    }

    pub fn texture_refs(&self) -> impl Iterator<Item = TextureRef> + '_ {
        [
            self.base_color_texture,
            self.metallic_roughness_texture,
            self.normal_texture,
            self.emissive_texture,
            self.transmission_texture,
            self.specular_texture,
            self.specular_color_texture,
            self.clearcoat.texture,
            self.clearcoat.roughness_texture,
            self.clearcoat.normal_texture,
        ]
        .into_iter()
        .flatten()
    }

    /// Whether the BSDF has a specular lobe (metal, transmission, a
    /// dielectric specular layer or a clearcoat), i.e. the appearance depends on the view
    /// direction beyond Lambert: appendix C's α_min clamp applies to such
    /// materials (shaders/sample_cache/common.glsl `has_specular_lobe`).
    pub fn is_view_dependent(&self) -> bool {
        self.metallic > 0.0
            || self.specular > 0.0
            || self.transmission > 0.0
            || self.clearcoat.factor > 0.0
            || self.metallic_roughness_texture.is_some()
    }
}
