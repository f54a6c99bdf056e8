//! Replay: render one method along a head-pose trace, frame by frame, and
//! record what every frame cost.
//!
//! [`trace_cameras`] turns a trace into one world-space [`StereoCamera`] per
//! frame (resampled at the render rate, the stage placed at a scene camera so
//! frame 0 *is* that camera). [`replay`] renders them in order with the
//! previous frame's camera attached (for methods that reproject) and writes,
//! under `out/`:
//!
//! - `frames/{index:05}_{left,right}.{exr,png}` every `every`-th frame (linear
//!   radiance and the tonemapped preview), and with `debug_views` each named
//!   debug view as `frames/{index:05}_{eye}_{view}.png` (clamped, not tonemapped);
//! - `frames.jsonl`: one JSON object per frame ([`FrameRecord`]), written line
//!   by line as `frames.jsonl.partial` and renamed when the last frame is done,
//!   so an interrupted run never leaves a file that looks complete (a run that
//!   fails removes it);
//! - `summary.json`: [`ReplaySummary`].
//!
//! Every file goes through [`output::atomic`]: a failed write (a full disk)
//! fails the replay with an error naming the file and leaves nothing under
//! its final name.
//!
//! Stale `frames.jsonl` and `summary.json` of an earlier run in the same
//! directory are removed before the first frame, so they cannot be mistaken
//! for this run's.

use crate::camera::{PoseTrace, Stage, StereoCamera};
use crate::error::{Error, Result};
use crate::methods::{hash_table, FrameInput};
use crate::methods::{EyeImage, FrameStats, Method, RayCounts, StereoFrame};
use crate::output;
use crate::session::{CameraSelect, Session};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The default render rate of a replay, frames per second (DESIGN.md: 90 Hz).
pub const DEFAULT_FPS: f64 = 90.0;

/// The highest render rate accepted (a sanity bound on user input).
pub const MAX_FPS: f64 = 10_000.0;

/// How a replay runs and where it writes.
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// Render only the first `k` frames of the resampled trace (all when `None`).
    pub frames: Option<usize>,
    /// Render rate the trace is resampled at, frames per second.
    pub fps: f64,
    /// Write images every `every`-th frame (frame 0 included); 0 = never.
    pub every: usize,
    /// Output directory (created when missing).
    pub out: PathBuf,
    /// Exposure multiplier of the PNG previews.
    pub exposure: f32,
    /// Also write each eye's named debug views as PNG.
    pub debug_views: bool,
    /// The trace file, recorded in `summary.json`.
    pub trace: PathBuf,
    /// The settings the method was created with (shared and method-specific),
    /// recorded as they are in `summary.json`.
    pub settings: serde_json::Value,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            frames: None,
            fps: DEFAULT_FPS,
            every: 1,
            out: PathBuf::from("out/replay"),
            exposure: 1.0,
            debug_views: false,
            trace: PathBuf::new(),
            settings: serde_json::Value::Null,
        }
    }
}

impl ReplayOptions {
    /// Checks the values a user can get wrong; one line naming the option.
    pub fn validate(&self) -> Result<()> {
        check_fps(self.fps)?;
        if self.frames == Some(0) {
            return Err(Error::Usage(
                "bad --frames 0: render at least one frame (omit --frames for the whole trace)"
                    .into(),
            ));
        }
        if !(self.exposure.is_finite() && self.exposure > 0.0) {
            return Err(Error::Usage(format!(
                "bad --exposure {}: expected a positive number",
                self.exposure
            )));
        }
        Ok(())
    }
}

impl ReplayOptions {
    /// How many frames a replay of `available` resampled frames renders:
    /// all of them, or the first `frames`, which may not exceed them.
    pub fn frame_count(&self, available: usize) -> Result<usize> {
        match self.frames {
            _ if available == 0 => Err(Error::Usage(format!(
                "{}: no frames to render",
                self.trace.display()
            ))),
            Some(k) if k > available => Err(Error::Usage(format!(
                "bad --frames {k}: {} has {available} frames at {} fps; use at most {available} or omit --frames",
                self.trace.display(),
                self.fps,
            ))),
            Some(k) => Ok(k),
            None => Ok(available),
        }
    }
}

