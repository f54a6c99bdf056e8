//! Furnace tests: known answers for energy conservation of the BSDFs.

mod common;
use common::*;
use glam::Vec3;
use stereocache::methods::RenderSettings;
use stereocache::rt::RtChoice;
use stereocache::scene::Material;

/// A white Lambertian sphere (no specular layer: KHR_materials_specular = 0)
/// in a uniform white environment returns exactly the environment radiance:
/// every cosine-weighted sample carries weight 1 and escapes (the sphere is
/// convex), so the only tolerance is float rounding. The sphere is faceted so
/// shading normals equal geometric normals (see the next test for smooth ones).
#[test]
fn lambert_white_furnace_returns_environment_radiance() {
    let ctx = context();
    for rt in [RtChoice::Software, RtChoice::Query] {
        if rt == RtChoice::Query && !require(ctx.ray_query_enabled(), "ray queries") {
            continue;
        }
        let s = session(
            &ctx,
            faceted_sphere_in_environment(lambert_white(), Vec3::ONE),
            rt,
        );
        let cam = look_at_camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 45.0, 1.0);
        let settings = RenderSettings {
            width: 48,
            height: 48,
            spp: 8,
            max_bounces: 3,
            seed: 7,
            all_features: false,
            ..Default::default()
        };
        let f = render(&s, "reference", cam, &settings);
        let mut sphere_pixels = 0;
        for eye in &f.eyes {
            for (px, fh) in eye.radiance.iter().zip(&eye.first_hit) {
                for c in &px[..3] {
                    assert!(
                        (c - 1.0).abs() < 1e-5,
                        "{rt:?}: radiance {c} differs from the environment's 1.0"
                    );
                }
                sphere_pixels += (fh[3] != u32::MAX) as usize;
            }
        }
        assert!(
            sphere_pixels > 1000,
            "the sphere covers {sphere_pixels} pixels"
        );
    }
    assert_no_validation_messages(&ctx);
}

fn lambert_white() -> Material {
    let mut m = Material::diffuse("white", Vec3::ONE);
    m.specular = 0.0;
    m
}

/// With smooth (interpolated) normals, cosine samples within the angle δ
/// between shading and geometric normal of the tangent plane go below the
/// geometric surface and are discarded: at most sin²δ of the energy per
/// sample (δ ≤ half the 3.75° facet angle of a 96-segment sphere). Nothing
/// may exceed the environment, and the mean loss stays below that bound.
#[test]
fn lambert_smooth_sphere_loses_at_most_the_shading_normal_fraction() {
    let ctx = context();
    let s = session(
        &ctx,
        sphere_in_environment(lambert_white(), Vec3::ZERO, 1.0, Vec3::ONE),
        RtChoice::Software,
    );
    let cam = look_at_camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 45.0, 1.0);
    let settings = RenderSettings {
        width: 48,
        height: 48,
        spp: 8,
        max_bounces: 3,
        seed: 7,
        all_features: false,
        ..Default::default()
    };
    let f = render(&s, "reference", cam, &settings);
    let delta = (3.75f64 / 2.0).to_radians();
    let bound = delta.sin().powi(2);
    let (mut sum, mut n) = (0.0f64, 0usize);
    for eye in &f.eyes {
        for (px, fh) in eye.radiance.iter().zip(&eye.first_hit) {
            assert!(
                px[0] <= 1.0 + 1e-5,
                "radiance {} above the environment",
                px[0]
            );
            if fh[3] != u32::MAX {
                sum += 1.0 - px[0] as f64;
                n += 1;
            }
        }
    }
    let mean_loss = sum / n as f64;
    assert!(
        mean_loss <= bound,
        "mean loss {mean_loss:.2e} exceeds sin²δ = {bound:.2e}"
    );
    assert_no_validation_messages(&ctx);
}

