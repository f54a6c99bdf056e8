//! glTF animation sampling (src/scene/animation.rs) against hand-computed
//! values, and the import of tests/data/animation/animated.gltf against a
//! CPU evaluation of the same node tree. CPU only, fast.
//!
//! Tolerances: every expected value is a short f32 expression of exactly
//! representable inputs, so results agree to a few ulps; 1e-6 absolute on
//! values of magnitude ≤ 5 is ~10 ulps (slerp goes through acos/sin, whose
//! f32 error is ≤ 1 ulp each, times a handful of operations).

use glam::{Mat4, Quat, Vec3, Vec4};
use std::path::PathBuf;
use stereocache::scene::animation::{
    slerp, Animation, Channel, ChannelError, Interpolation, TrsPath,
};
use stereocache::scene::{load_gltf, AnimationSelection};

const EPS: f32 = 1e-6;

fn data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(rel)
}

fn close(a: Vec4, b: Vec4, what: &str) {
    assert!(
        (a - b).abs().max_element() <= EPS,
        "{what}: got {a}, expected {b}"
    );
}

fn v3(x: f32, y: f32, z: f32) -> Vec4 {
    Vec4::new(x, y, z, 0.0)
}

/// Quaternion (x, y, z, w) of `deg` degrees about `axis`.
fn rot(axis: Vec3, deg: f32) -> Vec4 {
    Vec4::from(Quat::from_axis_angle(axis, deg.to_radians()))
}

#[test]
fn step_holds_each_key_until_the_next() {
    let c = Channel::new(
        0,
        TrsPath::Translation,
        Interpolation::Step,
        vec![0.0, 1.0, 2.0],
        vec![v3(1.0, 0.0, 0.0), v3(2.0, 0.0, 0.0), v3(3.0, 0.0, 0.0)],
    )
    .unwrap();
    for (t, x) in [
        (-1.0, 1.0),
        (0.0, 1.0),
        (0.5, 1.0),
        (0.999, 1.0),
        (1.0, 2.0),
        (1.99, 2.0),
        (2.0, 3.0),
        (7.0, 3.0),
    ] {
        assert_eq!(c.sample(t), v3(x, 0.0, 0.0), "t = {t}");
    }
}

#[test]
fn linear_translation_and_scale_interpolate_between_keys() {
    let c = Channel::new(
        0,
        TrsPath::Scale,
        Interpolation::Linear,
        vec![1.0, 3.0],
        vec![v3(0.0, 0.0, 0.0), v3(2.0, 4.0, -6.0)],
    )
    .unwrap();
    close(c.sample(0.0), v3(0.0, 0.0, 0.0), "before the first key");
    close(c.sample(1.5), v3(0.5, 1.0, -1.5), "a quarter");
    close(c.sample(2.0), v3(1.0, 2.0, -3.0), "half");
    close(c.sample(3.0), v3(2.0, 4.0, -6.0), "last key");
    close(c.sample(4.0), v3(2.0, 4.0, -6.0), "after the last key");
}

#[test]
fn linear_rotation_is_slerp_along_the_shorter_arc() {
    let y = Vec3::Y;
    // 0° → 90° about +Y: s = 1/2 is 45°, s = 1/3 is 30° (a lerp would not be).
    let c = Channel::new(
        0,
        TrsPath::Rotation,
        Interpolation::Linear,
        vec![0.0, 3.0],
        vec![Vec4::W, rot(y, 90.0)],
    )
    .unwrap();
    close(c.sample(1.5), rot(y, 45.0), "half way");
    close(c.sample(1.0), rot(y, 30.0), "a third");
    close(c.sample(2.0), rot(y, 60.0), "two thirds");
    // The same end orientation written as −q: the shorter arc is taken.
    close(
        slerp(Vec4::W, -rot(y, 90.0), 0.5),
        rot(y, 45.0),
        "negated end",
    );
    // 0° → 180° about +Z written exactly as (0, 0, 1, 0) (dot = 0; f32
    // cos 90° would make it −4e-8 and flip the arc): half way is 90°.
    close(
        slerp(Vec4::W, Vec4::Z, 0.5),
        rot(Vec3::Z, 90.0),
        "half turn",
    );
    // 10° → 10.01° (dot > 0.9995, the normalized-lerp branch): 10.005°.
    close(
        slerp(rot(y, 10.0), rot(y, 10.01), 0.5),
        rot(y, 10.005),
        "nearly parallel",
    );
}

