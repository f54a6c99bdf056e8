//! Options of the `hash-cache` method and their command-line spellings.

use crate::methods::TaaSettings;
use serde::Serialize;
use std::str::FromStr;

/// `--hash-lod`: how a hit's voxel level of detail is chosen (paper Fig. 9).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum HashLod {
    /// Voxel edge ≤ the pixel footprint at the hit distance.
    Distance,
    /// As `Distance`, with the footprint stretched by 1 / |cos θ| (θ = angle
    /// between the view ray and the normal), so grazing surfaces get coarser voxels.
    DistanceNormal,
}

#[derive(Clone, Debug, Serialize)]
pub struct HashCacheSettings {
    /// Entries in the table (24 B each), a multiple of 16 (one 4×4 tile).
    pub capacity: u32,
    /// Linear-probing bound: slots (or tiles with `tiles`) tried per lookup.
    pub max_probe: u32,
    /// An entry not touched for more than this many frames may be overwritten.
    pub stale_frames: u32,
    pub lod: HashLod,
    /// Store voxels in 4×4 tiles projected along the hit normal's major axis
    /// (GI-1.0; the default, the configuration the paper compares with).
    pub tiles: bool,
    /// Voxel edge as a multiple of the pixel footprint before quantization (1 = a pixel).
    pub lod_scale: f32,
    /// Running-mean sample count cap per entry (the cache forgets older samples
    /// with weight 1/max_samples once it is reached).
    pub max_samples: u32,
    /// Temporal antialiasing on the output (the paper applies it).
    pub taa: bool,
    /// Options of that TAA: the one TAA's (`--taa-*`, [`TaaSettings`]).
    pub taa_settings: TaaSettings,
    /// Download the debug views (voxel id, level of detail, samples).
    pub debug_views: bool,
}

impl Default for HashCacheSettings {
    fn default() -> Self {
        HashCacheSettings {
            capacity: 1 << 20,
            max_probe: 16,
            stale_frames: 64,
            // The paper's HashCache (§4): GI-1.0's 2D tiles on the normal's
            // major axis, LoD from the distance with voxels smaller than a
            // pixel (edge 2^floor(log2 footprint) ≤ the pixel footprint).
            lod: HashLod::Distance,
            tiles: true,
            lod_scale: 1.0,
            max_samples: 1024,
            taa: true,
            taa_settings: TaaSettings::default(),
            debug_views: false,
        }
    }
}

/// The largest table: 2^26 entries (1.5 GiB).
pub const MAX_CAPACITY: u32 = 1 << 26;

impl HashCacheSettings {
    /// Checks ranges; the message names the option.
    pub fn validate(&self) -> Result<(), String> {
        if self.capacity < 16 || self.capacity % 16 != 0 || self.capacity > MAX_CAPACITY {
            return Err(format!(
                "bad --hash-capacity {}: expected a multiple of 16 between 16 and {MAX_CAPACITY}",
                self.capacity
            ));
        }
        let slots = if self.tiles {
            self.capacity / 16
        } else {
            self.capacity
        };
        if self.max_probe == 0 || self.max_probe > 64 || self.max_probe > slots {
            return Err(format!(
                "bad --hash-max-probe {}: expected 1..=64 and at most the number of {} ({slots})",
                self.max_probe,
                if self.tiles { "tiles" } else { "entries" }
            ));
        }
        if self.stale_frames == 0 || self.stale_frames >= 1 << 31 {
            return Err(format!(
                "bad --hash-stale-frames {}: expected 1..2^31",
                self.stale_frames
            ));
        }
        if !(self.lod_scale.is_finite() && self.lod_scale > 0.0 && self.lod_scale <= 1024.0) {
            return Err(format!(
                "bad --hash-lod-scale {}: expected a positive factor up to 1024",
                self.lod_scale
            ));
        }
        if self.max_samples == 0 {
            return Err("bad --hash-max-samples 0: expected at least 1".into());
        }
        self.taa_settings.validate()
    }
}

impl FromStr for HashLod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "distance" => Ok(HashLod::Distance),
            "distance-normal" => Ok(HashLod::DistanceNormal),
            _ => Err(format!(
                "bad --hash-lod '{s}': expected distance or distance-normal"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_bad_values_name_the_option() {
        HashCacheSettings::default().validate().unwrap();
        let bad = |f: &dyn Fn(&mut HashCacheSettings)| {
            let mut s = HashCacheSettings::default();
            f(&mut s);
            s.validate().unwrap_err()
        };
        assert!(bad(&|s| s.capacity = 100).contains("--hash-capacity"));
        assert!(bad(&|s| s.capacity = 0).contains("--hash-capacity"));
        assert!(bad(&|s| s.max_probe = 0).contains("--hash-max-probe"));
        assert!(bad(&|s| {
            s.capacity = 32;
            s.tiles = true;
            s.max_probe = 4
        })
        .contains("tiles"));
        assert!(bad(&|s| s.stale_frames = 0).contains("--hash-stale-frames"));
        assert!(bad(&|s| s.lod_scale = f32::NAN).contains("--hash-lod-scale"));
        assert_eq!("distance-normal".parse(), Ok(HashLod::DistanceNormal));
        assert!("nearest"
            .parse::<HashLod>()
            .unwrap_err()
            .contains("--hash-lod"));
    }
}
