//! A plausibility check of an imported trace's coordinate convention:
//! people walk the way they look.
//!
//! Reading a recording with the wrong handedness or forward axis flips the
//! view direction relative to the motion: a left-handed Unity/HoloLens file
//! copied column by column into glTF axes makes the wearer walk backwards
//! (the position's z is not negated and the identity orientation looks down
//! −Z instead of the file's +Z). Walking backwards for most of a recording
//! is rare; so after import the horizontal motion is compared with the
//! horizontal view direction.
//!
//! # Method
//!
//! The trace is cut into *segments*: a segment ends as soon as the eye
//! midpoint is [`SEGMENT_M`] (horizontally, ⟂ +Y) from where it started,
//! so tracking jitter and head bob do not count as motion, and the
//! measure does not depend on the sample rate. Each segment's net
//! displacement `d` is compared with the mean horizontal viewing direction
//! `f̄` over its samples (skipped when `|f̄| < 0.5`: the view swept or
//! looked straight down):
//! forward if `cos∠(d, f̄) > cos 60°`, backward if `< −cos 60°`, sideways
//! otherwise (HoloLens users circle the content they look at: sideways).
//!
//! A warning is raised when the trace moves at least [`MIN_DISTANCE_M`]
//! along its view axis (forward + backward; orientation-only traces with a
//! head–neck model never do) and more than [`BACKWARD_FRACTION`] of that
//! distance is backwards. On the 14 Fraunhofer HHI pred6dof HoloLens
//! traces (8–28 m along the view axis each; not shipped, their licence is
//! for testing pred6dof) read correctly as left-handed Unity data, 5–20 %
//! of that distance is backwards for 13 users and 44 % for one (user 2, who
//! backs away often); read naively as right-handed it is the complement,
//! 56–95 %, so all 14 naive readings warn and no correct one does.

use glam::DVec2;

use super::pose::HeadPose;
use super::trace::{PoseSample, PoseTrace};

/// Horizontal distance that closes a segment, metres.
pub const SEGMENT_M: f64 = 0.25;
/// `cos 60°`: a segment within 60° of the view axis counts as along it.
pub const ALONG_COS: f64 = 0.5;
/// Least along-view distance for a verdict, metres.
pub const MIN_DISTANCE_M: f64 = 1.0;
/// Backward share of the along-view distance above which the trace warns.
pub const BACKWARD_FRACTION: f64 = 0.5;

/// Horizontal distances by direction relative to the view, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MotionStats {
    /// Moving within 60° of where the head looks.
    pub forward_m: f64,
    /// Moving within 60° of the opposite direction.
    pub backward_m: f64,
    /// Moving across the view direction.
    pub sideways_m: f64,
}

impl MotionStats {
    /// Forward + backward.
    pub fn along_m(&self) -> f64 {
        self.forward_m + self.backward_m
    }

    /// Backward share of the along-view distance (0 when there is none).
    pub fn backward_fraction(&self) -> f64 {
        if self.along_m() > 0.0 {
            self.backward_m / self.along_m()
        } else {
            0.0
        }
    }
}

fn horizontal(v: glam::Vec3) -> DVec2 {
    DVec2::new(v.x as f64, v.z as f64)
}

fn view(p: &HeadPose) -> DVec2 {
    horizontal(p.forward())
}

/// The motion of `samples` split by direction relative to the view (module
/// docs).
pub fn motion_vs_view(samples: &[PoseSample]) -> MotionStats {
    let mut stats = MotionStats::default();
    let Some(first) = samples.first() else {
        return stats;
    };
    let mut start = horizontal(first.pose.position);
    let mut view_sum = view(&first.pose);
    let mut count = 1.0;
    for s in &samples[1..] {
        view_sum += view(&s.pose);
        count += 1.0;
        let d = horizontal(s.pose.position) - start;
        let len = d.length();
        if len < SEGMENT_M {
            continue;
        }
        let f = view_sum / count;
        if f.length() >= 0.5 {
            let c = d.dot(f) / (len * f.length());
            if c > ALONG_COS {
                stats.forward_m += len;
            } else if c < -ALONG_COS {
                stats.backward_m += len;
            } else {
                stats.sideways_m += len;
            }
        }
        start = horizontal(s.pose.position);
        view_sum = view(&s.pose);
        count = 1.0;
    }
    stats
}

/// The one-line warning for a trace that mostly moves backwards relative to
/// its view, naming the likely convention problem; `None` when plausible.
pub fn convention_warning(trace: &PoseTrace) -> Option<String> {
    let m = motion_vs_view(&trace.samples);
    if m.along_m() < MIN_DISTANCE_M || m.backward_fraction() <= BACKWARD_FRACTION {
        return None;
    }
    Some(format!(
        "{}: the head moves backwards relative to where it looks for {:.0} % of the {:.1} m it moves along its view axis — likely a coordinate-convention problem: wrong handedness (Unity/HoloLens recordings are left-handed: --format csv --handedness left) or wrong forward axis (--forward)",
        trace.source.display(),
        100.0 * m.backward_fraction(),
        m.along_m()
    ))
}
