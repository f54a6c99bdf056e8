//! `bench materials --fill-cost` (issue 17): what a miss of the
//! memoization table costs, timed apart. The thesis's tables give frame
//! times at given hit rates; the cost of one fill (the graphs evaluated for
//! a texel or a whole tile, the lock, the write) only shows as the slope of
//! frame time over the misses. Here it is measured directly: one camera, the
//! same frame index (so the same rays, the same hit points and the same
//! texel keys) rendered twice in a row, first from an emptied table (every
//! lookup misses and fills) and then from the table that frame filled
//! (every lookup hits); the difference of the two frames' GPU times over
//! the difference of their fills is the time a fill costs beyond a hit.
//! Each round empties the table again; the rows alternate with an "off"
//! run (no table: the direct evaluation) in a carry-over balanced order, like
//! `bench_materials`.

use super::interleave::{mean_and_se, paired_ratio, pose_frame};
use crate::camera::StereoCamera;
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::materials::memo::state::MemoCounters;
use crate::materials::memo::{MemoFill, MemoHits, MemoSettings};
use crate::methods::{FrameInput, MethodConfig, RenderSettings};
use crate::output::csv_field;
use crate::rt::RtChoice;
use crate::scene::Scene;
use crate::session::Session;
use std::sync::Arc;

/// The configurations: the direct evaluation ("off"), then every hit
/// memoized non-tiled and with 4×4 and 8×8 tiles, each tiled size with
/// each of `fills` (the cooperative and the plain fill); the default table
/// size of each.
pub fn fill_cost_configs(fills: &[MemoFill]) -> Vec<(String, MemoSettings)> {
    let both = MemoSettings {
        hits: MemoHits::Both,
        ..MemoSettings::default()
    };
    let mut v = vec![
        ("off".to_string(), MemoSettings::default()),
        ("both".to_string(), both),
    ];
    for tile in [4u32, 8] {
        for &fill in fills {
            let label = match fill {
                MemoFill::Subgroup => format!("both tile {tile}x{tile}"),
                MemoFill::Plain => format!("both tile {tile}x{tile} plain fill"),
            };
            v.push((
                label,
                MemoSettings {
                    tile,
                    fill,
                    entries: MemoSettings::default_entries(tile),
                    ..both
                },
            ));
        }
    }
    v
}

/// One configuration's cold and warm frames, averaged over the rounds.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FillCostRow {
    pub label: String,
    /// The frame from an emptied table (the "off" row: every frame).
    pub cold_ms: f64,
    /// The same frame again, from the table the cold frame filled.
    pub warm_ms: f64,
    /// Per frame: misses and fills of the cold frame, hits and fills of
    /// the warm one.
    pub cold_misses: f64,
    pub cold_fills: f64,
    pub warm_hits: f64,
    pub warm_fills: f64,
    /// Lookups of the warm frame that hit.
    pub warm_hit_rate: f64,
    /// Σ(cold − warm) / Σ(cold fills − warm fills) over the rounds, in µs
    /// (a ratio of means, as every ratio of the benches: a mean of per-round
    /// ratios is biased and weighs a round with few fills as much as one
    /// with many), and its delta-method standard error.
    pub us_per_fill: f64,
    pub us_per_fill_se: f64,
    /// Cold and warm frame over the "off" frame of the same rounds (ratio of
    /// the means, paired by round).
    pub cold_over_off: f64,
    pub warm_over_off: f64,
}

