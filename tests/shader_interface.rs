//! The SPIR-V reflection (src/gpu/reflect.rs) against the Rust shader
//! interface (src/interface/): every shipped shader's real reads and writes
//! agree with its group's table; a table that declares a written binding
//! `read` (a plain store or an atomic), or lacks a binding the shader uses,
//! is refused when the pipeline is made; the pass builder binds and tracks
//! only the bindings a shader uses, so the recorder's barriers follow the
//! real hazards. The kernel is shaders/common/reflect_test.comp.
mod common;

use common::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use stereocache::gpu::reflect::{check_interface, reflect, PassUse};
use stereocache::gpu::{
    shaders, Buffer, ComputePipeline, GpuContext, GpuError, PassBinding, Recorder,
};
use stereocache::interface::{self, read, reflect_test, write, Interface};

/// The interface group of shader `name` (`sample_cache/trace.software`):
/// the last `interface/<group>.glsl` its source includes, directly or
/// through other includes, other than the scene's and the frame's.
fn group_of(name: &str) -> String {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let base = name.split('.').next().unwrap();
    fn walk(file: &Path, root: &Path, seen: &mut Vec<PathBuf>, groups: &mut Vec<String>) {
        if seen.iter().any(|p| p == file) {
            return;
        }
        seen.push(file.to_path_buf());
        let text =
            std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        for rest in text
            .lines()
            .filter_map(|l| l.trim().strip_prefix("#include"))
        {
            let inc = rest.trim().trim_matches('"');
            match inc.strip_prefix("interface/") {
                Some(g) => groups.push(g.trim_end_matches(".glsl").to_string()),
                // Generated at scene load from the scene's material graphs
                // (issue 17); it declares no bindings of its own.
                None if inc == stereocache::materials::scene_shaders::INCLUDE => {}
                None => walk(&root.join(inc), root, seen, groups),
            }
        }
    }
    let mut groups = Vec::new();
    walk(
        &root.join(format!("{base}.comp")),
        &root,
        &mut Vec::new(),
        &mut groups,
    );
    groups.retain(|g| g != "scene" && g != "frame");
    groups
        .pop()
        .unwrap_or_else(|| panic!("shader {name} includes no interface header"))
}

#[test]
fn every_shipped_shader_matches_its_interface() {
    assert!(shaders::SHADERS.len() > 30, "the shader table is filled");
    for (name, spirv) in shaders::SHADERS {
        let group = group_of(name);
        let iface = interface::ALL
            .iter()
            .find(|i| i.name == group)
            .unwrap_or_else(|| panic!("shader {name}: no interface named {group}"));
        let used = reflect(spirv).unwrap_or_else(|e| panic!("shader {name}: {e}"));
        let uses = check_interface(name, &used, iface).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            uses.iter().any(|u| *u != PassUse::Unused),
            "shader {name} uses none of interface {group}'s bindings"
        );
    }
}

#[test]
fn reflection_tells_loads_stores_atomics_and_lengths_apart() {
    let used = reflect(shaders::spirv("common/reflect_test").unwrap()).unwrap();
    let b = |n: u32| used.get(0, n).map(|b| (b.reads, b.writes));
    assert_eq!(b(0), Some((true, false)), "src is loaded");
    assert_eq!(b(1), Some((false, true)), "dst is stored");
    assert_eq!(b(2), Some((true, true)), "count: an atomic add");
    assert_eq!(b(3), Some((false, false)), "sized: only its length");
    assert_eq!(b(4), None, "unused is not in the module");
    assert_eq!(used.bindings.len(), 4, "{used:?}");
    let q = |n: u32| used.get(0, n).map(|b| b.non_writable).unwrap();
    assert!(q(3) && !q(0) && !q(1), "readonly only on sized: {used:?}");
    let uses = check_interface("t", &used, &reflect_test::INTERFACE).unwrap();
    assert_eq!(
        uses,
        [
            PassUse::Read,
            PassUse::Write,
            PassUse::Write,
            PassUse::Bound,
            PassUse::Unused
        ]
    );
}

fn pipeline(ctx: &Arc<GpuContext>, iface: &'static Interface) -> Result<ComputePipeline, GpuError> {
    pipeline_binding(ctx, iface, PassBinding::Default)
}

