//! Triangle meshes (one per glTF primitive) and their instances.

use glam::{Mat4, Vec2, Vec3, Vec4};

/// Indexed triangles with per-vertex attributes, all arrays the same length.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Unit normals; flat (each triangle's face normal on vertices of its own)
    /// when the file has none.
    pub normals: Vec<Vec3>,
    /// The uv set the material's textures read (glTF: TEXCOORD_n with its
    /// KHR_texture_transform applied at import); zeros when the file has none.
    pub uvs: Vec<Vec2>,
    /// A second uv channel (another TEXCOORD_n or another transform) for
    /// the texture slots in its material's `second_uv_slots`; empty when
    /// every slot reads `uvs`.
    pub uvs2: Vec<Vec2>,
    /// xyz tangent, w handedness; empty when neither the file nor a normal map needs them.
    pub tangents: Vec<Vec4>,
    /// Linear RGBA vertex colours (glTF COLOR_0, alpha 1 for a VEC3
    /// accessor), multiplying the base colour and its alpha; empty: white.
    pub colors: Vec<Vec4>,
    pub indices: Vec<u32>,
    pub material: u32,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    pub fn triangle(&self, prim: usize) -> [Vec3; 3] {
        let i = &self.indices[3 * prim..3 * prim + 3];
        [
            self.positions[i[0] as usize],
            self.positions[i[1] as usize],
            self.positions[i[2] as usize],
        ]
    }
}

/// A placement of a mesh in the world.
#[derive(Clone, Debug)]
pub struct Instance {
    pub mesh: u32,
    /// Object-to-world transform (node hierarchy already flattened).
    pub transform: Mat4,
    /// Name of the glTF node, for messages and debug views.
    pub name: String,
}