#[test]
fn cubic_spline_scales_tangents_by_the_key_interval() {
    // Keys at 0 and 2 (td = 2): v0 = (1,0,0), out-tangent b0 = (1,0,0),
    // in-tangent a1 = (0,1,0), v1 = (3,0,0). Hermite basis at s:
    //   s = 1/2: h00 = 1/2, h10 = 1/8, h01 = 1/2, h11 = −1/8
    //     x = 1/2·1 + 2·1/8·1 + 1/2·3 = 2.25, y = 2·(−1/8)·1 = −0.25
    //   s = 1/4: h00 = 27/32, h10 = 9/64, h01 = 5/32, h11 = −3/64
    //     x = 27/32 + 2·9/64 + 3·5/32 = 1.59375, y = 2·(−3/64) = −0.09375
    // (Unscaled tangents would give x = 2.125 and y = −0.125 at s = 1/2.)
    let c = Channel::new(
        0,
        TrsPath::Translation,
        Interpolation::CubicSpline,
        vec![0.0, 2.0],
        vec![
            v3(9.0, 9.0, 9.0), // a0: unused (before the first key)
            v3(1.0, 0.0, 0.0), // v0
            v3(1.0, 0.0, 0.0), // b0
            v3(0.0, 1.0, 0.0), // a1
            v3(3.0, 0.0, 0.0), // v1
            v3(9.0, 9.0, 9.0), // b1: unused (after the last key)
        ],
    )
    .unwrap();
    close(c.sample(1.0), v3(2.25, -0.25, 0.0), "s = 1/2");
    close(c.sample(0.5), v3(1.59375, -0.09375, 0.0), "s = 1/4");
    assert_eq!(c.sample(0.0), v3(1.0, 0.0, 0.0), "first key");
    assert_eq!(c.sample(2.0), v3(3.0, 0.0, 0.0), "last key");
}

#[test]
fn cubic_spline_rotation_comes_back_normalized() {
    // Zero tangents: p(s) = h00 q0 + h01 q1, then normalized. At s = 1/2 the
    // weights are equal, so the result is normalize(q0 + q1) = 45° about Z.
    let c = Channel::new(
        0,
        TrsPath::Rotation,
        Interpolation::CubicSpline,
        vec![0.0, 1.0],
        vec![
            Vec4::ZERO,
            Vec4::W,
            Vec4::ZERO,
            Vec4::ZERO,
            rot(Vec3::Z, 90.0),
            Vec4::ZERO,
        ],
    )
    .unwrap();
    close(c.sample(0.5), rot(Vec3::Z, 45.0), "s = 1/2");
}

#[test]
fn animations_loop_over_their_duration() {
    let c = Channel::new(
        0,
        TrsPath::Translation,
        Interpolation::Linear,
        vec![0.0, 2.0],
        vec![v3(0.0, 0.0, 0.0), v3(2.0, 0.0, 0.0)],
    )
    .unwrap();
    let a = Animation {
        name: "a".into(),
        channels: vec![c],
    };
    assert_eq!(a.duration(), 2.0);
    assert_eq!(a.local_time(5.0), 1.0);
    assert_eq!(a.local_time(1.5), 1.5);
    assert_eq!(a.local_time(4.0), 0.0);
    // Just below a multiple of the period (f64 frame times): it stays in
    // [0, duration) when rounded to f32, at the f32 just below 2.
    assert_eq!(
        a.local_time(4.0 - 1e-12),
        f32::from_bits(2.0f32.to_bits() - 1)
    );
}

