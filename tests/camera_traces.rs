//! Camera model and pose traces: eye geometry, rays, CSV, resampling,
//! hemisphere continuity, the MMSys'18 importer, bad traces, synthesis.

mod common;
use common::require_file;
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
    if !require_file(&raw) {
        return;
    }
    let tr = read_mmsys18(&raw, &Mmsys18Options::default()).unwrap();
    // Orientation only (head–neck model): the convention check has no
    // walking to judge and stays silent.
    assert_eq!(stereocache::camera::convention_warning(&tr), None);
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

/// The MMSys'18 quaternions were composed from Unity's Euler angles,
/// rounded to 0.1°, in the order Rx(−roll)·Rz(yaw)·Ry(−pitch) (module docs
/// of `camera::mmsys18`, "Composition order"): decomposed in that order by
/// `mmsys18_euler`, every sample of user 1 gives three angles on the 0.1°
/// grid (to 10⁻⁶ of a step; another order gives fractions spread over the
/// step). At the order's gimbal lock (a yaw of exactly ±90.0°, which the
/// 0.1° grid makes possible) only pitch ∓ roll is determined: the roll is
/// the previous sample's (the hint) and pitch ∓ roll is on the grid.
#[test]
fn mmsys18_quaternions_decompose_to_a_tenth_of_a_degree() {
    use glam::DQuat;
    use stereocache::camera::mmsys18::mmsys18_euler;
    let raw = manifest().join("../shared/captures/mmsys18/user1_quaternion.txt");
    if !require_file(&raw) {
        return;
    }
    let text = std::fs::read_to_string(&raw).unwrap();
    let off_grid = |x: f64| {
        let tenths = x.to_degrees() * 10.0;
        (tenths - tenths.round()).abs()
    };
    let (mut n, mut gimbal, mut worst, mut roll) = (0usize, 0usize, 0.0f64, 0.0f64);
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|t| t.parse().unwrap())
            .collect();
        let q = DQuat::from_xyzw(v[3], v[4], v[5], v[2]).normalize();
        let (a, b, c) = mmsys18_euler(q, f64::NAN);
        if a.is_nan() {
            // Gimbal lock: the hint's roll, pitch ∓ roll on the grid.
            let (a, b, c) = mmsys18_euler(q, roll);
            assert_eq!(a, roll);
            worst = worst.max(off_grid(b)).max(off_grid(c - b.signum() * a));
            gimbal += 1;
        } else {
            worst = worst.max(off_grid(a)).max(off_grid(b)).max(off_grid(c));
            roll = a;
        }
        n += 1;
    }
    eprintln!("{n} samples, {gimbal} at the gimbal lock, worst {worst} of a step");
    assert!(n > 15_000);
    assert!(worst < 1e-6, "an angle {worst} of a 0.1° step off the grid");
}

/// The end of user 4's session (source seconds 264–266): the head looks
/// almost straight down (pitch −76° to −89°), where the files' roll-
/// outermost order turns small head motions into fast spins (6 312°/s
/// between two samples) and the roll of the pitch-limited Euler angles
/// reaches 176°. The rebuilt rotation is continuous there: its fastest
/// step is slower than the file's. (Until session 56's review the Euler
/// branch alternated between samples there: 11 938°/s.)
#[test]
fn mmsys18_rebuild_does_not_spin_where_the_head_looks_down() {
    let raw = manifest().join("../shared/captures/mmsys18/user4_quaternion.txt");
    if !require_file(&raw) {
        return;
    }
    let (start, end) = (264.0, 266.0);
    let opts = Mmsys18Options {
        start,
        end,
        rebase_time: false,
        ..Default::default()
    };
    let tr = read_mmsys18(&raw, &opts).unwrap();
    let speed = |t0: f64, t1: f64, a: Quat, b: Quat| {
        2.0 * (a.dot(b).abs().min(1.0) as f64).acos().to_degrees() / (t1 - t0)
    };
    let rebuilt = tr
        .samples
        .windows(2)
        .filter(|w| w[1].t > w[0].t)
        .map(|w| speed(w[0].t, w[1].t, w[0].pose.orientation, w[1].pose.orientation))
        .fold(0.0f64, f64::max);
    // The file's own quaternions over the same samples.
    let text = std::fs::read_to_string(&raw).unwrap();
    let rows: Vec<(f64, Quat)> = text
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            (
                v[0],
                Quat::from_xyzw(v[3] as f32, v[4] as f32, v[5] as f32, v[2] as f32).normalize(),
            )
        })
        .filter(|(t, _)| (start..=end).contains(t))
        .collect();
    let file = rows
        .windows(2)
        .filter(|w| w[1].0 > w[0].0)
        .map(|w| speed(w[0].0, w[1].0, w[0].1, w[1].1))
        .fold(0.0f64, f64::max);
    eprintln!("fastest step: file {file:.0}°/s, rebuilt {rebuilt:.0}°/s");
    assert!(tr.samples.len() > 50 && rows.len() == tr.samples.len());
    assert!(rebuilt < file, "rebuilt {rebuilt}°/s, file {file}°/s");
}

