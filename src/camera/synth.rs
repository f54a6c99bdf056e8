//! Seeded synthetic head-pose traces.
//!
//! Every kind is deterministic for a seed (a [`Pcg32`] written here, no
//! `rand` crate) and starts at the stage origin looking down −Z. Rotations
//! are about a neck pivot ([`HeadNeckModel::default`]), so turning the head
//! also moves the eyes, as in a real head. Moves use the minimum-jerk
//! profile `θ(τ) = θ₀ + Δ·(10τ³ − 15τ⁴ + 6τ⁵)`, `τ ∈ [0, 1]`, whose peak
//! angular velocity is `1.875·|Δ| / T` (Flash & Hogan 1985); a move's
//! duration `T` is chosen from its amplitude and a drawn peak velocity.
//!
//! | kind        | motion |
//! |-------------|--------|
//! | `head-turn` | yaw sweeps between +30° and −30° (first direction from the seed; the first move is 0 → ±30°), peak angular velocity drawn per sweep from **[80, 120] °/s**, dwell 0.1–0.4 s at each end |
//! | `walk`      | 1.2 m/s along −Z; step frequency drawn from [1.8, 2.0] Hz; vertical bob ±2 cm at the step frequency, lateral sway ±2 cm and yaw ±1° at the stride frequency (half the step frequency), pitch ±0.5° at the step frequency; amplitudes scaled by a seeded factor in [0.8, 1.2] |
//! | `saccade`   | rest 0.3–0.9 s, then a rapid head jerk of 10–25° in a random direction (pitch component halved), peak angular velocity drawn from **[160, 240] °/s**; yaw kept within ±40°, pitch within ±20° |
//! | `still`     | exactly the identity pose at every sample: no tremor, so any temporal change in a rendering of `still` is the renderer's own |

use std::fmt;
use std::str::FromStr;

use glam::{Quat, Vec2, Vec3};

use super::neck::HeadNeckModel;
use super::pcg::Pcg32;
use super::pose::HeadPose;
use super::trace::{PoseSample, PoseTrace};

/// Which synthetic motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SynthKind {
    /// Smooth yaw sweeps ±30°, peaks 80–120 °/s.
    HeadTurn,
    /// Walking forward at 1.2 m/s with bob and sway.
    Walk,
    /// Rapid head jerks (160–240 °/s peaks) between rests.
    Saccade,
    /// Exactly still.
    Still,
}

impl SynthKind {
    /// All kinds, in CLI order.
    pub const ALL: [SynthKind; 4] = [
        SynthKind::HeadTurn,
        SynthKind::Walk,
        SynthKind::Saccade,
        SynthKind::Still,
    ];

    /// The CLI name: `head-turn`, `walk`, `saccade`, `still`.
    pub fn name(self) -> &'static str {
        match self {
            SynthKind::HeadTurn => "head-turn",
            SynthKind::Walk => "walk",
            SynthKind::Saccade => "saccade",
            SynthKind::Still => "still",
        }
    }
}

impl fmt::Display for SynthKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown synthetic-trace kind.
#[derive(Debug, thiserror::Error)]
#[error("unknown synthetic trace kind `{0}`; expected one of head-turn, walk, saccade, still")]
pub struct UnknownSynthKind(pub String);

impl FromStr for SynthKind {
    type Err = UnknownSynthKind;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        SynthKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| UnknownSynthKind(s.to_string()))
    }
}

/// Peak angular velocity range of `head-turn` sweeps, degrees per second.
pub const HEAD_TURN_PEAK_DEG_S: (f64, f64) = (80.0, 120.0);
/// Peak angular velocity range of `saccade` jerks, degrees per second.
pub const SACCADE_PEAK_DEG_S: (f64, f64) = (160.0, 240.0);
/// Walking speed of `walk`, metres per second.
pub const WALK_SPEED: f32 = 1.2;

