//! `bench scaling`: frame time against pixels and triangles, with fitted exponents.

use super::interleave::{report_pose_ms, run_interleaved};
use crate::error::Result;
use crate::methods::MethodKind;
use crate::session::Session;

/// Least-squares slope of y against x.
pub fn fit_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    if sxx > 0.0 {
        sxy / sxx
    } else {
        f64::NAN
    }
}

/// Steady-state mean GPU ms per frame of each of `methods` over `cameras`
/// (frames at `fps`; frame 0 excluded), the methods rendering the frames
/// interleaved; an animated scene is posed at each frame's time (the time
/// posing takes is reported apart, on stderr).
pub fn steady_frame_ms(
    session: &Session,
    methods: &[MethodKind],
    settings: &crate::methods::RenderSettings,
    cameras: &[crate::camera::StereoCamera],
    fps: f64,
) -> Result<Vec<f64>> {
    let mut m = Vec::new();
    for &kind in methods {
        m.push(session.create(kind, settings)?);
    }
    let run = run_interleaved(session, &mut m, cameras, fps)?;
    report_pose_ms("scaling point", &run.pose_ms);
    Ok(run
        .stats
        .iter()
        .map(|v| v.iter().map(|s| s.gpu_ms()).sum::<f64>() / v.len().max(1) as f64)
        .collect())
}
