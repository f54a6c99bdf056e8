//! `bench specialization`: GPU frame time of pipelines specialized to the
//! scene's features against the all-features build, of each unused
//! feature's code, and of skipping passes with nothing to do. Every argument
//! is checked and every scene loaded before the GPU is opened.

use crate::cli::args::{self, GpuArgs, MethodList};
use crate::cli::common::{device_line, environment_kind, load_labelled_scenes, report_validation};
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use stereocache::camera::PoseTrace;
use stereocache::gpu::GpuContext;
use stereocache::methods::RenderSettings;
use stereocache::output;
use stereocache::replay::{trace_cameras, DEFAULT_FPS};
use stereocache::rt::RtChoice;
use stereocache::scene::DefaultLighting;
use stereocache::session::{CameraSelect, Session};
use stereocache::values::{Size, MAX_BOUNCES};

/// Arguments of `bench specialization`.
#[derive(Args)]
pub struct BenchSpecArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    /// Scenes, comma-separated: built-in names, .gltf/.glb files or directories.
    #[arg(long, default_value = "cornell,hairball,plane")]
    scenes: String,
    /// Lighting added to every scene (see `render --lighting`; default: sun-sky where a scene has no lighting of its own).
    #[arg(long, value_parser = args::lighting)]
    lighting: Option<DefaultLighting>,
    /// Ray backend.
    #[arg(long, default_value = "auto", value_parser = args::rt)]
    rt: RtChoice,
    #[arg(long, default_value = "naive,sample-cache,hash-cache")]
    methods: MethodList,
    /// Bounce counts, comma-separated (single-feature builds at the largest).
    #[arg(long, default_value = "3,0", value_parser = bounce_list)]
    bounces: BounceList,
    #[arg(long, default_value = "captures/mmsys18-user1.csv")]
    trace: PathBuf,
    /// Frames measured per build (after one warm-up frame).
    #[arg(long, default_value_t = 8, value_parser = args::frames)]
    frames: usize,
    #[arg(long, default_value = "64x48")]
    size: Size,
    /// Also write the table as CSV to this file.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `--bounces 3,0`: counts in 0..=[`MAX_BOUNCES`].
#[derive(Clone, Debug)]
pub struct BounceList(Vec<u32>);

fn bounce_list(s: &str) -> Result<BounceList, String> {
    let bad = |s: &str| {
        format!("bad --bounces '{s}': expected comma-separated counts in 0..={MAX_BOUNCES}")
    };
    let v: Vec<u32> = args::list_of(s, bad)?;
    if v.iter().any(|&b| b > MAX_BOUNCES) {
        return Err(bad(s));
    }
    Ok(BounceList(v))
}

/// `stereocache bench specialization`: every argument is checked and every
/// scene loaded before the GPU is opened, so bad input fails fast.
pub fn run(a: BenchSpecArgs) -> Result<()> {
    if let Some(out) = &a.out {
        crate::cli::common::check_out_file(out)?;
    }
    let Size {
        width: w,
        height: h,
    } = a.size;
    let (rt, lighting) = (a.rt, a.lighting.as_ref());
    let (methods, bounces) = (&a.methods.0, &a.bounces.0);
    let trace = PoseTrace::read_csv(&a.trace)?;
    stereocache::replay::check_bench_frames(&trace, DEFAULT_FPS, a.frames, 1)?;
    let scenes = load_labelled_scenes(&a.scenes, lighting)?;
    let ctx = std::sync::Arc::new(GpuContext::new(&a.gpu.options()?)?);
    println!("{}", device_line(&ctx.caps));
    println!(
        "{w}x{h} per eye, both eyes, 1 spp, bounces {}, trace {} ({} frames at {DEFAULT_FPS} Hz after 1 warm-up), builds interleaved frame by frame",
        bounces
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(","),
        a.trace.display(),
        a.frames
    );
    let base = RenderSettings {
        width: w,
        height: h,
        spp: 1,
        seed: 1,
        ..Default::default()
    };
    let mut rows = Vec::new();
    for (label, scene) in scenes {
        let triangles = scene.instanced_triangle_count();
        let session = Session::with_context(ctx.clone(), scene, rt)?;
        stereocache::bench::check_frame_poses(&session, a.frames + 1, DEFAULT_FPS)?;
        println!(
            "\nscene {label} ({triangles} triangles, backend {}): uses {}; lacks {}",
            session.backend,
            feature_names(&session, true).join(", "),
            feature_names(&session, false).join(", ")
        );
        let mut cameras = trace_cameras(
            &session,
            &trace,
            DEFAULT_FPS,
            w,
            h,
            &CameraSelect::Default,
            None,
            None,
            Some(a.frames + 1),
        )?;
        if cameras.len() < a.frames + 1 {
            bail!(
                "bad --frames {}: {} gives {} frames",
                a.frames,
                a.trace.display(),
                cameras.len()
            );
        }
        cameras.truncate(a.frames + 1);
        let r = stereocache::bench::bench_specialization(
            &session,
            &label,
            methods,
            bounces,
            &cameras,
            DEFAULT_FPS,
            &base,
        )?;
        print!("{}", stereocache::bench::spec_table(&r));
        rows.extend(r);
    }
    println!("\nall scenes:");
    print!("{}", stereocache::bench::spec_table(&rows));
    if let Some(out) = &a.out {
        let csv = stereocache::bench::spec_csv(&rows);
        output::write_text(out, &csv)?;
        println!("wrote {}", out.display());
    }
    report_validation(&ctx)
}

/// The feature flags `session`'s scene uses (`on`; with the environment's
/// kind) or lacks.
fn feature_names(session: &Session, on: bool) -> Vec<String> {
    let f = session.scene_gpu.features;
    let mut v: Vec<String> = stereocache::bench::FEATURE_FLAGS
        .iter()
        .filter(|n| stereocache::bench::has_feature(&f, n) == on)
        .map(|n| n.to_string())
        .collect();
    if on {
        v.push(format!(
            "environment: {}",
            session
                .scene
                .environment
                .as_ref()
                .map(environment_kind)
                .unwrap_or("none")
        ));
    }
    v
}