/// The most frames a trace may resample to (about three hours at 90 Hz):
/// every frame's camera is built up front, so a trace spanning more (a
/// corrupt timestamp) is refused before anything is allocated.
pub const MAX_TRACE_FRAMES: usize = 1_000_000;

/// Refuses a bad `fps`, or a trace whose frames to build at it (all of
/// them, or the first `limit`) are more than [`MAX_TRACE_FRAMES`]; cheap,
/// so callers run it before opening the scene. [`trace_cameras`] runs it
/// too.
pub fn check_trace_length(trace: &PoseTrace, fps: f64, limit: Option<usize>) -> Result<()> {
    check_fps(fps)?;
    let n = trace.resampled_len(fps);
    let needed = limit.map_or(n, |k| n.min(k as f64));
    if needed > MAX_TRACE_FRAMES as f64 {
        return Err(Error::Usage(format!(
            "{}: the trace spans {:.6e} s, {n:.3e} frames at {fps} fps, more than the {MAX_TRACE_FRAMES} a replay builds at once (replay the first ones with --frames; a corrupt timestamp?)",
            trace.source.display(),
            trace.duration()
        )));
    }
    Ok(())
}

/// Refuses, before anything loads, a benchmark whose `frames` timed frames
/// plus `warmup` untimed ones are more than `trace` gives at `fps` (a
/// one-sample trace gives one frame): a bench never runs fewer frames than
/// asked, nor divides by none. Runs [`check_trace_length`] too.
pub fn check_bench_frames(trace: &PoseTrace, fps: f64, frames: usize, warmup: usize) -> Result<()> {
    let needed = frames.saturating_add(warmup);
    check_trace_length(trace, fps, Some(needed))?;
    let available = trace.resampled_len(fps);
    if needed as f64 > available {
        let most = (available as usize).saturating_sub(warmup);
        let warm = match warmup {
            0 => String::new(),
            n => format!(" (+{n} warm-up)"),
        };
        let fix = if most == 0 {
            "use a longer trace".to_string()
        } else {
            format!("use at most --frames {most}")
        };
        return Err(Error::Usage(format!(
            "bad --frames {frames}: {} has {available} frames at {fps} fps, the bench needs {needed}{warm}; {fix}",
            trace.source.display(),
        )));
    }
    Ok(())
}

fn check_fps(fps: f64) -> Result<()> {
    if fps.is_finite() && fps > 0.0 && fps <= MAX_FPS {
        Ok(())
    } else {
        Err(Error::Usage(format!(
            "bad --fps {fps}: expected frames per second in (0, {MAX_FPS}]"
        )))
    }
}

/// One world-space stereo camera per frame of `trace` resampled at `fps`
/// (the first `limit` frames only, when given).
///
/// The stage is placed so that the first sample's head pose lands exactly on
/// the selected camera (`Stage::at_camera`): frame 0 equals
/// `session.camera(select, ..)` and later frames move relative to it. Field
/// of view and aspect come from that camera (`yfov` overrides the field of
/// view); the IPD is the sample's when the trace has one, else `ipd`, else the
/// default.
#[allow(clippy::too_many_arguments)]
pub fn trace_cameras(
    session: &Session,
    trace: &PoseTrace,
    fps: f64,
    width: u32,
    height: u32,
    select: &CameraSelect,
    ipd: Option<f32>,
    yfov: Option<f32>,
    limit: Option<usize>,
) -> Result<Vec<StereoCamera>> {
    check_trace_length(trace, fps, limit)?;
    let samples = trace.resample_first(fps, limit.unwrap_or(MAX_TRACE_FRAMES));
    let Some(first) = samples.first() else {
        return Err(Error::Usage(format!(
            "{}: the trace has no samples",
            trace.source.display()
        )));
    };
    let base = session.camera(select, width, height, ipd, yfov)?;
    let stage = Stage::at_camera(base.head.to_mat4(), &first.pose);
    // The stage works relative to the base camera's anchor (f64), so a
    // camera far from the origin keeps the trace's millimetre motion.
    Ok(samples
        .iter()
        .map(|s| StereoCamera {
            anchor: base.anchor,
            projection: base.projection,
            ..stage.eye_camera(s, base.yfov, base.aspect, base.ipd)
        })
        .collect())
}

