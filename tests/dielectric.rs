//! Smooth glass, checked where a ray sent the wrong way shows (a furnace
//! cannot: a uniform environment looks the same from every direction):
//! the sampled directions against Snell's law, Fresnel and total internal
//! reflection through the GLSL (`dielectric_sample_world`, the function the
//! integrator calls); the transmission through a glass sphere at normal
//! incidence on both ray backends; the caustic of a glass sphere; rough
//! glass lit by light sampling: a point light through and in front of a
//! rough sheet against the closed form, and NEE against BSDF sampling.

mod common;
use common::*;
use glam::{DVec3, Mat4, Quat, Vec2, Vec3};
use stereocache::gpu::{
    shaders, Buffer, ComputePipeline, DescriptorLayout, DescriptorSet, Recorder, Resource,
};
use stereocache::interface::dielectric;
use stereocache::methods::RenderSettings;
use stereocache::rt::RtChoice;
use stereocache::scene::generate::{add_material, add_mesh, grid, uv_sphere};
use stereocache::scene::{Material, Scene};

const IOR: f64 = 1.5;

fn glass() -> Material {
    Material {
        name: "glass".into(),
        base_color: glam::Vec4::ONE,
        metallic: 0.0,
        roughness: 0.0,
        transmission: 1.0,
        ior: IOR as f32,
        volume: Some(stereocache::scene::Volume::CLEAR),
        ..Default::default()
    }
}

/// A black (non-reflecting) emitter of radiance `le`, facing `eu × ev`.
fn emitter(le: f32) -> Material {
    Material {
        emissive: Vec3::splat(le),
        specular: 0.0,
        ..Material::diffuse("light", Vec3::ZERO)
    }
}

// ---------------------------------------------------------------------------
// (c) Directions through the GLSL against the physics.

/// One case for dielectric_test.comp and what came back.
struct Case {
    n: DVec3,    // Surface.n: shading normal on the side the ray arrives from
    front: bool, // the ray hit the outside
    d: DVec3,    // ray direction
    u: [f64; 3], // random numbers
}

struct Sampled {
    ok: bool,
    wi: DVec3,
    weight: DVec3,
    delta: bool,
}

fn run_kernel(cases: &[Case], roughness: f32) -> Vec<Sampled> {
    run_kernel_ior(cases, roughness, IOR)
}

/// The same for another index of refraction.
fn run_kernel_ior(cases: &[Case], roughness: f32, ior: f64) -> Vec<Sampled> {
    let ctx = context();
    let raw: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|c| {
            [
                [
                    c.n.x as f32,
                    c.n.y as f32,
                    c.n.z as f32,
                    c.front as u32 as f32,
                ],
                [c.d.x as f32, c.d.y as f32, c.d.z as f32, ior as f32],
                [c.u[0] as f32, c.u[1] as f32, c.u[2] as f32, roughness],
            ]
        })
        .collect();
    let n = cases.len() as u32;
    let inp = Buffer::with_data(
        &ctx,
        "test.cases",
        bytemuck::cast_slice(&raw),
        Default::default(),
    )
    .unwrap();
    let out = Buffer::storage(&ctx, "test.out", n as u64 * 32).unwrap();
    // The kernel's buffers are set 1 (src/interface/dielectric.rs); set 0
    // stands in for the scene's (bound, unused).
    let layout = DescriptorLayout::buffers(&ctx, 2).unwrap();
    let set = DescriptorSet::new(
        &ctx,
        &layout,
        &[Resource::Buffer(&inp), Resource::Buffer(&out)],
    )
    .unwrap();
    let pipe = ComputePipeline::with_interface(
        &ctx,
        "dielectric_test",
        shaders::spirv("common/dielectric_test").expect("dielectric_test compiled"),
        &[layout],
        &dielectric::INTERFACE,
        Some(&dielectric::PUSH),
        &Default::default(),
    )
    .unwrap();
    let mut rec = Recorder::new(&ctx, 1).unwrap();
    rec.compute("dielectric_test", &pipe)
        .shared(&set)
        .read(&inp)
        .write(&out)
        .push(&n)
        .dispatch([n.div_ceil(64), 1, 1])
        .unwrap();
    rec.finish().unwrap();
    let got: Vec<[f32; 4]> = out.download_pod().unwrap();
    assert_no_validation_messages(&ctx);
    (0..cases.len())
        .map(|i| {
            let (a, b) = (got[2 * i], got[2 * i + 1]);
            Sampled {
                ok: a[3] > 0.5,
                wi: DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64),
                weight: DVec3::new(b[0] as f64, b[1] as f64, b[2] as f64),
                delta: b[3] > 0.5,
            }
        })
        .collect()
}

/// Deterministic pseudo-random numbers for the cases.
fn rand01(i: u32, k: u32) -> f64 {
    let h = stereocache::methods::hash_cache::hash::pcg_hash(
        i.wrapping_mul(0x9E37_79B9) ^ k.wrapping_mul(0x85EB_CA6B),
    );
    (h >> 8) as f64 / 16_777_216.0
}

