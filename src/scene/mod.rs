//! CPU-side scene: meshes, instances, materials, textures, lights, cameras and
//! the environment, as imported from glTF 2.0 or produced by a generator.
//!
//! Conventions (DESIGN.md): right-handed, +Y up, metres, column vectors, cameras
//! look down −Z. Everything the GPU needs is derived from these types by
//! `crate::rt` and `crate::methods`; nothing here touches Vulkan.

pub mod alias;
pub mod animation;
mod content_hash;
pub mod default_lighting;
pub mod emitters;
pub mod env_distribution;
pub mod env_map;
pub mod environment;
pub mod error;
pub mod export;
pub mod features;
pub mod generate;
mod gltf_animation;
mod gltf_buffers;
pub mod gltf_features;
pub mod gltf_import;
mod gltf_instancing;
mod gltf_textures;
mod gltf_uv;
pub mod light;
pub mod load;
pub mod material;
pub mod mesh;
pub mod mesh_ops;
pub mod preetham;
pub mod texture;

pub use animation::{AnimationSelection, SceneAnimation};
pub(crate) use content_hash::fnv1a;
pub use default_lighting::{
    apply_default_lighting, decide_lighting, light_scene, relight, DefaultLighting,
    LightingDecision, OwnLighting,
};
pub use environment::{Environment, SkyModel};
pub use error::SceneError;
pub use export::write_gltf;
pub use features::SceneFeatures;
pub use generate::{generate, generate_to_dir};
pub use gltf_import::load_gltf;
pub use gltf_uv::{UvAffine, SLOT_COUNT};
pub use light::{Light, LightKind};
pub use load::load_scene;
pub use material::{AlphaMode, Clearcoat, Material, TextureRef, Volume};
pub use mesh::{Instance, Mesh};
pub use texture::{Filter, Texture, TextureEncoding, TextureSampler, Wrap};

use glam::{Mat4, Vec3};
use std::path::PathBuf;

/// A camera found in the scene (glTF `cameras` referenced by a node).
#[derive(Clone, Debug)]
pub struct SceneCamera {
    pub name: String,
    /// Camera-to-world transform (camera looks down −Z, +Y up).
    pub transform: Mat4,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Aspect ratio if the file declares one.
    pub aspect: Option<f32>,
    pub znear: f32,
    /// `(xmag, ymag)` of an orthographic camera (glTF
    /// `orthographic`); `None` for a perspective one (`yfov` then applies).
    pub orthographic: Option<glam::Vec2>,
}

/// A whole scene ready to be uploaded.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Where it came from (file path or `generated:<name>`), used in messages.
    pub source: PathBuf,
    /// One mesh per glTF primitive (a single material each).
    pub meshes: Vec<Mesh>,
    /// Mesh instances with their object-to-world transforms (node hierarchy flattened).
    pub instances: Vec<Instance>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    pub cameras: Vec<SceneCamera>,
    /// The environment seen by rays that leave the scene. `None` means black.
    pub environment: Option<Environment>,
    /// Non-fatal problems met while loading (also printed once by the CLI).
    pub warnings: Vec<String>,
    /// Node animation (glTF `animations`); `None` for a static scene.
    pub animation: Option<SceneAnimation>,
    /// Material graphs bound to materials (issue 17, src/materials/binding.rs);
    /// empty for most scenes, whose shaders are then the build-time ones.
    pub graphs: crate::materials::SceneGraphs,
}

/// How far from the origin, along any axis, a vertex may lie in world
/// space ([`Scene::check_placement`]).
pub const MAX_WORLD_COORDINATE: f32 = 1e15;

/// The brightest emission a scene may hold, per channel: a material's
/// emissive factor × strength, a punctual light's colour × intensity, an
/// environment map's texel. Beyond it (1e38 is finite in f32) a path's
/// throughput overflows to ∞ and the metrics become `null`; real scenes
/// stay many orders of magnitude below (the sun is ~1e9 W/(m²·sr)).
pub const MAX_EMISSION: f32 = 1e30;

impl Scene {
    /// Total number of triangles over all instances.
    /// Whether rays pass through the back faces of `mesh` (its material's
    /// `Material::culls_back_faces`; a dangling material index culls nothing).
    pub fn mesh_culls_back_faces(&self, mesh: &Mesh) -> bool {
        self.materials
            .get(mesh.material as usize)
            .is_some_and(|m| m.culls_back_faces())
    }

