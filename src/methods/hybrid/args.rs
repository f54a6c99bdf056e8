//! The `hybrid` method's own command-line option (its table and sample
//! cache take theirs from the `--hash-*` and sample-cache groups).

use super::config::HybridLookups;

/// Options of the hybrid method (ignored by other methods).
#[derive(clap::Args, Clone, Debug)]
pub struct HybridArgs {
    /// per-pixel (the paper's §4: three lookups per pixel, one for shading
    /// and two for reconstruction, with voxel jitter) | per-sample (every
    /// visible sample looks up both levels, no voxel jitter: the variant
    /// before issue 15, a different method)
    #[arg(long, default_value = "per-pixel")]
    pub hybrid_lookups: HybridLookups,
}
