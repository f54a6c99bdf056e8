//! The scene's persistent descriptor set 0 (src/rt/gpu_scene.rs builds it;
//! shaders/common/scene.glsl, rt_software.glsl, rt_query.glsl, lights.glsl
//! and sky.glsl read it) and the scene-feature specialization constants of
//! shaders/common/features.glsl. Not a per-pass set: the binding kinds
//! (buffers, image arrays, the TLAS) are gpu_scene.rs's; this table names
//! the binding numbers once for both sides.

use super::{read, write, Interface};

/// Specialization constant ids of the scene features (features.glsl `SC_*`).
pub mod spec_id {
    pub const TEXTURES: u32 = 0;
    pub const NORMAL_MAPS: u32 = 1;
    pub const ALPHA_MASK: u32 = 2;
    pub const TRANSMISSION: u32 = 3;
    pub const EMISSIVE: u32 = 4;
    pub const PUNCTUAL: u32 = 5;
    pub const DIRECTIONAL: u32 = 6;
    pub const ENV_KIND: u32 = 7;
    pub const MAX_BOUNCES: u32 = 8;
    pub const TEXTURE_COUNT: u32 = 9;
    pub const VIEW_DEPENDENT: u32 = 10;
    pub const LIGHT_STRATEGY: u32 = 11;
    pub const TWO_LEVEL: u32 = 12;
    pub const ANIMATED: u32 = 13;
    pub const VERTEX_COLORS: u32 = 14;
    pub const CLEARCOAT: u32 = 15;
    pub const BACKFACE_CULLING: u32 = 16;
    pub const SECOND_UV: u32 = 17;
    pub const UV_AFFINE: u32 = 18;
}

pub const INTERFACE: Interface = Interface {
    name: "scene",
    set: 0,
    bindings: &[
        read("vertices"),
        read("indices"),
        read("meshes"),
        read("instances"),
        read("materials"),
        read("lights"),
        read("params"),
        read("bvh_nodes"),
        read("bvh_tri_ref"),
        read("bvh_tri_verts"),
        read("textures"),
        read("env_map"),
        read("emitters"),
        read("env_distribution"),
        // Linear RGBA per vertex (COLOR_0), parallel to `vertices`; a white
        // stand-in when no mesh has colours (SC_VERTEX_COLORS off).
        read("colors"),
        // The second uv channel (vec2 per vertex, parallel to `vertices`) of
        // texture slots that read another uv set or transform; a stand-in
        // when no mesh has one (SC_SECOND_UV off).
        read("uvs2"),
        read("tlas"),
        // The material-graph memoization cache (only in the set of a scene
        // whose graphs are memoized: gpu_scene.rs; shaders/common/memo.glsl).
        write("memo_keys"),
        write("memo_stamps"),
        write("memo_values"),
        write("memo_state"),
    ],
    push: &[],
    counters: &[],
    spec: &[
        ("SC_TEXTURES", spec_id::TEXTURES),
        ("SC_NORMAL_MAPS", spec_id::NORMAL_MAPS),
        ("SC_ALPHA_MASK", spec_id::ALPHA_MASK),
        ("SC_TRANSMISSION", spec_id::TRANSMISSION),
        ("SC_EMISSIVE", spec_id::EMISSIVE),
        ("SC_PUNCTUAL", spec_id::PUNCTUAL),
        ("SC_DIRECTIONAL", spec_id::DIRECTIONAL),
        ("SC_ENV_KIND", spec_id::ENV_KIND),
        ("SC_MAX_BOUNCES", spec_id::MAX_BOUNCES),
        ("SC_TEXTURE_COUNT", spec_id::TEXTURE_COUNT),
        ("SC_VIEW_DEPENDENT", spec_id::VIEW_DEPENDENT),
        ("SC_LIGHT_STRATEGY", spec_id::LIGHT_STRATEGY),
        ("SC_TWO_LEVEL", spec_id::TWO_LEVEL),
        ("SC_ANIMATED", spec_id::ANIMATED),
        ("SC_VERTEX_COLORS", spec_id::VERTEX_COLORS),
        ("SC_CLEARCOAT", spec_id::CLEARCOAT),
        ("SC_BACKFACE_CULLING", spec_id::BACKFACE_CULLING),
        ("SC_SECOND_UV", spec_id::SECOND_UV),
        ("SC_UV_AFFINE", spec_id::UV_AFFINE),
    ],
};
