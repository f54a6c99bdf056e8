//! `stereocache replay`: cameras along a pose trace, the files a replay
//! writes, and the command line's handling of broken traces. GPU tests run on
//! lavapipe with the validation layer on and fail on any message; images are
//! tiny and runs short.

mod common;
use common::single_error_line;

use glam::{EulerRot, Quat, Vec3};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use stereocache::camera::{HeadPose, PoseSample, PoseTrace, StereoCamera, DEFAULT_IPD};
use stereocache::gpu::{GpuContext, GpuError, GpuResult, Recorder};
use stereocache::methods::{FrameInput, FrameOutputs, Method, RenderSettings, StereoFrame};
use stereocache::replay::{replay, trace_cameras, ReplayOptions};
use stereocache::rt::RtChoice;
use stereocache::session::{CameraSelect, Session};

const W: u32 = 16;
const H: u32 = 12;

fn head_turn() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/synth-head-turn.csv")
}

fn out_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stereocache-replay-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn cornell(ctx: &std::sync::Arc<stereocache::gpu::GpuContext>) -> Session {
    let scene = Session::load_scene("cornell", None).unwrap();
    common::session(ctx, scene, RtChoice::Auto)
}

fn settings() -> RenderSettings {
    RenderSettings {
        width: W,
        height: H,
        spp: 1,
        max_bounces: 2,
        seed: 7,
        all_features: false,
        ..Default::default()
    }
}

fn close_pose(a: &HeadPose, b: &HeadPose, tol: f32) -> bool {
    (a.position - b.position).length() < tol && a.orientation.angle_between(b.orientation) < tol
}

/// Wraps a method: records what it was given, adds a counter and a debug
/// view, and fails on frame `fail_at` (an interrupted run).
struct Probe {
    inner: Box<dyn Method>,
    inputs: Vec<FrameInput>,
    fail_at: Option<u32>,
}

impl Method for Probe {
    fn name(&self) -> &'static str {
        "probe"
    }
    fn context(&self) -> &Arc<GpuContext> {
        self.inner.context()
    }
    fn record<'a>(
        &'a mut self,
        rec: &mut Recorder<'a>,
        frame: &FrameInput,
    ) -> GpuResult<FrameOutputs<'a>> {
        self.inner.record(rec, frame)
    }
    fn render_frame(&mut self, frame: &FrameInput) -> GpuResult<StereoFrame> {
        if Some(frame.index) == self.fail_at {
            return Err(GpuError::DeviceLost("probe frame".into()));
        }
        self.inputs.push(frame.clone());
        let mut f = self.inner.render_frame(frame)?;
        f.stats
            .counters
            .insert("probe.index".into(), frame.index as f64);
        for eye in &mut f.eyes {
            let n = eye.radiance.len();
            eye.debug
                .push(("probe view".into(), vec![[0.5, 0.0, 1.0, 1.0]; n]));
        }
        Ok(f)
    }
    fn memory_bytes(&self) -> u64 {
        self.inner.memory_bytes()
    }
}

/// `trace_cameras` at W×H from the default camera, with `ipd` where the
/// trace has none and the first `limit` frames only.
fn cameras_of(
    s: &Session,
    trace: &PoseTrace,
    fps: f64,
    ipd: Option<f32>,
    limit: Option<usize>,
) -> stereocache::error::Result<Vec<StereoCamera>> {
    trace_cameras(
        s,
        trace,
        fps,
        W,
        H,
        &CameraSelect::Default,
        ipd,
        None,
        limit,
    )
}