/// `captures/mmsys18-user1.csv` is what the importer makes of the source
/// file today (examples/make_captures.rs: source seconds 10 to 40), so a
/// change to the import cannot leave the shipped trace behind.
#[test]
fn shipped_mmsys18_excerpt_is_the_import_of_its_source() {
    let raw = manifest().join("../shared/captures/mmsys18/user1_quaternion.txt");
    if !require_file(&raw) {
        return;
    }
    let opts = Mmsys18Options {
        start: 10.0,
        end: 40.0,
        ..Default::default()
    };
    let fresh =
        std::env::temp_dir().join(format!("stereocache-mmsys18-{}.csv", std::process::id()));
    stereocache::camera::convert_mmsys18(&raw, &fresh, &opts).unwrap();
    let made = std::fs::read_to_string(&fresh).unwrap();
    std::fs::remove_file(&fresh).ok();
    assert!(
        made == std::fs::read_to_string(manifest().join("captures/mmsys18-user1.csv")).unwrap(),
        "captures/mmsys18-user1.csv is stale: cargo run --example make_captures"
    );
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

fn tempdir(name: &str) -> common::TempDir {
    common::TempDir::new(name)
}

// ---------------------------------------------------------------------------
// Recording importers (issue 13, item 4): conventions, time units, formats,
// the motion-vs-view check, bad input, and the command line.

use stereocache::camera::{
    convention_warning, motion_vs_view, parse_generic_csv, parse_mmsys17, parse_openxr,
    AxisConvention, ColumnMap, CsvOptions, Handedness, HeadNeckModel, Mmsys17Options, SignedAxis,
    TimeUnit, TimeWindow,
};

/// One 60 Hz tick step (1/60 s in 100-ns ticks, rounded as a recorder would).
const TICK_STEP: i64 = 166_667;
/// A .NET tick timestamp of April 2020 (pred6dof's first line), > 2⁵³.
const TICK_ORIGIN: i64 = 637_231_069_485_244_909;

/// A HoloLens/Unity recording in the pred6dof layout (`timestamp,x,y,z,
/// qx,qy,qz,qw`, ticks, `, ` separators): walking at `speed` m/s along the
/// Unity direction `dir` for `seconds` while looking along Unity `yaw`
/// (radians about +Y, Unity's rotation on coordinates).
fn unity_walk(seconds: f64, speed: f64, dir: Vec3, yaw: f32) -> String {
    let q = Quat::from_rotation_y(yaw);
    let mut s = String::from("timestamp,x,y,z,qx,qy,qz,qw\n");
    let n = (seconds * 60.0) as i64;
    for k in 0..=n {
        let t = k as f64 / 60.0;
        let p = dir * (speed * t) as f32 + Vec3::new(0.0, 1.6, 0.0);
        s += &format!(
            "{}, {}, {}, {}, {}, {}, {}, {}\n",
            TICK_ORIGIN + k * TICK_STEP,
            p.x,
            p.y,
            p.z,
            q.x,
            q.y,
            q.z,
            q.w
        );
    }
    s
}

fn hololens() -> CsvOptions {
    CsvOptions::new(TimeUnit::Ticks, AxisConvention::UNITY)
}

fn qv(q: [f64; 4]) -> Quat {
    Quat::from_xyzw(q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32).normalize()
}

fn mat_mul(m: &[[f64; 3]; 3], v: Vec3) -> Vec3 {
    let r = m.map(|row| row[0] * v.x as f64 + row[1] * v.y as f64 + row[2] * v.z as f64);
    Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32)
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

#[test]
fn unity_plus_z_view_becomes_gltf_minus_z_and_turns_keep_their_sense() {
    // Known row: the identity rotation in a left-handed Unity file looks
    // along Unity +Z; converted, the head looks along glTF −Z (the image of
    // Unity +Z, x and y unchanged) — the glTF camera's forward.
    let c = AxisConvention::UNITY;
    let q = qv(c.quaternion([0.0, 0.0, 0.0, 1.0]));
    assert!(q.abs_diff_eq(Quat::IDENTITY, 1e-7));
    assert_eq!(v3(c.position([0.0, 0.0, 1.0])), Vec3::NEG_Z);
    assert_eq!(v3(c.position([0.3, 1.6, 2.0])), Vec3::new(0.3, 1.6, -2.0));
    // Unity yaw +30° about +Y: forward +Z → (sin 30°, 0, cos 30°), towards
    // Unity +X, the wearer's right. After conversion the head still turns
    // right (+X) and still looks forward (−Z).
    let (s, co) = (30f32.to_radians().sin(), 30f32.to_radians().cos());
    let u = Quat::from_rotation_y(30f32.to_radians());
    let g = qv(c.quaternion([u.x as f64, u.y as f64, u.z as f64, u.w as f64]));
    assert!(g.forward_eq(Vec3::new(s, 0.0, -co)), "{}", g * Vec3::NEG_Z);
    // Pitch up in Unity (about +X by −20°: +Z tilts to +Y) stays pitch up.
    let u = Quat::from_rotation_x(-20f32.to_radians());
    let g = qv(c.quaternion([u.x as f64, u.y as f64, u.z as f64, u.w as f64]));
    assert!((g * Vec3::NEG_Z).y > 0.3);
}

trait ForwardEq {
    fn forward_eq(&self, v: Vec3) -> bool;
}
impl ForwardEq for Quat {
    fn forward_eq(&self, v: Vec3) -> bool {
        (*self * Vec3::NEG_Z).abs_diff_eq(v, 1e-5)
    }
}

#[test]
fn every_convention_maps_rotations_by_conjugation() {
    // For any source rotation R and convention M: the converted head's
    // forward, up and right are the images under M of the source head's
    // forward, up and right (R' = M·R·Mᵀ), and M is a reflection exactly
    // for left-handed sources.
    let unreal = AxisConvention::new(Handedness::Left, SignedAxis::PZ, SignedAxis::PX).unwrap();
    let ros = AxisConvention::new(Handedness::Right, SignedAxis::PZ, SignedAxis::PX).unwrap();
    let d3d_down = AxisConvention::new(Handedness::Left, SignedAxis::NY, SignedAxis::NZ).unwrap();
    let mut rng = stereocache::camera::pcg::Pcg32::new(13, 4);
    for c in [
        AxisConvention::GLTF,
        AxisConvention::UNITY,
        AxisConvention::CORBILLON,
        unreal,
        ros,
        d3d_down,
    ] {
        let m = c.matrix();
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        let expect_det = if c.handedness == Handedness::Left {
            -1.0
        } else {
            1.0
        };
        assert_eq!(det, expect_det, "{c}");
        let (f, u, r) = (
            v3(c.forward.vector()),
            v3(c.up.vector()),
            v3(c.right().vector()),
        );
        assert_eq!(mat_mul(&m, f), Vec3::NEG_Z, "{c}");
        assert_eq!(mat_mul(&m, u), Vec3::Y, "{c}");
        assert_eq!(mat_mul(&m, r), Vec3::X, "{c}");
        for _ in 0..50 {
            let src = Quat::from_xyzw(
                rng.uniform(-1.0, 1.0) as f32,
                rng.uniform(-1.0, 1.0) as f32,
                rng.uniform(-1.0, 1.0) as f32,
                rng.uniform(-1.0, 1.0) as f32,
            )
            .normalize();
            let g = qv(c.quaternion([src.x as f64, src.y as f64, src.z as f64, src.w as f64]));
            for (head, gltf_head) in [(f, Vec3::NEG_Z), (u, Vec3::Y), (r, Vec3::X)] {
                let want = mat_mul(&m, src * head);
                assert!((g * gltf_head).abs_diff_eq(want, 1e-5), "{c}: {src}");
            }
        }
    }
}

/// The MMSys'18 import's mapping is the documented formula for the
/// authors' left-handed frame (+x forward, +y right, +z up):
/// (qx, qy, qz, qw)_glTF = (−y, −z, x, w).
#[test]
fn corbillon_convention_is_the_mmsys18_mapping() {
    let mut rng = stereocache::camera::pcg::Pcg32::new(17, 1);
    for _ in 0..20 {
        let [w, x, y, z] = [0; 4].map(|_| rng.uniform(-1.0, 1.0));
        let a = stereocache::camera::mmsys18::mmsys18_to_gltf(glam::DQuat::from_xyzw(x, y, z, w));
        assert_eq!(a, glam::DQuat::from_xyzw(-y, -z, x, w));
    }
}

#[test]
fn hololens_walk_forward_stays_forward_and_a_naive_copy_warns() {
    let text = unity_walk(2.0, 1.2, Vec3::Z, 0.0);
    let tr = parse_generic_csv("walk.csv", &text, &hololens()).unwrap();
    assert!(tr.warnings.is_empty(), "{:?}", tr.warnings);
    assert_eq!(tr.samples.len(), 121);
    // Exact tick arithmetic: 166 667 ticks = 0.0166667 s.
    assert_eq!(tr.samples[1].t, 166_667.0 / 1e7);
    let (a, b) = (tr.samples[0].pose, tr.samples[120].pose);
    assert!(a.forward().abs_diff_eq(Vec3::NEG_Z, 1e-6));
    let walked = b.position - a.position;
    assert!(
        (walked - Vec3::new(0.0, 0.0, -2.4)).length() < 1e-5,
        "{walked}"
    );
    assert!(walked.dot(a.forward()) > 0.0, "the walk must stay forward");
    let m = motion_vs_view(&tr.samples);
    assert_eq!(m.backward_m, 0.0);
    assert!(m.forward_m >= 2.0, "{m:?}");
    assert_eq!(convention_warning(&tr), None);

    // Walking sideways-right while turned right (Unity yaw +90°: looking
    // along Unity +X) is also forward.
    let text = unity_walk(2.0, 1.2, Vec3::X, std::f32::consts::FRAC_PI_2);
    let tr = parse_generic_csv("turned.csv", &text, &hololens()).unwrap();
    assert!(tr.samples[0].pose.forward().abs_diff_eq(Vec3::X, 1e-5));
    assert!(convention_warning(&tr).is_none());
    assert!(motion_vs_view(&tr.samples).forward_m >= 2.0);

    // The same file copied as if it were glTF (right-handed, −Z forward):
    // the wearer walks backwards, and the check names the likely cause.
    let naive = CsvOptions::new(TimeUnit::Ticks, AxisConvention::GLTF);
    let tr = parse_generic_csv("walk.csv", &unity_walk(2.0, 1.2, Vec3::Z, 0.0), &naive).unwrap();
    let m = motion_vs_view(&tr.samples);
    assert_eq!(m.forward_m, 0.0);
    let w = convention_warning(&tr).expect("a backwards walk must warn");
    assert!(w.starts_with("walk.csv: ") && !w.contains('\n'), "{w}");
    assert!(
        w.contains("backwards") && w.contains("handedness") && w.contains("100 %"),
        "{w}"
    );
}

#[test]
fn motion_check_accepts_synthetic_walk_and_flags_it_mirrored() {
    let walk = synth(SynthKind::Walk, 5.0, 1, 90.0);
    assert_eq!(convention_warning(&walk), None);
    assert!(motion_vs_view(&walk.samples).forward_m > 5.0);
    // Positions mirrored in z (the naive handedness mistake on positions
    // alone): backwards.
    let mut back = walk.clone();
    for s in &mut back.samples {
        s.pose.position.z = -s.pose.position.z;
    }
    assert!(convention_warning(&back).is_some());
    // Head turns on the spot (neck model only) never reach a verdict.
    let turn = synth(SynthKind::HeadTurn, 5.0, 1, 90.0);
    assert_eq!(motion_vs_view(&turn.samples).along_m(), 0.0);
    assert_eq!(convention_warning(&turn), None);
}

#[test]
fn time_units_convert_exactly() {
    let text = "t,x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n1000,0,0,0,0,0,0,1\n2500,0,0,0,0,0,0,1\n";
    let times = |unit| {
        parse_generic_csv("u.csv", text, &CsvOptions::new(unit, AxisConvention::GLTF))
            .unwrap()
            .samples
            .iter()
            .map(|s| s.t)
            .collect::<Vec<_>>()
    };
    assert_eq!(times(TimeUnit::Seconds), vec![0.0, 1000.0, 2500.0]);
    assert_eq!(times(TimeUnit::Milliseconds), vec![0.0, 1.0, 2.5]);
    assert_eq!(times(TimeUnit::Microseconds), vec![0.0, 0.001, 0.0025]);
    assert_eq!(times(TimeUnit::Nanoseconds), vec![0.0, 1e-6, 2.5e-6]);
    assert_eq!(times(TimeUnit::Ticks), vec![0.0, 1e-4, 2.5e-4]);
    // Ticks beyond 2⁵³ one tick apart stay distinct (f64 ticks would merge).
    let text = format!(
        "timestamp,qx,qy,qz,qw\n{a},0,0,0,1\n{b},0,0,0,1\n",
        a = TICK_ORIGIN,
        b = TICK_ORIGIN + 1
    );
    let tr = parse_generic_csv("t.csv", &text, &hololens()).unwrap();
    assert_eq!(tr.samples.len(), 2);
    assert_eq!(tr.samples[1].t, 1e-7);
    // A window in seconds from the first sample, re-based to 0.
    let mut o = CsvOptions::new(TimeUnit::Milliseconds, AxisConvention::GLTF);
    o.window = TimeWindow {
        start: 0.5,
        end: 3.0,
    };
    let text = "t,x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n1000,0,0,0,0,0,0,1\n2500,0,0,0,0,0,0,1\n";
    let tr = parse_generic_csv("w.csv", text, &o).unwrap();
    assert_eq!(
        tr.samples.iter().map(|s| s.t).collect::<Vec<_>>(),
        vec![0.0, 1.5]
    );
}

#[test]
fn column_maps_by_index_and_name_and_orientation_only() {
    // Headerless, whitespace-separated, quaternion scalar-first.
    let text = "0.0 1 2 3 1 0 0 0\n0.5 1 2 3 0.7071068 0 0.7071068 0\n";
    let mut o = CsvOptions::new(TimeUnit::Seconds, AxisConvention::GLTF);
    o.columns = Some("t=0,x=1,y=2,z=3,qw=4,qx=5,qy=6,qz=7".parse().unwrap());
    let tr = parse_generic_csv("ws.txt", text, &o).unwrap();
    assert_eq!(tr.samples[0].pose.position, Vec3::new(1.0, 2.0, 3.0));
    // 90° about +Y (glTF): forward −Z turns to −X.
    assert!(tr.samples[1].pose.forward().abs_diff_eq(Vec3::NEG_X, 1e-5));
    // By name, extra columns ignored, orientation only → head–neck model.
    let text =
        "frame;time;rot_x;rot_y;rot_z;rot_w;gaze\n1;0;0;0;0;1;7\n2;10;0;0.7071068;0;0.7071068;7\n";
    o.columns = Some(
        "t=time,qx=rot_x,qy=rot_y,qz=rot_z,qw=rot_w"
            .parse()
            .unwrap(),
    );
    o.time_unit = TimeUnit::Milliseconds;
    let tr = parse_generic_csv("semi.csv", text, &o).unwrap();
    assert_eq!(tr.samples[1].t, 0.01);
    let neck = HeadNeckModel::default();
    assert_eq!(tr.samples[0].pose.position, Vec3::ZERO);
    assert!(
        (tr.samples[1].pose.position - neck.eye_position(tr.samples[1].pose.orientation)).length()
            < 1e-7
    );
    assert!(tr.samples[1].pose.position.length() > 0.05);
    // Map syntax errors.
    for (map, needle) in [
        ("t=0,roll=1,qx=2,qy=3,qz=4,qw=5", "unknown key `roll`"),
        ("t=0,x=1,qx=2,qy=3,qz=4,qw=5", "all of x, y, z"),
        ("t=0,qx=2,qy=3,qz=4", "qw"),
        ("t=0,t=1,qx=2,qy=3,qz=4,qw=5", "twice"),
        ("x=1,y=2,z=3,qx=2,qy=3,qz=4,qw=5", "`t`"),
    ] {
        let e = map.parse::<ColumnMap>().unwrap_err().to_string();
        assert!(e.contains(needle), "{map}: {e}");
    }
}

#[test]
fn hemisphere_continuity_after_import() {
    let mut text = String::from("timestamp,x,y,z,qx,qy,qz,qw\n");
    for k in 0..10i64 {
        // A slow Unity yaw with the sign of every other sample flipped.
        let q = Quat::from_rotation_y(0.05 * k as f32) * if k % 2 == 1 { -1.0 } else { 1.0 };
        text += &format!(
            "{},0,1.6,0,{},{},{},{}\n",
            TICK_ORIGIN + k * TICK_STEP,
            q.x,
            q.y,
            q.z,
            q.w
        );
    }
    let tr = parse_generic_csv("flip.csv", &text, &hololens()).unwrap();
    for w in tr.samples.windows(2) {
        assert!(w[0].pose.orientation.dot(w[1].pose.orientation) > 0.99);
    }
    assert!(
        tr.warnings.iter().any(|w| w
            == "flip.csv: 5 sample(s) had their quaternion sign flipped for hemisphere continuity"),
        "{:?}",
        tr.warnings
    );
}

#[test]
fn openxr_rows_keep_axes_exact_nanoseconds_and_valid_flags() {
    let text = "orientation.w,time,position.x,position.y,position.z,orientation.x,orientation.y,orientation.z,flags\n\
        1,1700000000000000000,0,1.6,0,0,0,0,15\n\
        1,1700000000011111111,0.1,1.6,-0.01,0,0,0,15\n\
        1,1700000000022222222,0.2,1.6,-0.02,0,0,0,3\n\
        1,1700000000033333333,9,9,9,0,0,0,1\n\
        0.9659258,1700000000044444444,0.4,1.6,-0.04,0,0.258819,0,0xF\n";
    let tr = parse_openxr("xr.csv", text, TimeWindow::default()).unwrap();
    let t: Vec<f64> = tr.samples.iter().map(|s| s.t).collect();
    assert_eq!(t, vec![0.0, 0.011111111, 0.022222222, 0.044444444]);
    // No axis change: values as written (OpenXR = glTF axes).
    assert_eq!(tr.samples[1].pose.position, Vec3::new(0.1, 1.6, -0.01));
    assert!(tr.samples[3]
        .pose
        .orientation
        .abs_diff_eq(Quat::from_rotation_y(30f32.to_radians()), 1e-6));
    assert!(
        tr.warnings
            .iter()
            .any(|w| w.contains("1 sample(s) without ORIENTATION_VALID") && w.contains("line 5")),
        "{:?}",
        tr.warnings
    );
    // Strict header: a typo is an error naming the column.
    let e = parse_openxr("xr.csv", "time,position.x,position.y,position.z,orientation.x,orientation.y,orientation.z,orientation.W\n0,0,0,0,0,0,0,1\n", TimeWindow::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("xr.csv:1:") && e.contains("`orientation.W`"),
        "{e}"
    );
}

#[test]
fn mmsys17_both_layouts_and_axes() {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    // 6 fields (published dataset): t frameId w x y z. The second sample is a
    // 90° turn about +z (up): a right turn in the recorder's frame (+y
    // right): forward → glTF +X; sign-flipped third.
    let six = format!("0.000000 0 1 0 0 0\n0.016667 1 {h} 0 0 {h}\n0.033334 2 -{h} 0 0 -{h}\n");
    let seven = format!(
        "0.000000 0 0.0 1 0 0 0\n0.016667 1 0.04 {h} 0 0 {h}\n0.033334 2 0.08 -{h} 0 0 -{h}\n"
    );
    for text in [six, seven] {
        let tr = parse_mmsys17("u.txt", &text, &Mmsys17Options::default()).unwrap();
        assert_eq!(tr.samples.len(), 3);
        assert_eq!(tr.samples[1].t, 0.016667);
        assert!(tr.samples[0].pose.forward().abs_diff_eq(Vec3::NEG_Z, 1e-6));
        assert!(tr.samples[1].pose.forward().abs_diff_eq(Vec3::X, 1e-5));
        // Neck model: the eyes swing with the turn.
        assert!(
            (tr.samples[1].pose.position
                - HeadNeckModel::default().eye_position(tr.samples[1].pose.orientation))
            .length()
                < 1e-7
        );
        assert!(
            tr.samples[2]
                .pose
                .orientation
                .dot(tr.samples[1].pose.orientation)
                > 0.99
        );
        assert!(
            tr.warnings.iter().any(|w| w.contains("hemisphere")),
            "{:?}",
            tr.warnings
        );
    }
    let e = parse_mmsys17(
        "u.txt",
        "timestamp frameId w x y z\n0 0 1 0 0 0\n",
        &Mmsys17Options::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("u.txt:1:") && e.contains("not a number"),
        "{e}"
    );
    let e = parse_mmsys17("u.txt", "0 0 1 0 0\n", &Mmsys17Options::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("u.txt:1:") && e.contains("5 fields"), "{e}");
}

#[test]
fn truncated_final_line_is_dropped_other_short_lines_are_errors() {
    // pred6dof's 12.csv ends mid-number without a newline.
    let mut text = unity_walk(0.1, 1.0, Vec3::Z, 0.0);
    text += "637231093681476118, 0.07112393, 0.0713555142, 1.0741663, -0.";
    let tr = parse_generic_csv("cut.csv", &text, &hololens()).unwrap();
    assert_eq!(tr.samples.len(), 7);
    assert!(
        tr.warnings
            .iter()
            .any(|w| w.starts_with("cut.csv:9: truncated final line")),
        "{:?}",
        tr.warnings
    );
    // With a newline after it, or in the middle, it is an error.
    let e = parse_generic_csv("cut.csv", &(text.clone() + "\n"), &hololens())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("cut.csv:9:") && e.contains("5 fields"), "{e}");
}

