//! What every benchmark that times methods shares: rendering them
//! interleaved frame by frame, per-pass means, paired ratios.

use crate::error::Result;
use crate::methods::FrameInput;

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

/// Renders `cameras` with every method in `methods`, interleaved frame by
/// frame in rotating order so drift of a shared machine hits them alike;
/// frame 0 is a warm-up and not counted. Returns stats[method][frame].
pub fn run_interleaved(
    methods: &mut [Box<dyn crate::methods::Method>],
    cameras: &[crate::camera::StereoCamera],
) -> Result<Vec<Vec<crate::methods::FrameStats>>> {
    let mut stats = vec![Vec::new(); methods.len()];
    for (i, cam) in cameras.iter().enumerate() {
        let input = FrameInput {
            index: i as u32,
            camera: *cam,
            prev_camera: if i > 0 { Some(cameras[i - 1]) } else { None },
        };
        for k in 0..methods.len() {
            let j = (k + i) % methods.len();
            let f = methods[j].render_frame(&input)?;
            if i > 0 {
                stats[j].push(f.stats);
            }
        }
    }
    Ok(stats)
}

/// Ratio of the means of `a` and `b` (paired per-frame times of two methods
/// on the same frames) and the standard error of the per-frame ratios.
pub fn paired_ratio(a: &[f64], b: &[f64]) -> (f64, f64) {
    let r: Vec<f64> = a.iter().zip(b).map(|(x, y)| x / y).collect();
    (mean_and_se(a).0 / mean_and_se(b).0, mean_and_se(&r).1)
}

/// The mean of `v` and its standard error (sample standard deviation over
/// √n; 0 for fewer than two values).
pub fn mean_and_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n.max(1.0);
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, (var / n.max(1.0)).sqrt())
}
