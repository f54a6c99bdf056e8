//! `SceneGpu`: the scene in GPU buffers (descriptor set 0 of every pipeline,
//! layout in shaders/common/scene.glsl), the ray-tracing structure of the
//! chosen backend, and the specialization constants the scene implies.

use super::origin::{relative_point, relative_transform, render_origin};
use super::{RtBackend, SoftwareBvh, TwoLevelBvh, TRAVERSAL_STACK_SIZE};
use crate::gpu::{
    accel::{AccelStructures, BlasInput, TlasInstance},
    BindingKind, Buffer, DescriptorLayout, DescriptorSet, GpuContext, GpuError, GpuResult,
    GpuTexture, Resource, Sampler, SpecConstants,
};
use crate::scene::emitters::Emitters;
use crate::scene::env_distribution::EnvDistribution;
use crate::scene::preetham::preetham_params;
use crate::scene::SLOT_COUNT;
use crate::scene::{
    AlphaMode, Environment, Filter, LightKind, Scene, SceneFeatures, SkyModel, TextureEncoding,
    TextureRef, TextureSampler, Wrap,
};
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Mat4, Vec3};
use std::sync::{Arc, Mutex};

/// Specialization constant ids (shaders/common/features.glsl), from the
/// shader interface (src/interface/scene.rs).
pub use crate::interface::scene::spec_id;

/// Descriptor-set-0 bindings of the light-sampling data (lights.glsl, sky.glsl)
/// and of the TLAS (rt_query.glsl, ray-query backend only); the numbers are
/// src/interface/scene.rs's.
pub mod binding {
    use crate::interface::scene::INTERFACE as SCENE;
    pub const EMITTERS: u32 = SCENE.binding("emitters");
    pub const ENV_DISTRIBUTION: u32 = SCENE.binding("env_distribution");
    pub const COLORS: u32 = SCENE.binding("colors");
    pub const UVS2: u32 = SCENE.binding("uvs2");
    pub const TLAS: u32 = SCENE.binding("tlas");
    pub const MEMO_KEYS: u32 = SCENE.binding("memo_keys");
    /// The sampled-image arrays: scene textures and the environment map.
    pub const TEXTURES: u32 = SCENE.binding("textures");
    pub const ENV_MAP: u32 = SCENE.binding("env_map");
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct VertexGpu {
    pos_u: [f32; 4],
    normal_v: [f32; 4],
    tangent: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct InstanceGpu {
    object_to_world: [f32; 16],
    normal_to_world: [f32; 16],
    mesh_pad: [u32; 4],
    /// `object_to_world` of the previous frame (motion vectors, appendix D;
    /// equal to it for a static scene and on a run's first frame).
    prev_object_to_world: [f32; 16],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct MaterialGpu {
    base_color: [f32; 4],
    emissive_metallic: [f32; 4],
    params: [f32; 4],
    tex0: [i32; 4],
    tex1: [i32; 4],
    extra: [f32; 4],
    /// KHR_materials_specular colour factor (rgb), unused.
    specular_color: [f32; 4],
    /// KHR_materials_clearcoat factor, roughness, normal scale; unused.
    coat: [f32; 4],
    /// KHR_materials_volume absorption σ_a (rgb, per world unit); 1 for a
    /// thin-walled transmissive surface (no volume), else 0.
    attenuation: [f32; 4],
    /// Clearcoat (R), clearcoat roughness (G), clearcoat normal, specular (A).
    tex2: [i32; 4],
    /// Specular colour (RGB); the slots reading the second uv channel (bit
    /// k = gltf_uv::SLOTS[k], `Material::second_uv_slots`); the slots that
    /// read their channel through a map (`Material::uv_affine`); unused.
    tex3: [i32; 4],
    /// Per slot k: rows 2k, 2k + 1 = (m00, m01, o0, 0), (m10, m11, o1, 0) of
    /// its map uv' = m · uv + o (`Material::uv_affine`; zeros where none).
    uv_affine: [[f32; 4]; 2 * SLOT_COUNT],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LightGpu {
    radiant_kind: [f32; 4],
    position_range: [f32; 4],
    direction: [f32; 4],
    cone: [f32; 4],
}

/// One emissive triangle for next-event estimation (lights.glsl `EmitterGpu`):
/// world vertices (render-origin relative), its alias-table entry, and
/// pdf_area = pick probability / area (the area-measure light pdf of its points).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct EmitterGpu {
    p0: [f32; 3],
    alias_prob: f32,
    p1: [f32; 3],
    alias: u32,
    p2: [f32; 3],
    pdf_area: f32,
    /// instance, primitive, unused, unused
    ids: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SceneParamsGpu {
    env_constant: [f32; 4],
    sun_dir: [f32; 4],
    zenith: [f32; 4],
    perez: [f32; 16],
    counts: [u32; 4],
}

/// `1 − cos r` of a sun disc of angular radius `r` (lights.glsl reads it
/// from `LightGpu.direction.w`; 0 = a delta light), as `2 sin²(r/2)` in
/// f64 (radii beyond π are the whole sphere; negative, zero or not finite:
/// a delta light; so is a disc under [`SMALLEST_SUN_DISC`], whose 1 − cos r
/// is far below any disc a ray could find, and whose 1/Ω squared in the
/// power heuristic overflows f32). Before
/// session 55 the shader got `cos r` in f32, whose rounding near 1 (a step
/// of 6·10⁻⁸) made the default sun's solid angle 0.21 % small, a 0.001 rad
/// disc's 4.6 % small, every disc from 2.4·10⁻⁴ to 4.2·10⁻⁴ rad that of a
/// 3.45·10⁻⁴ rad disc and any smaller one a delta light; and its cone
/// samples took only the ~181 values of cos θ that f32 has between cos r
/// and 1.
fn sun_one_minus_cos(r: f32) -> f32 {
    if !(r.is_finite() && r >= SMALLEST_SUN_DISC) {
        return 0.0;
    }
    let half = (r as f64).min(std::f64::consts::PI) / 2.0;
    (2.0 * half.sin().powi(2)) as f32
}

/// Angular radius (rad) below which a directional light is a delta light:
/// 1 − cos r = 5·10⁻²¹ there, far from f32's denormals (10⁻³⁸), and no ray
/// could find a disc of 10⁻¹⁰ rad.
const SMALLEST_SUN_DISC: f32 = 1e-10;

/// Environment kinds of `SC_ENV_KIND`.
fn env_kind(env: &Option<Environment>) -> u32 {
    match env {
        None => 0,
        Some(Environment::Constant(_)) => 1,
        Some(Environment::Sky { .. }) => 2,
        Some(Environment::Map { .. }) => 3,
    }
}

/// How the software backend holds the scene's triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BvhLayout {
    /// One CWBVH over every triangle in world space (`SoftwareBvh`): the
    /// fastest to trace, but moving an instance means rebuilding it all.
    Flattened,
    /// A CWBVH per mesh + one over the instances (`TwoLevelBvh`): a moved
    /// instance costs a rebuild of the small top level.
    TwoLevel,
}

impl BvhLayout {
    /// The automatic choice: two-level where an instance moves, flattened
    /// for static scenes (faster to trace, docs/PERFORMANCE.md "Two-level
    /// BVH", and bit-identical to the renderer before animation existed).
    pub fn auto(scene: &Scene) -> BvhLayout {
        if scene.is_animated() {
            BvhLayout::TwoLevel
        } else {
            BvhLayout::Flattened
        }
    }
}

impl std::str::FromStr for BvhLayout {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "flattened" => Ok(BvhLayout::Flattened),
            "two-level" => Ok(BvhLayout::TwoLevel),
            other => Err(format!(
                "unknown BVH layout '{other}' (expected flattened or two-level)"
            )),
        }
    }
}

pub struct SceneGpu {
    pub backend: RtBackend,
    /// The software structure (meaningful with `RtBackend::Software`).
    pub bvh_layout: BvhLayout,
    /// The render origin GPU positions are relative to (rt/origin.rs).
    pub origin: DVec3,
    pub features: SceneFeatures,
    pub layout: Arc<DescriptorLayout>,
    pub set: DescriptorSet,
    pub triangle_count: usize,
    /// Bytes of GPU memory the scene occupies (buffers, textures, BVH/AS).
    pub bytes: u64,
    /// Shaders rebuilt at load with the scene's material graphs
    /// (src/materials/scene_shaders.rs); `None`: the build-time SPIR-V.
    pub shaders: Option<Arc<dyn crate::gpu::shaders::ShaderOverride>>,
    /// The memoization table of the scene's graphs (`--memo …`), bound in
    /// set 0 after the TLAS slot; `None`: not memoized (the set as before).
    pub memo: Option<super::MemoGpu>,
    /// The memo's tiled fill is the subgroup-cooperative one (memo.glsl
    /// `MemoRound`); false: the plain fill, or no tiles.
    pub cooperative_fill: bool,
    texture_count: u32,
    /// The two-level structure, kept to rebuild its top level when instances move.
    /// (Behind a lock: methods share the scene through an `Arc`.)
    two_level: Mutex<Option<TwoLevelBvh>>,
    /// The instance transforms last uploaded (object-to-world, not origin
    /// relative): the scene's at rest until the first `set_instance_motion`.
    posed: Mutex<Vec<Mat4>>,
    /// Per instance, `InstanceGpu::mesh_pad` (mesh, 1 + first emitter,
    /// 1 where its material culls back faces); `instance_records` adds w,
    /// 1 where the instance's transform mirrors.
    instance_ids: Vec<[u32; 4]>,
    /// The emissive triangles as last uploaded (render-origin relative),
    /// moved with their instances by `set_instance_motion`.
    emitters: Mutex<Emitters>,
    _buffers: Vec<Buffer>,
    _textures: Vec<GpuTexture>,
    _samplers: Vec<Sampler>,
    _accel: Mutex<Option<AccelStructures>>,
}

impl SceneGpu {
    /// Uploads with the automatic software layout (`BvhLayout::auto`).
    pub fn upload(ctx: &Arc<GpuContext>, scene: &Scene, backend: RtBackend) -> GpuResult<SceneGpu> {
        Self::upload_with(ctx, scene, backend, BvhLayout::auto(scene))
    }

