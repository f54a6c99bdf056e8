#version 460
// variant: MEMO_CLOCK_COUNTER
// Stress kernel of the lock-and-validate protocol (tests/memo.rs): every
// lane looks up `iterations` keys drawn from a small set in a small table;
// a hit's record must be f(key) (else a torn read), a miss inserts f(key).
// The test then checks every entry left in the table holds f(its key).
// MEMO_REREAD = false drops the reader's second key read, so the test can
// show that torn reads happen without it. Mode 1 (`mode`): lavapipe runs a
// subgroup's lanes in lockstep and its threads seldom meet inside the few
// instructions of a read, so the natural mix tears too rarely to assert on
// (0 or 1 of 262 144 lookups without the re-read); this mode forces the thesis's read-during-write sequence
// (§5.3.4) with the protocol's own steps: even lanes read entry s, odd
// lanes overwrite it with another key, the steps interleaved in program
// order (reader key, writer lock + record, reader record, writer unlock,
// reader validate), a workgroup barrier between steps, so the sequence is
// exact on any device. Each lane pair has its own entry. Mode 2 forces the
// ABA of the key-only protocol: the reader sees key A, the writer evicts
// the entry for B (lock, record, unlock), the reader reads B's record, the
// writer evicts it back to A, the reader validates: the key is A again, so
// only the version (table.glsl) tells the read was torn. Mode 3 is mode 0
// by lane 0 alone: one sequence of lookups and inserts that the CPU twin
// (src/materials/memo/table.rs CpuMemo) replays, so its stamps and victims
// can be compared bit for bit. The MEMO_CLOCK_COUNTER build stamps by the
// 64-bit access clock, which heads the stamps buffer.
#ifdef MEMO_CLOCK_COUNTER
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#endif
#include "interface/memo_stress.glsl"
layout(local_size_x = 64) in;
layout(set = SET_MEMO_STRESS, binding = B_MEMO_STRESS_MEMO_KEYS, std430) coherent buffer K { uint memo_keys[]; };
#ifdef MEMO_CLOCK_COUNTER
layout(set = SET_MEMO_STRESS, binding = B_MEMO_STRESS_MEMO_STAMPS, std430) coherent buffer S { uint64_t memo_clock; uint64_t memo_times[]; };
#else
layout(set = SET_MEMO_STRESS, binding = B_MEMO_STRESS_MEMO_STAMPS, std430) coherent buffer S { uint memo_stamps[]; };
#endif
layout(set = SET_MEMO_STRESS, binding = B_MEMO_STRESS_MEMO_VALUES, std430) coherent buffer V { uvec4 memo_values[]; };
layout(set = SET_MEMO_STRESS, binding = B_MEMO_STRESS_COUNTERS, std430) buffer C { uint counters[]; };
layout(push_constant) uniform Push { MEMO_STRESS_PUSH } pc;
layout(constant_id = SPEC_MEMO_REREAD) const bool REREAD = true;
#include "memo/table.glsl"

// f(key): word j of the record of the entry holding h1 (same in tests/memo.rs).
uint f(uint h1, uint j) { return pcg_hash(h1 ^ (j * 0x9E3779B9u)); }

uint ha(uint s) { return memo_h1(1u, 0, ivec2(int(s), 0)); }
uint hb(uint s) { return memo_h1(2u, 0, ivec2(int(s), 0)); }

// Mode 1; the test fills entry s with ha(s), f(ha(s)) beforehand.
void interleaved(uint lane) {
    uint s = lane >> 1;   // capacity >= lanes / 2
    bool reader = (lane & 1u) == 0u, writer = !reader;
    uint a = ha(s), b = hb(s);
    bool seen = false, locked = false, valid = false;
    uint v0 = 0u;
    uvec4 r0, r1, r2;
    if (reader) {
        seen = memo_keys[s] == a;
        v0 = memo_version(s);
    }
    barrier();
    if (writer) locked = memo_lock(s, a);
    barrier();
    if (writer && locked) {
        memo_write_record(s, uvec4(f(b, 0u), f(b, 1u), f(b, 2u), f(b, 3u)), uvec4(f(b, 4u), f(b, 5u), f(b, 6u), f(b, 7u)),
                          uvec4(f(b, 8u), f(b, 9u), f(b, 10u), f(b, 11u)));
        // barrier() orders execution, not buffer memory: make the record
        // visible before the reader's read, so the read sees B's record
        // (the torn case this mode forces) on any device.
        memoryBarrierBuffer();
    }
    barrier();
    if (reader && seen) memo_read_record(s, r0, r1, r2);
    barrier();
    if (writer && locked) memo_unlock(s, b, pc.now);
    barrier();
    if (reader && seen) valid = memo_validate(s, a, v0, REREAD);
    if (writer) atomicAdd(counters[locked ? C_MEMO_STRESS_EVICTED : C_MEMO_STRESS_LOCK_FAILED], 1u);
    if (!reader) return;
    if (!seen) { atomicAdd(counters[C_MEMO_STRESS_MISSES], 1u); return; }
    if (!valid) { atomicAdd(counters[C_MEMO_STRESS_REFUSED], 1u); atomicAdd(counters[C_MEMO_STRESS_MISSES], 1u); return; }
    bool ok = true;
    for (uint j = 0u; j < 4u; ++j) ok = ok && r0[j] == f(a, j) && r1[j] == f(a, 4u + j) && r2[j] == f(a, 8u + j);
    atomicAdd(counters[ok ? C_MEMO_STRESS_HITS : C_MEMO_STRESS_TORN_READS], 1u);
}

