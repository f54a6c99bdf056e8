//! Stereo blending (§3.6) on the GPU: blended frames stay finite and
//! non-negative and are more consistent between the eyes than unblended ones;
//! the moments reconstruction hands to the blend (Eq. 5–6) against the cache
//! read back.

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

/// The moments reconstruct.comp hands to the blend (Eq. 5–6) and the colour
/// beside them, recomputed on the CPU from the cache read back after every
/// frame of a moving trace with adaptive shading at half the rate (so
/// pixels hold unshaded surface samples, and the silhouettes background
/// ones). A white base (demodulation factor 1, no emission) makes a
/// sample's radiance its record. Per pixel with visible samples:
/// * colour = (n_surf·(mean of the shaded surface samples) + Σ background)
///   / (n_surf + n_bg) where a surface sample is shaded or there is none;
/// * μ1, μ2 = (Σ c_s L_s^k + c_bg Σ bg^k) / (c_total + c_bg·n_bg) with
///   c_bg = c_total / n_surf, so surface and background weigh n_surf : n_bg
///   as in the colour (until session 43 c_total / shaded, which overweighted
///   the background while some surface samples were unshaded); without a
///   shaded surface sample behind a surface, μ1 = colour, μ2 = colour².
///
/// Tolerance: f32 sums of ≤ 16 terms, 10⁻⁵ relative.
#[test]
fn reconstruction_moments_weigh_coverage_like_the_colour() {
    use glam::Vec3;
    use stereocache::methods::sample_cache::Shading;
    let ctx = context();
    let mut scene = sphere_in_environment(
        stereocache::scene::Material::diffuse("white", Vec3::ONE),
        Vec3::ZERO,
        1.0,
        Vec3::new(0.2, 0.3, 0.5),
    );
    scene.lights.push(directional_light(
        Vec3::new(0.3, 1.0, 0.6).normalize(),
        2.0,
        0.0,
    ));
    let s = session(&ctx, scene, RtChoice::Software);
    let (w, h) = (32, 24);
    let st = RenderSettings {
        width: w,
        height: h,
        spp: 1,
        max_bounces: 1,
        seed: 5,
        all_features: false,
        ..Default::default()
    };
    let cache = SampleCacheSettings {
        shading: Shading::Adaptive,
        shading_rate: 0.5,
        ..Default::default()
    };
    let mut m = SampleCache::new(&s.ctx, &s.scene_gpu, &s.scene.environment, &st, &cache).unwrap();
    let cam0 = look_at_camera(
        Vec3::new(0.0, 0.3, 3.2),
        Vec3::ZERO,
        45.0,
        w as f32 / h as f32,
    );
    let (mut checked, mut partly_shaded, mut mixed, mut both) = (0usize, 0usize, 0usize, 0usize);
    let mut prev = None;
    for f in 0..6 {
        let cam = turning_head(&cam0, f, 3.0, 0.0);
        let fr = render_at(&mut m, f, cam, prev);
        prev = Some(cam);
        let snap = m.snapshot().unwrap();
        let mom = m.moments().unwrap();
        for eye in 0..2 {
            for p in 0..snap.npix() {
                let vis = snap.visible(snap.mask(eye, p));
                if vis == 0 {
                    continue;
                }
                let (mut n_bg, mut n_surf, mut shaded, mut c_total) =
                    (0.0f64, 0.0f64, 0.0f64, 0.0f64);
                let (mut sum, mut bg, mut m1, mut m2, mut bg2) = (
                    [0.0f64; 3],
                    [0.0f64; 3],
                    [0.0f64; 3],
                    [0.0f64; 3],
                    [0.0f64; 3],
                );
                let mut b = vis;
                while b != 0 {
                    let sl = b.trailing_zeros();
                    b &= b - 1;
                    let rec = snap.radiance[snap.slot(eye, sl, p)];
                    if snap.is_background(eye, sl, p) {
                        n_bg += 1.0;
                        for k in 0..3 {
                            bg[k] += rec[k] as f64;
                            bg2[k] += (rec[k] as f64).powi(2);
                        }
                    } else {
                        n_surf += 1.0;
                        if rec[3] > 0.0 {
                            shaded += 1.0;
                            c_total += rec[3] as f64;
                            for k in 0..3 {
                                let l = rec[k] as f64;
                                sum[k] += l;
                                m1[k] += rec[3] as f64 * l;
                                m2[k] += rec[3] as f64 * l * l;
                            }
                        }
                    }
                }
                if n_surf > 0.0 && shaded == 0.0 {
                    continue; // colour borrowed from the neighbours (tested elsewhere)
                }
                let i = eye * snap.npix() + p;
                let colour = fr.eyes[eye].radiance[p];
                let c_bg = if shaded > 0.0 { c_total / n_surf } else { 1.0 };
                let c_all = c_total + c_bg * n_bg;
                for k in 0..3 {
                    let surf_mean = if shaded > 0.0 { sum[k] / shaded } else { 0.0 };
                    let want_colour = (n_surf * surf_mean + bg[k]) / (n_surf + n_bg);
                    let want_m1 = (m1[k] + c_bg * bg[k]) / c_all;
                    let want_m2 = (m2[k] + c_bg * bg2[k]) / c_all;
                    for (what, got, want) in [
                        ("colour", colour[k], want_colour),
                        ("μ1", mom.m1[i][k], want_m1),
                        ("μ2", mom.m2[i][k], want_m2),
                    ] {
                        assert!(
                            (got as f64 - want).abs() <= 1e-5 * want.abs() + 1e-7,
                            "frame {f} eye {eye} pixel {p} channel {k}: {what} {got}, want {want} \
                             (n_surf {n_surf}, shaded {shaded}, n_bg {n_bg})"
                        );
                    }
                }
                checked += 1;
                partly_shaded += (shaded > 0.0 && shaded < n_surf) as usize;
                mixed += (n_bg > 0.0 && n_surf > 0.0) as usize;
                both += (n_bg > 0.0 && shaded > 0.0 && shaded < n_surf) as usize;
            }
        }
    }
    eprintln!(
        "{checked} pixels checked: {partly_shaded} with unshaded surface samples, {mixed} mixing \
         surface and background, {both} both"
    );
    // The cases the rule is about must occur (the old weight differed only
    // where both do).
    assert!(
        partly_shaded > 100 && mixed > 20 && both > 10,
        "{partly_shaded} partly shaded, {mixed} mixed, {both} both"
    );
    assert_no_validation_messages(&ctx);
}
