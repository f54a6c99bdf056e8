//! Storage buffers are bounded by the device's `maxStorageBufferRange`
//! (issue 14 item 6: "bounded by what the device allows"): a buffer meant for
//! storage-descriptor binding that is larger is refused when it is created,
//! with one error naming the buffer, its size and the limit, before anything
//! is allocated; one of exactly the limit is created and binds without a
//! validation message. The limit is the device's own (128 MiB on lavapipe),
//! so the sizes here follow it exactly; no tolerance.

mod common;
use common::*;
use stereocache::gpu::{Buffer, GpuError};
use stereocache::methods::sample_cache::SampleCacheSettings;
use stereocache::rt::RtChoice;

/// The limit itself is accepted; four bytes more is refused with the
/// `StorageRange` error carrying the exact sizes, for each constructor of a
/// descriptor-bound buffer. Buffers reached only by copy or device address
/// (`Buffer::new`) are not limited; memory exhaustion there stays the
/// "GPU out of memory" error.
#[test]
fn buffers_over_the_storage_range_are_refused_at_creation() {
    let ctx = context();
    let limit = ctx.caps.max_storage_buffer_range;
    assert!(limit >= 1 << 27, "Vulkan guarantees at least 2^27 bytes");

    let at_limit = Buffer::storage(&ctx, "test.at_limit", limit).expect("exactly the limit");
    assert_eq!(at_limit.size, limit);
    drop(at_limit);

    for (what, r) in [
        (
            "test.storage",
            Buffer::storage(&ctx, "test.storage", limit + 4).map(|_| ()),
        ),
        (
            "test.indirect",
            Buffer::indirect_args(&ctx, "test.indirect", limit + 4).map(|_| ()),
        ),
    ] {
        match r {
            Err(GpuError::StorageRange {
                what: w,
                bytes,
                limit: l,
                ..
            }) => {
                assert_eq!((w.as_str(), bytes, l), (what, limit + 4, limit));
            }
            Err(e) => panic!("{what}: wrong error {e}"),
            Ok(()) => panic!("{what}: a buffer of limit + 4 bytes was created"),
        }
    }
    let line = Buffer::storage(&ctx, "test.storage", limit + 4)
        .err()
        .unwrap()
        .to_string();
    for part in [
        "test.storage".to_string(),
        format!("{} bytes", limit + 4),
        format!("({limit} bytes, maxStorageBufferRange)"),
        "--size".to_string(),
    ] {
        assert!(line.contains(&part), "{part:?} missing from: {line}");
    }
    assert!(!line.contains('\n'), "one line: {line}");

    // A copy-only buffer far larger than any device's memory: still the
    // out-of-memory error, not the range one.
    match Buffer::new(
        &ctx,
        "test.huge_copy",
        1 << 44,
        ash::vk::BufferUsageFlags::TRANSFER_DST,
        gpu_allocator::MemoryLocation::GpuOnly,
    ) {
        Err(GpuError::OutOfMemory { what, bytes }) => {
            assert_eq!((what.as_str(), bytes), ("test.huge_copy", 1 << 44));
        }
        Err(e) => panic!("wrong error for 16 TiB: {e}"),
        Ok(_) => panic!("a 16 TiB buffer was allocated"),
    }
    assert_no_validation_messages(&ctx);
}

/// The sample cache's largest buffers, `first_hit`/`radiance`
/// (2·W·H·N·16 bytes, N = 12 slots by default): at the largest height whose
/// buffers fit the limit the method is built and its descriptor sets written
/// without a validation message; one row more is refused naming
/// `sample_cache.first_hit0` with its exact size.
#[test]
fn sample_cache_just_under_the_limit_builds_and_one_row_more_is_refused() {
    let ctx = context();
    let limit = ctx.caps.max_storage_buffer_range;
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let cache = SampleCacheSettings::default();
    let per_row = 800 * 2 * cache.slots as u64 * 16;
    let h = (limit / per_row) as u32;
    assert!(800 * h as u64 <= 1 << 26, "inside the 2^26-pixel bound");

    let fits = cache_settings(800, h, cache.clone(), 1);
    drop(cache_method(&s, &fits));
    assert_no_validation_messages(&ctx);

    let over = cache_settings(800, h + 1, cache, 1);
    let r = stereocache::methods::sample_cache::SampleCache::new(
        &s.ctx,
        &s.scene_gpu,
        &s.scene.environment,
        &over,
        &over.cache,
    );
    match r {
        Err(GpuError::StorageRange { what, bytes, .. }) => {
            assert_eq!(
                (what.as_str(), bytes),
                ("sample_cache.first_hit0", (h as u64 + 1) * per_row)
            );
        }
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("800x{} built with over-range buffers", h + 1),
    }
    assert_no_validation_messages(&ctx);
}

/// The command line of the bug report: one `error:` line naming the buffer
/// and the limit, no validation message, no output written.
#[test]
fn render_over_the_limit_is_one_error_line_before_rendering() {
    let ctx = context();
    let limit = ctx.caps.max_storage_buffer_range;
    drop(ctx);
    // 800x600 at 12 slots is 184 320 000 bytes per first_hit buffer: over
    // lavapipe's 2^27; on a device with a larger limit pick a height over it.
    let h = (limit / (800 * 2 * 12 * 16) + 1).max(600);
    let size = format!("800x{h}");
    let out = std::env::temp_dir().join(format!("stereocache-range-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let args = [
        "render",
        "--method",
        "sample-cache",
        "--scene",
        "cornell",
        "--size",
        &size,
        "--out",
        out.to_str().unwrap(),
    ];
    let o = cli(120).args(args).output().unwrap();
    let line = single_error_line(&o, &format!("{args:?}"));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        line.contains("storage buffer sample_cache.first_hit0")
            && line.contains(&format!("{} bytes", 800 * h * 2 * 12 * 16))
            && line.contains(&format!("({limit} bytes, maxStorageBufferRange)")),
        "{line}"
    );
    assert!(!stderr.contains("vulkan validation"), "{stderr}");
    assert!(!out.join("left.exr").exists() && !out.join("summary.json").exists());
    let _ = std::fs::remove_dir_all(&out);
}

/// A memoization table over the range names its buffer and the option that
/// sizes it: 2^20 tiled entries of 4×4 texels are 768 MiB of records.
#[test]
fn memo_table_over_the_limit_names_memo_entries() {
    let ctx = context();
    let limit = ctx.caps.max_storage_buffer_range;
    drop(ctx);
    let entries: u64 = 1 << 20;
    let bytes = entries * 16 * 3 * 16;
    assert!(bytes > limit, "{bytes} fits this device's {limit}");
    let out = std::env::temp_dir().join(format!("stereocache-memo-range-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let e = entries.to_string();
    let args = [
        "render",
        "--scene",
        "procedural-uv:cornell",
        "--memo",
        "both",
        "--memo-tile",
        "4",
        "--memo-entries",
        &e,
        "--size",
        "8x8",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = cli(120).args(args).output().unwrap();
    let line = single_error_line(&o, &format!("{args:?}"));
    assert!(
        line.contains("storage buffer memo.values")
            && line.contains(&format!("{bytes} bytes"))
            && line.contains("--memo-entries"),
        "{line}"
    );
    assert!(!out.join("left.exr").exists() && !out.join("summary.json").exists());
    let _ = std::fs::remove_dir_all(&out);
}
