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

/// What both sweeps share: the device, backend, trace, frame count, methods.
struct Sweep<'a> {
    ctx: Arc<GpuContext>,
    rt: RtChoice,
    trace: PoseTrace,
    frames: usize,
    methods: &'a [MethodKind],
}

impl Sweep<'_> {
    /// 1 spp, 3 bounces at `w`×`h`.
    fn base(w: u32, h: u32) -> RenderSettings {
        RenderSettings {
            width: w,
            height: h,
            spp: 1,
            max_bounces: 3,
            seed: 1,
            ..Default::default()
        }
    }

    /// The first `frames` + 1 cameras of the trace at `w`×`h`.
    fn cameras(&self, s: &Session, w: u32, h: u32) -> Result<Vec<StereoCamera>> {
        let cams = trace_cameras(
            s,
            &self.trace,
            DEFAULT_FPS,
            w,
            h,
            &CameraSelect::Default,
            None,
            None,
            Some(self.frames + 1),
        )?;
        Ok(cams)
    }

    /// One line of GPU ms per method at `w`×`h` on `session`; pushes
    /// (x, ms) to `by_method`.
    fn point(
        &self,
        session: &Session,
        (w, h): (u32, u32),
        x: f64,
        label: String,
        by_method: &mut [Vec<(f64, f64)>],
    ) -> Result<()> {
        let cams = self.cameras(session, w, h)?;
        let mut line = label;
        let times = stereocache::bench::steady_frame_ms(
            session,
            self.methods,
            &Self::base(w, h),
            &cams,
            DEFAULT_FPS,
        )?;
        for (i, (m, ms)) in self.methods.iter().zip(times).enumerate() {
            by_method[i].push((x, ms));
            line.push_str(&format!("  {m} {ms:8.2}"));
        }
        println!("{line}");
        Ok(())
    }

    /// Pixels ×1, ×2, ×4, ×8 of `w0`×`h0` on the hairball.
    fn pixels(&self, (w0, h0): (u32, u32)) -> Result<()> {
        let session = Session::with_context(
            self.ctx.clone(),
            stereocache::scene::generate("hairball").expect("built-in"),
            self.rt,
        )?;
        println!(
            "\nresolution scaling (hairball, {} backend): GPU ms per stereo frame",
            session.backend
        );
        let mut by_method: Vec<Vec<(f64, f64)>> = vec![Vec::new(); self.methods.len()];
        for f in [1.0f64, 2.0, 4.0, 8.0] {
            let (w, h) = (
                (w0 as f64 * f.sqrt()).round() as u32,
                (h0 as f64 * f.sqrt()).round() as u32,
            );
            let label = format!("  {w:>4}x{h:<4} ({:>6} px/eye):", w * h);
            self.point(&session, (w, h), (w * h) as f64, label, &mut by_method)?;
        }
        print_against_naive(self.methods, &by_method, "pixels per eye");
        for (i, m) in self.methods.iter().enumerate() {
            let logs: Vec<(f64, f64)> =
                by_method[i].iter().map(|(p, t)| (p.ln(), t.ln())).collect();
            println!(
                "  {m}: time ∝ pixels^{:.2} (1.0 = linear)",
                stereocache::bench::fit_slope(&logs)
            );
        }
        Ok(())
    }

    /// Hairballs of about 10k, 100k and 1M triangles at `w0`×`h0`.
    fn triangles(&self, (w0, h0): (u32, u32)) -> Result<()> {
        println!("\ntriangle scaling ({w0}x{h0} per eye): GPU ms per stereo frame");
        let mut by_method: Vec<Vec<(f64, f64)>> = vec![Vec::new(); self.methods.len()];
        for tubes in [21u32, 208, 2080] {
            let scene = stereocache::scene::generate::hairball::hairball_with_tubes(tubes);
            let tris = scene.instanced_triangle_count() as f64;
            let session = Session::with_context(self.ctx.clone(), scene, self.rt)?;
            let label = format!("  {:>8} triangles:", tris as u64);
            self.point(&session, (w0, h0), tris, label, &mut by_method)?;
        }
        print_against_naive(self.methods, &by_method, "triangles");
        for (i, m) in self.methods.iter().enumerate() {
            let logs: Vec<(f64, f64)> =
                by_method[i].iter().map(|(n, t)| (n.ln(), t.ln())).collect();
            let lin: Vec<(f64, f64)> = by_method[i].iter().map(|(n, t)| (n.ln(), *t)).collect();
            println!(
                "  {m}: time ∝ triangles^{:.2}; +{:.2} ms per ×e triangles (logarithmic growth shows as a small exponent)",
                stereocache::bench::fit_slope(&logs),
                stereocache::bench::fit_slope(&lin)
            );
        }
        Ok(())
    }
}

pub fn run(a: ScalingArgs) -> Result<()> {
    let trace = PoseTrace::read_csv(&a.trace)?;
    stereocache::replay::check_bench_frames(&trace, DEFAULT_FPS, a.frames, 1)?;
    let ctx = Arc::new(GpuContext::new(&a.gpu.options()?)?);
    println!("{}", device_line(&ctx.caps));
    println!(
        "trace {} ({} frames after 1 warm-up per point, methods interleaved frame by frame), 3 bounces, both eyes",
        a.trace.display(),
        a.frames
    );
    let sweep = Sweep {
        ctx,
        rt: a.rt,
        trace,
        frames: a.frames,
        methods: &a.methods.0,
    };
    let size = (a.size.width, a.size.height);
    sweep.pixels(size)?;
    sweep.triangles(size)?;
    report_validation(&sweep.ctx)
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
