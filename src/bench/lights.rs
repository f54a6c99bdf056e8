//! `bench lights`: MSE at equal time of light sampling (MIS, NEE) against
//! BSDF sampling alone.

use crate::error::Result;
use crate::methods::{FrameInput, MethodKind};
use crate::session::Session;

/// One strategy's row of `bench lights`.
#[derive(Clone, Debug)]
pub struct LightBenchRow {
    pub scene: String,
    pub strategy: crate::methods::LightSampling,
    /// Mean GPU time of a frame (both eyes) at the measured spp.
    pub frame_ms: f64,
    /// Mean squared error against the converged image (all pixels and
    /// channels), averaged over the frames, and its standard error over
    /// frames: the squared difference from the finite-spp reference minus
    /// the reference's own variance (`reference_noise`), since
    /// E‖p − q‖² = Var p + ‖q − T‖² and only Var p scales with time. The ±
    /// leaves out the reference's error (the same image in every frame).
    pub mse: f64,
    pub mse_se: f64,
    /// The reference's variance per pixel and channel, from its two halves
    /// (different seeds, ⌈spp/2⌉ samples each: an odd `--reference-spp`
    /// renders one more), `metrics::reference_noise`'s MSE estimate.
    pub reference_noise: f64,
    /// MSE at the frame time of the first strategy: mse · frame_ms / frame_ms[0]
    /// (MSE ∝ 1/samples ∝ 1/time for an unbiased estimator; with the
    /// reference's variance left in, the ratios were pulled towards 1: an
    /// audit's example, a true 0.350 printed 0.366 at 256 reference spp).
    pub mse_equal_time: f64,
}

/// `stereocache bench lights` (issue 13): the reference path tracer on a static
/// view with each light-sampling strategy in `strategies` (the first is the
/// baseline the equal-time MSE is normalised to), `frames` frames each (one
/// warm-up first) with fresh random numbers, interleaved frame by frame in
/// a carry-over balanced order, against one reference image rendered with MIS at
/// `reference_spp` with its own seed.
pub fn bench_lights(
    session: &Session,
    scene_label: &str,
    camera: crate::camera::StereoCamera,
    base: &crate::methods::RenderSettings,
    strategies: &[crate::methods::LightSampling],
    reference_spp: u32,
    frames: usize,
) -> Result<Vec<LightBenchRow>> {
    use crate::methods::{LightSampling, RenderSettings};
    // A still of the scene: an animated one posed at time 0, as `render`
    // poses it by default.
    super::interleave::pose_frame(session, 0, 1.0)?;
    let frame = |i: u32| FrameInput {
        index: i,
        camera,
        prev_camera: None,
    };
    // The reference in two halves of independent seeds, ⌈spp/2⌉ samples
    // each, as `compare` renders its references: their mean is the
    // reference, their difference its own error (evaluate::ReferenceFrame).
    let half = |salt: u32| -> Result<crate::methods::StereoFrame> {
        Ok(session
            .create(
                MethodKind::Reference,
                &RenderSettings {
                    spp: reference_spp.div_ceil(2).max(1),
                    seed: base.seed ^ 0x9E37_79B9 ^ salt,
                    light_sampling: LightSampling::Mis,
                    ..base.clone()
                },
            )?
            .render_frame(&frame(0))?)
    };
    let halves = [half(0)?, half(0x5A5A_0001)?];
    let ppd = crate::evaluate::flip_ppd(&camera, base.width);
    let reference = crate::evaluate::ReferenceFrame::from_halves(halves, ppd)?;
    let reference_noise = reference.noise.mse;
    let mut methods = Vec::new();
    for &s in strategies {
        methods.push(session.create(
            MethodKind::Reference,
            &RenderSettings {
                light_sampling: s,
                ..base.clone()
            },
        )?);
    }
    let mse_of = |f: &crate::methods::StereoFrame| -> f64 {
        let (mut acc, mut n) = (0.0f64, 0usize);
        let eyes = f.eyes.iter().zip(&reference.frame.eyes);
        for (p, q) in eyes.flat_map(|(a, b)| a.radiance.iter().zip(&b.radiance)) {
            for k in 0..3 {
                acc += (p[k] as f64 - q[k] as f64).powi(2);
                n += 1;
            }
        }
        acc / n.max(1) as f64 - reference_noise
    };
    let mut ms = vec![Vec::new(); methods.len()];
    let mut mse = vec![Vec::new(); methods.len()];
    for i in 0..=frames {
        for j in super::interleave::balanced_order(i, methods.len()) {
            let f = methods[j].render_frame(&frame(1 + i as u32))?;
            if i > 0 {
                ms[j].push(f.stats.gpu_ms());
                mse[j].push(mse_of(&f));
            }
        }
    }
    let mean = |v: &[f64]| super::interleave::mean_and_se(v).0;
    let se = |v: &[f64]| super::interleave::mean_and_se(v).1;
    let t0 = mean(&ms[0]);
    Ok(strategies
        .iter()
        .enumerate()
        .map(|(j, &s)| LightBenchRow {
            scene: scene_label.to_string(),
            strategy: s,
            frame_ms: mean(&ms[j]),
            mse: mean(&mse[j]),
            mse_se: se(&mse[j]),
            reference_noise,
            mse_equal_time: mean(&mse[j]) * mean(&ms[j]) / t0,
        })
        .collect())
}

/// `bench lights` rows as a text table (ratios against each scene's first row).
pub fn light_table(rows: &[LightBenchRow]) -> String {
    let mut s = format!(
        "{:<10} {:<6} {:>10} {:>12} {:>10} {:>15} {:>12}\n",
        "scene", "light", "frame ms", "MSE", "± se", "MSE equal time", "vs first"
    );
    let mut first: Option<(&str, f64)> = None;
    for r in rows {
        if first.is_none_or(|(sc, _)| sc != r.scene) {
            first = Some((&r.scene, r.mse_equal_time));
        }
        let f = first.map_or(1.0, |(_, m)| m);
        s += &format!(
            "{:<10} {:<6} {:>10.2} {:>12.4e} {:>10.2e} {:>15.4e} {:>11.3}x\n",
            r.scene,
            format!("{:?}", r.strategy).to_lowercase(),
            r.frame_ms,
            r.mse,
            r.mse_se,
            r.mse_equal_time,
            r.mse_equal_time / f
        );
    }
    s
}