#[test]
fn bad_recordings_are_one_line_errors_naming_file_and_line() {
    let walk = unity_walk(0.05, 1.0, Vec3::Z, 0.0);
    let lines: Vec<&str> = walk.lines().collect();
    let with_line = |k: usize, replacement: &str| {
        let mut l = lines.clone();
        l[k] = replacement;
        l.join("\n") + "\n"
    };
    let mut named = hololens();
    named.columns = Some(
        "t=time,x=x,y=y,z=z,qx=qx,qy=qy,qz=qz,qw=qw"
            .parse()
            .unwrap(),
    );
    let cases: Vec<(String, CsvOptions, Vec<&str>)> = vec![
        (String::new(), hololens(), vec![":1:", "empty"]),
        (
            "# only a comment\n\n".into(),
            hololens(),
            vec![":1:", "empty"],
        ),
        (
            lines[0].to_string() + "\n",
            hololens(),
            vec![":2:", "no samples"],
        ),
        (walk.clone(), named, vec![":1:", "unknown column `time`"]),
        (
            with_line(3, "637231069485244910, 0, 1.6, 0, 0, 0, 0, 1"),
            hololens(),
            vec![":4:", "earlier", "line 3"],
        ),
        (
            with_line(2, "637231069485411576, 0, 1.6, 0, 0, 0, NaN, 1"),
            hololens(),
            vec![":3:", "`qz`", "not finite"],
        ),
        (
            with_line(2, "637231069485411576, 0, 1.6, 0, 0, 0, 0, 0"),
            hololens(),
            vec![":3:", "zero norm"],
        ),
        (
            with_line(2, "637231069485411576, 0, 1.6, 1e39, 0, 0, 0, 1"),
            hololens(),
            vec![":3:", "`z`", "out of range"],
        ),
        (
            with_line(2, "637231069485411576, 0, 1.6, 0, 0, 0, 1"),
            hololens(),
            vec![":3:", "7 fields"],
        ),
        (
            with_line(2, "637231069485411576, 0, 1.6, abc, 0, 0, 0, 1"),
            hololens(),
            vec![":3:", "`abc` is not a number"],
        ),
        (
            with_line(0, "time,x,y,z,rx,ry,rz,rw"),
            hololens(),
            vec![":1:", "qx"],
        ),
    ];
    for (text, opts, needles) in cases {
        let e = parse_generic_csv("bad.csv", &text, &opts)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("bad.csv:"), "{e}");
        assert!(!e.contains('\n'), "{e}");
        for n in needles {
            assert!(e.contains(n), "`{n}` missing in: {e}");
        }
    }
    // A time going backwards outside the kept window is still an error.
    let mut o = hololens();
    o.window = TimeWindow {
        start: 10.0,
        end: f64::INFINITY,
    };
    let e = parse_generic_csv(
        "bad.csv",
        &with_line(3, "637231069485244910, 0, 1.6, 0, 0, 0, 0, 1"),
        &o,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains(":4:") && e.contains("earlier"), "{e}");
    // Field index beyond the row.
    let mut o = hololens();
    o.columns = Some(ColumnMap::indices(0, None, [4, 5, 6, 9]));
    let e = parse_generic_csv("bad.csv", &walk, &o)
        .unwrap_err()
        .to_string();
    assert!(e.contains("qw=9") && e.contains("8 fields"), "{e}");
    // Two quantities in one field.
    o.columns = Some("t=0,x=1,y=2,z=7,qx=4,qy=5,qz=6,qw=7".parse().unwrap());
    let e = parse_generic_csv("bad.csv", &walk, &o)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("bad.csv:1:") && e.contains("both `z` and `qw`"),
        "{e}"
    );
    // A headerless file whose first line has a damaged number: an error on
    // that line, not a silently skipped "header".
    let mut o = hololens();
    o.columns = Some(ColumnMap::indices(0, Some([1, 2, 3]), [4, 5, 6, 7]));
    let body: String = walk.lines().skip(1).map(|l| l.to_string() + "\n").collect();
    let damaged = body.replacen(", 0, 1.6,", ", 0x, 1.6,", 1);
    let e = parse_generic_csv("bad.csv", &damaged, &o)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("bad.csv:1:") && e.contains("`0x` is not a number"),
        "{e}"
    );
    assert_eq!(
        parse_generic_csv("ok.csv", &body, &o)
            .unwrap()
            .samples
            .len(),
        4
    );
}

