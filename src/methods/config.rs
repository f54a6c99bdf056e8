//! Per-method configuration. Every method's own options are a type in its
//! folder (`SampleCacheSettings`, `TaaSettings`, `IsrtSettings`,
//! `HashCacheSettings`, `HybridConfig`; [`NoOptions`] for methods without
//! any) implementing [`MethodOptions`]; the registry
//! (src/methods/registry.rs) gathers them into [`super::MethodConfig`], one
//! variant per method, which is what a method is created from together with
//! the [`super::RenderSettings`] every method shares.

use super::args::MethodArgs;
use serde::Serialize;

/// A method's own options: built from its command-line group(s), with the
/// debug views compare's grids turn on, and recorded beside the shared
/// settings in a run's summary.
pub trait MethodOptions: Clone + std::fmt::Debug + Default + Serialize {
    /// The options from the parsed command line (checked; the message names
    /// the option). `debug_views`: download the method's debug views.
    fn from_args(args: &MethodArgs, debug_views: bool) -> Result<Self, String>;

    /// Turns on the method's debug views, where it has any.
    fn enable_debug_views(&mut self) {}

    /// Adds the options to a run's settings record (summary.json,
    /// stats.json), under the key each part had in the shared settings
    /// before they moved here (`cache`, `taa`, `isrt`, `hash`).
    fn record(&self, settings: &mut serde_json::Map<String, serde_json::Value>);
}

/// The options of a method that has none (reference, naive, supersample,
/// debug-normals).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct NoOptions;

impl MethodOptions for NoOptions {
    fn from_args(_: &MethodArgs, _: bool) -> Result<Self, String> {
        Ok(NoOptions)
    }
    fn record(&self, _: &mut serde_json::Map<String, serde_json::Value>) {}
}

/// `value` as JSON under `key` of `settings` (for [`MethodOptions::record`]).
pub fn record_as(
    settings: &mut serde_json::Map<String, serde_json::Value>,
    key: &str,
    value: &impl Serialize,
) {
    settings.insert(
        key.to_string(),
        serde_json::to_value(value).unwrap_or_default(),
    );
}