/// Smith-GGX directional albedo E(μ) of a white metal (F = 1): the expected
/// value of G2/G1(wo) under visible-normal sampling, computed on the CPU in
/// f64 with stratified samples (quadrature error ≪ the GPU tolerance).
fn ggx_albedo(mu: f64, roughness: f64) -> f64 {
    let a = (roughness * roughness).max(1e-3);
    let wo = [(1.0 - mu * mu).sqrt(), 0.0, mu];
    let lambda = |w: [f64; 3]| {
        let c2 = w[2] * w[2];
        if c2 <= 0.0 {
            return f64::INFINITY;
        }
        let t2 = (1.0 - c2).max(0.0) / c2;
        0.5 * (-1.0 + (1.0 + a * a * t2).sqrt())
    };
    let n = 1000;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (u1, u2) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            // Spherical-cap VNDF sampling (Dupuy & Benyoub 2023), as in bsdf.glsl.
            let wh = {
                let v = [wo[0] * a, wo[1] * a, wo[2]];
                let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                [v[0] / l, v[1] / l, v[2] / l]
            };
            let phi = 2.0 * std::f64::consts::PI * u1;
            let z = (1.0 - u2) * (1.0 + wh[2]) - wh[2];
            let st = (1.0 - z * z).max(0.0).sqrt();
            let h = [st * phi.cos() + wh[0], st * phi.sin() + wh[1], z + wh[2]];
            let h = [h[0] * a, h[1] * a, h[2].max(1e-7)];
            let l = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            let h = [h[0] / l, h[1] / l, h[2] / l];
            let d = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
            let wi = [
                2.0 * d * h[0] - wo[0],
                2.0 * d * h[1] - wo[1],
                2.0 * d * h[2] - wo[2],
            ];
            if wi[2] <= 0.0 {
                continue;
            }
            let g2 = 1.0 / (1.0 + lambda(wo) + lambda(wi));
            let g1 = 1.0 / (1.0 + lambda(wo));
            sum += g2 / g1;
        }
    }
    sum / (n * n) as f64
}

/// A white GGX metal plane in a white environment, seen at a fixed angle with
/// a narrow field of view: the mean radiance equals the single-scattering
/// albedo E(μ) — it loses exactly the model's known single-scattering energy
/// and no more. E(μ) from two quadratures that share no sampling: half
/// vectors by D's own inverse CDF (`gltf_brdf_albedo`, written from the glTF
/// specification's formulas) and visible normals (`ggx_albedo`, the
/// shaders' sampling done in f64). Both integrands jump to 0 where the
/// reflected direction leaves the hemisphere, so a midpoint rule over n × n
/// cells errs by O(1/n) there (the cells the jump cuts): the two must agree
/// within 1/384 (the coarser grid's 1/n), and that bound is added to the
/// tolerance. Each sample is G2/G1 ∈ [0, 1], so its standard deviation is at
/// most 1/2 and the tolerance is 5σ of the mean over all samples.
#[test]
fn ggx_white_furnace_matches_single_scattering_albedo() {
    let ctx = context();
    let mut worst = 0.0f64;
    for &(roughness, view_deg) in &[
        (0.1f32, 0.0f32),
        (0.3, 45.0),
        (0.5, 60.0),
        (0.8, 30.0),
        (1.0, 70.0),
    ] {
        let mut m = Material::diffuse("white metal", Vec3::ONE);
        m.metallic = 1.0;
        m.roughness = roughness;
        let s = session(
            &ctx,
            plane_in_environment(m, 1000.0, Vec3::ONE),
            RtChoice::Software,
        );
        let theta = view_deg.to_radians();
        let target = Vec3::ZERO;
        let eye = target + 10.0 * Vec3::new(0.0, theta.cos(), theta.sin());
        // Looking straight down along −Y at 0°: use a tilted up vector via a tiny offset.
        let eye = if view_deg == 0.0 {
            eye + Vec3::new(0.0, 0.0, 1e-3)
        } else {
            eye
        };
        let cam = look_at_camera(eye, target, 1.0, 1.0);
        let (w, h, spp) = (32u32, 32u32, 32u32);
        let settings = RenderSettings {
            width: w,
            height: h,
            spp,
            max_bounces: 1,
            seed: 3,
            all_features: false,
            ..Default::default()
        };
        let f = render(&s, "reference", cam, &settings);
        let mut sum = 0.0f64;
        let mut n = 0usize;
        for eye in &f.eyes {
            for px in &eye.radiance {
                sum += px[0] as f64;
                n += 1;
            }
        }
        let mean = sum / n as f64;
        let mu = (view_deg as f64).to_radians().cos();
        let expected = gltf_brdf_albedo(mu, [1.0; 3], 1.0, roughness as f64).specular[0];
        let quadrature = (ggx_albedo(mu, roughness as f64) - expected).abs();
        assert!(
            quadrature <= 1.0 / 384.0,
            "roughness {roughness}, view {view_deg}°: the two quadratures differ by {quadrature:e}"
        );
        let sigma = 0.5 / ((n as f64) * spp as f64).sqrt();
        let err = (mean - expected).abs();
        worst = worst.max(err / sigma);
        eprintln!("roughness {roughness}, view {view_deg}°: mean {mean:.5}, E {expected:.5}, quadratures differ by {quadrature:.1e}, σ {sigma:.1e}");
        assert!(
            err < 5.0 * sigma + 1.0 / 384.0,
            "roughness {roughness}, view {view_deg}°: mean {mean:.5} vs single-scattering albedo {expected:.5} (σ {sigma:.5})"
        );
        assert!(mean <= 1.0 + 5.0 * sigma, "energy gain: {mean}");
    }
    eprintln!("worst deviation {worst:.2} σ");
    assert_no_validation_messages(&ctx);
}

