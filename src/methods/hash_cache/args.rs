//! The `hash-cache` method's command-line options (`hybrid` takes its table's
//! options from them).

use super::settings::{HashCacheSettings, HashLod, AUTO_CAPACITY, MAX_CAPACITY};
use crate::values::{float_with, int_in};

/// Options of the hash-cache method (ignored by other methods).
#[derive(clap::Args, Clone, Debug)]
pub struct HashCacheArgs {
    /// Hash-cache table entries (24 B each; a multiple of 16). Default: 8 per pixel of both eyes, as a power of two, at least 2^20, within the device's storage-buffer limit.
    #[arg(long, value_parser = int_in("--hash-capacity", 16u32, MAX_CAPACITY, "entries (a multiple of 16)"))]
    pub hash_capacity: Option<u32>,
    /// distance | distance-normal (level of detail also from the incidence angle)
    #[arg(long, default_value = "distance")]
    pub hash_lod: HashLod,
    /// Store voxels in 4x4 tiles across the hit normal's major axis (GI-1.0): the default.
    #[arg(long, conflicts_with = "hash_no_tiles")]
    pub hash_tiles: bool,
    /// One entry per voxel instead of 4x4 tiles (the default before issue 15).
    #[arg(long)]
    pub hash_no_tiles: bool,
    /// Linear-probing bound (tiles, or entries with --hash-no-tiles).
    #[arg(long, default_value_t = 16, value_parser = int_in("--hash-max-probe", 1u32, 64, "probes"))]
    pub hash_max_probe: u32,
    /// Entries untouched for more than this many frames may be overwritten.
    #[arg(long, default_value_t = 64, value_parser = int_in("--hash-stale-frames", 1u32, (1 << 31) - 1, "frames"))]
    pub hash_stale_frames: u32,
    /// Voxel edge as a multiple of the pixel footprint (before power-of-two quantization).
    #[arg(long, default_value_t = 1.0, value_parser = float_with("--hash-lod-scale", |v: f32| v.is_finite() && v > 0.0 && v <= 1024.0, "a positive factor up to 1024"))]
    pub hash_lod_scale: f32,
    /// Running-mean sample count cap per entry.
    #[arg(long, default_value_t = 1024, value_parser = int_in("--hash-max-samples", 1u32, u32::MAX, "samples"))]
    pub hash_max_samples: u32,
    /// Turn off the TAA pass on the hash cache's output.
    #[arg(long)]
    pub hash_no_taa: bool,
}

impl HashCacheArgs {
    /// The method's settings, with the checks that relate two options
    /// (a multiple of 16, probes within the table); the message names the option.
    pub fn settings(&self, debug_views: bool) -> Result<HashCacheSettings, String> {
        let s = HashCacheSettings {
            capacity: self.hash_capacity.unwrap_or(AUTO_CAPACITY),
            max_probe: self.hash_max_probe,
            stale_frames: self.hash_stale_frames,
            lod: self.hash_lod,
            tiles: self.hash_tiles || !self.hash_no_tiles,
            lod_scale: self.hash_lod_scale,
            max_samples: self.hash_max_samples,
            taa: !self.hash_no_taa,
            taa_settings: Default::default(),
            debug_views,
        };
        s.validate()?;
        Ok(s)
    }
}

impl crate::methods::MethodOptions for HashCacheSettings {
    /// The `--hash-*` options with the one TAA's `--taa-*` ones.
    fn from_args(args: &crate::methods::MethodArgs, debug_views: bool) -> Result<Self, String> {
        Ok(HashCacheSettings {
            taa_settings: args.taa.settings()?,
            ..args.hash.settings(debug_views)?
        })
    }
    fn enable_debug_views(&mut self) {
        self.debug_views = true;
    }
    fn record(&self, settings: &mut serde_json::Map<String, serde_json::Value>) {
        crate::methods::config::record_as(settings, "hash", self);
    }
}
