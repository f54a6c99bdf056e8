//! Vertex-attribute repair and generation shared by the importer and the
//! generators: area-weighted and flat normals, MikkTSpace tangents, triangle strips
//! and fans as lists, and removal of triangles that touch non-finite vertices.

use super::Mesh;
use glam::{Vec2, Vec3, Vec4};

/// Area-weighted vertex normals: each triangle adds its unnormalised face normal
/// (|e1 × e2| = 2 × area) to its three vertices. Vertices with no (non-degenerate)
/// triangle get +Y so the result is always a finite unit vector.
pub fn generate_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
        let face = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        n[a] += face;
        n[b] += face;
        n[c] += face;
    }
    n.into_iter()
        .map(|v| v.try_normalize().unwrap_or(Vec3::Y))
        .collect()
}

/// Flat normals for a primitive without NORMAL (glTF 2.0 §3.7.2.1: "When
/// normals are not specified, client implementations MUST calculate flat
/// normals and the provided tangents (if present) MUST be ignored"). Every
/// triangle gets three vertices of its own (the other attributes copied)
/// whose normal is the face's; supplied tangents are dropped (the caller
/// generates MikkTSpace ones where a normal texture needs them). A
/// degenerate triangle (no face normal) gets +Y, as [`generate_normals`]
/// gives an unused vertex.
pub fn flat_normals(mesh: &mut Mesh) {
    let corners = std::mem::take(&mut mesh.indices);
    fn pick<T: Copy>(v: &[T], corners: &[u32]) -> Vec<T> {
        if v.is_empty() {
            Vec::new()
        } else {
            corners.iter().map(|&i| v[i as usize]).collect()
        }
    }
    mesh.positions = pick(&mesh.positions, &corners);
    mesh.uvs = pick(&mesh.uvs, &corners);
    mesh.uvs2 = pick(&mesh.uvs2, &corners);
    mesh.colors = pick(&mesh.colors, &corners);
    mesh.tangents = Vec::new();
    mesh.normals = mesh
        .positions
        .chunks_exact(3)
        .flat_map(|t| {
            let n = (t[1] - t[0])
                .cross(t[2] - t[0])
                .try_normalize()
                .unwrap_or(Vec3::Y);
            [n; 3]
        })
        .collect();
    mesh.indices = (0..mesh.positions.len() as u32).collect();
}

/// MikkTSpace tangents (the algorithm glTF 2.0 asks for when a primitive has
/// no TANGENT), computed by the `mikktspace` crate, the reference
/// implementation's Rust port, for an indexed triangle list.
///
/// **uv convention.** MikkTSpace takes uvs with v pointing up the image
/// (Blender's convention, where it comes from); glTF's v points down. It is
/// therefore given (u, −v) (equivalent to 1 − v for derivatives, and exact),
/// which makes w the sign glTF uses: bitangent = cross(normal, tangent.xyz) ×
/// w points *up* the image (towards −v), where a normal texture's green
/// channel points. An unmirrored mapping gets w = +1, as in tangents that
/// Blender exports (glTF-Sample-Models issue 174; glTF-Transform's `tangents`
/// flips w of MikkTSpace run on raw glTF uvs for the same reason).
///
/// MikkTSpace returns one tangent per triangle corner. Where the corners
/// sharing a vertex get different tangents (a uv mirror seam whose vertices
/// share their uvs), the vertex is split: a copy with the other tangent is
/// appended and those corners' indices are rewritten, so `mesh` may gain
/// vertices. A tangent MikkTSpace could not determine (degenerate uvs, no
/// uvs) falls back to a unit vector perpendicular to the normal with w = +1.
/// Requires `mesh.normals` (unit) and `mesh.uvs`, one per position.
pub fn generate_tangents(mesh: &mut Mesh) {
    generate_tangents_for(mesh, false);
}

/// As [`generate_tangents`], for the uvs of the second channel
/// (`mesh.uvs2`) where `second` (a normal texture that reads it).
pub fn generate_tangents_for(mesh: &mut Mesh, second: bool) {
    let uvs = if second {
        mesh.uvs2.clone()
    } else {
        mesh.uvs.clone()
    };
    generate_tangents_from(mesh, &uvs);
}

