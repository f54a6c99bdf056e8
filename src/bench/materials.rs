//! `bench materials` (issue 17): the material-graph memoization cache in
//! rendering, measured as the thesis measures it (Urbach 2023, §6): frame
//! time with and without the cache, which hits use it (primary, secondary,
//! both), a table-size sweep (Table 6.3's analogue) and the eviction
//! policies (Table 6.2's analogue), with per-frame hit rates, fills,
//! evictions and lock failures. Every configuration renders the same
//! cameras from an empty table on its own upload of the scene (the table
//! belongs to the scene's set 0); the configurations alternate in a carry-over balanced
//! order over `repeats` rounds, and each round's frame times are paired
//! with the same round's "off" run for the ratio.

use super::interleave::{check_frame_poses, paired_ratio, pose_frame, report_pose_ms};
use crate::camera::StereoCamera;
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::materials::memo::state::MemoCounters;
use crate::materials::memo::table::Eviction;
use crate::materials::memo::{MemoClock, MemoFill, MemoHits, MemoSettings};
use crate::methods::{FrameInput, MethodConfig, RenderSettings};
use crate::output::csv_field;
use crate::rt::RtChoice;
use crate::scene::Scene;
use crate::session::Session;
use std::sync::Arc;

/// The variant of the size sweep and the eviction rows (thesis Tables 6.3
/// and 6.2 have a non-tiled and a tiled column).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SweepVariant {
    /// Texels per entry edge: 1 (non-tiled) or s (s×s tiles; the sizes
    /// then count tiles).
    pub tile: u32,
    /// The tiled sweep's fill.
    pub fill: MemoFill,
}

impl Default for SweepVariant {
    fn default() -> Self {
        SweepVariant {
            tile: 1,
            fill: MemoFill::Subgroup,
        }
    }
}

/// The configurations: off; primary, secondary and both with the default
/// table; both at each of `sizes` entries (LRU); 4×4 tiles (nearest with the
/// cooperative and the plain fill, bilinear); each eviction policy at the
/// smallest size (where eviction happens), LRW and LRU also by the access
/// counter, and without eviction (Table 6.2's "no eviction" baseline).
/// With a tiled `sweep` (s > 1) the size sweep and the eviction rows are of
/// s×s tiles with its fill (labels "both tile sxs S=…"), and secondary-only
/// gets a row with those tiles too.
pub fn memo_configs(sizes: &[u32], sweep: SweepVariant) -> Vec<(String, MemoSettings)> {
    let d = MemoSettings::default();
    let tiled = sweep.tile > 1;
    let sw = if tiled {
        MemoSettings {
            tile: sweep.tile,
            fill: sweep.fill,
            entries: MemoSettings::default_entries(sweep.tile),
            ..d
        }
    } else {
        d
    };
    let prefix = if tiled {
        format!("both tile {0}x{0}{1}", sweep.tile, fill_suffix(sweep.fill))
    } else {
        "both".to_string()
    };
    let mut v = vec![("off".to_string(), d)];
    for (name, hits) in [
        ("primary", MemoHits::Primary),
        ("secondary", MemoHits::Secondary),
        ("both", MemoHits::Both),
    ] {
        v.push((name.into(), MemoSettings { hits, ..d }));
    }
    if tiled {
        v.push((
            format!(
                "secondary tile {0}x{0}{1}",
                sweep.tile,
                fill_suffix(sweep.fill)
            ),
            MemoSettings {
                hits: MemoHits::Secondary,
                ..sw
            },
        ));
        // (4×4 at the default size is a row of its own below, with
        // either fill.)
        if sweep.tile != 4 {
            v.push((
                prefix.clone(),
                MemoSettings {
                    hits: MemoHits::Both,
                    ..sw
                },
            ));
        }
    }
    for &entries in sizes {
        if entries != sw.entries {
            v.push((
                format!("{prefix} S={entries}"),
                MemoSettings {
                    hits: MemoHits::Both,
                    entries,
                    ..sw
                },
            ));
        }
    }
    // The tiled variant (4×4 texels an entry) with the default table's
    // texel capacity, nearest and bilinear: with the subgroup-cooperative
    // fill (where the device has subgroup ballot and shuffle) and nearest
    // again with the plain fill; with `--sweep-fill plain`, every one with
    // the plain fill, so that no row needs the cooperative build (whose
    // pipeline takes llvmpipe about ten minutes to compile for the
    // procedural-heavy Sponza: docs/PERFORMANCE.md, "Memoization, session
    // 36").
    let tile4 = |bilinear: bool, fill: MemoFill| MemoSettings {
        hits: MemoHits::Both,
        entries: MemoSettings::default_entries(4),
        tile: 4,
        bilinear,
        fill,
        ..d
    };
    let fills: &[MemoFill] = match sweep.fill {
        MemoFill::Subgroup => &[MemoFill::Subgroup, MemoFill::Plain],
        MemoFill::Plain => &[MemoFill::Plain],
    };
    for &fill in fills {
        v.push((
            format!("both tile 4x4{}", fill_suffix(fill)),
            tile4(false, fill),
        ));
        if fill == sweep.fill {
            v.push((
                format!("both tile 4x4 bilinear{}", fill_suffix(fill)),
                tile4(true, fill),
            ));
        }
    }
    if let Some(&small) = sizes.iter().min() {
        // Table 6.2's rows: no eviction, random, LRW and LRU by the frame
        // clock (LRU is "both S=small" above), LRW and LRU by the access
        // counter.
        for (name, eviction, clock) in [
            ("no eviction", Eviction::Disabled, MemoClock::Frame),
            ("random", Eviction::Random, MemoClock::Frame),
            ("lrw", Eviction::Lrw, MemoClock::Frame),
            ("lrw counter", Eviction::Lrw, MemoClock::Counter),
            ("lru counter", Eviction::Lru, MemoClock::Counter),
        ] {
            v.push((
                format!("{prefix} S={small} {name}"),
                MemoSettings {
                    hits: MemoHits::Both,
                    entries: small,
                    eviction,
                    clock,
                    ..sw
                },
            ));
        }
    }
    v
}

