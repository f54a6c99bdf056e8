//! Benchmarks (never pass/fail tests): `stereocache bench rays` measures
//! primary and diffuse-bounce rays per second for each ray backend; `bench
//! specialization` what pipelines specialized to a scene and skipped passes save.

use crate::error::Result;
use crate::gpu::{shaders, Buffer, ComputePipeline, DescriptorSet, GpuError, Recorder};
use crate::interface::bench::{self, BenchRaysCounter};
use crate::interface::CounterSlot;
use crate::methods::{FrameInput, FrameParams};
use crate::session::Session;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
pub struct RayBench {
    pub backend: String,
    pub width: u32,
    pub height: u32,
    pub repeats: u32,
    pub primary_rays: u64,
    pub primary_ms: f64,
    pub bounce_rays: u64,
    pub bounce_ms: f64,
}

impl RayBench {
    pub fn primary_mrays_per_s(&self) -> f64 {
        self.primary_rays as f64 / (self.primary_ms * 1e3)
    }
    pub fn bounce_mrays_per_s(&self) -> f64 {
        self.bounce_rays as f64 / (self.bounce_ms * 1e3)
    }
}

/// Traces `repeats` rounds of primary + bounce rays for both eyes of `frame`;
/// the GPU time of the passes gives the rates.
pub fn bench_rays(
    session: &Session,
    frame: &FrameInput,
    width: u32,
    height: u32,
    repeats: u32,
) -> Result<RayBench> {
    let ctx = &session.ctx;
    let n = (width * height * 2) as u64;
    let fbuf = Buffer::storage(
        ctx,
        "bench.frame",
        std::mem::size_of::<FrameParams>() as u64,
    )?;
    let hits = Buffer::storage(ctx, "bench.hits", n * 16)?;
    let normals = Buffer::storage(ctx, "bench.normals", n * 16)?;
    let counters = Buffer::storage(ctx, "bench.counters", 16)?;
    let name = format!("bench/rays.{}", session.backend.shader_suffix());
    let spirv = shaders::spirv(&name)
        .ok_or_else(|| GpuError::Unsupported(format!("shader {name} missing")))?;
    let spec = session
        .scene_gpu
        .spec_constants(&session.scene.environment, 1, false);
    let pipe = ComputePipeline::with_interface(
        ctx,
        "bench.rays",
        spirv,
        std::slice::from_ref(&session.scene_gpu.layout),
        &bench::RAYS,
        Some(&bench::RAYS_PUSH),
        &spec,
    )?;
    let params = FrameParams::new(frame, width, height, 1, session.scene_gpu.origin);
    let groups = [width.div_ceil(8), height.div_ceil(8), 2];
    let bufs = [&fbuf, &hits, &normals, &counters];
    let set = &session.scene_gpu.set;
    let mut rec = Recorder::new(ctx, 5 + 2 * repeats)?;
    rec.pass("bench.params")
        .write(&fbuf)
        .update(bytemuck::bytes_of(&params));
    // One untimed round first: a CPU driver may compile (or load from its
    // disk cache) the pipeline at its first dispatch, which cost up to 5x
    // the round's time in the first run after a rebuild.
    rays_pass(&mut rec, "warmup.primary", &pipe, set, bufs, 0, groups)?;
    rays_pass(&mut rec, "warmup.bounce", &pipe, set, bufs, 1, groups)?;
    rec.pass("bench.clear").write(&counters).fill(0);
    for _ in 0..repeats {
        rays_pass(&mut rec, "primary", &pipe, set, bufs, 0, groups)?;
        rays_pass(&mut rec, "bounce", &pipe, set, bufs, 1, groups)?;
    }
    let timings = rec.finish()?;
    let c: Vec<u32> = counters.download_pod()?;
    let ms = |name: &str| {
        timings
            .iter()
            .filter(|t| t.name == name)
            .map(|t| t.ms)
            .sum::<f64>()
    };
    Ok(RayBench {
        backend: session.backend.to_string(),
        width,
        height,
        repeats,
        primary_rays: c[BenchRaysCounter::PrimaryRays.slot()] as u64,
        primary_ms: ms("primary"),
        bounce_rays: c[BenchRaysCounter::BounceRays.slot()] as u64,
        bounce_ms: ms("bounce"),
    })
}

