//! `stereocache render`: one stereo frame, written as DIR/{left,right}.{exr,png}
//! and DIR/stats.json; an animated scene is posed at `--time` (default 0).

use super::args::{self, CameraArgs, GpuArgs, MethodArgs, SceneArgs};
use super::common::{check_out, check_out_spares_inputs, report_validation};
use anyhow::{anyhow, Context, Result};
use clap::Args;
use std::path::PathBuf;
use stereocache::methods::{FrameInput, MethodKind};
use stereocache::output;
use stereocache::values::Size;

#[derive(Args)]
pub struct RenderArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    camera: CameraArgs,
    #[arg(long, default_value = "reference", value_parser = method)]
    method: MethodKind,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64, value_parser = args::spp)]
    spp: u32,
    /// Image size per eye, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240")]
    size: Size,
    /// Maximum scattering events per path.
    #[arg(long, default_value_t = 3, value_parser = args::bounces)]
    bounces: u32,
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// Scene time in seconds: animated instances (see --animation) are
    /// posed at it, as a replay poses them at its frame time.
    #[arg(long, default_value_t = 0.0, value_parser = args::time)]
    time: f64,
    /// Exposure multiplier for the PNG previews.
    #[arg(long, default_value_t = 1.0, value_parser = args::exposure)]
    exposure: f32,
    #[command(flatten)]
    method_opts: MethodArgs,
    #[arg(long, default_value = "out/render")]
    out: PathBuf,
}

/// `--method`: a registry name (the message lists them all).
pub fn method(s: &str) -> Result<MethodKind, String> {
    s.parse::<MethodKind>().map_err(|e| e.to_string())
}

pub fn run(a: RenderArgs) -> Result<()> {
    let Size {
        width: w,
        height: h,
    } = a.size;
    let settings = a
        .method_opts
        .settings(a.size, a.spp, a.bounces, a.seed, false)
        .map_err(|e| anyhow!(e))?;
    let config = a
        .method_opts
        .config(a.method, false)
        .map_err(|e| anyhow!(e))?;
    check_out(&a.out)?;
    let select = a.camera.select();
    let session = a.scene.open(&a.gpu)?;
    check_out_spares_inputs(&a.out, &|rel| {
        rel == std::path::Path::new("stats.json") || output::is_eye_output(rel)
    })?;
    let cam = session.camera(&select, w, h, a.camera.ipd, a.camera.fov_radians())?;
    let mut m = session.create(&config, &settings)?;
    // One frame: previous and current pose are both those at --time.
    session.pose_instances(a.time, None)?;
    let frame = m.render_frame(&FrameInput {
        index: 0,
        camera: cam,
        prev_camera: None,
    })?;
    let out = &a.out;
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create the output directory", out.display()))?;
    // stats.json, written last, marks a complete render: a previous one's
    // goes first, so a render failing part way does not leave its new
    // images beside the old render's description (until session 49).
    let stats_path = out.join("stats.json");
    output::remove_stale(&stats_path).with_context(|| {
        format!(
            "{}: cannot remove the previous render's",
            stats_path.display()
        )
    })?;
    output::write_eye(out, "left", w, h, &frame.eyes[0], a.exposure)?;
    output::write_eye(out, "right", w, h, &frame.eyes[1], a.exposure)?;
    let caps = &session.ctx.caps;
    let stats = serde_json::json!({
        "device": caps.name,
        "driver": format!("{} {}", caps.driver_name, caps.driver_info),
        "backend": session.backend,
        "scene": session.scene.source,
        "triangles": session.scene_gpu.triangle_count,
        "method": m.name(),
        "time": a.time,
        "settings": config.record(&settings),
        "camera": { "position": cam.world_position().to_array(), "orientation": cam.head.orientation.to_array(), "ipd": cam.ipd, "yfov_deg": cam.yfov.to_degrees(), "projection": cam.projection },
        "gpu_ms": frame.stats.gpu_ms(),
        "passes": frame.stats.passes,
        "rays": frame.stats.rays,
        "method_memory_bytes": m.memory_bytes(),
        "scene_memory_bytes": session.scene_gpu.bytes,
    });
    let mut stats = stats;
    if let Some(memo) = &session.scene_gpu.memo {
        let c = memo.counters()?;
        println!("{}", memo_line(&c));
        stats["memo"] = serde_json::to_value(c)?;
    }
    output::write_json(&stats_path, &stats)?;
    println!(
        "rendered {} ({}x{} per eye, {} spp, {} backend) in {:.1} GPU ms on {}: {}",
        session.scene.source.display(),
        w,
        h,
        a.spp,
        session.backend,
        frame.stats.gpu_ms(),
        caps.name,
        out.display()
    );
    report_validation(&session.ctx)
}

/// One line of the memoization cache's counters.
pub fn memo_line(c: &stereocache::materials::memo::state::MemoCounters) -> String {
    format!(
        "memo: {} lookups, hit rate {} (second eye {}; {} of lookups hit the other eye's fills of this frame), {} fills, {} evictions, {} lock failures, {} misses not stored (window full, no eviction), {} refused reads, {} hits evaluated directly (graphs that read more than the uv, or uvs beyond the level's texel grid)",
        c.hits + c.misses,
        c.hit_rate().map_or("-".into(), |r| format!("{:.2} %", 100.0 * r)),
        c.second_eye_hit_rate()
            .map_or("-".into(), |r| format!("{:.2} %", 100.0 * r)),
        c.other_eye_share()
            .map_or("-".into(), |r| format!("{:.2} %", 100.0 * r)),
        c.fills,
        c.evictions,
        c.lock_failures,
        c.window_full,
        c.refused,
        c.bypassed
    )
}
