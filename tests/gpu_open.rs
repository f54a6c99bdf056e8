//! Opening the GPU as probe → choose → open: `choose` rejects unusable
//! devices each with its reason and prefers as documented (pure data, no
//! Vulkan); `open` enables exactly the requested features (ray query only
//! when wanted) and the validation layer stays clean, also when a
//! submission outlives the watchdog and the context is abandoned.

mod common;
use common::*;
use glam::Vec3;
use std::sync::Arc;
use stereocache::gpu::{choose, Buffer, DeviceCaps, FeatureRequest, Features, GpuContext};
use stereocache::methods::RenderSettings;
use stereocache::rt::RtChoice;
use stereocache::scene::Material;

/// A usable device of `device_type` as `probe` would report it, with every
/// feature supported.
fn device(name: &str, device_type: &str) -> DeviceCaps {
    DeviceCaps {
        name: name.into(),
        device_type: device_type.into(),
        api_version: "1.3.0".into(),
        api: (1, 3),
        compute_queue_family: Some(0),
        supported: FeatureRequest::new(true, Features::default()).optional,
        timestamp_valid_bits: 64,
        ..Default::default()
    }
}

#[test]
fn choose_rejects_each_unusable_device_with_its_reason() {
    let mut old = device("Old GPU", "discrete GPU");
    old.api = (1, 1);
    old.api_version = "1.1.0".into();
    let mut graphics_only = device("Graphics GPU", "discrete GPU");
    graphics_only.compute_queue_family = None;
    let mut no_rq = device("No-RQ GPU", "discrete GPU");
    no_rq.supported.ray_query = false;
    let mut no_di = device("No-DI GPU", "discrete GPU");
    no_di.supported.descriptor_indexing = false;
    let mut no_ts = device("No-TS GPU", "discrete GPU");
    no_ts.timestamp_valid_bits = 0;
    let cpu = device("llvmpipe", "CPU");
    let devices = [old, graphics_only, no_rq, no_di, no_ts, cpu];
    let require = Features {
        ray_query: true,
        ..Default::default()
    };

    let c = choose(&devices, None, &require).unwrap();
    assert_eq!(c.chosen, 5, "the only device with every requirement");
    let reasons: Vec<(&str, &str, bool)> = c
        .rejected
        .iter()
        .map(|r| (r.device.as_str(), r.reason.as_str(), r.unusable))
        .collect();
    assert_eq!(
        reasons,
        [
            ("Old GPU", "no Vulkan 1.2 (has 1.1.0)", true),
            ("Graphics GPU", "no compute queue", true),
            ("No-RQ GPU", "lacks required ray_query", true),
            (
                "No-DI GPU",
                "no descriptor indexing (runtimeDescriptorArray, shaderSampledImageArrayNonUniformIndexing: the scene's texture array)",
                true
            ),
            ("No-TS GPU", "no timestamps on its compute queue (every pass is timed)", true),
        ]
    );

    // Without the requirement the discrete GPU lacking ray queries is
    // usable and preferred over the CPU.
    let c = choose(&devices, None, &Features::default()).unwrap();
    assert_eq!(c.chosen, 2);
    let cpu_reason = &c.rejected.iter().find(|r| r.index == 5).unwrap();
    assert!(!cpu_reason.unusable);
    assert_eq!(cpu_reason.reason, "discrete GPU preferred over CPU");

    // Nothing usable: one error naming every device and its reason.
    let e = choose(&devices[..3], None, &require)
        .unwrap_err()
        .to_string();
    for phrase in [
        "Old GPU: no Vulkan 1.2",
        "Graphics GPU: no compute queue",
        "No-RQ GPU: lacks required ray_query",
    ] {
        assert!(e.contains(phrase), "{phrase} missing from: {e}");
    }
}

#[test]
fn choose_prefers_by_type_and_honours_the_device_name() {
    let devices = [
        device("llvmpipe", "CPU"),
        device("Intel iGPU", "integrated GPU"),
        device("NVIDIA A", "discrete GPU"),
        device("NVIDIA B", "discrete GPU"),
    ];
    let none = Features::default();
    let c = choose(&devices, None, &none).unwrap();
    assert_eq!(c.chosen, 2, "first discrete GPU");
    assert_eq!(c.rejected.len(), 3);
    assert_eq!(
        c.rejected.iter().find(|r| r.index == 3).unwrap().reason,
        "NVIDIA A is enumerated first"
    );

    // --device: case-insensitive substring, first match in enumeration order.
    let c = choose(&devices, Some("nvidia b"), &none).unwrap();
    assert_eq!(c.chosen, 3);
    let c = choose(&devices, Some("LLVM"), &none).unwrap();
    assert_eq!(c.chosen, 0);
    assert!(c
        .rejected
        .iter()
        .all(|r| r.reason == "name does not match --device 'LLVM'" && !r.unusable));

    // A name that matches only an unusable device is refused, listing why.
    let mut devices = devices.to_vec();
    devices[0].compute_queue_family = None;
    let e = choose(&devices, Some("llvm"), &none)
        .unwrap_err()
        .to_string();
    assert!(e.contains("whose name contains 'llvm'"), "{e}");
    assert!(e.contains("llvmpipe (unusable: no compute queue)"), "{e}");
}

