// The memoization table of material-graph outputs (Urbach 2023, thesis
// §5.3): one global hash table, open addressing, linear probing over D
// entries, lock-and-validate. Pure functions over three buffers that the
// including shader declares before including this file (coherent: other
// invocations' writes must be seen; MEMO_HASHES_ONLY: only the hashes and
// the probe sequence, no buffers):
//   uint  memo_keys[]    H1 of the entry's key; MEMO_EMPTY, MEMO_LOCK
//   uint  memo_stamps[]  two words per entry: the eviction time, then the
//                        entry's write version (odd while a writer holds
//                        the lock)
//   uvec4 memo_values[]  MEMO_RECORD uvec4 per entry (the graph outputs)
// The eviction time (thesis §5.3.3) comes from one of the thesis's two
// clocks:
// - the frame clock (default): the frame counter mod 2^32 that the caller
//   passes as `now`, compared by wrapping age;
// - the access clock (-DMEMO_CLOCK_COUNTER): a 64-bit atomic counter that
//   every stamp write advances. The including shader then declares, in
//   place of memo_stamps, `uint64_t memo_clock` followed by
//   `uint64_t memo_times[]`, two per entry: the stamp, then the version.
//   A stamp is raised by atomicMax, so lanes touching one entry at once
//   never leave it torn, and it only moves forward. 64 bits, as the thesis
//   chose: a 32-bit counter rolls over within seconds (eq. 5.11) and then
//   ranks old entries as new.
// CPU twin, bit for bit: src/materials/memo/table.rs (hashes, probing, the
// single-threaded model of find / insert / evict).
#ifndef MEMO_TABLE_GLSL
#define MEMO_TABLE_GLSL
// pcg_hash, hc_xxhash32: the hash functions of issue 14's hash table.
#include "hash_table/hash.glsl"

const uint MEMO_EMPTY = 0u;
const uint MEMO_LOCK = 0xFFFFFFFFu;
const uint MEMO_NONE = 0xFFFFFFFFu;
const uint MEMO_RECORD = 3u;   // uvec4 per entry: 12 words, the thesis's 11 channels + mask
// MEMO_NO_EVICTION: Table 6.2's "no eviction" row: a miss stores only
// into an empty entry of its window; once the window is full it stores
// nothing (memo_insert's MEMO_WINDOW_FULL).
const uint MEMO_RANDOM = 0u, MEMO_LRW = 1u, MEMO_LRU = 2u, MEMO_NO_EVICTION = 3u;
// memo_insert results
const uint MEMO_FILLED = 0u, MEMO_EVICTED = 1u, MEMO_PRESENT = 2u, MEMO_LOCK_FAILED = 3u,
           MEMO_WINDOW_FULL = 4u;

// The two graph hashes computed ahead of time (ID0, ID1 of eqs. 5.8-5.9).
uint memo_id0(uint graph) { return pcg_hash(graph); }
uint memo_id1(uint graph) { return hc_xxhash32(graph); }

// Eq. 5.8: H0 = hash(m ^ hash(u ^ hash(v ^ ID0))) with PCG.
uint memo_h0(uint graph, int level, ivec2 q) {
    return pcg_hash(uint(level) ^ pcg_hash(uint(q.x) ^ pcg_hash(uint(q.y) ^ memo_id0(graph))));
}

// Eq. 5.9 with a different function (xxHash32) and ID1, never derived from
// H0; remapped off the EMPTY and LOCK markers.
uint memo_h1(uint graph, int level, ivec2 q) {
    uint h = hc_xxhash32(uint(level) ^ hc_xxhash32(uint(q.x) ^ hc_xxhash32(uint(q.y) ^ memo_id1(graph))));
    return h == MEMO_EMPTY ? 1u : (h == MEMO_LOCK ? 0xFFFFFFFEu : h);
}

// Eq. 5.10: probing starts at I = H0 mod (S - D); the i-th probe is I + i,
// so a window never wraps. capacity > probe.
uint memo_slot(uint h0, uint i, uint capacity, uint probe) { return h0 % (capacity - probe) + i; }

#ifndef MEMO_HASHES_ONLY

