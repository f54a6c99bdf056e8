//! CPU twin of the memoization table (`shaders/memo/table.glsl`), bit for
//! bit: tests/memo.rs runs `shaders/memo/hash_test.comp` on random keys and
//! compares. Also a single-threaded model of find / insert / evict, which
//! the tests run for 10 000 frames to check the table stays consistent.
//!
//! * **Key** (thesis §5.3.2): graph id, mip level m (texel density 2^m per
//!   unit of uv, any integer), quantised uv (û, v̂) = round(2^m (u, v)).
//! * **H0** (eq. 5.8) = pcg(m ⊕ pcg(û ⊕ pcg(v̂ ⊕ ID0))), ID0 = pcg(graph):
//!   picks the window.
//! * **H1** (eq. 5.9) = the same chain with xxHash32 and ID1 = xxh(graph):
//!   stored in the entry and compared. A different function and seed, never
//!   derived from H0 (a collision in H0 is not one in H1). Remapped off the
//!   markers: 0 (EMPTY) → 1, 0xFFFFFFFF (LOCK) → 0xFFFFFFFE.
//! * **Probing** (eq. 5.10): I = H0 mod (S − D), probes I, I+1, …, I+D−1
//!   (never wraps).
//! * **Eviction** (§5.3.3), within the window: an empty entry if any, else
//!   random (probe `pcg(H1 ⊕ now·0x9E3779B9) mod D`), LRW (oldest write
//!   stamp) or LRU (oldest read-or-write stamp), or none (Table 6.2's "no
//!   eviction": a full window stores nothing); locked entries are skipped.
//!   The stamps come from one of the thesis's two clocks ([`MemoClock`]):
//!   a frame counter mod 2^32 compared by wrapping age, exact below 2^32
//!   frames (18 months at 90 Hz), or an access counter that every stamp
//!   write advances, 64 bits wide as the thesis chose (32 bits roll over in
//!   seconds, eq. 5.11, and then rank old entries as new), raised by
//!   atomic max.

use crate::methods::hash_table::hash::{pcg_hash, xxhash32};

pub const EMPTY: u32 = 0;
pub const LOCK: u32 = 0xFFFF_FFFF;
/// 32-bit words of a record (the shader's `MEMO_RECORD` uvec4s).
pub const RECORD_WORDS: usize = 12;
/// Bytes of an entry besides its records with the frame clock: key word,
/// stamp, write version (the shader's seqlock word against the protocol's
/// ABA, table.glsl). The access clock's 64-bit stamp and version take 8
/// more ([`MemoClock::header_bytes`]).
pub const ENTRY_HEADER_BYTES: u64 = 4 + 4 + 4;
/// Bytes per non-tiled entry: the header and one record.
pub const ENTRY_BYTES: u64 = ENTRY_HEADER_BYTES + 4 * RECORD_WORDS as u64;

/// The eviction strategy (the shader's `MEMO_RANDOM`, `MEMO_LRW`, `MEMO_LRU`,
/// `MEMO_NO_EVICTION`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Eviction {
    Random = 0,
    Lrw = 1,
    Lru = 2,
    /// Thesis Table 6.2's "no eviction" row: a miss stores into an empty
    /// entry of its window only; a full window keeps what it holds.
    Disabled = 3,
}

impl Eviction {
    /// The `--memo-eviction` value.
    pub fn name(self) -> &'static str {
        match self {
            Eviction::Random => "random",
            Eviction::Lrw => "lrw",
            Eviction::Lru => "lru",
            Eviction::Disabled => "none",
        }
    }
}

/// Where LRW and LRU take the time of an access from (thesis §5.3.3 and
/// Table 6.2: "frame" and "counter").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MemoClock {
    /// The frame counter: cheap, but every entry stamped within one frame
    /// is equally old, so a table smaller than a frame's working set evicts
    /// entries the frame is still using (the thesis's tiled small-table
    /// collapse of LRW and LRU by frame).
    #[default]
    Frame,
    /// A 64-bit atomic counter that each stamp write advances (the shader's
    /// `MEMO_CLOCK_COUNTER`): exact order, one global atomic per access.
    Counter,
}

impl MemoClock {
    /// Bytes of an entry besides its records: the access clock's stamp and
    /// version are 64-bit words.
    pub fn header_bytes(self) -> u64 {
        match self {
            MemoClock::Frame => ENTRY_HEADER_BYTES,
            MemoClock::Counter => ENTRY_HEADER_BYTES + 8,
        }
    }

