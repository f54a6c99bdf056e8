//! The `isrt` method's command-line options.

use super::settings::{IsrtRetrace, IsrtSettings};
use crate::values::int_in;

/// Options of the isrt method (ignored by other methods).
#[derive(clap::Args, Clone, Debug)]
pub struct IsrtArgs {
    /// Super-resolution cells per pixel side M (2, 3 or 4).
    #[arg(long, default_value_t = 3, value_parser = int_in("--isrt-m", 2u32, 4, "cells per pixel side"))]
    pub isrt_m: u32,
    /// every (every sample, every frame; every empty cell filled) | one (one
    /// sample per pixel per frame, empty cells filled up to --isrt-n-target:
    /// the paper's Fig. 10 configuration with --isrt-n-target 4)
    #[arg(long, default_value = "every")]
    pub isrt_retrace: IsrtRetrace,
    /// With --isrt-retrace one: samples per pixel to fill up to (0 = every cell).
    #[arg(long, default_value_t = 0, value_parser = int_in("--isrt-n-target", 0u32, 16, "samples per pixel"))]
    pub isrt_n_target: u32,
}

impl IsrtArgs {
    /// The method's settings (checked; the message names the option).
    pub fn settings(&self) -> Result<IsrtSettings, String> {
        let s = IsrtSettings {
            m: self.isrt_m,
            retrace: self.isrt_retrace,
            n_target: self.isrt_n_target,
            ..Default::default()
        };
        s.validate()?;
        Ok(s)
    }
}

impl crate::methods::MethodOptions for IsrtSettings {
    fn from_args(args: &crate::methods::MethodArgs, _debug_views: bool) -> Result<Self, String> {
        // `--accumulation` is the sample cache's option; isrt averages alike.
        let mut s = args.isrt.settings()?;
        s.accumulation = args.cache.accumulation;
        s.accumulation.validate()?;
        Ok(s)
    }
    fn record(&self, settings: &mut serde_json::Map<String, serde_json::Value>) {
        crate::methods::config::record_as(settings, "isrt", self);
    }
}
