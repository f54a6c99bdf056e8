//! `hybrid`'s options: its parts' (paper §4, "Hybrid"): the sample cache's
//! visibility options and the hash table's (whose `taa` turns the TAA on its
//! output on or off). Both come from the same command-line groups as the
//! `sample-cache` and `hash-cache` methods'.

use crate::methods::config::{record_as, MethodOptions};
use crate::methods::{HashCacheSettings, MethodArgs, SampleCacheSettings};
use serde::Serialize;

#[derive(Clone, Debug, Default, Serialize)]
pub struct HybridConfig {
    /// The visibility-only sample cache's options (its shading options are unused).
    pub cache: SampleCacheSettings,
    /// The hash table's options (its debug views are not produced by hybrid).
    pub hash: HashCacheSettings,
}

impl MethodOptions for HybridConfig {
    fn from_args(args: &MethodArgs, debug_views: bool) -> Result<Self, String> {
        Ok(HybridConfig {
            cache: SampleCacheSettings::from_args(args, debug_views)?,
            hash: HashCacheSettings::from_args(args, debug_views)?,
        })
    }

    fn enable_debug_views(&mut self) {
        self.cache.enable_debug_views();
        self.hash.enable_debug_views();
    }

    fn record(&self, settings: &mut serde_json::Map<String, serde_json::Value>) {
        record_as(settings, "cache", &self.cache);
        record_as(settings, "hash", &self.hash);
    }
}