    pub fn upload_with(
        ctx: &Arc<GpuContext>,
        scene: &Scene,
        backend: RtBackend,
        bvh_layout: BvhLayout,
    ) -> GpuResult<SceneGpu> {
        let before = ctx.allocated_bytes();
        let features = SceneFeatures::of(scene);
        // Geometry.
        let mut vertices = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut meshes = Vec::new();
        for m in &scene.meshes {
            let vertex_offset = vertices.len() as u32;
            let index_offset = indices.len() as u32;
            for i in 0..m.positions.len() {
                let p = m.positions[i];
                let n = m.normals[i];
                let uv = m.uvs[i];
                let t = m.tangents.get(i).copied().unwrap_or_default();
                vertices.push(VertexGpu {
                    pos_u: [p.x, p.y, p.z, uv.x],
                    normal_v: [n.x, n.y, n.z, uv.y],
                    tangent: t.to_array(),
                });
            }
            indices.extend_from_slice(&m.indices);
            meshes.push([
                vertex_offset,
                index_offset,
                m.material,
                m.triangle_count() as u32,
            ]);
        }
        // Positions relative to the render origin (rt/origin.rs): instance
        // transforms, lights and the eyes (FrameParams) are rebased in f64.
        let origin = render_origin(scene);
        // Emissive triangles in the same (render-origin relative) frame.
        let emitters = Emitters::of(scene, |k| {
            relative_transform(scene.instances[k].transform, origin)
        });
        // .y: 1 + index of the instance's first emitter triangle (0 = none),
        // the MIS lookup of a BSDF-sampled emitter hit (lights.glsl).
        let instance_ids: Vec<[u32; 4]> = scene
            .instances
            .iter()
            .zip(&emitters.first)
            .map(|(i, first)| {
                let culls = scene.mesh_culls_back_faces(&scene.meshes[i.mesh as usize]);
                [i.mesh, first.map_or(0, |f| f + 1), culls as u32, 0]
            })
            .collect();
        let rest: Vec<Mat4> = scene.instances.iter().map(|i| i.transform).collect();
        let instances = instance_records(&rest, &rest, &instance_ids, origin);
        let emitter_bytes = emitter_buffer(&emitters);

        // Textures (descriptor array at binding 10; a 1×1 white stand-in when there are none).
        // The scene's textures, then the material graphs' image files
        // (SceneGraphs::images: texture scene.textures.len() + k).
        let mut textures = Vec::new();
        let graph_images = scene.graphs.images().map(|im| &*im.texture);
        for (ti, t) in scene.textures.iter().chain(graph_images).enumerate() {
            let format = match t.encoding {
                TextureEncoding::Srgb => vk::Format::R8G8B8A8_SRGB,
                TextureEncoding::Linear => vk::Format::R8G8B8A8_UNORM,
            };
            let levels: Vec<&[u8]> = t.mips.iter().map(|m| m.as_slice()).collect();
            textures.push(GpuTexture::new(
                ctx,
                &format!("texture{ti}:{}", t.name),
                format,
                t.width,
                t.height,
                &levels,
            )?);
        }
        if textures.is_empty() {
            textures.push(GpuTexture::new(
                ctx,
                "texture.white",
                vk::Format::R8G8B8A8_UNORM,
                1,
                1,
                &[&[255, 255, 255, 255]],
            )?);
        }
        let slots = TextureSlots::of(scene);
        let texture_count = slots.pairs.len().max(1) as u32;

        let materials: Vec<MaterialGpu> = scene
            .materials
            .iter()
            .map(|m| {
                let t = |r: Option<TextureRef>| r.map(|r| slots.slot(r) as i32).unwrap_or(-1);
                MaterialGpu {
                    base_color: m.base_color.to_array(),
                    emissive_metallic: [m.emissive.x, m.emissive.y, m.emissive.z, m.metallic],
                    params: [m.roughness, m.transmission, m.ior, m.alpha_cutoff],
                    tex0: [
                        t(m.base_color_texture),
                        t(m.metallic_roughness_texture),
                        t(m.normal_texture),
                        t(m.emissive_texture),
                    ],
                    tex1: [
                        t(m.transmission_texture),
                        // scene.glsl ALPHA_OPAQUE / ALPHA_MASK / ALPHA_BLEND
                        match m.alpha_mode {
                            AlphaMode::Opaque => 0,
                            AlphaMode::Mask => 1,
                            AlphaMode::Blend => 2,
                        },
                        m.double_sided as i32,
                        // KHR_materials_unlit: emission × COLOR_0 (material.glsl).
                        m.unlit as i32,
                    ],
                    // z: 1 where back faces are culled (Material::culls_back_faces:
                    // single-sided and no volume boundary), as the BVH's
                    // per-triangle sign and the instances' cull flags say.
                    extra: [
                        m.normal_scale,
                        m.specular,
                        if m.culls_back_faces() { 1.0 } else { 0.0 },
                        0.0,
                    ],
                    specular_color: m.specular_color.extend(0.0).to_array(),
                    coat: [
                        m.clearcoat.factor,
                        m.clearcoat.roughness,
                        m.clearcoat.normal_scale,
                        0.0,
                    ],
                    attenuation: m
                        .volume
                        .map_or(Vec3::ZERO, |v| v.sigma_a())
                        .extend(m.is_thin_walled() as i32 as f32)
                        .to_array(),
                    tex2: [
                        t(m.clearcoat.texture),
                        t(m.clearcoat.roughness_texture),
                        t(m.clearcoat.normal_texture),
                        t(m.specular_texture),
                    ],
                    tex3: [
                        t(m.specular_color_texture),
                        m.second_uv_slots as i32,
                        m.uv_affine
                            .iter()
                            .enumerate()
                            .filter(|(_, a)| a.is_some())
                            .fold(0, |bits, (k, _)| bits | 1 << k),
                        -1,
                    ],
                    uv_affine: std::array::from_fn(|row| {
                        let a = m.uv_affine[row / 2];
                        a.map_or([0.0; 4], |a| {
                            // Row r of the matrix: (col0[r], col1[r]).
                            let r = row % 2;
                            [a.linear.x_axis[r], a.linear.y_axis[r], a.offset[r], 0.0]
                        })
                    }),
                }
            })
            .collect();

        let lights: Vec<LightGpu> = scene
            .lights
            .iter()
            .map(|l| {
                let (kind, one_minus_cos, cone) = match l.kind {
                    LightKind::Point => (0.0, 0.0, [1.0, 0.0]),
                    LightKind::Spot {
                        inner_cone,
                        outer_cone,
                    } => (1.0, 0.0, [inner_cone.cos(), outer_cone.cos()]),
                    LightKind::Directional { angular_radius } => {
                        (2.0, sun_one_minus_cos(angular_radius), [1.0, 0.0])
                    }
                };
                let d = l.direction.normalize_or(Vec3::NEG_Y);
                let p = relative_point(l.position, origin);
                LightGpu {
                    radiant_kind: [l.radiant.x, l.radiant.y, l.radiant.z, kind],
                    position_range: [p.x, p.y, p.z, l.range.unwrap_or(0.0)],
                    direction: [d.x, d.y, d.z, one_minus_cos],
                    cone: [cone[0], cone[1], 0.0, 0.0],
                }
            })
            .collect();

        let mut params = SceneParamsGpu::zeroed();
        params.counts = [lights.len() as u32, 0, 0, instances.len() as u32];
        let mut env_texture = None;
        let mut env_dist = None;
        match &scene.environment {
            Some(Environment::Constant(c)) => params.env_constant = [c.x, c.y, c.z, 1.0],
            Some(Environment::Sky {
                model: SkyModel::Preetham { turbidity },
                sun_direction,
                scale,
            }) => {
                let p = preetham_params(*turbidity, *sun_direction);
                params.env_constant = [0.0, 0.0, 0.0, *scale];
                params.sun_dir = [
                    p.sun_direction.x,
                    p.sun_direction.y,
                    p.sun_direction.z,
                    p.sun_theta,
                ];
                params.zenith = [p.zenith[0], p.zenith[1], p.zenith[2], 0.0];
                for (c, row) in p.perez.iter().enumerate() {
                    params.perez[c * 5..c * 5 + 5].copy_from_slice(row);
                }
            }
            Some(Environment::Map {
                name,
                width,
                height,
                texels,
                scale,
            }) => {
                params.env_constant = [0.0, 0.0, 0.0, *scale];
                params.counts[1] = *width;
                params.counts[2] = *height;
                // Sampled through a LINEAR sampler (sky.glsl), which the
                // importance sampling's cell weights assume; linear
                // filtering of RGBA32F is optional in Vulkan.
                if !ctx.can_filter_linear(vk::Format::R32G32B32A32_SFLOAT) {
                    return Err(GpuError::Unsupported(format!(
                        "device '{}' cannot filter 32-bit float images linearly, which the environment map {name} needs",
                        ctx.caps.name
                    )));
                }
                env_dist = EnvDistribution::new(*width, *height, texels);
                let data: Vec<f32> = texels
                    .iter()
                    .flat_map(|t| [t[0], t[1], t[2], 1.0])
                    .collect();
                env_texture = Some(GpuTexture::new(
                    ctx,
                    &format!("environment:{name}"),
                    vk::Format::R32G32B32A32_SFLOAT,
                    *width,
                    *height,
                    &[bytemuck::cast_slice(&data)],
                )?);
            }
            None => {}
        }
        let env_texture = match env_texture {
            Some(t) => t,
            None => GpuTexture::new(
                ctx,
                "environment.none",
                vk::Format::R32G32B32A32_SFLOAT,
                1,
                1,
                &[bytemuck::cast_slice(&[0f32; 4])],
            )?,
        };

        let none = vk::BufferUsageFlags::empty();
        let b_vertices =
            Buffer::with_data(ctx, "scene.vertices", bytemuck::cast_slice(&vertices), none)?;
        let b_indices =
            Buffer::with_data(ctx, "scene.indices", bytemuck::cast_slice(&indices), none)?;
        let b_meshes = Buffer::with_data(ctx, "scene.meshes", bytemuck::cast_slice(&meshes), none)?;
        let b_instances = Buffer::with_data(
            ctx,
            "scene.instances",
            bytemuck::cast_slice(&instances),
            none,
        )?;
        let b_materials = Buffer::with_data(
            ctx,
            "scene.materials",
            bytemuck::cast_slice(&materials),
            none,
        )?;
        let b_lights = Buffer::with_data(ctx, "scene.lights", bytemuck::cast_slice(&lights), none)?;
        let b_params = Buffer::with_data(ctx, "scene.params", bytemuck::bytes_of(&params), none)?;
        let b_emitters = Buffer::with_data(ctx, "scene.emitters", &emitter_bytes, none)?;
        let b_env_dist = Buffer::with_data(
            ctx,
            "scene.env_distribution",
            &env_distribution_buffer(env_dist.as_ref()),
            none,
        )?;
        // Vertex colours parallel to `vertices` (white for meshes without),
        // or one white stand-in when no mesh has any (never read then).
        let colors: Vec<[f32; 4]> = if features.vertex_colors {
            scene
                .meshes
                .iter()
                .flat_map(|m| {
                    (0..m.positions.len()).map(|i| {
                        m.colors
                            .get(i)
                            .copied()
                            .unwrap_or(glam::Vec4::ONE)
                            .to_array()
                    })
                })
                .collect()
        } else {
            vec![[1.0; 4]]
        };
        let b_colors = Buffer::with_data(ctx, "scene.colors", bytemuck::cast_slice(&colors), none)?;
        // The second uv channel parallel to `vertices` (zeros for meshes
        // without), or one stand-in when no mesh has one (never read then).
        let uvs2: Vec<[f32; 2]> = if features.second_uv {
            scene
                .meshes
                .iter()
                .flat_map(|m| {
                    (0..m.positions.len())
                        .map(|i| m.uvs2.get(i).copied().unwrap_or_default().to_array())
                })
                .collect()
        } else {
            vec![[0.0; 2]]
        };
        let b_uvs2 = Buffer::with_data(ctx, "scene.uvs2", bytemuck::cast_slice(&uvs2), none)?;

        // Ray-tracing structure of the backend; the other backend's bindings get 16-byte stand-ins.
        let mut two_level = None;
        let (b_nodes, b_ref, b_verts, accel) = match backend {
            RtBackend::Software if bvh_layout == BvhLayout::TwoLevel => {
                let bvh = TwoLevelBvh::build_at(scene, origin);
                if bvh.max_depth >= TRAVERSAL_STACK_SIZE {
                    return Err(GpuError::Unsupported(format!(
                        "the two-level BVH of {} needs {} stack levels (TLAS + BLAS); the GLSL \
                         traversal stack holds {TRAVERSAL_STACK_SIZE}",
                        scene.source.display(),
                        bvh.max_depth
                    )));
                }
                let bufs = (
                    Buffer::with_data(ctx, "bvh.nodes", bytemuck::cast_slice(&bvh.nodes), none)?,
                    Buffer::with_data(
                        ctx,
                        "bvh.tri_ref",
                        bytemuck::cast_slice(&bvh.tri_ref),
                        none,
                    )?,
                    Buffer::with_data(
                        ctx,
                        "bvh.tri_verts",
                        bytemuck::cast_slice(&bvh.tri_verts),
                        none,
                    )?,
                    None,
                );
                two_level = Some(bvh);
                bufs
            }
            RtBackend::Software => {
                let bvh = SoftwareBvh::build_at(scene, origin);
                if bvh.nodes().is_empty() {
                    return Err(GpuError::Unsupported(format!(
                        "{}: every triangle has zero area at the precision of the render's coordinates",
                        scene.source.display()
                    )));
                }
                if bvh.max_depth >= TRAVERSAL_STACK_SIZE {
                    return Err(GpuError::Unsupported(format!(
                        "the software BVH of {} is {} levels deep; the GLSL traversal stack holds {TRAVERSAL_STACK_SIZE}",
                        scene.source.display(),
                        bvh.max_depth
                    )));
                }
                (
                    Buffer::with_data(ctx, "bvh.nodes", bytemuck::cast_slice(bvh.nodes()), none)?,
                    Buffer::with_data(
                        ctx,
                        "bvh.tri_ref",
                        bytemuck::cast_slice(&bvh.tri_ref),
                        none,
                    )?,
                    Buffer::with_data(
                        ctx,
                        "bvh.tri_verts",
                        bytemuck::cast_slice(&bvh.tri_verts),
                        none,
                    )?,
                    None,
                )
            }
            RtBackend::Query => {
                let positions: Vec<Vec<[f32; 3]>> = scene
                    .meshes
                    .iter()
                    .map(|m| m.positions.iter().map(|p| p.to_array()).collect())
                    .collect();
                let inputs: Vec<BlasInput> = scene
                    .meshes
                    .iter()
                    .zip(&positions)
                    .map(|(m, pos)| BlasInput {
                        positions: pos,
                        indices: &m.indices,
                        opaque: scene.materials[m.material as usize].alpha_mode
                            == AlphaMode::Opaque,
                    })
                    .collect();
                let tlas_instances = tlas_instances(&rest, &instance_ids, origin);
                let accel = AccelStructures::build(ctx, &inputs, &tlas_instances)?;
                (
                    Buffer::storage(ctx, "bvh.nodes.unused", 16)?,
                    Buffer::storage(ctx, "bvh.tri_ref.unused", 16)?,
                    Buffer::storage(ctx, "bvh.tri_verts.unused", 16)?,
                    Some(accel),
                )
            }
        };

        // The memoization table (only for a scene with graphs and --memo on):
        // its four buffers follow the TLAS slot, which the software backend
        // then fills with a stand-in.
        let memo = if scene.graphs.memo.enabled() && !scene.graphs.is_empty() {
            Some(super::MemoGpu::new(ctx, &scene.graphs.memo)?)
        } else {
            None
        };
        let tlas_stand_in = match (&memo, backend) {
            (Some(_), RtBackend::Software) => Some(Buffer::storage(ctx, "tlas.unused", 16)?),
            _ => None,
        };
        let mut kinds = vec![BindingKind::StorageBuffer; binding::TEXTURES as usize];
        debug_assert_eq!(kinds.len(), binding::TEXTURES as usize);
        kinds.push(BindingKind::SampledImages(texture_count));
        debug_assert_eq!(kinds.len(), binding::ENV_MAP as usize);
        kinds.push(BindingKind::SampledImages(1));
        kinds.push(BindingKind::StorageBuffer); // binding::EMITTERS
        kinds.push(BindingKind::StorageBuffer); // binding::ENV_DISTRIBUTION
        kinds.push(BindingKind::StorageBuffer); // binding::COLORS
        kinds.push(BindingKind::StorageBuffer); // binding::UVS2
        debug_assert_eq!(kinds.len(), binding::TLAS as usize);
        if backend == RtBackend::Query {
            kinds.push(BindingKind::AccelerationStructure);
        } else if tlas_stand_in.is_some() {
            kinds.push(BindingKind::StorageBuffer);
        }
        if memo.is_some() {
            debug_assert_eq!(kinds.len(), binding::MEMO_KEYS as usize);
            kinds.extend([BindingKind::StorageBuffer; 4]);
        }
        let layout = DescriptorLayout::new(ctx, &kinds)?;
        // One Vulkan sampler per distinct setting; slot k reads image
        // `pairs[k].0` through the sampler of `pairs[k].1`.
        let mut samplers: Vec<Sampler> = Vec::new();
        let mut sampler_of: Vec<usize> = Vec::new();
        let mut distinct: Vec<TextureSampler> = Vec::new();
        let defaults = [(0, TextureSampler::default())];
        let pairs = if slots.pairs.is_empty() {
            &defaults[..]
        } else {
            &slots.pairs[..]
        };
        for (_, s) in pairs {
            let k = match distinct.iter().position(|d| d == s) {
                Some(k) => k,
                None => {
                    samplers.push(Sampler::from_info(ctx, &sampler_info(s))?);
                    distinct.push(*s);
                    samplers.len() - 1
                }
            };
            sampler_of.push(k);
        }
        let env_sampler = Sampler::new(ctx, false)?;
        let slot_images: Vec<(&GpuTexture, &Sampler)> = pairs
            .iter()
            .zip(&sampler_of)
            .map(|(&(t, _), &k)| (&textures[t as usize], &samplers[k]))
            .collect();
        let mut resources = vec![
            Resource::Buffer(&b_vertices),
            Resource::Buffer(&b_indices),
            Resource::Buffer(&b_meshes),
            Resource::Buffer(&b_instances),
            Resource::Buffer(&b_materials),
            Resource::Buffer(&b_lights),
            Resource::Buffer(&b_params),
            Resource::Buffer(&b_nodes),
            Resource::Buffer(&b_ref),
            Resource::Buffer(&b_verts),
            Resource::Images(slot_images),
            Resource::Images(vec![(&env_texture, &env_sampler)]),
            Resource::Buffer(&b_emitters),
            Resource::Buffer(&b_env_dist),
            Resource::Buffer(&b_colors),
            Resource::Buffer(&b_uvs2),
        ];
        if let Some(a) = &accel {
            resources.push(Resource::Accel(a.tlas()));
        } else if let Some(b) = &tlas_stand_in {
            resources.push(Resource::Buffer(b));
        }
        if let Some(m) = &memo {
            for b in [&m.keys, &m.stamps, &m.values, &m.state] {
                resources.push(Resource::Buffer(b));
            }
        }
        let mut set = DescriptorSet::new(ctx, &layout, &resources)?;
        drop(resources);
        if let Some(m) = &memo {
            set.written = [&m.keys, &m.stamps, &m.values, &m.state]
                .iter()
                .map(|b| b.raw)
                .collect();
        }
        // The subgroup-cooperative tile fill: tiled tables, asked for, and
        // a device with subgroup ballot and shuffle (else the plain fill).
        let m = &scene.graphs.memo;
        let cooperative_fill = memo.is_some()
            && m.tile > 1
            && m.fill == crate::materials::memo::MemoFill::Subgroup
            && ctx.caps.has_subgroup_ops(&["ballot", "shuffle"]);
        let mut all_textures = textures;
        all_textures.push(env_texture);
        let bytes = ctx.allocated_bytes().saturating_sub(before);
        Ok(SceneGpu {
            backend,
            bvh_layout,
            origin,
            features,
            layout,
            set,
            triangle_count: scene.instanced_triangle_count(),
            bytes,
            shaders: crate::materials::scene_shaders::for_scene(
                &scene.graphs,
                origin,
                memo.as_ref()
                    .map(|_| crate::materials::scene_shaders::MemoBuild {
                        cooperative: cooperative_fill,
                        counter_clock: m.clock == crate::materials::memo::MemoClock::Counter,
                    }),
                &slots.graph_image_slots(scene),
            ),
            memo,
            cooperative_fill,
            texture_count,
            two_level: Mutex::new(two_level),
            posed: Mutex::new(rest),
            instance_ids,
            emitters: Mutex::new(emitters),
            _buffers: vec![
                b_vertices,
                b_indices,
                b_meshes,
                b_instances,
                b_materials,
                b_lights,
                b_params,
                b_nodes,
                b_ref,
                b_verts,
                b_emitters,
                b_env_dist,
                b_colors,
                b_uvs2,
            ]
            .into_iter()
            .chain(tlas_stand_in)
            .collect(),
            _textures: all_textures,
            _samplers: {
                samplers.push(env_sampler);
                samplers
            },
            _accel: Mutex::new(accel),
        })
    }

