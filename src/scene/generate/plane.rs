//! A 200 m × 200 m ground plane with a procedural checker-and-grid texture,
//! seen from eye height towards the horizon: the view sweeps from near
//! head-on (at the feet) to grazing angles (at the horizon), so texture
//! aliasing and its temporal flicker are as visible as they get.

use super::{add_material, add_mesh, grid, look_at};
use crate::scene::default_lighting::{apply_default_lighting, DefaultLighting};
use crate::scene::{Material, Scene, Texture, TextureEncoding, TextureRef};
use glam::{Mat4, Vec2, Vec3};

pub const SIZE: f32 = 200.0;
/// Quads per side; keeps triangles ≈ 3 m so ray/triangle precision stays good.
pub const SUBDIVISIONS: u32 = 64;
/// The texture repeats every `TILE` metres (8 × 8 checker cells of 0.25 m).
pub const TILE: f32 = 2.0;
pub const TEXTURE_SIZE: u32 = 256;
pub const EYE_HEIGHT: f32 = 1.7;

/// sRGB RGBA8 checker (8 × 8 cells) with 2-texel dark grid lines on cell borders.
pub fn checker_texture() -> Texture {
    let n = TEXTURE_SIZE;
    let cell = n / 8;
    let mut px = Vec::with_capacity((n * n * 4) as usize);
    for y in 0..n {
        for x in 0..n {
            let line = x % cell < 2 || y % cell < 2;
            let dark = ((x / cell) + (y / cell)) % 2 == 1;
            let c: [u8; 3] = if line {
                [20, 20, 24]
            } else if dark {
                [70, 90, 120]
            } else {
                [225, 220, 205]
            };
            px.extend_from_slice(&[c[0], c[1], c[2], 255]);
        }
    }
    Texture::with_mips("checker".into(), TextureEncoding::Srgb, n, n, px)
}

pub fn plane() -> Scene {
    let mut s = Scene {
        source: "generated:plane".into(),
        ..Default::default()
    };
    s.textures.push(checker_texture());
    let mat = add_material(
        &mut s,
        Material {
            base_color_texture: Some(TextureRef::new(0)),
            ..Material::diffuse("checker", Vec3::ONE)
        },
    );
    let h = SIZE / 2.0;
    let mesh = grid(
        "ground",
        Vec3::new(-h, 0.0, h),
        Vec3::X * SIZE,
        Vec3::NEG_Z * SIZE,
        SUBDIVISIONS,
        SUBDIVISIONS,
        Vec2::splat(SIZE / TILE),
    );
    add_mesh(&mut s, mesh, mat, Mat4::IDENTITY);
    // Pitched 12° down: the bottom of a 60° view sees the ground ≈ 2 m ahead, the top the horizon.
    let eye = Vec3::new(0.0, EYE_HEIGHT, 0.0);
    let pitch = 12f32.to_radians();
    s.cameras.push(look_at(
        "default",
        eye,
        eye + Vec3::new(0.0, -pitch.sin(), -pitch.cos()),
        Vec3::Y,
        60.0,
    ));
    s.cameras.push(look_at(
        "topdown",
        Vec3::new(0.0, 20.0, 0.0),
        Vec3::ZERO,
        Vec3::NEG_Z,
        60.0,
    ));
    apply_default_lighting(&mut s, &DefaultLighting::default()).expect("sun-sky needs no file");
    s
}