// -- the command line -------------------------------------------------------

fn cli() -> std::process::Command {
    common::cli(120)
}

struct Run {
    ok: bool,
    stdout: String,
    stderr: String,
}

fn run_cli(args: &[&str]) -> Run {
    let o = cli().args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    assert_ne!(o.status.code(), Some(124), "{args:?} hung");
    assert!(!stderr.contains("panicked"), "{args:?} panicked:\n{stderr}");
    Run {
        ok: o.status.success(),
        stdout: String::from_utf8_lossy(&o.stdout).to_string(),
        stderr,
    }
}

/// Expects failure with exactly one `error:` line; returns it.
fn cli_error(args: &[&str]) -> String {
    let o = cli().args(args).output().unwrap();
    common::single_error_line(&o, &format!("{args:?}"))
}

#[test]
fn cli_converts_recordings_and_warns_on_a_backwards_walk() {
    let dir = tempdir("cli_convert");
    let input = dir.join("1.csv");
    std::fs::write(&input, unity_walk(2.0, 1.2, Vec3::Z, 0.0)).unwrap();
    let out = dir.join("out.csv");
    let (i, o) = (input.to_str().unwrap(), out.to_str().unwrap());
    let hololens = [
        "trace",
        "convert",
        i,
        "--out",
        o,
        "--format",
        "csv",
        "--time-unit",
        "ticks",
        "--handedness",
        "left",
        "--up",
        "y",
    ];
    let r = run_cli(&hololens);
    assert!(r.ok, "{}", r.stderr);
    assert!(!r.stderr.contains("warning"), "{}", r.stderr);
    assert!(
        r.stdout.contains("121 samples") && r.stdout.contains("left-handed, +y up, +z forward"),
        "{}",
        r.stdout
    );
    let tr = PoseTrace::read_csv(&out).unwrap();
    let walked = tr.samples[120].pose.position - tr.samples[0].pose.position;
    assert!(walked.dot(tr.samples[0].pose.forward()) > 2.3, "{walked}");
    // Naive: the same file as right-handed. Converted, with one warning line.
    let mut naive = hololens;
    naive[10] = "right";
    let r = run_cli(&naive);
    assert!(r.ok, "{}", r.stderr);
    let warnings: Vec<&str> = r
        .stderr
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .collect();
    assert_eq!(warnings.len(), 1, "{}", r.stderr);
    assert!(
        warnings[0].contains("backwards") && warnings[0].contains("--handedness left"),
        "{}",
        warnings[0]
    );
    // OpenXR and MMSys'17 through the same command.
    let xr = dir.join("xr.csv");
    std::fs::write(&xr, "time,position.x,position.y,position.z,orientation.x,orientation.y,orientation.z,orientation.w\n5,0,1.6,0,0,0,0,1\n11111116,0,1.6,-0.01,0,0,0,1\n").unwrap();
    let r = run_cli(&[
        "trace",
        "convert",
        xr.to_str().unwrap(),
        "--out",
        o,
        "--format",
        "openxr",
    ]);
    assert!(r.ok && r.stdout.contains("2 samples"), "{}", r.stderr);
    assert_eq!(PoseTrace::read_csv(&out).unwrap().samples[1].t, 0.011111111);
    let m17 = dir.join("video_0.txt");
    std::fs::write(&m17, "0.000000 0 1 0 0 0\n0.016667 1 1 0 0 0\n").unwrap();
    let r = run_cli(&[
        "trace",
        "convert",
        m17.to_str().unwrap(),
        "--out",
        o,
        "--format",
        "mmsys17",
    ]);
    assert!(r.ok && r.stdout.contains("2 samples"), "{}", r.stderr);
}