/// Rays of one frame by kind, with their total.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct RayRecord {
    pub primary: u64,
    pub bounce: u64,
    pub shadow: u64,
    pub total: u64,
}

impl From<RayCounts> for RayRecord {
    fn from(r: RayCounts) -> Self {
        RayRecord {
            primary: r.primary,
            bounce: r.bounce,
            shadow: r.shadow,
            total: r.total(),
        }
    }
}

/// The head of a frame's camera in world space.
#[derive(Clone, Debug, Serialize)]
pub struct CameraRecord {
    /// Eye midpoint, metres.
    pub position: [f64; 3],
    /// Head orientation as a unit quaternion `[x, y, z, w]`.
    pub orientation: [f32; 4],
    /// Interpupillary distance, metres.
    pub ipd: f32,
}

/// One line of `frames.jsonl`.
#[derive(Clone, Debug, Serialize)]
pub struct FrameRecord {
    pub index: usize,
    /// Seconds since the trace's first sample (`index / fps`).
    pub t: f64,
    /// The frame's GPU time (`FrameStats::gpu_ms`: its passes' timings
    /// without the diagnostic `diag.` passes, which `passes` lists too).
    pub gpu_ms: f64,
    /// Milliseconds per pass name (passes with the same name summed).
    pub passes: BTreeMap<String, f64>,
    pub rays: RayRecord,
    /// The method's own counters, as it reported them.
    pub counters: BTreeMap<String, f64>,
    /// Metrics of this frame against the reference (compare), when computed.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub metrics: BTreeMap<String, f64>,
    pub camera: CameraRecord,
    /// Wall-clock milliseconds of posing the animated instances before the
    /// frame (`Session::pose_instances`: sampling the animation, the TLAS
    /// rebuild, the instance, BVH-top and emitter uploads); only on a scene
    /// that animates.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pose_ms: Option<f64>,
}

impl FrameRecord {
    /// The memoization cache's counters of the frame, as `memo_*` counters,
    /// and `memo_live_entries`: entries holding a key after the frame.
    /// Entries only ever go from empty to filled (an eviction replaces a
    /// key, nothing empties one until the next run's reset), so that is
    /// the fills since the reset, `live` (updated here).
    fn add_memo_counters(
        &mut self,
        c: &crate::materials::memo::state::MemoCounters,
        live: &mut u64,
    ) {
        *live += c.fills;
        self.counters
            .insert("memo_live_entries".to_string(), *live as f64);
        for (k, v) in [
            ("memo_hits", c.hits),
            ("memo_misses", c.misses),
            ("memo_fills", c.fills),
            ("memo_evictions", c.evictions),
            ("memo_lock_failures", c.lock_failures),
            ("memo_refused", c.refused),
            ("memo_bypassed", c.bypassed),
            ("memo_cooperative_fills", c.cooperative_fills),
            ("memo_window_full", c.window_full),
            ("memo_other_eye_hits", c.other_eye_hits),
        ] {
            self.counters.insert(k.to_string(), v as f64);
        }
        if let Some(r) = c.hit_rate() {
            self.counters.insert("memo_hit_rate".to_string(), r);
        }
        if let Some(r) = c.second_eye_hit_rate() {
            self.counters
                .insert("memo_second_eye_hit_rate".to_string(), r);
        }
    }

    fn new(index: usize, fps: f64, camera: &StereoCamera, stats: &FrameStats) -> Self {
        let mut passes = BTreeMap::new();
        for p in &stats.passes {
            *passes.entry(p.name.clone()).or_insert(0.0) += p.ms;
        }
        FrameRecord {
            index,
            t: index as f64 / fps,
            gpu_ms: stats.gpu_ms(),
            passes,
            rays: stats.rays.into(),
            counters: stats.counters.clone(),
            metrics: BTreeMap::new(),
            camera: CameraRecord {
                position: camera.world_position().to_array(),
                orientation: camera.head.orientation.to_array(),
                ipd: camera.ipd,
            },
            pose_ms: None,
        }
    }
}