fn pipeline_binding(
    ctx: &Arc<GpuContext>,
    iface: &'static Interface,
    binding: PassBinding,
) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::with_interface_binding(
        ctx,
        "reflect_test",
        shaders::spirv("common/reflect_test").unwrap(),
        &[],
        iface,
        None,
        &Default::default(),
        binding,
    )
}

fn interface_error(r: Result<ComputePipeline, GpuError>) -> String {
    match r {
        Err(GpuError::Interface(m)) => m,
        Err(other) => panic!("expected an interface error, got {other}"),
        Ok(_) => panic!("a wrong interface made a pipeline"),
    }
}

/// `dst` (a plain store) declared read.
static DST_READ: Interface = Interface {
    bindings: &[
        read("src"),
        read("dst"),
        write("count"),
        read("sized"),
        write("unused"),
    ],
    ..reflect_test::INTERFACE
};
/// `count` (only an atomic add) declared read.
static COUNT_READ: Interface = Interface {
    bindings: &[
        read("src"),
        write("dst"),
        read("count"),
        read("sized"),
        write("unused"),
    ],
    ..reflect_test::INTERFACE
};
/// Without `sized` (binding 3), which the shader uses.
static SHORT: Interface = Interface {
    bindings: &[read("src"), write("dst"), write("count")],
    ..reflect_test::INTERFACE
};

#[test]
fn a_written_binding_declared_read_is_refused_at_pipeline_creation() {
    let ctx = context();
    let msg = interface_error(pipeline(&ctx, &DST_READ));
    assert!(
        msg.contains("pipeline reflect_test")
            && msg.contains("writes binding 1 `dst`")
            && msg.contains("declares it read"),
        "the error names the pipeline, the binding and the direction: {msg}"
    );
    let msg = interface_error(pipeline(&ctx, &COUNT_READ));
    assert!(
        msg.contains("writes binding 2 `count`") && msg.contains("declares it read"),
        "an atomic is a write: {msg}"
    );
    let msg = interface_error(pipeline(&ctx, &SHORT));
    assert!(
        msg.contains("uses binding 3") && msg.contains("has 3 binding(s)"),
        "{msg}"
    );
    pipeline(&ctx, &reflect_test::INTERFACE).expect("the right interface");
    assert_no_validation_messages(&ctx);
}

struct Kernel {
    pipe: ComputePipeline,
    src: Buffer,
    dst: Buffer,
    count: Buffer,
    sized: Buffer,
    unused: Buffer,
}

const N: u32 = 128;

fn kernel(ctx: &Arc<GpuContext>, binding: PassBinding) -> Kernel {
    let src: Vec<u32> = (0..N).map(|i| 3 * i + 1).collect();
    Kernel {
        pipe: pipeline_binding(ctx, &reflect_test::INTERFACE, binding).unwrap(),
        src: Buffer::with_data(ctx, "t.src", bytemuck::cast_slice(&src), Default::default())
            .unwrap(),
        dst: Buffer::storage(ctx, "t.dst", N as u64 * 4).unwrap(),
        count: Buffer::storage(ctx, "t.count", 4).unwrap(),
        // Half as long: the kernel covers the first N/2 elements.
        sized: Buffer::storage(ctx, "t.sized", N as u64 * 2).unwrap(),
        unused: Buffer::storage(ctx, "t.unused", 16).unwrap(),
    }
}

/// Clears, runs the kernel, then fills `unused`, `sized` and `src` after it;
/// returns (dst, count, unused, barriers after the kernel and after each fill).
fn run(ctx: &Arc<GpuContext>, k: &Kernel) -> (Vec<u32>, u32, Vec<u32>, [u32; 4]) {
    let mut rec = Recorder::new(ctx, 5).unwrap();
    rec.pass("clear").write(&k.dst).write(&k.count).fill(0);
    rec.compute("reflect_test", &k.pipe)
        .read(&k.src)
        .write(&k.dst)
        .write(&k.count)
        .read(&k.sized)
        .write(&k.unused)
        .dispatch([N.div_ceil(64), 1, 1])
        .unwrap();
    let mut barriers = [rec.barrier_count(), 0, 0, 0];
    // Declared .write() but not in the module: neither bound nor tracked.
    rec.pass("fill.unused").write(&k.unused).fill(7);
    barriers[1] = rec.barrier_count();
    // Only its length was taken: no memory access to order.
    rec.pass("fill.sized").write(&k.sized).fill(9);
    barriers[2] = rec.barrier_count();
    // Read by the kernel: write after read.
    rec.pass("fill.src").write(&k.src).fill(0);
    barriers[3] = rec.barrier_count();
    rec.finish().unwrap();
    (
        k.dst.download_pod().unwrap(),
        k.count.download_pod::<u32>().unwrap()[0],
        k.unused.download_pod().unwrap(),
        barriers,
    )
}