/// One pass of bench/rays.comp in mode 0 (primary) or 1 (bounce); `bufs`
/// in the binding order of src/interface/bench.rs (frame, hits, normals,
/// counters).
fn rays_pass<'a>(
    rec: &mut Recorder<'a>,
    name: &str,
    pipe: &'a ComputePipeline,
    scene_set: &'a DescriptorSet,
    bufs: [&'a Buffer; 4],
    mode: u32,
    groups: [u32; 3],
) -> crate::gpu::GpuResult<()> {
    rec.compute(name, pipe)
        .shared(scene_set)
        .read(bufs[0])
        .write(bufs[1])
        .write(bufs[2])
        .write(bufs[3])
        .push(&mode)
        .dispatch(groups)
}

/// Mean milliseconds per frame of the passes whose name starts with `prefix`.
fn mean_pass_ms(frames: &[crate::methods::FrameStats], prefix: &str) -> f64 {
    let total: f64 = frames
        .iter()
        .flat_map(|f| &f.passes)
        .filter(|p| p.name.starts_with(prefix))
        .map(|p| p.ms)
        .sum();
    // + 0.0: an empty sum is -0.0, printed as "-0.00".
    total / frames.len().max(1) as f64 + 0.0
}

/// One configuration of `bench sample-cache`.
#[derive(Clone, Debug, Serialize)]
pub struct CacheBenchRow {
    pub label: String,
    pub frame_ms: f64,
    pub reproject_ms: f64,
    pub trace_ms: f64,
    pub shade_ms: f64,
    pub retrace_rays_per_frame: f64,
    pub rays_per_frame: f64,
    /// GPU frame time of every measured frame (for paired ratios).
    pub frame_ms_per_frame: Vec<f64>,
}

/// Renders `cameras` with every method in `methods`, interleaved frame by
/// frame in rotating order so drift of a shared machine hits them alike;
/// frame 0 is a warm-up and not counted. Returns stats[method][frame].
pub fn run_interleaved(
    methods: &mut [Box<dyn crate::methods::Method>],
    cameras: &[crate::camera::StereoCamera],
) -> Result<Vec<Vec<crate::methods::FrameStats>>> {
    let mut stats = vec![Vec::new(); methods.len()];
    for (i, cam) in cameras.iter().enumerate() {
        let input = FrameInput {
            index: i as u32,
            camera: *cam,
            prev_camera: if i > 0 { Some(cameras[i - 1]) } else { None },
        };
        for k in 0..methods.len() {
            let j = (k + i) % methods.len();
            let f = methods[j].render_frame(&input)?;
            if i > 0 {
                stats[j].push(f.stats);
            }
        }
    }
    Ok(stats)
}

/// Ratio of the means of `a` and `b` (paired per-frame times of two methods
/// on the same frames) and the standard error of the per-frame ratios.
pub fn paired_ratio(a: &[f64], b: &[f64]) -> (f64, f64) {
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let r: Vec<f64> = a.iter().zip(b).map(|(x, y)| x / y).collect();
    let m = mean(&r);
    let n = r.len() as f64;
    let var = r.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean(a) / mean(b), (var / n.max(1.0)).sqrt())
}