fn random_unit(i: u32, k: u32) -> DVec3 {
    let z = 2.0 * rand01(i, k) - 1.0;
    let phi = std::f64::consts::TAU * rand01(i, k + 1);
    let r = (1.0 - z * z).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A ray direction arriving at a surface of outward normal `out` from outside
/// (`inside` = false) or inside, at incidence angle θ to the normal.
fn arriving(out: DVec3, theta: f64, azimuth: DVec3, inside: bool) -> DVec3 {
    let t = (azimuth - out * azimuth.dot(out)).normalize();
    // Travelling against the normal of the side it comes from.
    let side = if inside { -out } else { out };
    (t * theta.sin() - side * theta.cos()).normalize()
}

/// Snell's law, the side of the surface, the plane of incidence and the
/// Fresnel choice for every smooth case: entering (air → glass), leaving
/// (glass → air), total internal reflection beyond the critical angle, and
/// reflection on both sides; the weight is 1 (white glass) and the event delta.
/// Directions agree with the exact vectors to 2e-5 (f32 arithmetic on unit
/// vectors, about 100 ulps).
/// KHR_materials_ior's ior 0 is an infinite index whose Fresnel term "MUST
/// evaluate to 1.0 independently of the view or light direction": glass of
/// ior 0 reflects every ray back out, at normal incidence too (where the
/// Fresnel quotient was 0/0 and sent a NaN direction on until session 48).
/// Smooth: every sample is the mirror direction with weight 1 (white,
/// specular 1); rough: every successful sample leaves on the outside with
/// a finite weight ≤ 1 (G2/G1).
#[test]
fn ior_zero_glass_reflects_every_ray_at_every_angle() {
    let n = DVec3::Z;
    let mut cases = vec![Case {
        n,
        front: true,
        d: -n,
        u: [0.3, 0.6, 0.999],
    }];
    for i in 0..500u32 {
        let theta = rand01(i, 3) * 85f64.to_radians();
        cases.push(Case {
            n,
            front: true,
            d: arriving(n, theta, random_unit(i, 4), false),
            u: [rand01(i, 7), rand01(i, 8), rand01(i, 6)],
        });
    }
    for roughness in [0.0f32, 0.3] {
        let got = run_kernel_ior(&cases, roughness, 0.0);
        for (k, (s, c)) in got.iter().zip(&cases).enumerate() {
            let what = format!("roughness {roughness}, case {k} (d = {:?})", c.d);
            assert!(
                s.wi.is_finite() && s.weight.is_finite(),
                "{what}: {:?} {:?}",
                s.wi,
                s.weight
            );
            if roughness == 0.0 {
                let mirror = c.d - 2.0 * c.d.dot(n) * n;
                assert!(s.ok && s.delta, "{what}: not a delta reflection");
                assert!(
                    (s.wi.normalize() - mirror).length() < 1e-5,
                    "{what}: {:?}",
                    s.wi
                );
                assert!(
                    (s.weight - DVec3::ONE).abs().max_element() < 1e-5,
                    "{what}: {:?}",
                    s.weight
                );
            } else if s.ok {
                assert!(s.wi.dot(n) > 0.0, "{what}: transmitted {:?}", s.wi);
                assert!(
                    s.weight.max_element() <= 1.0 + 1e-5,
                    "{what}: {:?}",
                    s.weight
                );
            }
        }
    }
}

#[test]
fn smooth_glass_directions_follow_snell_fresnel_and_total_internal_reflection() {
    let critical = (1.0 / IOR).asin();
    let mut cases = Vec::new();
    let mut kinds = Vec::new(); // (inside, theta, want_reflection)
    for i in 0..4000u32 {
        let out = random_unit(i, 1);
        let inside = i % 2 == 1;
        // Angles up to 85°, kept 0.5° away from the critical angle and grazing.
        let mut theta = rand01(i, 3) * 85f64.to_radians();
        if (theta - critical).abs() < 0.5f64.to_radians() {
            theta += 1f64.to_radians();
        }
        let d = arriving(out, theta, random_unit(i, 4), inside);
        let eta = if inside { 1.0 / IOR } else { IOR };
        let f = fresnel_dielectric(theta.cos(), eta);
        // u.z below F reflects; keep it 1e-3 away from F so f32 F cannot flip it.
        let mut uz = rand01(i, 6);
        if i % 3 == 0 {
            uz = 0.5 * f; // forced reflection
        }
        if (uz - f).abs() < 1e-3 {
            uz = (f + 2e-3).min(0.9999);
        }
        let tir = inside && theta > critical;
        cases.push(Case {
            n: if inside { -out } else { out },
            front: !inside,
            d,
            u: [rand01(i, 7), rand01(i, 8), uz],
        });
        kinds.push((inside, theta, tir || uz < f, out, d));
    }
    let got = run_kernel(&cases, 0.0);
    let (mut entering, mut leaving, mut tir, mut reflections) = (0, 0, 0, 0);
    for (k, (s, &(inside, theta, reflect, out, d))) in got.iter().zip(&kinds).enumerate() {
        assert!(
            s.ok && s.delta,
            "case {k}: a smooth sample is a valid delta event"
        );
        assert!(
            (s.weight - DVec3::ONE).abs().max_element() < 1e-6,
            "case {k}: weight {}",
            s.weight
        );
        assert!(
            (s.wi.length() - 1.0).abs() < 2e-5,
            "case {k}: |wi| = {}",
            s.wi.length()
        );
        let side = if inside { -out } else { out }; // the normal on the arriving side
        let want = if reflect {
            d - 2.0 * d.dot(side) * side
        } else {
            // Refraction into the far side: tangential part scaled by η_i/η_t (Snell).
            let eta_ratio = if inside { IOR } else { 1.0 / IOR }; // n_i / n_t
            let cos_i = -d.dot(side);
            let sin2_t = eta_ratio * eta_ratio * (1.0 - cos_i * cos_i);
            assert!(
                sin2_t < 1.0,
                "case {k}: refraction beyond the critical angle"
            );
            eta_ratio * d + (eta_ratio * cos_i - (1.0 - sin2_t).sqrt()) * side
        };
        assert!(
            (s.wi - want).abs().max_element() < 2e-5,
            "case {k} ({} at {:.2}°, {}): wi {} but want {}",
            if inside { "inside" } else { "outside" },
            theta.to_degrees(),
            if reflect { "reflection" } else { "refraction" },
            s.wi,
            want
        );
        // The physics in words: refraction crosses to the other side of the
        // surface (leaving glass goes outwards), reflection stays.
        let goes_out = s.wi.dot(out) > 0.0;
        assert_eq!(
            goes_out,
            reflect != inside,
            "case {k}: wrong side of the surface"
        );
        match (inside, reflect) {
            (false, false) => entering += 1,
            (true, false) => leaving += 1,
            (true, true) if theta > critical => tir += 1,
            _ => reflections += 1,
        }
    }
    assert!(
        entering > 500 && leaving > 300 && tir > 300 && reflections > 500,
        "{entering} {leaving} {tir} {reflections}"
    );
}

// --- CPU twin of bsdf.glsl for the rough dielectric (VNDF sampling depends on
// the tangent frame, so the twin mirrors frame_from too).

fn frame_from(n: DVec3) -> (DVec3, DVec3, DVec3) {
    let s = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        DVec3::new(b, s + n.y * n.y * a, -n.y),
        n,
    )
}

