//! Back-face culling of single-sided materials (glTF doubleSided false,
//! issue 18): a ray that meets such a triangle from behind passes through, on
//! both ray backends, for closest hits (camera and path rays) and occlusion
//! (shadow rays). glTF's front is counter-clockwise in object space, so a
//! mirroring instance transform keeps a face's front side (the determinant
//! rule of glTF §3.7.2.1); volume boundaries never cull.

mod common;
use common::*;
use glam::{Mat4, Vec2, Vec3};
use stereocache::methods::RenderSettings;
use stereocache::rt::{BvhLayout, RtChoice};
use stereocache::scene::generate::{add_material, add_mesh, grid};
use stereocache::scene::{Light, LightKind, Material, Scene, Volume};

/// The flattened and two-level software BVHs and the ray-query backend.
fn backends(ctx: &std::sync::Arc<stereocache::gpu::GpuContext>) -> Vec<(RtChoice, BvhLayout)> {
    let mut v = vec![
        (RtChoice::Software, BvhLayout::Flattened),
        (RtChoice::Software, BvhLayout::TwoLevel),
    ];
    if require(ctx.ray_query_enabled(), "ray queries") {
        v.push((RtChoice::Query, BvhLayout::Flattened));
    }
    v
}

fn open(
    ctx: &std::sync::Arc<stereocache::gpu::GpuContext>,
    s: Scene,
    (rt, layout): (RtChoice, BvhLayout),
) -> stereocache::session::Session {
    stereocache::session::Session::with_layout(ctx.clone(), s, rt, Some(layout))
        .expect("scene upload")
}

/// `s` lit by a sun alone (radiance 1, rays along `sun`), in a black world,
/// seen from `eye` towards `target`: 8 × 8 pixels, 1 spp, one bounce — each
/// pixel its surface's exact direct term, the sun being sampled exactly.
fn render_under_sun(
    ctx: &std::sync::Arc<stereocache::gpu::GpuContext>,
    mut s: Scene,
    backend: (RtChoice, BvhLayout),
    sun: Vec3,
    (eye, target, yfov): (Vec3, Vec3, f32),
) -> stereocache::methods::StereoFrame {
    s.lights.push(Light {
        name: "sun".into(),
        kind: LightKind::Directional {
            angular_radius: 0.0,
        },
        radiant: Vec3::ONE,
        position: Vec3::ZERO,
        direction: sun,
        range: None,
    });
    s.environment = None;
    s.validate().unwrap();
    let sess = open(ctx, s, backend);
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    render(
        &sess,
        "reference",
        look_at_camera(eye, target, yfov, 1.0),
        &settings,
    )
}

/// A 2 × 2 quad in the plane z = 0 whose counter-clockwise normal is +Z
/// (`facing_camera`) or −Z.
fn quad(facing_camera: bool) -> stereocache::scene::Mesh {
    if facing_camera {
        grid(
            "quad",
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::X * 2.0,
            Vec3::Y * 2.0,
            1,
            1,
            Vec2::ONE,
        )
    } else {
        grid(
            "quad",
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::Y * 2.0,
            Vec3::X * 2.0,
            1,
            1,
            Vec2::ONE,
        )
    }
}

fn black(double_sided: bool) -> Material {
    let mut m = Material::diffuse("occluder", Vec3::ZERO);
    m.specular = 0.0;
    m.double_sided = double_sided;
    m
}

