//! glTF 2.0 node animation (glTF spec §3.11 "Animations", appendix C
//! "Interpolation"): translation / rotation / scale channels sampled with
//! STEP, LINEAR (quaternions: slerp) or CUBICSPLINE (Hermite, tangents scaled
//! by the key interval), evaluated at a time `t` in seconds.
//!
//! Time is the replay's frame time (frame index / fps), so a 90 Hz and a
//! 45 Hz replay see the same motion at the same instants. It stays f64 until
//! it has been wrapped into the animation's loop ([`Animation::local_time`]):
//! an f32 frame time is quantized to 2⁻¹⁰ s ≈ 1 ms at 10⁴ s (a 90 Hz replay
//! of 2.8 h), a tenth of a frame, which jittered the motion and the
//! previous-frame transforms of the motion vectors by as much. Every selected
//! animation loops over its own duration (its last key time); before an
//! animation's first key the first value holds (spec: clamp). Where two
//! selected animations drive the same node property, the later one wins.
//!
//! Unsupported, with one warning naming the animation (import side,
//! `gltf_import`): morph-target weight channels (ignored) and channels that
//! drive skin joints (skinned meshes stay in their bind pose; rigid children
//! of joints do move). Lights and cameras under animated nodes stay where
//! they are at rest.
//!
//! The node hierarchy is kept as one node path per instance (root … node),
//! so an instance's world transform at `t` is the product of its path's local
//! transforms. Instances whose path holds no animated node keep their import
//! transform bit for bit.

use glam::{Mat4, Quat, Vec3, Vec4};

/// glTF `sampler.interpolation`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Step,
    Linear,
    CubicSpline,
}

/// glTF `channel.target.path` (the TRS ones; weights are refused at import).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrsPath {
    Translation,
    Rotation,
    Scale,
}

impl TrsPath {
    pub fn name(self) -> &'static str {
        match self {
            TrsPath::Translation => "translation",
            TrsPath::Rotation => "rotation",
            TrsPath::Scale => "scale",
        }
    }
}

/// One animated node property: key times and values (xyz, or a quaternion
/// as x, y, z, w). CUBICSPLINE stores three values per key: in-tangent a_k,
/// value v_k, out-tangent b_k (glTF's order).
#[derive(Clone, Debug)]
pub struct Channel {
    pub node: usize,
    pub path: TrsPath,
    pub interpolation: Interpolation,
    pub times: Vec<f32>,
    pub values: Vec<Vec4>,
}

/// Why a channel's data cannot be used; `Display` is the message after
/// "animation 'x' channel k: ".
#[derive(Clone, Debug, PartialEq)]
pub enum ChannelError {
    NoKeys,
    TimeNotFinite(usize),
    TimeNegative(usize),
    NotIncreasing(usize),
    CountMismatch {
        keys: usize,
        values: usize,
        expected: usize,
    },
    CubicNeedsTwoKeys,
    ValueNotFinite(usize),
}

impl std::fmt::Display for ChannelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ChannelError::NoKeys => write!(f, "sampler input has no keys"),
            ChannelError::TimeNotFinite(k) => write!(f, "sampler input key {k} is not finite"),
            ChannelError::TimeNegative(k) => write!(f, "sampler input key {k} is negative"),
            ChannelError::NotIncreasing(k) => write!(
                f,
                "sampler input is not strictly increasing (key {k} <= key {})",
                k - 1
            ),
            ChannelError::CountMismatch {
                keys,
                values,
                expected,
            } => write!(
                f,
                "sampler output has {values} values for {keys} keys (expected {expected})"
            ),
            ChannelError::CubicNeedsTwoKeys => {
                write!(f, "a CUBICSPLINE sampler needs at least 2 keys")
            }
            ChannelError::ValueNotFinite(k) => write!(f, "sampler output value {k} is not finite"),
        }
    }
}