/// `stereocache bench sample-cache`: in one run on the same frames, the
/// sample cache with each retrace mode and both reprojection variants, the
/// plain one-sample scatter, and the 1 spp path tracer.
pub fn bench_sample_cache(
    session: &Session,
    cameras: &[crate::camera::StereoCamera],
    base: &crate::methods::RenderSettings,
) -> Result<(Vec<CacheBenchRow>, ScatterBaselines)> {
    use crate::methods::sample_cache::{Reproject, Retrace, SampleCacheSettings};
    let mut rows = Vec::new();
    // Per-pass profile on stderr: GPU ms per frame in recording order (mean
    // and, less sensitive to other processes on a CPU device, median over
    // frames) and the cache's samples per pixel.
    let profile = |label: &str, stats: &[crate::methods::FrameStats]| {
        let n = stats.len().max(1) as f64;
        let mut names: Vec<&str> = Vec::new();
        for p in stats.iter().flat_map(|f| &f.passes) {
            if !names.contains(&p.name.as_str()) {
                names.push(&p.name);
            }
        }
        let profile: Vec<String> = names
            .iter()
            .chain(&["frame"])
            .map(|name| {
                let mut ms: Vec<f64> = stats
                    .iter()
                    .map(|f| {
                        f.passes
                            .iter()
                            .filter(|p| *name == "frame" || p.name == *name)
                            .map(|p| p.ms)
                            .sum()
                    })
                    .collect();
                ms.sort_by(f64::total_cmp);
                let mean = ms.iter().sum::<f64>() / n;
                format!("{name} {mean:.2}/{:.2}", ms[ms.len() / 2])
            })
            .collect();
        let per_pixel = |c: &str| {
            stats
                .iter()
                .map(|s| s.counters.get(c).copied().unwrap_or(0.0))
                .sum::<f64>()
                / (n * 2.0 * (base.width * base.height) as f64)
        };
        eprintln!(
            "passes ({label}), mean/median ms: {}; per pixel: {:.2} reprojected, \
             {:.2} visible, {:.2} shaded",
            profile.join(", "),
            per_pixel("reprojected_samples"),
            per_pixel("reprojected_visible"),
            per_pixel("shaded_samples"),
        );
    };
    // The last row: the default configuration with the plain shader builds
    // instead of the subgroup-operation ones (same where the device has none).
    let configs = [
        (
            "adaptive, one-pass",
            Retrace::Adaptive,
            Reproject::OnePass,
            true,
        ),
        (
            "single, one-pass",
            Retrace::Single,
            Reproject::OnePass,
            true,
        ),
        ("multi, one-pass", Retrace::Multi, Reproject::OnePass, true),
        (
            "adaptive, two-pass",
            Retrace::Adaptive,
            Reproject::TwoPass,
            true,
        ),
        (
            "adaptive, one-pass, plain builds",
            Retrace::Adaptive,
            Reproject::OnePass,
            false,
        ),
    ];
    let mut methods = Vec::new();
    let mut labels = Vec::new();
    for (label, retrace, reproject, subgroup_ops) in configs {
        let settings = crate::methods::RenderSettings {
            cache: SampleCacheSettings {
                retrace,
                reproject,
                ..base.cache.clone()
            },
            subgroup_ops,
            ..base.clone()
        };
        methods.push(session.method("sample-cache", &settings)?);
        labels.push(label);
    }
    // 1 spp path tracing: the reference method with one jittered sample.
    let naive = crate::methods::RenderSettings {
        spp: 1,
        ..base.clone()
    };
    methods.push(session.method("reference", &naive)?);
    labels.push("1 spp path tracing");
    let all = run_interleaved(&mut methods, cameras)?;
    drop(methods);
    let n_cache = labels.len() - 1;
    for (k, (label, stats)) in labels.into_iter().zip(all).enumerate() {
        let n = stats.len().max(1) as f64;
        let naive = k == n_cache;
        profile(label, &stats);
        let (trace_ms, shade_ms) = if naive {
            (
                mean_pass_ms(&stats, "reference.primary"),
                mean_pass_ms(&stats, "reference.trace"),
            )
        } else {
            (
                mean_pass_ms(&stats, "select") + mean_pass_ms(&stats, "trace"),
                mean_pass_ms(&stats, "shade"),
            )
        };
        let frame_ms: Vec<f64> = stats.iter().map(|s| s.gpu_ms()).collect();
        rows.push(CacheBenchRow {
            label: if naive {
                label.to_string()
            } else {
                format!("sample-cache ({label})")
            },
            frame_ms: frame_ms.iter().sum::<f64>() / n,
            reproject_ms: mean_pass_ms(&stats, "reproject"),
            trace_ms,
            shade_ms,
            retrace_rays_per_frame: stats
                .iter()
                .map(|s| s.counters.get("retrace_rays").copied().unwrap_or(0.0))
                .sum::<f64>()
                / n,
            rays_per_frame: stats.iter().map(|s| s.rays.total() as f64).sum::<f64>() / n,
            frame_ms_per_frame: frame_ms,
        });
    }
    Ok((rows, scatter_baselines(session, cameras, base)?))
}

/// GPU times of the two scatter baselines of `bench sample-cache` (mean ms
/// per frame over the measured frames).
#[derive(Clone, Debug, Serialize)]
pub struct ScatterBaselines {
    /// The paper's "simple reprojection" (Fig. 6): one first hit per pixel,
    /// plain store (`bench/scatter.comp`).
    pub one_sample_ms: f64,
    /// Every occupied slot of a warmed-up sample cache with its 32-byte
    /// payload, plain store into the same layer (`bench/scatter_slots.comp`).
    pub all_slots_ms: f64,
    /// Occupied slots per pixel (both eyes) of that cache.
    pub slots_per_pixel: f64,
}