    pub fn instanced_triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh as usize].triangle_count())
            .sum()
    }

    /// World-space bounds over all instances (min, max). Empty scenes give (0, 0).
    pub fn world_bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for inst in &self.instances {
            for p in &self.meshes[inst.mesh as usize].positions {
                let w = inst.transform.transform_point3(*p);
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
        if lo.x > hi.x {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        }
    }

    /// Whether any instance moves under the selected animations.
    pub fn is_animated(&self) -> bool {
        self.animation
            .as_ref()
            .is_some_and(|a| a.instance_moves().iter().any(|&m| m))
    }

    /// Whether each instance moves under the selected animation (all false,
    /// or empty, for a static scene).
    pub fn instance_moves(&self) -> Vec<bool> {
        match &self.animation {
            Some(a) => a.instance_moves(),
            None => Vec::new(),
        }
    }

    /// Object-to-world transform of every instance at time `t` (seconds, the
    /// replay's frame time, kept in f64 until the animation loop wraps it:
    /// `animation.rs`); a static scene's are `instances[i].transform`.
    pub fn instance_transforms_at(&self, t: impl Into<f64>) -> Vec<Mat4> {
        let rest: Vec<Mat4> = self.instances.iter().map(|i| i.transform).collect();
        match &self.animation {
            Some(a) => a.instance_transforms(t.into(), &rest),
            None => rest,
        }
    }

    pub fn has_emissive_triangles(&self) -> bool {
        self.materials
            .iter()
            .any(|m| m.emissive.max_element() > 0.0)
    }

    pub fn camera(&self, name: &str) -> Option<&SceneCamera> {
        self.cameras.iter().find(|c| c.name == name)
    }

    /// Checks the cross references (mesh → material, material → texture,
    /// instance → mesh), that there is at least one triangle, that the rest
    /// pose keeps world coordinates finite and within ±1e15
    /// ([`Self::check_placement`]), and that a still scene has a triangle of
    /// non-zero area. Loaders and generators call this before returning a
    /// scene.
    pub fn validate(&self) -> Result<(), SceneError> {
        let src = self.source.clone();
        for (mi, m) in self.meshes.iter().enumerate() {
            if m.material as usize >= self.materials.len() {
                return Err(SceneError::invalid(
                    &src,
                    format!(
                        "mesh {mi} refers to material {} of {}",
                        m.material,
                        self.materials.len()
                    ),
                ));
            }
            if m.indices.len() % 3 != 0 {
                return Err(SceneError::invalid(
                    &src,
                    format!(
                        "mesh {mi} has {} indices, not a multiple of 3",
                        m.indices.len()
                    ),
                ));
            }
            let n = m.positions.len() as u32;
            if let Some(bad) = m.indices.iter().find(|&&i| i >= n) {
                return Err(SceneError::invalid(
                    &src,
                    format!("mesh {mi} index {bad} is out of range (vertex count {n})"),
                ));
            }
            if m.normals.len() != m.positions.len() || m.uvs.len() != m.positions.len() {
                return Err(SceneError::invalid(
                    &src,
                    format!("mesh {mi} attribute arrays differ in length"),
                ));
            }
            if !m.tangents.is_empty() && m.tangents.len() != m.positions.len() {
                return Err(SceneError::invalid(
                    &src,
                    format!("mesh {mi} tangent array has the wrong length"),
                ));
            }
        }
        for (ii, inst) in self.instances.iter().enumerate() {
            if inst.mesh as usize >= self.meshes.len() {
                return Err(SceneError::invalid(
                    &src,
                    format!(
                        "instance {ii} refers to mesh {} of {}",
                        inst.mesh,
                        self.meshes.len()
                    ),
                ));
            }
        }
        for (mi, m) in self.materials.iter().enumerate() {
            for t in m.texture_refs() {
                if t.texture as usize >= self.textures.len() {
                    return Err(SceneError::invalid(
                        &src,
                        format!(
                            "material {mi} refers to texture {} of {}",
                            t.texture,
                            self.textures.len()
                        ),
                    ));
                }
            }
        }
        for (mi, binds) in &self.graphs.materials {
            if *mi as usize >= self.materials.len()
                || binds.iter().any(|b| b.graph >= self.graphs.graphs.len())
            {
                return Err(SceneError::invalid(
                    &src,
                    format!("material graph binding of material {mi} is out of range"),
                ));
            }
        }
        if self.instanced_triangle_count() == 0 {
            return Err(SceneError::invalid(
                &src,
                "the scene has no triangles".to_string(),
            ));
        }
        let rest: Vec<Mat4> = self.instances.iter().map(|i| i.transform).collect();
        self.check_placement(&self.mesh_bounds(), &rest)
            .map_err(|m| SceneError::invalid(&src, m))?;
        // A triangle of zero area is never hit; a still scene of nothing
        // else renders nothing (the software BVHs leave such triangles
        // out). An animated one may scale its instances up from zero.
        let hittable = self.animation.is_some()
            || self.instances.iter().any(|inst| {
                let m = inst.transform.as_dmat4();
                let mesh = &self.meshes[inst.mesh as usize];
                (0..mesh.triangle_count()).any(|p| {
                    let [a, b, c] = mesh.triangle(p).map(|v| m.transform_point3(v.as_dvec3()));
                    (b - a).cross(c - a) != glam::DVec3::ZERO
                })
            });
        if !hittable {
            return Err(SceneError::invalid(
                &src,
                "every triangle has zero area in world space (a node scaled to zero?)".to_string(),
            ));
        }
        Ok(())
    }

    /// Each mesh's object-space box (min, max), `None` without vertices:
    /// what [`Self::check_placement`] transforms (a session keeps it).
    pub fn mesh_bounds(&self) -> Vec<Option<(Vec3, Vec3)>> {
        self.meshes
            .iter()
            .map(|mesh| {
                (!mesh.positions.is_empty()).then(|| {
                    mesh.positions
                        .iter()
                        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
                            (lo.min(p), hi.max(p))
                        })
                })
            })
            .collect()
    }

    /// Refuses instance transforms (`transforms[i]` for instance i, object
    /// to world) that are not finite or take an instance's bounds (its
    /// mesh's box, `boxes` from [`Self::mesh_bounds`]) farther than
    /// [`MAX_WORLD_COORDINATE`] from the origin along an axis: f32 ray
    /// tracing cannot resolve such a scene, and the BVH builders' surface
    /// areas would overflow. The message names the instance's node. Loaders
    /// check the rest pose ([`Self::validate`]); the replay checks every
    /// frame's pose of an animated scene before it renders.
    pub fn check_placement(
        &self,
        boxes: &[Option<(Vec3, Vec3)>],
        transforms: &[Mat4],
    ) -> Result<(), String> {
        for (ii, (inst, m)) in self.instances.iter().zip(transforms).enumerate() {
            let what = || format!("instance {ii} (node '{}')", inst.name);
            if !m.is_finite() {
                return Err(format!("{}: its world transform is not finite", what()));
            }
            let Some((lo, hi)) = boxes[inst.mesh as usize] else {
                continue;
            };
            let m = m.as_dmat4();
            for i in 0..8 {
                let c = Vec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
                let w = m.transform_point3(c.as_dvec3());
                let far = w.abs().max_element();
                if !w.is_finite() || far > MAX_WORLD_COORDINATE as f64 {
                    return Err(format!(
                        "{}: its bounds reach {far:.3e} from the origin; world coordinates must stay within ±{MAX_WORLD_COORDINATE:e} (a broken scale or translation?)",
                        what()
                    ));
                }
            }
        }
        Ok(())
    }
}

