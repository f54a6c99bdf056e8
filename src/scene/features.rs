//! The scene features a pipeline needs, derived once from the loaded scene and
//! fed to shaders as specialization constants so a pipeline only contains the
//! code the scene uses.

use super::{AlphaMode, Environment, LightKind, Scene};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SceneFeatures {
    pub textures: bool,
    pub normal_maps: bool,
    pub alpha_mask: bool,
    pub transmission: bool,
    pub emissive_triangles: bool,
    pub punctual_lights: bool,
    pub directional_lights: bool,
    /// A material with a view-dependent opaque lobe: metallic > 0 or a
    /// dielectric specular layer (KHR_materials_specular factor > 0, default
    /// 1). Without one, every opaque surface is Lambertian.
    pub view_dependent: bool,
    pub environment_map: bool,
    pub sky: bool,
    pub constant_environment: bool,
    /// An instance moves under the selected animations (`Scene::is_animated`):
    /// the previous-frame instance transforms are read (motion vectors,
    /// appendix D). Off, a static scene compiles the motion code out.
    pub animated: bool,
    /// A mesh has vertex colours (glTF COLOR_0): they multiply the base
    /// colour and its alpha. Off, the colour buffer is never read.
    pub vertex_colors: bool,
    /// A material has a clearcoat (KHR_materials_clearcoat factor > 0; its
    /// texture only multiplies the factor). Off, the coat is compiled out.
    pub clearcoat: bool,
    /// A mesh has a single-sided material (glTF doubleSided false, not a
    /// volume boundary): rays pass through its back faces. Off, the
    /// traversals skip the facing test.
    pub backface_culling: bool,
    /// A mesh has a second uv channel (`Mesh::uvs2`: some texture slots read
    /// another uv set or transform). Off, only the first is read.
    pub second_uv: bool,
    /// A material's texture slot reads its uv channel through a map (a third
    /// `KHR_texture_transform` of a channel's uv set, `Material::uv_affine`).
    /// Off, no slot applies one.
    pub uv_affine: bool,
}

impl SceneFeatures {
    pub fn of(scene: &Scene) -> Self {
        let mats = &scene.materials;
        SceneFeatures {
            textures: !scene.textures.is_empty() || scene.graphs.images().next().is_some(),
            normal_maps: mats
                .iter()
                .any(|m| m.normal_texture.is_some() || m.clearcoat.normal_texture.is_some()),
            alpha_mask: mats.iter().any(|m| m.alpha_mode != AlphaMode::Opaque),
            transmission: mats.iter().any(|m| m.transmission > 0.0),
            emissive_triangles: scene.has_emissive_triangles(),
            punctual_lights: scene
                .lights
                .iter()
                .any(|l| !matches!(l.kind, LightKind::Directional { .. })),
            directional_lights: scene
                .lights
                .iter()
                .any(|l| matches!(l.kind, LightKind::Directional { .. })),
            view_dependent: mats
                .iter()
                .any(|m| m.metallic > 0.0 || m.specular > 0.0 || m.clearcoat.factor > 0.0),
            environment_map: matches!(scene.environment, Some(Environment::Map { .. })),
            sky: matches!(scene.environment, Some(Environment::Sky { .. })),
            constant_environment: matches!(scene.environment, Some(Environment::Constant(_))),
            animated: scene.is_animated(),
            vertex_colors: scene.meshes.iter().any(|m| !m.colors.is_empty()),
            clearcoat: mats.iter().any(|m| m.clearcoat.factor > 0.0),
            backface_culling: scene.meshes.iter().any(|m| scene.mesh_culls_back_faces(m)),
            second_uv: scene.meshes.iter().any(|m| !m.uvs2.is_empty()),
            uv_affine: mats.iter().any(|m| m.uv_affine.iter().any(Option::is_some)),
        }
    }

    /// Every feature on: the "all-features" build used to measure what specialization saves.
    pub fn all() -> Self {
        SceneFeatures {
            textures: true,
            normal_maps: true,
            alpha_mask: true,
            transmission: true,
            emissive_triangles: true,
            punctual_lights: true,
            directional_lights: true,
            view_dependent: true,
            environment_map: true,
            sky: true,
            constant_environment: true,
            animated: true,
            vertex_colors: true,
            clearcoat: true,
            backface_culling: true,
            second_uv: true,
            uv_affine: true,
        }
    }
}