/// Runs both scatter baselines in the same command buffer per frame over
/// `cameras` (frame 0 not counted): sources are the reference's first hits of
/// frame 0 and a sample cache (`base.cache`) after up to 10 frames.
fn scatter_baselines(
    session: &Session,
    cameras: &[crate::camera::StereoCamera],
    base: &crate::methods::RenderSettings,
) -> Result<ScatterBaselines> {
    let ctx = &session.ctx;
    let (w, h) = (base.width, base.height);
    let n = (w * h * 2) as u64;
    let slots = base.cache.slots;
    // First hits of frame 0 from the reference's pixel-centre rays.
    let mut reference = session.method(
        "reference",
        &crate::methods::RenderSettings {
            spp: 1,
            ..base.clone()
        },
    )?;
    let f0 = reference.render_frame(&FrameInput {
        index: 0,
        camera: cameras[0],
        prev_camera: None,
    })?;
    drop(reference);
    let hits: Vec<[u32; 4]> = f0
        .eyes
        .iter()
        .flat_map(|e| e.first_hit.iter().copied())
        .collect();
    // A warmed-up sample cache's slots.
    let snap = {
        let mut cache = crate::methods::sample_cache::SampleCache::new(
            ctx,
            &session.scene_gpu,
            &session.scene.environment,
            base,
        )?;
        use crate::methods::Method;
        let warm = cameras.len().min(11);
        for (i, cam) in cameras[..warm].iter().enumerate() {
            cache.render_frame(&FrameInput {
                index: i as u32,
                camera: *cam,
                prev_camera: if i > 0 { Some(cameras[i - 1]) } else { None },
            })?;
        }
        cache.snapshot()?
    };
    let occupied: u64 = snap
        .masks
        .iter()
        .map(|&m| snap.occupied(m).count_ones() as u64)
        .sum();
    let fbuf = Buffer::storage(
        ctx,
        "scatter.frame",
        std::mem::size_of::<FrameParams>() as u64,
    )?;
    let upload = |name: &str, data: &[u8]| {
        Buffer::with_data(ctx, name, data, ash::vk::BufferUsageFlags::empty())
    };
    let src = upload("scatter.src", bytemuck::cast_slice(&hits))?;
    let dst = Buffer::storage(ctx, "scatter.dst", n * 16)?;
    let masks = upload("scatter.slots.masks", bytemuck::cast_slice(&snap.masks))?;
    let src_fh = upload(
        "scatter.slots.src_fh",
        bytemuck::cast_slice(&snap.first_hits),
    )?;
    let src_rad = upload(
        "scatter.slots.src_rad",
        bytemuck::cast_slice(&snap.radiance),
    )?;
    let dst_fh = Buffer::storage(ctx, "scatter.slots.dst_fh", n * slots as u64 * 16)?;
    let dst_rad = Buffer::storage(ctx, "scatter.slots.dst_rad", n * slots as u64 * 16)?;
    let spec = session
        .scene_gpu
        .spec_constants(&session.scene.environment, 1, false);
    let pipeline = |name: &str,
                    interface: &'static crate::interface::Interface,
                    push: Option<&'static crate::interface::PushBlock>|
     -> Result<ComputePipeline> {
        let spirv = shaders::spirv(name)
            .ok_or_else(|| GpuError::Unsupported(format!("shader {name} missing")))?;
        Ok(ComputePipeline::with_interface(
            ctx,
            name,
            spirv,
            std::slice::from_ref(&session.scene_gpu.layout),
            interface,
            push,
            &spec,
        )?)
    };
    let pipe = pipeline("bench/scatter", &bench::SCATTER, None)?;
    let slots_pipe = pipeline(
        "bench/scatter_slots",
        &bench::SCATTER_SLOTS,
        Some(&bench::SCATTER_SLOTS_PUSH),
    )?;
    let groups = [w.div_ceil(8), h.div_ceil(8), 2];
    let (mut one, mut all) = (0.0, 0.0);
    for (i, cam) in cameras.iter().enumerate() {
        let params = FrameParams::new(
            &FrameInput {
                index: i as u32,
                camera: *cam,
                prev_camera: None,
            },
            w,
            h,
            1,
            session.scene_gpu.origin,
        );
        let mut rec = Recorder::new(ctx, 5)?;
        rec.pass("params")
            .write(&fbuf)
            .update(bytemuck::bytes_of(&params));
        rec.pass("clear")
            .write(&dst)
            .write(&dst_fh)
            .write(&dst_rad)
            .fill(0);
        rec.compute("scatter", &pipe)
            .shared(&session.scene_gpu.set)
            .read(&fbuf)
            .read(&src)
            .write(&dst)
            .dispatch(groups)?;
        rec.compute("scatter.slots", &slots_pipe)
            .shared(&session.scene_gpu.set)
            .read(&fbuf)
            .read(&masks)
            .read(&src_fh)
            .read(&src_rad)
            .write(&dst_fh)
            .write(&dst_rad)
            .push(&slots)
            .dispatch(groups)?;
        let t = rec.finish()?;
        if i > 0 {
            let ms = |name: &str| {
                t.iter()
                    .filter(|p| p.name == name)
                    .map(|p| p.ms)
                    .sum::<f64>()
            };
            one += ms("scatter");
            all += ms("scatter.slots");
        }
    }
    let frames = (cameras.len().saturating_sub(1)).max(1) as f64;
    Ok(ScatterBaselines {
        one_sample_ms: one / frames,
        all_slots_ms: all / frames,
        slots_per_pixel: occupied as f64 / n as f64,
    })
}

