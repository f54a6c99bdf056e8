//! The reference path tracer against a renderer we did not write: Mitsuba 3
//! (`scripts/mitsuba_reference.py`, installed into `.tools/venv` by
//! `scripts/setup.sh --test`). The shipped Cornell box — diffuse walls, an
//! area light seen directly and sampled by next-event estimation, a solid
//! smooth glass sphere (refraction, exact Fresnel, total internal
//! reflection) and a near-mirror metal sphere — is exported triangle for
//! triangle, rendered by both, and compared block by block with tolerances
//! from the two renders' own noise. A second comparison with the glass
//! sphere's transmission tinted by 0.9 (the shape of the old "glass far too
//! dark" bug, much milder) must fail it: the test can bite.
//!
//! Two changes to the shipped box make the models identical rather than
//! close: the walls' and the light's glTF dielectric layer is switched off
//! (`specular` 0: pure Lambert, Mitsuba's `diffuse`; with the layer, its
//! 4 % GGX reflection and the (1 − F) it puts on the diffuse have no Mitsuba
//! twin), and the spheres are flat-shaded (both renderers then see the same
//! facets and normals). The tinted metal is Mitsuba's `principled` at
//! metallic 1: Schlick's Fresnel with F0 = the base colour, GGX with
//! α = roughness², as glTF's (its Smith term is separable, ours
//! height-correlated: at α = 0.01 the same but for a sliver of the rim). A
//! second scene lights the box with a point light, a spot light, a delta
//! directional light and a constant environment instead, a third gives the
//! white walls a texture, a fourth puts spheres on a floor under an
//! importance-sampled environment map, a fifth shades spheres and an
//! ellipsoid with interpolated vertex normals (every mesh goes to Mitsuba
//! with its vertex normals in world space), and a sixth makes the fifth's
//! metal sphere half metal (glTF's linear metallic mix, Mitsuba's
//! blendbsdf of its diffuse and its metal).

mod common;

use common::*;
use glam::Vec3;
use std::io::Write;
use std::path::{Path, PathBuf};
use stereocache::camera::Eye;
use stereocache::methods::RenderSettings;
use stereocache::rt::RtChoice;
use stereocache::scene::{generate::cornell::cornell, Scene};

const W: u32 = 64;
const H: u32 = 64;
/// Samples per pixel of each of the two independent halves per renderer.
/// Enough for near-normal block means: at 256 one seed pair put a cluster
/// of Mitsuba fireflies into the metal sphere's reflection of the light
/// (one block at z −5.1, at 2048 spp −1.4; docs/ARCHITECTURE.md).
const SPP: u32 = 1024;
const BOUNCES: u32 = 3;
/// Block edge in pixels: 64 blocks of 64 pixels.
const BLOCK: u32 = 8;
/// Per block and channel, |z| above this fails. Chosen before the first run:
/// with 192 comparisons and normal errors, max |z| > 4.5 has probability
/// ≈ 1e-3.
const Z_MAX: f64 = 4.5;
/// The largest root mean square of the 192 z (see `agreement`).
const Z_RMS_MAX: f64 = 1.5;
/// Seeds of the two halves: ours and Mitsuba's.
const OUR_SEEDS: [u32; 2] = [1, 2];
const MITSUBA_SEEDS: [u32; 2] = [11, 12];

