//! Vertex-attribute repair and generation shared by the importer and the
//! generators: area-weighted normals, per-vertex tangents from uv derivatives,
//! and removal of triangles that touch non-finite vertices.

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

/// Per-vertex tangents from uv derivatives (Lengyel 2001, "Computing Tangent
/// Space Basis Vectors for an Arbitrary Mesh"): per triangle solve
/// `[e1 e2] = [T B] [Δuv1 Δuv2]`, accumulate T and B per vertex, Gram-Schmidt T
/// against the normal and store the handedness sign(dot(N × T, B)) in w
/// (glTF: bitangent = cross(normal, tangent.xyz) * w).
/// Degenerate uv mappings fall back to any vector perpendicular to the normal.
pub fn generate_tangents(
    positions: &[Vec3],
    normals: &[Vec3],
    uvs: &[Vec2],
    indices: &[u32],
) -> Vec<Vec4> {
    let mut tan = vec![Vec3::ZERO; positions.len()];
    let mut bit = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
        let e1 = positions[b] - positions[a];
        let e2 = positions[c] - positions[a];
        let d1 = uvs[b] - uvs[a];
        let d2 = uvs[c] - uvs[a];
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() < 1e-20 || !det.is_finite() {
            continue;
        }
        let r = 1.0 / det;
        let sdir = (e1 * d2.y - e2 * d1.y) * r;
        let tdir = (e2 * d1.x - e1 * d2.x) * r;
        if !(sdir.is_finite() && tdir.is_finite()) {
            continue;
        }
        for v in [a, b, c] {
            tan[v] += sdir;
            bit[v] += tdir;
        }
    }
    (0..positions.len())
        .map(|v| {
            let n = normals[v];
            let t = (tan[v] - n * n.dot(tan[v]))
                .try_normalize()
                .unwrap_or_else(|| n.any_orthonormal_vector());
            let w = if n.cross(t).dot(bit[v]) < 0.0 {
                -1.0
            } else {
                1.0
            };
            t.extend(w)
        })
        .collect()
}

/// Removes every triangle that references a vertex with a non-finite attribute
/// (position, normal, uv or tangent), then drops the vertices no triangle uses
/// any more, so no NaN or Inf reaches the GPU or the BVH builder.
/// Returns the number of triangles removed (0 leaves the mesh untouched).
pub fn drop_non_finite_triangles(mesh: &mut Mesh) -> usize {
    let bad: Vec<bool> = (0..mesh.positions.len())
        .map(|v| {
            !mesh.positions[v].is_finite()
                || mesh.normals.get(v).is_some_and(|n| !n.is_finite())
                || mesh.uvs.get(v).is_some_and(|n| !n.is_finite())
                || mesh.tangents.get(v).is_some_and(|n| !n.is_finite())
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
    mesh.tangents = pick(&mesh.tangents, &order);
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

    #[test]
    fn normals_face_plus_z_and_tangents_follow_u() {
        let (p, uv, idx) = quad();
        let n = generate_normals(&p, &idx);
        assert!(n.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
        let t = generate_tangents(&p, &n, &uv, &idx);
        for t in t {
            assert!((t.truncate() - Vec3::X).length() < 1e-6);
            // v grows downwards in glTF uv space, so the bitangent (+v) is −Y = N × T · w → w = −1.
            assert_eq!(t.w, -1.0);
        }
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
