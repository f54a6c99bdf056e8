//! The software ray-tracing structure: one obvhs CWBVH over every triangle of
//! every instance, transformed to world space ("flattened"). Leaf triangles
//! are stored in BVH order as their three vertices (v0, v1, v2) so the GLSL traversal
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
    /// 3 × vec4 per leaf slot: the vertices v0, v1, v2 (world), stored as
    /// they are (not v0 and the edges: v0 + (v1 − v0) can round an ulp off
    /// v1, and two triangles that share a vertex must see the same point or
    /// a ray at that vertex falls between them). v0's w is 0 unless the
    /// triangle's material culls back faces (`culls_back_faces`); then it is
    /// the sign of its instance transform's determinant: glTF's front is
    /// counter-clockwise in object space, so in world space
    /// (v1 − v0) × (v2 − v0) is the front normal times that sign, and a ray
    /// with a positive dot product of it and d, times w, meets the back and
    /// passes through.
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
                // Mirrored: by the placement the TLAS and the two-level
                // layout use (a singular one regularized: its sign decides
                // which side of the flattened mesh is the front there too).
                crate::scene::regularized_placement(inst.transform).determinant() < 0.0,
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
            tri_verts.push([t.v0.x, t.v0.y, t.v0.z, culls[pi as usize]]);
            tri_verts.push([t.v1.x, t.v1.y, t.v1.z, 0.0]);
            tri_verts.push([t.v2.x, t.v2.y, t.v2.z, 0.0]);
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

    /// The vertices of leaf slot `k`'s triangle, in this structure's frame.
    pub fn triangle(&self, k: usize) -> [Vec3; 3] {
        [0, 1, 2].map(|j| Vec3::from_slice(&self.tri_verts[3 * k + j][..3]))
    }

    /// A world point in this structure's frame (relative to `origin`).
    pub fn to_local(&self, world: DVec3) -> Vec3 {
        (world - self.origin).as_vec3()
    }

    pub fn nodes(&self) -> &[CwBvhNode] {
        &self.cwbvh.nodes
    }

    /// Closest hit on the CPU, for a ray in this structure's frame (see
    /// `to_local`): `cw_traverse` of rt_software.glsl, node test, traversal
    /// order and watertight triangle test, operation for operation
    /// (`cpu_traverse`; no alpha test: used on opaque scenes).
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<CpuHit> {
        if self.cwbvh.nodes.is_empty() {
            return None;
        }
        cpu_traverse(
            &self.cwbvh.nodes,
            &self.tri_ref,
            &self.tri_verts,
            false,
            origin,
            dir,
            tmin,
            tmax,
        )
    }
}

/// Per-ray constants of the watertight ray/triangle test (Woop, Benthin &
/// Wald 2013, "Watertight Ray/Triangle Intersection", JCGT 2(1)): the
/// dominant axis `kz` of the direction, the two others `kx`, `ky` (swapped
/// when d[kz] < 0, which keeps the winding of the projected triangle), and
/// the shear/scale (Sx, Sy, Sz) = (d[kx]/d[kz], d[ky]/d[kz], 1/d[kz]) that
/// takes the ray to (0, 0, 0) + t·(0, 0, 1). `wt_ray` in rt_software.glsl.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WatertightRay {
    pub origin: Vec3,
    /// (kx, ky, kz).
    pub k: [usize; 3],
    /// (Sx, Sy, Sz); Sx and Sy as d[kx]·Sz, d[ky]·Sz (one reciprocal, no
    /// division whose rounding a shader compiler may change).
    pub s: [f32; 3],
}

impl WatertightRay {
    pub fn new(origin: Vec3, d: Vec3) -> WatertightRay {
        let a = d.abs();
        // The largest |d_i|; ties go to the higher axis.
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = if kz == 2 { 0 } else { kz + 1 };
        let mut ky = if kx == 2 { 0 } else { kx + 1 };
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / d[kz];
        WatertightRay {
            origin,
            k: [kx, ky, kz],
            s: [d[kx] * sz, d[ky] * sz, sz],
        }
    }

