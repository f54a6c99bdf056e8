//! `bench scaling`: frame time per method against pixels and triangles.

use crate::cli::args::{self, GpuArgs, MethodList};
use crate::cli::common::{device_line, report_validation};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use std::sync::Arc;
use stereocache::camera::{PoseTrace, StereoCamera};
use stereocache::gpu::GpuContext;
use stereocache::methods::{MethodKind, RenderSettings};
use stereocache::replay::{trace_cameras, DEFAULT_FPS};
use stereocache::rt::RtChoice;
use stereocache::session::{CameraSelect, Session};
use stereocache::values::Size;

#[derive(Args)]
pub struct ScalingArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    /// Ray backend.
    #[arg(long, default_value = "software", value_parser = args::rt)]
    rt: RtChoice,
    #[arg(long, default_value = "captures/mmsys18-user1.csv")]
    trace: PathBuf,
    /// Frames measured per point (after one warm-up frame).
    #[arg(long, default_value_t = 6, value_parser = args::frames)]
    frames: usize,
    /// Base size per eye (×1 pixels).
    #[arg(long, default_value = "48x36")]
    size: Size,
    #[arg(long, default_value = "sample-cache,hash-cache,taa,naive")]
    methods: MethodList,
}

pub fn run(a: ScalingArgs) -> Result<()> {
    let Size {
        width: w0,
        height: h0,
    } = a.size;
    let (rt, frames, trace) = (a.rt, a.frames, &a.trace);
    let methods = &a.methods.0;
    let trace_data = PoseTrace::read_csv(trace)?;
    let ctx = Arc::new(GpuContext::new(&a.gpu.options()?)?);
    let c = &ctx.caps;
    println!("{}", device_line(c));
    println!(
        "trace {} ({frames} frames after 1 warm-up per point, methods interleaved frame by frame), 3 bounces, both eyes",
        trace.display()
    );
    let base = |w: u32, h: u32| RenderSettings {
        width: w,
        height: h,
        spp: 1,
        max_bounces: 3,
        seed: 1,
        ..Default::default()
    };
    let cameras_for = |s: &Session, w: u32, h: u32| -> Result<Vec<StereoCamera>> {
        let mut cams = trace_cameras(
            s,
            &trace_data,
            DEFAULT_FPS,
            w,
            h,
            &CameraSelect::Default,
            None,
            None,
        )?;
        cams.truncate(frames + 1);
        Ok(cams)
    };
    // Pixels.
    let session = Session::with_context(
        ctx.clone(),
        stereocache::scene::generate("hairball").expect("built-in"),
        rt,
    )?;
    println!(
        "\nresolution scaling (hairball, {} backend): GPU ms per stereo frame",
        session.backend
    );
    let factors = [1.0f64, 2.0, 4.0, 8.0];
    let mut by_method: Vec<Vec<(f64, f64)>> = vec![Vec::new(); methods.len()];
    for f in factors {
        let (w, h) = (
            (w0 as f64 * f.sqrt()).round() as u32,
            (h0 as f64 * f.sqrt()).round() as u32,
        );
        let cams = cameras_for(&session, w, h)?;
        let mut line = format!("  {w:>4}x{h:<4} ({:>6} px/eye):", w * h);
        let times = stereocache::bench::steady_frame_ms(&session, methods, &base(w, h), &cams)?;
        for (i, (m, ms)) in methods.iter().zip(times).enumerate() {
            by_method[i].push(((w * h) as f64, ms));
            line.push_str(&format!("  {m} {ms:8.2}"));
        }
        println!("{line}");
    }
    print_against_naive(methods, &by_method, "pixels per eye");
    for (i, m) in methods.iter().enumerate() {
        let logs: Vec<(f64, f64)> = by_method[i].iter().map(|(p, t)| (p.ln(), t.ln())).collect();
        println!(
            "  {m}: time ∝ pixels^{:.2} (1.0 = linear)",
            stereocache::bench::fit_slope(&logs)
        );
    }
    drop(session);
    // Triangles.
    println!("\ntriangle scaling ({w0}x{h0} per eye): GPU ms per stereo frame");
    let mut by_method: Vec<Vec<(f64, f64)>> = vec![Vec::new(); methods.len()];
    for tubes in [21u32, 208, 2080] {
        let scene = stereocache::scene::generate::hairball::hairball_with_tubes(tubes);
        let tris = scene.instanced_triangle_count() as f64;
        let session = Session::with_context(ctx.clone(), scene, rt)?;
        let cams = cameras_for(&session, w0, h0)?;
        let mut line = format!("  {:>8} triangles:", tris as u64);
        let times = stereocache::bench::steady_frame_ms(&session, methods, &base(w0, h0), &cams)?;
        for (i, (m, ms)) in methods.iter().zip(times).enumerate() {
            by_method[i].push((tris, ms));
            line.push_str(&format!("  {m} {ms:8.2}"));
        }
        println!("{line}");
    }
    print_against_naive(methods, &by_method, "triangles");
    for (i, m) in methods.iter().enumerate() {
        let logs: Vec<(f64, f64)> = by_method[i].iter().map(|(n, t)| (n.ln(), t.ln())).collect();
        let lin: Vec<(f64, f64)> = by_method[i].iter().map(|(n, t)| (n.ln(), *t)).collect();
        println!(
            "  {m}: time ∝ triangles^{:.2}; +{:.2} ms per ×e triangles (logarithmic growth shows as a small exponent)",
            stereocache::bench::fit_slope(&logs),
            stereocache::bench::fit_slope(&lin)
        );
    }
    report_validation(&ctx)
}

/// Every method's frame time over naive's at each point (same run, same
/// device), when naive was measured.
fn print_against_naive(methods: &[MethodKind], by_method: &[Vec<(f64, f64)>], x: &str) {
    let Some(n) = methods.iter().position(|&m| m == MethodKind::Naive) else {
        return;
    };
    for (i, m) in methods.iter().enumerate() {
        if i == n {
            continue;
        }
        let r: Vec<String> = by_method[i]
            .iter()
            .zip(&by_method[n])
            .map(|((_, t), (_, tn))| format!("{:.2}x", t / tn))
            .collect();
        println!("  {m} / naive by {x}: {}", r.join(", "));
    }
}
