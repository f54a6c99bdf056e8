//! Camera model and pose traces: eye geometry, rays, CSV, resampling,
//! hemisphere continuity, the MMSys'18 importer, bad traces, synthesis.

use std::path::PathBuf;

use glam::{EulerRot, Mat4, Quat, UVec2, Vec2, Vec3};
use stereocache::camera::{
    mmsys18::parse_mmsys18, read_mmsys18, synth, Eye, HeadPose, Mmsys18Options, PoseSample,
    PoseTrace, Stage, StereoCamera, SynthKind, DEFAULT_IPD,
};

fn manifest() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn bad(name: &str) -> PathBuf {
    manifest().join("tests/data/bad_traces").join(name)
}

/// Rotation angle between two orientations, accurate for tiny angles
/// (`Quat::angle_between` uses `acos`, which loses them in f32).
fn angle(a: Quat, b: Quat) -> f32 {
    let d = b * a.conjugate();
    2.0 * d.xyz().length().min(1.0).asin()
}

/// Largest angle (radians) between consecutive orientations.
fn max_step_angle(samples: &[PoseSample]) -> f32 {
    samples
        .windows(2)
        .map(|w| angle(w[0].pose.orientation, w[1].pose.orientation))
        .fold(0.0, f32::max)
}

/// Peak angular velocity (degrees per second) by finite differences.
fn peak_deg_per_s(samples: &[PoseSample]) -> f64 {
    samples
        .windows(2)
        .map(|w| {
            let a = angle(w[0].pose.orientation, w[1].pose.orientation) as f64;
            a.to_degrees() / (w[1].t - w[0].t)
        })
        .fold(0.0, f64::max)
}

#[test]
fn eye_separation_is_ipd_along_head_x() {
    let head = HeadPose::new(
        Vec3::new(-1.0, 1.7, 3.0),
        Quat::from_euler(EulerRot::YXZ, -2.1, 0.3, -0.2),
    );
    let mut cam = StereoCamera::new(head, 1.2, 1.0);
    for ipd in [DEFAULT_IPD, 0.07] {
        cam.ipd = ipd;
        let l = cam.eye(Eye::Left);
        let r = cam.eye(Eye::Right);
        let d = r.position - l.position;
        assert!((d - head.right() * ipd).length() < 1e-6, "{d}");
        // Left eye is on the head's −X side.
        assert!((l.position - head.position).dot(head.right()) < 0.0);
        // Parallel axes.
        assert_eq!(l.orientation, r.orientation);
    }
    assert_eq!(Eye::BOTH.map(Eye::index), [0, 1]);
}

#[test]
fn ray_project_round_trip() {
    let cam = StereoCamera::from_scene_camera(
        Mat4::from_rotation_translation(
            Quat::from_euler(EulerRot::YXZ, 0.9, -0.4, 0.0),
            Vec3::new(2.0, 1.0, -5.0),
        ),
        60f32.to_radians(),
        4.0 / 3.0,
    );
    let size = UVec2::new(128, 96);
    for eye in Eye::BOTH {
        let v = cam.eye(eye);
        for j in 0..12 {
            for i in 0..16 {
                let p = Vec2::new(i as f32 * 8.0 + 0.5, j as f32 * 8.0 + 0.5);
                let d = v.ray_direction(p, size);
                assert!((d.length() - 1.0).abs() < 1e-5);
                for dist in [0.1f32, 2.5, 80.0] {
                    let (q, depth) = v.project(v.position + d * dist, size).unwrap();
                    assert!((q - p).length() < 1e-2, "{eye:?} {p} → {q} at {dist}");
                    assert!(depth > 0.0 && depth <= dist * 1.0001);
                }
            }
        }
    }
}

