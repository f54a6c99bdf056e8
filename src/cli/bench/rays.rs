//! `bench rays`: primary and diffuse-bounce rays per second for each ray backend.

use crate::cli::args::{self, GpuArgs};
use crate::cli::common::{device_line, report_validation};
use anyhow::{anyhow, Result};
use clap::Args;
use std::sync::Arc;
use stereocache::gpu::GpuContext;
use stereocache::methods::FrameInput;
use stereocache::rt::{BvhLayout, RtChoice};
use stereocache::scene::DefaultLighting;
use stereocache::session::{CameraSelect, Session};
use stereocache::values::{int_in, Size};

#[derive(Args)]
pub struct RaysArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    #[arg(long, default_value = "hairball")]
    scene: String,
    /// Lighting added to the scene (see `render --lighting`; default: sun-sky where it has no lighting of its own).
    #[arg(long, value_parser = args::lighting)]
    lighting: Option<DefaultLighting>,
    #[arg(long, default_value = "256x256")]
    size: Size,
    /// Rounds of primary + bounce rays.
    #[arg(long, default_value_t = 4, value_parser = int_in("--repeats", 1u32, 1 << 16, "rounds"))]
    repeats: u32,
    /// Passes over the configurations (software flattened, software
    /// two-level, ray query), interleaved so drift hits all alike.
    #[arg(long, default_value_t = 1, value_parser = int_in("--interleave", 1u32, 64, "passes"))]
    interleave: u32,
}

pub fn run(a: RaysArgs) -> Result<()> {
    let Size {
        width: w,
        height: h,
    } = a.size;
    let repeats = a.repeats;
    stereocache::bench::check_ray_count(w, h, repeats).map_err(|e| anyhow!(e))?;
    let (loaded, lit) = Session::load_scene_lit(&a.scene, a.lighting.as_ref())?;
    eprintln!("{}", lit.line());
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
    let mut configs: Vec<(RtChoice, BvhLayout, &str)> = vec![
        (RtChoice::Software, BvhLayout::Flattened, "software"),
        (RtChoice::Software, BvhLayout::TwoLevel, "two-level"),
    ];
    if ctx.ray_query_enabled() {
        configs.push((RtChoice::Query, BvhLayout::Flattened, "query"));
    }
    let mut sessions = Vec::new();
    for (rt, layout, _) in &configs {
        sessions.push(Session::with_layout(
            ctx.clone(),
            loaded.clone(),
            *rt,
            Some(*layout),
        )?);
    }
    // Per configuration: (primary rays, primary ms, bounce rays, bounce ms) summed over passes.
    let mut sums = vec![(0u64, 0f64, 0u64, 0f64); configs.len()];
    for _ in 0..a.interleave {
        for (k, session) in sessions.iter().enumerate() {
            let cam = session.camera(&CameraSelect::Default, w, h, None, None)?;
            let r = stereocache::bench::bench_rays(
                session,
                &FrameInput {
                    index: 0,
                    camera: cam,
                    prev_camera: None,
                },
                w,
                h,
                repeats,
            )?;
            sums[k].0 += r.primary_rays;
            sums[k].1 += r.primary_ms;
            sums[k].2 += r.bounce_rays;
            sums[k].3 += r.bounce_ms;
        }
    }
    let rate = |rays: u64, ms: f64| rays as f64 / (ms * 1e3);
    for ((_, _, label), s) in configs.iter().zip(&sums) {
        println!(
            "{:>9}: primary {:8.3} Mrays/s ({} rays, {:.2} ms)   diffuse bounce {:8.3} Mrays/s ({} rays, {:.2} ms)",
            label,
            rate(s.0, s.1),
            s.0,
            s.1,
            rate(s.2, s.3),
            s.2,
            s.3
        );
    }
    let (f, t) = (sums[0], sums[1]);
    println!(
        "two-level / flattened time per ray: primary {:.2}x, bounce {:.2}x ({} interleaved passes)",
        rate(f.0, f.1) / rate(t.0, t.1),
        rate(f.2, f.3) / rate(t.2, t.3),
        a.interleave
    );
    // Moving the instances: the TLAS rebuild (CPU for two-level, device for
    // ray query) and the uploads, timed on the wall clock, every instance
    // moved (to where it is: the cost does not depend on the motion).
    let rest: Vec<glam::Mat4> = loaded.instances.iter().map(|i| i.transform).collect();
    for (k, (_, _, label)) in configs.iter().enumerate().skip(1) {
        let scene_gpu = &sessions[k].scene_gpu;
        let start = std::time::Instant::now();
        const MOVES: u32 = 8;
        for _ in 0..MOVES {
            scene_gpu.set_instance_transforms(&rest)?;
        }
        let ms = start.elapsed().as_secs_f64() * 1e3 / f64::from(MOVES);
        println!(
            "{label:>9}: moving {} instances (TLAS rebuild + upload) {ms:.2} ms wall per frame; \
             one primary round traces in {:.2} ms",
            rest.len(),
            sums[k].1 / f64::from(a.interleave * repeats)
        );
    }
    if let Some(q) = sums.get(2) {
        println!(
            "software / ray query time per ray: primary {:.2}x, bounce {:.2}x",
            rate(q.0, q.1) / rate(f.0, f.1),
            rate(q.2, q.3) / rate(f.2, f.3)
        );
    } else {
        println!("(this device has no ray queries: only the software backend was measured)");
    }
    report_validation(&ctx)
}
