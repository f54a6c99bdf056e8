//! The pass builder (src/gpu/compute_pass.rs) checks a pass's declarations
//! against its pipeline's shader interface (src/interface/) at record time:
//! a buffer left undeclared, declared with the wrong access, one too many, or
//! push constants of the wrong size fail with an error naming the pass and
//! the binding. And the per-pass descriptor sets used where
//! VK_KHR_push_descriptor is absent give the same result as push descriptors.
//! The kernel is the small dielectric test kernel (two buffers, one push
//! constant), so no scene is needed.
mod common;

use common::*;
use std::sync::Arc;
use stereocache::gpu::{
    shaders, Buffer, ComputePipeline, DescriptorLayout, DescriptorSet, GpuContext, GpuError,
    PassBinding, Recorder, Resource,
};
use stereocache::interface::dielectric;

struct Kernel {
    pipe: ComputePipeline,
    set: DescriptorSet,
    inp: Buffer,
    out: Buffer,
    n: u32,
}

fn kernel(ctx: &Arc<GpuContext>) -> Kernel {
    kernel_binding(ctx, PassBinding::Default)
}

fn kernel_binding(ctx: &Arc<GpuContext>, binding: PassBinding) -> Kernel {
    let n = 64u32;
    // Cases: normal +z, front face, direction down the normal, ior 1.5, u = 0.5.
    let cases: Vec<[f32; 4]> = (0..n)
        .flat_map(|i| {
            let t = i as f32 / n as f32;
            [
                [0.0, 0.0, 1.0, 1.0],
                [t * 0.5, 0.0, -1.0, 1.5],
                [0.5, t, 0.25, 0.0],
            ]
        })
        .collect();
    let inp = Buffer::with_data(
        ctx,
        "test.cases",
        bytemuck::cast_slice(&cases),
        Default::default(),
    )
    .unwrap();
    let out = Buffer::storage(ctx, "test.out", n as u64 * 32).unwrap();
    let layout = DescriptorLayout::buffers(ctx, 2).unwrap();
    let set = DescriptorSet::new(
        ctx,
        &layout,
        &[Resource::Buffer(&inp), Resource::Buffer(&out)],
    )
    .unwrap();
    let pipe = ComputePipeline::with_interface_binding(
        ctx,
        "dielectric_test",
        shaders::spirv("common/dielectric_test").expect("dielectric_test compiled"),
        &[layout],
        &dielectric::INTERFACE,
        Some(&dielectric::PUSH),
        &Default::default(),
        binding,
    )
    .unwrap();
    Kernel {
        pipe,
        set,
        inp,
        out,
        n,
    }
}

fn interface_error(e: GpuError) -> String {
    match e {
        GpuError::Interface(m) => m,
        other => panic!("expected an interface error, got {other}"),
    }
}

#[test]
fn an_undeclared_buffer_fails_at_record_time() {
    let ctx = context();
    let k = kernel(&ctx);
    let mut rec = Recorder::new(&ctx, 1).unwrap();
    // `outs` (binding 1) is deliberately left undeclared.
    let err = rec
        .compute("dielectric.undeclared", &k.pipe)
        .shared(&k.set)
        .read(&k.inp)
        .push(&k.n)
        .dispatch([1, 1, 1])
        .expect_err("a pass without its second buffer must not record");
    let msg = interface_error(err);
    assert!(
        msg.contains("pass dielectric.undeclared") && msg.contains("binding 1 `outs`"),
        "the error names the pass and the binding: {msg}"
    );
    assert!(msg.contains("not declared"), "{msg}");
    assert_eq!(rec.pass_count(), 0, "nothing was recorded");
    rec.finish().unwrap();
    assert_no_validation_messages(&ctx);
}

/// `update` and `copy` check their byte counts against the buffers they
/// were declared with before recording (a larger vkCmdUpdateBuffer or
/// vkCmdCopyBuffer is undefined behaviour that only the validation layer
/// would report); the sizes that fit record and run.
#[test]
fn update_and_copy_beyond_a_buffer_are_refused() {
    let ctx = context();
    let big = Buffer::storage(&ctx, "test.big", 256).unwrap();
    let small = Buffer::storage(&ctx, "test.small", 128).unwrap();
    // The panic message of recording `$pass` on a fresh recorder, which
    // must then hold no pass.
    macro_rules! refused {
        ($rec:ident => $pass:expr) => {{
            let mut $rec = Recorder::new(&ctx, 1).unwrap();
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| $pass));
            let rec = $rec;
            let msg = r
                .expect_err("the pass must be refused")
                .downcast::<String>()
                .map(|m| *m)
                .unwrap_or_default();
            assert_eq!(rec.pass_count(), 0, "nothing was recorded: {msg}");
            msg
        }};
    }
    let msg = refused!(rec => rec.pass("test.copy").read(&big).write(&small).copy(256));
    assert!(
        msg.contains("pass test.copy") && msg.contains("256 bytes"),
        "{msg}"
    );
    let msg = refused!(rec => rec.pass("test.copy0").read(&big).write(&small).copy(0));
    assert!(msg.contains("pass test.copy0"), "{msg}");
    let msg = refused!(rec => rec.pass("test.update").write(&small).update(&[0u8; 256]));
    assert!(
        msg.contains("pass test.update") && msg.contains("256 bytes"),
        "{msg}"
    );
    let mut rec = Recorder::new(&ctx, 2).unwrap();
    rec.pass("test.update").write(&big).update(&[7u8; 256]);
    rec.pass("test.copy").read(&big).write(&small).copy(128);
    assert_eq!(rec.pass_count(), 2);
    rec.finish().unwrap();
    assert_no_validation_messages(&ctx);
}