#[test]
fn csv_round_trip_is_exact() {
    let mut tr = synth(SynthKind::Saccade, 2.0, 11, 90.0);
    tr.samples[3].ipd = Some(0.061);
    tr.samples[4].ipd = Some(0.0655);
    let dir = tempdir("csv_round_trip");
    let path = dir.join("trace.csv");
    tr.write_csv(&path).unwrap();
    assert!(!dir.join("trace.csv.tmp").exists());
    let back = PoseTrace::read_csv(&path).unwrap();
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    assert_eq!(back.samples.len(), tr.samples.len());
    for (a, b) in tr.samples.iter().zip(&back.samples) {
        assert_eq!(a.t, b.t);
        assert_eq!(a.pose.position, b.pose.position);
        assert!(a.pose.orientation.angle_between(b.pose.orientation) < 1e-6);
        assert_eq!(a.ipd, b.ipd);
    }
}

#[test]
fn resample_hits_exact_times_and_slerps_halfway() {
    let q0 = Quat::from_rotation_y(0.0);
    let q1 = Quat::from_rotation_y(1.2);
    let s = |t, x: f32, q| PoseSample {
        t,
        pose: HeadPose::new(Vec3::new(x, 0.0, 0.0), q),
        ipd: Some(0.06 + x * 0.01),
    };
    // Uneven input spacing, flipped sign on the last sample.
    let tr = PoseTrace::from_samples("mem", vec![s(0.5, 0.0, q0), s(0.5 + 2.0 / 90.0, 1.0, -q1)]);
    let r = tr.resample(90.0);
    assert_eq!(r.len(), 3);
    for (k, x) in r.iter().enumerate() {
        assert_eq!(x.t, 0.5 + k as f64 / 90.0);
    }
    let mid = r[1];
    assert!((mid.pose.position.x - 0.5).abs() < 1e-5);
    let expect = Quat::from_rotation_y(0.6);
    assert!(mid.pose.orientation.angle_between(expect) < 1e-4);
    assert!(mid.pose.orientation.dot(expect) > 0.0);
    assert!((mid.ipd.unwrap() - 0.065).abs() < 1e-6);
    // A whole number of frames keeps the last frame, at the last time.
    let tr = PoseTrace::from_samples("mem", vec![s(0.0, 0.0, q0), s(1.0, 0.0, q1)]);
    let r = tr.resample(90.0);
    assert_eq!(r.len(), 91);
    assert!((r[90].t - 1.0).abs() < 1e-12);
}

#[test]
fn sign_flips_resample_smoothly() {
    // Real data with extra sign flips on every third sample.
    let text = std::fs::read_to_string(manifest().join("captures/mmsys18-user1.csv")).unwrap();
    let mut tr = PoseTrace::parse_csv("mmsys18-user1.csv", &text).unwrap();
    let data_max = tr
        .samples
        .windows(3)
        .map(|w| {
            angle(w[0].pose.orientation, w[1].pose.orientation)
                + angle(w[1].pose.orientation, w[2].pose.orientation)
        })
        .fold(0.0, f32::max);
    for s in tr.samples.iter_mut().step_by(3) {
        s.pose.orientation = -s.pose.orientation;
    }
    let r = tr.resample(90.0);
    // No frame-to-frame rotation larger than the data itself has over two
    // input steps (a resampled step spans at most two input segments).
    assert!(max_step_angle(&r) <= data_max + 1e-4);
    // And the quaternions themselves are sign-continuous.
    for w in r.windows(2) {
        assert!(w[0].pose.orientation.dot(w[1].pose.orientation) > 0.0);
    }
    let mut c = tr.clone();
    assert!(c.make_hemisphere_continuous() > 0);
    assert_eq!(c.make_hemisphere_continuous(), 0);
}