/// Renders `camera` (frame index 0) with `method`: per configuration and
/// round, one frame from an emptied table and the same frame again; the
/// first configuration must be "off" (the direct evaluation). One frame per
/// session first, not counted (pipeline creation).
#[allow(clippy::too_many_arguments)]
pub fn bench_fill_cost(
    ctx: &Arc<GpuContext>,
    scene: &Scene,
    rt: RtChoice,
    method: &MethodConfig,
    settings: &RenderSettings,
    camera: StereoCamera,
    configs: &[(String, MemoSettings)],
    rounds: usize,
) -> Result<Vec<FillCostRow>> {
    let rounds = rounds.max(2);
    // [config] -> per round ((cold ms, counters), (warm ms, counters))
    type Frame = (f64, MemoCounters);
    let mut runs: Vec<Vec<(Frame, Frame)>> = vec![Vec::new(); configs.len()];
    let sessions: Vec<Session> = configs
        .iter()
        .map(|(_, m)| {
            let mut s = scene.clone();
            s.graphs.memo = *m;
            Session::with_context(ctx.clone(), s, rt)
        })
        .collect::<Result<_>>()?;
    let mut methods = sessions
        .iter()
        .map(|s| method.create(s, settings))
        .collect::<Result<Vec<_>>>()?;
    let input = FrameInput {
        index: 0,
        camera,
        prev_camera: None,
    };
    // Every round renders frame 0: an animated scene posed at its time (0).
    for s in &sessions {
        pose_frame(s, 0, 1.0)?;
    }
    for m in methods.iter_mut() {
        m.render_frame(&input)?;
    }
    for round in 0..rounds {
        for c in super::interleave::balanced_order(round, configs.len()) {
            let memo = sessions[c].scene_gpu.memo.as_ref();
            let frame = |m: &mut Box<dyn crate::methods::Method>| -> Result<Frame> {
                if let Some(t) = memo {
                    t.begin_frame(0)?;
                }
                let f = m.render_frame(&input)?;
                let counters = match memo {
                    Some(t) => t.counters()?,
                    None => MemoCounters::default(),
                };
                Ok((f.stats.gpu_ms(), counters))
            };
            if let Some(t) = memo {
                t.reset()?;
            }
            let cold = frame(&mut methods[c])?;
            let warm = frame(&mut methods[c])?;
            runs[c].push((cold, warm));
        }
    }
    // Per configuration: the mean over rounds of a figure of the round's
    // (cold, warm) pair; its ratio to the "off" frames and the µs per fill
    // as ratios of means over the rounds.
    let off: Vec<f64> = runs[0].iter().map(|r| 0.5 * (r.0 .0 + r.1 .0)).collect();
    Ok(configs
        .iter()
        .zip(&runs)
        .map(|((label, _), r)| {
            let mean = |f: &dyn Fn(&(Frame, Frame)) -> f64| {
                mean_and_se(&r.iter().map(f).collect::<Vec<f64>>()).0
            };
            let over_off = |f: &dyn Fn(&(Frame, Frame)) -> f64| {
                paired_ratio(&r.iter().map(f).collect::<Vec<f64>>(), &off).0
            };
            // µs per fill: the rounds' time differences over their fill
            // differences, pooled (every round kept: one whose cold frame
            // filled nothing more than its warm one adds its time, not a
            // division by zero).
            let dt: Vec<f64> = r.iter().map(|(c, w)| 1e3 * (c.0 - w.0)).collect();
            let dfills: Vec<f64> = r
                .iter()
                .map(|(c, w)| c.1.fills as f64 - w.1.fills as f64)
                .collect();
            let (us_per_fill, us_per_fill_se) = if dfills.iter().sum::<f64>() > 0.0 {
                paired_ratio(&dt, &dfills)
            } else {
                (f64::NAN, f64::NAN)
            };
            let warm_lookups: u64 = r.iter().map(|(_, w)| w.1.hits + w.1.misses).sum();
            let warm_hits: u64 = r.iter().map(|(_, w)| w.1.hits).sum();
            FillCostRow {
                label: label.clone(),
                cold_ms: mean(&|x| x.0 .0),
                warm_ms: mean(&|x| x.1 .0),
                cold_misses: mean(&|x| x.0 .1.misses as f64),
                cold_fills: mean(&|x| x.0 .1.fills as f64),
                warm_hits: mean(&|x| x.1 .1.hits as f64),
                warm_fills: mean(&|x| x.1 .1.fills as f64),
                warm_hit_rate: if warm_lookups > 0 {
                    warm_hits as f64 / warm_lookups as f64
                } else {
                    0.0
                },
                us_per_fill,
                us_per_fill_se,
                cold_over_off: over_off(&|x| x.0 .0),
                warm_over_off: over_off(&|x| x.1 .0),
            }
        })
        .collect())
}

/// The table `bench materials --fill-cost` prints.
pub fn fill_cost_table(rows: &[FillCostRow]) -> String {
    let mut s = format!(
        "{:<26} {:>9} {:>9} {:>9} {:>10} {:>10} {:>10} {:>9} {:>11} {:>8} {:>9} {:>9}\n",
        "configuration",
        "cold ms",
        "warm ms",
        "cold/off",
        "cold miss",
        "cold fills",
        "warm fills",
        "warm hits",
        "µs / fill",
        "± se",
        "warm/off",
        "hit rate"
    );
    for r in rows {
        s.push_str(&format!(
            "{:<26} {:>9.2} {:>9.2} {:>9.3} {:>10.0} {:>10.0} {:>10.0} {:>9.0} {:>11.3} {:>8.3} {:>9.3} {:>9.4}\n",
            r.label,
            r.cold_ms,
            r.warm_ms,
            r.cold_over_off,
            r.cold_misses,
            r.cold_fills,
            r.warm_fills,
            r.warm_hits,
            r.us_per_fill,
            r.us_per_fill_se,
            r.warm_over_off,
            r.warm_hit_rate
        ));
    }
    s
}

/// The rows as CSV (one header line).
pub fn fill_cost_csv(rows: &[FillCostRow]) -> String {
    let mut s = String::from(
        "label,cold_ms,warm_ms,cold_over_off,warm_over_off,cold_misses,cold_fills,warm_hits,warm_fills,warm_hit_rate,us_per_fill,us_per_fill_se\n",
    );
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{}\n",
            csv_field(&r.label),
            r.cold_ms,
            r.warm_ms,
            r.cold_over_off,
            r.warm_over_off,
            r.cold_misses,
            r.cold_fills,
            r.warm_hits,
            r.warm_fills,
            r.warm_hit_rate,
            r.us_per_fill,
            r.us_per_fill_se
        ));
    }
    s
}