/// MikkTSpace tangents for the meshes whose material's graphs output a
/// tangent-space normal (`normal_tangent`: a KHR_texture_procedurals
/// `normalTexture`, an `.mtlx` output, the texture-space library graphs)
/// and that have none: glTF 2.0 §3.7.2.1, "When tangents are not specified,
/// client implementations SHOULD calculate tangents using default
/// MikkTSpace algorithms with the specified vertex positions, normals, and
/// texture coordinates associated with the normal texture" — here the
/// graph is the normal texture, and its uvs are the lowest texture
/// coordinate set it reads, untransformed (the channel `SceneGraphs`
/// keeps it in; set 0 where it reads none). Until session 50 such meshes
/// got no tangents and material_at kept the interpolated normal: the
/// graphs' bumps vanished without a word (the procedural Cornell box, any
/// glTF without TANGENT). Returns the number of meshes given tangents.
pub fn generate_graph_normal_tangents(scene: &mut super::Scene) -> usize {
    use crate::materials::binding::Slot;
    let graphs = &scene.graphs;
    let mut generated = 0;
    for mesh in &mut scene.meshes {
        let m = mesh.material;
        if !mesh.tangents.is_empty()
            || !graphs
                .of_material(m)
                .iter()
                .any(|b| b.slot == Slot::NormalTangent)
        {
            continue;
        }
        let sets = graphs.uv_sets_of(m);
        let set = if sets == 0 { 0 } else { sets.trailing_zeros() };
        let swapped = graphs.uv_swapped.contains(&m);
        let second = if swapped { set == 0 } else { set == 1 };
        let channel = if second { &mesh.uvs2 } else { &mesh.uvs };
        if channel.len() != mesh.positions.len() || mesh.normals.len() != mesh.positions.len() {
            continue;
        }
        generate_tangents_for(mesh, second);
        generated += 1;
    }
    generated
}

/// As [`generate_tangents`], for the uvs `uvs` (one per vertex): those a
/// normal texture reads through a map of a channel (gltf_uv `UvAffine`).
pub fn generate_tangents_from(mesh: &mut Mesh, uvs: &[Vec2]) {
    struct Corners<'a> {
        positions: &'a [Vec3],
        normals: &'a [Vec3],
        uvs: &'a [Vec2],
        indices: &'a [u32],
        /// Per triangle corner; NaN where MikkTSpace set nothing.
        out: Vec<[f32; 4]>,
    }
    impl Corners<'_> {
        fn vertex(&self, face: usize, vert: usize) -> usize {
            self.indices[3 * face + vert] as usize
        }
    }
    impl mikktspace::Geometry for Corners<'_> {
        fn num_faces(&self) -> usize {
            self.indices.len() / 3
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.positions[self.vertex(face, vert)].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            self.normals[self.vertex(face, vert)].to_array()
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            let uv = self.uvs[self.vertex(face, vert)];
            [uv.x, -uv.y]
        }
        fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
            self.out[3 * face + vert] = tangent;
        }
    }
    let corners = mesh.indices.len() / 3 * 3;
    let mut geo = Corners {
        positions: &mesh.positions,
        normals: &mesh.normals,
        uvs,
        indices: &mesh.indices[..corners],
        out: vec![[f32::NAN; 4]; corners],
    };
    if corners > 0 {
        // `false` (nothing usable) leaves the NaNs: every tangent falls back.
        mikktspace::generate_tangents(&mut geo);
    }
    let out = geo.out;
    // Orthonormal to the vertex normal, w exactly ±1.
    let finish = |n: Vec3, t: [f32; 4]| -> Vec4 {
        let t3 = Vec3::new(t[0], t[1], t[2]);
        match (t3 - n * n.dot(t3)).try_normalize() {
            Some(t3) => t3.extend(if t[3] < 0.0 { -1.0 } else { 1.0 }),
            None => n.any_orthonormal_vector().extend(1.0),
        }
    };
    let n = mesh.positions.len();
    let mut tangents: Vec<Vec4> = mesh
        .normals
        .iter()
        .map(|&nv| nv.any_orthonormal_vector().extend(1.0))
        .collect();
    let mut first: Vec<Option<[u32; 4]>> = vec![None; n];
    let mut copies: std::collections::HashMap<(u32, [u32; 4]), u32> = Default::default();
    for (c, t) in out.into_iter().enumerate() {
        let v = mesh.indices[c] as usize;
        let t = finish(mesh.normals[v], t);
        let key = t.to_array().map(f32::to_bits);
        match first[v] {
            None => {
                first[v] = Some(key);
                tangents[v] = t;
            }
            Some(k) if k == key => {}
            Some(_) => {
                let next = mesh.positions.len();
                let Ok(next) = u32::try_from(next) else {
                    continue; // 2^32 vertices: keep the first tangent.
                };
                let copy = *copies.entry((v as u32, key)).or_insert_with(|| {
                    mesh.positions.push(mesh.positions[v]);
                    mesh.normals.push(mesh.normals[v]);
                    mesh.uvs.push(mesh.uvs[v]);
                    if !mesh.uvs2.is_empty() {
                        mesh.uvs2.push(mesh.uvs2[v]);
                    }
                    if !mesh.colors.is_empty() {
                        mesh.colors.push(mesh.colors[v]);
                    }
                    tangents.push(t);
                    next
                });
                mesh.indices[c] = copy;
            }
        }
    }
    mesh.tangents = tangents;
}