    /// Specialization constants for this scene: only the features it uses are compiled in.
    /// `all_features` turns everything on (the unspecialized comparison build).
    pub fn spec_constants(
        &self,
        env: &Option<Environment>,
        max_bounces: u32,
        all_features: bool,
    ) -> SpecConstants {
        let f = if all_features {
            SceneFeatures::all()
        } else {
            self.features
        };
        let mut s = SpecConstants::default();
        s.flag(spec_id::TEXTURES, f.textures)
            .flag(spec_id::NORMAL_MAPS, f.normal_maps)
            .flag(spec_id::ALPHA_MASK, f.alpha_mask)
            .flag(spec_id::TRANSMISSION, f.transmission)
            .flag(spec_id::EMISSIVE, f.emissive_triangles)
            .flag(spec_id::PUNCTUAL, f.punctual_lights)
            .flag(spec_id::DIRECTIONAL, f.directional_lights)
            .flag(spec_id::VIEW_DEPENDENT, f.view_dependent)
            .set(spec_id::ENV_KIND, env_kind(env))
            .set(spec_id::MAX_BOUNCES, max_bounces)
            .set(spec_id::TEXTURE_COUNT, self.texture_count)
            .flag(
                spec_id::TWO_LEVEL,
                self.bvh_layout_in_use() == Some(BvhLayout::TwoLevel),
            )
            .flag(spec_id::ANIMATED, f.animated)
            .flag(spec_id::VERTEX_COLORS, f.vertex_colors)
            .flag(spec_id::CLEARCOAT, f.clearcoat)
            .flag(spec_id::BACKFACE_CULLING, f.backface_culling)
            .flag(spec_id::SECOND_UV, f.second_uv)
            .flag(spec_id::UV_AFFINE, f.uv_affine);
        s
    }

