//! `debug-normals`: the colour is 0.5·n + 0.5 of the world-space shading
//! normal at the pixel-centre first hit, black for a miss; depth, first hits
//! and albedo are those of `reference`'s primary pass; one primary ray per
//! pixel and eye. Checked where the normal is known exactly: a tilted plane
//! (one normal, rotated by its instance transform) and a faceted sphere (each
//! triangle's normal is its face normal, computed here from its vertices).
//! Both ray backends; no validation message.

mod common;
use common::*;
use glam::{Mat4, Vec3};
use stereocache::camera::StereoCamera;
use stereocache::methods::{RenderSettings, StereoFrame};
use stereocache::rt::RtChoice;
use stereocache::scene::{Material, Scene};

const W: u32 = 40;
const H: u32 = 30;

/// Float-precision bound on a colour channel: the GPU normalizes a normal
/// that is exact up to a few roundings (the barycentric sum of three equal
/// vertex normals, or the inverse-transpose of the instance transform: each
/// a few ulp of 1), then 0.5·n + 0.5 rounds once more. 8 ulp of 1 covers it.
const TOL: f32 = 8.0 * f32::EPSILON;

fn settings() -> RenderSettings {
    RenderSettings {
        width: W,
        height: H,
        spp: 1,
        max_bounces: 1,
        seed: 1,
        ..Default::default()
    }
}

fn camera(eye: Vec3, target: Vec3) -> StereoCamera {
    look_at_camera(eye, target, 60.0, W as f32 / H as f32)
}

/// Renders `method` on `scene` with backend `rt`.
fn frame(
    ctx: &std::sync::Arc<stereocache::gpu::GpuContext>,
    scene: &Scene,
    rt: RtChoice,
    method: &str,
    cam: StereoCamera,
) -> StereoFrame {
    let s = session(ctx, scene.clone(), rt);
    render(&s, method, cam, &settings())
}

/// Checks every pixel of both eyes: a hit's colour is 0.5·n + 0.5 of
/// `expected(first_hit)` within `TOL`, a miss is black with depth 0; the
/// outputs other than colour are exactly `reference`'s primary pass; the
/// frame traced 2·W·H primary rays and nothing else. Returns (hits, misses).
fn check(
    f: &StereoFrame,
    r: &StereoFrame,
    expected: &dyn Fn([u32; 4]) -> Vec3,
    what: &str,
) -> (usize, usize) {
    let (mut hits, mut misses) = (0, 0);
    for e in 0..2 {
        let (d, re) = (&f.eyes[e], &r.eyes[e]);
        for i in 0..(W * H) as usize {
            let c = d.radiance[i];
            let fh = d.first_hit[i];
            assert_eq!(
                fh, re.first_hit[i],
                "{what}: eye {e} pixel {i} first hit vs reference"
            );
            assert_eq!(
                d.depth[i].to_bits(),
                re.depth[i].to_bits(),
                "{what}: eye {e} pixel {i} depth vs reference"
            );
            assert_eq!(
                d.albedo[i], re.albedo[i],
                "{what}: eye {e} pixel {i} albedo vs reference"
            );
            if fh[3] == u32::MAX {
                misses += 1;
                assert_eq!(
                    c[..3],
                    [0.0; 3],
                    "{what}: eye {e} pixel {i}: a miss is black"
                );
                assert_eq!(
                    d.depth[i], 0.0,
                    "{what}: eye {e} pixel {i}: a miss has depth 0"
                );
            } else {
                hits += 1;
                let want = 0.5 * expected(fh) + Vec3::splat(0.5);
                for k in 0..3 {
                    assert!(
                        (c[k] - want[k]).abs() <= TOL,
                        "{what}: eye {e} pixel {i} colour {c:?}, expected {want:?} (first hit {fh:?})"
                    );
                }
            }
        }
    }
    let rays = f.stats.rays;
    assert_eq!(
        (rays.primary, rays.bounce, rays.shadow),
        (2 * (W * H) as u64, 0, 0),
        "{what}: ray counts"
    );
    (hits, misses)
}

/// Both backends (the query one where the device has ray queries; a skip
/// fails in CI), each against `expected` and against the other.
fn check_backends(
    scene: &Scene,
    cam: StereoCamera,
    expected: &dyn Fn([u32; 4]) -> Vec3,
    what: &str,
) {
    let ctx = context();
    let mut backends = vec![RtChoice::Software];
    if require(ctx.ray_query_enabled(), "ray queries (the second backend)") {
        backends.push(RtChoice::Query);
    }
    let mut frames = Vec::new();
    for rt in backends {
        let what = format!("{what} ({rt:?})");
        let f = frame(&ctx, scene, rt, "debug-normals", cam);
        let r = frame(&ctx, scene, rt, "reference", cam);
        let (hits, misses) = check(&f, &r, expected, &what);
        // The camera sees the object and the background around it.
        assert!(
            hits > (W * H) as usize / 4 && misses > (W * H) as usize / 10,
            "{what}: {hits} hits, {misses} misses"
        );
        frames.push(f);
    }
    if let [s, q] = &frames[..] {
        // Same hit/miss mask and, where both hit the same triangle, the same
        // normal (as tests/backends.rs: ids on ≥ 99.9 % of pixels).
        let (mut id_mismatch, mut n) = (0, 0);
        for e in 0..2 {
            for i in 0..(W * H) as usize {
                n += 1;
                let (a, b) = (s.eyes[e].first_hit[i], q.eyes[e].first_hit[i]);
                assert_eq!(
                    a[3] == u32::MAX,
                    b[3] == u32::MAX,
                    "{what}: eye {e} pixel {i} hit in one backend only"
                );
                if a[2..] != b[2..] {
                    id_mismatch += 1;
                    continue;
                }
                let (ca, cb) = (s.eyes[e].radiance[i], q.eyes[e].radiance[i]);
                for k in 0..3 {
                    assert!(
                        (ca[k] - cb[k]).abs() <= TOL,
                        "{what}: eye {e} pixel {i}: software {ca:?}, query {cb:?}"
                    );
                }
            }
        }
        assert!(
            id_mismatch * 1000 <= n,
            "{what}: {id_mismatch} of {n} pixels hit different triangles"
        );
    }
    assert_no_validation_messages(&ctx);
}

#[test]
fn tilted_plane_shows_its_rotated_normal() {
    let mut scene = plane_in_environment(Material::default(), 2.0, Vec3::splat(0.5));
    let angle = 30f32.to_radians();
    scene.instances[0].transform = Mat4::from_rotation_x(angle);
    let n = Vec3::new(0.0, angle.cos(), angle.sin());
    let cam = camera(2.5 * n + Vec3::new(0.3, 0.0, 0.0), Vec3::ZERO);
    check_backends(&scene, cam, &|_| n, "tilted plane");
}

#[test]
fn faceted_sphere_shows_each_face_normal() {
    let scene = faceted_sphere_in_environment(Material::default(), Vec3::splat(0.5));
    let mesh = &scene.meshes[0];
    let face_normal = |fh: [u32; 4]| {
        assert_eq!(fh[3], 0, "the sphere is instance 0");
        let t = &mesh.indices[3 * fh[2] as usize..][..3];
        let p: Vec<Vec3> = t.iter().map(|&i| mesh.positions[i as usize]).collect();
        (p[1] - p[0]).cross(p[2] - p[0]).normalize()
    };
    let cam = camera(Vec3::new(0.4, 0.8, 2.6), Vec3::ZERO);
    check_backends(&scene, cam, &face_normal, "faceted sphere");
}