/// What a replay did: the content of `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ReplaySummary {
    pub device: String,
    pub driver: String,
    pub backend: crate::rt::RtBackend,
    pub scene: PathBuf,
    pub trace: PathBuf,
    pub method: String,
    pub settings: serde_json::Value,
    /// Image size per eye.
    pub width: u32,
    pub height: u32,
    pub fps: f64,
    /// Frames rendered.
    pub frames: usize,
    /// Image cadence (0 = no images).
    pub every: usize,
    /// Frames whose images were written.
    pub images_written: usize,
    /// Mean GPU time per frame over **all** frames, frame 0 included.
    pub mean_gpu_ms: f64,
    /// 95th percentile (nearest rank) of the per-frame GPU time, all frames.
    pub p95_gpu_ms: f64,
    /// GPU time of frame 0, which carries the driver's one-time costs
    /// (lavapipe compiles pipelines on first use).
    pub first_frame_gpu_ms: f64,
    /// Mean and p95 over the frames after the first (the steady state; equal
    /// to the plain figures for a one-frame run). Benchmarks, `compare` and
    /// the printed summary quote these.
    pub steady_mean_gpu_ms: f64,
    pub steady_p95_gpu_ms: f64,
    /// The frames the steady figures cover: `frames − 1` (frames 1.. ), or 1
    /// for a one-frame run, whose only frame then includes the first-use costs.
    pub steady_frames: usize,
    /// Mean milliseconds per frame of each pass name (0 for frames without it).
    pub pass_mean_ms: BTreeMap<String, f64>,
    /// The same over the frames after the first (what the per-pass
    /// breakdowns of reports show).
    pub steady_pass_mean_ms: BTreeMap<String, f64>,
    /// Rays over the whole replay.
    pub rays: RayRecord,
    /// Rays per frame over the frames after the first, as the steady times
    /// (frame 0 only where there is one frame): the warm-up frame fills
    /// every cache from nothing. Until session 50 frame 0 was included, so
    /// a ratio of two caching configurations over 8 frames was pulled
    /// towards 1 by their common cold frame.
    pub rays_per_frame: f64,
    pub method_memory_bytes: u64,
    pub scene_memory_bytes: u64,
    /// Wall-clock seconds of the frame loop (rendering, read-back, writing).
    pub wall_s: f64,
    /// Mean and maximum of the frames' `pose_ms` after the first (frame 0
    /// poses nothing that moved), on a scene that animates: the per-frame
    /// cost of the animation beside `steady_mean_gpu_ms`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub steady_pose_ms: Option<[f64; 2]>,
    pub out: PathBuf,
}

impl std::fmt::Display for ReplaySummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "replayed {} frames of {} at {} fps with {} on {} ({}x{} per eye, {} backend, {})",
            self.frames,
            self.trace.display(),
            self.fps,
            self.method,
            self.scene.display(),
            self.width,
            self.height,
            self.backend,
            self.device
        )?;
        // Steady state as `compare` reports it: frame 0 carries the driver's
        // one-time costs (lavapipe compiles pipelines on first use).
        let steady = if self.frames > 1 {
            format!("frames 1-{}", self.frames - 1)
        } else {
            "one frame, first-use costs included".to_string()
        };
        writeln!(
            f,
            "GPU {:.2} ms/frame steady ({steady}; p95 {:.2} ms), first frame {:.2} ms, {} rays/frame, wall {:.1} s",
            self.steady_mean_gpu_ms,
            self.steady_p95_gpu_ms,
            self.first_frame_gpu_ms,
            si(self.rays_per_frame),
            self.wall_s
        )?;
        if let Some([mean, max]) = self.steady_pose_ms {
            writeln!(
                f,
                "posing the animated instances: {mean:.2} ms/frame steady (max {max:.2} ms; wall clock, before each frame)"
            )?;
        }
        write!(
            f,
            "wrote {} (frames.jsonl, summary.json, images of {} frames)",
            self.out.display(),
            self.images_written
        )
    }
}

/// `1234567` → `1.23 M`: a count with an SI prefix.
fn si(v: f64) -> String {
    match v {
        v if v >= 1e9 => format!("{:.2} G", v * 1e-9),
        v if v >= 1e6 => format!("{:.2} M", v * 1e-6),
        v if v >= 1e3 => format!("{:.2} k", v * 1e-3),
        v => format!("{v:.0}"),
    }
}

