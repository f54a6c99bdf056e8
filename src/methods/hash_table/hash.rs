//! CPU twin of the hash cache's keys, hashes and probe sequence
//! (`shaders/hash_cache/hash.glsl`), bit for bit: the GPU test
//! `tests/hash_cache.rs` runs `shaders/hash_cache/hash_test.comp` on random
//! keys and compares. Also a single-threaded model of the table's
//! find-or-insert, used by the unit tests to check eviction and uniqueness.
//!
//! * **Key** = integer voxel (or tile) coordinates and a 32-bit `meta` word:
//!   bits 0–5 level of detail + 32, bits 6–8 major axis of the normal
//!   (0..5 = +X, −X, +Y, −Y, +Z, −Z; 7 = none), bits 9–12 the voxel's offset
//!   within its 4×4 tile, bit 13 tiles on.
//! * **Index hash**: PCG (Jarzynski & Olano 2020) chained over the words,
//!   `pcg(x + pcg(y + pcg(z + pcg(meta'))))`, as in GI-1.0's hash grid,
//!   where meta' is meta without the offset within the tile, so a tile's 16
//!   voxels share one 16-entry tile of the table (§4).
//! * **Checksum**: xxHash32's finalizer chained the same way; never 0 (0 marks
//!   an empty entry), so a computed 0 becomes 1.
//! * **Probe sequence**: linear. Without tiles slot i = (h mod C + i) mod C; with
//!   tiles the table is C/16 tiles of 16 entries, tile i = (h mod T + i) mod T
//!   and slot = 16 · tile + offset within the tile.
//! * **Entry word** (64 bit): checksum << 32 | last access frame (mod 2^32).

/// PCG-RXS-M-XS 32-bit hash (same as `pcg_hash` in shaders/common/random.glsl).
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

/// xxHash32's avalanche of one 32-bit word (Jarzynski & Olano 2020).
pub fn xxhash32(p: u32) -> u32 {
    const P2: u32 = 2246822519;
    const P3: u32 = 3266489917;
    const P4: u32 = 668265263;
    const P5: u32 = 374761393;
    let mut h = p.wrapping_add(P5);
    h = P4.wrapping_mul(h.rotate_left(17));
    h = P2.wrapping_mul(h ^ (h >> 15));
    h = P3.wrapping_mul(h ^ (h >> 13));
    h ^ (h >> 16)
}

/// Tiles are 4×4 voxels (16 entries).
pub const TILE: i32 = 4;
pub const TILE_ENTRIES: u32 = 16;
/// `meta` axis value of no axis: keys carry the normal's signed major axis
/// (0–5) tiled or not since session 52; Hybrid's per-pixel record
/// (`reserve.comp` `pix_cell.w`) still writes this, where only the level
/// and tile offset are read.
pub const NO_AXIS: u32 = 7;
/// Levels of detail are stored as level + LEVEL_BIAS in 6 bits.
pub const LEVEL_BIAS: i32 = 32;

/// A voxel key: coordinates (of the voxel, or of its tile) and the meta word.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct VoxelKey {
    pub coord: [i32; 3],
    pub meta: u32,
}

/// The `meta` word of a key.
pub fn pack_meta(level: i32, axis: u32, local: u32, tiles: bool) -> u32 {
    ((level + LEVEL_BIAS).clamp(0, 63) as u32)
        | ((axis & 7) << 6)
        | ((local & 15) << 9)
        | ((tiles as u32) << 13)
}

impl VoxelKey {
    pub fn level(&self) -> i32 {
        (self.meta & 63) as i32 - LEVEL_BIAS
    }
    pub fn local(&self) -> u32 {
        (self.meta >> 9) & 15
    }
    pub fn tiles(&self) -> bool {
        (self.meta >> 13) & 1 == 1
    }

    /// The index hash. The offset within the tile (bits 9-12) is left out,
    /// so a tile's 16 voxels share one probe sequence and one 16-entry tile
    /// (§4's spatially coherent tiles); the checksum keeps it.
    pub fn index_hash(&self) -> u32 {
        let [x, y, z] = self.coord.map(|c| c as u32);
        let meta = self.meta & !(15 << 9);
        pcg_hash(x.wrapping_add(pcg_hash(
            y.wrapping_add(pcg_hash(z.wrapping_add(pcg_hash(meta)))),
        )))
    }

