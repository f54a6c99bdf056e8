//! The hash-grid radiance table (paper §4's HashCache, after Roth et al.
//! 2020, GI-1.0 (Boissé et al. 2023) and Gautron 2021), one component shared
//! by `hash-cache` and `hybrid` (and by later caches that hash).
//!
//! Table: `capacity` entries of 24 B ([`ENTRY_BYTES`]) — a 64-bit key word
//! (checksum << 32 | last access frame mod 2^32, updated with 64-bit
//! compare-and-swap) and an RGBA32F record (demodulated radiance running
//! mean, sample count). Keys, hashes and probing: [`hash`] (CPU twin of
//! `shaders/hash_table/hash.glsl`); find-or-insert, stale eviction and the
//! descriptor interface: `shaders/hash_table/table.glsl`.
//!
//! What a method using the table does per frame (both eyes per dispatch,
//! `z` = eye): [`HashTable::begin_frame`], [`HashTable::record_clear`]
//! (counters) → its own pass ([`HashTable::pass`]) that
//! finds or reserves one entry per pixel and writes the per-pixel requests
//! ([`PixelBuffers`]: first hit, ray, entry, status; the first toucher of an
//! entry this frame becomes its updater) → [`HashTable::record_update`]
//! (`update.comp`: one secondary path per updated entry into its running
//! mean, the pixel's own path where the lookup failed) → its own resolve →
//! [`HashTable::record_count`] (`count.comp`, live entries: a statistic, not
//! counted in the frame time); its counters are [`table_counters`].

pub mod counters;
pub mod hash;
mod pixels;
mod push;
mod table;

pub use counters::{table_counters, with_occupancy, OCCUPANCY};
pub use pixels::PixelBuffers;
pub use push::TablePush;
pub use table::{stamp, HashTable, PixelRequests, TableDesc, TableSnapshot, ENTRY_BYTES};
