//! Deterministic built-in scenes: `cornell`, `hairball` and `plane`, the
//! animated `cornell-moving` and `hairball-rotating` (animated.rs), and
//! `material-balls` (material graphs, issue 17). Each has a
//! camera named `default`; the same name always gives bit-identical scenes.

pub mod animated;
pub mod cornell;
pub mod hairball;
pub mod material_balls;
pub mod plane;

use super::export::write_gltf;
use super::{Instance, Material, Mesh, Scene, SceneCamera, SceneError};
use glam::{Mat4, Vec2, Vec3};
use std::path::{Path, PathBuf};

/// Names accepted by [`generate`].
pub const NAMES: &[&str] = &[
    "cornell",
    "hairball",
    "plane",
    "cornell-moving",
    "hairball-rotating",
    "material-balls",
];

/// Builds the named scene, or `None` for an unknown name. The result has passed
/// `Scene::validate`.
pub fn generate(name: &str) -> Option<Scene> {
    let scene = match name {
        "cornell" => cornell::cornell(),
        "hairball" => hairball::hairball(),
        "plane" => plane::plane(),
        "cornell-moving" => animated::cornell_moving(),
        "hairball-rotating" => animated::hairball_rotating(),
        "material-balls" => material_balls::material_balls(),
        _ => return None,
    };
    // Generators are code, not user input: a failure here is a bug.
    if let Err(e) = scene.validate() {
        panic!("generated scene '{name}' is invalid: {e}");
    }
    Some(scene)
}

/// Generates `name` and writes it as `DIR/NAME.gltf` (+ `.bin`, `.png`s); returns
/// the `.gltf` path. This is what `stereocache scene generate NAME --out DIR` runs.
/// The sun-sky environment of `hairball`/`plane` is not stored (glTF has no sky);
/// loading the file applies the CLI's default lighting instead.
pub fn generate_to_dir(name: &str, dir: &Path) -> Result<PathBuf, SceneError> {
    let scene = generate(name).ok_or_else(|| {
        SceneError::invalid(
            Path::new(name),
            format!("unknown scene generator; known: {}", NAMES.join(", ")),
        )
    })?;
    if dir.exists() && !dir.is_dir() {
        return Err(SceneError::invalid(
            dir,
            "the output directory is a file, not a directory",
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| SceneError::write(dir, e))?;
    let path = dir.join(format!("{name}.gltf"));
    write_gltf(&scene, &path)?;
    Ok(path)
}

/// Adds a mesh with the given material and one instance of it.
pub fn add_mesh(scene: &mut Scene, mut mesh: Mesh, material: u32, transform: Mat4) {
    mesh.material = material;
    scene.instances.push(Instance {
        mesh: scene.meshes.len() as u32,
        transform,
        name: mesh.name.clone(),
    });
    scene.meshes.push(mesh);
}

pub fn add_material(scene: &mut Scene, m: Material) -> u32 {
    scene.materials.push(m);
    (scene.materials.len() - 1) as u32
}

/// A camera at `eye` looking at `target` (camera-to-world: columns right, up, −forward, eye).
pub fn look_at(name: &str, eye: Vec3, target: Vec3, up: Vec3, yfov_deg: f32) -> SceneCamera {
    let forward = (target - eye).normalize();
    let right = forward.cross(up).normalize();
    let up = right.cross(forward);
    SceneCamera {
        name: name.into(),
        transform: Mat4::from_cols(
            right.extend(0.0),
            up.extend(0.0),
            (-forward).extend(0.0),
            eye.extend(1.0),
        ),
        yfov: yfov_deg.to_radians(),
        aspect: None,
        znear: 0.01,
        orthographic: None,
    }
}

/// A planar grid of `nu × nv` quads: corner `origin`, edges `eu`, `ev`; the
/// front face (counter-clockwise) faces `eu × ev`; uv spans [0, uv_scale.x] × [0, uv_scale.y].
pub fn grid(
    name: &str,
    origin: Vec3,
    eu: Vec3,
    ev: Vec3,
    nu: u32,
    nv: u32,
    uv_scale: Vec2,
) -> Mesh {
    let normal = eu.cross(ev).normalize();
    let mut m = Mesh {
        name: name.into(),
        ..Default::default()
    };
    for j in 0..=nv {
        for i in 0..=nu {
            let (s, t) = (i as f32 / nu as f32, j as f32 / nv as f32);
            m.positions.push(origin + eu * s + ev * t);
            m.normals.push(normal);
            m.uvs
                .push(Vec2::new(s * uv_scale.x, (1.0 - t) * uv_scale.y));
        }
    }
    let row = nu + 1;
    for j in 0..nv {
        for i in 0..nu {
            let a = j * row + i;
            m.indices
                .extend([a, a + 1, a + row + 1, a, a + row + 1, a + row]);
        }
    }
    m
}

/// A unit-radius UV sphere at the origin with smooth normals (`segments`
/// around Y, `rings` from pole to pole), uv = (longitude, latitude).
pub fn uv_sphere(name: &str, segments: u32, rings: u32) -> Mesh {
    let mut m = Mesh {
        name: name.into(),
        ..Default::default()
    };
    for r in 0..=rings {
        let v = r as f32 / rings as f32;
        let theta = v * std::f32::consts::PI;
        for s in 0..=segments {
            let u = s as f32 / segments as f32;
            let phi = u * std::f32::consts::TAU;
            let n = Vec3::new(
                theta.sin() * phi.sin(),
                theta.cos(),
                theta.sin() * phi.cos(),
            );
            m.positions.push(n);
            m.normals.push(n);
            m.uvs.push(Vec2::new(u, v));
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let a = r * row + s;
            let b = a + row;
            // Skip the degenerate triangle at each pole.
            if r != 0 {
                m.indices.extend([a, b, a + 1]);
            }
            if r != rings - 1 {
                m.indices.extend([a + 1, b, b + 1]);
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_is_outward_and_closed() {
        let m = uv_sphere("s", 16, 8);
        for t in 0..m.triangle_count() {
            let [a, b, c] = m.triangle(t);
            let n = (b - a).cross(c - a);
            assert!(n.length() > 0.0, "degenerate triangle {t}");
            assert!(n.dot(a + b + c) > 0.0, "triangle {t} faces inwards");
        }
    }

    #[test]
    fn grid_faces_its_normal() {
        let m = grid("g", Vec3::ZERO, Vec3::X, Vec3::NEG_Z, 2, 2, Vec2::ONE);
        let [a, b, c] = m.triangle(0);
        assert!((b - a).cross(c - a).normalize().dot(Vec3::Y) > 0.99);
        assert_eq!(m.triangle_count(), 8);
    }

    #[test]
    fn unknown_name_is_none_and_generators_are_deterministic() {
        assert!(generate("nope").is_none());
        let a = generate("cornell").unwrap();
        let b = generate("cornell").unwrap();
        assert_eq!(a.meshes[0].positions, b.meshes[0].positions);
    }
}