/// Triangle list of a glTF TRIANGLE_STRIP (glTF 2.0, "Topology types"):
/// triangle i is (vᵢ, vᵢ₊₁, vᵢ₊₂) for even i and (vᵢ, vᵢ₊₂, vᵢ₊₁) for odd i,
/// so every triangle keeps the first one's winding. Degenerate triangles
/// (strip stitching) are kept; fewer than 3 vertices give none.
pub fn strip_to_triangles(strip: &[u32]) -> Vec<u32> {
    let n = strip.len().saturating_sub(2);
    let mut out = Vec::with_capacity(3 * n);
    for i in 0..n {
        if i % 2 == 0 {
            out.extend([strip[i], strip[i + 1], strip[i + 2]]);
        } else {
            out.extend([strip[i], strip[i + 2], strip[i + 1]]);
        }
    }
    out
}

/// Triangle list of a glTF TRIANGLE_FAN (glTF 2.0, "Topology types"):
/// triangle i is (vᵢ₊₁, vᵢ₊₂, v₀). Fewer than 3 vertices give none.
pub fn fan_to_triangles(fan: &[u32]) -> Vec<u32> {
    let n = fan.len().saturating_sub(2);
    let mut out = Vec::with_capacity(3 * n);
    for i in 0..n {
        out.extend([fan[i + 1], fan[i + 2], fan[0]]);
    }
    out
}

