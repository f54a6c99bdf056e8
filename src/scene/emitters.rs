//! Emissive triangles as lights for next-event estimation: every triangle of
//! every instance whose material emits, in world space, with its power and an
//! alias table that picks one in proportion to power (scene::alias).
//!
//! Power of triangle i (what the pick probability is proportional to):
//!   Φ_i = π · A_i · lum(emissive factor · mean emissive texel) · sides,
//! sides = 2 for double-sided materials (they emit from both faces, as
//! material.glsl shades them), 1 otherwise. For a textured emitter the mean
//! texel of the whole texture stands in for the mean over the triangle's uv
//! footprint — a documented approximation that only affects how well the pick
//! probability follows the light (the estimator stays unbiased: the radiance
//! at the sampled point is evaluated exactly from the material, lights.glsl
//! `emitted_radiance`), except that a triangle whose factor is non-zero but
//! whose texels are all black gets probability 0 (it also emits nothing).

use super::alias::AliasTable;
use super::{Scene, Texture, TextureEncoding};
use glam::{Mat4, Vec3};

/// Rec. 709 luminance, the weight used for light power.
pub fn luminance(c: Vec3) -> f64 {
    0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64
}

#[derive(Clone, Debug)]
pub struct EmitterTriangle {
    pub instance: u32,
    /// Triangle index within its mesh (RtHit.prim).
    pub prim: u32,
    /// World-space vertices (in the frame the caller's transforms give).
    pub vertices: [Vec3; 3],
    pub area: f32,
    pub power: f64,
    /// Object-space vertices and (luminance, sides) of the emission: what
    /// [`Emitters::pose`] recomputes `vertices`, `area` and `power` from.
    pub object_vertices: [Vec3; 3],
    pub emission: (f64, f64),
}

impl EmitterTriangle {
    /// World vertices, area and power under object-to-world `m`.
    fn place(&mut self, m: Mat4) {
        let v = self.object_vertices.map(|p| m.transform_point3(p));
        let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
        let (lum, sides) = self.emission;
        let power = std::f64::consts::PI * area as f64 * lum * sides;
        self.vertices = v;
        self.area = area;
        self.power = if power.is_finite() { power } else { 0.0 };
    }
}

#[derive(Clone, Debug, Default)]
pub struct Emitters {
    /// All triangles of emissive instances; instance k's triangles are
    /// contiguous from `first[k]` in primitive order.
    pub triangles: Vec<EmitterTriangle>,
    /// Per instance: index of its first triangle in `triangles`, if it emits.
    pub first: Vec<Option<u32>>,
    /// Pick-by-power table over `triangles` (`None`: nothing emits).
    pub table: Option<AliasTable>,
}

/// The mean linear RGB of a texture's level 0 (sRGB decoded for colour data).
pub fn mean_texel(t: &Texture) -> Vec3 {
    let lin = |c: u8| -> f64 {
        let c = c as f64 / 255.0;
        match t.encoding {
            TextureEncoding::Srgb if c <= 0.04045 => c / 12.92,
            TextureEncoding::Srgb => ((c + 0.055) / 1.055).powf(2.4),
            TextureEncoding::Linear => c,
        }
    };
    let mut s = [0.0f64; 3];
    let level0 = t.mips.first().map(|m| m.as_slice()).unwrap_or(&[]);
    for px in level0.chunks_exact(4) {
        for k in 0..3 {
            s[k] += lin(px[k]);
        }
    }
    let n = (level0.len() / 4).max(1) as f64;
    Vec3::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32)
}

impl Emitters {
    /// Collects the emitters of `scene`; `transform(k)` is instance k's
    /// object-to-world matrix in the frame the GPU uses (render-origin relative).
    pub fn of(scene: &Scene, transform: impl Fn(usize) -> Mat4) -> Emitters {
        let mut out = Emitters {
            first: vec![None; scene.instances.len()],
            ..Default::default()
        };
        let mut tex_mean = vec![None; scene.textures.len()];
        for (k, inst) in scene.instances.iter().enumerate() {
            let mesh = &scene.meshes[inst.mesh as usize];
            let mat = &scene.materials[mesh.material as usize];
            if mat.emissive.max_element() <= 0.0 || mesh.indices.is_empty() {
                continue;
            }
            let mut radiance = mat.emissive;
            if let Some(t) = mat.emissive_texture {
                let i = t.texture as usize;
                let m = *tex_mean[i].get_or_insert_with(|| mean_texel(&scene.textures[i]));
                radiance *= m;
            }
            let sides = if mat.double_sided { 2.0 } else { 1.0 };
            let lum = luminance(radiance).max(0.0);
            out.first[k] = Some(out.triangles.len() as u32);
            let m = transform(k);
            for (prim, tri) in mesh.indices.chunks_exact(3).enumerate() {
                let mut t = EmitterTriangle {
                    instance: k as u32,
                    prim: prim as u32,
                    vertices: [Vec3::ZERO; 3],
                    area: 0.0,
                    power: 0.0,
                    object_vertices: [0, 1, 2].map(|j| mesh.positions[tri[j] as usize]),
                    emission: (lum, sides),
                };
                t.place(m);
                out.triangles.push(t);
            }
        }
        let powers: Vec<f64> = out.triangles.iter().map(|t| t.power).collect();
        out.table = AliasTable::new(&powers);
        out
    }

    /// Moves every emitter with its instance to `transform(k)` (an animated
    /// scene's pose, issue 16): world vertices, areas, powers and the
    /// pick-by-power table as [`Self::of`] computes them at that pose.
    pub fn pose(&mut self, transform: impl Fn(usize) -> Mat4) {
        for t in &mut self.triangles {
            t.place(transform(t.instance as usize));
        }
        let powers: Vec<f64> = self.triangles.iter().map(|t| t.power).collect();
        self.table = AliasTable::new(&powers);
    }
}