#[test]
fn only_the_bindings_a_shader_uses_are_bound_and_tracked() {
    let ctx = context();
    let pushed = kernel(&ctx, PassBinding::Default);
    let fallback = kernel(&ctx, PassBinding::DescriptorSets);
    assert!(!fallback.pipe.uses_push_descriptors());
    for k in [&pushed, &fallback] {
        let (dst, count, unused, barriers) = run(&ctx, k);
        let want: Vec<u32> = (0..N)
            .map(|i| if i < N / 2 { 2 * (3 * i + 1) } else { 0 })
            .collect();
        assert_eq!(dst, want, "dst = 2 src over sized.length() elements");
        assert_eq!(count, N / 2);
        assert_eq!(unused, [7; 4], "the fill after the kernel");
        // clear -> kernel: read after write (dst, count) = 1 barrier; then
        // none for `unused` and `sized`, one for `src` (write after read).
        assert_eq!(
            barriers,
            [1, 1, 1, 2],
            "push descriptors: {}",
            k.pipe.uses_push_descriptors()
        );
    }
    assert_no_validation_messages(&ctx);
}

#[test]
fn a_binding_the_shader_writes_declared_read_fails_at_record_time() {
    let ctx = context();
    let k = kernel(&ctx, PassBinding::Default);
    let mut rec = Recorder::new(&ctx, 1).unwrap();
    let err = rec
        .compute("reflect_test.wrong", &k.pipe)
        .read(&k.src)
        .read(&k.dst)
        .write(&k.count)
        .read(&k.sized)
        .write(&k.unused)
        .dispatch([1, 1, 1])
        .expect_err("a written buffer declared read must not record");
    let GpuError::Interface(msg) = err else {
        panic!("expected an interface error, got {err}")
    };
    assert!(
        msg.contains("pass reflect_test.wrong")
            && msg.contains("binding 1 `dst` is written by shader reflect_test")
            && msg.contains(".read(t.dst)"),
        "{msg}"
    );
    assert_eq!(rec.pass_count(), 0, "nothing was recorded");
    rec.finish().unwrap();
    assert_no_validation_messages(&ctx);
}

/// A measurement, not a test: passes and barriers in the second frame of
/// every method (cornell, 40×30). `cargo test --test shader_interface --
/// --ignored --nocapture barriers`.
#[test]
#[ignore]
fn barriers_per_frame() {
    use stereocache::methods::{FrameInput, MethodKind, RenderSettings};
    let ctx = context();
    let s = session(
        &ctx,
        shipped("cornell"),
        stereocache::rt::RtChoice::Software,
    );
    let settings = RenderSettings {
        width: 40,
        height: 30,
        spp: 1,
        max_bounces: 2,
        seed: 1,
        ..Default::default()
    };
    let camera = default_camera(&s, 40, 30);
    for kind in MethodKind::ALL {
        let mut m = s.method(kind.name(), &settings).unwrap();
        render_at(m.as_mut(), 0, camera, None);
        let mut rec = Recorder::new(&ctx, 32).unwrap();
        let input = FrameInput {
            index: 1,
            camera: turning_head(&camera, 1, 2.0, 0.01),
            prev_camera: Some(camera),
        };
        let outputs = m.record(&mut rec, &input).unwrap();
        drop(outputs);
        println!(
            "{}: {} passes, {} barriers",
            kind.name(),
            rec.pass_count(),
            rec.barrier_count()
        );
        rec.finish().unwrap();
    }
    assert_no_validation_messages(&ctx);
}
