//! Every method's command-line options, each group defined in its method's
//! folder, flattened into the commands that create methods. A method's
//! [`super::MethodOptions::from_args`] picks its group(s) out of it.

use super::hash_cache::args::HashCacheArgs;
use super::hybrid::args::HybridArgs;
use super::isrt::args::IsrtArgs;
use super::sample_cache::args::SampleCacheArgs;
use super::taa::args::TaaArgs;
use super::{MethodConfig, MethodKind, RenderSettings};
use crate::values::Size;

#[derive(clap::Args, Clone, Debug)]
pub struct MethodArgs {
    #[command(flatten)]
    pub cache: SampleCacheArgs,
    #[command(flatten)]
    pub taa: TaaArgs,
    #[command(flatten)]
    pub isrt: IsrtArgs,
    #[command(flatten)]
    pub hash: HashCacheArgs,
    #[command(flatten)]
    pub hybrid: HybridArgs,
    /// Use the plain shader builds even where the device supports subgroup
    /// operations (the sample cache's counters, lists and histogram).
    #[arg(long)]
    pub no_subgroup_ops: bool,
}

impl MethodArgs {
    /// The settings every method shares, after checking every method's
    /// options (so a bad option is refused whichever method runs; one error
    /// line each).
    pub fn settings(
        &self,
        size: Size,
        spp: u32,
        max_bounces: u32,
        seed: u32,
        debug_views: bool,
    ) -> Result<RenderSettings, String> {
        self.check(debug_views)?;
        Ok(RenderSettings {
            width: size.width,
            height: size.height,
            spp,
            max_bounces,
            seed,
            all_features: false,
            extra_features: Default::default(),
            all_passes: false,
            subgroup_ops: !self.no_subgroup_ops,
            light_sampling: Default::default(),
            taa_output: match self.taa.taa_output {
                true => Some(self.taa.settings()?),
                false => None,
            },
        })
    }

    /// `kind`'s configuration from these options (checked).
    pub fn config(&self, kind: MethodKind, debug_views: bool) -> Result<MethodConfig, String> {
        kind.config_from_args(self, debug_views)
    }

    /// Checks every method's options, so a bad option is refused whichever
    /// method runs (one error line, registry order).
    pub fn check(&self, debug_views: bool) -> Result<(), String> {
        MethodKind::ALL
            .iter()
            .try_for_each(|&k| self.config(k, debug_views).map(|_| ()))
    }
}