/// Renders `cameras` (or the first `opts.frames` of them) in order with
/// `method` and writes images, `frames.jsonl` and `summary.json` under
/// `opts.out` (see the module documentation).
pub fn replay(
    session: &Session,
    method: &mut dyn Method,
    cameras: &[StereoCamera],
    opts: &ReplayOptions,
) -> Result<ReplaySummary> {
    replay_observed(session, method, cameras, opts, &mut |_, _, _| {
        Ok(BTreeMap::new())
    })
}

/// What an observer of a replay receives per frame: the frame's index, its
/// camera and the rendered frame (before it is dropped). It returns metrics
/// for `frames.jsonl` (empty for none). `compare` keeps the frames it shows
/// side by side and evaluates every frame against the reference here.
pub type FrameObserver<'a> =
    dyn FnMut(usize, &StereoCamera, &StereoFrame) -> Result<BTreeMap<String, f64>> + 'a;

/// [`replay`] with an observer called after every frame.
pub fn replay_observed(
    session: &Session,
    method: &mut dyn Method,
    cameras: &[StereoCamera],
    opts: &ReplayOptions,
    observer: &mut FrameObserver<'_>,
) -> Result<ReplaySummary> {
    opts.validate()?;
    let n = opts.frame_count(cameras.len())?;
    let cameras = &cameras[..n];
    session.check_poses((0..n).map(|k| k as f64 / opts.fps))?;

    let out = &opts.out;
    let frames_dir = out.join("frames");
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    // A previous run's frame images go first: a shorter re-run left frames
    // beyond its own beside its frames.jsonl (until session 49). Only the
    // finished files: a `.partial` is a writer's temporary name, never
    // taken for a result, and is replaced when written.
    output::remove_run_files(&frames_dir, &|rel, dir| !dir && output::is_frame_image(rel))
        .map_err(|e| Error::io(&frames_dir, e))?;
    if opts.every > 0 {
        std::fs::create_dir_all(&frames_dir).map_err(|e| Error::io(&frames_dir, e))?;
    }
    let jsonl = out.join("frames.jsonl");
    let summary_path = out.join("summary.json");
    for stale in [&jsonl, &summary_path] {
        match std::fs::remove_file(stale) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(Error::io(stale, e)),
            _ => {}
        }
    }
    let mut lines = output::AtomicFile::create(&jsonl)?;

    let progress = progress_bar(n);
    let start = Instant::now();
    let mut gpu_ms = Vec::with_capacity(n);
    let mut pass_sums: BTreeMap<String, f64> = BTreeMap::new();
    let mut steady_pass_sums: BTreeMap<String, f64> = BTreeMap::new();
    let mut rays = RayCounts::default();
    let mut first_frame_rays = 0u64;
    let mut images_written = 0;
    let (mut width, mut height) = (0, 0);
    let animated = session.scene.is_animated();
    let mut pose_ms: Vec<f64> = Vec::new();
    // A memoized scene's table starts empty for every run (methods compared
    // one after another must not inherit each other's entries).
    let memo = session.scene_gpu.memo.as_ref();
    let mut memo_live = 0u64;
    // The hash table's lookups and failures over the run (hash-cache, hybrid).
    let mut table_lookups: Option<(f64, f64)> = None;
    let mut dropped_paths = 0.0;
    if let Some(m) = memo {
        m.reset()?;
    }
    for (i, camera) in cameras.iter().enumerate() {
        let input = FrameInput {
            index: i as u32,
            camera: *camera,
            prev_camera: i.checked_sub(1).map(|p| cameras[p]),
        };
        let t = |k: usize| k as f64 / opts.fps;
        let posing = session.pose_instances(t(i), i.checked_sub(1).map(t))?;
        if let Some(m) = memo {
            m.begin_frame(i as u32)?;
        }
        let frame = method.render_frame(&input)?;
        let metrics = observer(i, camera, &frame)?;
        (width, height) = (frame.width, frame.height);
        if opts.every > 0 && i % opts.every == 0 {
            write_frame_images(&frames_dir, i, &frame, opts)?;
            images_written += 1;
        }

        let mut record = FrameRecord::new(i, opts.fps, camera, &frame.stats);
        if let Some(m) = memo {
            record.add_memo_counters(&m.counters()?, &mut memo_live);
        }
        record.metrics = metrics;
        dropped_paths += record
            .counters
            .get(NON_FINITE_SAMPLES)
            .copied()
            .unwrap_or(0.0);
        if let Some((l, f)) = hash_table::counters::lookups_and_failures(&record.counters) {
            let t = table_lookups.get_or_insert((0.0, 0.0));
            t.0 += l;
            t.1 += f;
        }
        if animated {
            let ms = posing.as_secs_f64() * 1e3;
            record.pose_ms = Some(ms);
            pose_ms.push(ms);
        }
        let mut line = serde_json::to_string(&record).map_err(|e| {
            Error::io(
                &jsonl,
                std::io::Error::new(std::io::ErrorKind::InvalidData, e),
            )
        })?;
        line.push('\n');
        lines.write_all(line.as_bytes())?;

        for (name, ms) in &record.passes {
            *pass_sums.entry(name.clone()).or_insert(0.0) += ms;
            if i > 0 {
                *steady_pass_sums.entry(name.clone()).or_insert(0.0) += ms;
            }
        }
        gpu_ms.push(record.gpu_ms);
        if i == 0 {
            first_frame_rays = frame.stats.rays.total();
        }
        rays.primary += frame.stats.rays.primary;
        rays.bounce += frame.stats.rays.bounce;
        rays.shadow += frame.stats.rays.shadow;
        progress.set_message(format!(
            "{:.1} GPU ms/frame",
            gpu_ms.iter().sum::<f64>() / gpu_ms.len() as f64
        ));
        progress.inc(1);
    }
    let wall_s = start.elapsed().as_secs_f64();
    progress.finish_and_clear();
    lines.commit()?;
    if let Some(w) = table_lookups
        .and_then(|(l, f)| hash_table::counters::failed_lookup_warning(method.name(), l, f))
    {
        eprintln!("warning: {w}");
    }
    if let Some(w) = dropped_paths_warning(method.name(), dropped_paths, gpu_ms.len()) {
        eprintln!("warning: {w}");
    }

    let caps = &session.ctx.caps;
    let summary = ReplaySummary {
        device: caps.name.clone(),
        driver: format!("{} {}", caps.driver_name, caps.driver_info),
        backend: session.backend,
        scene: session.scene.source.clone(),
        trace: opts.trace.clone(),
        method: method.name().to_string(),
        settings: opts.settings.clone(),
        width,
        height,
        fps: opts.fps,
        frames: n,
        every: opts.every,
        images_written,
        mean_gpu_ms: gpu_ms.iter().sum::<f64>() / n as f64,
        p95_gpu_ms: percentile_nearest_rank(&gpu_ms, 0.95),
        first_frame_gpu_ms: gpu_ms[0],
        steady_mean_gpu_ms: {
            let s = if n > 1 { &gpu_ms[1..] } else { &gpu_ms[..] };
            s.iter().sum::<f64>() / s.len() as f64
        },
        steady_p95_gpu_ms: percentile_nearest_rank(
            if n > 1 { &gpu_ms[1..] } else { &gpu_ms[..] },
            0.95,
        ),
        steady_frames: if n > 1 { n - 1 } else { 1 },
        pass_mean_ms: pass_sums
            .into_iter()
            .map(|(k, v)| (k, v / n as f64))
            .collect(),
        steady_pass_mean_ms: if n > 1 {
            steady_pass_sums
                .into_iter()
                .map(|(k, v)| (k, v / (n - 1) as f64))
                .collect()
        } else {
            BTreeMap::new()
        },
        rays: rays.into(),
        rays_per_frame: if n > 1 {
            (rays.total() - first_frame_rays) as f64 / (n - 1) as f64
        } else {
            rays.total() as f64
        },
        method_memory_bytes: method.memory_bytes(),
        scene_memory_bytes: session.scene_gpu.bytes,
        wall_s,
        steady_pose_ms: (pose_ms.len() > 1).then(|| {
            let s = &pose_ms[1..];
            [
                s.iter().sum::<f64>() / s.len() as f64,
                s.iter().cloned().fold(0.0, f64::max),
            ]
        }),
        out: out.clone(),
    };
    let value = serde_json::to_value(&summary).map_err(|e| {
        Error::io(
            &summary_path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, e),
        )
    })?;
    output::write_json(&summary_path, &value)?;
    Ok(summary)
}