/// A synthetic trace of `seconds` seconds sampled at `rate_hz`
/// (`t_k = k / rate_hz`, `k = 0 ..= round(seconds · rate_hz)`), deterministic
/// for `seed`. Its `source` is `synth:<kind>:seed=<seed>`.
///
/// # Panics
/// If `seconds` is negative or not finite, or `rate_hz` is not positive and
/// finite (callers validate user input).
pub fn synth(kind: SynthKind, seconds: f64, seed: u64, rate_hz: f64) -> PoseTrace {
    assert!(
        seconds.is_finite() && seconds >= 0.0,
        "synth: bad duration {seconds}"
    );
    assert!(
        rate_hz.is_finite() && rate_hz > 0.0,
        "synth: bad rate {rate_hz}"
    );
    // One PCG stream per kind, so kinds with the same seed are unrelated.
    let mut rng = Pcg32::new(seed, kind as u64 + 1);
    let neck = HeadNeckModel::default();
    let n = (seconds * rate_hz).round() as usize;
    let times = (0..=n).map(|k| k as f64 / rate_hz);
    let samples: Vec<PoseSample> = match kind {
        SynthKind::Still => times.map(|t| sample(t, HeadPose::IDENTITY)).collect(),
        SynthKind::HeadTurn => {
            let plan = head_turn_plan(&mut rng, seconds);
            times
                .map(|t| sample(t, neck.pose(plan.orientation(t))))
                .collect()
        }
        SynthKind::Saccade => {
            let plan = saccade_plan(&mut rng, seconds);
            times
                .map(|t| sample(t, neck.pose(plan.orientation(t))))
                .collect()
        }
        SynthKind::Walk => {
            let walk = Walk::new(&mut rng);
            times.map(|t| sample(t, walk.pose(t, &neck))).collect()
        }
    };
    PoseTrace::from_samples(format!("synth:{kind}:seed={seed}"), samples)
}

fn sample(t: f64, pose: HeadPose) -> PoseSample {
    PoseSample { t, pose, ipd: None }
}

/// Minimum-jerk position profile on τ ∈ [0, 1].
fn min_jerk(tau: f64) -> f64 {
    let t = tau.clamp(0.0, 1.0);
    t * t * t * (10.0 + t * (-15.0 + 6.0 * t))
}

/// One move from `from` to `to` (yaw, pitch in radians) starting at `t0`.
#[derive(Clone, Copy, Debug)]
struct Move {
    t0: f64,
    duration: f64,
    from: Vec2,
    to: Vec2,
}

/// A sequence of moves separated by rests.
struct Plan {
    moves: Vec<Move>,
}

impl Plan {
    fn yaw_pitch(&self, t: f64) -> Vec2 {
        // Last move that has started (moves are sorted by t0).
        let i = self.moves.partition_point(|m| m.t0 <= t);
        if i == 0 {
            return self.moves.first().map_or(Vec2::ZERO, |m| m.from);
        }
        let m = self.moves[i - 1];
        let s = min_jerk((t - m.t0) / m.duration) as f32;
        m.from.lerp(m.to, s)
    }

    fn orientation(&self, t: f64) -> Quat {
        let yp = self.yaw_pitch(t);
        Quat::from_rotation_y(yp.x) * Quat::from_rotation_x(yp.y)
    }
}

/// Duration of a minimum-jerk move of `amplitude` radians with peak angular
/// velocity `peak_deg_s`.
fn move_duration(amplitude: f32, peak_deg_s: f64) -> f64 {
    1.875 * (amplitude as f64).to_degrees() / peak_deg_s
}

