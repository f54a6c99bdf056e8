//! What every benchmark that times methods shares: rendering them
//! interleaved frame by frame, per-pass means, paired ratios.

use crate::error::Result;
use crate::methods::FrameInput;
use crate::session::Session;

/// Mean milliseconds per frame of the passes whose name starts with `prefix`.
pub(crate) fn mean_pass_ms(frames: &[crate::methods::FrameStats], prefix: &str) -> f64 {
    let total: f64 = frames
        .iter()
        .flat_map(|f| &f.passes)
        .filter(|p| p.name.starts_with(prefix))
        .map(|p| p.ms)
        .sum();
    // + 0.0: an empty sum is -0.0, printed as "-0.00".
    total / frames.len().max(1) as f64 + 0.0
}

/// The scene time of frame `i` of a sequence rendered at `fps` frames per
/// second (the rate its cameras were resampled at): frame / fps in f64, as
/// replay computes it (`replay::replay_observed`).
pub fn frame_time(i: usize, fps: f64) -> f64 {
    i as f64 / fps
}

/// Refuses, before anything renders, an animation that would place an
/// instance out of bounds in any of the first `frames` frames at `fps`
/// ([`Session::check_poses`], as replay checks its frames up front). Nothing
/// to do for a static scene.
pub fn check_frame_poses(session: &Session, frames: usize, fps: f64) -> Result<()> {
    session.check_poses((0..frames).map(|k| frame_time(k, fps)))
}

/// Poses the scene's instances for frame `i` of a sequence at `fps`, as
/// replay does before each frame: at the frame's time, with the previous
/// frame's beside it for the motion vectors (none on frame 0). Returns the
/// wall-clock milliseconds it took (animation sampling, TLAS rebuild,
/// uploads: outside every pass's GPU time), `None` on a static scene
/// (where it does nothing).
pub fn pose_frame(session: &Session, i: usize, fps: f64) -> Result<Option<f64>> {
    let d = session.pose_instances(
        frame_time(i, fps),
        i.checked_sub(1).map(|p| frame_time(p, fps)),
    )?;
    Ok(session.scene.is_animated().then_some(d.as_secs_f64() * 1e3))
}

/// Prints (stderr) the mean wall-clock time of posing the animated
/// instances per measured frame, which no pass's GPU time includes; nothing
/// for a static scene (`pose_ms` empty).
pub fn report_pose_ms(what: &str, pose_ms: &[f64]) {
    if pose_ms.is_empty() {
        return;
    }
    let mean = pose_ms.iter().sum::<f64>() / pose_ms.len() as f64;
    let max = pose_ms.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "posing the animated instances ({what}): {mean:.4} ms wall per frame \
         (max {max:.4}, {} measured frames; animation sampling, TLAS rebuild, \
         uploads; not in the GPU frame times)",
        pose_ms.len()
    );
}

/// What [`run_interleaved`] measured.
pub struct Interleaved {
    /// stats[method][frame] of the measured frames (frame 0 excluded).
    pub stats: Vec<Vec<crate::methods::FrameStats>>,
    /// Wall-clock ms of posing the instances before each measured frame
    /// ([`pose_frame`]); empty for a static scene.
    pub pose_ms: Vec<f64>,
}

/// Renders `cameras` (frames at `fps`) with every method in `methods`,
/// interleaved frame by frame in a carry-over balanced order (`balanced_order`) so drift of a shared
/// machine hits them alike; frame 0 is a warm-up and not counted. Before
/// each frame the scene's instances are posed at the frame's time
/// ([`pose_frame`]; the poses of every frame are checked first), once for
/// all methods, since they share the session's scene.
pub fn run_interleaved(
    session: &Session,
    methods: &mut [Box<dyn crate::methods::Method>],
    cameras: &[crate::camera::StereoCamera],
    fps: f64,
) -> Result<Interleaved> {
    check_frame_poses(session, cameras.len(), fps)?;
    let mut stats = vec![Vec::new(); methods.len()];
    let mut pose_ms = Vec::new();
    for (i, cam) in cameras.iter().enumerate() {
        let input = FrameInput {
            index: i as u32,
            camera: *cam,
            prev_camera: if i > 0 { Some(cameras[i - 1]) } else { None },
        };
        let posing = pose_frame(session, i, fps)?;
        if i > 0 {
            pose_ms.extend(posing);
        }
        for j in balanced_order(i, methods.len()) {
            let f = methods[j].render_frame(&input)?;
            if i > 0 {
                stats[j].push(f.stats);
            }
        }
    }
    Ok(Interleaved { stats, pose_ms })
}