fn lambda(w: DVec3, a: f64) -> f64 {
    let c2 = w.z * w.z;
    if c2 <= 0.0 {
        return 1e30;
    }
    0.5 * (-1.0 + (1.0 + a * a * (1.0 - c2).max(0.0) / c2).sqrt())
}

fn refract(i: DVec3, n: DVec3, eta: f64) -> DVec3 {
    // GLSL refract().
    let k = 1.0 - eta * eta * (1.0 - n.dot(i) * n.dot(i));
    if k < 0.0 {
        DVec3::ZERO
    } else {
        eta * i - (eta * n.dot(i) + k.sqrt()) * n
    }
}

/// bsdf.glsl dielectric_sample_world in f64: (ok, wi_world, weight).
fn twin(n: DVec3, front: bool, d: DVec3, u: [f64; 3], roughness: f64) -> (bool, DVec3, f64) {
    let (t, b, nn) = frame_from(if front { n } else { -n });
    let wd = -d;
    let wo = DVec3::new(wd.dot(t), wd.dot(b), wd.dot(nn));
    let entering = wo.z > 0.0;
    let eta = if entering { IOR } else { 1.0 / IOR };
    let wo_up = if entering { wo } else { -wo };
    let a = (roughness * roughness).max(1e-3);
    let wh = DVec3::new(wo_up.x * a, wo_up.y * a, wo_up.z).normalize();
    let phi = std::f64::consts::TAU * u[0];
    let z = (1.0 - u[1]) * (1.0 + wh.z) - wh.z;
    let st = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
    let h = DVec3::new(st * phi.cos(), st * phi.sin(), z) + wh;
    let h = DVec3::new(h.x * a, h.y * a, h.z.max(1e-7)).normalize();
    let c = wo_up.dot(h);
    let f = fresnel_dielectric(c, eta);
    let wi_up = if u[2] < f {
        let r = -wo_up - 2.0 * (-wo_up).dot(h) * h;
        if r.z <= 0.0 {
            return (false, DVec3::ZERO, 0.0);
        }
        r
    } else {
        let r = refract(-wo_up, h, 1.0 / eta);
        if r == DVec3::ZERO || r.z >= 0.0 {
            return (false, DVec3::ZERO, 0.0);
        }
        r
    };
    let wi_abs = DVec3::new(wi_up.x, wi_up.y, wi_up.z.abs());
    let weight = (1.0 + lambda(wo_up, a)) / (1.0 + lambda(wo_up, a) + lambda(wi_abs, a));
    let wi = if entering { wi_up } else { -wi_up };
    (true, wi.x * t + wi.y * b + wi.z * nn, weight)
}