fn read_jsonl(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn replay_writes_frames_at_the_cadence_and_one_record_per_frame() {
    let ctx = common::context();
    let s = cornell(&ctx);
    let trace = PoseTrace::read_csv(head_turn()).unwrap();
    let cams = cameras_of(&s, &trace, 90.0, None, None).unwrap();
    assert_eq!(cams.len(), trace.resample(90.0).len());
    let out = out_dir("cadence");
    // A stale result of an earlier run must not survive into this one.
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("summary.json"), "{}").unwrap();
    let opts = ReplayOptions {
        frames: Some(7),
        every: 3,
        out: out.clone(),
        trace: head_turn(),
        settings: serde_json::to_value(settings()).unwrap(),
        ..Default::default()
    };
    let mut m = s.method("reference", &settings()).unwrap();
    let summary = replay(&s, m.as_mut(), &cams, &opts).unwrap();
    common::assert_no_validation_messages(&ctx);

    // Images of frames 0, 3, 6 only.
    let mut files: Vec<String> = std::fs::read_dir(out.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    let mut expect = Vec::new();
    for i in [0, 3, 6] {
        for eye in ["left", "right"] {
            for ext in ["exr", "png"] {
                expect.push(format!("{i:05}_{eye}.{ext}"));
            }
        }
    }
    expect.sort();
    assert_eq!(files, expect);
    let png = image::open(out.join("frames/00003_right.png")).unwrap();
    assert_eq!((png.width(), png.height()), (W, H));

    // One record per frame with the documented fields.
    assert!(!out.join("frames.jsonl.partial").exists());
    let recs = read_jsonl(&out.join("frames.jsonl"));
    assert_eq!(recs.len(), 7);
    let mut ray_total = 0;
    for (i, r) in recs.iter().enumerate() {
        assert_eq!(r["index"], i);
        assert!((r["t"].as_f64().unwrap() - i as f64 / 90.0).abs() < 1e-12);
        let passes = r["passes"].as_object().unwrap();
        assert!(!passes.is_empty());
        // gpu_ms is the method's own passes: diagnostic ones are left out.
        let pass_sum: f64 = passes
            .iter()
            .filter(|(k, _)| !k.starts_with(stereocache::methods::frame::DIAGNOSTIC_PASS_PREFIX))
            .map(|(_, v)| v.as_f64().unwrap())
            .sum();
        assert!((r["gpu_ms"].as_f64().unwrap() - pass_sum).abs() < 1e-9);
        let rays = &r["rays"];
        let kinds: u64 = ["primary", "bounce", "shadow"]
            .iter()
            .map(|k| rays[k].as_u64().unwrap())
            .sum();
        assert!(rays["primary"].as_u64().unwrap() > 0);
        assert_eq!(rays["total"].as_u64().unwrap(), kinds);
        ray_total += kinds;
        assert!(r["counters"].is_object());
        let pos: Vec<f64> = serde_json::from_value(r["camera"]["position"].clone()).unwrap();
        let q: Vec<f32> = serde_json::from_value(r["camera"]["orientation"].clone()).unwrap();
        // serde_json's default float parsing may be 1 ulp off in f64.
        let world = cams[i].world_position().to_array();
        assert!(pos
            .iter()
            .zip(world)
            .all(|(a, b)| (a - b).abs() <= 1e-12 * b.abs().max(1.0)));
        assert_eq!(q, cams[i].head.orientation.to_array());
        assert_eq!(r["camera"]["ipd"].as_f64().unwrap() as f32, DEFAULT_IPD);
    }

    let sum: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(sum["frames"], 7);
    assert_eq!(sum["images_written"], 3);
    assert_eq!(sum["method"], "reference");
    assert_eq!(sum["settings"]["spp"], 1);
    assert_eq!(sum["rays"]["total"].as_u64().unwrap(), ray_total);
    // Rays per frame over the steady frames, as the steady times (frame 0,
    // the warm-up, was included until session 50).
    let first = recs[0]["rays"]["total"].as_u64().unwrap();
    assert_eq!(
        sum["rays_per_frame"].as_f64().unwrap(),
        (ray_total - first) as f64 / 6.0
    );
    assert!(sum["trace"]
        .as_str()
        .unwrap()
        .ends_with("synth-head-turn.csv"));
    for key in [
        "device",
        "driver",
        "backend",
        "scene",
        "mean_gpu_ms",
        "p95_gpu_ms",
        "pass_mean_ms",
        "method_memory_bytes",
        "scene_memory_bytes",
        "wall_s",
    ] {
        assert!(!sum[key].is_null(), "summary.json lacks {key}");
    }
    // Statistics computed from the records (not timing assertions): with 7
    // frames the nearest-rank p95 is the slowest frame.
    let ms: Vec<f64> = recs.iter().map(|r| r["gpu_ms"].as_f64().unwrap()).collect();
    let mean = ms.iter().sum::<f64>() / ms.len() as f64;
    assert!((sum["mean_gpu_ms"].as_f64().unwrap() - mean).abs() < 1e-9);
    assert_eq!(
        sum["p95_gpu_ms"].as_f64().unwrap(),
        ms.iter().cloned().fold(0.0, f64::max)
    );
    assert_eq!(summary.frames, 7);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn frames_chain_previous_cameras_and_write_debug_views_and_counters() {
    let ctx = common::context();
    let s = cornell(&ctx);
    let trace = PoseTrace::read_csv(head_turn()).unwrap();
    let cams = cameras_of(&s, &trace, 90.0, None, None).unwrap();
    let out = out_dir("probe");
    let mut probe = Probe {
        inner: s.method("reference", &settings()).unwrap(),
        inputs: Vec::new(),
        fail_at: None,
    };
    let opts = ReplayOptions {
        frames: Some(3),
        every: 2,
        debug_views: true,
        out: out.clone(),
        ..Default::default()
    };
    replay(&s, &mut probe, &cams, &opts).unwrap();
    common::assert_no_validation_messages(&ctx);

    assert_eq!(probe.inputs.len(), 3);
    assert!(probe.inputs[0].prev_camera.is_none());
    for (i, f) in probe.inputs.iter().enumerate() {
        assert_eq!(f.index as usize, i);
        assert_eq!(f.camera, cams[i]);
        if i > 0 {
            assert_eq!(f.prev_camera, Some(cams[i - 1]));
        }
    }
    for i in [0, 2] {
        for eye in ["left", "right"] {
            let p = out.join(format!("frames/{i:05}_{eye}_probe-view.png"));
            let img = image::open(&p).unwrap().to_rgb8();
            // Shown as is: linear 0.5 → sRGB 188, 1 → 255, no tone curve.
            assert_eq!(img.get_pixel(0, 0).0, [188, 0, 255], "{}", p.display());
        }
    }
    assert!(!out.join("frames/00001_left_probe-view.png").exists());
    let recs = read_jsonl(&out.join("frames.jsonl"));
    for (i, r) in recs.iter().enumerate() {
        assert_eq!(r["counters"]["probe.index"].as_f64().unwrap(), i as f64);
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn an_interrupted_replay_leaves_no_complete_looking_files() {
    let ctx = common::context();
    let s = cornell(&ctx);
    let trace = PoseTrace::read_csv(head_turn()).unwrap();
    let cams = cameras_of(&s, &trace, 90.0, None, None).unwrap();
    let out = out_dir("interrupted");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("frames.jsonl"), "{\"stale\":true}\n").unwrap();
    // A previous run's frame images (until session 49 kept: a shorter
    // re-run left them beside its own frames).
    std::fs::create_dir_all(out.join("frames")).unwrap();
    std::fs::write(out.join("frames").join("00003_left.png"), b"old").unwrap();
    let mut probe = Probe {
        inner: s.method("reference", &settings()).unwrap(),
        inputs: Vec::new(),
        fail_at: Some(2),
    };
    let opts = ReplayOptions {
        frames: Some(5),
        every: 0,
        out: out.clone(),
        ..Default::default()
    };
    let e = replay(&s, &mut probe, &cams, &opts).unwrap_err();
    assert!(e.to_string().contains("device was lost"), "{e}");
    common::assert_no_validation_messages(&ctx);
    assert!(!out.join("frames.jsonl").exists());
    assert!(!out.join("summary.json").exists());
    let left: Vec<_> = std::fs::read_dir(out.join("frames")).unwrap().collect();
    assert!(
        left.is_empty(),
        "--every 0 writes no images, and the old ones go: {left:?}"
    );
    assert_eq!(read_jsonl(&out.join("frames.jsonl.partial")).len(), 2);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn frame_zero_is_the_scene_camera_and_later_frames_follow_the_trace() {
    let ctx = common::context();
    let s = cornell(&ctx);
    let trace = PoseTrace::read_csv(head_turn()).unwrap();
    let samples = trace.resample(90.0);
    let tilted = HeadPose::new(
        Vec3::new(0.3, 0.6, 1.5),
        Quat::from_euler(EulerRot::YXZ, 0.4, -0.2, 0.05),
    );
    for select in [
        CameraSelect::Default,
        CameraSelect::Named("default".into()),
        CameraSelect::Pose(tilted),
    ] {
        let scene_cam: StereoCamera = s.camera(&select, W, H, None, None).unwrap();
        let cams = trace_cameras(&s, &trace, 90.0, W, H, &select, None, None, None).unwrap();
        assert_eq!(cams.len(), samples.len());
        assert_eq!(cams[0].anchor, scene_cam.anchor, "{select:?}: anchor");
        assert!(
            close_pose(&cams[0].head, &scene_cam.head, 1e-5),
            "{select:?}: frame 0 {:?} != camera {:?}",
            cams[0].head,
            scene_cam.head
        );
        assert_eq!(
            (cams[0].yfov, cams[0].aspect, cams[0].ipd),
            (scene_cam.yfov, scene_cam.aspect, scene_cam.ipd)
        );
        // Motion relative to frame 0 is the trace's motion relative to its first sample.
        let world0 = cams[0].head.inverse();
        let stage0 = samples[0].pose.inverse();
        for (cam, sample) in cams.iter().zip(&samples) {
            let rel_world = world0.compose(&cam.head);
            let rel_stage = stage0.compose(&sample.pose);
            assert!(
                close_pose(&rel_world, &rel_stage, 1e-4),
                "t = {}: {rel_world:?} vs {rel_stage:?}",
                sample.t
            );
        }
    }
    // The head actually turns: yaw (about world +Y for the level default
    // camera) changes between successive frames and sweeps tens of degrees.
    let cams = cameras_of(&s, &trace, 90.0, None, None).unwrap();
    let yaw = |c: &StereoCamera| c.head.orientation.to_euler(EulerRot::YXZ).0;
    let yaws: Vec<f32> = cams.iter().map(yaw).collect();
    assert!(yaws[1] != yaws[0] && yaws[10] != yaws[9]);
    let (lo, hi) = yaws
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &y| (a.min(y), b.max(y)));
    assert!(hi - lo > 20f32.to_radians(), "yaw range {}", hi - lo);
    common::assert_no_validation_messages(&ctx);
}

#[test]
fn the_samples_ipd_wins_and_fps_sets_the_frame_count() {
    let ctx = common::context();
    let s = cornell(&ctx);
    let sample = |t: f64, ipd: Option<f32>| PoseSample {
        t,
        pose: HeadPose::new(Vec3::new(t as f32, 0.0, 0.0), Quat::IDENTITY),
        ipd,
    };
    let trace = PoseTrace::from_samples(
        "mem",
        vec![sample(0.0, Some(0.07)), sample(1.0, Some(0.05))],
    );
    let cams = cameras_of(&s, &trace, 10.0, Some(0.06), None).unwrap();
    assert_eq!(cams.len(), 11);
    assert!((cams[0].ipd - 0.07).abs() < 1e-6);
    assert!((cams[10].ipd - 0.05).abs() < 1e-6);
    let no_ipd = PoseTrace::from_samples("mem", vec![sample(0.0, None), sample(1.0, None)]);
    let cams = cameras_of(&s, &no_ipd, 4.0, Some(0.06), None).unwrap();
    assert_eq!(cams.len(), 5);
    assert!(cams.iter().all(|c| c.ipd == 0.06));
    // The first 3 only: the same cameras.
    let first = cameras_of(&s, &no_ipd, 4.0, Some(0.06), Some(3)).unwrap();
    assert_eq!(first.len(), 3);
    assert!(first
        .iter()
        .zip(&cams)
        .all(|(a, b)| a.head.to_mat4() == b.head.to_mat4()));
    // A trace spanning 1e300 s: refused whole, its first 2 frames built.
    let far = PoseTrace::from_samples("mem", vec![sample(0.0, None), sample(1e300, None)]);
    let e = cameras_of(&s, &far, 90.0, None, None).unwrap_err();
    assert!(
        e.to_string()
            .contains("replay the first ones with --frames"),
        "{e}"
    );
    let two = cameras_of(&s, &far, 90.0, None, Some(2)).unwrap();
    assert_eq!(two.len(), 2);
    for fps in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(cameras_of(&s, &no_ipd, fps, None, None).is_err());
    }
}

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_stereocache"));
    c.env("STEREOCACHE_VALIDATE", "1");
    c
}

#[test]
fn cli_replay_with_a_broken_trace_gives_one_error_line_and_writes_nothing() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bad_traces");
    for (file, phrase) in [
        ("decreasing_time.csv", ":4: timestamp"),
        ("empty.csv", "empty file"),
        ("header_only.csv", "no samples"),
        ("inf.csv", "not finite"),
        ("nan.csv", "not finite"),
        ("unknown_column.csv", "unknown column"),
        ("zero_quaternion.csv", "zero norm"),
        ("does_not_exist.csv", "No such file"),
    ] {
        let out = out_dir("cli-bad");
        let path = dir.join(file);
        let o = bin()
            .args([
                "replay", "--scene", "cornell", "--size", "16x12", "--spp", "1",
            ])
            .arg("--trace")
            .arg(&path)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let error = single_error_line(&o, file);
        assert!(error.contains(file), "{file}: {error}");
        assert!(error.contains(phrase), "{file}: {error}");
        assert!(!out.join("frames.jsonl").exists());
        assert!(!out.exists(), "{file}: nothing should be written");
    }
}

