// Counter-based randomness (DESIGN.md "Randomness"): PCG hashes seeded by
// (run seed, frame, eye, pixel, sample, bounce), reproducible bit for bit.
#ifndef RANDOM_GLSL
#define RANDOM_GLSL

// PCG-RXS-M-XS 32-bit hash (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering").
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

struct Rng { uint state; };

Rng rng_init(uint seed, uint frame, uint eye, uint pixel, uint sample_index) {
    uint h = pcg_hash(seed);
    h = pcg_hash(h ^ frame);
    h = pcg_hash(h ^ (eye * 0x9E3779B9u));
    h = pcg_hash(h ^ pixel);
    h = pcg_hash(h ^ (sample_index * 0x85EBCA6Bu));
    return Rng(h);
}

// A fresh stream for a bounce of the same path (keeps dimensions decorrelated).
Rng rng_fork(Rng r, uint bounce) { return Rng(pcg_hash(r.state ^ (bounce * 0xC2B2AE35u + 0x27D4EB2Fu))); }

float rng_next(inout Rng r) {
    r.state = pcg_hash(r.state);
    // 24 high-quality bits → [0, 1)
    return float(r.state >> 8) * (1.0 / 16777216.0);
}

vec2 rng_next2(inout Rng r) { return vec2(rng_next(r), rng_next(r)); }

// All 32 bits of the next number: for choosing among up to 2^32 items
// uniformly (lights.glsl sample_emitter), which a 24-bit float cannot do
// beyond a few thousand items.
uint rng_next_u32(inout Rng r) {
    r.state = pcg_hash(r.state);
    return r.state;
}
#endif