    /// Elements of the scene's texture array (`SC_TEXTURE_COUNT`): one per
    /// (texture, sampler) pair the materials use, at least one per texture
    /// ([`TextureSlots`]).
    pub fn texture_slots(&self) -> u32 {
        self.texture_count
    }

    /// Vulkan samplers the texture array uses (one per distinct sampler
    /// setting; the environment map's own sampler not counted).
    pub fn texture_sampler_count(&self) -> usize {
        self._samplers.len() - 1
    }

    /// The software layout the pipelines are compiled for (None: ray queries).
    pub fn bvh_layout_in_use(&self) -> Option<BvhLayout> {
        (self.backend == RtBackend::Software).then_some(self.bvh_layout)
    }

    /// Moves the instances to `transforms` (object-to-world, one per
    /// instance, e.g. `Scene::instance_transforms_at`): the instance buffer is
    /// rewritten and the top level of the ray-tracing structure rebuilt,
    /// the BLAS untouched — ray queries: the TLAS on the device, in place;
    /// software two-level: the TLAS on the CPU, then the front of the BVH
    /// buffers uploaded. The flattened BVH cannot move instances (an error).
    /// Emissive triangles on instances that moved are moved with them
    /// (their light samples: world vertices, areas, the pick-by-power table).
    /// Call between frames (it submits and waits). The previous-frame
    /// transforms become `transforms` too (no motion); a frame loop uses
    /// [`Self::set_instance_motion`].
    pub fn set_instance_transforms(&self, transforms: &[Mat4]) -> GpuResult<()> {
        self.set_instance_motion(transforms, transforms)
    }