/// The configurations `bench tradeoff` sweeps: every method, and for the
/// sample cache N ∈ {4, 8, 12, 16}, n_target, retrace single/multi/adaptive,
/// shading uniform/adaptive at several rates, one-/two-pass reprojection;
/// hash-cache capacities and LoD rules; supersampling at several spp.
pub fn tradeoff_configs(base: &crate::methods::RenderSettings) -> Vec<crate::compare::Config> {
    use crate::compare::Config;
    use crate::methods::hash_cache::settings::HashLod;
    use crate::methods::sample_cache::{Reproject, Retrace, Shading};
    let mut v = Vec::new();
    let cfg = |label: String, method: &str, s: crate::methods::RenderSettings| Config {
        label,
        method: method.into(),
        settings: s,
    };
    for n in [4u32, 8, 12, 16] {
        let mut s = base.clone();
        s.cache.slots = n;
        s.cache.n_target = 4.min(n - 1).max(2);
        s.cache.delta = 1;
        v.push(cfg(format!("sc-N{n}"), "sample-cache", s));
    }
    for nt in [2u32, 6] {
        let mut s = base.clone();
        s.cache.n_target = nt;
        v.push(cfg(format!("sc-ntarget{nt}"), "sample-cache", s));
    }
    for (name, r) in [("single", Retrace::Single), ("multi", Retrace::Multi)] {
        let mut s = base.clone();
        s.cache.retrace = r;
        v.push(cfg(format!("sc-retrace-{name}"), "sample-cache", s));
    }
    for rate in [0.25f32, 0.5, 1.0] {
        let mut s = base.clone();
        s.cache.shading = Shading::Adaptive;
        s.cache.shading_rate = rate;
        v.push(cfg(format!("sc-adaptive-shading{rate}"), "sample-cache", s));
    }
    let mut s = base.clone();
    s.cache.reproject = Reproject::TwoPass;
    v.push(cfg("sc-two-pass".into(), "sample-cache", s));
    for (cap, lod) in [
        (1u32 << 16, HashLod::Distance),
        (1 << 20, HashLod::Distance),
        (1 << 20, HashLod::DistanceNormal),
    ] {
        let mut s = base.clone();
        s.hash.capacity = cap;
        s.hash.lod = lod;
        let lname = if lod == HashLod::Distance {
            "dist"
        } else {
            "distnormal"
        };
        v.push(cfg(
            format!("hash-2e{}-{lname}", cap.trailing_zeros()),
            "hash-cache",
            s,
        ));
    }
    v.push(cfg("hybrid".into(), "hybrid", base.clone()));
    v.push(cfg("taa".into(), "taa", base.clone()));
    v.push(cfg("isrt".into(), "isrt", base.clone()));
    v.push(cfg("naive".into(), "naive", base.clone()));
    for spp in [2u32, 4, 8] {
        v.push(cfg(
            format!("supersample-{spp}spp"),
            "supersample",
            crate::methods::RenderSettings {
                spp,
                ..base.clone()
            },
        ));
    }
    v
}