fn fill_suffix(fill: MemoFill) -> &'static str {
    match fill {
        MemoFill::Subgroup => "",
        MemoFill::Plain => " plain fill",
    }
}

/// One configuration's figures, over the steady frames (frame 0 is the
/// warm-up: pipeline creation and the first fills) of every round.
#[derive(Clone, Debug, serde::Serialize)]
pub struct MemoBenchRow {
    pub label: String,
    pub hits: String,
    pub entries: u32,
    pub eviction: String,
    pub table_bytes: u64,
    pub frame_ms: f64,
    /// Frame time over the "off" run's, paired per frame and round.
    pub ratio_to_off: f64,
    pub ratio_se: f64,
    /// hits / lookups over the steady frames, and in the last frame.
    pub hit_rate: f64,
    pub last_hit_rate: f64,
    /// The second (right) eye's hit rate over the steady frames.
    pub second_eye_hit_rate: f64,
    /// The share of lookups (both eyes) that hit a record the other eye
    /// filled in the same frame.
    pub other_eye_share: f64,
    pub lookups_per_frame: f64,
    pub fills_per_frame: f64,
    pub evictions_per_frame: f64,
    pub lock_failures_per_frame: f64,
    pub bypassed_per_frame: f64,
    /// Tiles filled by the subgroup-cooperative fill, per frame.
    pub cooperative_fills_per_frame: f64,
    /// Misses not stored because their window was full (no eviction).
    pub window_full_per_frame: f64,
}