/// The nearest-rank percentile `p` in (0, 1] of `v` (0 for an empty slice).
fn percentile_nearest_rank(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let rank = ((p * s.len() as f64).ceil() as usize).clamp(1, s.len());
    s[rank - 1]
}

/// A progress bar on stderr, hidden when stderr is not a terminal.
fn progress_bar(n: usize) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(n as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{pos}/{len} frames [{bar:30}] {elapsed} elapsed, {eta} left  {msg}",
    ) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

fn check_len(path: &Path, len: usize, width: u32, height: u32) -> Result<()> {
    let want = width as usize * height as usize;
    if len == want {
        Ok(())
    } else {
        Err(Error::Usage(format!(
            "{}: the method returned {len} pixels for a {width}x{height} image",
            path.display()
        )))
    }
}

/// A debug view's name as a file-name part: letters, digits, `-` and `_`.
fn file_part(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect()
}

fn write_frame_images(
    dir: &Path,
    index: usize,
    frame: &StereoFrame,
    opts: &ReplayOptions,
) -> Result<()> {
    let (w, h) = (frame.width, frame.height);
    for (eye, img) in ["left", "right"].into_iter().zip(&frame.eyes) {
        let EyeImage {
            radiance, debug, ..
        } = img;
        let exr = dir.join(format!("{index:05}_{eye}.exr"));
        check_len(&exr, radiance.len(), w, h)?;
        output::write_exr(&exr, w, h, radiance)?;
        output::write_png(
            &dir.join(format!("{index:05}_{eye}.png")),
            w,
            h,
            radiance,
            opts.exposure,
        )?;
        if opts.debug_views {
            for (name, view) in debug {
                let png = dir.join(format!("{index:05}_{eye}_{}.png", file_part(name)));
                check_len(&png, view.len(), w, h)?;
                output::write_png_clamped(&png, w, h, view)?;
            }
        }
    }
    Ok(())
}

