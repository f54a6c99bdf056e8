//! `bench rays`: primary and diffuse-bounce rays per second for each ray backend.

use crate::cli::args::{self, GpuArgs};
use crate::cli::common::{device_line, report_validation};
use anyhow::Result;
use clap::Args;
use std::sync::Arc;
use stereocache::gpu::GpuContext;
use stereocache::methods::FrameInput;
use stereocache::rt::RtChoice;
use stereocache::scene::DefaultLighting;
use stereocache::session::{CameraSelect, Session};
use stereocache::values::{int_in, Size};

#[derive(Args)]
pub struct RaysArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    #[arg(long, default_value = "hairball")]
    scene: String,
    #[arg(long, default_value = "sun-sky", value_parser = args::lighting)]
    lighting: DefaultLighting,
    #[arg(long, default_value = "256x256")]
    size: Size,
    /// Rounds of primary + bounce rays.
    #[arg(long, default_value_t = 4, value_parser = int_in("--repeats", 1u32, 1 << 16, "rounds"))]
    repeats: u32,
}

pub fn run(a: RaysArgs) -> Result<()> {
    let Size {
        width: w,
        height: h,
    } = a.size;
    let repeats = a.repeats;
    let loaded = Session::load_scene(&a.scene, &a.lighting)?;
    let ctx = Arc::new(GpuContext::new(&a.gpu.options()?)?);
    println!("{}", device_line(&ctx.caps));
    println!(
        "scene: {} ({} triangles), {}x{} per eye, both eyes, {} rounds",
        loaded.source.display(),
        loaded.instanced_triangle_count(),
        w,
        h,
        repeats
    );
    let mut results = Vec::new();
    let backends: Vec<RtChoice> = if ctx.ray_query_enabled() {
        vec![RtChoice::Software, RtChoice::Query]
    } else {
        vec![RtChoice::Software]
    };
    for rt in backends {
        let session = Session::with_context(ctx.clone(), loaded.clone(), rt)?;
        let cam = session.camera(&CameraSelect::Default, w, h, None, None)?;
        let r = stereocache::bench::bench_rays(
            &session,
            &FrameInput {
                index: 0,
                camera: cam,
                prev_camera: None,
            },
            w,
            h,
            repeats,
        )?;
        println!(
            "{:>9}: primary {:8.3} Mrays/s ({} rays, {:.2} ms)   diffuse bounce {:8.3} Mrays/s ({} rays, {:.2} ms)",
            r.backend,
            r.primary_mrays_per_s(),
            r.primary_rays,
            r.primary_ms,
            r.bounce_mrays_per_s(),
            r.bounce_rays,
            r.bounce_ms
        );
        results.push(r);
    }
    if let [s, q] = results.as_slice() {
        println!(
            "software / ray query time per ray: primary {:.2}x, bounce {:.2}x",
            q.primary_mrays_per_s() / s.primary_mrays_per_s(),
            q.bounce_mrays_per_s() / s.bounce_mrays_per_s()
        );
    } else {
        println!("(this device has no ray queries: only the software backend was measured)");
    }
    report_validation(&ctx)
}