/// Renders `cameras` (frames at `fps`) with `method` once per configuration
/// and round; an animated scene is posed at each frame's time (its poses
/// checked before anything renders), as replay poses it.
#[allow(clippy::too_many_arguments)]
pub fn bench_materials(
    ctx: &Arc<GpuContext>,
    scene: &Scene,
    rt: RtChoice,
    method: &MethodConfig,
    settings: &RenderSettings,
    cameras: &[StereoCamera],
    fps: f64,
    configs: &[(String, MemoSettings)],
    repeats: usize,
) -> Result<Vec<MemoBenchRow>> {
    // [config][round] -> per-frame (ms, counters)
    let mut runs: Vec<Vec<Vec<(f64, MemoCounters)>>> = vec![Vec::new(); configs.len()];
    // Wall ms of posing before each steady frame, all runs.
    let mut pose_ms = Vec::new();
    for round in 0..repeats.max(1) {
        for (k, c) in super::interleave::balanced_order(round, configs.len())
            .into_iter()
            .enumerate()
        {
            let mut s = scene.clone();
            s.graphs.memo = configs[c].1;
            let session = Session::with_context(ctx.clone(), s, rt)?;
            if round == 0 && k == 0 {
                check_frame_poses(&session, cameras.len(), fps)?;
            }
            let mut m = method.create(&session, settings)?;
            let memo = session.scene_gpu.memo.as_ref();
            let mut frames = Vec::with_capacity(cameras.len());
            for (i, cam) in cameras.iter().enumerate() {
                let posing = pose_frame(&session, i, fps)?;
                if i > 0 {
                    pose_ms.extend(posing);
                }
                if let Some(t) = memo {
                    t.begin_frame(i as u32)?;
                }
                let input = FrameInput {
                    index: i as u32,
                    camera: *cam,
                    prev_camera: i.checked_sub(1).map(|p| cameras[p]),
                };
                let f = m.render_frame(&input)?;
                let counters = match memo {
                    Some(t) => t.counters()?,
                    None => MemoCounters::default(),
                };
                frames.push((f.stats.gpu_ms(), counters));
            }
            runs[c].push(frames);
        }
    }
    report_pose_ms("materials, every configuration and round", &pose_ms);
    let steady_ms = |r: &Vec<Vec<(f64, MemoCounters)>>| -> Vec<f64> {
        r.iter()
            .flat_map(|f| f.iter().skip(1).map(|x| x.0))
            .collect()
    };
    let off = steady_ms(&runs[0]);
    Ok(configs
        .iter()
        .zip(&runs)
        .map(|((label, s), r)| {
            let ms = steady_ms(r);
            let (ratio, se) = paired_ratio(&ms, &off);
            let mut total = MemoCounters::default();
            let mut n = 0usize;
            for f in r.iter().flat_map(|f| f.iter().skip(1)) {
                total.add(&f.1);
                n += 1;
            }
            let per = |x: u64| x as f64 / n.max(1) as f64;
            let last = r
                .last()
                .and_then(|f| f.last())
                .map(|x| x.1)
                .unwrap_or_default();
            MemoBenchRow {
                label: label.clone(),
                hits: format!("{:?}", s.hits).to_lowercase(),
                entries: s.entries,
                eviction: match s.clock {
                    MemoClock::Frame => s.eviction.name().to_string(),
                    MemoClock::Counter => format!("{} counter", s.eviction.name()),
                },
                table_bytes: if s.enabled() { s.table_bytes() } else { 0 },
                frame_ms: ms.iter().sum::<f64>() / ms.len().max(1) as f64,
                ratio_to_off: ratio,
                ratio_se: se,
                hit_rate: total.hit_rate().unwrap_or(0.0),
                last_hit_rate: last.hit_rate().unwrap_or(0.0),
                second_eye_hit_rate: total.second_eye_hit_rate().unwrap_or(0.0),
                other_eye_share: total.other_eye_share().unwrap_or(0.0),
                lookups_per_frame: per(total.hits + total.misses),
                fills_per_frame: per(total.fills),
                evictions_per_frame: per(total.evictions),
                lock_failures_per_frame: per(total.lock_failures),
                bypassed_per_frame: per(total.bypassed),
                cooperative_fills_per_frame: per(total.cooperative_fills),
                window_full_per_frame: per(total.window_full),
            }
        })
        .collect())
}

/// The table `bench materials` prints.
pub fn memo_table(rows: &[MemoBenchRow]) -> String {
    let mut s = format!(
        "{:<24} {:>9} {:>10} {:>10} {:>10} {:>9} {:>9} {:>8} {:>9} {:>10} {:>10} {:>10} {:>9} {:>9} {:>9}\n",
        "configuration",
        "hits",
        "entries",
        "eviction",
        "table MiB",
        "frame ms",
        "ratio",
        "± se",
        "hit rate",
        "last frame",
        "second eye",
        "other eye",
        "fills/fr",
        "evict/fr",
        "full/fr"
    );
    for r in rows {
        s.push_str(&format!(
            "{:<24} {:>9} {:>10} {:>10} {:>10.1} {:>9.2} {:>9.3} {:>8.3} {:>9.4} {:>10.4} {:>10.4} {:>10.4} {:>9.0} {:>9.0} {:>9.0}\n",
            r.label,
            r.hits,
            r.entries,
            r.eviction,
            r.table_bytes as f64 / (1u64 << 20) as f64,
            r.frame_ms,
            r.ratio_to_off,
            r.ratio_se,
            r.hit_rate,
            r.last_hit_rate,
            r.second_eye_hit_rate,
            r.other_eye_share,
            r.fills_per_frame,
            r.evictions_per_frame,
            r.window_full_per_frame
        ));
    }
    s
}

