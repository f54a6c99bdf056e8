//! The two-level software ray-tracing structure: one obvhs CWBVH per mesh
//! over its triangles in object space (a BLAS, built once) and one CWBVH
//! over the instances' world bounds (the TLAS, rebuilt when something
//! moves). The GLSL traversal (`cw_traverse_two_level` in
//! shaders/common/rt_software.glsl) transforms the ray into object space at
//! each instance leaf, so moving an instance costs a TLAS rebuild over a
//! few boxes instead of a rebuild over every triangle (appendix D's moving
//! instances; issue 16).
//!
//! All of it lives in the same three storage buffers as the flattened BVH
//! (`SoftwareBvh`), so the descriptor set is unchanged:
//!   nodes:     [TLAS, `tlas_capacity` slots][BLAS of mesh 0][mesh 1]…
//!   leaf slots (tri_ref, 3 × tri_verts each):
//!              [TLAS leaves, one per instance][triangles of mesh 0][mesh 1]…
//! A TLAS leaf slot k holds tri_ref = (instance, BLAS root node) and
//! tri_verts = the three rows of the instance's object-from-world 3×4
//! matrix; a triangle slot holds tri_ref = (unused, primitive) and its
//! vertices (v0, v1, v2) in object space. BLAS child/primitive indices are rebased to the
//! combined arrays. The TLAS region has a fixed capacity, so a rebuild
//! rewrites only the front of each buffer.
//!
//! Positions are relative to the render origin (`super::origin`) like the
//! flattened structure: instance transforms are rebased in f64 first.

use super::bvh::{cpu_traverse, hittable, max_depth, CpuHit};
use super::origin::relative_transform;
use crate::scene::Scene;
use glam::{DVec3, Mat4, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::{builder::build_cwbvh, builder::build_cwbvh_from_tris, node::CwBvhNode, CwBvh};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use std::time::Duration;

/// One mesh's BLAS in object space.
struct MeshBvh {
    cwbvh: CwBvh,
    /// Object-space bounds (empty mesh: none).
    bounds: Option<Aabb>,
    /// First node of this BLAS in the combined node array.
    node_base: u32,
}

pub struct TwoLevelBvh {
    /// The render origin every position is relative to.
    pub origin: DVec3,
    /// Combined nodes (layout in the module documentation).
    pub nodes: Vec<CwBvhNode>,
    /// Per leaf slot: (instance, BLAS root) for TLAS leaves, (0, primitive) for triangles.
    pub tri_ref: Vec<[u32; 2]>,
    /// 3 × vec4 per leaf slot.
    pub tri_verts: Vec<[f32; 4]>,
    /// Nodes reserved for the TLAS at the front of `nodes`.
    pub tlas_capacity: usize,
    /// Leaf slots of the TLAS (one per instance with triangles).
    pub tlas_slots: usize,
    /// Deepest TLAS node + 1 + deepest BLAS node: the traversal stack's need.
    pub max_depth: u32,
    blas: Vec<MeshBvh>,
    tlas: CwBvh,
    /// Instances with triangles (the TLAS's primitives), by TLAS primitive index.
    tlas_instances: Vec<u32>,
    mesh_of: Vec<u32>,
    /// World-from-object (render-origin relative) per instance.
    world_from_object: Vec<Mat4>,
    /// BLAS depth maximum, kept for depth after TLAS rebuilds.
    blas_depth: u32,
}

/// The world box of an instance, or `None` for one scaled to a point (it
/// cannot be hit: left out of the TLAS, as zero-area triangles are left
/// out of the BVHs, bvh.rs `hittable`; thousands of such boxes on one spot
/// would chain the TLAS).
fn instance_bounds(object: &Aabb, m: Mat4) -> Option<Aabb> {
    let mut b = Aabb::empty();
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 {
                object.min.x
            } else {
                object.max.x
            },
            if i & 2 == 0 {
                object.min.y
            } else {
                object.max.y
            },
            if i & 4 == 0 {
                object.min.z
            } else {
                object.max.z
            },
        );
        b.extend(Vec3A::from(m.transform_point3(c)));
    }
    if b.min == b.max {
        return None;
    }
    // Widen by a few ulps of the box's magnitude: the corners were rounded
    // once more than the triangles the ray meets in object space.
    let pad = Vec3A::splat(4.0 * f32::EPSILON) * b.min.abs().max(b.max.abs()) + 1e-30;
    Some(Aabb::new(b.min - pad, b.max + pad))
}

