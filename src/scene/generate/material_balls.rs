//! `material-balls`: the shipped material-graph library (scenes/materials/,
//! issue 17) on ten unit spheres in two rows and a ground plane, lit by the
//! default sun and sky. Each sphere's material is a library graph bound by
//! name (materials::binding's `.mtlx` form), so every hit of every method
//! evaluates a graph. `lava` (emissive) is left out: a scene with emissive
//! materials gets no default lighting when loaded from glTF.

use super::{add_material, add_mesh, grid, look_at, uv_sphere};
use crate::materials::library;
use crate::scene::default_lighting::{apply_default_lighting, DefaultLighting};
use crate::scene::{Material, Scene};
use glam::{Mat4, Quat, Vec2, Vec3};

/// The sphere graphs, in row order, and the ground's.
pub const SPHERES: [&str; 10] = [
    "bricks",
    "marble",
    "wood",
    "rust",
    "fabric",
    "concrete",
    "cardboard",
    "granite",
    "leather",
    "terrazzo",
];
pub const GROUND: &str = "tiles";
pub const RADIUS: f32 = 0.45;
pub const SPACING: f32 = 1.2;

pub fn material_balls() -> Scene {
    let mut s = Scene {
        source: "generated:material-balls".into(),
        ..Default::default()
    };
    let ground = add_material(&mut s, Material::diffuse(GROUND, Vec3::ONE));
    add_mesh(
        &mut s,
        grid(
            "ground",
            Vec3::new(-4.0, 0.0, 3.0),
            Vec3::X * 8.0,
            Vec3::NEG_Z * 6.0,
            8,
            6,
            Vec2::new(4.0, 3.0),
        ),
        ground,
        Mat4::IDENTITY,
    );
    for (k, name) in SPHERES.iter().enumerate() {
        let m = add_material(&mut s, Material::diffuse(name, Vec3::ONE));
        let (col, row) = ((k % 5) as f32, (k / 5) as f32);
        let centre = Vec3::new((col - 2.0) * SPACING, RADIUS, -row * SPACING);
        add_mesh(
            &mut s,
            uv_sphere(name, 64, 32),
            m,
            Mat4::from_scale_rotation_translation(Vec3::splat(RADIUS), Quat::IDENTITY, centre),
        );
    }
    s.cameras.push(look_at(
        "default",
        Vec3::new(0.0, 1.6, 3.4),
        Vec3::new(0.0, 0.35, -0.6),
        Vec3::Y,
        50.0,
    ));
    apply_default_lighting(&mut s, &DefaultLighting::default()).expect("sun-sky needs no file");
    // Bound after the lighting (binding sets factors, none emissive here).
    let names = std::iter::once(GROUND).chain(SPHERES);
    for (mi, name) in names.enumerate() {
        let file = format!("{name}.mtlx");
        let text = library::EMBEDDED
            .iter()
            .find(|(n, _)| *n == file)
            .map(|(_, t)| *t)
            .expect("a shipped library file");
        let mut m = s.materials[mi].clone();
        s.graphs
            .attach_mtlx(mi as u32, &mut m, &format!("materials/{file}"), text)
            .unwrap_or_else(|e| panic!("library graph {name}: {e}"));
        s.materials[mi] = m;
    }
    s
}
