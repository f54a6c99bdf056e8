//! Stereo blending (§3.6) on the GPU: blended frames stay finite and
//! non-negative and are more consistent between the eyes than unblended ones.

mod common;
use common::*;
use stereocache::camera::Eye;
use stereocache::methods::sample_cache::{SampleCache, SampleCacheSettings};
use stereocache::methods::{RenderSettings, StereoFrame};
use stereocache::metrics::{stereo::stereo_discrepancy, LinearImage, ViewBuffers};
use stereocache::rt::RtChoice;
use stereocache::scene::{apply_default_lighting, load_scene, DefaultLighting};
use stereocache::stereo::BlendMode;

#[test]
fn blending_lowers_stereo_discrepancy() {
    let ctx = context();
    let mut scene = load_scene("hairball").unwrap();
    apply_default_lighting(&mut scene, &DefaultLighting::default()).unwrap();
    let s = session(&ctx, scene, RtChoice::Software);
    let (w, h) = (48, 36);
    let cam = default_camera(&s, w, h);
    let run = |mode: BlendMode| -> StereoFrame {
        let st = RenderSettings {
            width: w,
            height: h,
            spp: 1,
            max_bounces: 2,
            seed: 3,
            all_features: false,
            ..Default::default()
        };
        let cache = SampleCacheSettings {
            stereo_blend: mode,
            sharpness: 0.5,
            ..Default::default()
        };
        let mut m =
            SampleCache::new(&s.ctx, &s.scene_gpu, &s.scene.environment, &st, &cache).unwrap();
        render_still(&mut m, cam, 4)
    };
    let views = cam.eyes();
    let discrepancy = |f: &StereoFrame| {
        let img =
            |e: usize| LinearImage::from_rgba(&f.eyes[e].radiance, w as usize, h as usize).unwrap();
        let (li, ri) = (Eye::Left.index(), Eye::Right.index());
        let (l, r) = (img(li), img(ri));
        let left = ViewBuffers {
            image: &l,
            depth: &f.eyes[li].depth,
            view: &views[li],
            first_hits: Some(&f.eyes[li].first_hit),
        };
        let right = ViewBuffers {
            image: &r,
            depth: &f.eyes[ri].depth,
            view: &views[ri],
            first_hits: Some(&f.eyes[ri].first_hit),
        };
        stereo_discrepancy(&left, &right, 0.01).unwrap()
    };
    let none = run(BlendMode::None);
    for mode in [BlendMode::Moments, BlendMode::Neighbourhood] {
        let blended = run(mode);
        assert_finite_non_negative(&blended, &format!("{mode:?}"));
        let (a, b) = (discrepancy(&none), discrepancy(&blended));
        eprintln!(
            "{mode:?}: stereo discrepancy {:.4} → {:.4} (co-visible {:.2})",
            a.mean, b.mean, b.covisible_fraction
        );
        assert!(
            b.mean < a.mean,
            "{mode:?}: blending did not lower the discrepancy: {} vs {}",
            b.mean,
            a.mean
        );
        // Background and non-co-visible pixels are left as they were.
        let same = none.eyes[0]
            .radiance
            .iter()
            .zip(&blended.eyes[0].radiance)
            .filter(|(x, y)| x == y)
            .count();
        assert!(
            same > 0,
            "{mode:?}: every pixel changed, including background"
        );
    }
    assert_no_validation_messages(&ctx);
}
