//! `hybrid`'s options: its parts' (paper §4, "Hybrid"): the sample cache's
//! visibility options and the hash table's (whose `taa` turns the TAA on its
//! output on or off), both from the same command-line groups as the
//! `sample-cache` and `hash-cache` methods', and its own lookup variant
//! (`--hybrid-lookups`).

use crate::methods::config::{record_as, MethodOptions};
use crate::methods::{HashCacheSettings, MethodArgs, SampleCacheSettings};
use serde::Serialize;
use std::str::FromStr;

/// `--hybrid-lookups`: how the visible samples look up the hash table.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum HybridLookups {
    /// The paper's Hybrid (§4; §5.1: "a total of three lookups per pixel (one
    /// for shading, two for reconstruction)"): per pixel and frame one of its
    /// visible surface samples, drawn uniformly, is voxel-jittered as in
    /// HashCache; one lookup reserves and updates one of its two levels (a
    /// coin), two find the hit voxel and its parent for the colour, which
    /// the pixel mixes with its background samples' environment by
    /// coverage. TAA integrates the per-frame sample.
    #[default]
    PerPixel,
    /// Every visible sample finds both levels of its unjittered point and the
    /// pixel shows their mean (≈ 2 × n_target lookups per pixel), one update
    /// per pixel round robin over the samples: the variant before issue 15,
    /// measured as a different method in docs/PERFORMANCE.md.
    PerSample,
}

impl FromStr for HybridLookups {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "per-pixel" => Ok(HybridLookups::PerPixel),
            "per-sample" => Ok(HybridLookups::PerSample),
            _ => Err(format!(
                "bad --hybrid-lookups '{s}': expected per-pixel or per-sample"
            )),
        }
    }
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct HybridConfig {
    /// The visibility-only sample cache's options (its shading options are unused).
    pub cache: SampleCacheSettings,
    /// The hash table's options (its debug views are not produced by hybrid).
    pub hash: HashCacheSettings,
    /// How the samples look up the table.
    pub lookups: HybridLookups,
}

impl MethodOptions for HybridConfig {
    fn from_args(args: &MethodArgs, debug_views: bool) -> Result<Self, String> {
        Ok(HybridConfig {
            cache: SampleCacheSettings::from_args(args, debug_views)?,
            hash: HashCacheSettings::from_args(args, debug_views)?,
            lookups: args.hybrid.hybrid_lookups,
        })
    }

    fn enable_debug_views(&mut self) {
        self.cache.enable_debug_views();
        self.hash.enable_debug_views();
    }

    fn record(&self, settings: &mut serde_json::Map<String, serde_json::Value>) {
        record_as(settings, "cache", &self.cache);
        record_as(settings, "hash", &self.hash);
        record_as(settings, "lookups", &self.lookups);
    }
}
