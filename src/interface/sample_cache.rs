//! Interface of shaders/sample_cache/ (src/methods/sample_cache/): every
//! pass of the sample cache declares the same 28 buffers of set 1 (one list
//! for the whole group, see `SampleCache::pass`); each pass binds and tracks
//! only the ones its shader uses (src/gpu/reflect.rs).
//! `_prev` / `_cur`: the previous frame's cache (read) and this frame's
//! (written), the two halves of the ping-pong pair.

use super::{read, write, CounterSlot, Interface, PushBlock, PushType};

crate::counter_slots! {
    /// Slots of `sample_cache.counters` (32 slots are cleared by begin.comp;
    /// these are the ones the shaders use). GLSL: `C_SAMPLE_CACHE_<NAME>`.
    pub enum SampleCacheCounter("SAMPLE_CACHE") {
        /// Rays of the retrace pass (§3.4).
        RetraceRays = "RETRACE_RAYS" => "retrace_rays",
        /// Primary rays of new samples.
        NewRays = "NEW_RAYS" => "new_sample_rays",
        BounceRays = "BOUNCE_RAYS",
        ShadowRays = "SHADOW_RAYS",
        Holes = "HOLES" => "holes_filled",
        Added = "ADDED" => "samples_added",
        Purged = "PURGED" => "slots_purged",
        Reprojected = "REPROJECTED" => "reprojected_samples",
        ReprojectFull = "REPROJECT_FULL" => "reproject_no_free_slot",
        Offscreen = "OFFSCREEN" => "reproject_offscreen",
        Shaded = "SHADED" => "shaded_samples",
        Replaced = "REPLACED" => "last_visible_replaced",
        EdgePixels = "EDGE_PIXELS" => "edge_pixels",
        /// Visible samples after this frame's visibility passes (also
        /// reported per pixel as `visible_samples_per_pixel`).
        Visible = "VISIBLE" => "visible_samples",
        /// Primary rays of background samples (§3.3).
        BgRays = "BG_RAYS" => "background_rays",
        ReprojectedVisible = "REPROJECTED_VISIBLE" => "reprojected_visible",
        ReprojectedBackground = "REPROJECTED_BACKGROUND" => "reprojected_visible_background",
        /// Retrace rays of background samples (occlusion queries to infinity).
        RetraceBackground = "RETRACE_BACKGROUND" => "retrace_background_rays",
        /// Retrace rays of visible surface samples (occlusion queries that
        /// end before the sample); the rest of `retrace_rays` are
        /// closest-hit rays of invisible surface samples.
        RetraceOcclusion = "RETRACE_OCCLUSION" => "retrace_occlusion_rays",
        /// Retraced samples found behind a closer hit.
        RetraceOccluded = "RETRACE_OCCLUDED" => "retrace_occluded",
        /// Visible surface samples reprojected as invisible because the new
        /// eye sees their single-sided triangle from behind (eye rays pass
        /// through it: first_hit.glsl `first_hit_culled`).
        ReprojectedBackfacing = "REPROJECTED_BACKFACING" => "reprojected_backfacing",
        /// Shading paths whose radiance came out ∞ or NaN, dropped
        /// (averaged into the record as black; shade.comp).
        NonFiniteSamples = "NONFINITE_SAMPLES" => "non_finite_samples",
    }
}

/// Slots in `sample_cache.counters` (begin.comp clears this many).
pub const COUNTER_SLOTS: u64 = 32;

/// Push constants of every sample-cache pass.
pub const PUSH: PushBlock = PushBlock {
    name: "SAMPLE_CACHE",
    fields: &[
        // 1.0 = one shading invocation per pixel
        ("shading_rate", PushType::F32),
        ("fixed_alpha", PushType::F32),
        // retrace tolerance, relative to the hit distance
        ("eps0", PushType::F32),
        // Eq. 2
        ("eps1", PushType::F32),
        ("n_target", PushType::U32),
        ("delta", PushType::U32),
        // 0 none, 1 moments, 2 neighbourhood (stereo_blend.comp)
        ("blend_mode", PushType::U32),
        // R of §3.6
        ("sharpness", PushType::F32),
    ],
};

/// Specialization constant ids (GLSL `SPEC_SAMPLE_CACHE_*`).
pub mod spec {
    pub const SLOTS: u32 = 20;
    pub const RETRACE: u32 = 21;
    pub const SHADING: u32 = 22;
    pub const ACCUM: u32 = 23;
    pub const TWO_PASS: u32 = 24;
    pub const SHADING_STORAGE: u32 = 25;
    pub const DEBUG_VIEWS: u32 = 26;
    /// indirect_args.comp: which list's dispatch it writes (0 retrace, 1 shade).
    pub const ARGS_LIST: u32 = 27;
    /// shade_select.comp: 0 counts the importance histogram, 1 selects.
    pub const SELECT_PHASE: u32 = 28;
}

pub const INTERFACE: Interface = Interface {
    name: "sample_cache",
    set: 1,
    bindings: &[
        read("frame"),
        read("mask_prev"),
        write("mask_cur"),
        read("fh_prev"),
        write("fh_cur"),
        read("rad_prev"),
        write("rad_cur"),
        write("depth_min"),
        write("depth_max"),
        write("hist"),
        write("state"),
        write("shade_list"),
        write("target_src"),
        write("out_color"),
        write("out_m1"),
        write("out_m2"),
        write("out_depth"),
        write("out_fh"),
        write("out_albedo"),
        write("counters"),
        write("pixel_action"),
        write("pixel_stats"),
        write("debug"),
        write("out_blended"),
        write("retrace_list"),
        write("retrace_found"),
        write("indirect_args"),
        write("slot_depth"),
    ],
    push: &[PUSH],
    counters: &[SampleCacheCounter::TABLE],
    spec: &[
        ("SAMPLE_CACHE_SLOTS", spec::SLOTS),
        ("SAMPLE_CACHE_RETRACE", spec::RETRACE),
        ("SAMPLE_CACHE_SHADING", spec::SHADING),
        ("SAMPLE_CACHE_ACCUM", spec::ACCUM),
        ("SAMPLE_CACHE_TWO_PASS", spec::TWO_PASS),
        ("SAMPLE_CACHE_SHADING_STORAGE", spec::SHADING_STORAGE),
        ("SAMPLE_CACHE_DEBUG_VIEWS", spec::DEBUG_VIEWS),
        ("SAMPLE_CACHE_ARGS_LIST", spec::ARGS_LIST),
        ("SAMPLE_CACHE_SELECT_PHASE", spec::SELECT_PHASE),
    ],
};