    /// The checksum stored in the entry's high 32 bits (never 0).
    pub fn checksum(&self) -> u32 {
        let [x, y, z] = self.coord.map(|c| c as u32);
        let c = xxhash32(x.wrapping_add(xxhash32(
            y.wrapping_add(xxhash32(z.wrapping_add(xxhash32(self.meta)))),
        )));
        c.max(1)
    }

    /// Slot of the i-th probe in a table of `capacity` entries.
    pub fn probe_slot(&self, i: u32, capacity: u32) -> u32 {
        probe_slot(self.index_hash(), self.local(), self.tiles(), i, capacity)
    }
}

/// Slot of the i-th probe for index hash `h` (see the module notes).
pub fn probe_slot(h: u32, local: u32, tiles: bool, i: u32, capacity: u32) -> u32 {
    if tiles {
        let tiles_n = capacity / TILE_ENTRIES;
        let tile = ((h % tiles_n) as u64 + i as u64) % tiles_n as u64;
        tile as u32 * TILE_ENTRIES + local
    } else {
        ((h % capacity) as u64 + i as u64).rem_euclid(capacity as u64) as u32
    }
}

/// Wrapping age of an entry last touched at `last` seen at frame `now`
/// (both mod 2^32): correct as long as real ages stay below 2^32 frames.
pub fn age(now: u32, last: u32) -> u32 {
    now.wrapping_sub(last)
}

pub fn pack_entry(checksum: u32, frame: u32) -> u64 {
    ((checksum as u64) << 32) | frame as u64
}

pub fn entry_checksum(word: u64) -> u32 {
    (word >> 32) as u32
}

pub fn entry_frame(word: u64) -> u32 {
    word as u32
}

/// True when an entry may be overwritten: empty, or older than `stale` frames.
pub fn replaceable(word: u64, now: u32, stale: u32) -> bool {
    entry_checksum(word) == 0 || age(now, entry_frame(word)) > stale
}

/// How a lookup ended (the shader's counters).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lookup {
    /// The key's entry exists (possibly stale, then it is revived).
    Found(u32),
    /// Inserted into an empty entry.
    Reserved(u32),
    /// Inserted over a stale entry of another key.
    Evicted(u32),
    /// No matching, empty or stale entry within `max_probe` probes.
    Failed,
}

/// A single-threaded model of the GPU table (keys only).
pub struct CpuTable {
    pub words: Vec<u64>,
    pub max_probe: u32,
    pub stale: u32,
}

impl CpuTable {
    pub fn new(capacity: u32, max_probe: u32, stale: u32) -> Self {
        CpuTable {
            words: vec![0; capacity as usize],
            max_probe,
            stale,
        }
    }

    /// Find the key within the probe window, else insert it into the first
    /// empty or stale entry: the order the shader follows (without the races).
    pub fn find_or_insert(&mut self, key: &VoxelKey, now: u32) -> Lookup {
        let cap = self.words.len() as u32;
        let c = key.checksum();
        for i in 0..self.max_probe {
            let s = key.probe_slot(i, cap) as usize;
            if entry_checksum(self.words[s]) == c {
                self.words[s] = pack_entry(c, now);
                return Lookup::Found(s as u32);
            }
        }
        for i in 0..self.max_probe {
            let s = key.probe_slot(i, cap) as usize;
            let w = self.words[s];
            if replaceable(w, now, self.stale) {
                self.words[s] = pack_entry(c, now);
                return if entry_checksum(w) == 0 {
                    Lookup::Reserved(s as u32)
                } else {
                    Lookup::Evicted(s as u32)
                };
            }
        }
        Lookup::Failed
    }
}

