//! Pipelines specialized to the scene's features render the same image as the
//! all-features build of the same shaders: the disabled branches are dead code
//! for that scene, so the results must agree bit for bit (or within float
//! rounding where the compiler reorders arithmetic; observed: bit-exact).
//! Passes skipped because they have nothing to do (issue 6) leave the image
//! bit-identical to the build that records every pass, and are absent from
//! the frame's per-pass stats.

mod common;
use common::*;
use stereocache::methods::{FrameInput, HashCacheSettings, MethodConfig, RenderSettings};
use stereocache::rt::RtChoice;
use stereocache::scene::{apply_default_lighting, load_scene, DefaultLighting};

#[test]
fn specialized_and_all_features_pipelines_agree() {
    let ctx = context();
    // A Lambertian scene (specular layer 0, metallic 0): the only one here
    // whose pipelines compile the GGX lobe out (`view_dependent` false).
    let lambert = sphere_in_environment(
        stereocache::scene::Material {
            specular: 0.0,
            ..stereocache::scene::Material::diffuse("lambert", glam::Vec3::new(0.7, 0.5, 0.3))
        },
        glam::Vec3::ZERO,
        1.0,
        glam::Vec3::new(0.9, 0.8, 1.0),
    );
    assert!(!stereocache::scene::SceneFeatures::of(&lambert).view_dependent);
    for name in ["cornell", "plane", "lambert"] {
        let scene = if name == "lambert" {
            lambert.clone()
        } else {
            let mut scene = load_scene(name).unwrap();
            apply_default_lighting(&mut scene, &DefaultLighting::default()).unwrap();
            assert!(stereocache::scene::SceneFeatures::of(&scene).view_dependent);
            scene
        };
        let s = session(&ctx, scene, RtChoice::Software);
        let (w, h) = (16, 12);
        let cam = default_camera(&s, w, h);
        // The sample cache's nine pipelines take lavapipe a while to compile
        // in their all-features form: one scene is enough for them.
        let methods: &[&str] = if name == "cornell" {
            &["reference", "sample-cache"]
        } else {
            &["reference"]
        };
        for &method in methods {
            let run = |all_features: bool| {
                let st = RenderSettings {
                    width: w,
                    height: h,
                    spp: 2,
                    max_bounces: 3,
                    seed: 9,
                    all_features,
                    ..Default::default()
                };
                render(&s, method, cam, &st)
            };
            let (a, b) = (run(false), run(true));
            let mut max_rel = 0.0f32;
            let mut differ = 0usize;
            for (ea, eb) in a.eyes.iter().zip(&b.eyes) {
                assert_eq!(
                    ea.first_hit, eb.first_hit,
                    "{name}/{method}: first hits differ"
                );
                for (pa, pb) in ea.radiance.iter().zip(&eb.radiance) {
                    for c in 0..3 {
                        if pa[c].to_bits() != pb[c].to_bits() {
                            differ += 1;
                            max_rel = max_rel.max(
                                (pa[c] - pb[c]).abs() / pa[c].abs().max(pb[c].abs()).max(1e-6),
                            );
                        }
                    }
                }
            }
            eprintln!("{name}/{method}: {differ} channel values differ, max relative difference {max_rel:.2e}");
            // Float rounding only: a reordered sum differs in its last bits.
            assert!(
                max_rel <= 1e-5,
                "{name}/{method}: max relative difference {max_rel}"
            );
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Zero bounces: `hash-cache` skips `update` (every cell and fallback path
/// would receive exactly 0) and clears `fallback` instead. Over a moving
/// trace through a tiny table (probe failures, misses that move across
/// pixels) on an emissive scene and a textured sky scene, every output is
/// bit-identical to the build that records every pass; with bounces or debug
/// views `update` stays.
#[test]
fn zero_bounce_hash_cache_skips_update_with_identical_images() {
    let ctx = context();
    for name in ["cornell", "plane"] {
        let s = session(&ctx, shipped(name), RtChoice::Software);
        let (w, h) = (24, 16);
        let cam0 = default_camera(&s, w, h);
        let settings = |bounces: u32, all_passes: bool| RenderSettings {
            width: w,
            height: h,
            spp: 1,
            max_bounces: bounces,
            seed: 3,
            all_passes,
            ..Default::default()
        };
        let hash = |debug_views: bool| {
            MethodConfig::HashCache(HashCacheSettings {
                capacity: 128,
                max_probe: 4,
                stale_frames: 2,
                // 128 single entries, as before tiles became the default.
                tiles: false,
                debug_views,
                ..Default::default()
            })
        };
        let mut skip = s.create(hash(false), &settings(0, false)).unwrap();
        let mut every = s.create(hash(false), &settings(0, true)).unwrap();
        let mut failures = 0.0;
        let mut prev = None;
        for f in 0..4u32 {
            let cam = turning_head(&cam0, f, 2.0, 0.02);
            let input = FrameInput {
                index: f,
                camera: cam,
                prev_camera: prev,
            };
            prev = Some(cam);
            let (a, b) = (
                skip.render_frame(&input).unwrap(),
                every.render_frame(&input).unwrap(),
            );
            let names = |fr: &stereocache::methods::StereoFrame| -> Vec<String> {
                fr.stats.passes.iter().map(|p| p.name.clone()).collect()
            };
            let (na, nb) = (names(&a), names(&b));
            assert!(!na.contains(&"update".to_string()), "{name}: {na:?}");
            assert!(na.contains(&"clear.fallback".to_string()), "{name}: {na:?}");
            assert!(nb.contains(&"update".to_string()), "{name}: {nb:?}");
            failures += b.stats.counters["probe_failures"];
            for (e, (ea, eb)) in a.eyes.iter().zip(&b.eyes).enumerate() {
                let bits = |v: &[[f32; 4]]| -> Vec<[u32; 4]> {
                    v.iter().map(|p| p.map(f32::to_bits)).collect()
                };
                assert_eq!(
                    bits(&ea.radiance),
                    bits(&eb.radiance),
                    "{name} frame {f} eye {e}: radiance differs"
                );
                assert_eq!(ea.first_hit, eb.first_hit, "{name} frame {f} eye {e}");
                assert_eq!(
                    bits(&ea.albedo),
                    bits(&eb.albedo),
                    "{name} frame {f} eye {e}: albedo differs"
                );
                let depth = |v: &[f32]| -> Vec<u32> { v.iter().map(|d| d.to_bits()).collect() };
                assert_eq!(
                    depth(&ea.depth),
                    depth(&eb.depth),
                    "{name} frame {f} eye {e}"
                );
            }
        }
        // The fallback path of a failed probe is part of what is compared.
        assert!(failures > 0.0, "{name}: the tiny table never overflowed");
        // With bounces, or with debug views (they show cell sample counts), `update` stays.
        for (bounces, debug) in [(1, false), (0, true)] {
            let mut m = s.create(hash(debug), &settings(bounces, false)).unwrap();
            let fr = render_at(m.as_mut(), 0, cam0, None);
            assert!(
                fr.stats.passes.iter().any(|p| p.name == "update"),
                "{name}: bounces {bounces}, debug views {debug}: update skipped"
            );
        }
    }
    assert_no_validation_messages(&ctx);
}
