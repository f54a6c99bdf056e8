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
    /// Entries in the table (24 B each), a multiple of 16 (one 4×4 tile);
    /// [`AUTO_CAPACITY`] (0, the default): sized from the frame when the
    /// table is created ([`auto_capacity`]; written `"auto"` in JSON).
    #[serde(serialize_with = "capacity_json")]
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
            capacity: AUTO_CAPACITY,
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

/// `capacity` meaning "size the table from the frame" ([`auto_capacity`]).
pub const AUTO_CAPACITY: u32 = 0;

/// `capacity` in JSON: the number, or `"auto"` for [`AUTO_CAPACITY`].
fn capacity_json<S: serde::Serializer>(c: &u32, s: S) -> Result<S::Ok, S::Error> {
    if *c == AUTO_CAPACITY {
        s.serialize_str("auto")
    } else {
        s.serialize_u32(*c)
    }
}

/// The smallest table [`auto_capacity`] makes: 2^20 entries (24 MiB), the
/// fixed default until session 49, so the small frames of the tests and
/// docs keep their table.
pub const MIN_AUTO_CAPACITY: u32 = 1 << 20;

/// Live entries per pixel (both eyes' pixels) [`auto_capacity`] provides
/// for: a table holds an entry per voxel touched within `stale_frames`
/// frames, and voxels are smaller than a pixel (§4), so the live set is a
/// multiple of the pixel count. Measured (docs/PERFORMANCE.md, "The hash
/// table's size"): 4.3 live entries per pixel on Cornell along 100 frames
/// of `mmsys18-user1` (160×120), where a table of 6.8 per pixel failed
/// 0.1 % of its lookups and 13.7 none.
pub const AUTO_ENTRIES_PER_PIXEL: u64 = 8;

/// The default table for `pixels` pixels (both eyes): the power of two at
/// or above [`AUTO_ENTRIES_PER_PIXEL`] · pixels, at least
/// [`MIN_AUTO_CAPACITY`], at most [`MAX_CAPACITY`] and the largest power of
/// two whose 16-byte cell buffer the device binds (`max_storage_bytes`,
/// maxStorageBufferRange). The flag says whether a limit cut it below
/// [`AUTO_ENTRIES_PER_PIXEL`] per pixel. Until session 49 the default was
/// 2^20 at every size: at 1920×1080 (4.1 M pixels over both eyes) the first
/// frames filled it, and since no entry can be replaced before it is
/// `stale_frames` old, most later lookups failed and those pixels showed
/// their own 1 spp path (640×360 on Cornell: 2.8 % of the lookups failed
/// by frame 6 and rising).
pub fn auto_capacity(pixels: u64, max_storage_bytes: u64) -> (u32, bool) {
    let want = (AUTO_ENTRIES_PER_PIXEL * pixels)
        .next_power_of_two()
        .max(MIN_AUTO_CAPACITY as u64);
    let device = (max_storage_bytes / 16).max(16);
    let device = 1u64 << (63 - device.leading_zeros());
    let cap = want.min(MAX_CAPACITY as u64).min(device);
    (cap as u32, cap < AUTO_ENTRIES_PER_PIXEL * pixels)
}

impl HashCacheSettings {
    /// Checks ranges; the message names the option.
    pub fn validate(&self) -> Result<(), String> {
        // Auto: sized at creation, never below MIN_AUTO_CAPACITY (a device
        // binds at least 2^27 bytes, 2^23 cells), so the probe bound holds
        // for the smallest table it can make.
        let capacity = if self.capacity == AUTO_CAPACITY {
            MIN_AUTO_CAPACITY
        } else if self.capacity < 16 || self.capacity % 16 != 0 || self.capacity > MAX_CAPACITY {
            return Err(format!(
                "bad --hash-capacity {}: expected a multiple of 16 between 16 and {MAX_CAPACITY}",
                self.capacity
            ));
        } else {
            self.capacity
        };
        let slots = if self.tiles { capacity / 16 } else { capacity };
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
        assert!(bad(&|s| s.capacity = 8).contains("--hash-capacity"));
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

    #[test]
    fn the_default_table_grows_with_the_frame_within_the_device() {
        let big = u32::MAX as u64; // maxStorageBufferRange of most desktop GPUs
                                   // 160×120 stereo: 8 · 38 400 = 307 200 → 2^19, raised to 2^20.
        assert_eq!(auto_capacity(2 * 160 * 120, big), (1 << 20, false));
        // 640×360: 3 686 400 → 2^22.
        assert_eq!(auto_capacity(2 * 640 * 360, big), (1 << 22, false));
        // 1920×1080: 33 177 600 → 2^25 (768 MiB of entries).
        assert_eq!(auto_capacity(2 * 1920 * 1080, big), (1 << 25, false));
        // lavapipe binds 2^27 bytes: 2^23 cells of 16 B, short of 8 a pixel.
        assert_eq!(auto_capacity(2 * 1920 * 1080, 1 << 27), (1 << 23, true));
        // 4K stereo: capped at MAX_CAPACITY.
        assert_eq!(auto_capacity(2 * 3840 * 2160, big), (MAX_CAPACITY, true));
    }
}
