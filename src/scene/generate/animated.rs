//! Built-in scenes that move (issue 16, the paper's appendix D and Fig. 19):
//!
//! - `cornell-moving`: the Cornell box with a tilted cone that spins about
//!   the vertical while it travels from the left wall to the right and back
//!   (Fig. 19: "the rotating cone stays too bright where its surface turns
//!   away from the sun" — here from the ceiling light), 4 s loop.
//! - `hairball-rotating`: the hairball turning once about the vertical in 8 s.
//! - `spin:NODE:SCENE` ([`spin_named_instances`]): any static scene with the
//!   instances of one named glTF node turning about the vertical through
//!   their node origin, e.g. Sponza with one animated instance
//!   (`spin:VaseRound.006:../shared/scenes/sponza`), for the animation benchmarks.
//!
//! The animation is ordinary glTF node animation (LINEAR translation and
//! rotation keys on the moving instance's node), so `scene generate` writes
//! it into the file and loading the file plays the same motion. One glTF
//! node per instance: `SceneAnimation::nodes[i]` is instance `i`'s node.

use super::{add_material, add_mesh, cornell::cornell, hairball::hairball};
use crate::scene::animation::{
    Animation, Channel, Interpolation, LocalRest, SceneAnimation, TrsPath,
};
use crate::scene::{Material, Mesh, Scene};
use glam::{Mat4, Quat, Vec2, Vec3, Vec4};

/// Loop period of `cornell-moving` (s).
pub const CONE_PERIOD: f32 = 4.0;
/// Loop period of `hairball-rotating` (s).
pub const HAIRBALL_PERIOD: f32 = 8.0;
/// Cone base radius and height (m).
pub const CONE_RADIUS: f32 = 0.12;
pub const CONE_HEIGHT: f32 = 0.3;
/// Tilt of the cone's axis away from the vertical.
pub const CONE_TILT_DEG: f32 = 30.0;

/// A cone along +Y: base disc of radius 1 at y = 0, apex at y = 1, smooth
/// side normals, `segments` around. Every face points outwards.
pub fn cone(name: &str, segments: u32) -> Mesh {
    let mut m = Mesh {
        name: name.into(),
        ..Default::default()
    };
    // Side: one ring at the base and one apex vertex per segment (the apex
    // normal differs per segment), normals ∝ (sin φ, r/h = 1, cos φ): the
    // cone's normal is constant along each ruling, so segment s's apex takes
    // the normal of its middle ruling, φ at s + ½ (until session 49 it took
    // φ_s, half a segment off: 3.75° at 48 segments).
    let normal = |u: f32| {
        let (sin, cos) = (u * std::f32::consts::TAU).sin_cos();
        Vec3::new(sin, 1.0, cos).normalize()
    };
    for s in 0..=segments {
        let u = s as f32 / segments as f32;
        let (sin, cos) = (u * std::f32::consts::TAU).sin_cos();
        m.positions.push(Vec3::new(sin, 0.0, cos));
        m.normals.push(normal(u));
        m.uvs.push(Vec2::new(u, 1.0));
        let mid = (s as f32 + 0.5) / segments as f32;
        m.positions.push(Vec3::Y);
        m.normals.push(normal(mid));
        m.uvs.push(Vec2::new(mid, 0.0));
    }
    for s in 0..segments {
        let a = 2 * s;
        m.indices.extend([a, a + 2, a + 1]);
    }
    // Base cap facing −Y.
    let centre = m.positions.len() as u32;
    m.positions.push(Vec3::ZERO);
    m.normals.push(Vec3::NEG_Y);
    m.uvs.push(Vec2::splat(0.5));
    for s in 0..=segments {
        let phi = s as f32 / segments as f32 * std::f32::consts::TAU;
        let (sin, cos) = phi.sin_cos();
        m.positions.push(Vec3::new(sin, 0.0, cos));
        m.normals.push(Vec3::NEG_Y);
        m.uvs.push(Vec2::new(0.5 + 0.5 * sin, 0.5 + 0.5 * cos));
    }
    for s in 0..segments {
        let a = centre + 1 + s;
        m.indices.extend([centre, a + 1, a]);
    }
    m
}

/// One node per instance, at rest as its import transform; `moving` get TRS
/// nodes (identity scale) so glTF may animate them.
fn flat_animation(scene: &Scene, animations: Vec<Animation>) -> SceneAnimation {
    let mut moved = vec![false; scene.instances.len()];
    for a in &animations {
        for c in &a.channels {
            moved[c.node] = true;
        }
    }
    let nodes = scene
        .instances
        .iter()
        .zip(&moved)
        .map(|(inst, &m)| {
            if m {
                let (scale, rotation, translation) = inst.transform.to_scale_rotation_translation();
                LocalRest::Trs {
                    translation,
                    rotation,
                    scale,
                }
            } else {
                LocalRest::Matrix(inst.transform)
            }
        })
        .collect();
    let mut a = SceneAnimation {
        nodes,
        instance_paths: (0..scene.instances.len() as u32).map(|i| vec![i]).collect(),
        instance_offsets: Vec::new(),
        animations,
        active: Vec::new(),
    };
    a.select(&Default::default())
        .expect("all animations can be selected");
    a
}

fn channel(node: usize, path: TrsPath, times: Vec<f32>, values: Vec<Vec4>) -> Channel {
    Channel::new(node, path, Interpolation::Linear, times, values)
        .expect("generated keys follow glTF's rules")
}