impl Channel {
    /// Checks the data against glTF's rules: times finite, ≥ 0 and strictly
    /// increasing; as many values as keys (three per key for CUBICSPLINE,
    /// which needs two keys); values finite.
    pub fn new(
        node: usize,
        path: TrsPath,
        interpolation: Interpolation,
        times: Vec<f32>,
        values: Vec<Vec4>,
    ) -> Result<Channel, ChannelError> {
        if times.is_empty() {
            return Err(ChannelError::NoKeys);
        }
        for (k, &t) in times.iter().enumerate() {
            if !t.is_finite() {
                return Err(ChannelError::TimeNotFinite(k));
            }
            if t < 0.0 {
                return Err(ChannelError::TimeNegative(k));
            }
            if k > 0 && t <= times[k - 1] {
                return Err(ChannelError::NotIncreasing(k));
            }
        }
        let per_key = if interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        if values.len() != per_key * times.len() {
            return Err(ChannelError::CountMismatch {
                keys: times.len(),
                values: values.len(),
                expected: per_key * times.len(),
            });
        }
        if interpolation == Interpolation::CubicSpline && times.len() < 2 {
            return Err(ChannelError::CubicNeedsTwoKeys);
        }
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(ChannelError::ValueNotFinite(k));
        }
        Ok(Channel {
            node,
            path,
            interpolation,
            times,
            values,
        })
    }

    /// Time of the last key.
    pub fn end(&self) -> f32 {
        *self.times.last().unwrap_or(&0.0)
    }

    /// The key's value (the middle of a CUBICSPLINE triple).
    fn value(&self, k: usize) -> Vec4 {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        }
    }

    /// The property at time `t` (seconds, not wrapped here). Rotations come
    /// back normalized.
    pub fn sample(&self, t: f32) -> Vec4 {
        let n = self.times.len();
        // Key k with times[k] <= t < times[k + 1]; clamped outside the keys.
        let next = self.times.partition_point(|&x| x <= t);
        let v = if next == 0 {
            self.value(0)
        } else if next == n {
            self.value(n - 1)
        } else {
            let k = next - 1;
            let (t0, t1) = (self.times[k], self.times[k + 1]);
            let td = t1 - t0;
            let s = (t - t0) / td;
            match self.interpolation {
                Interpolation::Step => self.value(k),
                Interpolation::Linear if self.path == TrsPath::Rotation => {
                    slerp(self.values[k], self.values[k + 1], s)
                }
                Interpolation::Linear => self.values[k].lerp(self.values[k + 1], s),
                Interpolation::CubicSpline => {
                    // glTF appendix C: p(s) = (2s³ − 3s² + 1) v_k + td (s³ − 2s² + s) b_k
                    //   + (−2s³ + 3s²) v_{k+1} + td (s³ − s²) a_{k+1}, td = t_{k+1} − t_k.
                    let (s2, s3) = (s * s, s * s * s);
                    let vk = self.values[3 * k + 1];
                    let bk = self.values[3 * k + 2];
                    let ak1 = self.values[3 * (k + 1)];
                    let vk1 = self.values[3 * (k + 1) + 1];
                    vk * (2.0 * s3 - 3.0 * s2 + 1.0)
                        + bk * (td * (s3 - 2.0 * s2 + s))
                        + vk1 * (-2.0 * s3 + 3.0 * s2)
                        + ak1 * (td * (s3 - s2))
                }
            }
        };
        if self.path == TrsPath::Rotation {
            v.normalize_or(Vec4::W)
        } else {
            v
        }
    }
}

/// Spherical linear interpolation of unit quaternions (x, y, z, w) along the
/// shorter arc (glTF appendix C: negate `b` when the dot product is negative).
pub fn slerp(a: Vec4, b: Vec4, s: f32) -> Vec4 {
    let mut d = a.dot(b);
    let b = if d < 0.0 {
        d = -d;
        -b
    } else {
        b
    };
    if d > 0.9995 {
        // Nearly parallel: sin θ → 0, so the normalized lerp instead; at
        // this cut-off (θ ≤ 0.0316) it departs from slerp by at most
        // 5·10⁻⁷ rad of quaternion angle (10⁻⁶ rad of rotation, a few f32
        // ulps; an audit's computation).
        return a.lerp(b, s).normalize_or(Vec4::W);
    }
    let theta = d.clamp(-1.0, 1.0).acos();
    let sin = theta.sin();
    a * (((1.0 - s) * theta).sin() / sin) + b * ((s * theta).sin() / sin)
}

/// One glTF animation.
#[derive(Clone, Debug)]
pub struct Animation {
    pub name: String,
    pub channels: Vec<Channel>,
}

impl Animation {
    /// Loop period: the last key time over all channels.
    pub fn duration(&self) -> f32 {
        self.channels.iter().map(Channel::end).fold(0.0, f32::max)
    }

    /// `t` (seconds, f64) wrapped into [0, duration) (looping) in f64, then
    /// rounded to f32, the key times' type; 0 for a zero-length animation.
    pub fn local_time(&self, t: f64) -> f32 {
        let d = self.duration();
        if d > 0.0 {
            let local = t.rem_euclid(f64::from(d)) as f32;
            // A time just below a multiple of `d` can round up to `d` itself:
            // keep it in the loop, at the f32 just below `d`.
            if local >= d {
                f32::from_bits(d.to_bits() - 1)
            } else {
                local
            }
        } else {
            0.0
        }
    }
}

/// A node's local transform at rest.
#[derive(Clone, Copy, Debug)]
pub enum LocalRest {
    /// A node with a `matrix` (must not be animated, glTF §5.25).
    Matrix(Mat4),
    Trs {
        translation: Vec3,
        rotation: Quat,
        scale: Vec3,
    },
}

