//! The `sample-cache` method's command-line options (flattened into every
//! command that creates methods; `hybrid` takes its visibility from them).

use super::settings::{Accumulation, Payload, Reproject, Retrace, SampleCacheSettings, Shading};
use crate::stereo::BlendMode;
use crate::values::{float_with, int_in};

/// Options of the sample-cache method (ignored by other methods).
#[derive(clap::Args, Clone, Debug)]
pub struct SampleCacheArgs {
    /// Cache slots per pixel N (1..=16).
    #[arg(long, default_value_t = 12, value_parser = int_in("--slots", 1u32, 16, "slots per pixel (the 32-bit mask)"))]
    pub slots: u32,
    /// Target visible samples per pixel.
    #[arg(long, default_value_t = 4, value_parser = int_in("--n-target", 1u32, 16, "visible samples per pixel"))]
    pub n_target: u32,
    /// Tolerance around --n-target.
    #[arg(long, default_value_t = 1, value_parser = int_in("--delta", 0u32, 15, "samples"))]
    pub delta: u32,
    /// single | multi | adaptive
    #[arg(long, default_value = "adaptive")]
    pub retrace: Retrace,
    /// uniform | adaptive | skip (no shading: visibility and reconstruction only, Fig. 7's timing)
    #[arg(long, default_value = "uniform")]
    pub shading: Shading,
    /// radiance (256-bit entries: first hit + radiance record) | none (128-bit first hits only, Fig. 6's no-shade rows; needs --shading skip)
    #[arg(long, default_value = "radiance")]
    pub payload: Payload,
    /// Shading invocations per frame for adaptive shading, per pixel that uniform shading shades (a visible surface sample): 1.0 = uniform's work, 0.7 = Fig. 14's 70 %.
    #[arg(long, default_value_t = 1.0, value_parser = float_with("--shading-rate", |v: f32| v.is_finite() && v > 0.0 && v <= 16.0, "a fraction in (0, 16] (at most --slots)"))]
    pub shading_rate: f32,
    /// one-pass | two-pass
    #[arg(long, default_value = "one-pass")]
    pub reproject: Reproject,
    /// mean (running mean, §4–5's radiance cache; HashCache's too) | alpha-min (appendix C: α floored at α_min(α_GGX) for samples with a specular lobe) | fixed:ALPHA (α floored at ALPHA for every sample, §5.2). Also isrt's.
    #[arg(long, default_value = "mean")]
    pub accumulation: Accumulation,
    /// Stereo blending of the two eyes (§3.6): none | moments | neighbourhood
    #[arg(long, default_value = "none")]
    pub stereo_blend: BlendMode,
    /// Sharpness R of the stereo blending in [0, 1] (1 = no neighbour enters Y's moments; X's are resampled with Dodgson's kernel at any R).
    #[arg(long, default_value_t = 0.5, value_parser = float_with("--sharpness", |v: f32| (0.0..=1.0).contains(&v), "R in [0, 1]"))]
    pub sharpness: f32,
}

impl SampleCacheArgs {
    /// The method's settings, with the checks that relate two options
    /// (`--n-target` ≤ `--slots`, ...); the message names the option.
    pub fn settings(&self, debug_views: bool) -> Result<SampleCacheSettings, String> {
        let s = SampleCacheSettings {
            slots: self.slots,
            n_target: self.n_target,
            delta: self.delta,
            retrace: self.retrace,
            shading: self.shading,
            payload: self.payload,
            shading_rate: self.shading_rate,
            reproject: self.reproject,
            accumulation: self.accumulation,
            stereo_blend: self.stereo_blend,
            sharpness: self.sharpness,
            debug_views,
            ..Default::default()
        };
        s.validate()?;
        Ok(s)
    }
}

impl crate::methods::MethodOptions for SampleCacheSettings {
    fn from_args(args: &crate::methods::MethodArgs, debug_views: bool) -> Result<Self, String> {
        args.cache.settings(debug_views)
    }
    fn enable_debug_views(&mut self) {
        self.debug_views = true;
    }
    fn record(&self, settings: &mut serde_json::Map<String, serde_json::Value>) {
        crate::methods::config::record_as(settings, "cache", self);
    }
}