/// The interpreter that has Mitsuba 3: `.tools/venv`'s first, else `python3`.
fn mitsuba_python() -> Option<PathBuf> {
    let venv = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".tools/venv/bin/python3");
    [venv, PathBuf::from("python3")].into_iter().find(|p| {
        std::process::Command::new(p)
            .args(["-c", "import mitsuba, numpy"])
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// The shipped Cornell box with the two changes of the module comment.
fn comparable_cornell(glass_tint: f32) -> Scene {
    let mut s = cornell();
    s.source = format!("cornell for Mitsuba, glass tint {glass_tint}").into();
    for m in &mut s.materials {
        if m.metallic == 0.0 && m.transmission == 0.0 {
            m.specular = 0.0;
        }
        if m.name == "glass" {
            m.base_color = Vec3::splat(glass_tint).extend(1.0);
        }
    }
    s.meshes = s.meshes.drain(..).map(faceted).collect();
    s
}

/// [`comparable_cornell`] lit by the other kinds of light instead of its
/// area light: a point light and a spot light inside the box, a delta
/// directional light and a constant environment both entering through its
/// open front. The area
/// light's quad goes: it is single-sided and hangs 1 mm below the ceiling,
/// and glTF's back-face culling lets rays through it from behind (ours:
/// shadow rays too) where Mitsuba's one-sided surfaces still block them, so
/// the ceiling above it is lit through it from the point light below in
/// ours only and leaks into the room (measured: ≈ 1 % on the ceiling's
/// nearby blocks, z up to 4.3 at 4096 spp; with the quad two-sided in both
/// renderers, z ≤ 2.1).
fn comparable_cornell_lit_otherwise() -> Scene {
    use stereocache::scene::{Environment, Light, LightKind};
    let mut s = comparable_cornell(1.0);
    s.source = "cornell for Mitsuba, point, spot, directional and environment light".into();
    let light = s.materials.iter().position(|m| m.name == "light").unwrap() as u32;
    let meshes = &s.meshes;
    s.instances
        .retain(|i| meshes[i.mesh as usize].material != light);
    s.lights.push(Light {
        name: "point".into(),
        kind: LightKind::Point,
        radiant: Vec3::new(0.5, 0.4, 0.6),
        position: Vec3::new(-0.2, 0.65, 0.15),
        direction: Vec3::NEG_Z,
        range: None,
    });
    s.lights.push(Light {
        name: "directional".into(),
        kind: LightKind::Directional {
            angular_radius: 0.0,
        },
        radiant: Vec3::new(1.0, 0.9, 0.7),
        position: Vec3::ZERO,
        direction: Vec3::new(0.3, -0.5, -1.0).normalize(),
        range: None,
    });
    // A spot light from under the ceiling onto the back wall's right half
    // and the floor before it, both spheres outside its cone (lit by a
    // delta light, the near-mirror sphere's caustics are fireflies that
    // drown the cone's edge in noise); its cones one milliradian apart
    // leave the edge as sharp as our falloff allows (a ramp 0.001 wide in
    // cos θ, 4 mrad here), so the comparison sees the cone's angle, not the
    // falloff's shape (see `export`).
    let outer = SPOT_OUTER;
    s.lights.push(Light {
        name: "spot".into(),
        kind: LightKind::Spot {
            inner_cone: outer - 1e-3,
            outer_cone: outer,
        },
        radiant: Vec3::new(1.5, 1.2, 0.8),
        position: Vec3::new(0.0, 0.9, 0.3),
        direction: Vec3::new(0.3, -0.65, -0.8).normalize(),
        range: None,
    });
    s.environment = Some(Environment::Constant(Vec3::new(0.2, 0.25, 0.3)));
    s
}

/// The spot light's outer cone angle (radians) in
/// [`comparable_cornell_lit_otherwise`].
const SPOT_OUTER: f32 = 0.25;

/// [`comparable_cornell`] with a 4×4 sRGB base-colour texture (bilinear,
/// repeat) on its white walls: a texel spans ≥ 8 pixels there, so the ray
/// cone keeps level 0 (magnification), the level Mitsuba's bitmap reads.
fn textured_cornell() -> Scene {
    use stereocache::scene::texture::{Texture, TextureEncoding};
    use stereocache::scene::TextureRef;
    let mut s = comparable_cornell(1.0);
    s.source = "cornell for Mitsuba, textured walls".into();
    let texels: Vec<u8> = (0..16u32)
        .flat_map(|i| {
            let (x, y) = (i % 4, i / 4);
            [
                (130 + 40 * x) as u8,
                (250 - 35 * y) as u8,
                (90 + 25 * (x + y)) as u8,
                255,
            ]
        })
        .collect();
    s.textures.push(Texture::with_mips(
        "checker".into(),
        TextureEncoding::Srgb,
        4,
        4,
        texels,
    ));
    for m in &mut s.materials {
        if m.name == "white" {
            m.base_color_texture = Some(TextureRef::new(0));
        }
    }
    s.validate().unwrap();
    s
}

/// Width and height of the environment map of [`environment_map_scene`].
const ENV_W: u32 = 1024;
const ENV_H: u32 = 512;

/// The radiance of [`environment_map_scene`]'s environment in unit
/// direction `d`: uniform up to 5° above the horizon (everything the camera
/// sees of it directly, so those pixels have no lookup difference between
/// the renderers), above that a sky gradient and two lobes 12° and 20°
/// wide. Smooth at the map's resolution (0.35° a texel).
fn environment_radiance(d: Vec3) -> Vec3 {
    let lobe = |axis: Vec3, width_deg: f32| {
        let a = d.dot(axis.normalize()).clamp(-1.0, 1.0).acos();
        (-(a / width_deg.to_radians()).powi(2) / 2.0).exp()
    };
    let ramp = ((d.y - 5f32.to_radians().sin()) / 0.3).clamp(0.0, 1.0);
    let ramp = ramp * ramp * (3.0 - 2.0 * ramp);
    let above = Vec3::new(0.25, 0.35, 0.5) * (0.4 + 0.6 * d.y.max(0.0))
        + Vec3::new(12.0, 10.0, 8.0) * lobe(Vec3::new(0.6, 0.7, -0.4), 12.0)
        + Vec3::new(1.0, 2.0, 3.0) * lobe(Vec3::new(-0.7, 0.5, 0.6), 20.0);
    Vec3::splat(0.2) + ramp * above
}

/// Spheres of absorbing glass, tinted metal and Lambert on a Lambert floor under an
/// equirectangular map of [`environment_radiance`] (texel (x, y) holds the
/// radiance at its centre's direction; Mitsuba gets the same function on
/// its own lattice, see `export`).
fn environment_map_scene() -> Scene {
    use stereocache::scene::generate::{add_material, add_mesh, grid, look_at, uv_sphere};
    use stereocache::scene::{env_map::equirect_direction, Environment, Material};
    let mut s = Scene {
        source: "spheres under a map, for Mitsuba".into(),
        ..Default::default()
    };
    let lambert = |name: &str, c: Vec3| Material {
        specular: 0.0,
        ..Material::diffuse(name, c)
    };
    let floor = add_material(&mut s, lambert("floor", Vec3::new(0.6, 0.55, 0.5)));
    let red = add_material(&mut s, lambert("red", Vec3::new(0.7, 0.2, 0.15)));
    // The box's metal and clear glass, as `comparable_cornell` makes them.
    let boxed = comparable_cornell(1.0);
    let mut reuse = |name: &str| {
        let m = boxed
            .materials
            .iter()
            .find(|m| m.name == name)
            .unwrap()
            .clone();
        add_material(&mut s, m)
    };
    let (metal, glass) = (reuse("metal"), reuse("glass"));
    // The glass absorbs inside (KHR_materials_volume): white light turns
    // this colour over 0.5 m; chords through the 0.35 m spheres reach 0.7 m.
    s.materials[glass as usize].volume = Some(stereocache::scene::Volume {
        attenuation_color: Vec3::new(0.55, 0.8, 0.95),
        attenuation_distance: 0.5,
    });
    add_mesh(
        &mut s,
        grid(
            "floor",
            Vec3::new(-2.0, 0.0, 2.0),
            Vec3::X * 4.0,
            Vec3::NEG_Z * 4.0,
            4,
            4,
            glam::Vec2::ONE,
        ),
        floor,
        glam::Mat4::IDENTITY,
    );
    for (mat, c, r) in [
        (glass, Vec3::new(-0.55, 0.35, 0.0), 0.35),
        (metal, Vec3::new(0.55, 0.35, 0.0), 0.35),
        (red, Vec3::new(0.0, 0.2, 0.55), 0.2),
    ] {
        let place =
            glam::Mat4::from_scale_rotation_translation(Vec3::splat(r), glam::Quat::IDENTITY, c);
        add_mesh(&mut s, faceted(uv_sphere("sphere", 32, 16)), mat, place);
    }
    s.cameras.push(look_at(
        "default",
        Vec3::new(0.0, 1.1, 2.6),
        Vec3::new(0.0, 0.25, 0.0),
        Vec3::Y,
        40.0,
    ));
    let texels = (0..ENV_H)
        .flat_map(|y| (0..ENV_W).map(move |x| (x, y)))
        .map(|(x, y)| environment_radiance(equirect_direction(x, y, ENV_W, ENV_H)).to_array())
        .collect();
    s.environment = Some(Environment::Map {
        name: "lobes".into(),
        width: ENV_W,
        height: ENV_H,
        texels,
        scale: 1.0,
    });
    s.validate().unwrap();
    s
}

/// GGX α of [`smooth_shaded_scene`]'s metal sphere.
const ROUGH_METAL_ALPHA: f32 = 0.1;

/// The linear part of [`smooth_shaded_scene`]'s ellipsoid: scaled
/// unevenly, then turned, so its normals need the inverse transpose.
fn ellipsoid_linear() -> glam::Mat3 {
    glam::Mat3::from_quat(glam::Quat::from_euler(glam::EulerRot::YXZ, 0.6, 0.0, 0.5))
        * glam::Mat3::from_diagonal(Vec3::new(0.42, 0.2, 0.28))
}

/// Smooth-shaded (interpolated vertex normals) spheres under
/// [`environment_radiance`] and a point light: a Lambert ellipsoid (a uv
/// sphere scaled unevenly and turned, so its world normals need the
/// inverse transpose of its transform; 96×48 segments: at 24×12 the band
/// on its silhouette where the interpolated normal faces away from the eye,
/// which we shade with the geometric normal and Mitsuba leaves black, made
/// two blocks 0.7–0.9 % brighter in ours at 4096 spp), a tinted rough metal sphere (GGX
/// `rough_metal_alpha`; its blurred reflections show the interpolation and
/// the rough lobe; our height-correlated Smith term and Mitsuba's separable
/// one differ only at its rim at α = 0.1, docs/ARCHITECTURE.md) and a
/// glass sphere (refraction about the shading normal), on a Lambert floor.
/// `normals_like_points`: the ellipsoid's normals as a renderer that
/// transformed them like positions would see them (the biting comparison).
fn smooth_shaded_scene(normals_like_points: bool, rough_metal_alpha: f32) -> Scene {
    use stereocache::scene::generate::{add_material, add_mesh, uv_sphere};
    use stereocache::scene::{Light, LightKind};
    let mut s = environment_map_scene();
    s.source = "smooth-shaded spheres under a map and a point light, for Mitsuba".into();
    // The map scene's floor and materials, its faceted spheres replaced.
    let find =
        |s: &Scene, name: &str| s.materials.iter().position(|m| m.name == name).unwrap() as u32;
    let (metal, glass, red) = (find(&s, "metal"), find(&s, "glass"), find(&s, "red"));
    // The metal rough: GGX α (glTF roughness √α).
    let mut rough = s.materials[metal as usize].clone();
    rough.name = "rough metal".into();
    rough.roughness = rough_metal_alpha.sqrt();
    let metal = add_material(&mut s, rough);
    s.instances.truncate(1);
    s.meshes.truncate(1);
    let lin = ellipsoid_linear();
    let mut ellipsoid = uv_sphere("ellipsoid", 96, 48);
    if normals_like_points {
        // Shown as normalize(M n) after our transform by M^-T: n' = Mᵀ M n.
        for n in &mut ellipsoid.normals {
            *n = (lin.transpose() * lin * *n).normalize();
        }
    }
    let translate = |c: Vec3| glam::Mat4::from_translation(c);
    add_mesh(
        &mut s,
        ellipsoid,
        red,
        translate(Vec3::new(0.0, 0.3, 0.5)) * glam::Mat4::from_mat3(lin),
    );
    for (mat, c) in [
        (glass, Vec3::new(-0.6, 0.35, -0.1)),
        (metal, Vec3::new(0.6, 0.35, -0.1)),
    ] {
        add_mesh(
            &mut s,
            uv_sphere("sphere", 32, 16),
            mat,
            translate(c) * glam::Mat4::from_scale(Vec3::splat(0.35)),
        );
    }
    s.lights.push(Light {
        name: "point".into(),
        kind: LightKind::Point,
        radiant: Vec3::new(0.6, 0.5, 0.4),
        position: Vec3::new(-0.3, 1.2, 1.1),
        direction: Vec3::NEG_Z,
        range: None,
    });
    s.validate().unwrap();
    s
}

/// Writes one binary PLY per instance (world-space triangles) and the
/// scene description `mitsuba_reference.py` reads.
/// `map_radiance`: the function an environment map was sampled from (Mitsuba
/// gets it on its own lattice, below).
fn export(
    s: &Scene,
    camera: &stereocache::camera::EyeView,
    dir: &Path,
    seeds: &[u32],
    map_radiance: Option<fn(Vec3) -> Vec3>,
) {
    std::fs::create_dir_all(dir).unwrap();
    let mut shapes = Vec::new();
    for (k, inst) in s.instances.iter().enumerate() {
        let mesh = &s.meshes[inst.mesh as usize];
        let mat = &s.materials[mesh.material as usize];
        let name = format!("mesh{k}.ply");
        let mut f = std::io::BufWriter::new(std::fs::File::create(dir.join(&name)).unwrap());
        // Texture coordinates only where a texture reads them: Mitsuba
        // builds its shading frames from them, and the uv spheres' poles,
        // where a triangle's uvs are degenerate, then shaded wrongly (the
        // comparison with point, directional and environment light failed
        // with rms z 1.6 when every mesh had them).
        let uvs = mat.base_color_texture.is_some();
        write!(
            f,
            "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n{}element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            mesh.positions.len(),
            if uvs { "property float u\nproperty float v\n" } else { "" },
            mesh.indices.len() / 3
        )
        .unwrap();
        // Vertex normals in world space by the inverse transpose of the
        // instance's linear part (computed here, apart from the renderer's
        // own transform), interpolated by Mitsuba as by us: the shading
        // normals of smooth meshes, the face normals of faceted ones.
        let to_world_normal = glam::Mat3::from_mat4(inst.transform).inverse().transpose();
        assert!(
            mesh.normals.len() == mesh.positions.len() && mesh.uvs.len() == mesh.positions.len()
        );
        for ((p, n), uv) in mesh.positions.iter().zip(&mesh.normals).zip(&mesh.uvs) {
            let p = inst.transform.transform_point3(*p).to_array();
            let n = (to_world_normal * *n).normalize().to_array();
            // Mitsuba's bitmap puts the image's first row at v = 0, as
            // glTF does (measured: written as 1 − v the textured comparison
            // fails with rms z 28).
            let vertex = [p[0], p[1], p[2], n[0], n[1], n[2], uv.x, uv.y];
            for c in &vertex[..if uvs { 8 } else { 6 }] {
                f.write_all(&c.to_le_bytes()).unwrap();
            }
        }
        for t in mesh.indices.chunks_exact(3) {
            f.write_all(&[3u8]).unwrap();
            for &i in t {
                f.write_all(&(i as i32).to_le_bytes()).unwrap();
            }
        }
        // A solid glass's absorption inside (KHR_materials_volume's
        // Beer–Lambert: σ_a = −ln(attenuationColor) / attenuationDistance).
        let mut absorption = serde_json::Value::Null;
        let bsdf = if mat.transmission > 0.0 {
            let v = mat.volume.expect("solid glass");
            assert!(mat.transmission == 1.0);
            let sigma = -v.attenuation_color.map(f32::ln) / v.attenuation_distance;
            if sigma.max_element() > 0.0 {
                assert!(
                    sigma.is_finite(),
                    "{}: an attenuation colour of 0",
                    mat.name
                );
                absorption = serde_json::json!(sigma.to_array());
            }
            // A tinted glass has no Mitsuba twin: the tint is applied to the
            // transmitted light by stereocache only (the biting comparison).
            // Rough from roughness 0.02 on, as bsdf.glsl's dielectric (GGX,
            // α = roughness², Mitsuba's roughdielectric with visible-normal
            // sampling; its Smith term is the separable one, ours the
            // height-correlated one).
            if mat.roughness >= 0.02 {
                serde_json::json!({ "rough_dielectric": {
                    "ior": mat.ior,
                    "alpha": (mat.roughness * mat.roughness).max(1e-3),
                } })
            } else {
                serde_json::json!({ "dielectric": mat.ior })
            }
        } else if mat.metallic > 0.0 && mat.metallic < 1.0 {
            // glTF's mix(dielectric, metal, metallic) is linear in
            // metallic; with the dielectric's specular layer off
            // (specular 0: F0 = F90 = 0, a pure Lambert) it is Mitsuba's
            // blendbsdf of a diffuse and the metal with that weight.
            assert!(mat.specular == 0.0 && mat.metallic_roughness_texture.is_none());
            serde_json::json!({ "blend_metal": {
                "base_color": mat.base_color.truncate().to_array(),
                "roughness": mat.roughness,
                "metallic": mat.metallic,
            } })
        } else if mat.metallic > 0.0 {
            assert!(mat.metallic == 1.0 && mat.metallic_roughness_texture.is_none());
            serde_json::json!({ "schlick_metal": {
                "base_color": mat.base_color.truncate().to_array(),
                "roughness": mat.roughness,
            } })
        } else if let Some(t) = &mat.base_color_texture {
            // The texture as Mitsuba reads it: linear floats decoded from
            // sRGB with the exact curve (our GPU samples an sRGB format, which
            // decodes before filtering, as Mitsuba converts before it filters).
            let tex = &s.textures[t.texture as usize];
            let srgb = |c: u8| stereocache::metrics::image::srgb_decode(c as f32 / 255.0);
            // baseColorFactor multiplies the texture: baked into the file.
            let k = mat.base_color;
            let rgba: Vec<[f32; 4]> = tex.mips[0]
                .chunks_exact(4)
                .map(|p| [k.x * srgb(p[0]), k.y * srgb(p[1]), k.z * srgb(p[2]), 1.0])
                .collect();
            let file = format!("texture{}.exr", t.texture);
            stereocache::output::write_exr(&dir.join(&file), tex.width, tex.height, &rgba).unwrap();
            serde_json::json!({ "diffuse_texture": file })
        } else {
            serde_json::json!({ "diffuse": mat.base_color.truncate().to_array() })
        };
        let emission = (mat.emissive != Vec3::ZERO).then(|| mat.emissive.to_array());
        // Mitsuba's `area` emitter emits from the front only and its
        // `twosided` wrapper turns only the BSDF, and the script writes no
        // emission texture: a double-sided or textured emitter has no twin
        // here (ours emits from both faces and reads the texture), so a
        // scene with one must not reach the comparison.
        assert!(
            emission.is_none() || (!mat.double_sided && mat.emissive_texture.is_none()),
            "{}: a double-sided or textured emitter has no Mitsuba twin in this export",
            mat.name
        );
        shapes.push(serde_json::json!({
            "ply": name, "twosided": mat.double_sided, "bsdf": bsdf, "emission": emission,
            "absorption": absorption,
        }));
    }
    use stereocache::scene::{Environment, LightKind};
    let lights: Vec<_> = s
        .lights
        .iter()
        .map(|l| match l.kind {
            LightKind::Point if l.range.is_none() => serde_json::json!({
                "point": { "position": l.position.to_array(), "intensity": l.radiant.to_array() }
            }),
            LightKind::Spot {
                inner_cone,
                outer_cone,
            } if l.range.is_none() => {
                // Our spot (KHR_lights_punctual's recommended falloff) is
                // a² with a rising linearly in cos θ from cos outer to
                // cos outer + max(0.001, cos inner − cos outer); Mitsuba's
                // rises linearly in θ. Over a band this narrow (4 mrad at
                // an outer angle of 0.25 rad, a sixth of a pixel where it
                // crosses the back wall) both act
                // as a hard edge at their band's integral: ours at
                // cos θ = cos outer + ⅔·band. Mitsuba gets its cutoff
                // there with a band of 10⁻⁵ rad.
                let band = (inner_cone.cos() - outer_cone.cos()).max(1e-3);
                let edge = (outer_cone.cos() + 2.0 / 3.0 * band).acos().to_degrees();
                serde_json::json!({
                    "spot": {
                        "position": l.position.to_array(),
                        "direction": l.direction.to_array(),
                        "intensity": l.radiant.to_array(),
                        "cutoff_deg": edge,
                        "beam_width_deg": edge - 1e-5f32.to_degrees(),
                    }
                })
            }
            LightKind::Directional { angular_radius: 0.0 } => serde_json::json!({
                "directional": { "direction": l.direction.to_array(), "irradiance": l.radiant.to_array() }
            }),
            _ => panic!("light {} has no Mitsuba twin here", l.name),
        })
        .collect();
    let environment = match &s.environment {
        None => serde_json::Value::Null,
        Some(Environment::Constant(c)) => serde_json::json!({ "constant": c.to_array() }),
        Some(Environment::Map {
            width,
            height,
            scale,
            ..
        }) => {
            // Mitsuba's envmap interpolates bilinearly between samples at
            // u = (x + 0.5)/W (as ours) but v = y/(H − 1): row 0 at the +Y
            // pole, row H − 1 at −Y (measured with a ramp map: its value at
            // v is v·(H − 1)). So it gets the same function sampled on its
            // own lattice, not our texels.
            let f =
                map_radiance.expect("an environment map needs the function it was sampled from");
            let (w, h) = (*width, *height);
            let rgba: Vec<[f32; 4]> = (0..h)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .map(|(x, y)| {
                    let phi = (x as f32 + 0.5) / w as f32 * std::f32::consts::TAU;
                    let theta = y as f32 / (h - 1) as f32 * std::f32::consts::PI;
                    let d = Vec3::new(
                        theta.sin() * phi.sin(),
                        theta.cos(),
                        -theta.sin() * phi.cos(),
                    );
                    f(d).extend(1.0).to_array()
                })
                .collect();
            stereocache::output::write_exr(&dir.join("env.exr"), w, h, &rgba).unwrap();
            serde_json::json!({ "map": "env.exr", "scale": scale })
        }
        Some(Environment::Sky { .. }) => panic!("the sky model has no Mitsuba twin"),
    };
    let fwd = camera.orientation * Vec3::NEG_Z;
    let up = camera.orientation * Vec3::Y;
    let cfg = serde_json::json!({
        "width": W, "height": H, "spp": SPP, "seeds": seeds, "max_bounces": BOUNCES,
        "camera": {
            "origin": camera.position.to_array(),
            "target": (camera.position + fwd).to_array(),
            "up": up.to_array(),
            "yfov_deg": camera.yfov.to_degrees(),
        },
        "shapes": shapes,
        "lights": lights,
        "environment": environment,
    });
    std::fs::write(dir.join("scene.json"), cfg.to_string()).unwrap();
}

fn read_f32_image(path: &Path) -> Vec<[f64; 3]> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(bytes.len(), (W * H * 3 * 4) as usize, "{}", path.display());
    bytes
        .chunks_exact(12)
        .map(|p| {
            std::array::from_fn(|c| {
                f32::from_le_bytes(p[4 * c..4 * c + 4].try_into().unwrap()) as f64
            })
        })
        .collect()
}

/// Per block and channel: the mean of the two halves and the variance of
/// that mean, estimated per pixel from the halves' difference
/// (E[((x0 − x1)/2)²] = Var((x0 + x1)/2) for independent halves) and summed
/// over the block's pixels.
fn block_stats(a: &[[f64; 3]], b: &[[f64; 3]]) -> Vec<([f64; 3], [f64; 3])> {
    let n = (BLOCK * BLOCK) as f64;
    let mut out = Vec::new();
    for by in 0..H / BLOCK {
        for bx in 0..W / BLOCK {
            let (mut mean, mut var) = ([0.0; 3], [0.0; 3]);
            for y in by * BLOCK..(by + 1) * BLOCK {
                for x in bx * BLOCK..(bx + 1) * BLOCK {
                    let i = (y * W + x) as usize;
                    for c in 0..3 {
                        mean[c] += 0.5 * (a[i][c] + b[i][c]) / n;
                        var[c] += (0.5 * (a[i][c] - b[i][c])).powi(2) / (n * n);
                    }
                }
            }
            out.push((mean, var));
        }
    }
    out
}

/// The variance standing for float rounding in a mean of `SPP` f32 samples
/// around `m`: a relative error of SPP · 2⁻²⁴ (where neither renderer has
/// noise, e.g. a uniform environment seen directly, the halves agree
/// exactly and the noise estimate is 0).
fn float_variance(m: f64) -> f64 {
    (m.abs() * SPP as f64 * 2f64.powi(-24)).powi(2)
}

/// Whether our reference and Mitsuba's agree within their noise: Err names
/// what does not. Three criteria: no block and channel with |z| > `Z_MAX`,
/// the root mean square of all 192 z at most `Z_RMS_MAX` (a bias too small
/// to push one block past `Z_MAX` but present in many raises it; for equal
/// expectations it is about 1, a little more since the variances are
/// estimates, and it scatters more than 192 independent z would, a block's
/// three channels sharing their paths) — both fixed before the first run —
/// and, added after it, |z| ≤ `Z_MAX` for each channel's whole-image mean
/// (a bias spread thinly over every block).
fn agreement(ours: &[Vec<[f64; 3]>; 2], theirs: &[Vec<[f64; 3]>; 2]) -> Result<(), String> {
    let (a, b) = (
        block_stats(&ours[0], &ours[1]),
        block_stats(&theirs[0], &theirs[1]),
    );
    let mut bad = Vec::new();
    let mut zs = Vec::new();
    for (k, ((ma, va), (mb, vb))) in a.iter().zip(&b).enumerate() {
        for c in 0..3 {
            let z = (ma[c] - mb[c]) / (va[c] + vb[c] + float_variance(ma[c])).sqrt().max(1e-12);
            zs.push(z);
            if z.abs() > Z_MAX {
                bad.push(format!(
                    "block {k} channel {c}: ours {:.4}, Mitsuba {:.4}, z = {z:.1}",
                    ma[c], mb[c]
                ));
            }
        }
    }
    // The whole image: the mean of the block means and its variance.
    let nb = a.len() as f64;
    for c in 0..3 {
        let (ma, mb) = (
            a.iter().map(|x| x.0[c]).sum::<f64>() / nb,
            b.iter().map(|x| x.0[c]).sum::<f64>() / nb,
        );
        let v = (a.iter().map(|x| x.1[c]).sum::<f64>() + b.iter().map(|x| x.1[c]).sum::<f64>())
            / (nb * nb);
        let z = (ma - mb) / (v + float_variance(ma)).sqrt().max(1e-12);
        eprintln!("image channel {c}: ours {ma:.5}, Mitsuba {mb:.5}, z = {z:.2}");
        if z.abs() > Z_MAX {
            bad.push(format!(
                "the whole image, channel {c}: ours {ma:.5}, Mitsuba {mb:.5}, z = {z:.1}"
            ));
        }
    }
    let rms = (zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64).sqrt();
    let max = zs.iter().fold(0.0f64, |m, z| m.max(z.abs()));
    eprintln!(
        "z over {} block means: rms {rms:.2}, max |z| {max:.2}",
        zs.len()
    );
    if bad.is_empty() && rms <= Z_RMS_MAX {
        return Ok(());
    }
    Err(format!(
        "{} block means beyond {Z_MAX} standard errors, rms z {rms:.2} (at most {Z_RMS_MAX}):\n{}",
        bad.len(),
        bad.join("\n")
    ))
}

/// Our reference's left eye for `seed` (ipd 0: the eye is the head).
fn ours(
    s: &stereocache::session::Session,
    cam: stereocache::camera::StereoCamera,
    seed: u32,
) -> Vec<[f64; 3]> {
    let settings = RenderSettings {
        width: W,
        height: H,
        spp: SPP,
        max_bounces: BOUNCES,
        seed,
        ..Default::default()
    };
    let fr = render(s, "reference", cam, &settings);
    fr.eye(Eye::Left)
        .radiance
        .iter()
        .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64])
        .collect()
}