    /// The watertight test against a stored triangle (v0, v1, v2) (as the
    /// GPU reads them), each vertex taken to ray space on its own, so a vertex two triangles share lands
    /// on the same point in both. Returns (t, u, v): t along the ray's own
    /// (unnormalised) direction, (u, v) the weights of vertices 1 and 2; no
    /// t range test (the caller's). `intersect_triangle` in
    /// rt_software.glsl, operation for operation (there `precise`).
    ///
    /// Edge functions U, V, W (U of edge v1→v2, V of v2→v0, W of v0→v1):
    /// a neighbour evaluates the edge it shares from the same two ray-space
    /// vertices with the operands swapped, which in IEEE arithmetic gives
    /// exactly the negated value (products commute, a − b = −(b − a)), so
    /// the two triangles never both reject a ray for that edge. An edge
    /// value of exactly 0 (the paper recomputes it in double precision,
    /// which not every GPU has) counts as inside in both triangles: both
    /// report the hit (at the same t up to rounding) and the traversal
    /// keeps the closer, so no ray falls through; a true value rounded to
    /// 0 can only add a hit within rounding of the edge, never remove one.
    pub fn intersect(&self, v0: Vec3, v1: Vec3, v2: Vec3) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.s;
        let a = v0 - self.origin;
        let b = v1 - self.origin;
        let c = v2 - self.origin;
        let ax = a[kx] - sx * a[kz];
        let ay = a[ky] - sy * a[kz];
        let bx = b[kx] - sx * b[kz];
        let by = b[ky] - sy * b[kz];
        let cx = c[kx] - sx * c[kz];
        let cy = c[ky] - sy * c[kz];
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = sz * a[kz];
        let bz = sz * b[kz];
        let cz = sz * c[kz];
        let t = u * az + v * bz + w * cz;
        let inv = 1.0 / det;
        Some((t * inv, v * inv, w * inv))
    }
}

/// Back-face culling as `culled` in rt_software.glsl: v0.w is 0, or the
/// sign that makes w·((v1 − v0) × (v2 − v0)) the front normal; a ray
/// meeting the back passes through.
fn culled(v0w: f32, v0: Vec3, v1: Vec3, v2: Vec3, d: Vec3) -> bool {
    (v1 - v0).cross(v2 - v0).dot(d) * v0w > 0.0
}

/// `safe_inverse` of rt_software.glsl: |d_i| ≤ 1e-30 (−0.0 and +0.0
/// included) becomes ±1e-30 with the sign of d_i < 0, so −0.0 is +0.0.
fn safe_inverse(d: Vec3) -> Vec3 {
    const TINY: f32 = 1e-30;
    let f = |x: f32| {
        if x.abs() > TINY {
            x
        } else if x < 0.0 {
            -TINY
        } else {
            TINY
        }
    };
    Vec3::ONE / Vec3::new(f(d.x), f(d.y), f(d.z))
}

/// `cw_octant_inv4` of rt_software.glsl.
fn octant_inv4(d: Vec3) -> u32 {
    (if d.x < 0.0 { 0 } else { 0x0404_0404 })
        | (if d.y < 0.0 { 0 } else { 0x0202_0202 })
        | (if d.z < 0.0 { 0 } else { 0x0101_0101 })
}

/// Conservative slabs (Ize 2013, "Robust BVH Ray Traversal", JCGT 2(2)):
/// a child's entry and exit distances, q·adj_inv + adj_o, round at most
/// about six times relative to |q·ext/d| + |(p − o)/d| ≤ 255·|adj_inv| +
/// |adj_o| (q ≤ 255); each slab is widened by 2^-20 (16 units in the last
/// place) of that bound, so a ray aimed at a vertex on a child box's plane
/// cannot leave the box by rounding before it enters it. As
/// `cw_intersect_node` in rt_software.glsl.
fn node_slab_pad(adj_inv: Vec3, adj_o: Vec3) -> Vec3 {
    (255.0 * adj_inv.abs() + adj_o.abs()) * (1.0 / 1_048_576.0)
}

