//! Pipelines specialized to the scene's features render the same image as the
//! all-features build of the same shaders: the disabled branches are dead code
//! for that scene, so the results must agree bit for bit (or within float
//! rounding where the compiler reorders arithmetic; observed: bit-exact).

mod common;
use common::*;
use stereocache::methods::{RenderSettings, SampleCacheSettings};
use stereocache::rt::RtChoice;
use stereocache::scene::{apply_default_lighting, load_scene, DefaultLighting};
use stereocache::session::CameraSelect;

#[test]
fn specialized_and_all_features_pipelines_agree() {
    let ctx = context();
    for name in ["cornell", "plane"] {
        let mut scene = load_scene(name).unwrap();
        apply_default_lighting(&mut scene, &DefaultLighting::default()).unwrap();
        let s = session(&ctx, scene, RtChoice::Software);
        let (w, h) = (16, 12);
        let cam = s.camera(&CameraSelect::Default, w, h, None, None).unwrap();
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
                    cache: SampleCacheSettings::default(),
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