/// The order in which `m` configurations run in round (frame) `round` of an
/// interleaved benchmark: the rows of a Williams design (Williams 1949), so
/// that over m rounds (2m when m is odd) every configuration runs in every
/// position equally often *and* follows every other one equally often.
/// The rotation used before (k + round mod m) balanced the positions but
/// put each configuration after the same neighbour in every round, so a
/// carry-over from one workload to the next (clock, caches, the driver's
/// state) fell on the same configuration every time, a bias no ± shows.
/// Row r of the first m is (r, r+1, r−1, r+2, r−2, …) mod m; for odd m the
/// next m are those rows reversed. The balance is within rounds: the step
/// from one round's last configuration to the next round's first is not
/// balanced, and only whole cycles of rounds are balanced at all.
pub fn balanced_order(round: usize, m: usize) -> Vec<usize> {
    if m == 0 {
        return Vec::new();
    }
    let r = round % if m % 2 == 0 { m } else { 2 * m };
    let shift = r % m;
    let mut row: Vec<usize> = (0..m)
        .map(|j| {
            // 0, 1, m−1, 2, m−2, …
            let base = if j == 0 {
                0
            } else if j % 2 == 1 {
                j.div_ceil(2)
            } else {
                m - j / 2
            };
            (base + shift) % m
        })
        .collect();
    if r >= m {
        row.reverse();
    }
    row
}

/// Ratio of the means of `a` and `b` (paired per-frame times of two methods
/// on the same frames) and the standard error of that ratio: the delta
/// method with the frames' covariance, widened for lag-1 autocorrelation
/// (`metrics::uncertainty::ratio_of_means`, as `compare` reports its
/// ratios). `∞` for fewer than two frames, NaN ratio for none. (Until
/// session 48 the ± was the standard error of the mean of the per-frame
/// ratios, a different number from the ratio of the means it followed:
/// a = [1, 4], b = [1, 2] printed 1.667 ± 0.5, the 0.5 belonging to 1.5.)
pub fn paired_ratio(a: &[f64], b: &[f64]) -> (f64, f64) {
    crate::metrics::uncertainty::ratio_of_means(a, b)
        .map_or((f64::NAN, f64::INFINITY), |r| (r.mean, r.stderr))
}

/// The mean of `v` and its standard error (sample standard deviation over
/// √n, frames taken as independent); the error is `∞` for fewer than two
/// values (unknown, not 0), the mean NaN for none.
pub fn mean_and_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return (m, f64::INFINITY);
    }
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Over a full cycle of rounds every configuration takes every position
    /// equally often and follows every other configuration equally often
    /// (the first-order carry-over balance the old rotation lacked: with it
    /// configuration j always followed j − 1).
    #[test]
    fn balanced_order_balances_positions_and_predecessors() {
        for m in 1..=9usize {
            let rounds = if m % 2 == 0 { m } else { 2 * m };
            let mut position = vec![vec![0usize; m]; m];
            let mut follows = vec![vec![0usize; m]; m];
            for r in 0..rounds {
                let row = balanced_order(r, m);
                let mut sorted = row.clone();
                sorted.sort();
                assert_eq!(
                    sorted,
                    (0..m).collect::<Vec<_>>(),
                    "m {m} round {r}: {row:?}"
                );
                for (p, &c) in row.iter().enumerate() {
                    position[c][p] += 1;
                }
                for w in row.windows(2) {
                    follows[w[1]][w[0]] += 1;
                }
                assert_eq!(
                    balanced_order(r + rounds, m),
                    row,
                    "m {m}: the cycle repeats"
                );
            }
            let per = rounds / m;
            for c in 0..m {
                assert!(
                    position[c].iter().all(|&n| n == per),
                    "m {m}: positions {position:?}"
                );
                for b in 0..m {
                    let want = if b == c {
                        0
                    } else {
                        rounds * (m - 1) / (m * (m - 1)).max(1)
                    };
                    assert_eq!(follows[c][b], want, "m {m}: {c} after {b}: {follows:?}");
                }
            }
        }
        assert!(balanced_order(3, 0).is_empty());
    }

    /// The ± belongs to the ratio printed before it: the ratio of the means
    /// and its delta-method error, not the spread of the per-frame ratios
    /// (whose mean, 1.5 here, is another number); one frame has no error
    /// estimate.
    #[test]
    fn the_ratio_and_its_error_are_of_the_same_estimator() {
        let (r, se) = paired_ratio(&[1.0, 4.0], &[1.0, 2.0]);
        assert!((r - 5.0 / 3.0).abs() < 1e-12, "{r}");
        // Delta method by hand: R = 5/3, ȳ = 1.5, sample (co)variances
        // s_xx = 4.5, s_xy = 1.5, s_yy = 0.5 (n − 1 = 1); no lag-1 widening
        // below three frames.
        let rr: f64 = 5.0 / 3.0;
        let want = ((4.5 - 2.0 * rr * 1.5 + rr * rr * 0.5) / (2.0 * 1.5 * 1.5)).sqrt();
        assert!((se - want).abs() < 1e-12, "{se} vs {want}");
        let (r, se) = paired_ratio(&[2.0], &[1.0]);
        assert_eq!((r, se), (2.0, f64::INFINITY));
        assert_eq!(mean_and_se(&[3.0]), (3.0, f64::INFINITY));
        let (m, se) = mean_and_se(&[1.0, 3.0]);
        assert_eq!(m, 2.0);
        assert!((se - 1.0).abs() < 1e-12, "{se}");
    }
}