#[test]
fn mmsys18_user1_imports() {
    let raw = manifest().join("../shared/captures/mmsys18/user1_quaternion.txt");
    if !raw.exists() {
        eprintln!("skipping: {} not present", raw.display());
        return;
    }
    let tr = read_mmsys18(&raw, &Mmsys18Options::default()).unwrap();
    assert!(tr.samples.len() > 15_000);
    let rate = (tr.samples.len() - 1) as f64 / tr.duration();
    assert!((55.0..65.0).contains(&rate), "{rate} Hz");
    for s in &tr.samples {
        assert!(s.t.is_finite());
        assert!(s.pose.position.is_finite() && s.pose.orientation.is_finite());
        assert!((s.pose.orientation.length() - 1.0).abs() < 1e-5);
        // Head-neck model: eyes stay within the offset radius of the pivot.
        assert!(s.pose.position.length() < 0.25);
    }
    // Converted axes: +Y is up. The head's up axis stays near +Y, and yaw
    // (about +Y) dominates the motion, as in the source data.
    let mean_up: f32 =
        tr.samples.iter().map(|s| s.pose.up().y).sum::<f32>() / tr.samples.len() as f32;
    assert!(mean_up > 0.9, "{mean_up}");
    let mut axis_sum = Vec3::ZERO;
    for w in tr.samples.windows(2) {
        let d = w[1].pose.orientation * w[0].pose.orientation.conjugate();
        let (axis, angle) = d.to_axis_angle();
        axis_sum += (axis * angle).abs();
    }
    assert!(
        axis_sum.y > axis_sum.x && axis_sum.y > axis_sum.z,
        "{axis_sum}"
    );
    // Pitch stays moderate: 95 % of samples within ±35°.
    let mut pitch: Vec<f32> = tr
        .samples
        .iter()
        .map(|s| {
            s.pose
                .forward()
                .y
                .clamp(-1.0, 1.0)
                .asin()
                .to_degrees()
                .abs()
        })
        .collect();
    pitch.sort_by(f32::total_cmp);
    assert!(pitch[pitch.len() * 95 / 100] < 35.0);
}

#[test]
fn shipped_mmsys18_excerpt_is_sane() {
    let tr = PoseTrace::read_csv(manifest().join("captures/mmsys18-user1.csv")).unwrap();
    assert!(tr.warnings.is_empty());
    assert_eq!(tr.samples[0].t, 0.0);
    assert!((tr.duration() - 30.0).abs() < 0.1);
    let rate = (tr.samples.len() - 1) as f64 / tr.duration();
    assert!((55.0..65.0).contains(&rate), "{rate} Hz");
    let r = tr.resample(90.0);
    assert_eq!(r.len(), (tr.duration() * 90.0).floor() as usize + 1);
    // The first frame, placed at a scene camera, is that camera's view.
    let cam = Mat4::from_translation(Vec3::new(0.0, 1.6, 0.0));
    let stage = Stage::at_camera(cam, &r[0].pose);
    let c = stage.eye_camera(&r[0], 1.0, 1.0, DEFAULT_IPD);
    assert!((c.head.position - Vec3::new(0.0, 1.6, 0.0)).length() < 1e-5);
    assert!(c.head.forward().abs_diff_eq(Vec3::NEG_Z, 1e-4));
}

fn assert_error(name: &str, needles: &[&str]) {
    let err = PoseTrace::read_csv(bad(name)).unwrap_err().to_string();
    assert!(
        err.contains(name),
        "{name}: message does not name the file: {err}"
    );
    for n in needles {
        assert!(err.contains(n), "{name}: `{n}` missing in: {err}");
    }
    assert!(!err.contains('\n'), "{err}");
}

#[test]
fn bad_traces_are_errors_naming_file_and_line() {
    assert_error("empty.csv", &[":1:", "empty"]);
    assert_error("header_only.csv", &[":2:", "no samples"]);
    assert_error("nan.csv", &[":3:", "`px`", "column 2", "not finite"]);
    assert_error("inf.csv", &[":3:", "`py`", "not finite"]);
    assert_error("zero_quaternion.csv", &[":3:", "zero norm"]);
    assert_error("unknown_column.csv", &[":1:", "`roll`", "column 9"]);
    assert_error("decreasing_time.csv", &[":4:", "earlier", "line 3"]);
    let missing = PoseTrace::read_csv(bad("no_such_file.csv"))
        .unwrap_err()
        .to_string();
    assert!(missing.contains("no_such_file.csv"));
}

#[test]
fn duplicate_timestamps_are_dropped_with_warning() {
    let tr = PoseTrace::read_csv(bad("duplicate_time.csv")).unwrap();
    assert_eq!(tr.samples.len(), 3);
    // The first of the duplicates is kept.
    assert_eq!(tr.samples[1].pose.position.x, 1.0);
    assert_eq!(tr.warnings.len(), 1);
    let w = &tr.warnings[0];
    assert!(
        w.contains("duplicate_time.csv:4:") && w.contains("line 3"),
        "{w}"
    );
}