/// Quaternion keys of a full turn about `axis` (after a fixed `pre`
/// rotation) at `keys + 1` evenly spaced times over `period`; neighbours are
/// 360°/keys apart, so slerp turns the right way.
fn turn_keys(axis: Vec3, pre: Quat, keys: u32, period: f32) -> (Vec<f32>, Vec<Vec4>) {
    let times = (0..=keys)
        .map(|k| period * k as f32 / keys as f32)
        .collect();
    let values = (0..=keys)
        .map(|k| {
            let q =
                Quat::from_axis_angle(axis, std::f32::consts::TAU * k as f32 / keys as f32) * pre;
            Vec4::from(q)
        })
        .collect();
    (times, values)
}

/// `cornell-moving`: the Cornell box and a spinning, travelling cone.
pub fn cornell_moving() -> Scene {
    let mut s = cornell();
    s.source = "generated:cornell-moving".into();
    let orange = add_material(&mut s, Material::diffuse("cone", Vec3::new(0.8, 0.45, 0.1)));
    let rest = Mat4::from_scale_rotation_translation(
        Vec3::new(CONE_RADIUS, CONE_HEIGHT, CONE_RADIUS),
        Quat::IDENTITY,
        Vec3::new(-0.3, 0.45, 0.0),
    );
    add_mesh(&mut s, cone("cone", 48), orange, rest);
    let node = s.instances.len() - 1;
    // Left → right → left at mid height, in front of the spheres.
    let p = |x: f32| Vec4::new(x, 0.45, 0.0, 0.0);
    let translation = channel(
        node,
        TrsPath::Translation,
        vec![0.0, CONE_PERIOD / 2.0, CONE_PERIOD],
        vec![p(-0.3), p(0.3), p(-0.3)],
    );
    let (times, values) = turn_keys(
        Vec3::Y,
        Quat::from_rotation_z(CONE_TILT_DEG.to_radians()),
        8,
        CONE_PERIOD,
    );
    let rotation = channel(node, TrsPath::Rotation, times, values);
    let animation = flat_animation(
        &s,
        vec![Animation {
            name: "cone".into(),
            channels: vec![translation, rotation],
        }],
    );
    s.animation = Some(animation);
    // The rest transform is the pose at t = 0 (what a static viewer sees).
    s.instances[node].transform = s.instance_transforms_at(0.0)[node];
    s
}

/// Loop period of a `spin:NODE:SCENE` turn (s).
pub const SPIN_PERIOD: f32 = 4.0;

/// Makes the instances of glTF node `node` (every primitive of it) turn once
/// every [`SPIN_PERIOD`] about the world vertical through their node origin,
/// starting from their rest pose (t = 0 is the static scene exactly). An
/// error, naming the scene, when the scene already animates or has no
/// instance of that name.
pub fn spin_named_instances(s: &mut Scene, node: &str) -> Result<(), String> {
    if s.animation.is_some() {
        return Err(
            "the scene has animations of its own; spin: adds one only to a static scene".into(),
        );
    }
    let picked: Vec<usize> = (0..s.instances.len())
        .filter(|&i| s.instances[i].name == node)
        .collect();
    if picked.is_empty() {
        let mut names: Vec<&str> = s.instances.iter().map(|i| i.name.as_str()).collect();
        names.sort_unstable();
        names.dedup();
        let shown = names
            .iter()
            .take(12)
            .copied()
            .collect::<Vec<_>>()
            .join(", ");
        let more = names.len().saturating_sub(12);
        return Err(format!(
            "no instance of a node named '{node}'; the scene's nodes: {shown}{}",
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        ));
    }
    // The turn is a rotation channel over the node's T·R·S: a transform
    // with shear (a non-uniform scale under a rotated parent) has no exact
    // T·R·S, and its decomposition would draw it distorted from frame 0 on.
    for &i in &picked {
        let m = s.instances[i].transform;
        let (sc, r, t) = m.to_scale_rotation_translation();
        let back = glam::Mat4::from_scale_rotation_translation(sc, r, t);
        let size = m.to_cols_array().iter().fold(1.0f32, |a, v| a.max(v.abs()));
        let off = (back - m)
            .to_cols_array()
            .iter()
            .fold(0.0f32, |a, v| a.max(v.abs()));
        if off.is_nan() || off > 1e-4 * size {
            return Err(format!(
                "node '{node}' has a sheared transform (a non-uniform scale under a rotated parent: no translation·rotation·scale form), which spin: cannot turn"
            ));
        }
    }
    let channels = picked
        .iter()
        .map(|&i| {
            let (_, rest, _) = s.instances[i].transform.to_scale_rotation_translation();
            let (times, values) = turn_keys(Vec3::Y, rest, 8, SPIN_PERIOD);
            channel(i, TrsPath::Rotation, times, values)
        })
        .collect();
    s.animation = Some(flat_animation(
        s,
        vec![Animation {
            name: format!("spin {node}"),
            channels,
        }],
    ));
    // The rest transforms become the pose at t = 0 (what a static viewer sees).
    let posed = s.instance_transforms_at(0.0);
    for &i in &picked {
        s.instances[i].transform = posed[i];
    }
    Ok(())
}

/// `hairball-rotating`: the hairball turning about the vertical.
pub fn hairball_rotating() -> Scene {
    let mut s = hairball();
    s.source = "generated:hairball-rotating".into();
    let (times, values) = turn_keys(Vec3::Y, Quat::IDENTITY, 8, HAIRBALL_PERIOD);
    let rotation = channel(0, TrsPath::Rotation, times, values);
    s.animation = Some(flat_animation(
        &s,
        vec![Animation {
            name: "spin".into(),
            channels: vec![rotation],
        }],
    ));
    s
}