/// The ratios `bench tradeoff` prints under its table (configurations of
/// the same run on the same device, run one after another): each method's
/// default configuration against naive, and the sample cache's variants
/// against its default (`sc-N12`). Pairs whose rows are missing are skipped.
pub fn tradeoff_ratios(rows: &[crate::compare::MethodRow]) -> String {
    let row = |label: &str| rows.iter().find(|r| r.method == label);
    let rse = |r: &crate::compare::MethodRow| r.metrics.get("rse").copied();
    let mut out =
        String::from("ratios (same run, same device; configurations one after another):\n");
    let mut line = |a: &str, b: &str, what: &str| {
        if let (Some(x), Some(y)) = (row(a), row(b)) {
            let mut l = format!(
                "  {:<44} {:.2}x time, {:.2}x rays",
                format!("{a} / {b}{what}:"),
                x.steady_mean_gpu_ms / y.steady_mean_gpu_ms,
                x.rays_per_frame / y.rays_per_frame
            );
            if let (Some(ex), Some(ey)) = (rse(x), rse(y)) {
                l.push_str(&format!(", {:.2}x RSE", ex / ey));
            }
            out.push_str(&l);
            out.push('\n');
        }
    };
    for m in [
        "sc-N12",
        "hash-2e20-dist",
        "hybrid",
        "taa",
        "isrt",
        "supersample-4spp",
    ] {
        line(m, "naive", "");
    }
    line("sc-retrace-multi", "sc-N12", " (multi / adaptive retrace)");
    line(
        "sc-retrace-single",
        "sc-N12",
        " (single / adaptive retrace)",
    );
    line("sc-two-pass", "sc-N12", " (two- / one-pass reprojection)");
    line(
        "sc-adaptive-shading1",
        "sc-N12",
        " (adaptive / uniform shading)",
    );
    out
}

/// Least-squares slope of y against x.
pub fn fit_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    if sxx > 0.0 {
        sxy / sxx
    } else {
        f64::NAN
    }
}

/// Steady-state mean GPU ms per frame of each of `methods` over `cameras`
/// (frame 0 excluded), the methods rendering the frames interleaved.
pub fn steady_frame_ms(
    session: &Session,
    methods: &[String],
    settings: &crate::methods::RenderSettings,
    cameras: &[crate::camera::StereoCamera],
) -> Result<Vec<f64>> {
    let mut m = Vec::new();
    for name in methods {
        m.push(session.method(name, settings)?);
    }
    let stats = run_interleaved(&mut m, cameras)?;
    Ok(stats
        .iter()
        .map(|v| v.iter().map(|s| s.gpu_ms()).sum::<f64>() / v.len().max(1) as f64)
        .collect())
}

/// The scene features a specialization constant switches on or off, by name
/// (the environment kind and the bounce count are values, not flags).
pub const FEATURE_FLAGS: &[&str] = &[
    "textures",
    "normal_maps",
    "alpha_mask",
    "transmission",
    "emissive_triangles",
    "punctual_lights",
    "directional_lights",
    "view_dependent",
];

/// Whether flag `name` of [`FEATURE_FLAGS`] is on in `f`; with `set`, turns it on.
fn feature_flag(f: &mut crate::scene::SceneFeatures, name: &str, set: bool) -> bool {
    let v = match name {
        "textures" => &mut f.textures,
        "normal_maps" => &mut f.normal_maps,
        "alpha_mask" => &mut f.alpha_mask,
        "transmission" => &mut f.transmission,
        "emissive_triangles" => &mut f.emissive_triangles,
        "punctual_lights" => &mut f.punctual_lights,
        "directional_lights" => &mut f.directional_lights,
        "view_dependent" => &mut f.view_dependent,
        _ => unreachable!("FEATURE_FLAGS names every flag"),
    };
    if set {
        *v = true;
    }
    *v
}

/// Whether flag `name` of [`FEATURE_FLAGS`] is on in `f`.
pub fn has_feature(f: &crate::scene::SceneFeatures, name: &str) -> bool {
    feature_flag(&mut f.clone(), name, false)
}

/// One build of one method on one scene in `bench specialization`.
#[derive(Clone, Debug, Serialize)]
pub struct SpecBenchRow {
    pub scene: String,
    pub method: String,
    pub bounces: u32,
    /// `all features`, `specialized`, `specialized + skip`, or
    /// `specialized + FEATURE` (one unused feature compiled back in).
    pub build: String,
    /// Mean GPU ms per stereo frame (frame 0 excluded).
    pub frame_ms: f64,
    /// `frame_ms` over that of the group's baseline build (`all features`
    /// for the specialized builds, `specialized` for single-feature builds).
    pub ratio: f64,
    /// Standard error of the mean per-frame ratio (frames paired).
    pub ratio_se: f64,
    /// The baseline the ratio is taken against.
    pub against: String,
    /// Passes recorded per frame.
    pub passes: usize,
}