/// True when two slots can lie on one probe sequence of `max_probe` probes
/// (same tile offset and tile distance < max_probe with tiles; slot distance
/// < max_probe without), i.e. when equal checksums there would be a duplicate key.
pub fn share_probe_window(a: u32, b: u32, capacity: u32, max_probe: u32, tiles: bool) -> bool {
    let (a, b, n) = if tiles {
        if a % TILE_ENTRIES != b % TILE_ENTRIES {
            return false;
        }
        (a / TILE_ENTRIES, b / TILE_ENTRIES, capacity / TILE_ENTRIES)
    } else {
        (a, b, capacity)
    };
    let d = a.abs_diff(b);
    d.min(n - d) < max_probe
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(i: u32, tiles: bool) -> VoxelKey {
        let h = pcg_hash(i);
        VoxelKey {
            coord: [
                (h & 0xFF) as i32 - 128,
                ((h >> 8) & 0xFF) as i32 - 128,
                ((h >> 16) & 0xFF) as i32,
            ],
            meta: pack_meta(
                ((h >> 24) & 15) as i32 - 8,
                if tiles { (h >> 28) % 6 } else { NO_AXIS },
                if tiles { i & 3 } else { 0 },
                tiles,
            ),
        }
    }

    #[test]
    fn known_values_and_meta_fields() {
        // Reference values of the published functions.
        assert_eq!(pcg_hash(0), 129708002);
        assert_eq!(xxhash32(0), 0x3456_0F83);
        let k = VoxelKey {
            coord: [-3, 4, 5],
            meta: pack_meta(-7, 2, 9, true),
        };
        assert_eq!((k.level(), k.local(), k.tiles()), (-7, 9, true));
        assert_ne!(k.checksum(), 0);
        assert_eq!(age(3, u32::MAX - 1), 5, "ages wrap");
    }

    #[test]
    fn probe_sequences_stay_in_range_and_keep_the_tile_offset() {
        for tiles in [false, true] {
            for i in 0..500 {
                let k = key(i, tiles);
                for p in 0..16 {
                    let s = k.probe_slot(p, 256);
                    assert!(s < 256);
                    if tiles {
                        assert_eq!(s % 16, k.local());
                    }
                    if p > 0 {
                        assert!(share_probe_window(s, k.probe_slot(0, 256), 256, 16, tiles));
                    }
                }
            }
        }
    }

    #[test]
    fn a_tiles_sixteen_voxels_share_one_tile_of_the_table() {
        // §4: voxels "stored in spatially coherent 2D tiles". Until session
        // 43 the offset within the tile entered the index hash, and the 16
        // voxels of tile (10, −3, 7) landed in 16 different tiles of a 2^20
        // table (slots spread over 780,339 entries).
        for (coord, level, axis) in [([10, -3, 7], -6, 2), ([-5, 0, 1 << 20], 3, 5)] {
            let slots: Vec<u32> = (0..16)
                .map(|l| {
                    let k = VoxelKey {
                        coord,
                        meta: pack_meta(level, axis, l, true),
                    };
                    k.probe_slot(0, 1 << 20)
                })
                .collect();
            let tile = slots[0] / TILE_ENTRIES;
            for (l, s) in slots.iter().enumerate() {
                assert_eq!(
                    (s / TILE_ENTRIES, s % TILE_ENTRIES),
                    (tile, l as u32),
                    "{coord:?} voxel {l}"
                );
            }
        }
    }

    #[test]
    fn table_evicts_stale_entries_and_never_duplicates_a_key() {
        for tiles in [false, true] {
            let probe = if tiles { 4 } else { 8 };
            let mut t = CpuTable::new(64, probe, 2);
            let (mut evicted, mut failed) = (0, 0);
            for frame in 1..40u32 {
                for i in 0..40 {
                    let k = key(frame / 3 * 7 + i, tiles);
                    match t.find_or_insert(&k, frame) {
                        Lookup::Evicted(_) => evicted += 1,
                        Lookup::Failed => failed += 1,
                        _ => {}
                    }
                }
                for a in 0..64u32 {
                    for b in a + 1..64 {
                        let (wa, wb) = (t.words[a as usize], t.words[b as usize]);
                        if entry_checksum(wa) != 0 && entry_checksum(wa) == entry_checksum(wb) {
                            assert!(!share_probe_window(a, b, 64, probe, tiles), "duplicate key");
                        }
                    }
                }
            }
            assert!(
                evicted > 0 && failed > 0,
                "tiles {tiles}: {evicted} {failed}"
            );
        }
    }
}