impl TwoLevelBvh {
    /// BLAS per mesh and the TLAS over the scene's instances at rest.
    pub fn build_at(scene: &Scene, origin: DVec3) -> TwoLevelBvh {
        let transforms: Vec<Mat4> = scene.instances.iter().map(|i| i.transform).collect();
        Self::build_with(scene, origin, &transforms)
    }

    /// As `build_at` with the instances at `transforms` (object-to-world).
    pub fn build_with(scene: &Scene, origin: DVec3, transforms: &[Mat4]) -> TwoLevelBvh {
        let n_inst = scene.instances.len();
        let tlas_capacity = 2 * n_inst + 1;
        let mut nodes = vec![CwBvhNode::default(); tlas_capacity];
        let mut tri_ref = vec![[0u32; 2]; n_inst];
        let mut tri_verts = vec![[0f32; 4]; 3 * n_inst];
        let mut blas = Vec::with_capacity(scene.meshes.len());
        let mut blas_depth = 0;
        for mesh in &scene.meshes {
            // v0's w: 1 where the mesh's material culls back faces (object
            // space, where glTF's front is counter-clockwise whatever the
            // instance transform: no sign as in the flattened BVH).
            let cull = if scene.mesh_culls_back_faces(mesh) {
                1.0
            } else {
                0.0
            };
            // Zero-area triangles are never hit (bvh.rs `hittable`): left
            // out, each kept triangle with its primitive index.
            let (tris, prims): (Vec<Triangle>, Vec<u32>) = (0..mesh.triangle_count())
                .map(|p| {
                    let [a, b, c] = mesh.triangle(p);
                    let tri = Triangle {
                        v0: a.into(),
                        v1: b.into(),
                        v2: c.into(),
                    };
                    (tri, p as u32)
                })
                .filter(|(tri, _)| hittable(tri))
                .unzip();
            let node_base = nodes.len() as u32;
            let slot_base = tri_ref.len() as u32;
            let mut t = Duration::ZERO;
            let cwbvh = if tris.is_empty() {
                CwBvh::default()
            } else {
                build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut t)
            };
            for n in &cwbvh.nodes {
                let mut n = *n;
                n.child_base_idx += node_base;
                n.primitive_base_idx += slot_base;
                nodes.push(n);
            }
            for &pi in &cwbvh.primitive_indices {
                let tri = &tris[pi as usize];
                tri_ref.push([0, prims[pi as usize]]);
                tri_verts.push([tri.v0.x, tri.v0.y, tri.v0.z, cull]);
                tri_verts.push([tri.v1.x, tri.v1.y, tri.v1.z, 0.0]);
                tri_verts.push([tri.v2.x, tri.v2.y, tri.v2.z, 0.0]);
            }
            if !cwbvh.nodes.is_empty() {
                blas_depth = blas_depth.max(max_depth(&cwbvh));
            }
            let bounds = (!mesh.positions.is_empty()).then(|| {
                let pts: Vec<Vec3A> = mesh.positions.iter().map(|&p| p.into()).collect();
                Aabb::from_points(&pts)
            });
            blas.push(MeshBvh {
                cwbvh,
                bounds,
                node_base,
            });
        }
        let mut s = TwoLevelBvh {
            origin,
            nodes,
            tri_ref,
            tri_verts,
            tlas_capacity,
            tlas_slots: 0,
            max_depth: 0,
            blas,
            tlas: CwBvh::default(),
            tlas_instances: Vec::new(),
            mesh_of: scene.instances.iter().map(|i| i.mesh).collect(),
            world_from_object: Vec::new(),
            blas_depth,
        };
        s.rebuild_tlas(transforms);
        s
    }

    /// Rebuilds the TLAS for new instance transforms (object-to-world, not
    /// yet origin relative). Only the first `tlas_capacity` nodes and the
    /// first `tlas_slots` leaf slots change.
    pub fn rebuild_tlas(&mut self, transforms: &[Mat4]) {
        assert_eq!(
            transforms.len(),
            self.mesh_of.len(),
            "one transform per instance"
        );
        self.world_from_object = transforms
            .iter()
            .map(|&m| relative_transform(m, self.origin))
            .collect();
        let mut boxes = Vec::new();
        self.tlas_instances.clear();
        for (i, m) in self.world_from_object.iter().enumerate() {
            let b = &self.blas[self.mesh_of[i] as usize];
            if let (Some(bounds), false) = (b.bounds, b.cwbvh.nodes.is_empty()) {
                let Some(bx) = instance_bounds(&bounds, *m) else {
                    continue;
                };
                boxes.push(bx);
                self.tlas_instances.push(i as u32);
            }
        }
        let mut t = Duration::ZERO;
        // No instance with a hittable triangle (all scaled to points, this
        // frame): an empty TLAS, whose root is reset to a node without
        // children so every ray misses (the last frame's root stays there
        // otherwise: nothing below overwrites node 0).
        self.tlas = if boxes.is_empty() {
            self.nodes[0] = CwBvhNode::default();
            CwBvh::default()
        } else {
            build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut t)
        };
        assert!(
            self.tlas.nodes.len() <= self.tlas_capacity,
            "TLAS of {} nodes exceeds its {} reserved",
            self.tlas.nodes.len(),
            self.tlas_capacity
        );
        self.nodes[..self.tlas.nodes.len()].copy_from_slice(&self.tlas.nodes);
        self.tlas_slots = self.tlas.primitive_indices.len();
        for (k, &p) in self.tlas.primitive_indices.iter().enumerate() {
            let inst = self.tlas_instances[p as usize];
            let blas = &self.blas[self.mesh_of[inst as usize] as usize];
            self.tri_ref[k] = [inst, blas.node_base];
            // Rows of object-from-world, inverted in f64 (a singular
            // placement made invertible: scene::regularized_placement).
            let inv = crate::scene::regularized_placement(self.world_from_object[inst as usize])
                .as_dmat4()
                .inverse()
                .as_mat4()
                .transpose();
            for r in 0..3 {
                self.tri_verts[3 * k + r] = inv.col(r).to_array();
            }
        }
        self.max_depth = max_depth(&self.tlas) + 1 + self.blas_depth;
    }

    /// Bytes of the front of each buffer a TLAS rebuild rewrote: (nodes,
    /// tri_ref, tri_verts) prefixes.
    pub fn tlas_bytes(&self) -> (&[u8], &[u8], &[u8]) {
        (
            bytemuck::cast_slice(&self.nodes[..self.tlas_capacity]),
            bytemuck::cast_slice(&self.tri_ref[..self.tlas_instances.len().max(1)]),
            bytemuck::cast_slice(&self.tri_verts[..3 * self.tlas_instances.len().max(1)]),
        )
    }

    /// A world point in this structure's frame (relative to `origin`).
    pub fn to_local(&self, world: DVec3) -> Vec3 {
        (world - self.origin).as_vec3()
    }

    /// Closest hit on the CPU for a ray in this structure's frame:
    /// `cw_traverse_two_level` of rt_software.glsl step for step, over the
    /// same combined buffers the GPU reads (`bvh::cpu_traverse`): the TLAS
    /// over the instance boxes; at each instance the ray goes to object
    /// space through the same f32 rows, then the mesh's BLAS is walked with
    /// the watertight triangle test on the same stack.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<CpuHit> {
        if self.tlas.nodes.is_empty() {
            return None;
        }
        cpu_traverse(
            &self.nodes,
            &self.tri_ref,
            &self.tri_verts,
            true,
            origin,
            dir,
            tmin,
            tmax,
        )
    }
}