/// The occluder quad (material `m`, transform `t`) at z = 0 in front of a
/// double-sided emitter of radiance 1 at z = −2, seen from z = 5: the mean
/// radiance of all pixels (all see the emitter's middle through the quad).
fn seen_through(
    ctx: &std::sync::Arc<stereocache::gpu::GpuContext>,
    rt: (RtChoice, BvhLayout),
    m: Material,
    facing_camera: bool,
    t: Mat4,
) -> f64 {
    let mut s = Scene {
        source: "test:culling".into(),
        ..Default::default()
    };
    let occ = add_material(&mut s, m);
    add_mesh(&mut s, quad(facing_camera), occ, t);
    let mut light = Material::diffuse("light", Vec3::ZERO);
    light.specular = 0.0;
    light.emissive = Vec3::ONE;
    light.double_sided = true;
    let l = add_material(&mut s, light);
    add_mesh(
        &mut s,
        grid(
            "emitter",
            Vec3::new(-2.0, -2.0, -2.0),
            Vec3::X * 4.0,
            Vec3::Y * 4.0,
            1,
            1,
            Vec2::ONE,
        ),
        l,
        Mat4::IDENTITY,
    );
    s.environment = None;
    s.validate().unwrap();
    let sess = open(ctx, s, rt);
    // 5° field of view from z = 5: ±0.22 at the quad, well inside it.
    let cam = look_at_camera(Vec3::new(0.1, 0.1, 5.0), Vec3::new(0.1, 0.1, 0.0), 5.0, 1.0);
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 2,
        max_bounces: 1,
        seed: 1,
        all_features: false,
        ..Default::default()
    };
    let f = render(&sess, "reference", cam, &settings);
    let v: Vec<f64> = f
        .eyes
        .iter()
        .flat_map(|e| e.radiance.iter().map(|p| p[0] as f64))
        .collect();
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn single_sided_back_faces_let_camera_rays_through() {
    let ctx = context();
    let mirror_x = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    let mirror_z = Mat4::from_scale(Vec3::new(1.0, 1.0, -1.0));
    // (case, material, counter-clockwise normal towards the camera?, transform, radiance)
    let cases = [
        (
            "single-sided, front",
            black(false),
            true,
            Mat4::IDENTITY,
            0.0,
        ),
        (
            "single-sided, back",
            black(false),
            false,
            Mat4::IDENTITY,
            1.0,
        ),
        (
            "double-sided, back",
            black(true),
            false,
            Mat4::IDENTITY,
            0.0,
        ),
        // Mirrored in x: the world winding reverses, the front stays +Z.
        (
            "single-sided, front, mirrored x",
            black(false),
            true,
            mirror_x,
            0.0,
        ),
        (
            "single-sided, back, mirrored x",
            black(false),
            false,
            mirror_x,
            1.0,
        ),
        // Mirrored in z (positions of a z = 0 quad unchanged): the front
        // turns to −Z with the object's normal.
        (
            "single-sided, front, mirrored z",
            black(false),
            true,
            mirror_z,
            1.0,
        ),
        (
            "single-sided, back, mirrored z",
            black(false),
            false,
            mirror_z,
            0.0,
        ),
        (
            "volume boundary, back",
            {
                let mut m = black(false);
                m.volume = Some(Volume::CLEAR);
                m
            },
            false,
            Mat4::IDENTITY,
            0.0,
        ),
    ];
    for rt in backends(&ctx) {
        for (what, m, facing, t, expected) in cases.iter().cloned() {
            let got = seen_through(&ctx, rt, m, facing, t);
            assert_eq!(got, expected, "{rt:?}, {what}");
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Shadow rays too: a white floor under a sun straight overhead, with a
/// single-sided roof between them. Facing down (its front towards the
/// floor) the roof shadows the floor; facing up the shadow rays meet its
/// back and pass: the floor is lit, E = sun radiance·cos 0 = 1, radiance
/// 1/π for the white Lambertian floor (up to its specular layer: 0 here).
#[test]
fn single_sided_back_faces_let_shadow_rays_through() {
    let ctx = context();
    for rt in backends(&ctx) {
        for (roof_faces_floor, expected) in [(true, 0.0), (false, std::f64::consts::FRAC_1_PI)] {
            let mut s = Scene {
                source: "test:culling-shadow".into(),
                ..Default::default()
            };
            let mut white = Material::diffuse("floor", Vec3::ONE);
            white.specular = 0.0;
            white.double_sided = true;
            let floor = add_material(&mut s, white);
            add_mesh(
                &mut s,
                grid(
                    "floor",
                    Vec3::new(-5.0, 0.0, 5.0),
                    Vec3::X * 10.0,
                    Vec3::NEG_Z * 10.0,
                    1,
                    1,
                    Vec2::ONE,
                ),
                floor,
                Mat4::IDENTITY,
            );
            let roof = add_material(&mut s, black(false));
            let roof_mesh = if roof_faces_floor {
                grid(
                    "roof",
                    Vec3::new(-5.0, 1.0, 5.0),
                    Vec3::NEG_Z * 10.0,
                    Vec3::X * 10.0,
                    1,
                    1,
                    Vec2::ONE,
                )
            } else {
                grid(
                    "roof",
                    Vec3::new(-5.0, 1.0, 5.0),
                    Vec3::X * 10.0,
                    Vec3::NEG_Z * 10.0,
                    1,
                    1,
                    Vec2::ONE,
                )
            };
            add_mesh(&mut s, roof_mesh, roof, Mat4::IDENTITY);
            // Between floor and roof, looking down at the floor.
            let f = render_under_sun(
                &ctx,
                s,
                rt,
                Vec3::NEG_Y,
                (Vec3::new(0.3, 0.5, 0.3), Vec3::new(0.3, 0.0, 0.29), 10.0),
            );
            for e in &f.eyes {
                for p in &e.radiance {
                    assert!(
                        (p[0] as f64 - expected).abs() < 1e-5,
                        "{rt:?}, roof facing the floor {roof_faces_floor}: {} vs {expected}",
                        p[0]
                    );
                }
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// A mirroring instance transform keeps a face's front (glTF §3.7.2.1), and
/// it must keep its shading too: a white Lambertian floor (no specular
/// layer) under a sun 40° from the zenith, seen from above, one bounce into
/// a black world, so each pixel is exactly the sun's direct term
/// cos θ_s / π, θ_s between the sun and the shading normal. Plain and
/// mirrored (x scaled by −1) the floor must give the same: cos 40° / π
/// without a normal map; with a constant normal map tilted 20° towards the
/// bitangent (glTF: cross(n, t)·w in object space, here −z, the side the
/// sun shines from, so θ_s ≈ 20°; the exact value from the texture's
/// bytes), the mirrored floor's bitangent must still point to −z: a
/// mirroring transform turns cross(n, t) of the transformed vectors over.
/// (Before session 37 the mirrored floor was black: its geometric normal
/// faced away from the ray and every path ended at it; and its mapped
/// normal tilted the wrong way, giving cos 60° / π.) Deterministic: the
/// sun is sampled exactly and nothing else is lit; every pixel within
/// 10⁻⁵ relative (f32 rounding of the decode, normalisation and frame).
#[test]
fn mirrored_instances_are_shaded_like_their_unmirrored_twins() {
    use stereocache::scene::{Texture, TextureEncoding, TextureRef};
    let ctx = context();
    let (sun_zenith, tilt) = (40f32.to_radians(), 20f32.to_radians());
    // The normal map's bytes and the unit tangent-space normal they decode to.
    let texel = [0.0f32, tilt.sin(), tilt.cos()].map(|c| ((c * 0.5 + 0.5) * 255.0).round() as u8);
    let tn = Vec3::from_array([0, 1, 2].map(|k| texel[k] as f32 / 255.0 * 2.0 - 1.0)).normalize();
    // Towards the sun: up, and towards −z.
    let to_sun = Vec3::new(0.0, sun_zenith.cos(), -sun_zenith.sin());
    for rt in backends(&ctx) {
        for mapped in [false, true] {
            // Object space: n = +y, t = +x, w = 1, so b = cross(n, t) = −z.
            let want = if mapped {
                Vec3::new(tn.x, tn.z, -tn.y).dot(to_sun) / std::f32::consts::PI
            } else {
                to_sun.y / std::f32::consts::PI
            };
            let mut got = Vec::new();
            for mirror in [false, true] {
                let mut s = Scene {
                    source: "test:mirrored-floor".into(),
                    ..Default::default()
                };
                let mut white = Material::diffuse("floor", Vec3::ONE);
                white.specular = 0.0;
                if mapped {
                    s.textures.push(Texture::with_mips(
                        "tilted".into(),
                        TextureEncoding::Linear,
                        1,
                        1,
                        vec![texel[0], texel[1], texel[2], 255],
                    ));
                    white.normal_texture = Some(TextureRef::new(0));
                }
                let floor = add_material(&mut s, white);
                let mut mesh = grid(
                    "floor",
                    Vec3::new(-5.0, 0.0, 5.0),
                    Vec3::X * 10.0,
                    Vec3::NEG_Z * 10.0,
                    1,
                    1,
                    Vec2::ONE,
                );
                mesh.tangents = vec![glam::Vec4::new(1.0, 0.0, 0.0, 1.0); mesh.positions.len()];
                let t = if mirror {
                    Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))
                } else {
                    Mat4::IDENTITY
                };
                add_mesh(&mut s, mesh, floor, t);
                let f = render_under_sun(
                    &ctx,
                    s,
                    rt,
                    -to_sun,
                    (Vec3::new(0.3, 2.0, 0.3), Vec3::new(0.3, 0.0, 0.29), 20.0),
                );
                for eye in &f.eyes {
                    for p in &eye.radiance {
                        assert!(
                            (p[0] - want).abs() <= 1e-5 * want,
                            "{rt:?} normal map {mapped}, mirrored {mirror}: radiance {} where cos θ_s / π = {want}",
                            p[0]
                        );
                    }
                }
                got.push(f.eyes[0].radiance[0][0]);
            }
            eprintln!(
                "{rt:?} normal map {mapped}: plain {}, mirrored {}, want {want}",
                got[0], got[1]
            );
        }
    }
    assert_no_validation_messages(&ctx);
}
