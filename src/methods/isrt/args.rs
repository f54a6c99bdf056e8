//! The `isrt` method's command-line options.

use super::settings::IsrtSettings;
use crate::values::int_in;

/// Options of the isrt method (ignored by other methods).
#[derive(clap::Args, Clone, Debug)]
pub struct IsrtArgs {
    /// Super-resolution cells per pixel side M (2, 3 or 4).
    #[arg(long, default_value_t = 3, value_parser = int_in("--isrt-m", 2u32, 4, "cells per pixel side"))]
    pub isrt_m: u32,
}

impl IsrtArgs {
    /// The method's settings (checked; the message names the option).
    pub fn settings(&self) -> Result<IsrtSettings, String> {
        let s = IsrtSettings {
            m: self.isrt_m,
            ..Default::default()
        };
        s.validate()?;
        Ok(s)
    }
}

impl crate::methods::MethodOptions for IsrtSettings {
    fn from_args(args: &crate::methods::MethodArgs, _debug_views: bool) -> Result<Self, String> {
        args.isrt.settings()
    }
    fn record(&self, settings: &mut serde_json::Map<String, serde_json::Value>) {
        crate::methods::config::record_as(settings, "isrt", self);
    }
}