#[test]
fn the_request_resolves_to_required_plus_supported_optional_features() {
    let all = FeatureRequest::new(true, Features::default()).optional;
    // Ray query only when wanted, even where supported.
    let r = FeatureRequest::new(false, Features::default()).resolve(&all);
    assert!(!r.ray_query);
    assert_eq!(
        Features {
            ray_query: true,
            ..r
        },
        all,
        "everything else supported is enabled"
    );
    assert!(
        FeatureRequest::new(true, Features::default())
            .resolve(&all)
            .ray_query
    );
    // Never what the device lacks.
    let lacking = Features {
        push_descriptor: false,
        ray_query: false,
        ..all
    };
    let r = FeatureRequest::new(true, Features::default()).resolve(&lacking);
    assert_eq!(r, lacking);
}

fn open(want_ray_query: bool) -> Arc<GpuContext> {
    let mut o = gpu_options();
    o.want_ray_query = want_ray_query;
    Arc::new(GpuContext::new(&o).expect("a Vulkan 1.2 device (run scripts/setup.sh)"))
}

/// On the real device: `ctx.enabled` is the request resolved against
/// `ctx.caps.supported` (so ray queries are off when not wanted, however
/// supported), push descriptors and debug utils are on where supported, and
/// a software-backend frame with ray queries off is validation-clean.
#[test]
fn open_enables_exactly_the_requested_features() {
    for want in [false, true] {
        let ctx = open(want);
        let s = &ctx.caps.supported;
        assert_eq!(
            ctx.enabled,
            FeatureRequest::new(want, Features::default()).resolve(s),
            "want_ray_query={want}"
        );
        assert!(
            ctx.enabled.missing_from(s).is_empty(),
            "enabled but unsupported: {:?}",
            ctx.enabled.missing_from(s)
        );
        assert_eq!(ctx.enabled.ray_query, want && s.ray_query);
        assert_eq!(ctx.ray_query_enabled(), ctx.enabled.ray_query);
        assert_eq!(ctx.push_descriptor_enabled(), s.push_descriptor);
        assert_eq!(ctx.enabled.debug_utils, s.debug_utils);
        if ctx.validation_enabled {
            assert!(s.debug_utils, "the validation layer provides debug utils");
        }
        assert!(ctx.devices.len() == ctx.rejected.len() + 1);
        if !want {
            // Without ray queries the check below still runs; only the
            // "left off although supported" part is then vacuous.
            common::require(
                s.ray_query,
                "a device with ray queries (to see them left off)",
            );
            let scene = sphere_in_environment(
                Material::default(),
                Vec3::new(0.0, 0.0, -3.0),
                1.0,
                Vec3::splat(0.5),
            );
            let sess = session(&ctx, scene, RtChoice::Software);
            let cam = look_at_camera(Vec3::ZERO, Vec3::new(0.0, 0.0, -3.0), 60.0, 1.0);
            let settings = RenderSettings {
                width: 16,
                height: 16,
                spp: 1,
                max_bounces: 1,
                seed: 1,
                all_features: false,
                ..Default::default()
            };
            let f = render(&sess, "reference", cam, &settings);
            let centre = (8 * 16 + 8) as usize;
            assert_ne!(
                f.eyes[0].first_hit[centre][3],
                u32::MAX,
                "the sphere is hit"
            );
        }
        assert_no_validation_messages(&ctx);
    }
}

/// A submission that outlives the watchdog abandons the context: the error
/// says so, nothing pending is freed (before: vkFreeCommandBuffers on the
/// pending command buffer, a validation error and a crash at exit when the
/// driver ran the freed commands: with the old free this test dies of
/// SIGSEGV) and later submissions are refused.
#[test]
fn a_timed_out_submission_frees_nothing_in_use() {
    let mut o = gpu_options();
    o.timeout = Some(std::time::Duration::from_nanos(1));
    let ctx = Arc::new(GpuContext::new(&o).unwrap());
    let buf = Buffer::storage(&ctx, "big", 64 << 20).unwrap();
    let data = vec![7u8; 64 << 20];
    // lavapipe executes on its own thread, so a 1 ns wait on a 64 MiB
    // copy times out; a few tries in case the copy ever wins.
    let mut err = None;
    for _ in 0..8 {
        if let Err(e) = buf.upload(&data) {
            err = Some(e.to_string());
            break;
        }
    }
    let err = err.expect("a 64 MiB copy finished within 1 ns eight times");
    assert!(err.contains("did not finish buffer upload"), "{err}");
    assert!(ctx.is_abandoned());
    let later = buf.upload(&data).unwrap_err().to_string();
    assert!(later.contains("lost earlier"), "{later}");
    assert_no_validation_messages(&ctx);
}
