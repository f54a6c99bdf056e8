//! What the memoization cache does in rendering (`--memo …`, issue 17):
//! which hits look graph outputs up, the table's size, its probe window,
//! the eviction policy and the level-of-detail bias. Off by default: a
//! scene's graphs are then evaluated at every hit, as before.

use super::table::{Eviction, MemoClock, ENTRY_BYTES, ENTRY_HEADER_BYTES};

/// Which hits go through the cache (thesis §6: the error comes almost
/// entirely from primary hits, the time from all of them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MemoHits {
    #[default]
    Off,
    /// First hits only (those shaded with a pixel's ray cone).
    Primary,
    /// Hits after the first bounce only.
    Secondary,
    Both,
}

impl MemoHits {
    /// Bit 0: primary hits, bit 1: secondary hits (the shader's flags).
    pub fn flags(self) -> u32 {
        match self {
            MemoHits::Off => 0,
            MemoHits::Primary => 1,
            MemoHits::Secondary => 2,
            MemoHits::Both => 3,
        }
    }
}

impl std::str::FromStr for MemoHits {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "off" => MemoHits::Off,
            "primary" => MemoHits::Primary,
            "secondary" => MemoHits::Secondary,
            "both" => MemoHits::Both,
            _ => {
                return Err(format!(
                    "bad --memo '{s}': expected off, primary, secondary or both"
                ))
            }
        })
    }
}

impl std::str::FromStr for Eviction {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "random" => Eviction::Random,
            "lrw" => Eviction::Lrw,
            "lru" => Eviction::Lru,
            "none" => Eviction::Disabled,
            _ => {
                return Err(format!(
                    "bad --memo-eviction '{s}': expected random, lrw, lru or none"
                ))
            }
        })
    }
}

impl std::str::FromStr for MemoClock {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "frame" => MemoClock::Frame,
            "counter" => MemoClock::Counter,
            _ => return Err(format!("bad --memo-clock '{s}': expected frame or counter")),
        })
    }
}

/// The largest table `--memo-entries` accepts (2^24 entries, 0.9 GiB).
pub const MAX_ENTRIES: u32 = 1 << 24;
/// The widest probe window `--memo-probe` accepts.
pub const MAX_PROBE: u32 = 64;

/// How a missing tile is filled (the tiled variants; thesis §5.4.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MemoFill {
    /// The lane that missed evaluates the whole tile.
    Plain,
    /// The subgroup's lanes evaluate each missing tile together (ballot,
    /// shuffle) where the device supports subgroup ballot and shuffle; the
    /// plain fill elsewhere.
    #[default]
    Subgroup,
}

impl std::str::FromStr for MemoFill {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "plain" => MemoFill::Plain,
            "subgroup" => MemoFill::Subgroup,
            _ => return Err(format!("bad --memo-fill '{s}': expected plain or subgroup")),
        })
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MemoSettings {
    pub hits: MemoHits,
    /// Entries of the table (S of eq. 5.10).
    pub entries: u32,
    /// Linear-probing window D (thesis default 8).
    pub probe: u32,
    pub eviction: Eviction,
    /// Where LRW and LRU take an access's time from.
    pub clock: MemoClock,
    /// Added to the level of detail (eq. 5.5's bias; + = finer texels).
    pub bias: f32,
    /// Texels per entry edge: 1 non-tiled, else s×s texels an entry (the
    /// thesis's tiled variant, nearest texel; a power of two up to 8).
    pub tile: u32,
    /// Bilinear lookup between the four nearest texel centres: in tiles of
    /// (s+1)² texels (the one-texel overlap, one lookup), or without tiles
    /// four lookups of single texels.
    pub bilinear: bool,
    /// How the tiled variants fill a missing tile.
    pub fill: MemoFill,
}

impl Default for MemoSettings {
    fn default() -> Self {
        MemoSettings {
            hits: MemoHits::Off,
            entries: DEFAULT_TEXELS,
            probe: 8,
            eviction: Eviction::Lru,
            clock: MemoClock::Frame,
            bias: 0.0,
            tile: 1,
            bilinear: false,
            fill: MemoFill::Subgroup,
        }
    }
}

/// The texels a default table holds: 2^20 (the non-tiled default's entries).
pub const DEFAULT_TEXELS: u32 = 1 << 20;

impl MemoSettings {
    /// The default table's entries for tiles of `tile`² texels: 2^20 texels'
    /// worth (1,048,576 entries non-tiled, 65,536 tiles of 4×4), so every
    /// variant fits a 128 MiB storage range (4×4 bilinear tiles: 75.8 MiB).
    pub fn default_entries(tile: u32) -> u32 {
        let t = tile.clamp(1, 8);
        DEFAULT_TEXELS / (t * t)
    }

    pub fn enabled(&self) -> bool {
        self.hits != MemoHits::Off
    }

    /// Texel records an entry holds: 1 (non-tiled, nearest or bilinear),
    /// s², or (s+1)² with bilinear tiles.
    pub fn texels_per_entry(&self) -> u64 {
        if self.tile <= 1 {
            return 1;
        }
        let e = self.tile as u64 + u64::from(self.bilinear);
        e * e
    }