    /// The instance transforms last uploaded (object-to-world).
    pub fn posed_transforms(&self) -> Vec<Mat4> {
        self.posed.lock().expect("pose lock").clone()
    }

    /// As [`Self::set_instance_transforms`] for one frame of a frame loop:
    /// the instances move to `transforms` and `prev` (the previous frame's,
    /// `InstanceInfo.prev_object_to_world`) is uploaded beside them for the
    /// motion vectors (TAA, shaders/taa/resolve.comp).
    pub fn set_instance_motion(&self, prev: &[Mat4], transforms: &[Mat4]) -> GpuResult<()> {
        if transforms.len() != self.instance_ids.len() || prev.len() != transforms.len() {
            return Err(GpuError::Unsupported(format!(
                "{} instance transforms for {} instances",
                transforms.len(),
                self.instance_ids.len()
            )));
        }
        self.pose_emitters(transforms)?;
        if let Some(accel) = self._accel.lock().expect("accel lock").as_mut() {
            accel.rebuild_tlas(&tlas_instances(transforms, &self.instance_ids, self.origin))?;
            let records = instance_records(transforms, prev, &self.instance_ids, self.origin);
            *self.posed.lock().expect("pose lock") = transforms.to_vec();
            return self._buffers[BUF_INSTANCES].upload(bytemuck::cast_slice(&records));
        }
        let mut two_level = self.two_level.lock().expect("BVH lock");
        let Some(bvh) = two_level.as_mut() else {
            return Err(GpuError::Unsupported(
                "the flattened software BVH cannot move instances; upload with BvhLayout::TwoLevel"
                    .into(),
            ));
        };
        bvh.rebuild_tlas(transforms);
        if bvh.max_depth >= TRAVERSAL_STACK_SIZE {
            return Err(GpuError::Unsupported(format!(
                "the moved two-level BVH needs {} stack levels; the GLSL traversal stack holds \
                 {TRAVERSAL_STACK_SIZE}",
                bvh.max_depth
            )));
        }
        let (nodes, refs, verts) = bvh.tlas_bytes();
        self._buffers[BUF_NODES].upload(nodes)?;
        self._buffers[BUF_TRI_REF].upload(refs)?;
        self._buffers[BUF_TRI_VERTS].upload(verts)?;
        let records = instance_records(transforms, prev, &self.instance_ids, self.origin);
        *self.posed.lock().expect("pose lock") = transforms.to_vec();
        self._buffers[BUF_INSTANCES].upload(bytemuck::cast_slice(&records))
    }
}

impl SceneGpu {
    /// Moves the emissive triangles whose instance's transform differs from
    /// the one last uploaded to `transforms` and re-uploads the emitter
    /// buffer (NEE samples and the MIS pdf read world vertices, lights.glsl);
    /// nothing when no emitter moved.
    fn pose_emitters(&self, transforms: &[Mat4]) -> GpuResult<()> {
        let posed = self.posed.lock().expect("pose lock");
        let mut emitters = self.emitters.lock().expect("emitter lock");
        let moved = emitters
            .first
            .iter()
            .enumerate()
            .any(|(k, f)| f.is_some() && transforms[k] != posed[k]);
        if !moved {
            return Ok(());
        }
        let origin = self.origin;
        emitters.pose(|k| relative_transform(transforms[k], origin));
        self._buffers[BUF_EMITTERS].upload(&emitter_buffer(&emitters))
    }
}

/// The TLAS instances (custom index = instance, BLAS = its mesh) for
/// transforms rebased on `origin`.
fn tlas_instances(transforms: &[Mat4], ids: &[[u32; 4]], origin: DVec3) -> Vec<TlasInstance> {
    transforms
        .iter()
        .zip(ids)
        .enumerate()
        .map(|(i, (t, id))| TlasInstance {
            // A singular placement may not enter a TLAS
            // (VUID-VkTransformMatrixKHR-matrix-03799): made invertible
            // (scene::regularized_placement), the same world triangles.
            transform: row_major_3x4(relative_transform(
                crate::scene::regularized_placement(*t),
                origin,
            )),
            custom_index: i as u32,
            blas: id[0] as usize,
            cull_back_faces: id[2] != 0,
        })
        .collect()
}

/// The elements of the scene's texture array: slot i < `scene.textures.len()`
/// is texture i read with the sampler of its first reference (the default
/// sampler when no material uses it), then one slot per further (texture,
/// sampler) pair in the order the materials first use them. A scene whose
/// texture references all use the default sampler therefore binds exactly
/// one slot per texture, slot i = texture i, as before samplers were read;
/// an image read with two samplers is uploaded once and bound twice.
pub struct TextureSlots {
    /// (texture, sampler) per slot.
    pub pairs: Vec<(u32, TextureSampler)>,
}

impl TextureSlots {
    pub fn of(scene: &Scene) -> TextureSlots {
        let graph_refs: Vec<TextureRef> = scene
            .graphs
            .image_refs(scene.textures.len() as u32)
            .into_iter()
            .flatten()
            .collect();
        let refs = || {
            scene
                .materials
                .iter()
                .flat_map(|m| m.texture_refs())
                .chain(graph_refs.iter().copied())
        };
        let count = scene.textures.len() + graph_refs.len();
        let mut first: Vec<Option<TextureSampler>> = vec![None; count];
        for r in refs() {
            if let Some(f) = first.get_mut(r.texture as usize) {
                f.get_or_insert(r.sampler);
            }
        }
        let mut pairs: Vec<(u32, TextureSampler)> = first
            .iter()
            .enumerate()
            .map(|(i, s)| (i as u32, s.unwrap_or_default()))
            .collect();
        for r in refs() {
            if !pairs.contains(&(r.texture, r.sampler)) {
                pairs.push((r.texture, r.sampler));
            }
        }
        TextureSlots { pairs }
    }