impl LocalRest {
    fn matrix(&self) -> Mat4 {
        match *self {
            LocalRest::Matrix(m) => m,
            LocalRest::Trs {
                translation,
                rotation,
                scale,
            } => Mat4::from_scale_rotation_translation(scale, rotation, translation),
        }
    }
}

/// Which of a file's animations play (`--animation NAME|INDEX`, default all).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AnimationSelection {
    #[default]
    All,
    Index(usize),
    Name(String),
}

impl std::str::FromStr for AnimationSelection {
    type Err = std::convert::Infallible;
    /// "all", an index, or a name.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "all" => AnimationSelection::All,
            _ => match s.parse::<usize>() {
                Ok(i) => AnimationSelection::Index(i),
                Err(_) => AnimationSelection::Name(s.to_string()),
            },
        })
    }
}

/// Everything needed to pose a scene's instances at a time.
#[derive(Clone, Debug, Default)]
pub struct SceneAnimation {
    /// Rest local transform of every glTF node.
    pub nodes: Vec<LocalRest>,
    /// Per instance, the node path from its root to its node.
    pub instance_paths: Vec<Vec<u32>>,
    /// Per instance, a transform applied after its path's (glTF
    /// EXT_mesh_gpu_instancing's T·R·S); empty means identity for all.
    pub instance_offsets: Vec<Mat4>,
    pub animations: Vec<Animation>,
    /// Indices into `animations` that play.
    pub active: Vec<usize>,
}

impl SceneAnimation {
    /// Chooses the animations that play; an unknown name or index is an
    /// error listing what the file has.
    pub fn select(&mut self, sel: &AnimationSelection) -> Result<(), String> {
        let list = || {
            self.animations
                .iter()
                .enumerate()
                .map(|(i, a)| format!("{i} '{}'", a.name))
                .collect::<Vec<_>>()
                .join(", ")
        };
        self.active = match sel {
            AnimationSelection::All => (0..self.animations.len()).collect(),
            AnimationSelection::Index(i) if *i < self.animations.len() => vec![*i],
            AnimationSelection::Index(i) => {
                return Err(format!("no animation {i}; the file has: {}", list()))
            }
            AnimationSelection::Name(n) => {
                match self.animations.iter().position(|a| &a.name == n) {
                    Some(i) => vec![i],
                    None => {
                        return Err(format!(
                            "no animation named '{n}'; the file has: {}",
                            list()
                        ))
                    }
                }
            }
        };
        Ok(())
    }

    /// Nodes driven by an active animation.
    fn animated_nodes(&self) -> Vec<bool> {
        let mut moved = vec![false; self.nodes.len()];
        for &a in &self.active {
            for c in &self.animations[a].channels {
                moved[c.node] = true;
            }
        }
        moved
    }

    /// Whether instance `i` can move (its path holds an animated node).
    pub fn instance_moves(&self) -> Vec<bool> {
        let moved = self.animated_nodes();
        self.instance_paths
            .iter()
            .map(|p| p.iter().any(|&n| moved[n as usize]))
            .collect()
    }

    /// Local transforms of every node at time `t` (seconds).
    pub fn local_transforms(&self, t: f64) -> Vec<Mat4> {
        let mut trs: Vec<LocalRest> = self.nodes.clone();
        for &a in &self.active {
            let anim = &self.animations[a];
            let lt = anim.local_time(t);
            for c in &anim.channels {
                let v = c.sample(lt);
                let (mut translation, mut rotation, mut scale) = match trs[c.node] {
                    LocalRest::Trs {
                        translation,
                        rotation,
                        scale,
                    } => (translation, rotation, scale),
                    // The importer refuses animated matrix nodes.
                    LocalRest::Matrix(m) => {
                        let (s, r, t) = m.to_scale_rotation_translation();
                        (t, r, s)
                    }
                };
                match c.path {
                    TrsPath::Translation => translation = v.truncate(),
                    TrsPath::Rotation => rotation = Quat::from_vec4(v),
                    TrsPath::Scale => scale = v.truncate(),
                }
                trs[c.node] = LocalRest::Trs {
                    translation,
                    rotation,
                    scale,
                };
            }
        }
        trs.iter().map(LocalRest::matrix).collect()
    }

    /// World transforms of every instance at `t` (seconds); instances that do
    /// not move keep `rest` (their import transforms) exactly.
    pub fn instance_transforms(&self, t: f64, rest: &[Mat4]) -> Vec<Mat4> {
        let moves = self.instance_moves();
        let local = self.local_transforms(t);
        self.instance_paths
            .iter()
            .zip(rest)
            .zip(moves)
            .enumerate()
            .map(|(i, ((path, &r), m))| {
                if m {
                    let world = path
                        .iter()
                        .fold(Mat4::IDENTITY, |acc, &n| acc * local[n as usize]);
                    match self.instance_offsets.get(i) {
                        Some(offset) => world * *offset,
                        None => world,
                    }
                } else {
                    r
                }
            })
            .collect()
    }
}