#[test]
fn cli_replay_rejects_bad_values_before_rendering() {
    for (args, phrase) in [
        (&["--fps", "0"][..], "bad --fps 0"),
        (&["--fps", "nan"][..], "bad --fps"),
        (&["--frames", "0"][..], "bad --frames 0"),
        (&["--frames", "100000"][..], "use at most"),
        (&["--spp", "0"][..], "bad --spp 0"),
        (&["--method", "nope"][..], "unknown method 'nope'"),
    ] {
        let out = out_dir("cli-values");
        let o = bin()
            .args(["replay", "--scene", "cornell", "--size", "16x12"])
            .arg("--trace")
            .arg(head_turn())
            .arg("--out")
            .arg(&out)
            .args(args)
            .output()
            .unwrap();
        let error = single_error_line(&o, &format!("{args:?}"));
        assert!(error.contains(phrase), "{args:?}: {error}");
        assert!(!out.join("frames.jsonl").exists());
    }
}

#[test]
fn cli_replay_writes_summary_and_prints_it() {
    let out = out_dir("cli-ok");
    let o = bin()
        .args([
            "replay",
            "--scene",
            "cornell",
            "--size",
            "16x12",
            "--spp",
            "1",
            "--frames",
            "4",
            "--every",
            "2",
            "--bounces",
            "1",
        ])
        .arg("--trace")
        .arg(head_turn())
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stdout.contains("replayed 4 frames"), "{stdout}");
    assert!(stdout.contains("ms/frame"), "{stdout}");
    // Steady-state GPU time, as compare reports it, and the first frame apart.
    assert!(stdout.contains("ms/frame steady (frames 1-3"), "{stdout}");
    assert!(stdout.contains("first frame"), "{stdout}");
    assert!(stdout.contains(&out.display().to_string()), "{stdout}");
    // A hidden progress bar: nothing on stderr when it is not a terminal.
    assert!(!stderr.contains("frames ["), "{stderr}");
    assert_eq!(read_jsonl(&out.join("frames.jsonl")).len(), 4);
    assert!(out.join("frames/00002_left.exr").exists());
    assert!(!out.join("frames/00001_left.exr").exists());
    let sum: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(sum["frames"], 4);
    assert_eq!(sum["settings"]["max_bounces"], 1);
    assert_eq!(sum["steady_frames"], 3);
    let steady = sum["steady_mean_gpu_ms"].as_f64().unwrap();
    assert!(
        stdout.contains(&format!("GPU {steady:.2} ms/frame steady")),
        "the printed figure is summary.json's steady_mean_gpu_ms ({steady}): {stdout}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// A full disk while a PNG is written fails the replay with one `error:`
/// line naming the file and leaves nothing under its final name (before,
/// the encoder's unflushed buffer lost the error and a 0-byte PNG was
/// renamed into place while the run went on). The disk is `/dev/full`
/// behind the PNG's temporary name: the file opens, every write fails with
/// ENOSPC, as on a disk that fills up after a file was created.
#[cfg(target_os = "linux")]
#[test]
fn cli_replay_on_a_full_disk_fails_with_one_error_and_no_file() {
    let out = out_dir("full-disk");
    let frames = out.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    std::os::unix::fs::symlink("/dev/full", frames.join("00000_left.png.partial")).unwrap();
    let o = bin()
        .args([
            "replay", "--scene", "cornell", "--size", "16x12", "--spp", "1",
        ])
        .args(["--frames", "2", "--bounces", "1"])
        .arg("--trace")
        .arg(head_turn())
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    // A failed write must fail the command.
    let error = single_error_line(&o, "a replay onto a full disk");
    assert!(
        error.contains("00000_left.png: cannot write") && error.contains("No space left"),
        "{error}"
    );
    let png = frames.join("00000_left.png");
    assert!(png.symlink_metadata().is_err(), "{} exists", png.display());
    assert!(!frames.join("00000_left.png.partial").exists());
    assert!(!out.join("frames.jsonl").exists() && !out.join("summary.json").exists());
    assert!(Path::new("/dev/full").exists());
    let _ = std::fs::remove_dir_all(&out);
}
