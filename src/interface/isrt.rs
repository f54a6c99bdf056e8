//! Interface of shaders/isrt/ (src/methods/isrt/).

use super::{read, write, CounterSlot, Interface, PushBlock, PushType};

crate::counter_slots! {
    /// Slots of `isrt.counters`.
    pub enum IsrtCounter("ISRT") {
        Reprojected = "REPROJECTED" => "reprojected_samples",
        Offscreen = "OFFSCREEN" => "reproject_offscreen",
        /// Samples dropped because the new eye sees their single-sided
        /// triangle from behind (first_hit.glsl `first_hit_culled`).
        Backfacing = "BACKFACING" => "reproject_backfacing",
        Kept = "KEPT" => "kept_samples",
        RetraceRays = "RETRACE_RAYS" => "retrace_rays",
        /// Retraced samples replaced by the closer hit their ray found
        /// (isrt/common.glsl `isrt_retrace`).
        RetraceReplaced = "RETRACE_REPLACED" => "retrace_replaced",
        NewRays = "NEW_RAYS" => "new_sample_rays",
        NewHits = "NEW_HITS" => "new_samples",
        Shaded = "SHADED" => "shaded_samples",
        BounceRays = "BOUNCE_RAYS",
        ShadowRays = "SHADOW_RAYS",
        /// Surface samples in the grid.
        Samples = "SAMPLES" => "samples",
        /// Background samples (rays that missed the scene).
        Background = "BACKGROUND" => "background_samples",
        /// Shading paths whose radiance came out ∞ or NaN, dropped (shade.comp).
        NonFiniteSamples = "NONFINITE_SAMPLES" => "non_finite_samples",
    }
}

/// Push constants of every isrt pass.
pub const PUSH: PushBlock = PushBlock {
    name: "ISRT",
    fields: &[
        // retrace tolerance, relative to the hit distance
        ("eps0", PushType::F32),
        // trace_pixel.comp: samples per pixel to fill up to (0 = every cell)
        ("n_target", PushType::U32),
        // shade.comp: `--accumulation` (common/accumulation.glsl accumulation_floor)
        ("accum_mode", PushType::U32),
        ("fixed_alpha", PushType::F32),
    ],
};

/// Specialization constant id of `M` (cells per pixel side).
pub const SPEC_M: u32 = 30;

pub const INTERFACE: Interface = Interface {
    name: "isrt",
    set: 1,
    bindings: &[
        read("frame"),
        read("fh_prev"),
        write("fh_cur"),
        read("rad_prev"),
        write("rad_cur"),
        write("claim"),
        write("out_color"),
        write("out_depth"),
        write("out_fh"),
        write("out_albedo"),
        write("counters"),
    ],
    push: &[PUSH],
    counters: &[IsrtCounter::TABLE],
    spec: &[("ISRT_M", SPEC_M)],
};