fn head_turn_plan(rng: &mut Pcg32, seconds: f64) -> Plan {
    let amp = 30f32.to_radians();
    let mut target = if rng.next_u32() & 1 == 0 { amp } else { -amp };
    let mut from = Vec2::ZERO;
    let mut t = 0.0;
    let mut moves = Vec::new();
    while t <= seconds {
        let to = Vec2::new(target, 0.0);
        let peak = rng.uniform(HEAD_TURN_PEAK_DEG_S.0, HEAD_TURN_PEAK_DEG_S.1);
        let duration = move_duration((to.x - from.x).abs(), peak);
        moves.push(Move {
            t0: t,
            duration,
            from,
            to,
        });
        t += duration + rng.uniform(0.1, 0.4);
        from = to;
        target = -target;
    }
    Plan { moves }
}

fn saccade_plan(rng: &mut Pcg32, seconds: f64) -> Plan {
    let (yaw_max, pitch_max) = (40f32.to_radians(), 20f32.to_radians());
    let mut from = Vec2::ZERO;
    let mut t = rng.uniform(0.3, 0.9);
    let mut moves = Vec::new();
    while t <= seconds {
        let amp = rng.uniform(10.0, 25.0).to_radians() as f32;
        let phi = rng.uniform(0.0, std::f64::consts::TAU) as f32;
        let mut dir = Vec2::new(phi.cos(), 0.5 * phi.sin()).normalize();
        // Turn back towards the centre instead of leaving the range.
        let probe = from + dir * amp;
        if probe.x.abs() > yaw_max {
            dir.x = -dir.x;
        }
        if probe.y.abs() > pitch_max {
            dir.y = -dir.y;
        }
        let to = from + dir * amp;
        let peak = rng.uniform(SACCADE_PEAK_DEG_S.0, SACCADE_PEAK_DEG_S.1);
        let duration = move_duration(amp, peak);
        moves.push(Move {
            t0: t,
            duration,
            from,
            to,
        });
        t += duration + rng.uniform(0.3, 0.9);
        from = to;
    }
    Plan { moves }
}

/// Walking parameters.
struct Walk {
    step_hz: f64,
    scale: f32,
}

impl Walk {
    const BOB: f32 = 0.02;
    const SWAY: f32 = 0.02;
    const YAW: f32 = 1.0;
    const PITCH: f32 = 0.5;

    fn new(rng: &mut Pcg32) -> Self {
        Self {
            step_hz: rng.uniform(1.8, 2.0),
            scale: rng.uniform(0.8, 1.2) as f32,
        }
    }

    fn pose(&self, t: f64, neck: &HeadNeckModel) -> HeadPose {
        let step = (std::f64::consts::TAU * self.step_hz * t) as f32;
        let stride = 0.5 * step;
        let k = self.scale;
        let yaw = (k * Self::YAW).to_radians() * stride.sin();
        let pitch = (k * Self::PITCH).to_radians() * step.sin();
        let q = Quat::from_rotation_y(yaw) * Quat::from_rotation_x(pitch);
        let body = Vec3::new(
            k * Self::SWAY * stride.sin(),
            k * Self::BOB * step.sin(),
            -WALK_SPEED * t as f32,
        );
        HeadPose::new(body + neck.eye_position(q), q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_parse_and_print() {
        for k in SynthKind::ALL {
            assert_eq!(k.name().parse::<SynthKind>().unwrap(), k);
        }
        let e = "run".parse::<SynthKind>().unwrap_err().to_string();
        assert!(e.contains("`run`") && e.contains("head-turn"));
    }

    #[test]
    fn all_kinds_start_at_rest_pose() {
        for k in SynthKind::ALL {
            let tr = synth(k, 1.0, 7, 90.0);
            assert_eq!(tr.samples.len(), 91);
            let p0 = tr.samples[0].pose;
            assert!(p0.position.length() < 1e-6, "{k}");
            assert!(p0.orientation.angle_between(Quat::IDENTITY) < 1e-4, "{k}");
        }
    }

    #[test]
    fn walk_moves_forward_at_speed() {
        let tr = synth(SynthKind::Walk, 5.0, 3, 90.0);
        let d = tr.samples.last().unwrap().pose.position.z;
        assert!((d + 6.0).abs() < 0.05, "{d}");
    }
}