// The protocol's steps (thesis §5.3.4), composed by memo_find and
// memo_insert; the stress test also runs them in a forced interleaving.
// Reader: the key was seen holding h1 -> its version v0 -> memo_read_record
// -> memo_validate (key still h1, version still v0 and even).
// Writer: memo_lock (version odd) -> memo_write_record -> memo_unlock
// (version even again, then the key).
// The version closes the thesis protocol's ABA hole: between a reader's two
// key reads the entry can be evicted for another key and filled with h1
// again (LRU and LRW pick the same victim over and over within a frame, all
// its stamps being equal), the key then reads h1 both times while the
// record read in between mixes two writes; any write in between moves the
// version (tests/memo.rs saw one such torn read in a stress run without it).
#ifdef MEMO_CLOCK_COUNTER
uint memo_version(uint s) { return uint(memo_times[2u * s + 1u]); }
void memo_version_bump(uint s) { atomicAdd(memo_times[2u * s + 1u], 1ul); }
// Stamps entry s with the access clock's next count.
void memo_stamp(uint s, uint now) { atomicMax(memo_times[2u * s], atomicAdd(memo_clock, 1ul) + 1ul); }
// LRU's stamp on a read: every read advances the clock.
void memo_touch(uint s, uint now) { memo_stamp(s, now); }
#else
uint memo_stamp_at(uint s) { return 2u * s; }
uint memo_version(uint s) { return memo_stamps[2u * s + 1u]; }
void memo_version_bump(uint s) { atomicAdd(memo_stamps[2u * s + 1u], 1u); }
// Stamps entry s with the frame `now`.
void memo_stamp(uint s, uint now) { memo_stamps[memo_stamp_at(s)] = now; }
// LRU's stamp on a read, skipped when the entry holds this frame's already.
void memo_touch(uint s, uint now) {
    if (memo_stamps[memo_stamp_at(s)] != now) memo_stamp(s, now);
}
#endif
void memo_read_record(uint s, out uvec4 r0, out uvec4 r1, out uvec4 r2) {
    memoryBarrierBuffer();
    r0 = memo_values[MEMO_RECORD * s];
    r1 = memo_values[MEMO_RECORD * s + 1u];
    r2 = memo_values[MEMO_RECORD * s + 2u];
    memoryBarrierBuffer();
}
// The key read again: still h1 with the version `v0` read before the record
// (even: no write was under way), or the read is refused (a miss).
// `reread` off only in the stress test, to show the test bites.
bool memo_validate(uint s, uint h1, uint v0, bool reread) {
    memoryBarrierBuffer();
    return !reread || (memo_keys[s] == h1 && (v0 & 1u) == 0u && memo_version(s) == v0);
}
// Exchanges the key word `seen` for LOCK (false when it changed: never
// spin), then makes the version odd.
bool memo_lock(uint s, uint seen) {
    if (atomicCompSwap(memo_keys[s], seen, MEMO_LOCK) != seen) return false;
    memo_version_bump(s);
    memoryBarrierBuffer();
    return true;
}
void memo_write_record(uint s, uvec4 r0, uvec4 r1, uvec4 r2) {
    memoryBarrierBuffer();
    memo_values[MEMO_RECORD * s] = r0;
    memo_values[MEMO_RECORD * s + 1u] = r1;
    memo_values[MEMO_RECORD * s + 2u] = r2;
}
// Writing the key unlocks the entry, after the record, the stamp and the
// version (even again).
void memo_unlock(uint s, uint h1, uint now) {
    memo_stamp(s, now);
    memoryBarrierBuffer();
    memo_version_bump(s);
    memoryBarrierBuffer();
    atomicExchange(memo_keys[s], h1);
}

// Linear search for h1 in the window (only the keys are read); on a match
// the record is read and validated. Returns the slot, or MEMO_NONE for a
// miss; `torn` tells a miss caused by a key that changed during the read.
// LRU stamps the entry with `now` on a hit.
uint memo_find(uint h0, uint h1, uint capacity, uint probe, bool reread, uint policy, uint now,
               out uvec4 r0, out uvec4 r1, out uvec4 r2, out bool torn) {
    torn = false;
    r0 = uvec4(0u); r1 = uvec4(0u); r2 = uvec4(0u);
    for (uint i = 0u; i < probe; ++i) {
        uint s = memo_slot(h0, i, capacity, probe);
        if (memo_keys[s] != h1) continue;
        uint v0 = memo_version(s);
        memo_read_record(s, r0, r1, r2);
        if (!memo_validate(s, h1, v0, reread)) { torn = true; return MEMO_NONE; }
        if (policy == MEMO_LRU) memo_touch(s, now);
        return s;
    }
    return MEMO_NONE;
}