/// Rough glass (roughness 0.3 and 0.7), entering and leaving: the GLSL's
/// directions and weights equal the f64 twin's to 1e-3 (f32 through VNDF
/// sampling and refraction; cases within 1e-3 of a Fresnel or horizon
/// decision are moved off it). Rough leaving rays also cross to the outside
/// in the majority (a reversed direction would put them inside).
#[test]
fn rough_glass_samples_match_the_cpu_twin() {
    for roughness in [0.3f64, 0.7] {
        let mut cases = Vec::new();
        for i in 0..2000u32 {
            let out = random_unit(i, 11);
            let inside = i % 2 == 1;
            let theta = rand01(i, 12) * 80f64.to_radians();
            let d = arriving(out, theta, random_unit(i, 13), inside);
            let mut u = [rand01(i, 15), rand01(i, 16), rand01(i, 17)];
            // Move u.z off the Fresnel threshold of this microfacet (a decision
            // within 1e-3 of it could go either way in f32).
            let n = if inside { -out } else { out };
            for _ in 0..8 {
                let at = |uz: f64| {
                    twin(
                        n,
                        !inside,
                        d,
                        [u[0], u[1], uz.clamp(0.0, 0.9999)],
                        roughness,
                    )
                };
                let (ok, wi, _) = at(u[2]);
                let stable = [u[2] - 1e-3, u[2] + 1e-3].iter().all(|&z| {
                    let (o, w, _) = at(z);
                    o == ok && (w - wi).length() < 1e-9
                });
                if stable {
                    break;
                }
                u[2] = (u[2] + 0.01) % 1.0;
            }
            cases.push(Case {
                n: if inside { -out } else { out },
                front: !inside,
                d,
                u,
            });
        }
        let got = run_kernel(&cases, roughness as f32);
        let (mut compared, mut out_of_glass, mut leaving_refracted) = (0, 0, 0);
        for (k, (c, s)) in cases.iter().zip(&got).enumerate() {
            let (ok, wi, w) = twin(c.n, c.front, c.d, c.u, roughness);
            // Near the horizon f32 and f64 may disagree on validity; skip only those.
            if ok != s.ok {
                assert!(
                    wi.dot(c.n).abs() < 2e-3 || !ok && s.wi.dot(c.n).abs() < 2e-3,
                    "case {k}: GLSL ok = {} but twin ok = {ok} away from the horizon",
                    s.ok
                );
                continue;
            }
            assert!(!s.delta, "case {k}: rough glass is not a delta event");
            if !ok {
                continue;
            }
            compared += 1;
            assert!(
                (s.wi - wi).abs().max_element() < 1e-3,
                "case {k}: wi {} vs twin {wi}",
                s.wi
            );
            assert!(
                (s.weight.x - w).abs() < 1e-3,
                "case {k}: weight {} vs twin {w}",
                s.weight.x
            );
            let out = if c.front { c.n } else { -c.n };
            if !c.front && wi.dot(out) > 0.0 {
                leaving_refracted += 1;
                out_of_glass += (s.wi.dot(out) > 0.0) as usize;
            }
        }
        assert!(
            compared > 1500,
            "roughness {roughness}: only {compared} cases compared"
        );
        assert_eq!(
            out_of_glass, leaving_refracted,
            "roughness {roughness}: rays leaving glass sent back in"
        );
        assert!(leaving_refracted > 200, "{leaving_refracted}");
    }
}

// ---------------------------------------------------------------------------
// (a) Transmission through a glass sphere at normal incidence.

fn rt_backends(ctx: &stereocache::gpu::GpuContext) -> Vec<RtChoice> {
    let mut v = vec![RtChoice::Software];
    if require(ctx.ray_query_enabled(), "the ray-query backend") {
        v.push(RtChoice::Query);
    }
    v
}

/// A unit sphere of material `m` (`segments` around, half as many rings)
/// at the origin before a 40 m emitter of radiance `le` at z = −4 facing
/// +Z (towards the sphere and a camera on +Z), in a black scene.
fn sphere_before_emitter(m: Material, segments: u32, le: f32) -> Scene {
    let mut s = Scene {
        source: "test:sphere-before-emitter".into(),
        ..Default::default()
    };
    let g = add_material(&mut s, m);
    let e = add_material(&mut s, emitter(le));
    add_mesh(
        &mut s,
        uv_sphere("sphere", segments, segments / 2),
        g,
        Mat4::IDENTITY,
    );
    add_mesh(
        &mut s,
        grid(
            "emitter",
            Vec3::new(-20.0, -20.0, -4.0),
            Vec3::X * 40.0,
            Vec3::Y * 40.0,
            1,
            1,
            Vec2::ONE,
        ),
        e,
        Mat4::IDENTITY,
    );
    s.validate().unwrap();
    s
}

/// A smooth glass sphere (radius 1, η = 1.5) between the camera and a large
/// emitter of radiance Le in an otherwise black scene; a 2° field of view
/// through the sphere's centre, at most 2 scattering events (enter, leave).
/// Each path either refracts twice and reaches the emitter (probability
/// (1 − F)², value Le) or reflects into the black, so the mean radiance is
/// (1 − F)²·Le with F(0) = ((η − 1)/(η + 1))² = 0.04 → 0.9216·Le. Tolerance:
/// 5 standard errors of that Bernoulli mean over all samples, plus the
/// largest change of (1 − F)² over the incidence angles in view (≤ 7.5°,
/// computed). With the old back-face flip every leaving ray went back in.
#[test]
fn glass_sphere_transmits_one_minus_fresnel_squared_at_normal_incidence() {
    let ctx = context();
    let le = 2.0f32;
    let s = sphere_before_emitter(glass(), 192, le);
    let cam = look_at_camera(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 2.0, 1.0);
    let (w, h, spp) = (16u32, 16u32, 64u32);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp,
        max_bounces: 2,
        seed: 3,
        ..Default::default()
    };
    let f0 = ((IOR - 1.0) / (IOR + 1.0)).powi(2);
    let expected = (1.0 - f0).powi(2);
    // Largest incidence angle: corner ray of either eye (ipd/2 off axis).
    let mut max_sin = 0.0f64;
    for v in cam.eyes() {
        for (px, py) in [
            (0.0, 0.0),
            (w as f32, 0.0),
            (0.0, h as f32),
            (w as f32, h as f32),
        ] {
            let dir = v
                .ray_direction(Vec2::new(px, py), glam::UVec2::new(w, h))
                .as_dvec3();
            let o = v.position.as_dvec3();
            // Distance of the ray's line from the centre = sin θ on the unit sphere.
            max_sin = max_sin.max(o.cross(dir).length());
        }
    }
    let bias = (0..=100)
        .map(|k| {
            let th = (max_sin * k as f64 / 100.0).asin();
            (expected - (1.0 - fresnel_dielectric(th.cos(), IOR)).powi(2)).abs()
        })
        .fold(0.0, f64::max);
    let n = (2 * w * h * spp) as f64;
    let se = le as f64 * (expected * (1.0 - expected) / n).sqrt();
    let tol = 5.0 * se + bias * le as f64;
    for rt in rt_backends(&ctx) {
        let sess = session(&ctx, s.clone(), rt);
        let fr = render(&sess, "reference", cam, &settings);
        let (mut sum, mut count) = (0.0f64, 0usize);
        for eye in &fr.eyes {
            for (px, fh) in eye.radiance.iter().zip(&eye.first_hit) {
                assert_eq!(fh[3], 0, "{rt:?}: every pixel sees the sphere (instance 0)");
                sum += px[0] as f64 + px[1] as f64 + px[2] as f64;
                count += 3;
            }
        }
        let mean = sum / count as f64;
        eprintln!(
            "{rt:?}: {:.5}·Le, want {expected:.5} ± {:.5}",
            mean / le as f64,
            tol / le as f64
        );
        assert!(
            (mean - expected * le as f64).abs() < tol,
            "{rt:?}: radiance through the sphere {mean:.5} = {:.4}·Le, want (1 − F0)² = {expected:.4} (±{:.4})",
            mean / le as f64,
            tol / le as f64
        );
    }
    assert_no_validation_messages(&ctx);
}