// f(h1)'s record.
void record_of(uint h1, out uvec4 r0, out uvec4 r1, out uvec4 r2) {
    r0 = uvec4(f(h1, 0u), f(h1, 1u), f(h1, 2u), f(h1, 3u));
    r1 = uvec4(f(h1, 4u), f(h1, 5u), f(h1, 6u), f(h1, 7u));
    r2 = uvec4(f(h1, 8u), f(h1, 9u), f(h1, 10u), f(h1, 11u));
}

// Mode 2 (the entry filled with ha(s) as in mode 1).
void aba(uint lane) {
    uint s = lane >> 1;
    bool reader = (lane & 1u) == 0u, writer = !reader;
    uint a = ha(s), b = hb(s);
    bool seen = false, locked = false, back = false;
    uint v0 = 0u;
    uvec4 r0, r1, r2, w0, w1, w2;
    if (reader) {
        seen = memo_keys[s] == a;
        v0 = memo_version(s);
    }
    barrier();
    if (writer) {
        locked = memo_lock(s, a);
        record_of(b, w0, w1, w2);
        if (locked) { memo_write_record(s, w0, w1, w2); memo_unlock(s, b, pc.now); }
    }
    barrier();
    if (reader && seen) memo_read_record(s, r0, r1, r2);
    barrier();
    if (writer && locked) {
        back = memo_lock(s, b);
        record_of(a, w0, w1, w2);
        if (back) { memo_write_record(s, w0, w1, w2); memo_unlock(s, a, pc.now); }
    }
    barrier();
    if (writer) atomicAdd(counters[locked && back ? C_MEMO_STRESS_EVICTED : C_MEMO_STRESS_LOCK_FAILED], 1u);
    if (!reader) return;
    if (!seen) { atomicAdd(counters[C_MEMO_STRESS_MISSES], 1u); return; }
    bool ok = true;
    for (uint j = 0u; j < 4u; ++j) ok = ok && r0[j] == f(a, j) && r1[j] == f(a, 4u + j) && r2[j] == f(a, 8u + j);
    bool key_only = memo_keys[s] == a;
    if (key_only && !ok) atomicAdd(counters[C_MEMO_STRESS_ABA_KEY_ONLY], 1u);
    if (!memo_validate(s, a, v0, REREAD)) { atomicAdd(counters[C_MEMO_STRESS_REFUSED], 1u); atomicAdd(counters[C_MEMO_STRESS_MISSES], 1u); return; }
    atomicAdd(counters[ok ? C_MEMO_STRESS_HITS : C_MEMO_STRESS_TORN_READS], 1u);
}

void main() {
    uint lane = gl_GlobalInvocationID.x;
    if (pc.mode == 1u) { interleaved(lane); return; }
    if (pc.mode == 2u) { aba(lane); return; }
    if (pc.mode == 3u && lane != 0u) return;
    uint hits = 0u, torn = 0u, refused = 0u, misses = 0u;
    uint results[5] = uint[5](0u, 0u, 0u, 0u, 0u);
    for (uint it = 0u; it < pc.iterations; ++it) {
        uint k = pcg_hash(pc.seed ^ pcg_hash(lane * pc.iterations + it)) % pc.keys;
        uint graph = k & 15u;
        int level = int((k >> 4) & 7u) - 2;
        ivec2 q = ivec2(int(k >> 7) - 3, int(k * 3u) - 100);
        uint h0 = memo_h0(graph, level, q), h1 = memo_h1(graph, level, q);
        uvec4 r0, r1, r2;
        bool was_torn;
        uint s = memo_find(h0, h1, pc.capacity, pc.probe, REREAD, pc.policy, pc.now, r0, r1, r2, was_torn);
        if (s != MEMO_NONE) {
            bool ok = true;
            for (uint j = 0u; j < 4u; ++j)
                ok = ok && r0[j] == f(h1, j) && r1[j] == f(h1, 4u + j) && r2[j] == f(h1, 8u + j);
            if (ok) ++hits; else ++torn;
            continue;
        }
        if (was_torn) ++refused;
        ++misses;
        uvec4 w0 = uvec4(f(h1, 0u), f(h1, 1u), f(h1, 2u), f(h1, 3u));
        uvec4 w1 = uvec4(f(h1, 4u), f(h1, 5u), f(h1, 6u), f(h1, 7u));
        uvec4 w2 = uvec4(f(h1, 8u), f(h1, 9u), f(h1, 10u), f(h1, 11u));
        ++results[memo_insert(h0, h1, pc.capacity, pc.probe, pc.policy, pc.now, w0, w1, w2)];
    }
    atomicAdd(counters[C_MEMO_STRESS_HITS], hits);
    atomicAdd(counters[C_MEMO_STRESS_TORN_READS], torn);
    atomicAdd(counters[C_MEMO_STRESS_REFUSED], refused);
    atomicAdd(counters[C_MEMO_STRESS_MISSES], misses);
    for (uint r = 0u; r < 5u; ++r) atomicAdd(counters[C_MEMO_STRESS_FILLED + r], results[r]);
}
