//! `bench lights`: MSE at equal time of light sampling (MIS, NEE) against
//! BSDF sampling alone, on a static view, strategies interleaved.

use crate::cli::args::{self, GpuArgs};
use crate::cli::common::{device_line, environment_kind, load_labelled_scenes, report_validation};
use anyhow::Result;
use clap::Args;
use stereocache::gpu::GpuContext;
use stereocache::methods::{LightSampling, RenderSettings};
use stereocache::rt::RtChoice;
use stereocache::scene::DefaultLighting;
use stereocache::session::{CameraSelect, Session};
use stereocache::values::{int_in, Size, MAX_SPP};

#[derive(Args)]
pub struct BenchLightsArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    /// Scenes, comma-separated: built-in names, .gltf/.glb files or directories.
    #[arg(long, default_value = "cornell,plane")]
    scenes: String,
    /// Lighting added to every scene (see `render --lighting`; default: sun-sky where a scene has no lighting of its own).
    #[arg(long, value_parser = args::lighting)]
    lighting: Option<DefaultLighting>,
    /// Ray backend.
    #[arg(long, default_value = "auto", value_parser = args::rt)]
    rt: RtChoice,
    /// Strategies, comma-separated (the first is the equal-time baseline): bsdf, mis, nee.
    #[arg(long, default_value = "bsdf,mis,nee", value_parser = strategies)]
    strategies: Strategies,
    #[arg(long, default_value = "64x64")]
    size: Size,
    /// Samples per pixel of each measured frame.
    #[arg(long, default_value_t = 16, value_parser = args::spp)]
    spp: u32,
    /// Samples per pixel of the reference image (MIS, its own seed).
    #[arg(long, default_value_t = 2048, value_parser = int_in("--reference-spp", 1u32, MAX_SPP, "samples per pixel"))]
    reference_spp: u32,
    #[arg(long, default_value_t = 3, value_parser = args::bounces)]
    bounces: u32,
    /// Frames measured per strategy (after one warm-up frame).
    #[arg(long, default_value_t = 8, value_parser = args::frames)]
    frames: usize,
}

/// `--strategies bsdf,mis,nee` (the first is the equal-time baseline).
#[derive(Clone, Debug)]
pub struct Strategies(Vec<LightSampling>);

fn strategies(list: &str) -> Result<Strategies, String> {
    let mut v = Vec::new();
    for s in list.split(',').map(str::trim) {
        v.push(match s {
            "mis" => LightSampling::Mis,
            "nee" => LightSampling::Nee,
            "bsdf" => LightSampling::Bsdf,
            _ => {
                return Err(format!(
                    "bad --strategies: unknown strategy '{s}' (expected bsdf, mis or nee)"
                ))
            }
        });
    }
    Ok(Strategies(v))
}

pub fn run(a: BenchLightsArgs) -> Result<()> {
    let Size {
        width: w,
        height: h,
    } = a.size;
    let (rt, lighting, strategies) = (a.rt, a.lighting.as_ref(), &a.strategies.0);
    let scenes = load_labelled_scenes(&a.scenes, lighting)?;
    let ctx = std::sync::Arc::new(GpuContext::new(&a.gpu.options()?)?);
    println!("{}", device_line(&ctx.caps));
    println!(
        "{w}x{h} per eye, both eyes, {} spp, bounces {}, reference {} spp (MIS, two halves: its own variance is subtracted from each MSE), {} frames per strategy after 1 warm-up, interleaved frame by frame",
        a.spp, a.bounces, a.reference_spp, a.frames
    );
    let base = RenderSettings {
        width: w,
        height: h,
        spp: a.spp,
        max_bounces: a.bounces,
        seed: 1,
        ..Default::default()
    };
    let mut rows = Vec::new();
    for (label, scene) in scenes {
        let session = Session::with_context(ctx.clone(), scene, rt)?;
        let camera = session.camera(&CameraSelect::Default, w, h, None, None)?;
        println!(
            "scene {label}: backend {}, emissive triangles {}, environment {}",
            session.backend,
            session.scene_gpu.features.emissive_triangles,
            session
                .scene
                .environment
                .as_ref()
                .map(environment_kind)
                .unwrap_or("none")
        );
        rows.extend(stereocache::bench::bench_lights(
            &session,
            &label,
            camera,
            &base,
            strategies,
            a.reference_spp,
            a.frames,
        )?);
    }
    print!("{}", stereocache::bench::light_table(&rows));
    report_validation(&ctx)
}