/// `stereocache bench specialization` for one scene: for each method and
/// bounce count, the all-features build with every pass, the specialized
/// build with every pass, the specialized build that skips passes with
/// nothing to do (where it records as many passes as `specialized`, the two
/// are the same build and their ratio shows the measurement noise), and — at the largest
/// bounce count — the specialized build with one unused feature compiled
/// back in, for each feature the scene lacks. All builds of a group render
/// the same frames interleaved (frame by frame, in rotating order) so drift
/// of a shared machine hits them alike.
pub fn bench_specialization(
    session: &Session,
    scene_label: &str,
    methods: &[String],
    bounce_counts: &[u32],
    cameras: &[crate::camera::StereoCamera],
    base: &crate::methods::RenderSettings,
) -> Result<Vec<SpecBenchRow>> {
    use crate::methods::RenderSettings;
    let used = session.scene_gpu.features;
    let max_bounces = bounce_counts.iter().copied().max().unwrap_or(0);
    let mut rows = Vec::new();
    for method in methods {
        for &bounces in bounce_counts {
            let b = RenderSettings {
                max_bounces: bounces,
                ..base.clone()
            };
            let all = RenderSettings {
                all_features: true,
                all_passes: true,
                ..b.clone()
            };
            let spec = RenderSettings {
                all_passes: true,
                ..b.clone()
            };
            let mut builds: Vec<(String, RenderSettings)> = vec![
                ("all features".into(), all),
                ("specialized".into(), spec.clone()),
                ("specialized + skip".into(), b.clone()),
            ];
            if bounces == max_bounces {
                for &name in FEATURE_FLAGS {
                    if !has_feature(&used, name) {
                        let mut s = spec.clone();
                        feature_flag(&mut s.extra_features, name, true);
                        builds.push((format!("specialized + {name}"), s));
                    }
                }
            }
            let mut instances = Vec::new();
            for (_, s) in &builds {
                instances.push(session.method(method, s)?);
            }
            // times[build][frame], pass counts per build.
            let stats = run_interleaved(&mut instances, cameras)?;
            drop(instances);
            let times: Vec<Vec<f64>> = stats
                .iter()
                .map(|v| v.iter().map(|f| f.gpu_ms()).collect())
                .collect();
            let passes: Vec<usize> = stats
                .iter()
                .map(|v| v.last().map_or(0, |f| f.passes.len()))
                .collect();
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
            for (j, (label, _)) in builds.iter().enumerate() {
                let base_idx = if j <= 2 { 0 } else { 1 };
                let (r, se) = paired_ratio(&times[j], &times[base_idx]);
                rows.push(SpecBenchRow {
                    scene: scene_label.to_string(),
                    method: method.clone(),
                    bounces,
                    build: label.clone(),
                    frame_ms: mean(&times[j]),
                    ratio: r,
                    ratio_se: if j == base_idx { 0.0 } else { se },
                    against: builds[base_idx].0.clone(),
                    passes: passes[j],
                });
            }
        }
    }
    Ok(rows)
}

/// `bench specialization` rows as a text table.
pub fn spec_table(rows: &[SpecBenchRow]) -> String {
    let mut t = format!(
        "{:<10} {:<13} {:>3} {:<32} {:>6} {:>10} {:>16}  {}\n",
        "scene", "method", "B", "build", "passes", "frame ms", "ratio ± se", "against"
    );
    for r in rows {
        t.push_str(&format!(
            "{:<10} {:<13} {:>3} {:<32} {:>6} {:>10.2} {:>9.3} ± {:.3}  {}\n",
            r.scene,
            r.method,
            r.bounces,
            r.build,
            r.passes,
            r.frame_ms,
            r.ratio,
            r.ratio_se,
            r.against
        ));
    }
    t
}

/// `bench specialization` rows as CSV (header line first).
pub fn spec_csv(rows: &[SpecBenchRow]) -> String {
    let mut c = String::from("scene,method,bounces,build,passes,frame_ms,ratio,ratio_se,against\n");
    for r in rows {
        c.push_str(&format!(
            "{},{},{},{},{},{:.4},{:.4},{:.4},{}\n",
            r.scene,
            r.method,
            r.bounces,
            r.build,
            r.passes,
            r.frame_ms,
            r.ratio,
            r.ratio_se,
            r.against
        ));
    }
    c
}