/// `cw_intersect_node` of rt_software.glsl: the child hit mask of `node`
/// for a ray with inverse direction `inv_d`, slab entry clamped to `tmin`,
/// exit to `tmax`.
fn intersect_node(
    node: &CwBvhNode,
    o: Vec3,
    inv_d: Vec3,
    oct_inv4: u32,
    tmin: f32,
    tmax: f32,
) -> u32 {
    let p = node.p;
    let ext = Vec3::new(
        f32::from_bits((node.e[0] as u32) << 23),
        f32::from_bits((node.e[1] as u32) << 23),
        f32::from_bits((node.e[2] as u32) << 23),
    );
    let adj_inv = ext * inv_d;
    let adj_o = (p - o) * inv_d;
    let pad = node_slab_pad(adj_inv, adj_o);
    let (adj_lo, adj_hi) = (adj_o - pad, adj_o + pad);
    let neg = [inv_d.x < 0.0, inv_d.y < 0.0, inv_d.z < 0.0];
    let oct = oct_inv4 & 0xFF;
    let mut hit_mask = 0;
    for i in 0..8 {
        let meta = node.child_meta[i] as u32;
        if meta == 0 {
            continue;
        }
        let lo = [
            node.child_min_x[i],
            node.child_min_y[i],
            node.child_min_z[i],
        ];
        let hi = [
            node.child_max_x[i],
            node.child_max_y[i],
            node.child_max_z[i],
        ];
        let q = |k: usize, far: bool| (if neg[k] != far { hi[k] } else { lo[k] }) as f32;
        let qmin = Vec3::new(q(0, false), q(1, false), q(2, false));
        let qmax = Vec3::new(q(0, true), q(1, true), q(2, true));
        let t0 = qmin * adj_inv + adj_lo;
        let t1 = qmax * adj_inv + adj_hi;
        let tn = t0.x.max(t0.y).max(t0.z.max(tmin));
        let tf = t1.x.min(t1.y).min(t1.z.min(tmax));
        if tn <= tf {
            let inner = (meta & 0x18) == 0x18;
            let child_bits = meta >> 5;
            let bit_index = (meta ^ if inner { oct } else { 0 }) & 0x1F;
            hit_mask |= child_bits << bit_index;
        }
    }
    hit_mask
}

