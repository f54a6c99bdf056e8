//! The memoization cache's state word array, shared by the host and every
//! rendering shader of a scene whose graphs are memoized (descriptor set 0,
//! `memo_state` in shaders/common/memo.glsl): the frame's parameters, then
//! the frame's counters, which the shaders count atomically and the host
//! reads back after each frame.

use super::settings::MemoSettings;

/// Words of parameters before the counters (the shader's `MEMO_S_*`).
pub const PARAM_WORDS: usize = 8;

/// Per-frame counters (the shader's `MEMO_C_*`, in this order).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct MemoCounters {
    /// Lookups that found their texel (record read and validated).
    pub hits: u64,
    /// Lookups that did not (the graph was evaluated at the texel centre).
    pub misses: u64,
    /// Misses stored into an empty entry.
    pub fills: u64,
    /// Misses stored over another key's entry.
    pub evictions: u64,
    /// Misses whose store found the entry locked or changed (the value was
    /// used by that hit only).
    pub lock_failures: u64,
    /// Hits refused because the key changed during the read (counted in
    /// `misses` as well).
    pub refused: u64,
    /// Hits of memoized kind evaluated directly, never cached: their
    /// material's graphs read more than uv set 0 (position, normal,
    /// tangent, set 1), or their uv lies beyond what the level's texel
    /// grid holds exactly (lod.rs `fits`).
    pub bypassed: u64,
    /// The right (second) eye's hits and misses, counted in `hits` and
    /// `misses` too (shaders/common/memo.glsl `sc_memo_eye`). "Second"
    /// where its work groups run after the left eye's (llvmpipe); Vulkan
    /// does not order them, so on a GPU this is the right eye's own hit
    /// rate (docs/MATERIALS.md).
    pub second_eye_hits: u64,
    pub second_eye_misses: u64,
    /// Tiles filled by the subgroup-cooperative fill (one per round: the
    /// subgroup's lanes evaluate one tile's texels together; 0 with the
    /// plain fill).
    #[serde(default)]
    pub cooperative_fills: u64,
    /// Misses that stored nothing because their probing window was full
    /// and eviction is disabled (`--memo-eviction none`).
    #[serde(default)]
    pub window_full: u64,
    /// Hits on a record the other eye filled in this frame (either eye;
    /// the fill's eye and frame are tagged in the record, memo.glsl
    /// `memo_fill_tag`): the reuse between the eyes, independent of the
    /// order the device runs their work groups in. Counted in `hits` too;
    /// 0 in passes that do not know their eye. "This frame" is the state's
    /// `now`: callers advance it per frame (`MemoGpu::begin_frame`).
    #[serde(default)]
    pub other_eye_hits: u64,
}

impl MemoCounters {
    /// The counters' words: each counter's low word, then each one's high
    /// word in the same order (`memo_add` in shaders/common/memo.glsl
    /// carries into it: one frame of a long render counts past 2^32).
    pub const COUNT: usize = 12;
    pub const WORDS: usize = 2 * Self::COUNT;

    pub fn from_words(w: &[u32]) -> MemoCounters {
        let word = |k: usize| w.get(k).copied().unwrap_or(0) as u64;
        let g = |k: usize| word(k) | word(k + Self::COUNT) << 32;
        MemoCounters {
            hits: g(0),
            misses: g(1),
            fills: g(2),
            evictions: g(3),
            lock_failures: g(4),
            refused: g(5),
            bypassed: g(6),
            second_eye_hits: g(7),
            second_eye_misses: g(8),
            cooperative_fills: g(9),
            window_full: g(10),
            other_eye_hits: g(11),
        }
    }

    /// hits / (hits + misses), `None` without lookups.
    pub fn hit_rate(&self) -> Option<f64> {
        let n = self.hits + self.misses;
        (n > 0).then(|| self.hits as f64 / n as f64)
    }

    /// The right eye's hits / lookups (`second_eye_hits`), `None` without
    /// lookups.
    pub fn second_eye_hit_rate(&self) -> Option<f64> {
        let n = self.second_eye_hits + self.second_eye_misses;
        (n > 0).then(|| self.second_eye_hits as f64 / n as f64)
    }

    /// The share of all lookups that hit a record the other eye filled in
    /// the same frame, `None` without lookups.
    pub fn other_eye_share(&self) -> Option<f64> {
        let n = self.hits + self.misses;
        (n > 0).then(|| self.other_eye_hits as f64 / n as f64)
    }

    pub fn add(&mut self, o: &MemoCounters) {
        self.hits += o.hits;
        self.misses += o.misses;
        self.fills += o.fills;
        self.evictions += o.evictions;
        self.lock_failures += o.lock_failures;
        self.refused += o.refused;
        self.bypassed += o.bypassed;
        self.second_eye_hits += o.second_eye_hits;
        self.second_eye_misses += o.second_eye_misses;
        self.cooperative_fills += o.cooperative_fills;
        self.window_full += o.window_full;
        self.other_eye_hits += o.other_eye_hits;
    }
}

/// The state words at the start of a frame: `now` (the frame counter the
/// eviction stamps use, from 1), the table's shape and policy, which hits
/// look up, the level-of-detail bias, and zeroed counters.
pub fn frame_words(s: &MemoSettings, now: u32) -> Vec<u32> {
    let mut w = vec![0u32; PARAM_WORDS + MemoCounters::WORDS];
    w[0] = now;
    w[1] = s.entries;
    w[2] = s.probe;
    w[3] = s.eviction as u32;
    w[4] = s.hits.flags();
    w[5] = s.bias.to_bits();
    w[6] = s.tile.trailing_zeros();
    w[7] = u32::from(s.bilinear);
    w
}

/// Bytes of the state buffer.
pub const STATE_BYTES: u64 = ((PARAM_WORDS + MemoCounters::WORDS) * 4) as u64;

#[cfg(test)]
mod tests {
    use super::*;

    /// A counter's high word (`memo_add`'s carries) is its upper 32 bits.
    #[test]
    fn counters_join_their_carry_words() {
        let mut w = vec![0u32; MemoCounters::WORDS];
        w[0] = 7; // hits, low
        w[MemoCounters::COUNT] = 2; // hits, high
        w[9] = u32::MAX; // cooperative fills, low
        w[9 + MemoCounters::COUNT] = 1;
        w[11] = 5; // other-eye hits, low
        w[11 + MemoCounters::COUNT] = 3;
        let c = MemoCounters::from_words(&w);
        assert_eq!(c.hits, (2u64 << 32) + 7);
        assert_eq!(c.cooperative_fills, (1u64 << 32) + u32::MAX as u64);
        assert_eq!(c.other_eye_hits, (3u64 << 32) + 5);
        assert_eq!(c.misses, 0);
        assert_eq!(
            STATE_BYTES as usize,
            4 * frame_words(&MemoSettings::default(), 1).len()
        );
    }
}