    /// The slot of each material graph's images (`SceneGraphs::image_refs`), per graph.
    pub fn graph_image_slots(&self, scene: &Scene) -> Vec<Vec<u32>> {
        scene
            .graphs
            .image_refs(scene.textures.len() as u32)
            .into_iter()
            .map(|g| g.into_iter().map(|r| self.slot(r)).collect())
            .collect()
    }

    /// The slot of a texture reference (one `of` made it).
    pub fn slot(&self, r: TextureRef) -> u32 {
        self.pairs
            .iter()
            .position(|&p| p == (r.texture, r.sampler))
            .unwrap_or(r.texture as usize) as u32
    }
}

/// The Vulkan sampler of a glTF sampler. Not mipmapped (`mipmap: None`,
/// glTF minFilter NEAREST/LINEAR): level 0 only, with the minification
/// filter still chosen over the magnification one when minified — the
/// setting VkSamplerCreateInfo's specification gives for OpenGL's
/// non-mipmapped filters (mipmapMode NEAREST, minLod 0, maxLod 0.25).
/// The default sampler gives exactly `Sampler::new(ctx, true)`'s settings.
pub fn sampler_info(s: &TextureSampler) -> vk::SamplerCreateInfo<'static> {
    let filter = |f: Filter| match f {
        Filter::Nearest => vk::Filter::NEAREST,
        Filter::Linear => vk::Filter::LINEAR,
    };
    let wrap = |w: Wrap| match w {
        Wrap::Repeat => vk::SamplerAddressMode::REPEAT,
        Wrap::ClampToEdge => vk::SamplerAddressMode::CLAMP_TO_EDGE,
        Wrap::MirroredRepeat => vk::SamplerAddressMode::MIRRORED_REPEAT,
    };
    let (mipmap_mode, max_lod) = match s.mipmap {
        Some(Filter::Nearest) => (vk::SamplerMipmapMode::NEAREST, vk::LOD_CLAMP_NONE),
        Some(Filter::Linear) => (vk::SamplerMipmapMode::LINEAR, vk::LOD_CLAMP_NONE),
        None => (vk::SamplerMipmapMode::NEAREST, 0.25),
    };
    vk::SamplerCreateInfo::default()
        .mag_filter(filter(s.mag_filter))
        .min_filter(filter(s.min_filter))
        .mipmap_mode(mipmap_mode)
        .address_mode_u(wrap(s.wrap_s))
        .address_mode_v(wrap(s.wrap_t))
        .address_mode_w(vk::SamplerAddressMode::REPEAT)
        .min_lod(0.0)
        .max_lod(max_lod)
}