/// Removes every triangle that references a vertex with a non-finite attribute
/// (position, normal, uv, tangent or colour), then drops the vertices no triangle uses
/// any more, so no NaN or Inf reaches the GPU or the BVH builder.
/// Returns the number of triangles removed (0 leaves the mesh untouched).
pub fn drop_non_finite_triangles(mesh: &mut Mesh) -> usize {
    let bad: Vec<bool> = (0..mesh.positions.len())
        .map(|v| {
            !mesh.positions[v].is_finite()
                || mesh.normals.get(v).is_some_and(|n| !n.is_finite())
                || mesh.uvs.get(v).is_some_and(|n| !n.is_finite())
                || mesh.uvs2.get(v).is_some_and(|n| !n.is_finite())
                || mesh.tangents.get(v).is_some_and(|n| !n.is_finite())
                || mesh.colors.get(v).is_some_and(|n| !n.is_finite())
        })
        .collect();
    if !bad.iter().any(|&b| b) {
        return 0;
    }
    let before = mesh.indices.len() / 3;
    let kept: Vec<u32> = mesh
        .indices
        .chunks_exact(3)
        .filter(|t| t.iter().all(|&i| !bad[i as usize]))
        .flatten()
        .copied()
        .collect();
    let removed = before - kept.len() / 3;
    // Compact: keep only vertices referenced by a surviving triangle.
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    let mut order = Vec::new();
    for &i in &kept {
        if remap[i as usize] == u32::MAX {
            remap[i as usize] = order.len() as u32;
            order.push(i as usize);
        }
    }
    fn pick<T: Copy>(v: &[T], order: &[usize]) -> Vec<T> {
        if v.is_empty() {
            Vec::new()
        } else {
            order.iter().map(|&i| v[i]).collect()
        }
    }
    mesh.positions = pick(&mesh.positions, &order);
    mesh.normals = pick(&mesh.normals, &order);
    mesh.uvs = pick(&mesh.uvs, &order);
    mesh.uvs2 = pick(&mesh.uvs2, &order);
    mesh.tangents = pick(&mesh.tangents, &order);
    mesh.colors = pick(&mesh.colors, &order);
    mesh.indices = kept.iter().map(|&i| remap[i as usize]).collect();
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> (Vec<Vec3>, Vec<Vec2>, Vec<u32>) {
        (
            vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            vec![
                Vec2::new(0.0, 1.0),
                Vec2::new(1.0, 1.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(0.0, 0.0),
            ],
            vec![0, 1, 2, 0, 2, 3],
        )
    }

    fn mesh(p: Vec<Vec3>, uvs: Vec<Vec2>, indices: Vec<u32>) -> Mesh {
        let normals = generate_normals(&p, &indices);
        Mesh {
            positions: p,
            normals,
            uvs,
            indices,
            ..Default::default()
        }
    }

    /// The bitangent the shader builds (material.glsl: cross(N, T) × sign(w)).
    fn bitangent(n: Vec3, t: Vec4) -> Vec3 {
        n.cross(t.truncate()) * t.w.signum()
    }

    #[test]
    fn normals_face_plus_z_and_tangents_follow_u() {
        // u along +X, v down the image = along −Y (glTF: v = 0 is the image top).
        let (p, uv, idx) = quad();
        let mut m = mesh(p, uv, idx);
        assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
        generate_tangents(&mut m);
        assert_eq!(m.positions.len(), 4, "nothing to split");
        for (t, n) in m.tangents.iter().zip(&m.normals) {
            assert!((t.truncate() - Vec3::X).length() < 1e-6, "{t}");
            // Unmirrored mapping: w = +1, and the bitangent points up the
            // image (−v = +Y), where a normal map's green channel points.
            assert_eq!(t.w, 1.0);
            assert!((bitangent(*n, *t) - Vec3::Y).length() < 1e-6);
        }
    }

    #[test]
    fn mirrored_u_flips_tangent_and_w() {
        let (p, mut uv, idx) = quad();
        for t in &mut uv {
            t.x = 1.0 - t.x;
        }
        let mut m = mesh(p, uv, idx);
        generate_tangents(&mut m);
        for (t, n) in m.tangents.iter().zip(&m.normals) {
            assert!((t.truncate() + Vec3::X).length() < 1e-6, "{t}");
            assert_eq!(t.w, -1.0);
            // Still up the image: the mirror is in u only.
            assert!((bitangent(*n, *t) - Vec3::Y).length() < 1e-6);
        }
    }

    #[test]
    fn mirror_seam_sharing_vertices_is_split() {
        // Two unit quads side by side sharing the edge x = 1; the right one's
        // u is mirrored, so the shared vertices (u = 1 on both sides) need
        // tangent +X on the left and −X on the right.
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
        ];
        let uv = vec![
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 0.0),
            Vec2::new(0.0, 1.0),
            Vec2::new(0.0, 0.0),
        ];
        let idx = vec![0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2];
        let mut m = mesh(p, uv, idx);
        generate_tangents(&mut m);
        assert_eq!(m.positions.len(), 8, "vertices 1 and 2 split once each");
        assert_eq!(m.tangents.len(), 8);
        for (tri, want) in [(0, 1.0), (1, 1.0), (2, -1.0), (3, -1.0)] {
            for &i in &m.indices[3 * tri..3 * tri + 3] {
                let t = m.tangents[i as usize];
                assert!(
                    (t.truncate() - Vec3::X * want).length() < 1e-5,
                    "{tri}: {t}"
                );
                assert_eq!(t.w, want, "triangle {tri}");
            }
        }
        // The copies are the same points: the triangles did not move.
        assert_eq!(m.triangle(2)[0], Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(m.triangle(3)[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(m.uvs[m.indices[6] as usize], Vec2::new(1.0, 1.0));
    }

    #[test]
    fn cylinder_tangents_follow_the_circumference() {
        // Open cylinder about +Y, radius 1, u = θ / 2π around, v = 1 − y down
        // the image; duplicate seam column at θ = 2π (u = 1).
        let (seg, rows) = (24usize, 3usize);
        let (mut p, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new());
        for r in 0..=rows {
            for s in 0..=seg {
                let th = s as f32 / seg as f32 * std::f32::consts::TAU;
                let y = r as f32 / rows as f32;
                // Outward normal, counter-clockwise seen from outside:
                // position (sin θ, y, cos θ) moves along +tangent (cos θ, 0, −sin θ).
                p.push(Vec3::new(th.sin(), y, th.cos()));
                uv.push(Vec2::new(s as f32 / seg as f32, 1.0 - y));
            }
        }
        let w = (seg + 1) as u32;
        for r in 0..rows as u32 {
            for s in 0..seg as u32 {
                let a = r * w + s;
                idx.extend([a, a + 1, a + w + 1, a, a + w + 1, a + w]);
            }
        }
        // The file's normals: the exact radial directions.
        let normals = p
            .iter()
            .map(|q| Vec3::new(q.x, 0.0, q.z).normalize())
            .collect();
        let mut m = Mesh {
            positions: p,
            normals,
            uvs: uv,
            indices: idx,
            ..Default::default()
        };
        generate_tangents(&mut m);
        assert_eq!(m.positions.len(), (rows + 1) * (seg + 1), "no splits");
        // Every face's dP/du is a horizontal chord; projected onto the plane
        // perpendicular to a vertex's radial normal, any horizontal direction
        // becomes ± the circumferential one, so MikkTSpace's average is the
        // analytic tangent up to rounding (1e-5: a few ulps of the trigonometry).
        for (v, t) in m.tangents.iter().enumerate() {
            let radial = m.normals[v];
            let analytic = Vec3::new(radial.z, 0.0, -radial.x);
            assert!(t.truncate().dot(m.normals[v]).abs() < 1e-5, "{v}: not ⟂ N");
            assert!(
                (t.truncate() - analytic).length() < 1e-5,
                "{v}: {t} vs {analytic}"
            );
            assert_eq!(t.w, 1.0, "{v}");
        }
    }

    #[test]
    fn degenerate_uvs_fall_back_to_a_perpendicular_unit_tangent() {
        let (p, _, idx) = quad();
        let mut m = mesh(p, vec![Vec2::ZERO; 4], idx);
        generate_tangents(&mut m);
        for (t, n) in m.tangents.iter().zip(&m.normals) {
            assert!(t.is_finite());
            assert!((t.truncate().length() - 1.0).abs() < 1e-6);
            assert!(t.truncate().dot(*n).abs() < 1e-6);
            assert_eq!(t.w.abs(), 1.0);
        }
    }

    #[test]
    fn tangents_stay_finite_unit_and_perpendicular_on_messy_meshes() {
        // Deterministic pseudo-random meshes: repeated indices (zero-area
        // triangles), snapped coincident/collinear points, zero uvs and
        // shared vertices whose faces disagree on uv orientation.
        let mut state = 0x2545_f491_u32;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        for case in 0..60 {
            let nv = 3 + (rnd() * 40.0) as usize;
            let mut p = Vec::with_capacity(nv);
            let mut uv = Vec::with_capacity(nv);
            for _ in 0..nv {
                let q = Vec3::new(rnd(), rnd(), rnd());
                p.push(if rnd() < 0.2 { q.round() } else { q });
                uv.push(if rnd() < 0.3 {
                    Vec2::ZERO
                } else {
                    Vec2::new(4.0 * rnd() - 2.0, rnd())
                });
            }
            let nt = 1 + (rnd() * 60.0) as usize;
            let idx: Vec<u32> = (0..3 * nt)
                .map(|_| (rnd() * nv as f32) as u32 % nv as u32)
                .collect();
            let mut m = mesh(p, uv, idx);
            let before: Vec<[Vec3; 3]> = (0..m.triangle_count()).map(|t| m.triangle(t)).collect();
            generate_tangents(&mut m);
            let n = m.positions.len();
            assert!(n >= nv, "case {case}");
            assert_eq!((m.normals.len(), m.uvs.len(), m.tangents.len()), (n, n, n));
            assert!(m.indices.iter().all(|&i| (i as usize) < n), "case {case}");
            let after: Vec<[Vec3; 3]> = (0..m.triangle_count()).map(|t| m.triangle(t)).collect();
            assert_eq!(before, after, "case {case}: splitting moved a triangle");
            for (t, nrm) in m.tangents.iter().zip(&m.normals) {
                assert!(t.is_finite(), "case {case}: {t}");
                // Unit and perpendicular up to f32 rounding of a normalisation.
                assert!(
                    (t.truncate().length() - 1.0).abs() < 1e-5,
                    "case {case}: {t}"
                );
                assert!(
                    t.truncate().dot(*nrm).abs() < 1e-5,
                    "case {case}: {t} vs {nrm}"
                );
                assert_eq!(t.w.abs(), 1.0, "case {case}");
            }
        }
    }

    #[test]
    fn strips_and_fans_follow_the_gltf_topology_rules() {
        // glTF-Sample-Assets MeshPrimitiveModes: a hexagon around vertex 0,
        // vertex k at angle 60°·(k − 1) − 30°; each mode's indices cover it
        // with counter-clockwise triangles.
        let p: Vec<Vec3> = std::iter::once(Vec3::ZERO)
            .chain((1..=6).map(|k| {
                let a = (60.0 * (k - 1) as f32 - 30.0).to_radians();
                Vec3::new(a.cos(), a.sin(), 0.0)
            }))
            .collect();
        let strip = strip_to_triangles(&[2, 3, 1, 4, 6, 5]);
        assert_eq!(strip, vec![2, 3, 1, 3, 4, 1, 1, 4, 6, 4, 5, 6]);
        let fan = fan_to_triangles(&[0, 1, 2, 3, 4, 5, 6, 1]);
        assert_eq!(fan.len(), 18);
        assert_eq!(&fan[..6], &[1, 2, 0, 2, 3, 0]);
        for (name, tris) in [("strip", &strip), ("fan", &fan)] {
            let mut area = 0.0;
            for t in tris.chunks_exact(3) {
                let [a, b, c] = [0, 1, 2].map(|k| p[t[k] as usize]);
                let z = (b - a).cross(c - a).z;
                assert!(z > 0.0, "{name}: {t:?} is clockwise");
                area += z / 2.0;
            }
            // Both cover the hexagon of circumradius 1 once: area 3√3/2
            // (the strip with 4 triangles between outer vertices, vertex 0 unused).
            let want = 1.5 * 3f32.sqrt();
            assert!((area - want).abs() < 1e-5, "{name}: area {area}");
        }
        assert!(strip_to_triangles(&[0, 1]).is_empty());
        assert!(fan_to_triangles(&[]).is_empty());
        // Stitched strips keep their degenerate triangles (a renderer ignores them).
        assert_eq!(strip_to_triangles(&[0, 1, 1, 2]), vec![0, 1, 1, 1, 2, 1]);
    }

    #[test]
    fn nan_vertices_drop_their_triangles() {
        let (mut p, uv, idx) = quad();
        p[3].x = f32::NAN;
        let n = generate_normals(&p, &idx);
        let mut m = Mesh {
            positions: p,
            normals: n,
            uvs: uv,
            indices: idx,
            ..Default::default()
        };
        assert_eq!(drop_non_finite_triangles(&mut m), 1);
        assert_eq!(m.indices, vec![0, 1, 2]);
        assert_eq!(m.positions.len(), 3);
        assert!(m.positions.iter().all(|p| p.is_finite()));
    }
}