/// An instance's placement made invertible for the layouts that need its
/// inverse or forbid a singular one. A node scaled to zero along some axis
/// (a static file's flat node, an animated flip through 0) has a singular
/// linear part; its world triangles are still there (a cube flattened to a
/// square), and the flattened software layout hits them as they are. The
/// TLAS may not hold a singular matrix (VUID-VkTransformMatrixKHR-matrix-03799)
/// and the software two-level layout traces in object space through the
/// inverse (NaN: the instance was missed), so both take the linear part
/// plus ε·I, ε = 2^-22 of its largest entry (2^-22 when it is all zero):
/// the same world geometry to a few f32 ulps, a finite inverse, and a
/// normal matrix that gives the flattened mesh its plane's normal. The
/// sign of the result's determinant is arbitrary (diag(−1.5, 0, 1.5) gives
/// a negative one, a small positive y-scale a positive one), so every
/// layout takes a singular placement's mirror flag from this matrix (the
/// flattened BVH's cull sign, the instance record's front sign), and all
/// agree on which side of a flattened single-sided mesh is its front. An
/// invertible placement (det finite and non-zero, in f64) is returned as
/// it is.
pub fn regularized_placement(m: Mat4) -> Mat4 {
    let m3 = glam::DMat3::from_mat4(m.as_dmat4());
    let d = m3.determinant();
    if d.is_finite() && d != 0.0 {
        return m;
    }
    let big = [m3.x_axis, m3.y_axis, m3.z_axis]
        .iter()
        .map(|c| c.abs().max_element())
        .fold(0.0f64, f64::max);
    let scale = if big > 0.0 && big.is_finite() {
        big
    } else {
        1.0
    };
    let eps = scale * 2f64.powi(-22);
    let mut r = m3 + glam::DMat3::from_diagonal(glam::DVec3::splat(eps));
    // M + εI is singular only where M has the eigenvalue −ε: one more step.
    if r.determinant() == 0.0 {
        r = m3 + glam::DMat3::from_diagonal(glam::DVec3::splat(2.0 * eps));
    }
    let mut out = m;
    out.x_axis = r.x_axis.as_vec3().extend(0.0);
    out.y_axis = r.y_axis.as_vec3().extend(0.0);
    out.z_axis = r.z_axis.as_vec3().extend(0.0);
    out
}