/// Indices into `SceneGpu::_buffers` (the order `upload` keeps them in).
const BUF_INSTANCES: usize = 3;
const BUF_NODES: usize = 7;
const BUF_TRI_REF: usize = 8;
const BUF_TRI_VERTS: usize = 9;
const BUF_EMITTERS: usize = 10;

/// The `instances` buffer records (scene.glsl `InstanceInfo`) for transforms
/// (this frame's and the previous frame's) rebased on `origin`.
fn instance_records(
    transforms: &[Mat4],
    prev: &[Mat4],
    ids: &[[u32; 4]],
    origin: DVec3,
) -> Vec<InstanceGpu> {
    transforms
        .iter()
        .zip(prev)
        .zip(ids)
        .map(|((t, p), &ids)| InstanceGpu {
            object_to_world: relative_transform(*t, origin).to_cols_array(),
            // (A singular placement's normals through its regularized
            // inverse: a mesh flattened to a plane gets the plane's normal.)
            normal_to_world: crate::scene::regularized_placement(*t)
                .inverse()
                .transpose()
                .to_cols_array(),
            // w: 1 where the transform mirrors (scene.glsl instance_front_sign).
            // (The regularized placement's sign, as the TLAS and the
            // two-level layout see a singular one.)
            mesh_pad: [
                ids[0],
                ids[1],
                ids[2],
                (crate::scene::regularized_placement(*t).determinant() < 0.0) as u32,
            ],
            prev_object_to_world: relative_transform(*p, origin).to_cols_array(),
        })
        .collect()
}