/// The software traversal of rt_software.glsl on the CPU, step for step:
/// `cw_traverse` (`two_level` false: `nodes` one CWBVH, leaf slots
/// triangles with their (instance, primitive)) or `cw_traverse_two_level`
/// (TLAS from node 0; a TLAS leaf's slot holds (instance, BLAS root) and the
/// object-from-world rows; the BLAS is walked with the object-space ray on
/// the same stack). The node test (`safe_inverse`, the ray's tmin as slab
/// entry), the child order, the stack of `TRAVERSAL_STACK_SIZE` entries and
/// the watertight triangle test are the GLSL's. Closest hit, no alpha test.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cpu_traverse(
    nodes: &[CwBvhNode],
    tri_ref: &[[u32; 2]],
    tri_verts: &[[f32; 4]],
    two_level: bool,
    wo: Vec3,
    wd: Vec3,
    tmin: f32,
    tmax: f32,
) -> Option<CpuHit> {
    const STACK: usize = TRAVERSAL_STACK_SIZE as usize;
    let mut h = CpuHit {
        t: tmax,
        instance: u32::MAX,
        prim: 0,
        bary: [0.0; 2],
    };
    let vec3 = |v: &[f32; 4]| Vec3::new(v[0], v[1], v[2]);
    let w_inv_d = safe_inverse(wd);
    let w_oct = octant_inv4(wd);
    let (mut o, mut d, mut inv_d, mut oct_inv4) = (wo, wd, w_inv_d, w_oct);
    // The flattened traversal's per-ray constants; the two-level one's are
    // set at each instance leaf for the object-space ray.
    let mut wr = WatertightRay::new(wo, wd);
    let mut stack = [[0u32; 2]; STACK];
    let mut sp = 0usize;
    let mut current = [0u32, 0x8000_0000];
    let mut prims = [0u32, 0];
    let mut found = false;
    let mut in_blas = !two_level;
    let mut inst = 0u32;
    let mut tlas_sp = 0usize;
    let mut tlas_current = [0u32; 2];
    let mut tlas_prims = [0u32; 2];
    loop {
        while prims[1] != 0 {
            let local = 31 - prims[1].leading_zeros();
            prims[1] &= !(1 << local);
            let k = (prims[0] + local) as usize;
            if in_blas {
                let v0w = tri_verts[3 * k][3];
                let [v0, v1, v2] = [0, 1, 2].map(|j| vec3(&tri_verts[3 * k + j]));
                if let Some((t, u, v)) = wr.intersect(v0, v1, v2) {
                    if t > tmin && t < h.t && !culled(v0w, v0, v1, v2, d) {
                        let [i, prim] = tri_ref[k];
                        h = CpuHit {
                            t,
                            instance: if two_level { inst } else { i },
                            prim,
                            bary: [u, v],
                        };
                        found = true;
                    }
                }
            } else {
                let [i, root] = tri_ref[k];
                let r = [0, 1, 2].map(|j| tri_verts[3 * k + j]);
                let row = |r: &[f32; 4], p: Vec3| r[0] * p.x + r[1] * p.y + r[2] * p.z;
                o = Vec3::new(
                    row(&r[0], wo) + r[0][3],
                    row(&r[1], wo) + r[1][3],
                    row(&r[2], wo) + r[2][3],
                );
                d = Vec3::new(row(&r[0], wd), row(&r[1], wd), row(&r[2], wd));
                inv_d = safe_inverse(d);
                oct_inv4 = octant_inv4(d);
                wr = WatertightRay::new(o, d);
                tlas_current = current;
                tlas_prims = prims;
                tlas_sp = sp;
                inst = i;
                current = [root, 0x8000_0000];
                prims = [0, 0];
                in_blas = true;
                break;
            }
        }
        if current[1] & 0xFF00_0000 != 0 {
            let hits_imask = current[1];
            let child_offset = 31 - hits_imask.leading_zeros();
            let child_base = current[0];
            current[1] &= !(1 << child_offset);
            if current[1] & 0xFF00_0000 != 0 && sp < STACK {
                stack[sp] = current;
                sp += 1;
            }
            let slot = (child_offset - 24) ^ (oct_inv4 & 0xFF);
            let relative = (hits_imask & !(u32::MAX << slot)).count_ones();
            let node = &nodes[(child_base + relative) as usize];
            let hit_mask = intersect_node(node, o, inv_d, oct_inv4, tmin, h.t);
            current = [
                node.child_base_idx,
                (hit_mask & 0xFF00_0000) | node.imask as u32,
            ];
            prims = [node.primitive_base_idx, hit_mask & 0x00FF_FFFF];
        } else {
            current = [0, 0];
        }
        if prims[1] == 0 && current[1] & 0xFF00_0000 == 0 {
            if two_level && in_blas && sp == tlas_sp {
                in_blas = false;
                (o, d, inv_d, oct_inv4) = (wo, wd, w_inv_d, w_oct);
                current = tlas_current;
                prims = tlas_prims;
                continue;
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            current = stack[sp];
        }
    }
    found.then_some(h)
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

/// Whether the traversal's triangle test can ever report `tri`: its edges'
/// cross product is finite and not zero (a triangle with a repeated vertex
/// has det = U + V + W = 0 for every ray, intersect_triangle in
/// rt_software.glsl).
/// Such triangles are left out of the software BVHs, which changes no hit
/// (triangles whose cross product merely rounds near zero are kept); kept
/// in, thousands of them sharing one centroid (a node scaled to zero) build
/// a chain deeper than the traversal stack.
pub(crate) fn hittable(tri: &Triangle) -> bool {
    let n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
    n.is_finite() && n != Vec3A::ZERO
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rt::TwoLevelBvh;
    use crate::scene::generate::{add_material, add_mesh};
    use crate::scene::{Material, Mesh};
    use glam::{Mat4, Quat};

    /// One mesh (`positions`, `indices`) placed at `transform`, double-sided
    /// or not.
    fn scene_of(positions: &[Vec3], indices: &[u32], double_sided: bool, transform: Mat4) -> Scene {
        let mut s = Scene::default();
        let mat = add_material(
            &mut s,
            Material {
                double_sided,
                ..Material::diffuse("m", Vec3::ONE)
            },
        );
        let mesh = Mesh {
            name: "mesh".into(),
            positions: positions.to_vec(),
            normals: vec![Vec3::Y; positions.len()],
            uvs: vec![glam::Vec2::ZERO; positions.len()],
            indices: indices.to_vec(),
            ..Default::default()
        };
        add_mesh(&mut s, mesh, mat, transform);
        s.validate().unwrap();
        s
    }

    /// The audit's unit quad at y = 0, split along its diagonal (0,0,0)–(1,0,1).
    fn unit_quad(double_sided: bool) -> Scene {
        scene_of(
            &[
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(0.0, 0.0, 1.0),
            ],
            &[0, 2, 1, 0, 3, 2],
            double_sided,
            Mat4::IDENTITY,
        )
    }

    /// Closest hit on both CPU structures (flattened and two-level); they
    /// must agree on whether and what they hit.
    fn both(s: &Scene, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<CpuHit> {
        let flat = SoftwareBvh::build(s);
        let two = TwoLevelBvh::build_at(s, flat.origin);
        let a = flat.closest_hit(o, d, tmin, tmax);
        let b = two.closest_hit(o, d, tmin, tmax);
        assert_eq!(
            a.map(|h| h.prim),
            b.map(|h| h.prim),
            "flattened {a:?} vs two-level {b:?}"
        );
        a
    }

    /// A small deterministic generator (xorshift64*) for the ray sets.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            ((self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32) / (1u64 << 24) as f32
        }
        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * self.next()
        }
    }

    #[test]
    fn the_audit_ray_through_the_shared_diagonal_hits() {
        let o = Vec3::new(-1.01, 1.88, 0.69);
        // The audit's f32 direction (0.650921642780304, −0.7583460807800293,
        // −0.03481684625148773 printed in f64).
        let d = Vec3::new(0.650_921_64, -0.758_346_1, -0.034_816_846);
        for ds in [false, true] {
            let h = both(&unit_quad(ds), o, d, 0.0, 1e30)
                .expect("the ray meets the quad's diagonal: one of its triangles is hit");
            assert_eq!(h.prim, 0, "exact arithmetic hits triangle 0: {h:?}");
            assert!((h.t - 1.88 / 0.758_346_1).abs() < 1e-5, "{h:?}");
        }
    }

    /// Rays from above and below aimed at points of the diagonal: every one
    /// hits one of the two triangles (Möller–Trumbore missed ~5 %).
    #[test]
    fn rays_aimed_at_a_shared_edge_never_miss() {
        let s = unit_quad(true);
        let flat = SoftwareBvh::build(&s);
        let two = TwoLevelBvh::build_at(&s, flat.origin);
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut misses = 0;
        let n = 4000;
        for _ in 0..n {
            let a = rng.next();
            let target = Vec3::new(a, 0.0, a);
            let o = Vec3::new(
                rng.range(-2.0, 3.0),
                rng.range(0.1, 3.0) * if rng.next() < 0.5 { -1.0 } else { 1.0 },
                rng.range(-2.0, 3.0),
            );
            let d = target - o;
            for bvh_hit in [
                flat.closest_hit(o, d, 0.0, 1e30),
                two.closest_hit(o, d, 0.0, 1e30),
            ] {
                if bvh_hit.is_none() {
                    misses += 1;
                }
            }
        }
        assert_eq!(
            misses,
            0,
            "{misses} of {} rays at the diagonal missed",
            2 * n
        );
    }

    /// An icosphere (subdivided icosahedron, shared vertices) of radius 1.
    fn icosphere(levels: u32) -> (Vec<Vec3>, Vec<u32>) {
        let t = (1.0 + 5f32.sqrt()) / 2.0;
        let mut p: Vec<Vec3> = [
            (-1.0, t, 0.0),
            (1.0, t, 0.0),
            (-1.0, -t, 0.0),
            (1.0, -t, 0.0),
            (0.0, -1.0, t),
            (0.0, 1.0, t),
            (0.0, -1.0, -t),
            (0.0, 1.0, -t),
            (t, 0.0, -1.0),
            (t, 0.0, 1.0),
            (-t, 0.0, -1.0),
            (-t, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
        .collect();
        let mut f: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..levels {
            let mut mid = std::collections::HashMap::new();
            let mut m = |a: u32, b: u32, p: &mut Vec<Vec3>| {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    p.push(((p[a as usize] + p[b as usize]) * 0.5).normalize());
                    p.len() as u32 - 1
                })
            };
            let mut g = Vec::new();
            for [a, b, c] in f {
                let (ab, bc, ca) = (m(a, b, &mut p), m(b, c, &mut p), m(c, a, &mut p));
                g.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            f = g;
        }
        (p, f.concat())
    }

    /// `n` rays from inside the icosphere `(p, idx)` placed by `m` (origins
    /// near its centre) at points of its edges, every 8th at a vertex, as
    /// (origin, direction, the edge's endpoints), in the frame of `origin`.
    fn rays_at_edges(
        p: &[Vec3],
        idx: &[u32],
        m: Mat4,
        origin: DVec3,
        seed: u64,
        n: usize,
    ) -> Vec<(Vec3, Vec3, [u32; 2])> {
        let mut rng = Rng(seed);
        let tris = idx.len() / 3;
        let place = |q: Vec3| (m.as_dmat4().transform_point3(q.as_dvec3()) - origin).as_vec3();
        (0..n)
            .map(|k| {
                let tri = (rng.next() * tris as f32) as usize % tris;
                let e = (rng.next() * 3.0) as usize % 3;
                let (ia, ib) = (idx[3 * tri + e], idx[3 * tri + (e + 1) % 3]);
                let (a, b) = (p[ia as usize], p[ib as usize]);
                let local = if k % 8 == 0 { a } else { a.lerp(b, rng.next()) };
                let centre = Vec3::new(
                    rng.range(-0.3, 0.3),
                    rng.range(-0.3, 0.3),
                    rng.range(-0.3, 0.3),
                );
                let o = place(centre);
                (o, place(local) - o, [ia, ib])
            })
            .collect()
    }

    /// Möller–Trumbore as the software backend had it (the test's
    /// counter-example): (t, u, v) or none.
    fn moller_trumbore(o: Vec3, d: Vec3, v0: Vec3, e1: Vec3, e2: Vec3) -> Option<(f32, f32, f32)> {
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

    /// The triangle test alone (every triangle, no BVH) on a closed mesh
    /// with generic coordinates (an icosphere under a scale, rotation and
    /// translation): each ray from inside at an edge or a vertex hits at
    /// least one triangle, in front of it, because neighbours read their
    /// shared vertices as the same stored points. The same rays through
    /// Möller–Trumbore (vertex and edges) fall through several per cent.
    #[test]
    fn the_triangle_test_leaves_no_crack_in_a_closed_mesh() {
        let (p, idx) = icosphere(2);
        let m = generic_transform();
        // World vertices as `rays_at_edges` places its targets.
        let world: Vec<Vec3> = p
            .iter()
            .map(|&v| m.as_dmat4().transform_point3(v.as_dvec3()).as_vec3())
            .collect();
        let tris: Vec<[Vec3; 3]> = idx
            .chunks(3)
            .map(|t| [0, 1, 2].map(|i| world[t[i] as usize]))
            .collect();
        let rays = rays_at_edges(&p, &idx, m, DVec3::ZERO, 7, 20000);
        let (mut wt_miss, mut mt_miss) = (0, 0);
        for &(o, d, _) in &rays {
            let wr = WatertightRay::new(o, d);
            wt_miss += !tris
                .iter()
                .any(|&[a, b, c]| wr.intersect(a, b, c).is_some_and(|h| h.0 > 0.0))
                as u32;
            mt_miss += !tris
                .iter()
                .any(|&[a, b, c]| moller_trumbore(o, d, a, b - a, c - a).is_some_and(|h| h.0 > 0.0))
                as u32;
        }
        assert_eq!(
            wt_miss,
            0,
            "watertight: {wt_miss} of {} rays missed",
            rays.len()
        );
        assert!(
            mt_miss > rays.len() as u32 / 50,
            "the rays are hard: Möller–Trumbore missed {mt_miss}"
        );
    }

    /// A scale, rotation and translation with nothing exact about it.
    fn generic_transform() -> Mat4 {
        Mat4::from_scale_rotation_translation(
            Vec3::new(0.7, 1.3, 0.9),
            Quat::from_axis_angle(Vec3::new(0.3, -1.0, 0.6).normalize(), 0.83),
            Vec3::new(0.37, -1.91, 2.63),
        )
    }

    /// Rays from inside the mesh `(p, idx)` placed by `m`, aimed at its
    /// edges and vertices (`rays_at_edges`, 6000): how many miss through the
    /// flattened and the two-level BVH, and how many were traced.
    fn misses_through_both(p: &[Vec3], idx: &[u32], m: Mat4) -> (usize, usize, usize) {
        let s = scene_of(p, idx, true, m);
        let flat = SoftwareBvh::build(&s);
        let two = TwoLevelBvh::build_at(&s, flat.origin);
        let rays = rays_at_edges(p, idx, m, flat.origin, 0x1234_5678_9ABC_DEF1, 6000);
        let miss = |f: &dyn Fn(Vec3, Vec3) -> bool| rays.iter().filter(|r| f(r.0, r.1)).count();
        (
            miss(&|o, d| flat.closest_hit(o, d, 0.0, 1e30).is_none()),
            miss(&|o, d| two.closest_hit(o, d, 0.0, 1e30).is_none()),
            rays.len(),
        )
    }

    /// Rays from inside a closed mesh (generic coordinates) aimed at its
    /// edges and vertices, through both BVHs: none misses.
    #[test]
    fn rays_from_inside_a_closed_mesh_aimed_at_edges_and_vertices_never_miss() {
        let (p, idx) = icosphere(2);
        let (a, b, n) = misses_through_both(&p, &idx, Mat4::IDENTITY);
        assert!(
            a == 0 && b == 0,
            "{a} (flattened) and {b} (two-level) of {n} rays from inside missed"
        );
    }

    /// The icosphere placed by a generic transform, so that the flattened
    /// BVH holds world-space vertices nothing rounds back exactly: rays from
    /// inside aimed at its edges and vertices never miss, through either
    /// structure. (Until session 48 a triangle was stored as v0 and its
    /// edges, and the test read its vertices as v0 + e1, v0 + e2, which for
    /// ~3 % of the Cornell box's triangles is an ulp off the vertex a
    /// neighbour stores: 2 of these 6000 rays fell between two triangles.)
    #[test]
    fn rays_at_the_vertices_of_a_transformed_mesh_never_miss() {
        let (p, idx) = icosphere(2);
        let (a, b, n) = misses_through_both(&p, &idx, generic_transform());
        assert!(
            a == 0 && b == 0,
            "{a} (flattened) and {b} (two-level) of {n} rays missed"
        );
    }

    /// The node test (`cw_intersect_node`, its CPU twin here) is
    /// conservative: vertices on a 2^-10 grid lie exactly on quantized
    /// child-box planes, and before session 48 a ray aimed at such a vertex
    /// could leave the box by rounding before it entered it (2 of these
    /// 6000 rays missed, on the CPU and the GPU alike, although the triangle
    /// test hits them). The slabs are now widened by a bound on the rounding
    /// of their entry and exit distances (`node_slab_pad`).
    #[test]
    fn rays_at_vertices_on_box_planes_are_not_culled_by_the_node_test() {
        let (p, idx) = icosphere(2);
        let p: Vec<Vec3> = p.iter().map(|v| (*v * 1024.0).round() / 1024.0).collect();
        let (a, b, _) = misses_through_both(&p, &idx, Mat4::IDENTITY);
        assert!(
            a == 0 && b == 0,
            "{a} (flattened) and {b} (two-level) missed"
        );
    }

    /// A triangle pair facing each of ±X, ±Y, ±Z (so every dominant axis
    /// kz, with d[kz] of either sign: the kx/ky swap that keeps the
    /// winding), seen along a tilted ray: from the front it is hit at the
    /// right t and barycentrics; from behind a single-sided one lets the
    /// ray through (`culled`: w·(e1 × e2)·d > 0) and a double-sided one is
    /// hit.
    #[test]
    fn every_dominant_axis_and_sign_hits_fronts_and_culls_backs() {
        let axes = [Vec3::X, Vec3::Y, Vec3::Z];
        for k in 0..3 {
            for sign in [1.0f32, -1.0] {
                let n = axes[k] * sign;
                let (mut eu, mut ev) = (axes[(k + 1) % 3], axes[(k + 2) % 3]);
                if sign < 0.0 {
                    std::mem::swap(&mut eu, &mut ev);
                }
                assert_eq!(eu.cross(ev), n);
                let corner = Vec3::new(0.2, -0.3, 0.1) - eu - ev;
                let g = crate::scene::generate::grid(
                    "q",
                    corner,
                    eu * 2.0,
                    ev * 2.0,
                    1,
                    1,
                    glam::Vec2::ONE,
                );
                let tilt = eu * 0.23 - ev * 0.17;
                for double_sided in [false, true] {
                    let s = scene_of(&g.positions, &g.indices, double_sided, Mat4::IDENTITY);
                    let what = format!("normal {n}, double-sided {double_sided}");
                    // From the front: d against n.
                    let o = Vec3::new(0.2, -0.3, 0.1) + n * 3.0 + eu * 0.05;
                    let d = (tilt - n) * 0.7;
                    let h =
                        both(&s, o, d, 0.0, 1e30).unwrap_or_else(|| panic!("{what}: front missed"));
                    let p = o + h.t * d;
                    let [a, b, c] = s.meshes[0].triangle(h.prim as usize);
                    let q = a + h.bary[0] * (b - a) + h.bary[1] * (c - a);
                    assert!((p - q).length() < 1e-5, "{what}: {p} vs barycentric {q}");
                    assert!(
                        ((p - corner).dot(n)).abs() < 1e-5,
                        "{what}: {p} off the plane"
                    );
                    // From behind.
                    let h = both(&s, o - n * 6.0, (tilt + n) * 0.7, 0.0, 1e30);
                    assert_eq!(h.is_some(), double_sided, "{what}: from behind {h:?}");
                }
            }
        }
    }

    /// (a) A direction with negative-zero components (−Vec3::Y) is the
    /// direction straight down: it hits the quad below.
    #[test]
    fn negative_zero_direction_components_hit() {
        let h = both(
            &unit_quad(false),
            Vec3::new(0.3, 1.0, 0.6),
            -Vec3::Y,
            0.0,
            1e30,
        )
        .expect("-Y from above the quad hits it");
        assert!((h.t - 1.0).abs() < 1e-6, "{h:?}");
    }

    /// (b) The node test honours the ray's tmin (obvhs clamped entry at
    /// 1e-4): a hit at t = 5e-5 with tmin 0 is found, and tmin above it
    /// skips it.
    #[test]
    fn a_hit_closer_than_1e_4_is_found() {
        let s = unit_quad(false);
        let o = Vec3::new(0.3, 5e-5, 0.6);
        let d = Vec3::new(0.0, -1.0, 0.0);
        let h = both(&s, o, d, 0.0, 1e30).expect("hit at t = 5e-5");
        assert!((h.t - 5e-5).abs() < 1e-9, "{h:?}");
        assert!(both(&s, o, d, 6e-5, 1e30).is_none(), "tmin beyond the hit");
    }

    /// (c) An origin 1 µm inside a slab 2 µm thick, direction almost
    /// parallel to it (d.x = 1e-8): the ray stays inside the slab until
    /// t = 100, so the triangle at t = 20 is hit (obvhs replaced 1/1e-8 by
    /// 8.4e6 and left the slab at t ≈ 8.4).
    #[test]
    fn a_thin_slab_is_left_where_the_ray_leaves_it() {
        let s = scene_of(
            &[
                Vec3::new(0.0, 0.0, 20.0),
                Vec3::new(2e-6, 0.0, 20.0),
                Vec3::new(0.0, 1.0, 20.0),
            ],
            &[0, 1, 2],
            true,
            Mat4::IDENTITY,
        );
        let h = both(
            &s,
            Vec3::new(1e-6, 0.1, 0.0),
            Vec3::new(1e-8, 0.0, 1.0),
            0.0,
            1e30,
        )
        .expect("the thin triangle at t = 20 is hit");
        assert!((h.t - 20.0).abs() < 1e-5, "{h:?}");
    }
}