// ---------------------------------------------------------------------------
// (b) The caustic.

/// A glass ball (radius 1, η = 1.5) above a white diffuse floor, a 0.5 m
/// square light 10 m above the floor, black elsewhere. The ball lens images
/// the light onto the floor below it (ball-lens focal length ηR/2(η − 1) =
/// 1.5 m from the centre; the floor is at the image distance 1.834 m), so the
/// floor there — in the ball's shadow for direct light — is much brighter
/// than the floor's unshadowed direct light ρ/π·π·Le·F (F: the exact form
/// factor to the light). The floor points within 5 cm of the axis are averaged
/// (pixels picked by intersecting their centre rays with the floor on the
/// CPU); they must exceed the direct light by 5 standard errors of their mean
/// (the spread between those pixels, which includes real variation, bounds it).
#[test]
fn glass_sphere_caustic_is_brighter_than_unshadowed_direct_light() {
    let ctx = context();
    let (le, rho, side, height) = (100.0f32, 0.8f32, 0.5f32, 10.0f32);
    let centre_y = 1.834f32;
    let mut s = Scene {
        source: "test:caustic".into(),
        ..Default::default()
    };
    let g = add_material(&mut s, glass());
    let floor = add_material(
        &mut s,
        Material {
            specular: 0.0,
            ..Material::diffuse("floor", Vec3::splat(rho))
        },
    );
    let e = add_material(&mut s, emitter(le));
    add_mesh(
        &mut s,
        uv_sphere("ball", 128, 64),
        g,
        Mat4::from_scale_rotation_translation(
            Vec3::ONE,
            Quat::IDENTITY,
            Vec3::new(0.0, centre_y, 0.0),
        ),
    );
    add_mesh(
        &mut s,
        grid(
            "floor",
            Vec3::new(-10.0, 0.0, 10.0),
            Vec3::X * 20.0,
            Vec3::NEG_Z * 20.0,
            4,
            4,
            Vec2::ONE,
        ),
        floor,
        Mat4::IDENTITY,
    );
    // Facing −Y: eu × ev = Z × X = +Y would face up, so use X × Z = −Y.
    let h = 0.5 * side;
    add_mesh(
        &mut s,
        grid(
            "light",
            Vec3::new(-h, height, -h),
            Vec3::X * side,
            Vec3::Z * side,
            1,
            1,
            Vec2::ONE,
        ),
        e,
        Mat4::IDENTITY,
    );
    s.validate().unwrap();
    let cam = look_at_camera(Vec3::new(4.0, 1.2, 0.0), Vec3::ZERO, 4.0, 1.0);
    let (w, hgt) = (32u32, 32u32);
    let settings = RenderSettings {
        width: w,
        height: hgt,
        spp: 128,
        max_bounces: 3,
        seed: 5,
        ..Default::default()
    };
    let hd = h as f64;
    let direct =
        rho as f64 * le as f64 * form_factor_to_parallel_rect(-hd, hd, -hd, hd, height as f64);
    let sess = session(&ctx, s, RtChoice::Software);
    let fr = render(&sess, "reference", cam, &settings);
    let mut vals = Vec::new();
    for (v, eye) in cam.eyes().iter().zip(&fr.eyes) {
        for (p, px) in eye.radiance.iter().enumerate() {
            let dir = v.ray_direction(pixel_centre(p, w), glam::UVec2::new(w, hgt));
            if dir.y >= 0.0 {
                continue;
            }
            let t = -v.position.y / dir.y;
            let q = v.position + t * dir;
            if Vec2::new(q.x, q.z).length() < 0.05 {
                vals.push((px[0] + px[1] + px[2]) as f64 / 3.0);
            }
        }
    }
    assert!(
        vals.len() >= 20,
        "only {} pixels see the caustic region",
        vals.len()
    );
    let (mean, se) = mean_and_standard_error(&vals);
    eprintln!(
        "caustic {mean:.4} ± {se:.4} over {} pixels, direct {direct:.4}",
        vals.len()
    );
    assert!(
        mean - direct > 5.0 * se,
        "caustic {mean:.4} ± {se:.4} is not brighter than the unshadowed direct light {direct:.4}"
    );
    assert_no_validation_messages(&ctx);
}

