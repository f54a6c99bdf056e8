//! The software ray-tracing structure: one obvhs CWBVH over every triangle of
//! every instance, transformed to world space ("flattened"). Leaf triangles
//! are stored in BVH order as (v0, e1, e2) so the GLSL traversal
//! (shaders/common/rt_software.glsl) reads them without an indirection.
//! A CPU traversal of the same structure checks the GPU in tests.
//!
//! Positions are relative to the scene's render origin (`super::origin`):
//! triangles are transformed to world space and rebased in f64 before they
//! become f32, so a scene far from its file's origin keeps its precision.

use super::origin::render_origin;
use crate::scene::Scene;
use glam::{DVec3, Vec3, Vec3A};
use obvhs::cwbvh::{builder::build_cwbvh_from_tris, node::CwBvhNode, CwBvh};
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use std::time::Duration;

/// Depth of the traversal stack in shaders/common/rt_software.glsl
/// (`CWBVH_STACK_SIZE`); a deeper CWBVH could drop nodes there.
pub const TRAVERSAL_STACK_SIZE: u32 = 32;

pub struct SoftwareBvh {
    pub cwbvh: CwBvh,
    /// The render origin every position below is relative to.
    pub origin: DVec3,
    /// Depth of the deepest internal node (root = 0).
    pub max_depth: u32,
    /// (instance, primitive within its mesh) per leaf slot.
    pub tri_ref: Vec<[u32; 2]>,
    /// 3 × vec4 per leaf slot: v0, e1 = v1 − v0, e2 = v2 − v0 (world). v0's
    /// w is 0 unless the triangle's material culls back faces
    /// (`culls_back_faces`); then it is the sign of its instance transform's
    /// determinant: glTF's front is counter-clockwise in object space, so in
    /// world space e1 × e2 is the front normal times that sign, and a ray
    /// with dot(e1 × e2, d)·w > 0 meets the back and passes through.
    pub tri_verts: Vec<[f32; 4]>,
}

/// A CPU ray hit, in the same convention as `RtHit` in GLSL.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpuHit {
    pub t: f32,
    pub instance: u32,
    pub prim: u32,
    pub bary: [f32; 2],
}

impl SoftwareBvh {
    /// The structure relative to the scene's render origin.
    pub fn build(scene: &Scene) -> SoftwareBvh {
        Self::build_at(scene, render_origin(scene))
    }