/// A white Lambertian plane tilted in all three axes, 2 km across and
/// passing through the origin (where the render origin sits), double-sided,
/// in a uniform white environment, one bounce: every cosine-weighted bounce
/// ray escapes with weight 1, so every pixel is exactly 1 — unless the ray
/// re-hits the plane it leaves (then 0: its bounce budget is spent). The
/// rounding error of a hit point on this triangle grows with its vertices
/// (≈ 10⁻⁴ m at 1 km), not with the point's own coordinates (≈ 1 m from
/// the origin here), so an offset of 256 ulps of the point alone
/// (3·10⁻⁵ m) let about a fifth of the bounce rays start behind the plane
/// and hit it (session 44; scene.glsl `surface_offset` now offsets by the
/// vertices' magnitude too). Checked on both ray backends.
#[test]
fn a_large_plane_near_the_origin_does_not_shadow_itself() {
    use glam::{Mat4, Vec2};
    use stereocache::scene::generate::{add_material, add_mesh, grid};
    let ctx = context();
    let mut s = stereocache::scene::Scene {
        source: "test:kilometre plane".into(),
        ..Default::default()
    };
    let mut m = lambert_white();
    m.double_sided = true;
    let mat = add_material(&mut s, m);
    let r = 1000.0f32;
    add_mesh(
        &mut s,
        grid(
            "plane",
            Vec3::new(-r, 0.0, r),
            Vec3::X * (2.0 * r),
            Vec3::NEG_Z * (2.0 * r),
            1,
            1,
            Vec2::ONE,
        ),
        mat,
        Mat4::from_rotation_x(0.37) * Mat4::from_rotation_z(0.23) * Mat4::from_rotation_y(0.61),
    );
    s.environment = Some(stereocache::scene::Environment::Constant(Vec3::ONE));
    s.validate().unwrap();
    let n = (Mat4::from_rotation_x(0.37) * Mat4::from_rotation_z(0.23)).transform_vector3(Vec3::Y);
    let settings = RenderSettings {
        width: 32,
        height: 32,
        spp: 4,
        max_bounces: 1,
        seed: 3,
        all_features: false,
        ..Default::default()
    };
    for rt in rt_backends(&ctx) {
        let sess = session(&ctx, s.clone(), rt);
        // 2 m above the plane's point at the origin, looking down at it
        // from 40° off the normal: the pixels see points within ≈ 1.5 m.
        let eye = n * 1.5 + n.cross(Vec3::X).normalize() * 1.3;
        let f = render(
            &sess,
            "reference",
            look_at_camera(eye, Vec3::ZERO, 60.0, 1.0),
            &settings,
        );
        let mut dark = 0usize;
        for e in &f.eyes {
            for (p, fh) in e.radiance.iter().zip(&e.first_hit) {
                assert_ne!(fh[3], u32::MAX, "{rt:?}: a pixel misses the plane");
                dark += p[..3].iter().any(|c| (c - 1.0).abs() > 1e-5) as usize;
            }
        }
        assert_eq!(
            dark,
            0,
            "{rt:?}: {dark} of {} pixels darker than the environment",
            2 * 32 * 32
        );
    }
    assert_no_validation_messages(&ctx);
}