#[test]
fn malformed_channels_are_refused() {
    let ch = |interp, times: Vec<f32>, n: usize| {
        Channel::new(0, TrsPath::Translation, interp, times, vec![Vec4::ZERO; n]).map(|_| ())
    };
    use Interpolation::*;
    assert_eq!(ch(Linear, vec![], 0), Err(ChannelError::NoKeys));
    assert_eq!(
        ch(Linear, vec![0.0, 1.0, 1.0], 3),
        Err(ChannelError::NotIncreasing(2))
    );
    assert_eq!(
        ch(Linear, vec![0.0, f32::NAN], 2),
        Err(ChannelError::TimeNotFinite(1))
    );
    assert_eq!(
        ch(Step, vec![-1.0, 1.0], 2),
        Err(ChannelError::TimeNegative(0))
    );
    assert_eq!(
        ch(Linear, vec![0.0, 1.0], 3),
        Err(ChannelError::CountMismatch {
            keys: 2,
            values: 3,
            expected: 2
        })
    );
    assert_eq!(
        ch(CubicSpline, vec![0.0, 1.0], 2),
        Err(ChannelError::CountMismatch {
            keys: 2,
            values: 2,
            expected: 6
        })
    );
    assert_eq!(
        ch(CubicSpline, vec![0.0], 3),
        Err(ChannelError::CubicNeedsTwoKeys)
    );
    let nan_value = Channel::new(
        0,
        TrsPath::Scale,
        Interpolation::Step,
        vec![0.0],
        vec![Vec4::new(1.0, f32::NAN, 1.0, 0.0)],
    );
    assert_eq!(nan_value.map(|_| ()), Err(ChannelError::ValueNotFinite(0)));
}

/// animated.gltf (tests/data/animation/make.py): node "carrier" (animation
/// "slide": translation LINEAR (0,0,0) → (1,0,0) → (1,2,0) at t = 0, 1, 2 and
/// rotation LINEAR 0° → 90° about Z at t = 0, 2) holds "moving" (mesh,
/// translation (0,0,−5)); "hopper" (mesh, rest translation (3,0,0)) is
/// driven by "hop": STEP (3,0,0) → (3,1,0) at t = 0, 1.
#[test]
fn imported_animation_poses_instances_as_the_node_tree_says() {
    let mut s = load_gltf(&data("animation/animated.gltf")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(s.is_animated());
    let names: Vec<&str> = s.instances.iter().map(|i| i.name.as_str()).collect();
    assert_eq!(names, ["moving", "hopper"]);
    let child = Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0));
    let expect_moving = |t: Vec3, deg: f32| {
        Mat4::from_translation(t) * Mat4::from_quat(Quat::from_rotation_z(deg.to_radians())) * child
    };
    let check = |got: Mat4, want: Mat4, what: &str| {
        let d = (got - want)
            .to_cols_array()
            .iter()
            .fold(0f32, |m, x| m.max(x.abs()));
        // Entries ≤ 5 in magnitude: 1e-6 relative to that is ~20 ulps.
        assert!(d <= 5.0 * EPS, "{what}: {got} vs {want}");
    };
    for (t, tr, deg, hop) in [
        (0.0, Vec3::ZERO, 0.0, 0.0),
        (0.5, Vec3::new(0.5, 0.0, 0.0), 22.5, 0.0),
        (1.5, Vec3::new(1.0, 1.0, 0.0), 67.5, 0.0), // hop wraps: local 0.5
        (2.5, Vec3::new(0.5, 0.0, 0.0), 22.5, 0.0), // slide wraps: local 0.5
        (1.0, Vec3::new(1.0, 0.0, 0.0), 45.0, 0.0), // hop wraps to local 0
        (0.99, Vec3::new(0.99, 0.0, 0.0), 44.55, 0.0),
    ] {
        let m = s.instance_transforms_at(t);
        check(m[0], expect_moving(tr, deg), &format!("moving at t = {t}"));
        check(
            m[1],
            Mat4::from_translation(Vec3::new(3.0, hop, 0.0)),
            &format!("hopper at t = {t}"),
        );
    }
    // Only "hop": the carrier's instance keeps its import transform bit for bit.
    let a = s.animation.as_mut().unwrap();
    a.select(&"hop".parse().unwrap()).unwrap();
    let rest = s.instances[0].transform;
    let m = s.instance_transforms_at(0.5);
    assert_eq!(m[0], rest);
    // By index: 0 = "slide"; "hopper" then rests at its node's translation.
    let a = s.animation.as_mut().unwrap();
    a.select(&AnimationSelection::Index(0)).unwrap();
    let m = s.instance_transforms_at(0.5);
    assert_eq!(m[1], s.instances[1].transform);
    check(
        m[0],
        expect_moving(Vec3::new(0.5, 0.0, 0.0), 22.5),
        "slide only",
    );
    let a = s.animation.as_mut().unwrap();
    let e = a.select(&"jump".parse().unwrap()).unwrap_err();
    assert!(
        e.contains("'jump'") && e.contains("0 'slide'") && e.contains("1 'hop'"),
        "{e}"
    );
    assert!(a.select(&AnimationSelection::Index(2)).is_err());
}