/// The rows as CSV (one header line).
pub fn memo_csv(rows: &[MemoBenchRow]) -> String {
    let mut s = String::from(
        "label,hits,entries,eviction,table_bytes,frame_ms,ratio_to_off,ratio_se,hit_rate,last_hit_rate,second_eye_hit_rate,other_eye_share,lookups_per_frame,fills_per_frame,evictions_per_frame,lock_failures_per_frame,bypassed_per_frame,cooperative_fills_per_frame,window_full_per_frame\n",
    );
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            csv_field(&r.label),
            csv_field(&r.hits),
            r.entries,
            csv_field(&r.eviction),
            r.table_bytes,
            r.frame_ms,
            r.ratio_to_off,
            r.ratio_se,
            r.hit_rate,
            r.last_hit_rate,
            r.second_eye_hit_rate,
            r.other_eye_share,
            r.lookups_per_frame,
            r.fills_per_frame,
            r.evictions_per_frame,
            r.lock_failures_per_frame,
            r.bypassed_per_frame,
            r.cooperative_fills_per_frame,
            r.window_full_per_frame
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default sweep is of single texels; a tiled one puts every sweep
    /// and eviction row (and a secondary-only row) on its tiles and fill,
    /// keeps the fixed rows, and repeats no label.
    #[test]
    fn a_tiled_sweep_puts_the_sweep_and_eviction_rows_on_its_tiles() {
        let plain = memo_configs(&[64, 4096], SweepVariant::default());
        assert!(plain
            .iter()
            .filter(|(l, _)| l.starts_with("both S="))
            .all(|(_, s)| s.tile == 1));
        for tile in [2, 4, 8] {
            let v = memo_configs(
                &[64, 4096],
                SweepVariant {
                    tile,
                    fill: MemoFill::Plain,
                },
            );
            let mut labels: Vec<&str> = v.iter().map(|(l, _)| l.as_str()).collect();
            let n = labels.len();
            labels.sort();
            labels.dedup();
            assert_eq!(labels.len(), n, "tile {tile}: a label twice");
            let prefix = format!("both tile {tile}x{tile} plain fill S=");
            let swept: Vec<_> = v.iter().filter(|(l, _)| l.starts_with(&prefix)).collect();
            // Two sizes and five more policies at the smallest.
            assert_eq!(swept.len(), 7, "tile {tile}: {labels:?}");
            for (l, s) in &swept {
                assert_eq!(
                    (s.tile, s.fill, s.hits),
                    (tile, MemoFill::Plain, MemoHits::Both),
                    "{l}"
                );
            }
            let small: Vec<_> = swept.iter().filter(|(l, _)| l.contains("S=64 ")).collect();
            assert_eq!(small.len(), 5);
            assert!(small.iter().any(|(_, s)| s.eviction == Eviction::Disabled));
            assert!(small.iter().all(|(_, s)| s.entries == 64));
            let secondary = v
                .iter()
                .find(|(l, _)| l.starts_with("secondary tile"))
                .expect("a tiled secondary-only row");
            assert_eq!(
                (secondary.1.tile, secondary.1.hits),
                (tile, MemoHits::Secondary)
            );
            // The fixed rows stay: off, the three hit modes, the 4×4 rows
            // (nearest and bilinear), all with the plain fill: no row needs
            // the cooperative build.
            for fixed in [
                "off",
                "primary",
                "secondary",
                "both",
                "both tile 4x4 plain fill",
                "both tile 4x4 bilinear plain fill",
            ] {
                assert!(v.iter().any(|(l, _)| l == fixed), "tile {tile}: {fixed}");
            }
            assert!(
                v.iter()
                    .all(|(_, s)| s.tile == 1 || s.fill == MemoFill::Plain),
                "tile {tile}: a cooperative row with --sweep-fill plain: {labels:?}"
            );
        }
        // The default (subgroup) sweep keeps both fills of the 4×4 rows.
        let v = memo_configs(&[64, 4096], SweepVariant::default());
        for (label, fill, bilinear) in [
            ("both tile 4x4", MemoFill::Subgroup, false),
            ("both tile 4x4 bilinear", MemoFill::Subgroup, true),
            ("both tile 4x4 plain fill", MemoFill::Plain, false),
        ] {
            let (_, s) = v
                .iter()
                .find(|(l, _)| l == label)
                .unwrap_or_else(|| panic!("{label}"));
            assert_eq!((s.tile, s.fill, s.bilinear), (4, fill, bilinear), "{label}");
        }
    }
}
