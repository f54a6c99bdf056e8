//! The one TAA's command-line options: the `taa` method's, and those of the
//! TAA `hash-cache`, `hybrid` and `--taa-output` run on a method's output.

use super::settings::{TaaHistory, TaaSettings, TaaWeights};
use crate::values::float_with;

/// Options of the one TAA: the taa method's, hash-cache's and hybrid's TAA and --taa-output.
#[derive(clap::Args, Clone, Debug)]
pub struct TaaArgs {
    /// Blend factor of the new frame (fixed weights), or its lower bound α_min (count weights).
    #[arg(long, default_value_t = 0.1, value_parser = float_with("--taa-alpha", |v: f32| v > 0.0 && v <= 1.0, "a number in (0, 1]"))]
    pub taa_alpha: f32,
    /// count (running mean, then EMA at --taa-alpha) | pfj23 (Eq. 4 per pixel from 3×3 neighbourhood variances: our reading of the paper's weights; see docs) | fixed (EMA with --taa-alpha)
    #[arg(long, default_value = "count")]
    pub taa_weights: TaaWeights,
    /// Clipping box half-width in standard deviations of the 3×3 YCoCg neighbourhood.
    #[arg(long, default_value_t = 1.0, value_parser = float_with("--taa-gamma", crate::values::positive_f32, "a positive number"))]
    pub taa_gamma: f32,
    /// catmull-rom (the history resampled over 4x4 texels where all are consistent, else bilinear) | bilinear
    #[arg(long, default_value = "catmull-rom")]
    pub taa_history: TaaHistory,
    /// Apply this TAA to the output of every method (the paper's Fig. 12,
    /// "TAA on top of all methods"); methods that already end in it
    /// (taa; hash-cache and hybrid unless --hash-no-taa) are left as they are.
    #[arg(long)]
    pub taa_output: bool,
}

impl TaaArgs {
    /// The method's settings (checked; the message names the option).
    pub fn settings(&self) -> Result<TaaSettings, String> {
        let s = TaaSettings {
            alpha: self.taa_alpha,
            weights: self.taa_weights,
            gamma: self.taa_gamma,
            history: self.taa_history,
            ..Default::default()
        };
        s.validate()?;
        Ok(s)
    }
}

impl crate::methods::MethodOptions for TaaSettings {
    fn from_args(args: &crate::methods::MethodArgs, _debug_views: bool) -> Result<Self, String> {
        args.taa.settings()
    }
    fn record(&self, settings: &mut serde_json::Map<String, serde_json::Value>) {
        crate::methods::config::record_as(settings, "taa", self);
    }
}