// ---------------------------------------------------------------------------
// (e) Light sampling at rough glass (session 43: rough glass used to be a
// delta event for next-event estimation, so delta lights never reached it).

/// A rough thin-walled sheet (KHR_materials_transmission without a volume,
/// roughness 0.3: α = 0.09, ior 1.5, white) filling a 0.1° view from 100 m,
/// lit by a point light of intensity I = 10⁴ 100 m away on the axis: behind
/// the sheet (the transmitted lobe) or at the camera (the reflected one).
/// At normal incidence D = 1/(π α²), G2 = 1 and F = 0.04, so the sheet's
/// radiance is (1 − F)·D/4 · I/d² = 9.431 through it and F·D/4 ·
/// I/d² = 0.3930 in reflection (bsdf.glsl dielectric_eval; the thin sheet's
/// transmission is its reflection lobe mirrored through the surface). Off
/// the axis the view and the light direction tilt the same way (the
/// mirrored lobe), by < 1.3·10⁻³ rad each at the image corners (and the
/// eyes' ±IPD/2 by 3·10⁻⁴), so the half vector by < 1.6·10⁻³ rad, which
/// lowers D by < 0.1 % (1 + tan²θ/α² squared); the tolerance is 0.5 %. With
/// one bounce nothing else lights the sheet. Until session 43 both were 0.
#[test]
fn rough_thin_sheet_is_lit_by_a_point_light_through_and_in_front() {
    let ctx = context();
    let alpha = 0.3f64 * 0.3;
    let d_n = 1.0 / (std::f64::consts::PI * alpha * alpha);
    let f = fresnel_dielectric(1.0, IOR);
    for (name, light_z, want) in [
        ("through", -100.0f32, (1.0 - f) * d_n / 4.0),
        ("in front", 100.0, f * d_n / 4.0),
    ] {
        let mut s = Scene {
            source: "test:rough-sheet".into(),
            ..Default::default()
        };
        let sheet = add_material(
            &mut s,
            Material {
                name: "rough sheet".into(),
                base_color: glam::Vec4::ONE,
                metallic: 0.0,
                roughness: 0.3,
                transmission: 1.0,
                ior: IOR as f32,
                double_sided: true,
                ..Default::default()
            },
        );
        add_mesh(
            &mut s,
            grid(
                "sheet",
                Vec3::new(-10.0, -10.0, 0.0),
                Vec3::X * 20.0,
                Vec3::Y * 20.0,
                1,
                1,
                Vec2::ONE,
            ),
            sheet,
            Mat4::IDENTITY,
        );
        s.lights.push(stereocache::scene::Light {
            name: "point".into(),
            kind: stereocache::scene::LightKind::Point,
            radiant: Vec3::splat(1e4),
            position: Vec3::new(0.0, 0.0, light_z),
            direction: Vec3::NEG_Z,
            range: None,
        });
        s.validate().unwrap();
        let cam = look_at_camera(Vec3::new(0.0, 0.0, 100.0), Vec3::ZERO, 0.1, 1.0);
        let settings = RenderSettings {
            width: 8,
            height: 8,
            spp: 4,
            max_bounces: 1,
            seed: 5,
            ..Default::default()
        };
        let fr = render(
            &session(&ctx, s, RtChoice::Software),
            "reference",
            cam,
            &settings,
        );
        for (e, eye) in fr.eyes.iter().enumerate() {
            for (p, px) in eye.radiance.iter().enumerate() {
                for v in &px[..3] {
                    let v = *v as f64;
                    assert!(
                        (v - want).abs() <= 0.005 * want,
                        "{name}: eye {e} pixel {p}: {px:?}, want {want:.4}"
                    );
                }
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Delta lights through smooth thin sheets (session 54): a white Lambert
/// floor (y = 0) seen from below the sheets, lit through one or two smooth
/// thin-walled sheets (KHR_materials_transmission without a volume,
/// roughness 0, ior 1.5, transmission 0.5, base (0.9, 0.6, 0.3)) at y = 5
/// and 6 by a point light 10 m above the origin (a black ceiling 2 m above
/// it, which a shadow ray that overshot its light would find), a delta
/// directional light straight down, or one at 60° from the vertical. Each
/// sheet passes on transmission·(1 − F(cos θ))·base of the light
/// (path_radiance's expected weight for a path going straight through:
/// integrator.glsl thin_sheet_transmittance), so each pixel's ratio to the
/// same render without the sheets (the same seed: the same floor points,
/// the same light samples) lies between the products at the steepest and
/// at the most normal incidence: for the point light over the floor the
/// view covers (|x|, |z| ≤ 3.2 m: cos θ ≥ 0.91, F from 0.0400 to 0.0406),
/// for the directional lights exactly (F(1) = 0.0400, F(cos 60°) = 0.0891).
/// With two bounces one sheet is within the path's budget and two are not
/// (a path through two sheets to a small emitter would need three): 0
/// there, as for the emitter. The sheets (120 m) outreach the floor (80 m)
/// by more than the slanted light's offset, so a path reflected back down by
/// a sheet finds its light behind them as well. Until session 54 every
/// ratio was 0 (a delta light was never reached through a delta event).
#[test]
fn delta_lights_shine_through_smooth_thin_sheets() {
    use stereocache::scene::{Light, LightKind};
    let ctx = context();
    let tint = [0.9f64, 0.6, 0.3];
    let transmission = 0.5f64;
    let slant = 60f32.to_radians();
    // (name, light, cos θ at the sheets: the range over the view, below)
    let lights = [
        (
            "point light",
            Light {
                name: "point".into(),
                kind: LightKind::Point,
                radiant: Vec3::splat(100.0),
                position: Vec3::new(0.0, 10.0, 0.0),
                direction: Vec3::NEG_Y,
                range: None,
            },
        ),
        (
            "directional light, vertical",
            Light {
                name: "sun".into(),
                kind: LightKind::Directional {
                    angular_radius: 0.0,
                },
                radiant: Vec3::splat(3.0),
                position: Vec3::ZERO,
                direction: Vec3::NEG_Y,
                range: None,
            },
        ),
        (
            "directional light, 60°",
            Light {
                name: "low sun".into(),
                kind: LightKind::Directional {
                    angular_radius: 0.0,
                },
                radiant: Vec3::splat(3.0),
                position: Vec3::ZERO,
                direction: Vec3::new(slant.sin(), -slant.cos(), 0.0),
                range: None,
            },
        ),
    ];
    let cam = look_at_camera(Vec3::new(0.0, 4.5, 6.0), Vec3::ZERO, 20.0, 1.0);
    let scene = |sheets: &[f32], light: &Light| {
        let mut s = Scene {
            source: "test:thin-sheets".into(),
            ..Default::default()
        };
        let floor = add_material(
            &mut s,
            Material {
                name: "floor".into(),
                base_color: glam::Vec4::ONE,
                metallic: 0.0,
                roughness: 1.0,
                double_sided: true,
                ..Default::default()
            },
        );
        add_mesh(
            &mut s,
            grid(
                "floor",
                Vec3::new(-40.0, 0.0, 40.0),
                Vec3::X * 80.0,
                Vec3::NEG_Z * 80.0,
                1,
                1,
                Vec2::ONE,
            ),
            floor,
            Mat4::IDENTITY,
        );
        let sheet = add_material(
            &mut s,
            Material {
                name: "window".into(),
                base_color: glam::Vec4::new(tint[0] as f32, tint[1] as f32, tint[2] as f32, 1.0),
                metallic: 0.0,
                roughness: 0.0,
                transmission: transmission as f32,
                ior: IOR as f32,
                double_sided: true,
                ..Default::default()
            },
        );
        for (i, y) in sheets.iter().enumerate() {
            add_mesh(
                &mut s,
                grid(
                    &format!("sheet {i}"),
                    Vec3::new(-60.0, *y, 60.0),
                    Vec3::X * 120.0,
                    Vec3::NEG_Z * 120.0,
                    1,
                    1,
                    Vec2::ONE,
                ),
                sheet,
                Mat4::IDENTITY,
            );
        }
        if light.kind == LightKind::Point {
            let black = add_material(
                &mut s,
                Material {
                    name: "ceiling".into(),
                    base_color: glam::Vec4::new(0.0, 0.0, 0.0, 1.0),
                    metallic: 0.0,
                    specular: 0.0,
                    double_sided: true,
                    ..Default::default()
                },
            );
            add_mesh(
                &mut s,
                grid(
                    "ceiling",
                    Vec3::new(-60.0, 12.0, 60.0),
                    Vec3::X * 120.0,
                    Vec3::NEG_Z * 120.0,
                    1,
                    1,
                    Vec2::ONE,
                ),
                black,
                Mat4::IDENTITY,
            );
        }
        s.lights.push(light.clone());
        s.validate().unwrap();
        s
    };
    // The floor the view covers, from the camera's corner rays.
    let v = cam.eyes()[0];
    let mut reach = 0.0f64;
    for (px, py) in [(0.0, 0.0), (16.0, 0.0), (0.0, 16.0), (16.0, 16.0)] {
        let d = v
            .ray_direction(Vec2::new(px, py), glam::UVec2::new(16, 16))
            .as_dvec3();
        let o = v.position.as_dvec3();
        let t = -o.y / d.y;
        reach = reach.max((o.x + t * d.x).abs()).max((o.z + t * d.z).abs());
    }
    assert!(reach < 3.2, "the view covers the floor to {reach} m");
    let cos_range = [
        (10.0 / (10.0f64 * 10.0 + 2.0 * reach * reach).sqrt(), 1.0),
        (1.0, 1.0),
        ((slant as f64).cos(), (slant as f64).cos()),
    ];
    let sheet_t = |c: f64| transmission * (1.0 - fresnel_dielectric(c, IOR));
    for rt in rt_backends(&ctx) {
        for ((name, light), (c_lo, c_hi)) in lights.iter().zip(cos_range) {
            for bounces in [2u32, 3] {
                let settings = RenderSettings {
                    width: 16,
                    height: 16,
                    spp: 2,
                    max_bounces: bounces,
                    seed: 9,
                    ..Default::default()
                };
                let open = render(
                    &session(&ctx, scene(&[], light), rt),
                    "reference",
                    cam,
                    &settings,
                );
                let cases: &[(&[f32], i32)] = if bounces == 2 {
                    &[(&[5.0], 1), (&[5.0, 6.0], 0)]
                } else {
                    &[(&[5.0, 6.0], 2)]
                };
                for &(sheets, count) in cases {
                    let covered = render(
                        &session(&ctx, scene(sheets, light), rt),
                        "reference",
                        cam,
                        &settings,
                    );
                    for (e, (a, b)) in open.eyes.iter().zip(&covered.eyes).enumerate() {
                        for (p, (pa, pb)) in a.radiance.iter().zip(&b.radiance).enumerate() {
                            for k in 0..3 {
                                let (lo, hi) = if count == 0 {
                                    (0.0, 0.0)
                                } else {
                                    (
                                        (sheet_t(c_lo) * tint[k]).powi(count),
                                        (sheet_t(c_hi) * tint[k]).powi(count),
                                    )
                                };
                                let r = pb[k] as f64 / pa[k] as f64;
                                assert!(
                                    pa[k] > 0.0 && r >= lo * (1.0 - 1e-4) && r <= hi * (1.0 + 1e-4),
                                    "{rt:?}, {name}, {} sheet(s), {bounces} bounces: eye {e} pixel {p} channel {k}: {} / {} = {r:.5}, want [{lo:.5}, {hi:.5}]",
                                    sheets.len(),
                                    pb[k],
                                    pa[k]
                                );
                            }
                        }
                    }
                }
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Light sampling and BSDF sampling must see the same rough glass: an
/// emitter behind rough glass (roughness 0.4), a thin sheet and a sphere
/// with a volume (its back face transmits towards the emitter from inside,
/// two bounces), and a clearcoat over the sheet, rendered by NEE alone and
/// by BSDF sampling alone agree on the glass's pixels within 5 standard
/// errors (`assert_light_samplers_agree_at`). NEE uses dielectric_eval's
/// f·cos and BSDF-sampled hits are weighted 0, so a density that is not the
/// sampler's shows here.
#[test]
fn rough_glass_light_sampling_agrees_with_bsdf_sampling() {
    let ctx = context();
    for (what, volume, coat) in [
        ("thin sheet", false, 0.0f32),
        ("sphere with a volume", true, 0.0),
        ("coated sheet", false, 1.0),
    ] {
        let mut s = Scene {
            source: "test:rough-glass-before-emitter".into(),
            ..Default::default()
        };
        let mut m = Material {
            name: "rough glass".into(),
            base_color: glam::Vec4::new(0.9, 0.8, 1.0, 1.0),
            metallic: 0.0,
            roughness: 0.4,
            transmission: 1.0,
            ior: IOR as f32,
            double_sided: true,
            volume: volume.then_some(stereocache::scene::Volume::CLEAR),
            ..Default::default()
        };
        m.clearcoat.factor = coat;
        m.clearcoat.roughness = 0.2;
        let g = add_material(&mut s, m);
        let e = add_material(&mut s, emitter(2.0));
        if volume {
            add_mesh(&mut s, uv_sphere("sphere", 96, 48), g, Mat4::IDENTITY);
        } else {
            add_mesh(
                &mut s,
                grid(
                    "sheet",
                    Vec3::new(-1.0, -1.0, 0.0),
                    Vec3::X * 2.0,
                    Vec3::Y * 2.0,
                    1,
                    1,
                    Vec2::ONE,
                ),
                g,
                Mat4::IDENTITY,
            );
        }
        // A 1.5 m square emitter at z = −3 facing +Z, off the axis so both
        // lobes' tails and peaks are sampled.
        add_mesh(
            &mut s,
            grid(
                "emitter",
                Vec3::new(-0.5, -0.2, -3.0),
                Vec3::X * 1.5,
                Vec3::Y * 1.5,
                1,
                1,
                Vec2::ONE,
            ),
            e,
            Mat4::IDENTITY,
        );
        s.validate().unwrap();
        let sess = session(&ctx, s, RtChoice::Software);
        let cam = look_at_camera(Vec3::new(0.3, 0.2, 3.0), Vec3::ZERO, 40.0, 1.0);
        let bounces = if volume { 2 } else { 1 };
        assert_light_samplers_agree_at(&sess, g, cam, 16, 16, bounces, what);
    }
    assert_no_validation_messages(&ctx);
}

/// A rough (roughness 0.5) solid sphere of index 1 — KHR_materials_ior
/// 1.0, the same medium as outside — before an emitter of radiance Le in
/// a black scene: every microfacet refracts straight through and Fresnel
/// reflects nothing, so every pixel is exactly Le (white base, no
/// absorption). Until session 44 the rough lobe's density there was taken
/// at the half vector −normalize(wo + wi) of a zero (or rounding-sized)
/// vector, which weighed the emission seen through by an arbitrary MIS
/// weight and light-sampled the emitter with an arbitrary BSDF value.
#[test]
fn an_index_matched_rough_boundary_passes_light_straight_through() {
    let ctx = context();
    let le = 2.0f32;
    let s = sphere_before_emitter(
        Material {
            roughness: 0.5,
            ior: 1.0,
            ..glass()
        },
        48,
        le,
    );
    let cam = look_at_camera(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 20.0, 1.0);
    let settings = RenderSettings {
        width: 16,
        height: 16,
        spp: 8,
        max_bounces: 3,
        seed: 5,
        ..Default::default()
    };
    for rt in rt_backends(&ctx) {
        let sess = session(&ctx, s.clone(), rt);
        let f = render(&sess, "reference", cam, &settings);
        for (k, eye) in f.eyes.iter().enumerate() {
            for (p, c) in eye.radiance.iter().enumerate() {
                assert!(
                    (0..3).all(|i| (c[i] - le).abs() <= 1e-4 * le),
                    "{rt:?}, eye {k}, pixel {p}: {:?}, want {le}",
                    &c[..3]
                );
            }
        }
    }
    assert_no_validation_messages(&ctx);
}