/// Two independent halves of `scene` by each renderer, seen from its
/// default camera with ipd 0 (the left eye is the head).
struct Renders {
    ctx: std::sync::Arc<stereocache::gpu::GpuContext>,
    camera: stereocache::camera::StereoCamera,
    theirs: [Vec<[f64; 3]>; 2],
    ours: [Vec<[f64; 3]>; 2],
}

/// [`Renders`] of `scene` (`map_radiance` as for [`export`]); None when
/// Mitsuba is missing outside CI.
fn render_both(scene: Scene, tag: &str, map_radiance: Option<fn(Vec3) -> Vec3>) -> Option<Renders> {
    let python = mitsuba_python();
    if !require(
        python.is_some(),
        "Mitsuba 3 in .tools/venv (scripts/setup.sh --test)",
    ) {
        return None;
    }
    let ctx = context();
    let dir =
        std::env::temp_dir().join(format!("stereocache-mitsuba-{tag}-{}", std::process::id()));
    let s = session(&ctx, scene.clone(), RtChoice::Software);
    let mut camera = default_camera(&s, W, H);
    camera.ipd = 0.0;
    export(
        &scene,
        &camera.eye(Eye::Left),
        &dir,
        &MITSUBA_SEEDS,
        map_radiance,
    );
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scripts/mitsuba_reference.py");
    let out = std::process::Command::new(python.unwrap())
        .arg(&script)
        .arg(dir.join("scene.json"))
        .arg(dir.join("mitsuba"))
        .output()
        .expect("run mitsuba_reference.py");
    assert!(
        out.status.success(),
        "mitsuba_reference.py failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let theirs = [0, 1].map(|k| read_f32_image(&dir.join(format!("mitsuba_{k}.f32"))));
    let _ = std::fs::remove_dir_all(&dir);
    let ours = OUR_SEEDS.map(|seed| ours(&s, camera, seed));
    Some(Renders {
        ctx,
        camera,
        theirs,
        ours,
    })
}

/// The comparison must fail for `mutated`, a copy of the scene with one
/// deliberate error of `what` (the test can bite).
fn must_catch(r: &Renders, mutated: Scene, what: &str) {
    let s = session(&r.ctx, mutated, RtChoice::Software);
    let wrong = OUR_SEEDS.map(|seed| ours(&s, r.camera, seed));
    let verdict = agreement(&wrong, &r.theirs);
    let first = verdict
        .as_ref()
        .err()
        .map_or("agrees", |e| e.lines().next().unwrap());
    eprintln!("{what}: {first}");
    assert!(verdict.is_err(), "{what} went unnoticed");
}

#[test]
fn reference_matches_mitsuba_on_the_cornell_box() {
    let Some(r) = render_both(comparable_cornell(1.0), "area", None) else {
        return;
    };
    if let Err(e) = agreement(&r.ours, &r.theirs) {
        panic!("the reference disagrees with Mitsuba 3 on the Cornell box: {e}");
    }
    // The shape of the old "glass far too dark" bug, much milder.
    must_catch(&r, comparable_cornell(0.9), "glass 10 % too dark");
    assert_no_validation_messages(&r.ctx);
}

#[test]
fn reference_matches_mitsuba_under_point_spot_directional_and_environment_light() {
    let Some(r) = render_both(comparable_cornell_lit_otherwise(), "lights", None) else {
        return;
    };
    if let Err(e) = agreement(&r.ours, &r.theirs) {
        panic!("the reference disagrees with Mitsuba 3 under point, spot, directional and environment light: {e}");
    }
    let mut brighter = comparable_cornell_lit_otherwise();
    brighter.lights[0].radiant *= 1.1;
    must_catch(&r, brighter, "a point light 10 % too bright");
    let mut wider = comparable_cornell_lit_otherwise();
    let spot = wider.lights.iter_mut().find(|l| l.name == "spot").unwrap();
    spot.kind = stereocache::scene::LightKind::Spot {
        inner_cone: 1.1 * SPOT_OUTER - 1e-3,
        outer_cone: 1.1 * SPOT_OUTER,
    };
    must_catch(&r, wider, "the spot's cone 10 % wider");
    assert_no_validation_messages(&r.ctx);
}

/// Rough glass (roughness 0.3, α = 0.09) under the same point, spot,
/// directional and environment light: its highlights and what it
/// transmits from the delta lights come from next-event estimation at
/// rough dielectric vertices (until session 43 rough glass had none, and
/// the delta lights reached it not at all). Against Mitsuba's
/// `roughdielectric` (GGX, visible normals), which shares our lobe but for
/// the Smith term (separable there, height-correlated here: < 1 % apart
/// at this α away from grazing angles).
#[test]
fn reference_matches_mitsuba_with_rough_glass_under_point_spot_directional_and_environment_light() {
    let rough = |tint: f32| {
        let mut s = comparable_cornell_lit_otherwise();
        s.source = format!("cornell for Mitsuba, rough glass tint {tint}, point, spot, directional and environment light").into();
        let g = s.materials.iter_mut().find(|m| m.name == "glass").unwrap();
        g.roughness = 0.3;
        g.base_color = Vec3::splat(tint).extend(1.0);
        s
    };
    let Some(r) = render_both(rough(1.0), "rough-glass", None) else {
        return;
    };
    if let Err(e) = agreement(&r.ours, &r.theirs) {
        panic!("the reference disagrees with Mitsuba 3 on rough glass: {e}");
    }
    must_catch(&r, rough(0.9), "rough glass 10 % too dark");
    assert_no_validation_messages(&r.ctx);
}

#[test]
fn reference_matches_mitsuba_under_an_environment_map() {
    let Some(r) = render_both(
        environment_map_scene(),
        "env-map",
        Some(environment_radiance),
    ) else {
        return;
    };
    if let Err(e) = agreement(&r.ours, &r.theirs) {
        panic!("the reference disagrees with Mitsuba 3 under an environment map: {e}");
    }
    // Mirrored left to right (u → 1 − u): the lobes move to the other side.
    let mut mirrored = environment_map_scene();
    if let Some(stereocache::scene::Environment::Map { texels, .. }) = &mut mirrored.environment {
        for row in texels.chunks_exact_mut(ENV_W as usize) {
            row.reverse();
        }
    }
    must_catch(&r, mirrored, "the map mirrored");
    // The glass absorbing as over a 20 % longer attenuation distance.
    let mut clearer = environment_map_scene();
    for m in &mut clearer.materials {
        if let Some(v) = &mut m.volume {
            v.attenuation_distance *= 1.2;
        }
    }
    must_catch(&r, clearer, "the glass's absorption 1/1.2 as strong");
    assert_no_validation_messages(&r.ctx);
}

#[test]
fn reference_matches_mitsuba_on_textured_walls() {
    let Some(r) = render_both(textured_cornell(), "texture", None) else {
        return;
    };
    if let Err(e) = agreement(&r.ours, &r.theirs) {
        panic!("the reference disagrees with Mitsuba 3 on textured walls: {e}");
    }
    // The texture upside down (its rows reversed: v → 1 − v).
    let mut flipped = textured_cornell();
    let tex = &mut flipped.textures[0];
    let row = 4 * tex.width as usize;
    let rows: Vec<&[u8]> = tex.mips[0].chunks_exact(row).rev().collect();
    let level0 = rows.concat();
    *tex = stereocache::scene::texture::Texture::with_mips(
        tex.name.clone(),
        tex.encoding,
        tex.width,
        tex.height,
        level0,
    );
    must_catch(&r, flipped, "the texture upside down");
    assert_no_validation_messages(&r.ctx);
}

/// [`smooth_shaded_scene`] with its rough metal sphere half metal
/// (`metallic`; the dielectric half a pure Lambert, specular 0) and its
/// base colour a light tint: glTF's linear metallic mix, and our one-sample
/// choice between the diffuse and the GGX lobe with its mixture density in
/// the MIS weights, against Mitsuba's blendbsdf of its diffuse and its
/// metal.
fn half_metal_scene(metallic: f32) -> Scene {
    let mut s = smooth_shaded_scene(false, ROUGH_METAL_ALPHA);
    s.source =
        format!("smooth-shaded spheres, the metal one metallic {metallic}, for Mitsuba").into();
    let m = s
        .materials
        .iter_mut()
        .find(|m| m.name == "rough metal")
        .unwrap();
    m.metallic = metallic;
    m.specular = 0.0;
    m.base_color = Vec3::new(0.9, 0.75, 0.5).extend(1.0);
    s
}

#[test]
fn reference_matches_mitsuba_on_a_half_metal() {
    let Some(r) = render_both(
        half_metal_scene(0.5),
        "half-metal",
        Some(environment_radiance),
    ) else {
        return;
    };
    if let Err(e) = agreement(&r.ours, &r.theirs) {
        panic!("the reference disagrees with Mitsuba 3 on a half-metal sphere: {e}");
    }
    must_catch(&r, half_metal_scene(0.65), "metallic 0.65 instead of 0.5");
    assert_no_validation_messages(&r.ctx);
}

#[test]
fn reference_matches_mitsuba_with_smooth_shading_normals() {
    let Some(r) = render_both(
        smooth_shaded_scene(false, ROUGH_METAL_ALPHA),
        "smooth",
        Some(environment_radiance),
    ) else {
        return;
    };
    if let Err(e) = agreement(&r.ours, &r.theirs) {
        panic!("the reference disagrees with Mitsuba 3 on smooth-shaded spheres: {e}");
    }
    must_catch(
        &r,
        smooth_shaded_scene(true, ROUGH_METAL_ALPHA),
        "the ellipsoid's normals transformed like positions",
    );
    must_catch(
        &r,
        smooth_shaded_scene(false, 1.2 * ROUGH_METAL_ALPHA),
        "the rough metal's GGX α 20 % larger",
    );
    assert_no_validation_messages(&r.ctx);
}
