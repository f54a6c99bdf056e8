//! `bench materials`: the material-graph memoization cache (issue 17) off,
//! on primary, secondary and all hits, over a table-size sweep and the
//! eviction policies; frame time ratios to "off", hit rates, fills and
//! evictions per frame (library: `stereocache::bench::materials`).

use crate::cli::args::{self, GpuArgs};
use crate::cli::common::{device_line, report_validation};
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use stereocache::camera::PoseTrace;
use stereocache::gpu::GpuContext;
use stereocache::materials::memo::settings::MAX_ENTRIES;
use stereocache::materials::memo::MemoFill;
use stereocache::methods::{MethodConfig, MethodKind, RenderSettings};
use stereocache::replay::{trace_cameras, DEFAULT_FPS};
use stereocache::rt::RtChoice;
use stereocache::scene::DefaultLighting;
use stereocache::session::{CameraSelect, Session};
use stereocache::values::Size;

#[derive(Args)]
pub struct BenchMaterialsArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    /// A scene with material graphs; texture-space graphs (procedural-uv:)
    /// are the ones the cache can hold.
    #[arg(long, default_value = "procedural-uv:cornell")]
    scene: String,
    #[arg(long, value_parser = args::lighting)]
    lighting: Option<DefaultLighting>,
    #[arg(long, default_value = "auto", value_parser = args::rt)]
    rt: RtChoice,
    #[arg(long, default_value = "captures/synth-head-turn.csv")]
    trace: PathBuf,
    /// Frames per run (frame 0 is the warm-up, not counted).
    #[arg(long, default_value_t = 12, value_parser = args::frames)]
    frames: usize,
    #[arg(long, default_value = "96x72")]
    size: Size,
    /// The method whose path tracing shades through the cache.
    #[arg(long, default_value = "reference")]
    method: MethodKind,
    #[arg(long, default_value_t = 1, value_parser = args::spp)]
    spp: u32,
    #[arg(long, default_value_t = 2, value_parser = args::bounces)]
    bounces: u32,
    /// Table sizes of the sweep (entries); the smallest also gets each
    /// eviction policy.
    #[arg(long, default_value = "4096,65536,1048576", value_delimiter = ',')]
    sizes: Vec<u32>,
    /// The sweep's and the eviction rows' entries: 1 (single texels) or s
    /// (s×s tiles, s = 2, 4, 8; --sizes then counts tiles, and
    /// secondary-only gets a row of these tiles too).
    #[arg(long, default_value_t = 1)]
    sweep_tile: u32,
    /// The tiled sweep's fill: subgroup (the default) or plain (as
    /// --memo-fill); plain also puts the fixed 4×4 rows on the plain fill,
    /// so no row needs the subgroup-cooperative build (whose pipeline takes
    /// llvmpipe about ten minutes to compile for the procedural-heavy
    /// Sponza); with --fill-cost, the one fill of its tiled rows (both
    /// fills when not given).
    #[arg(long)]
    sweep_fill: Option<MemoFill>,
    /// Rounds over all configurations (alternating, in a carry-over balanced order: over m rounds, 2m for odd m, every configuration takes every position, and within a round follows every other, equally often).
    #[arg(long, default_value_t = 2)]
    repeats: usize,
    /// Instead of the sweep: what one fill costs, timed apart. The trace's
    /// first camera rendered from an emptied table and again from the
    /// table it filled (same rays), per configuration (off; every hit
    /// memoized non-tiled, 4×4 and 8×8 tiles with either fill, or the
    /// --sweep-fill one), --repeats rounds (at least 2).
    #[arg(long)]
    fill_cost: bool,
    /// Write the rows as CSV here.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(a: BenchMaterialsArgs) -> Result<()> {
    if let Some(out) = &a.out {
        crate::cli::common::check_out_file(out)?;
    }
    if ![1, 2, 4, 8].contains(&a.sweep_tile) {
        bail!(
            "bad --sweep-tile {}: expected 1 (single texels), 2, 4 or 8",
            a.sweep_tile
        );
    }
    let configs = stereocache::bench::memo_configs(
        &a.sizes,
        stereocache::bench::SweepVariant {
            tile: a.sweep_tile,
            fill: a.sweep_fill.unwrap_or(MemoFill::Subgroup),
        },
    );
    for (label, s) in &configs {
        s.validate()
            .map_err(|e| anyhow::anyhow!("bad --sizes ({label}): {e}"))?;
    }
    if a.sizes.iter().any(|&s| s > MAX_ENTRIES) || a.repeats == 0 {
        bail!("bad --sizes or --repeats: sizes up to {MAX_ENTRIES} entries, at least one round");
    }
    let trace = PoseTrace::read_csv(&a.trace)?;
    if a.frames < 2 && !a.fill_cost {
        bail!(
            "bad --frames {}: frame 0 is the untimed warm-up; use at least 2",
            a.frames
        );
    }
    stereocache::replay::check_bench_frames(&trace, DEFAULT_FPS, a.frames, 0)?;
    let (scene, lit) = Session::load_scene_lit(&a.scene, a.lighting.as_ref())?;
    eprintln!("{}", lit.line());
    if scene.graphs.is_empty() {
        bail!(
            "{}: the scene has no material graphs: nothing to memoize (try procedural-uv:{})",
            a.scene,
            a.scene
        );
    }
    let mut opts = a.gpu.options()?;
    opts.want_ray_query = a.rt != RtChoice::Software;
    opts.require.ray_query |= a.rt == RtChoice::Query;
    let ctx = std::sync::Arc::new(GpuContext::new(&opts)?);
    let probe = Session::with_context(ctx.clone(), scene.clone(), a.rt)?;
    let mut cameras = trace_cameras(
        &probe,
        &trace,
        DEFAULT_FPS,
        a.size.width,
        a.size.height,
        &CameraSelect::Default,
        None,
        None,
        Some(a.frames),
    )?;
    // (--fill-cost renders frame 0 alone.)
    let posed = if a.fill_cost { 1 } else { a.frames };
    stereocache::bench::check_frame_poses(&probe, posed, DEFAULT_FPS)?;
    drop(probe);
    if cameras.len() < a.frames {
        bail!(
            "bad --frames {}: {} gives {} frames",
            a.frames,
            a.trace.display(),
            cameras.len()
        );
    }
    cameras.truncate(a.frames);
    println!("{}", device_line(&ctx.caps));
    let memoizable = scene
        .graphs
        .materials
        .iter()
        .filter(|(_, b)| {
            b.iter()
                .all(|b| scene.graphs.graphs[b.graph].reads_only_uv())
        })
        .count();
    println!(
        "scene: {} ({} of {} graph-bound materials read only the uv), method {}, trace {} ({} frames at {DEFAULT_FPS} Hz, 1 warm-up), {}x{} per eye, {} spp, {} bounces, {} rounds",
        a.scene,
        memoizable,
        scene.graphs.materials.len(),
        a.method.name(),
        a.trace.display(),
        a.frames,
        a.size.width,
        a.size.height,
        a.spp,
        a.bounces,
        a.repeats
    );
    let settings = RenderSettings {
        width: a.size.width,
        height: a.size.height,
        spp: a.spp,
        max_bounces: a.bounces,
        seed: 1,
        ..Default::default()
    };
    if a.fill_cost {
        let fills = match a.sweep_fill {
            Some(f) => vec![f],
            None => vec![MemoFill::Subgroup, MemoFill::Plain],
        };
        let rows = stereocache::bench::bench_fill_cost(
            &ctx,
            &scene,
            a.rt,
            &MethodConfig::from(a.method),
            &settings,
            cameras[0],
            &stereocache::bench::fill_cost_configs(&fills),
            a.repeats,
        )?;
        print!("{}", stereocache::bench::fill_cost_table(&rows));
        if let Some(p) = &a.out {
            stereocache::output::write_file(
                p,
                stereocache::bench::fill_cost_csv(&rows).as_bytes(),
            )?;
            println!("wrote {}", p.display());
        }
        return report_validation(&ctx);
    }
    let rows = stereocache::bench::bench_materials(
        &ctx,
        &scene,
        a.rt,
        &MethodConfig::from(a.method),
        &settings,
        &cameras,
        DEFAULT_FPS,
        &configs,
        a.repeats,
    )?;
    print!("{}", stereocache::bench::memo_table(&rows));
    if let Some(p) = &a.out {
        stereocache::output::write_file(p, stereocache::bench::memo_csv(&rows).as_bytes())?;
        println!("wrote {}", p.display());
    }
    report_validation(&ctx)
}