/// The emitter buffer: a uvec4 header (triangle count, 0, 0, 0) and one
/// `EmitterGpu` per triangle (lights.glsl `Emitters`). No emitters (or no
/// power) → count 0, and NEE of emissive triangles does nothing.
fn emitter_buffer(e: &Emitters) -> Vec<u8> {
    let mut out: Vec<u8> = Vec::new();
    let Some(table) = &e.table else {
        out.extend_from_slice(bytemuck::cast_slice(&[0u32; 4]));
        out.extend_from_slice(bytemuck::bytes_of(&EmitterGpu::zeroed()));
        return out;
    };
    out.extend_from_slice(bytemuck::cast_slice(&[e.triangles.len() as u32, 0, 0, 0]));
    for (t, (a, pmf)) in e.triangles.iter().zip(table.entries.iter().zip(&table.pmf)) {
        let g = EmitterGpu {
            p0: t.vertices[0].to_array(),
            alias_prob: a.prob,
            p1: t.vertices[1].to_array(),
            alias: a.alias,
            p2: t.vertices[2].to_array(),
            pdf_area: if t.area > 0.0 { pmf / t.area } else { 0.0 },
            ids: [t.instance, t.prim, 0, 0],
        };
        out.extend_from_slice(bytemuck::bytes_of(&g));
    }
    out
}

/// The environment distribution buffer: a uvec4 header (width, height, 0, 0;
/// width 0 = no distribution), the marginal CDF (h + 1 floats), then the
/// conditional CDFs (h rows of w + 1 floats) — sky.glsl `EnvDistribution`.
fn env_distribution_buffer(d: Option<&EnvDistribution>) -> Vec<u8> {
    let mut out: Vec<u8> = Vec::new();
    match d {
        Some(d) => {
            out.extend_from_slice(bytemuck::cast_slice(&[d.width, d.height, 0, 0]));
            out.extend_from_slice(bytemuck::cast_slice(&d.marginal_cdf));
            out.extend_from_slice(bytemuck::cast_slice(&d.conditional_cdf));
        }
        None => out.extend_from_slice(bytemuck::cast_slice(&[0u32; 8])),
    }
    out
}

fn row_major_3x4(m: Mat4) -> [[f32; 4]; 3] {
    let r = m.transpose().to_cols_array_2d();
    [r[0], r[1], r[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1 − cos r of a sun disc: exact to f32 rounding against the series
    /// r²/2 − r⁴/24 + r⁶/720 for small discs (where f32's cos r has no
    /// digits left), 1 at a quarter sphere, 2 from π on; no disc (a delta
    /// light) for zero, negative, non-finite and sub-10⁻¹⁰ radii.
    #[test]
    fn sun_discs_carry_one_minus_cos_exactly() {
        for r in [1e-10f32, 1e-6, 3e-4, 0.001, 0.00465, 0.01] {
            let x = r as f64;
            let series = x * x / 2.0 - x.powi(4) / 24.0 + x.powi(6) / 720.0;
            let got = sun_one_minus_cos(r) as f64;
            assert!(
                (got / series - 1.0).abs() < 1.2e-7,
                "r = {r}: {got} against {series}"
            );
        }
        assert!((sun_one_minus_cos(std::f32::consts::FRAC_PI_2) - 1.0).abs() < 1e-7);
        assert_eq!(sun_one_minus_cos(std::f32::consts::PI), 2.0);
        assert_eq!(sun_one_minus_cos(4.0), 2.0);
        for r in [0.0, -0.1, f32::NAN, f32::INFINITY, 9e-11] {
            assert_eq!(sun_one_minus_cos(r), 0.0, "r = {r}");
        }
    }
}