/// A closed box of emissive Lambert walls (albedo ρ, emission Le, no
/// specular layer, faces towards the inside) seen from its centre: whatever
/// the enclosure's shape, every wall point receives uniform radiance from
/// the walls, so the radiance after k bounces obeys L_k = Le + ρ L_{k−1}, and
/// a path tracer limited to B bounces (hits 0..B, the last one's emission
/// counted) returns Le·Σ_{k=0..B} ρ^k in every pixel. This exercises what
/// the convex furnaces above cannot: emitters found both by light sampling
/// (every wall is an emitter) and by BSDF sampling, weighted by MIS at every
/// vertex, Russian roulette from the second bounce (β = ρ = q: unbiased only
/// if divided by q), and the bounce count. The reference's pixels are
/// independent: the image mean must lie within 5 standard errors (from the
/// pixels' spread) of the series, plus 10⁻⁴ relative for f32 sums.
#[test]
fn emissive_lambert_box_returns_the_bounce_series() {
    use stereocache::scene::generate::{add_material, add_mesh, grid};
    use stereocache::scene::Scene;
    let ctx = context();
    let (rho, le) = (0.5f32, 1.0f32);
    let mut scene = Scene {
        source: "test:emissive-box".into(),
        ..Default::default()
    };
    let mut wall = Material::diffuse("wall", Vec3::splat(rho));
    wall.specular = 0.0;
    wall.emissive = Vec3::splat(le);
    let mat = add_material(&mut scene, wall);
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    // (origin, u, v): u × v is each face's normal, towards the inside.
    let faces = [
        (Vec3::new(-1.0, -1.0, 1.0), x, -z), // floor, +y
        (Vec3::new(-1.0, 1.0, -1.0), x, z),  // ceiling, −y
        (Vec3::new(-1.0, -1.0, -1.0), y, z), // x = −1, +x
        (Vec3::new(1.0, -1.0, -1.0), z, y),  // x = +1, −x
        (Vec3::new(-1.0, -1.0, -1.0), x, y), // z = −1, +z
        (Vec3::new(-1.0, -1.0, 1.0), y, x),  // z = +1, −z
    ];
    for (i, (o, u, v)) in faces.into_iter().enumerate() {
        let m = grid(&format!("face{i}"), o, u, v, 2, 2, glam::Vec2::ONE);
        add_mesh(&mut scene, m, mat, glam::Mat4::IDENTITY);
    }
    scene.validate().unwrap();
    let s = session(&ctx, scene, RtChoice::Software);
    let cam = look_at_camera(
        Vec3::new(0.1, 0.2, 0.3),
        Vec3::new(0.5, -0.3, -1.0),
        100.0,
        1.0,
    );
    for bounces in [1u32, 2, 5] {
        let want: f64 = (0..=bounces)
            .map(|k| (le * rho.powi(k as i32)) as f64)
            .sum();
        let settings = RenderSettings {
            width: 24,
            height: 24,
            spp: 32,
            max_bounces: bounces,
            seed: 11,
            all_features: false,
            ..Default::default()
        };
        let f = render(&s, "reference", cam, &settings);
        for k in 0..3 {
            let v: Vec<f64> = f
                .eyes
                .iter()
                .flat_map(|e| e.radiance.iter().map(move |p| p[k] as f64))
                .collect();
            let (mean, se) = mean_and_standard_error(&v);
            eprintln!("{bounces} bounces, channel {k}: {mean:.5} ± {se:.5}, series {want:.5}");
            assert!(
                (mean - want).abs() <= 5.0 * se + 1e-4 * want,
                "{bounces} bounces, channel {k}: mean {mean} ± {se}, want Le·Σρ^k = {want}"
            );
        }
    }
    assert_no_validation_messages(&ctx);
}