#[test]
fn a_90_hz_and_a_45_hz_replay_see_the_same_motion() {
    let s = load_gltf(&data("animation/animated.gltf")).unwrap();
    for k in 0..90u32 {
        let t90 = (f64::from(2 * k) / 90.0) as f32;
        let t45 = (f64::from(k) / 45.0) as f32;
        assert_eq!(s.instance_transforms_at(t90), s.instance_transforms_at(t45));
    }
}

/// Frame times hours into a replay keep their precision: the loop is taken
/// in f64 before the time becomes f32 (an f32 frame time is quantized to
/// 2⁻¹⁰ s at 10⁴ s, a tenth of a 90 Hz frame). `cornell-moving`'s cone
/// slides LINEAR −0.3 → 0.3 → −0.3 m along x at t = 0, 2, 4 s (looping), so
/// its node origin is at x(u) = −0.3 + 0.3·u for u = t mod 4 ≤ 2 and
/// 0.3 − 0.3·(u − 2) after, computed here in f64. Tolerance: the local time
/// rounded to f32 (≤ 2.4e-7 s below 4 s) times the 0.3 m/s slope, plus a few
/// f32 ulps of the lerp at |x| ≤ 0.3 (3e-8 m each): 1e-6 m. The motion over
/// one frame (what `prev_object_to_world` gives the motion vectors) is
/// 0.3/90 m in magnitude; the old f32 frame time was off by up to 1.5e-4 m.
#[test]
fn frame_times_hours_into_a_replay_keep_their_precision() {
    let s = stereocache::scene::load_scene("cornell-moving").unwrap();
    let moves = s.instance_moves();
    let cone = moves.iter().position(|&m| m).unwrap();
    assert_eq!(moves.iter().filter(|&&m| m).count(), 1);
    let x_at = |t: f64| {
        let u = t.rem_euclid(4.0);
        if u <= 2.0 {
            -0.3 + 0.3 * u
        } else {
            0.3 - 0.3 * (u - 2.0)
        }
    };
    let fps = 90.0;
    let mut prev: Option<f32> = None;
    for i in 900_000u32..=900_000 + 2 * 90 {
        let t = f64::from(i) / fps;
        let x = s.instance_transforms_at(t)[cone].w_axis.x;
        let want = x_at(t);
        assert!(
            (f64::from(x) - want).abs() <= 1e-6,
            "frame {i} (t = {t} s): cone at x = {x}, expected {want}"
        );
        if let Some(p) = prev {
            let step = f64::from(x - p).abs();
            assert!(
                (step - 0.3 / fps).abs() <= 2e-6,
                "frame {i}: moved {step} m over one frame, expected {}",
                0.3 / fps
            );
        }
        prev = Some(x);
    }
}