#[test]
fn mmsys18_errors_name_file_and_line() {
    let opts = Mmsys18Options::default();
    let e = parse_mmsys18(
        "u.txt",
        "timestamp viewpoint w x y z\n0 0 1 0 0 0\n0.1 0 0 0 0 0\n",
        &opts,
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("u.txt:3:") && e.contains("zero norm"), "{e}");
    let e = parse_mmsys18(
        "u.txt",
        "timestamp viewpoint w x y z\n0 0 nan 0 0 0\n",
        &opts,
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("u.txt:2:") && e.contains("`w`"), "{e}");
    let e = parse_mmsys18("u.txt", "timestamp view w x y z\n", &opts)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("u.txt:1:") && e.contains("`view`"), "{e}");
    let e = parse_mmsys18(
        "u.txt",
        "timestamp viewpoint w x y z\n1 0 1 0 0 0\n0.5 0 1 0 0 0\n",
        &opts,
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("u.txt:3:") && e.contains("earlier"), "{e}");
}

#[test]
fn synth_is_deterministic_per_seed() {
    for kind in [SynthKind::HeadTurn, SynthKind::Walk, SynthKind::Saccade] {
        let a = synth(kind, 4.0, 1, 90.0);
        let b = synth(kind, 4.0, 1, 90.0);
        let c = synth(kind, 4.0, 2, 90.0);
        assert_eq!(a.samples, b.samples, "{kind}");
        assert_ne!(a.samples, c.samples, "{kind}");
        assert!(a.samples.iter().all(|s| s.pose.position.is_finite()));
    }
    let still = synth(SynthKind::Still, 2.0, 5, 90.0);
    assert!(still.samples.iter().all(|s| s.pose == HeadPose::IDENTITY));
    assert_eq!(still.samples, synth(SynthKind::Still, 2.0, 6, 90.0).samples);
}

#[test]
fn head_turn_and_saccade_peak_velocities_in_documented_range() {
    use stereocache::camera::synth::{HEAD_TURN_PEAK_DEG_S, SACCADE_PEAK_DEG_S};
    for seed in 0..8 {
        // Sampled finely so finite differences see the true peak.
        let ht = synth(SynthKind::HeadTurn, 6.0, seed, 1000.0);
        let peak = peak_deg_per_s(&ht.samples);
        assert!(
            (HEAD_TURN_PEAK_DEG_S.0 - 1.0..=HEAD_TURN_PEAK_DEG_S.1 + 1.0).contains(&peak),
            "head-turn seed {seed}: {peak} °/s"
        );
        let max_yaw = ht
            .samples
            .iter()
            .map(|s| {
                s.pose
                    .orientation
                    .to_euler(EulerRot::YXZ)
                    .0
                    .abs()
                    .to_degrees()
            })
            .fold(0.0, f32::max);
        assert!((max_yaw - 30.0).abs() < 0.01, "{max_yaw}");
        let sc = synth(SynthKind::Saccade, 6.0, seed, 1000.0);
        let peak = peak_deg_per_s(&sc.samples);
        assert!(
            (SACCADE_PEAK_DEG_S.0 - 1.0..=SACCADE_PEAK_DEG_S.1 + 1.0).contains(&peak),
            "saccade seed {seed}: {peak} °/s"
        );
    }
}

#[test]
fn shipped_synth_traces_match_generator() {
    for kind in [SynthKind::HeadTurn, SynthKind::Walk] {
        let path = manifest().join(format!("captures/synth-{kind}.csv"));
        let shipped = PoseTrace::read_csv(&path).unwrap();
        let fresh = synth(kind, 5.0, 1, 90.0);
        assert_eq!(shipped.samples.len(), fresh.samples.len());
        for (a, b) in shipped.samples.iter().zip(&fresh.samples) {
            assert_eq!(a.t, b.t);
            assert!((a.pose.position - b.pose.position).length() < 1e-6);
            assert!(a.pose.orientation.angle_between(b.pose.orientation) < 1e-5);
        }
    }
}

fn tempdir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("stereocache-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
