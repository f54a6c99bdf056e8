//! Guard bands (src/gpu/guard.rs): with `GpuOptions::guard_bands` every
//! storage buffer is followed by a canary-filled band that no descriptor or
//! fill covers, and the shared frame loop fails a frame whose passes wrote
//! into one. On lavapipe device memory is host memory, so such a write
//! corrupts whatever follows the buffer (the heap corruption once seen in
//! tests/baselines). Known answers: a copy 16 bytes past a buffer's end
//! changes exactly 4 guard words starting at byte 0 past it; a fill of the
//! whole buffer and an in-bounds copy change none; and every method, in its
//! default and its other buffer-shaping configurations, on every shipped
//! scene writes no guard word over frames of a moving head. The image size
//! is not a multiple of the 8×8 workgroups, so border threads run.

mod common;
use common::*;
use std::sync::Arc;
use stereocache::gpu::{guard, Buffer, GpuContext, GpuError, Recorder};
use stereocache::methods::hybrid::HybridLookups;
use stereocache::methods::sample_cache::{Reproject, Shading};
use stereocache::methods::{
    FrameInput, HashCacheSettings, HybridConfig, IsrtSettings, MethodConfig, MethodKind,
    RenderSettings, SampleCacheSettings,
};
use stereocache::rt::RtChoice;
use stereocache::session::METHODS;

fn guarded_context() -> Arc<GpuContext> {
    let mut o = gpu_options();
    o.guard_bands = true;
    Arc::new(GpuContext::new(&o).expect("a Vulkan 1.2 device (run scripts/setup.sh)"))
}

#[test]
fn a_write_past_the_end_is_caught_and_named() {
    let ctx = guarded_context();
    assert!(ctx.guard_bands_enabled());
    let src = Buffer::storage(&ctx, "test.src", 64).unwrap();
    let dst = Buffer::storage(&ctx, "test.dst", 32).unwrap();
    assert_eq!(dst.size, 32, "the band is not part of the buffer's size");

    // In bounds: a fill of the whole buffer and a copy of its 32 bytes.
    let mut rec = Recorder::new(&ctx, 2).unwrap();
    rec.pass("fill").write(&dst).fill(7);
    rec.pass("copy.in").read(&src).write(&dst).copy(32);
    rec.finish().unwrap();
    guard::check(&ctx).expect("in-bounds writes leave every band intact");

    // 16 bytes past the end: the band's first 4 words.
    let mut rec = Recorder::new(&ctx, 1).unwrap();
    rec.pass("copy.over").read(&src).write(&dst).copy(48);
    rec.finish().unwrap();
    match guard::check(&ctx) {
        Err(GpuError::OutOfBounds(m)) => {
            assert!(
                m.contains("test.dst (byte 0 past its end, 4 of"),
                "message names the buffer and the overrun: {m}"
            );
            assert!(!m.contains("test.src"), "only the overrun buffer: {m}");
        }
        other => panic!("expected an out-of-bounds error, got {other:?}"),
    }
    assert_no_validation_messages(&ctx);
}

/// Every method's defaults, then the configurations that size or index
/// buffers differently: the sample cache with 16 slots, two-pass
/// reprojection, adaptive shading (the histogram) and its debug views; the
/// hash cache with debug views and without tiles; hybrid with per-sample
/// lookups; isrt with M = 2 (those on the Cornell box only: they change
/// sizes and indices, not what a scene exercises, and each costs its own
/// pipeline compiles). Three frames of a turning head each (frame 0 has no
/// history, frames 1 and 2 reproject); every frame's guard check is the
/// frame loop's.
#[test]
fn every_method_writes_only_inside_its_buffers_on_every_shipped_scene() {
    let ctx = guarded_context();
    let (w, h) = (21, 13);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 2,
        max_bounces: 2,
        seed: 5,
        ..Default::default()
    };
    let cache = SampleCacheSettings {
        slots: 16,
        reproject: Reproject::TwoPass,
        shading: Shading::Adaptive,
        debug_views: true,
        ..Default::default()
    };
    let hash = HashCacheSettings {
        debug_views: true,
        tiles: false,
        ..Default::default()
    };
    let defaults: Vec<(String, MethodConfig)> = METHODS
        .iter()
        .map(|m| (m.to_string(), m.parse::<MethodKind>().unwrap().into()))
        .collect();
    let variants: Vec<(String, MethodConfig)> = vec![
        (
            "sample-cache (16 slots, two-pass, adaptive, debug views)".into(),
            MethodConfig::SampleCache(cache),
        ),
        (
            "hash-cache (debug views, no tiles)".into(),
            MethodConfig::HashCache(hash),
        ),
        (
            "hybrid (per-sample lookups)".into(),
            MethodConfig::Hybrid(HybridConfig {
                lookups: HybridLookups::PerSample,
                ..Default::default()
            }),
        ),
        (
            "isrt (M = 2)".into(),
            MethodConfig::Isrt(IsrtSettings {
                m: 2,
                ..Default::default()
            }),
        ),
    ];
    for scene in ["cornell", "hairball", "plane"] {
        let s = session(&ctx, shipped(scene), RtChoice::Auto);
        let cam0 = default_camera(&s, w, h);
        let extra = if scene == "cornell" {
            variants.len()
        } else {
            0
        };
        for (what, config) in defaults.iter().chain(&variants[..extra]) {
            let mut m = s.create(config.clone(), &settings).unwrap();
            let mut prev = None;
            for f in 0..3 {
                let cam = turning_head(&cam0, f, 2.0, 0.004);
                let input = FrameInput {
                    index: f,
                    camera: cam,
                    prev_camera: prev,
                };
                if let Err(e) = m.render_frame(&input) {
                    panic!("{what} on {scene}, frame {f}: {e}");
                }
                prev = Some(cam);
            }
        }
    }
    assert_no_validation_messages(&ctx);
}
