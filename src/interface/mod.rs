//! The shader interface, written once in Rust: for every group of compute
//! shaders, the per-pass storage buffers in binding order (name and access),
//! the push-constant blocks, the counter slots and the specialization
//! constant ids. build.rs includes this module (plain Rust, no dependencies)
//! and writes one GLSL header per group into `OUT_DIR/interface/` (included
//! as `#include "interface/<group>.glsl"`), so the shaders use the generated
//! names (`layout(set = 1, binding = B_REFERENCE_ACCUM)`, `C_TAA_CLIPPED`,
//! `REFERENCE_TRACE_PUSH`) and the two sides cannot drift. At record time
//! the pass builder (src/gpu/compute_pass.rs) checks each pass's
//! `.read()`/`.write()` declarations against the same table.

pub mod bench;
pub mod debug_normals;
pub mod dielectric;
pub mod glsl;
pub mod hash_cache;
pub mod hash_table;
pub mod hybrid;
pub mod isrt;
pub mod memo;
pub mod packing_test;
pub mod reference;
pub mod reflect_test;
pub mod sample_cache;
pub mod scene;
pub mod taa;
mod types;

pub use types::*;

/// Every interface group; build.rs writes a header for each.
pub const ALL: &[&Interface] = &[
    &scene::INTERFACE,
    &reference::INTERFACE,
    &taa::INTERFACE,
    &isrt::INTERFACE,
    &sample_cache::INTERFACE,
    &bench::RAYS,
    &bench::SCATTER,
    &bench::SCATTER_SLOTS,
    &dielectric::INTERFACE,
    &hash_table::INTERFACE,
    &hash_table::TEST,
    &hash_cache::INTERFACE,
    &hybrid::INTERFACE,
    &debug_normals::INTERFACE,
    &reflect_test::INTERFACE,
    &memo::HASH_TEST,
    &memo::STRESS,
    &packing_test::INTERFACE,
];

/// camera.glsl's `FrameBuf` (the per-frame stereo camera, `FrameParams`):
/// every interface whose shaders include camera.glsl has `frame` at this
/// set and binding (asserted in the tests below).
pub const FRAME_SET: u32 = 1;
pub const FRAME_BINDING: u32 = 0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_where_camera_glsl_reads_it() {
        for i in ALL {
            if let Some(pos) = i.bindings.iter().position(|b| b.name == "frame") {
                assert_eq!(
                    (i.set, pos as u32),
                    (FRAME_SET, FRAME_BINDING),
                    "{}",
                    i.name
                );
                assert_eq!(i.bindings[pos].access, Access::Read, "{}", i.name);
            }
        }
    }

    #[test]
    fn names_are_unique() {
        let mut groups: Vec<&str> = ALL.iter().map(|i| i.name).collect();
        groups.sort();
        groups.dedup();
        assert_eq!(groups.len(), ALL.len(), "interface group names");
        for i in ALL {
            let mut b: Vec<&str> = i.bindings.iter().map(|b| b.name).collect();
            b.sort();
            b.dedup();
            assert_eq!(b.len(), i.bindings.len(), "binding names of {}", i.name);
        }
    }

    /// Every path-tracing method reports its dropped (∞/NaN) paths under
    /// the one name replay's warning reads.
    #[test]
    fn dropped_paths_share_one_report_name() {
        let name = Some(crate::replay::NON_FINITE_SAMPLES);
        assert_eq!(
            reference::ReferenceCounter::NonFiniteSamples.report_name(),
            name
        );
        assert_eq!(
            sample_cache::SampleCacheCounter::NonFiniteSamples.report_name(),
            name
        );
        assert_eq!(isrt::IsrtCounter::NonFiniteSamples.report_name(), name);
        assert_eq!(
            hash_table::TableCounter::NonFiniteSamples.report_name(),
            name
        );
        assert_eq!(hybrid::HybridCounter::NonFiniteSamples.report_name(), name);
    }

    #[test]
    fn push_block_sizes_follow_std430() {
        let p = PushBlock {
            name: "T",
            fields: &[
                ("a", PushType::U32),
                ("b", PushType::Vec2),
                ("c", PushType::F32),
            ],
        };
        // a at 0, b aligned to 8, c at 16, block rounded to its 8-byte alignment.
        assert_eq!(p.size(), 24);
        assert_eq!(reference::TRACE_PUSH.size(), 24);
        let h = glsl::header(&reference::INTERFACE);
        assert!(h.contains("#define B_REFERENCE_COUNTERS 5"), "{h}");
        assert!(
            h.contains("const uint C_REFERENCE_SHADOW_RAYS = 2u;"),
            "{h}"
        );
    }
}