    /// 32-bit words of the stamps buffer per entry (stamp, version).
    pub fn stamp_words(self) -> u64 {
        match self {
            MemoClock::Frame => 2,
            MemoClock::Counter => 4,
        }
    }

    /// Bytes at the head of the stamps buffer: the access clock's 64-bit
    /// counter.
    pub fn counter_bytes(self) -> u64 {
        match self {
            MemoClock::Frame => 0,
            MemoClock::Counter => 8,
        }
    }
}

/// A cache key (thesis §5.3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MemoKey {
    pub graph: u32,
    pub level: i32,
    pub q: [i32; 2],
}

impl MemoKey {
    /// Eq. 5.8.
    pub fn h0(&self) -> u32 {
        let id0 = pcg_hash(self.graph);
        pcg_hash(
            (self.level as u32) ^ pcg_hash((self.q[0] as u32) ^ pcg_hash((self.q[1] as u32) ^ id0)),
        )
    }

    /// Eq. 5.9 (xxHash32, ID1), remapped off EMPTY and LOCK.
    pub fn h1(&self) -> u32 {
        let id1 = xxhash32(self.graph);
        let h = xxhash32(
            (self.level as u32) ^ xxhash32((self.q[0] as u32) ^ xxhash32((self.q[1] as u32) ^ id1)),
        );
        match h {
            EMPTY => 1,
            LOCK => LOCK - 1,
            h => h,
        }
    }
}

/// Slot of the i-th probe (eq. 5.10); `capacity > probe`.
pub fn slot(h0: u32, i: u32, capacity: u32, probe: u32) -> u32 {
    h0 % (capacity - probe) + i
}

/// Wrapping age of a stamp.
pub fn age(now: u32, stamp: u32) -> u32 {
    now.wrapping_sub(stamp)
}

/// How an insert ended (the shader's `MEMO_FILLED` …).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Insert {
    Filled(u32),
    Evicted(u32),
    Present,
    LockFailed,
    /// No empty entry in the window and eviction disabled: nothing stored.
    WindowFull,
}

/// A single-threaded model of the GPU table: the same search, victim choice
/// and stamps as the shader, without the races (so never LOCK).
pub struct CpuMemo {
    pub keys: Vec<u32>,
    /// Each entry's stamp: the frame (low 32 bits) or the access count.
    pub stamps: Vec<u64>,
    pub records: Vec<[u32; RECORD_WORDS]>,
    pub probe: u32,
    pub policy: Eviction,
    pub clock: MemoClock,
    /// The access clock's counter (the shader's `memo_clock`): the last
    /// count given out.
    pub ticks: u64,
}

impl CpuMemo {
    pub fn new(capacity: u32, probe: u32, policy: Eviction) -> CpuMemo {
        assert!(
            capacity > probe,
            "capacity {capacity} must exceed the probe distance {probe}"
        );
        CpuMemo {
            keys: vec![EMPTY; capacity as usize],
            stamps: vec![0; capacity as usize],
            records: vec![[0; RECORD_WORDS]; capacity as usize],
            probe,
            policy,
            clock: MemoClock::Frame,
            ticks: 0,
        }
    }

    /// The same with the access clock, its counter at `ticks`.
    pub fn with_counter(capacity: u32, probe: u32, policy: Eviction, ticks: u64) -> CpuMemo {
        CpuMemo {
            clock: MemoClock::Counter,
            ticks,
            ..CpuMemo::new(capacity, probe, policy)
        }
    }

    fn capacity(&self) -> u32 {
        self.keys.len() as u32
    }

    /// memo_stamp: the frame `now`, or the access clock's next count
    /// (raised to it: atomic max).
    fn stamp(&mut self, s: usize, now: u32) {
        self.stamps[s] = match self.clock {
            MemoClock::Frame => now as u64,
            MemoClock::Counter => {
                self.ticks = self.ticks.wrapping_add(1);
                self.stamps[s].max(self.ticks)
            }
        };
    }

    /// memo_oldness: larger = older.
    fn oldness(&self, s: usize, now: u32) -> u64 {
        match self.clock {
            MemoClock::Frame => age(now, self.stamps[s] as u32).wrapping_add(1) as u64,
            MemoClock::Counter => !self.stamps[s],
        }
    }

    /// The slot holding `k` and its record (memo_find); LRU stamps it.
    pub fn find(&mut self, k: &MemoKey, now: u32) -> Option<(u32, [u32; RECORD_WORDS])> {
        let (h0, h1) = (k.h0(), k.h1());
        for i in 0..self.probe {
            let s = slot(h0, i, self.capacity(), self.probe) as usize;
            if self.keys[s] == h1 {
                if self.policy == Eviction::Lru {
                    self.stamp(s, now);
                }
                return Some((s as u32, self.records[s]));
            }
        }
        None
    }