#[test]
fn cli_refuses_bad_recordings_and_flags_with_one_error_line() {
    let dir = tempdir("cli_bad");
    let bad = dir.join("unsorted.csv");
    let walk = unity_walk(0.05, 1.0, Vec3::Z, 0.0);
    let mut lines: Vec<&str> = walk.lines().collect();
    lines[3] = "637231069485244910, 0, 1.6, 0, 0, 0, 0, 1";
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    let good = dir.join("good.csv");
    std::fs::write(&good, &walk).unwrap();
    let out = dir.join("never.csv");
    let (b, g, o) = (
        bad.to_str().unwrap(),
        good.to_str().unwrap(),
        out.to_str().unwrap(),
    );
    let csv = [
        "--format",
        "csv",
        "--time-unit",
        "ticks",
        "--handedness",
        "left",
    ];
    let with = |input: &str, extra: &[&str]| {
        let mut v = vec!["trace", "convert", input, "--out", o];
        v.extend_from_slice(extra);
        v.into_iter().map(String::from).collect::<Vec<_>>()
    };
    for (args, needles) in [
        (with(b, &csv), vec!["unsorted.csv:4:", "earlier"]),
        (
            with(dir.join("missing.csv").to_str().unwrap(), &csv),
            vec!["missing.csv"],
        ),
        (
            with(g, &["--time-unit", "ticks"]),
            vec!["--format csv only"],
        ),
        (
            with(g, &["--format", "csv", "--time-unit", "ticks"]),
            vec!["--handedness"],
        ),
        (
            with(g, &["--format", "csv", "--handedness", "left"]),
            vec!["--time-unit"],
        ),
        (
            with(
                g,
                &[
                    "--format",
                    "csv",
                    "--time-unit",
                    "ticks",
                    "--handedness",
                    "left",
                    "--up",
                    "x",
                ],
            ),
            vec!["--forward"],
        ),
        (
            with(
                g,
                &[
                    "--format",
                    "csv",
                    "--time-unit",
                    "ticks",
                    "--handedness",
                    "left",
                    "--forward",
                    "-y",
                ],
            ),
            vec!["same axis"],
        ),
        (
            with(
                g,
                &[
                    "--format",
                    "csv",
                    "--time-unit",
                    "fortnights",
                    "--handedness",
                    "left",
                ],
            ),
            vec!["fortnights"],
        ),
        (
            with(
                g,
                &[
                    "--format",
                    "csv",
                    "--time-unit",
                    "ticks",
                    "--handedness",
                    "left",
                    "--columns",
                    "t=0,roll=1",
                ],
            ),
            vec!["unknown key `roll`"],
        ),
        (
            with(
                g,
                &[
                    "--format",
                    "csv",
                    "--time-unit",
                    "ticks",
                    "--handedness",
                    "left",
                    "--columns",
                    "t=time,qx=qx,qy=qy,qz=qz,qw=qw",
                ],
            ),
            vec!["good.csv:1:", "unknown column `time`"],
        ),
        (
            with(g, &["--format", "openxr"]),
            vec!["good.csv:1:", "unknown column `timestamp`"],
        ),
        (
            with(
                g,
                &csv.iter()
                    .copied()
                    .chain(["--start", "5", "--end", "1"])
                    .collect::<Vec<_>>(),
            ),
            vec!["--end"],
        ),
    ] {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let line = cli_error(&args);
        for n in needles {
            assert!(line.contains(n), "{args:?}: `{n}` missing in: {line}");
        }
        assert!(!out.exists(), "{args:?} left {o}");
    }
}