#[test]
fn wrong_access_extra_buffers_and_push_size_fail_at_record_time() {
    let ctx = context();
    let k = kernel(&ctx);
    let mut rec = Recorder::new(&ctx, 1).unwrap();
    let msg = interface_error(
        rec.compute("dielectric.access", &k.pipe)
            .shared(&k.set)
            .write(&k.inp)
            .write(&k.out)
            .push(&k.n)
            .dispatch([1, 1, 1])
            .unwrap_err(),
    );
    assert!(
        msg.contains("pass dielectric.access")
            && msg.contains("binding 0 `cases`")
            && msg.contains("is read"),
        "{msg}"
    );
    let msg = interface_error(
        rec.compute("dielectric.extra", &k.pipe)
            .shared(&k.set)
            .read(&k.inp)
            .write(&k.out)
            .write(&k.out)
            .push(&k.n)
            .dispatch([1, 1, 1])
            .unwrap_err(),
    );
    assert!(
        msg.contains("pass dielectric.extra") && msg.contains("test.out"),
        "{msg}"
    );
    let msg = interface_error(
        rec.compute("dielectric.push", &k.pipe)
            .shared(&k.set)
            .read(&k.inp)
            .write(&k.out)
            .push(&[k.n, 0u32])
            .dispatch([1, 1, 1])
            .unwrap_err(),
    );
    assert!(
        msg.contains("pass dielectric.push") && msg.contains("8 bytes"),
        "{msg}"
    );
    let msg = interface_error(
        rec.compute("dielectric.shared", &k.pipe)
            .read(&k.inp)
            .write(&k.out)
            .push(&k.n)
            .dispatch([1, 1, 1])
            .unwrap_err(),
    );
    assert!(msg.contains("shared set"), "{msg}");
    assert_eq!(rec.pass_count(), 0);
    rec.finish().unwrap();
    assert_no_validation_messages(&ctx);
}

fn run(ctx: &Arc<GpuContext>, k: &Kernel) -> Vec<[f32; 4]> {
    let mut rec = Recorder::new(ctx, 2).unwrap();
    rec.pass("clear").write(&k.out).fill(0);
    rec.compute("dielectric_test", &k.pipe)
        .shared(&k.set)
        .read(&k.inp)
        .write(&k.out)
        .push(&k.n)
        .dispatch([k.n.div_ceil(64), 1, 1])
        .unwrap();
    rec.finish().unwrap();
    k.out.download_pod().unwrap()
}

#[test]
fn per_pass_descriptor_sets_match_push_descriptors() {
    let ctx = context();
    let pushed = kernel(&ctx);
    // Pipelines keep the binding path they were created with.
    let fallback = kernel_binding(&ctx, PassBinding::DescriptorSets);
    assert!(!fallback.pipe.uses_push_descriptors());
    if !pushed.pipe.uses_push_descriptors() {
        // Then both runs take the fallback path and compare nothing.
        assert!(
            std::env::var("CI").is_err(),
            "device '{}' lacks VK_KHR_push_descriptor",
            ctx.caps.name
        );
        eprintln!("skipped: device lacks VK_KHR_push_descriptor");
        return;
    }
    let a = run(&ctx, &pushed);
    let b = run(&ctx, &fallback);
    assert!(
        a.iter().all(|v| v.iter().all(|x| x.is_finite())),
        "finite outputs"
    );
    assert!(
        a.iter().any(|v| v[3] == 1.0),
        "some cases sample a direction"
    );
    let bits = |v: &[[f32; 4]]| -> Vec<u32> { v.iter().flatten().map(|x| x.to_bits()).collect() };
    assert_eq!(bits(&a), bits(&b), "same bits through both binding paths");
    assert_no_validation_messages(&ctx);
}

/// A context shared between threads (it is `Sync`): recorders on several
/// threads at once, each with its own command pool, and uploads and
/// downloads through the context's one-time pool, whose use and the queue's
/// are serialised by locks. Every thread gets back what it wrote, and the
/// validation layer (its thread-safety checks included) reports nothing.
#[test]
fn threads_share_a_context() {
    let ctx = context();
    std::thread::scope(|scope| {
        for t in 0..4u32 {
            let ctx = &ctx;
            scope.spawn(move || {
                for i in 0..25u32 {
                    let v = t * 1000 + i;
                    let src = Buffer::with_data(
                        ctx,
                        "test.src",
                        bytemuck::cast_slice(&[v; 64]),
                        Default::default(),
                    )
                    .unwrap();
                    let dst = Buffer::storage(ctx, "test.dst", 256).unwrap();
                    let mut rec = Recorder::new(ctx, 2).unwrap();
                    rec.pass("test.fill").write(&dst).fill(0);
                    rec.pass("test.copy").read(&src).write(&dst).copy(256);
                    rec.finish().unwrap();
                    assert_eq!(
                        dst.download_pod::<u32>().unwrap(),
                        vec![v; 64],
                        "thread {t}, round {i}"
                    );
                }
            });
        }
    });
    assert_no_validation_messages(&ctx);
}