    /// The victim in `k`'s window (memo_victim), or `None` when `k` is
    /// present (`check_presence`; the thesis's insert does not look) or no
    /// entry can be taken; `saw_lock` is set where a locked entry was passed
    /// before any victim was found (memo_victim's `seen` = MEMO_LOCK: the
    /// shader then reports a lock failure, not a full window).
    fn victim(
        &self,
        k: &MemoKey,
        now: u32,
        check_presence: bool,
        saw_lock: &mut bool,
    ) -> Option<u32> {
        let (h0, h1) = (k.h0(), k.h1());
        let pick = pcg_hash(h1 ^ now.wrapping_mul(0x9E37_79B9)) % self.probe;
        let (mut victim, mut best) = (None, 0u64);
        *saw_lock = false;
        for i in 0..self.probe {
            let s = slot(h0, i, self.capacity(), self.probe);
            let key = self.keys[s as usize];
            if key == h1 && check_presence {
                return None;
            }
            if key == EMPTY {
                return Some(s);
            }
            if key == LOCK {
                *saw_lock |= victim.is_none();
                continue;
            }
            if self.policy == Eviction::Disabled {
                continue;
            }
            let score = match self.policy {
                // The pick, or the next unlocked entry after it (cyclic).
                Eviction::Random => (self.probe - (i + self.probe - pick) % self.probe) as u64,
                _ => self.oldness(s as usize, now),
            };
            if victim.is_none() || score > best {
                victim = Some(s);
                best = score;
            }
        }
        victim
    }

    /// Inserts `record` for `k` (memo_insert).
    pub fn insert(&mut self, k: &MemoKey, now: u32, record: [u32; RECORD_WORDS]) -> Insert {
        let mut saw_lock = false;
        let Some(s) = self.victim(k, now, true, &mut saw_lock) else {
            return if self.find_slot(k).is_some() {
                Insert::Present
            } else if !saw_lock {
                // Only without eviction does a window without a lock offer
                // no victim.
                Insert::WindowFull
            } else {
                Insert::LockFailed
            };
        };
        self.write(s, k, now, record)
    }

    /// The thesis's insert (§5.3.3: "I always insert a cache entry at the
    /// potentially incorrect location found by the linear search"): the
    /// victim is chosen without looking for `k` first, so a key filled by
    /// several lanes at once is stored several times. Not the shader's
    /// rule; for the eviction models of tests/memo.rs.
    pub fn insert_unchecked(
        &mut self,
        k: &MemoKey,
        now: u32,
        record: [u32; RECORD_WORDS],
    ) -> Insert {
        let mut saw_lock = false;
        match self.victim(k, now, false, &mut saw_lock) {
            Some(s) => self.write(s, k, now, record),
            None if !saw_lock => Insert::WindowFull,
            None => Insert::LockFailed,
        }
    }

    fn write(&mut self, s: u32, k: &MemoKey, now: u32, record: [u32; RECORD_WORDS]) -> Insert {
        let was = self.keys[s as usize];
        self.keys[s as usize] = k.h1();
        self.stamp(s as usize, now);
        self.records[s as usize] = record;
        if was == EMPTY {
            Insert::Filled(s)
        } else {
            Insert::Evicted(s)
        }
    }