    /// The structure relative to `origin` (the upload passes the origin it
    /// already computed for the rest of the scene).
    pub fn build_at(scene: &Scene, origin: DVec3) -> SoftwareBvh {
        let mut tris = Vec::with_capacity(scene.instanced_triangle_count());
        let mut refs = Vec::with_capacity(tris.capacity());
        let mut culls = Vec::with_capacity(tris.capacity());
        for (ii, inst) in scene.instances.iter().enumerate() {
            let mesh = &scene.meshes[inst.mesh as usize];
            let cull = match (
                scene.mesh_culls_back_faces(mesh),
                inst.transform.determinant() < 0.0,
            ) {
                (false, _) => 0.0,
                (true, false) => 1.0,
                (true, true) => -1.0,
            };
            for prim in 0..mesh.triangle_count() {
                let [a, b, c] = mesh.triangle(prim);
                let m = inst.transform.as_dmat4();
                let t =
                    |p: Vec3| Vec3A::from((m.transform_point3(p.as_dvec3()) - origin).as_vec3());
                let tri = Triangle {
                    v0: t(a),
                    v1: t(b),
                    v2: t(c),
                };
                if !hittable(&tri) {
                    continue;
                }
                tris.push(tri);
                refs.push([ii as u32, prim as u32]);
                culls.push(cull);
            }
        }
        let mut build_time = Duration::ZERO;
        // Empty when no triangle is hittable (the upload refuses that).
        let cwbvh = if tris.is_empty() {
            CwBvh::default()
        } else {
            build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut build_time)
        };
        let mut tri_ref = Vec::with_capacity(cwbvh.primitive_indices.len());
        let mut tri_verts = Vec::with_capacity(3 * cwbvh.primitive_indices.len());
        for &pi in &cwbvh.primitive_indices {
            let t = &tris[pi as usize];
            tri_ref.push(refs[pi as usize]);
            let e1 = t.v1 - t.v0;
            let e2 = t.v2 - t.v0;
            tri_verts.push([t.v0.x, t.v0.y, t.v0.z, culls[pi as usize]]);
            tri_verts.push([e1.x, e1.y, e1.z, 0.0]);
            tri_verts.push([e2.x, e2.y, e2.z, 0.0]);
        }
        let max_depth = max_depth(&cwbvh);
        SoftwareBvh {
            cwbvh,
            origin,
            max_depth,
            tri_ref,
            tri_verts,
        }
    }

    /// A world point in this structure's frame (relative to `origin`).
    pub fn to_local(&self, world: DVec3) -> Vec3 {
        (world - self.origin).as_vec3()
    }

    pub fn nodes(&self) -> &[CwBvhNode] {
        &self.cwbvh.nodes
    }

    /// Closest hit on the CPU, for a ray in this structure's frame (see
    /// `to_local`), with the same Möller–Trumbore test as the GLSL
    /// traversal (no alpha test: used on opaque scenes).
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<CpuHit> {
        if self.cwbvh.nodes.is_empty() {
            return None;
        }
        let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
        let mut hit = RayHit::none();
        let mut best: Option<CpuHit> = None;
        self.cwbvh.ray_traverse(ray, &mut hit, |r, k| {
            let v = &self.tri_verts[3 * k..3 * k + 3];
            let (v0, e1, e2) = (
                Vec3::from_slice(&v[0][..3]),
                Vec3::from_slice(&v[1][..3]),
                Vec3::from_slice(&v[2][..3]),
            );
            let back = e1.cross(e2).dot(Vec3::from(r.direction)) * v[0][3] > 0.0;
            match moller_trumbore(Vec3::from(r.origin), Vec3::from(r.direction), v0, e1, e2) {
                Some((t, u, w)) if t > tmin && t < r.tmax && !back => {
                    let [inst, prim] = self.tri_ref[k];
                    best = Some(CpuHit {
                        t,
                        instance: inst,
                        prim,
                        bary: [u, w],
                    });
                    t
                }
                _ => f32::INFINITY,
            }
        });
        best
    }
}

/// Möller & Trumbore 1997, the exact arithmetic of `intersect_triangle` in rt_software.glsl.
pub fn moller_trumbore(o: Vec3, d: Vec3, v0: Vec3, e1: Vec3, e2: Vec3) -> Option<(f32, f32, f32)> {
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = o - v0;
    let u = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = d.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(qv) * inv, u, v))
}

/// Depth of the deepest internal node, walked iteratively (obvhs's own check
/// runs only in its debug builds).
pub(crate) fn max_depth(bvh: &CwBvh) -> u32 {
    let mut deepest = 0;
    let mut stack = vec![(0usize, 0u32)];
    if bvh.nodes.is_empty() {
        return 0;
    }
    while let Some((i, depth)) = stack.pop() {
        deepest = deepest.max(depth);
        let node = &bvh.nodes[i];
        for ch in 0..8 {
            let meta = node.child_meta[ch] as u32;
            if meta == 0 || node.imask & (1 << ch) == 0 {
                continue;
            }
            let slot = (meta & 0b11111) - 24;
            let rel = (node.imask as u32 & !(u32::MAX << slot)).count_ones();
            stack.push((node.child_base_idx as usize + rel as usize, depth + 1));
        }
    }
    deepest
}

/// Whether the traversal's Möller–Trumbore test can ever report `tri`: its
/// edges' cross product is finite and not zero (a triangle of exactly zero
/// area has det = 0 for every ray, intersect_triangle in rt_software.glsl).
/// Such triangles are left out of the software BVHs, which changes no hit
/// (triangles whose cross product merely rounds near zero are kept); kept
/// in, thousands of them sharing one centroid (a node scaled to zero) build
/// a chain deeper than the traversal stack.
pub(crate) fn hittable(tri: &Triangle) -> bool {
    let n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
    n.is_finite() && n != Vec3A::ZERO
}
