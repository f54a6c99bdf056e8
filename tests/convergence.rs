//! The reference path tracer converges as Monte Carlo predicts: for
//! independent unbiased estimates with N and M samples per pixel, the mean
//! squared difference is Σσ²_p (1/N + 1/M), so
//! MSE(64, 1024) / MSE(256, 1024) = (1/64 + 1/1024) / (1/256 + 1/1024) = 3.4.
//! The tolerance is 4σ of that ratio, estimated from the per-pixel spread of
//! the squared differences (the statistics of the images themselves).

mod common;
use common::*;
use stereocache::methods::{RenderSettings, StereoFrame};
use stereocache::rt::RtChoice;
use stereocache::scene::{apply_default_lighting, load_scene, DefaultLighting};

fn diff_stats(a: &StereoFrame, b: &StereoFrame) -> (f64, f64) {
    mean_and_standard_error(&squared_errors(a, b))
}

#[test]
fn cornell_reference_error_falls_as_one_over_samples() {
    let ctx = context();
    let mut scene = load_scene("cornell").unwrap();
    apply_default_lighting(&mut scene, &DefaultLighting::default()).unwrap();
    let s = session(&ctx, scene, RtChoice::Auto);
    let (w, h) = (32, 32);
    let cam = default_camera(&s, w, h);
    let run = |spp, seed| {
        render(
            &s,
            "reference",
            cam,
            &RenderSettings {
                width: w,
                height: h,
                spp,
                max_bounces: 3,
                seed,
                all_features: false,
                ..Default::default()
            },
        )
    };
    let r1024 = run(1024, 11);
    let r256 = run(256, 12);
    let r64 = run(64, 13);
    for f in [&r1024, &r256, &r64] {
        assert_finite_non_negative(f, "reference");
    }
    let (m64, s64) = diff_stats(&r64, &r1024);
    let (m256, s256) = diff_stats(&r256, &r1024);
    let ratio = m64 / m256;
    let sigma = ratio * ((s64 / m64).powi(2) + (s256 / m256).powi(2)).sqrt();
    let predicted = (1.0 / 64.0 + 1.0 / 1024.0) / (1.0 / 256.0 + 1.0 / 1024.0);
    eprintln!("MSE(64,1024) = {m64:.3e}, MSE(256,1024) = {m256:.3e}, ratio {ratio:.3} ± {sigma:.3} (predicted {predicted:.3})");
    assert!(
        (ratio - predicted).abs() < 4.0 * sigma,
        "ratio {ratio:.3} ± {sigma:.3}, predicted {predicted:.3}"
    );
    assert!(m256 < m64, "more samples must lower the error");
    assert_no_validation_messages(&ctx);
}