    fn find_slot(&self, k: &MemoKey) -> Option<u32> {
        let (h0, h1) = (k.h0(), k.h1());
        (0..self.probe)
            .map(|i| slot(h0, i, self.capacity(), self.probe))
            .find(|&s| self.keys[s as usize] == h1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashes_avoid_the_markers_and_are_independent() {
        let mut same = 0;
        for i in 0..20_000u32 {
            let k = MemoKey {
                graph: i % 7,
                level: (i % 13) as i32 - 4,
                q: [i as i32 * 31 - 9000, -(i as i32)],
            };
            let (h0, h1) = (k.h0(), k.h1());
            assert!(h1 != EMPTY && h1 != LOCK);
            same += (h0 == h1) as u32;
        }
        assert_eq!(same, 0, "H1 equals H0 for some keys");
    }

    /// A key whose window (D = 8 of 16 entries) is full of other keys.
    fn full_window(policy: Eviction) -> (CpuMemo, MemoKey, Vec<u32>) {
        let mut t = CpuMemo::new(16, 8, policy);
        let k = MemoKey {
            graph: 3,
            level: 2,
            q: [5, -7],
        };
        let window: Vec<u32> = (0..8).map(|i| slot(k.h0(), i, 16, 8)).collect();
        for (j, &s) in window.iter().enumerate() {
            t.keys[s as usize] = 1000 + j as u32;
            t.stamps[s as usize] = 7;
        }
        (t, k, window)
    }

    /// Random eviction takes the hashed pick, or where it is locked the
    /// next unlocked entry after it, cyclically (it used to fall back to the
    /// window's first unlocked entry, the tie rule's choice).
    #[test]
    fn random_eviction_passes_a_locked_pick_to_the_next_entry() {
        let now: u32 = 7;
        let (mut t, k, window) = full_window(Eviction::Random);
        let pick = pcg_hash(k.h1() ^ now.wrapping_mul(0x9E37_79B9)) % 8;
        assert_eq!(
            t.insert(&k, now, [1; RECORD_WORDS]),
            Insert::Evicted(window[pick as usize])
        );
        for locked in [1, 2] {
            let (mut t, k, window) = full_window(Eviction::Random);
            for j in 0..locked {
                t.keys[window[((pick + j) % 8) as usize] as usize] = LOCK;
            }
            let want = window[((pick + locked) % 8) as usize];
            assert_eq!(
                t.insert(&k, now, [1; RECORD_WORDS]),
                Insert::Evicted(want),
                "{locked} locked"
            );
        }
    }

    /// The thesis's tie rule (§6.5): among entries all stamped this frame,
    /// LRW by the frame clock overwrites the window's first; so does the
    /// next insert of the same frame (the entry just written).
    #[test]
    fn tied_frame_stamps_evict_the_first_entry() {
        let (mut t, k, window) = full_window(Eviction::Lrw);
        assert_eq!(
            t.insert(&k, 7, [1; RECORD_WORDS]),
            Insert::Evicted(window[0])
        );
        // Another key with the same window.
        let k2 = (0..)
            .map(|x| MemoKey { q: [x, 11], ..k })
            .find(|k2| slot(k2.h0(), 0, 16, 8) == window[0] && k2.h1() != k.h1())
            .unwrap();
        assert_eq!(
            t.insert(&k2, 7, [2; RECORD_WORDS]),
            Insert::Evicted(window[0])
        );
        // The access clock orders the same inserts: the first insert took
        // the count's next stamp, so the second evicts the next-oldest.
        let (mut t, k, window) = full_window(Eviction::Lrw);
        t.clock = MemoClock::Counter;
        for (j, &s) in window.iter().enumerate() {
            t.stamps[s as usize] = 10 + j as u64;
        }
        t.ticks = 20;
        assert_eq!(
            t.insert(&k, 7, [1; RECORD_WORDS]),
            Insert::Evicted(window[0])
        );
        assert_eq!(
            t.insert(&k2, 7, [2; RECORD_WORDS]),
            Insert::Evicted(window[1])
        );
    }

    /// Without eviction a full window keeps its keys and stores nothing;
    /// an empty entry anywhere in it is still filled, and a present key is
    /// found.
    #[test]
    fn disabled_eviction_fills_empty_entries_only() {
        let (mut t, k, window) = full_window(Eviction::Disabled);
        let before = t.keys.clone();
        assert_eq!(t.insert(&k, 8, [1; RECORD_WORDS]), Insert::WindowFull);
        assert_eq!(
            t.insert_unchecked(&k, 8, [1; RECORD_WORDS]),
            Insert::WindowFull
        );
        assert_eq!(t.keys, before, "a full window changed");
        assert!(t.find(&k, 8).is_none());
        t.keys[window[5] as usize] = EMPTY;
        assert_eq!(
            t.insert(&k, 8, [2; RECORD_WORDS]),
            Insert::Filled(window[5])
        );
        assert_eq!(t.find(&k, 9), Some((window[5], [2; RECORD_WORDS])));
        assert_eq!(t.insert(&k, 9, [3; RECORD_WORDS]), Insert::Present);
        // A full window with a locked entry (without eviction, an empty one
        // another lane is filling): this lane lost the race for it, a lock
        // failure, as the shader counts it.
        let (mut t, k, window) = full_window(Eviction::Disabled);
        t.keys[window[3] as usize] = LOCK;
        assert_eq!(t.insert(&k, 8, [1; RECORD_WORDS]), Insert::LockFailed);
    }

    #[test]
    fn probes_stay_in_the_table_and_never_wrap() {
        for h0 in [0u32, 1, 12345, u32::MAX] {
            for i in 0..8 {
                let s = slot(h0, i, 64, 8);
                assert!(s < 64 && s >= slot(h0, 0, 64, 8));
            }
        }
    }
}