    /// Bytes of one entry: key, stamp, version and its texel records.
    pub fn entry_bytes(&self) -> u64 {
        self.clock.header_bytes() + (ENTRY_BYTES - ENTRY_HEADER_BYTES) * self.texels_per_entry()
    }

    /// Bytes of the table's buffers (keys, stamps, records; the access
    /// clock's 8-byte counter).
    pub fn table_bytes(&self) -> u64 {
        self.entries as u64 * self.entry_bytes() + self.clock.counter_bytes()
    }

    /// One line naming the option at fault.
    pub fn validate(&self) -> Result<(), String> {
        if self.probe == 0 || self.probe > MAX_PROBE {
            return Err(format!(
                "bad --memo-probe {}: expected 1 to {MAX_PROBE} entries",
                self.probe
            ));
        }
        if self.entries <= self.probe || self.entries > MAX_ENTRIES {
            return Err(format!(
                "bad --memo-entries {}: expected more than --memo-probe ({}) and at most {MAX_ENTRIES}",
                self.entries, self.probe
            ));
        }
        if !matches!(self.tile, 1 | 2 | 4 | 8) {
            return Err(format!(
                "bad --memo-tile {}: expected 1 (one texel an entry), 2, 4 or 8",
                self.tile
            ));
        }
        if self.table_bytes() > MAX_ENTRIES as u64 * ENTRY_BYTES * 4 {
            return Err(format!(
                "bad --memo-entries {} with --memo-tile {}: {} MiB of records, more than {} MiB",
                self.entries,
                self.tile,
                self.table_bytes() >> 20,
                (MAX_ENTRIES as u64 * ENTRY_BYTES * 4) >> 20
            ));
        }
        if self.clock == MemoClock::Counter
            && matches!(self.eviction, Eviction::Random | Eviction::Disabled)
        {
            return Err(format!(
                "bad --memo-clock counter with --memo-eviction {0}: --memo-eviction {0} reads no \
                 stamps (the access clock ages entries for lrw and lru)",
                self.eviction.name()
            ));
        }
        if !self.bias.is_finite() || self.bias.abs() > 16.0 {
            return Err(format!(
                "bad --memo-bias {}: expected a number of levels in [-16, 16]",
                self.bias
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default table of every variant holds 2^20 texels and its record
    /// buffer fits 2^27 bytes, the smallest maxStorageBufferRange the
    /// project runs on (lavapipe's): `--memo-tile s` alone never asks for
    /// more than the device binds.
    #[test]
    fn default_tables_hold_2_20_texels_within_lavapipes_storage_range() {
        let record = ENTRY_BYTES - ENTRY_HEADER_BYTES;
        for tile in [1, 2, 4, 8] {
            for bilinear in [false, true] {
                let s = MemoSettings {
                    hits: MemoHits::Both,
                    entries: MemoSettings::default_entries(tile),
                    tile,
                    bilinear,
                    ..Default::default()
                };
                assert_eq!(s.validate(), Ok(()), "tile {tile} bilinear {bilinear}");
                assert_eq!(
                    s.entries as u64 * (tile * tile) as u64,
                    DEFAULT_TEXELS as u64,
                    "tile {tile}"
                );
                let values = s.entries as u64 * s.texels_per_entry() * record;
                assert!(
                    values <= 1 << 27,
                    "tile {tile} bilinear {bilinear}: {values} bytes of records"
                );
            }
        }
        assert_eq!(
            MemoSettings::default().entries,
            MemoSettings::default_entries(1)
        );
    }

    /// `--memo-clock counter`: one error line with random eviction (which
    /// reads no stamps); otherwise 64-bit stamp and version (68 B a
    /// non-tiled entry against 60) and the 8-byte counter in the table's
    /// bytes.
    #[test]
    fn the_access_clock_widens_entries_and_is_refused_with_random_eviction() {
        let counter = |eviction| MemoSettings {
            hits: MemoHits::Both,
            eviction,
            clock: MemoClock::Counter,
            entries: 1000,
            ..Default::default()
        };
        let e = counter(Eviction::Random).validate().unwrap_err();
        assert!(
            e.contains("--memo-clock counter") && e.contains("random"),
            "{e}"
        );
        let e = counter(Eviction::Disabled).validate().unwrap_err();
        assert!(
            e.contains("--memo-clock counter") && e.contains("--memo-eviction none"),
            "{e}"
        );
        for eviction in [Eviction::Lrw, Eviction::Lru] {
            let s = counter(eviction);
            assert_eq!(s.validate(), Ok(()));
            assert_eq!(s.entry_bytes(), 68);
            assert_eq!(s.table_bytes(), 1000 * 68 + 8);
        }
        let frame = MemoSettings {
            clock: MemoClock::Frame,
            ..counter(Eviction::Random)
        };
        assert_eq!(frame.validate(), Ok(()));
        assert_eq!((frame.entry_bytes(), frame.table_bytes()), (60, 60_000));
    }
}