// Wrapping age of a frame stamp: exact while real ages stay below 2^32
// frames (18 months at 90 Hz).
uint memo_age(uint now, uint stamp) { return now - stamp; }

// How old entry s is, larger = older, compared within a window: the frame
// clock's wrapping age + 1 (> 0), or the access clock's complement of the
// stamp (the smallest count is the oldest; no subtraction from a `now`,
// which other lanes' accesses may have passed since it was read). A stamp
// being written by another lane may read torn; it only steers the choice.
#ifdef MEMO_CLOCK_COUNTER
uint64_t memo_oldness(uint s, uint now) { return ~memo_times[2u * s]; }
#define MEMO_OLDNESS uint64_t
#else
uint memo_oldness(uint s, uint now) { return memo_age(now, memo_stamps[memo_stamp_at(s)]) + 1u; }
#define MEMO_OLDNESS uint
#endif

// The victim of an insert in h1's window (§5.3.3): an empty entry if there
// is one, else random (a hash of h1 and now picks the probe; if that entry
// is locked, the next unlocked one after it, cyclically — not the window's
// first, the tie rule's choice) or the oldest stamp (LRW: set on write, LRU:
// also on read; memo_oldness); no other entry under MEMO_NO_EVICTION.
// Locked entries are skipped.
// Returns MEMO_NONE when h1 is already present (`present`), when every
// entry it could take is locked (`seen` = MEMO_LOCK) or, without eviction,
// when the window is full (`seen` = MEMO_EMPTY); else `seen` is the key
// word the victim held.
uint memo_victim(uint h0, uint h1, uint capacity, uint probe, uint policy, uint now, out uint seen, out bool present) {
    uint victim = MEMO_NONE;
    MEMO_OLDNESS best = MEMO_OLDNESS(0u);
    uint pick = pcg_hash(h1 ^ (now * 0x9E3779B9u)) % probe;
    seen = MEMO_EMPTY;
    present = false;
    for (uint i = 0u; i < probe; ++i) {
        uint s = memo_slot(h0, i, capacity, probe);
        uint k = memo_keys[s];
        if (k == h1) { present = true; return MEMO_NONE; }
        if (k == MEMO_EMPTY) { seen = k; return s; }
        if (k == MEMO_LOCK) { if (victim == MEMO_NONE) seen = MEMO_LOCK; continue; }
        if (policy == MEMO_NO_EVICTION) continue;
        MEMO_OLDNESS score = policy == MEMO_RANDOM ? MEMO_OLDNESS(probe - (i + probe - pick) % probe) : memo_oldness(s, now);
        if (victim == MEMO_NONE || score > best) { victim = s; best = score; seen = k; }
    }
    return victim;
}

// Inserts the record for h1 (thesis §5.3.4): the victim's key word is
// exchanged for LOCK by compare-and-swap (never spin, never retry: on
// failure the value is used by this thread only), the record and stamp are
// written, then the key, which unlocks the entry. Without eviction a full
// window stores nothing (MEMO_WINDOW_FULL).
uint memo_insert(uint h0, uint h1, uint capacity, uint probe, uint policy, uint now,
                 uvec4 r0, uvec4 r1, uvec4 r2) {
    uint seen;
    bool present;
    uint s = memo_victim(h0, h1, capacity, probe, policy, now, seen, present);
    if (present) return MEMO_PRESENT;
    if (s == MEMO_NONE && seen != MEMO_LOCK) return MEMO_WINDOW_FULL;
    if (s == MEMO_NONE || !memo_lock(s, seen)) return MEMO_LOCK_FAILED;
    memo_write_record(s, r0, r1, r2);
    memo_unlock(s, h1, now);
    return seen == MEMO_EMPTY ? MEMO_FILLED : MEMO_EVICTED;
}
#endif   // MEMO_HASHES_ONLY
#endif