/// The frame counter in which every path-tracing method reports the paths
/// it dropped because their radiance was ∞ or NaN.
pub const NON_FINITE_SAMPLES: &str = "non_finite_samples";

/// One line when a run's path tracing dropped paths of ∞ or NaN radiance
/// (counted as black by the shaders, so the images alone do not show it).
pub fn dropped_paths_warning(method: &str, dropped: f64, frames: usize) -> Option<String> {
    (dropped > 0.0).then(|| {
        format!(
            "{method}: {dropped} paths of ∞ or NaN radiance were dropped (counted as black) over {frames} frames, a bug in the scene's data or the path tracer; frames.jsonl `{NON_FINITE_SAMPLES}` says which frames"
        )
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn dropped_paths_are_one_warning() {
        assert_eq!(super::dropped_paths_warning("taa", 0.0, 8), None);
        let w = super::dropped_paths_warning("taa", 12.0, 8).unwrap();
        assert!(
            w.starts_with(
                "taa: 12 paths of ∞ or NaN radiance were dropped (counted as black) over 8 frames"
            ),
            "{w}"
        );
    }

    use super::*;

    #[test]
    fn p95_is_nearest_rank() {
        let v: Vec<f64> = (1..=20).map(f64::from).collect();
        assert_eq!(percentile_nearest_rank(&v, 0.95), 19.0);
        assert_eq!(percentile_nearest_rank(&[3.0], 0.95), 3.0);
        assert_eq!(percentile_nearest_rank(&[], 0.95), 0.0);
    }

    #[test]
    fn options_reject_bad_values() {
        let ok = ReplayOptions::default();
        assert!(ok.validate().is_ok());
        for bad in [
            ReplayOptions {
                fps: 0.0,
                ..Default::default()
            },
            ReplayOptions {
                fps: f64::NAN,
                ..Default::default()
            },
            ReplayOptions {
                frames: Some(0),
                ..Default::default()
            },
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.starts_with("bad --"), "{e}");
        }
    }

    #[test]
    fn debug_view_names_become_safe_file_parts() {
        assert_eq!(file_part("trace-mask"), "trace-mask");
        assert_eq!(file_part("a/b c"), "a-b-c");
    }
}
