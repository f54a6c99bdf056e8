//! The Cornell box of the paper's appendix C: red/green side walls, white
//! floor, ceiling and back wall, a rectangular area light just below the
//! ceiling, a metal sphere and a glass sphere. 1 m box, metres, +Y up, open
//! towards +Z where the `default` camera stands.
//!
//! Colours are linear RGB reflectances as in Bitterli's `cornell-box`
//! rendering resource (white 0.725, 0.71, 0.68; red 0.63, 0.065, 0.05;
//! green 0.14, 0.45, 0.091; light 17, 12, 4), used as they are. The box's
//! size and the light's (0.25 × 0.2 m in a 1 m box) are the paper's
//! appendix-C box, not the measured Cornell data (1.30 × 1.05 m of light in
//! a 5.56 m box).

use super::{add_material, add_mesh, grid, look_at, uv_sphere};
use crate::scene::{Material, Scene, Volume};
use glam::{Mat4, Quat, Vec2, Vec3};

/// Linear RGB radiance of the ceiling light (warm white, classic ratio 17:12:4).
pub const LIGHT_RADIANCE: Vec3 = Vec3::new(17.0, 12.0, 4.0);
/// Light size (x, z) in metres and its gap below the ceiling.
pub const LIGHT_SIZE: Vec2 = Vec2::new(0.25, 0.2);
pub const LIGHT_GAP: f32 = 0.001;
pub const SPHERE_RADIUS: f32 = 0.18;

pub fn cornell() -> Scene {
    build(None)
}

/// The Cornell box with both spheres at GGX roughness α_GGX = `alpha`
/// (appendix C sweeps α_GGX ∈ {0, 0.2, 0.4}): glTF roughness √α, since the
/// BSDF uses α = roughness² (bsdf.glsl `ggx_alpha`). The scene spec
/// `cornell:alpha=A` (scene::load).
pub fn cornell_with_sphere_alpha(alpha: f32) -> Scene {
    build(Some(alpha))
}

/// `sphere_alpha`: None = the shipped spheres (metal roughness 0.1, smooth glass).
fn build(sphere_alpha: Option<f32>) -> Scene {
    let mut s = Scene {
        source: match sphere_alpha {
            None => "generated:cornell".into(),
            Some(a) => format!("generated:cornell:alpha={a}").into(),
        },
        ..Default::default()
    };
    let sphere_roughness = |shipped: f32| sphere_alpha.map_or(shipped, f32::sqrt);
    let white = add_material(
        &mut s,
        Material::diffuse("white", Vec3::new(0.725, 0.71, 0.68)),
    );
    let red = add_material(
        &mut s,
        Material::diffuse("red", Vec3::new(0.63, 0.065, 0.05)),
    );
    let green = add_material(
        &mut s,
        Material::diffuse("green", Vec3::new(0.14, 0.45, 0.091)),
    );
    let light = add_material(
        &mut s,
        Material {
            emissive: LIGHT_RADIANCE,
            ..Material::diffuse("light", Vec3::splat(0.78))
        },
    );
    let metal = add_material(
        &mut s,
        Material {
            name: "metal".into(),
            base_color: Vec3::new(0.95, 0.93, 0.88).extend(1.0),
            metallic: 1.0,
            roughness: sphere_roughness(0.1),
            ..Default::default()
        },
    );
    let glass = add_material(
        &mut s,
        Material {
            name: "glass".into(),
            base_color: glam::Vec4::ONE,
            metallic: 0.0,
            roughness: sphere_roughness(0.0),
            transmission: 1.0,
            ior: 1.5,
            // A solid glass ball: a volume boundary (glTF's transmission
            // alone would make it a thin soap bubble).
            volume: Some(Volume::CLEAR),
            ..Default::default()
        },
    );

    // Box x ∈ [−0.5, 0.5], y ∈ [0, 1], z ∈ [−0.5, 0.5]; every wall faces inwards.
    let (lo, hi) = (Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5));
    let n = 4; // a few quads per wall keep triangles well shaped for the BVH
    let walls = [
        (
            "floor",
            Vec3::new(lo.x, lo.y, hi.z),
            Vec3::X,
            Vec3::NEG_Z,
            white,
        ),
        (
            "ceiling",
            Vec3::new(lo.x, hi.y, lo.z),
            Vec3::X,
            Vec3::Z,
            white,
        ),
        ("back", Vec3::new(lo.x, lo.y, lo.z), Vec3::X, Vec3::Y, white),
        (
            "left",
            Vec3::new(lo.x, lo.y, hi.z),
            Vec3::NEG_Z,
            Vec3::Y,
            red,
        ),
        (
            "right",
            Vec3::new(hi.x, lo.y, lo.z),
            Vec3::Z,
            Vec3::Y,
            green,
        ),
    ];
    for (name, origin, eu, ev, mat) in walls {
        let mesh = grid(name, origin, eu, ev, n, n, Vec2::ONE);
        add_mesh(&mut s, mesh, mat, Mat4::IDENTITY);
    }
    // Light: faces −Y, centred, LIGHT_GAP below the ceiling.
    let y = hi.y - LIGHT_GAP;
    let origin = Vec3::new(-LIGHT_SIZE.x / 2.0, y, -LIGHT_SIZE.y / 2.0);
    let mesh = grid(
        "light",
        origin,
        Vec3::X * LIGHT_SIZE.x,
        Vec3::Z * LIGHT_SIZE.y,
        1,
        1,
        Vec2::ONE,
    );
    add_mesh(&mut s, mesh, light, Mat4::IDENTITY);

    let r = SPHERE_RADIUS;
    let place = |c: Vec3| Mat4::from_scale_rotation_translation(Vec3::splat(r), Quat::IDENTITY, c);
    add_mesh(
        &mut s,
        uv_sphere("metal sphere", 64, 32),
        metal,
        place(Vec3::new(-0.2, r, -0.15)),
    );
    add_mesh(
        &mut s,
        uv_sphere("glass sphere", 64, 32),
        glass,
        place(Vec3::new(0.2, r, 0.12)),
    );

    s.cameras.push(look_at(
        "default",
        Vec3::new(0.0, 0.5, 1.9),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::Y,
        40.0,
    ));
    s
}