// -- no panic on arbitrary input --------------------------------------------

use proptest::prelude::*;

const IMPORT_TOKENS: &[&str] = &[
    "timestamp",
    "time",
    "x",
    "qw",
    "position.x",
    "orientation.w",
    "flags",
    ",",
    ",",
    ",",
    ";",
    " ",
    " ",
    "\t",
    "\n",
    "\n",
    "\r\n",
    "#",
    "0",
    "1",
    "-1",
    "0.5",
    "1e308",
    "1e39",
    "NaN",
    "inf",
    "-",
    ".",
    "e",
    "0x",
    "F",
    "637231069485244909",
    "9223372036854775807",
    "-9223372036854775808",
    "99999999999999999999",
    "\u{feff}",
    "é",
    "\"",
];

/// Imported traces are sorted, finite and unit; errors and warnings name
/// the file and are one line.
fn check_import(
    r: Result<PoseTrace, stereocache::camera::TraceError>,
) -> Result<(), TestCaseError> {
    match r {
        Err(e) => {
            let m = e.to_string();
            prop_assert!(m.starts_with("f.txt") && !m.contains('\n'), "{}", m);
        }
        Ok(tr) => {
            prop_assert!(!tr.samples.is_empty());
            for w in tr.samples.windows(2) {
                prop_assert!(w[1].t > w[0].t, "{:?}", w);
            }
            for s in &tr.samples {
                prop_assert!(s.t.is_finite() && s.pose.position.is_finite());
                prop_assert!((s.pose.orientation.length() - 1.0).abs() < 1e-3, "{:?}", s);
            }
            for w in tr.warnings.iter().chain(convention_warning(&tr).iter()) {
                prop_assert!(w.starts_with("f.txt") && !w.contains('\n'), "{}", w);
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn importers_never_panic(
        tokens in prop::collection::vec(prop::sample::select(IMPORT_TOKENS), 0..80),
        unit in prop::sample::select(vec![TimeUnit::Seconds, TimeUnit::Nanoseconds, TimeUnit::Ticks]),
    ) {
        let text = tokens.concat();
        check_import(parse_generic_csv("f.txt", &text, &CsvOptions::new(unit, AxisConvention::UNITY)))?;
        let mut by_index = CsvOptions::new(unit, AxisConvention::CORBILLON);
        by_index.columns = Some(ColumnMap::indices(0, Some([1, 2, 3]), [4, 5, 6, 7]));
        check_import(parse_generic_csv("f.txt", &text, &by_index))?;
        check_import(parse_openxr("f.txt", &text, TimeWindow::default()))?;
        check_import(parse_mmsys17("f.txt", &text, &Mmsys17Options::default()))?;
    }

    #[test]
    fn hololens_rows_with_a_field_replaced_never_panic(
        line in 1usize..8,
        field in 0usize..8,
        value in prop::sample::select(IMPORT_TOKENS),
    ) {
        let text = unity_walk(0.1, 1.0, Vec3::Z, 0.0);
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let mut fields: Vec<String> = lines[line].split(", ").map(String::from).collect();
        fields[field] = value.to_string();
        lines[line] = fields.join(", ");
        let text = lines.join("\n");
        check_import(parse_generic_csv("f.txt", &text, &hololens()))?;
    }
}

/// Fuzzing session: 20,001 repeated timestamps printed 20,001 warning lines;
/// they are one warning now (first line, count, last line), as non-unit
/// quaternions already were.
#[test]
fn repeated_timestamps_are_one_warning() {
    let mut text = String::from("t,px,py,pz,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n");
    for _ in 0..20_000 {
        text.push_str("0,0,0,0,0,0,0,1\n");
    }
    text.push_str("1,0,0,0,0,0,0,1\n");
    let tr = PoseTrace::parse_csv("dups.csv", &text).unwrap();
    assert_eq!(tr.samples.len(), 2);
    assert_eq!(
        tr.warnings.len(),
        1,
        "{:?}",
        &tr.warnings[..3.min(tr.warnings.len())]
    );
    let w = &tr.warnings[0];
    assert!(
        w.starts_with("dups.csv:3: duplicate timestamp 0 (same as line 2)")
            && w.contains("19999 more duplicate timestamp(s)")
            && w.contains("up to line 20002"),
        "{w}"
    );
}

/// An MMSys'18 file cut off mid-write (its last line short, no newline at
/// the end) was an error, while the README and the MMSys'17, OpenXR and
/// generic CSV importers drop that line with a warning; it is dropped now.
/// A short line elsewhere, or one followed by a newline, is still an error.
#[test]
fn mmsys18_truncated_final_line_is_dropped_with_a_warning() {
    let opts = Mmsys18Options::default();
    let head = "timestamp viewpoint w x y z\n10.0 0 1 0 0 0\n10.017 0 1 0 0 0\n";
    let tr = parse_mmsys18("cut.txt", &format!("{head}10.034 0 0.99"), &opts).unwrap();
    assert_eq!(tr.samples.len(), 2);
    assert!(
        tr.warnings
            .iter()
            .any(|w| w.starts_with("cut.txt:4: truncated final line (3 of 6 fields")),
        "{:?}",
        tr.warnings
    );
    let e = parse_mmsys18("cut.txt", &format!("{head}10.034 0 0.99\n"), &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("cut.txt:4: 3 fields, the header has 6"), "{e}");
    let e = parse_mmsys18(
        "cut.txt",
        &format!("{head}10.034 0 0.99\n10.05 0 1 0 0 0"),
        &opts,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("cut.txt:4:"), "{e}");
}

/// Only `ipd` may be left empty (the default IPD, as documented); an empty
/// `py` said "`` is not a number" and now says which fields may be empty.
#[test]
fn only_the_ipd_field_may_be_empty() {
    let ok = "t,px,py,pz,qx,qy,qz,qw,ipd\n0,0,0,0,0,0,0,1,\n1,0,0,0,0,0,0,1,0.06\n";
    let tr = PoseTrace::parse_csv("e.csv", ok).unwrap();
    assert_eq!(tr.samples[0].ipd, None);
    let bad = "t,px,py,pz,qx,qy,qz,qw,ipd\n0,0,,0,0,0,0,1,0.06\n";
    let e = PoseTrace::parse_csv("e.csv", bad).unwrap_err().to_string();
    assert!(
        e.contains("e.csv:2: column `py` (column 3): empty field; only `ipd` may be left empty"),
        "{e}"
    );
}

/// Head positions of 3e38 m (finite in f32) were accepted and rendered
/// black; the scene's ±1e15 m bound applies to traces too.
#[test]
fn far_away_head_positions_are_refused() {
    for (v, ok) in [
        ("3e38", false),
        ("1e20", false),
        ("-2e15", false),
        ("1e14", true),
    ] {
        let text = format!("t,px,py,pz,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n1,0,{v},0,0,0,0,1\n");
        let r = PoseTrace::parse_csv("far.csv", &text);
        match (r, ok) {
            (Ok(_), true) => {}
            (Err(e), false) => {
                let e = e.to_string();
                assert!(
                    e.starts_with("far.csv:3: column `py` (column 3): position")
                        && e.contains("out of range (|x| ≤ 1e15)"),
                    "{v}: {e}"
                );
            }
            (r, _) => panic!("{v}: {:?}", r.map(|t| t.samples.len())),
        }
    }
}

/// Times finite on their own whose difference from the first is not
/// (`1e308` after `-1e308`) are refused naming the recording and its line
/// (they were accepted, converted to `inf` and refused later, naming the
/// converted file; an audit's finding).
#[test]
fn a_time_out_of_range_after_the_first_is_refused_on_its_line() {
    let text = "t,x,y,z,qx,qy,qz,qw\n-1e308,0,0,0,0,0,0,1\n1e308,0,0,0,0,0,0,1\n";
    let err = parse_generic_csv(
        "f.txt",
        text,
        &CsvOptions::new(TimeUnit::Seconds, AxisConvention::GLTF),
    )
    .expect_err("an infinite relative time")
    .to_string();
    assert!(
        err.contains("f.txt:3") && err.contains("out of range"),
        "{err}"
    );
}