/// Lights and cameras stay at their rest pose (only mesh instances are
/// re-posed): an animation that moves a node carrying one — itself or
/// through a child — is named in one warning (until session 50 the light
/// stood still silently). `animated.gltf` with a point light on "moving",
/// the child of the animated "carrier": a warning naming "slide" only.
#[test]
fn animations_moving_a_light_say_it_stays_at_rest() {
    let src = std::fs::read_to_string(data("animation/animated.gltf")).unwrap();
    let mut j: serde_json::Value = serde_json::from_str(&src).unwrap();
    j["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
    j["extensions"] = serde_json::json!({ "KHR_lights_punctual": { "lights": [
        { "type": "point", "intensity": 1.0 } ] } });
    j["nodes"][1]["extensions"] = serde_json::json!({ "KHR_lights_punctual": { "light": 0 } });
    let p = std::env::temp_dir().join(format!(
        "stereocache-animated-light-{}.gltf",
        std::process::id()
    ));
    std::fs::write(&p, j.to_string()).unwrap();
    let s = load_gltf(&p);
    let _ = std::fs::remove_file(&p);
    let s = s.unwrap();
    let w: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("carries a light or camera"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", s.warnings);
    assert!(
        w[0].contains("'slide'") && w[0].contains("rest pose"),
        "{}",
        w[0]
    );
}

fn expect_error(name: &str, phrases: &[&str]) {
    let e = match load_gltf(&data(&format!("bad_scenes/{name}"))) {
        Ok(_) => panic!("{name}: loaded, expected an error"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains(name),
        "{name}: message does not name the file: {e}"
    );
    for p in phrases {
        assert!(e.contains(p), "{name}: expected '{p}' in: {e}");
    }
    assert!(!e.contains('\n'), "{name}: message should be one line: {e}");
}

#[test]
fn malformed_animation_files_are_one_line_errors_naming_animation_and_channel() {
    let at = "animation 'slide' channel 0";
    expect_error("anim_not_increasing.gltf", &[at, "not strictly increasing"]);
    expect_error("anim_count_mismatch.gltf", &[at, "2 values for 3 keys"]);
    expect_error(
        "anim_unknown_path.gltf",
        &[at, "unknown target path 'colour'"],
    );
    expect_error("anim_nan_key.gltf", &[at, "not finite"]);
}

/// `spin:NODE:SCENE`: the named node's instances turn about the world
/// vertical through their node origin, one turn in 4 s (8 LINEAR keys, so a
/// key time is an exact quaternion); every other instance keeps its rest
/// transform bit for bit, and t = 0 is the static scene.
#[test]
fn spin_turns_the_named_instances_about_the_vertical_through_their_origin() {
    use stereocache::scene::load_scene;
    let rest = load_scene("cornell").unwrap();
    let s = load_scene("spin:glass sphere:cornell").unwrap();
    assert!(s.is_animated());
    let moves = s.instance_moves();
    let picked: Vec<usize> = (0..rest.instances.len())
        .filter(|&i| rest.instances[i].name == "glass sphere")
        .collect();
    assert_eq!(picked.len(), 1);
    for (i, m) in moves.iter().enumerate() {
        assert_eq!(*m, picked.contains(&i), "instance {i} moves: {m}");
    }
    let at0 = s.instance_transforms_at(0.0);
    // A quarter turn (key 2 of 8) and three eighths (key 3): exact keys.
    for (t, deg) in [(1.0f32, 90.0f32), (1.5, 135.0), (4.0, 0.0)] {
        let at = s.instance_transforms_at(t);
        for i in 0..rest.instances.len() {
            let r = rest.instances[i].transform;
            if picked.contains(&i) {
                // Node origin stays; the object turns about +Y through it.
                let o = r.w_axis.truncate();
                let expect = Mat4::from_translation(o)
                    * Mat4::from_rotation_y(deg.to_radians())
                    * Mat4::from_translation(-o)
                    * r;
                for c in 0..4 {
                    close(at[i].col(c), expect.col(c), &format!("t = {t}, column {c}"));
                }
                for c in 0..4 {
                    close(at0[i].col(c), r.col(c), "rest pose");
                }
            } else {
                assert_eq!(at[i], r, "instance {i} (static) at t = {t}");
            }
        }
    }
    // Errors name the spec and the problem, on one line.
    for (spec, phrase) in [
        (
            "spin:no such node:cornell",
            "no instance of a node named 'no such node'",
        ),
        ("spin:cone:cornell-moving", "animations of its own"),
        ("spin:cornell", "expected spin:NODE:SCENE"),
    ] {
        let e = match load_scene(spec) {
            Ok(_) => panic!("{spec}: loaded, expected an error"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(spec) && e.contains(phrase), "{spec}: {e}");
        assert!(!e.contains('\n'), "{spec}: {e}");
    }
    // The unknown-node error lists the scene's node names.
    let e = load_scene("spin:x:cornell").err().unwrap().to_string();
    assert!(
        e.contains("glass sphere") && e.contains("metal sphere"),
        "{e}"
    );
    // A sheared node (a non-uniform scale under a rotated parent) has no
    // T·R·S form to turn: refused, where its decomposition used to draw it
    // distorted from t = 0 on (R_z(45°)·diag(2, 1, 1)·R_z(45°)ᵀ: its
    // normalised columns are 0.6 from orthogonal).
    let mut sheared = rest.clone();
    let r = Mat4::from_rotation_z(45f32.to_radians());
    let i = picked[0];
    sheared.instances[i].transform = Mat4::from_translation(Vec3::new(0.1, 0.2, 0.3))
        * r
        * Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0))
        * r.transpose();
    let e =
        stereocache::scene::generate::animated::spin_named_instances(&mut sheared, "glass sphere")
            .unwrap_err();
    assert!(e.contains("sheared transform"), "{e}");
    assert!(sheared.animation.is_none());
}
