//! `bench scaling`: frame time against pixels and triangles, with fitted exponents.

use super::interleave::run_interleaved;
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
/// (frame 0 excluded), the methods rendering the frames interleaved.
pub fn steady_frame_ms(
    session: &Session,
    methods: &[MethodKind],
    settings: &crate::methods::RenderSettings,
    cameras: &[crate::camera::StereoCamera],
) -> Result<Vec<f64>> {
    let mut m = Vec::new();
    for &kind in methods {
        m.push(session.create(kind, settings)?);
    }
    let stats = run_interleaved(&mut m, cameras)?;
    Ok(stats
        .iter()
        .map(|v| v.iter().map(|s| s.gpu_ms()).sum::<f64>() / v.len().max(1) as f64)
        .collect())
}