/// One strategy's row of `bench lights`.
#[derive(Clone, Debug)]
pub struct LightBenchRow {
    pub scene: String,
    pub strategy: crate::methods::LightSampling,
    /// Mean GPU time of a frame (both eyes) at the measured spp.
    pub frame_ms: f64,
    /// Mean squared error against the reference (all pixels and channels),
    /// averaged over the frames, and its standard error over frames.
    pub mse: f64,
    pub mse_se: f64,
    /// MSE at the frame time of the first strategy: mse · frame_ms / frame_ms[0]
    /// (MSE ∝ 1/samples ∝ 1/time for an unbiased estimator).
    pub mse_equal_time: f64,
}

/// `stereocache bench lights` (issue 13): the reference path tracer on a static
/// view with each light-sampling strategy in `strategies` (the first is the
/// baseline the equal-time MSE is normalised to), `frames` frames each (one
/// warm-up first) with fresh random numbers, interleaved frame by frame in
/// rotating order, against one reference image rendered with MIS at
/// `reference_spp` with its own seed.
pub fn bench_lights(
    session: &Session,
    scene_label: &str,
    camera: crate::camera::StereoCamera,
    base: &crate::methods::RenderSettings,
    strategies: &[crate::methods::LightSampling],
    reference_spp: u32,
    frames: usize,
) -> Result<Vec<LightBenchRow>> {
    use crate::methods::{LightSampling, RenderSettings};
    let frame = |i: u32| FrameInput {
        index: i,
        camera,
        prev_camera: None,
    };
    let reference = session
        .method(
            "reference",
            &RenderSettings {
                spp: reference_spp,
                seed: base.seed ^ 0x9E37_79B9,
                light_sampling: LightSampling::Mis,
                ..base.clone()
            },
        )?
        .render_frame(&frame(0))?;
    let mut methods = Vec::new();
    for &s in strategies {
        methods.push(session.method(
            "reference",
            &RenderSettings {
                light_sampling: s,
                ..base.clone()
            },
        )?);
    }
    let mse_of = |f: &crate::methods::StereoFrame| -> f64 {
        let (mut acc, mut n) = (0.0f64, 0usize);
        for (a, b) in f.eyes.iter().zip(&reference.eyes) {
            for (p, q) in a.radiance.iter().zip(&b.radiance) {
                for k in 0..3 {
                    acc += ((p[k] - q[k]) as f64).powi(2);
                    n += 1;
                }
            }
        }
        acc / n.max(1) as f64
    };
    let mut ms = vec![Vec::new(); methods.len()];
    let mut mse = vec![Vec::new(); methods.len()];
    for i in 0..=frames {
        for k in 0..methods.len() {
            let j = (k + i) % methods.len();
            let f = methods[j].render_frame(&frame(1 + i as u32))?;
            if i > 0 {
                ms[j].push(f.stats.gpu_ms());
                mse[j].push(mse_of(&f));
            }
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let se = |v: &[f64]| {
        let m = mean(v);
        let n = v.len() as f64;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0) / n.max(1.0)).sqrt()
    };
    let t0 = mean(&ms[0]);
    Ok(strategies
        .iter()
        .enumerate()
        .map(|(j, &s)| LightBenchRow {
            scene: scene_label.to_string(),
            strategy: s,
            frame_ms: mean(&ms[j]),
            mse: mean(&mse[j]),
            mse_se: se(&mse[j]),
            mse_equal_time: mean(&mse[j]) * mean(&ms[j]) / t0,
        })
        .collect())
}

/// `bench lights` rows as a text table (ratios against each scene's first row).
pub fn light_table(rows: &[LightBenchRow]) -> String {
    let mut s = format!(
        "{:<10} {:<6} {:>10} {:>12} {:>10} {:>15} {:>12}\n",
        "scene", "light", "frame ms", "MSE", "± se", "MSE equal time", "vs first"
    );
    let mut first: Option<(&str, f64)> = None;
    for r in rows {
        if first.is_none_or(|(sc, _)| sc != r.scene) {
            first = Some((&r.scene, r.mse_equal_time));
        }
        let f = first.map_or(1.0, |(_, m)| m);
        s += &format!(
            "{:<10} {:<6} {:>10.2} {:>12.4e} {:>10.2e} {:>15.4e} {:>11.3}x\n",
            r.scene,
            format!("{:?}", r.strategy).to_lowercase(),
            r.frame_ms,
            r.mse,
            r.mse_se,
            r.mse_equal_time,
            r.mse_equal_time / f
        );
    }
    s
}
