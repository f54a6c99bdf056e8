//! Benchmarks (never pass/fail tests): `stereocache bench rays` measures
//! primary and diffuse-bounce rays per second for each ray backend.

use crate::error::Result;
use crate::gpu::{
    shaders, Buffer, ComputePipeline, DescriptorLayout, DescriptorSet, GpuError, Recorder, Resource,
};
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
    let layout = DescriptorLayout::buffers(ctx, 4)?;
    let set = DescriptorSet::new(
        ctx,
        &layout,
        &[
            Resource::Buffer(&fbuf),
            Resource::Buffer(&hits),
            Resource::Buffer(&normals),
            Resource::Buffer(&counters),
        ],
    )?;
    let name = format!("bench/rays.{}", session.backend.shader_suffix());
    let spirv = shaders::spirv(&name)
        .ok_or_else(|| GpuError::Unsupported(format!("shader {name} missing")))?;
    let spec = session
        .scene_gpu
        .spec_constants(&session.scene.environment, 1, false);
    let pipe = ComputePipeline::new(
        ctx,
        "bench.rays",
        spirv,
        &[session.scene_gpu.layout.clone(), layout],
        4,
        &spec,
    )?;
    let params = FrameParams::new(frame, width, height, 1);
    let groups = [width.div_ceil(8), height.div_ceil(8), 2];
    let sets = [&session.scene_gpu.set, &set];
    let mut rec = Recorder::new(ctx, 2 + 2 * repeats)?;
    rec.pass("bench.params")
        .write(&fbuf)
        .update(bytemuck::bytes_of(&params));
    rec.pass("bench.clear").write(&counters).fill(0);
    for _ in 0..repeats {
        rec.pass("primary")
            .read(&fbuf)
            .write(&hits)
            .write(&normals)
            .write(&counters)
            .dispatch(&pipe, &sets, &0u32.to_le_bytes(), groups);
        rec.pass("bounce")
            .read(&fbuf)
            .read(&hits)
            .read(&normals)
            .write(&counters)
            .dispatch(&pipe, &sets, &1u32.to_le_bytes(), groups);
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
        primary_rays: c[0] as u64,
        primary_ms: ms("primary"),
        bounce_rays: c[1] as u64,
        bounce_ms: ms("bounce"),
    })
}

/// Mean milliseconds per frame of the passes whose name starts with `prefix`.
fn mean_pass_ms(frames: &[crate::methods::FrameStats], prefix: &str) -> f64 {
    let total: f64 = frames
        .iter()
        .flat_map(|f| &f.passes)
        .filter(|p| p.name.starts_with(prefix))
        .map(|p| p.ms)
        .sum();
    total / frames.len().max(1) as f64
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
}

/// Renders `cameras` (frame 0 is a warm-up and not counted) with `method`.
fn run_frames(
    method: &mut dyn crate::methods::Method,
    cameras: &[crate::camera::StereoCamera],
) -> Result<Vec<crate::methods::FrameStats>> {
    let mut stats = Vec::new();
    for (i, cam) in cameras.iter().enumerate() {
        let prev = if i > 0 { Some(cameras[i - 1]) } else { None };
        let f = method.render_frame(&FrameInput {
            index: i as u32,
            camera: *cam,
            prev_camera: prev,
        })?;
        if i > 0 {
            stats.push(f.stats);
        }
    }
    Ok(stats)
}

/// `stereocache bench sample-cache`: in one run on the same frames, the
/// sample cache with each retrace mode and both reprojection variants, the
/// plain one-sample scatter, and the 1 spp path tracer.
pub fn bench_sample_cache(
    session: &Session,
    cameras: &[crate::camera::StereoCamera],
    base: &crate::methods::RenderSettings,
) -> Result<(Vec<CacheBenchRow>, f64)> {
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
    let configs = [
        ("adaptive, one-pass", Retrace::Adaptive, Reproject::OnePass),
        ("single, one-pass", Retrace::Single, Reproject::OnePass),
        ("multi, one-pass", Retrace::Multi, Reproject::OnePass),
        ("adaptive, two-pass", Retrace::Adaptive, Reproject::TwoPass),
    ];
    for (label, retrace, reproject) in configs {
        let settings = crate::methods::RenderSettings {
            cache: SampleCacheSettings {
                retrace,
                reproject,
                ..base.cache.clone()
            },
            ..base.clone()
        };
        let mut m = session.method("sample-cache", &settings)?;
        let stats = run_frames(m.as_mut(), cameras)?;
        let n = stats.len().max(1) as f64;
        profile(label, &stats);
        rows.push(CacheBenchRow {
            label: format!("sample-cache ({label})"),
            frame_ms: stats.iter().map(|s| s.gpu_ms()).sum::<f64>() / n,
            reproject_ms: mean_pass_ms(&stats, "reproject"),
            trace_ms: mean_pass_ms(&stats, "select") + mean_pass_ms(&stats, "trace"),
            shade_ms: mean_pass_ms(&stats, "shade"),
            retrace_rays_per_frame: stats
                .iter()
                .map(|s| s.counters.get("retrace_rays").copied().unwrap_or(0.0))
                .sum::<f64>()
                / n,
            rays_per_frame: stats.iter().map(|s| s.rays.total() as f64).sum::<f64>() / n,
        });
    }
    // 1 spp path tracing: the reference method with one jittered sample.
    let naive = crate::methods::RenderSettings {
        spp: 1,
        ..base.clone()
    };
    let mut m = session.method("reference", &naive)?;
    let stats = run_frames(m.as_mut(), cameras)?;
    let n = stats.len().max(1) as f64;
    profile("1 spp", &stats);
    rows.push(CacheBenchRow {
        label: "1 spp path tracing".into(),
        frame_ms: stats.iter().map(|s| s.gpu_ms()).sum::<f64>() / n,
        reproject_ms: 0.0,
        trace_ms: mean_pass_ms(&stats, "reference.primary"),
        shade_ms: mean_pass_ms(&stats, "reference.trace"),
        retrace_rays_per_frame: 0.0,
        rays_per_frame: stats.iter().map(|s| s.rays.total() as f64).sum::<f64>() / n,
    });
    Ok((rows, plain_scatter_ms(session, cameras, base)?))
}

/// Mean GPU time of the plain one-sample-per-pixel scatter over the frames.
fn plain_scatter_ms(
    session: &Session,
    cameras: &[crate::camera::StereoCamera],
    base: &crate::methods::RenderSettings,
) -> Result<f64> {
    let ctx = &session.ctx;
    let (w, h) = (base.width, base.height);
    let n = (w * h * 2) as u64;
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
    let hits: Vec<[u32; 4]> = f0
        .eyes
        .iter()
        .flat_map(|e| e.first_hit.iter().copied())
        .collect();
    let fbuf = Buffer::storage(
        ctx,
        "scatter.frame",
        std::mem::size_of::<FrameParams>() as u64,
    )?;
    let src = Buffer::with_data(
        ctx,
        "scatter.src",
        bytemuck::cast_slice(&hits),
        ash::vk::BufferUsageFlags::empty(),
    )?;
    let dst = Buffer::storage(ctx, "scatter.dst", n * 16)?;
    let layout = DescriptorLayout::buffers(ctx, 3)?;
    let set = DescriptorSet::new(
        ctx,
        &layout,
        &[
            Resource::Buffer(&fbuf),
            Resource::Buffer(&src),
            Resource::Buffer(&dst),
        ],
    )?;
    let spirv = shaders::spirv("bench/scatter")
        .ok_or_else(|| GpuError::Unsupported("shader bench/scatter missing".into()))?;
    let spec = session
        .scene_gpu
        .spec_constants(&session.scene.environment, 1, false);
    let pipe = ComputePipeline::new(
        ctx,
        "bench.scatter",
        spirv,
        &[session.scene_gpu.layout.clone(), layout],
        0,
        &spec,
    )?;
    let groups = [w.div_ceil(8), h.div_ceil(8), 2];
    let mut total = 0.0;
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
        );
        let mut rec = Recorder::new(ctx, 3)?;
        rec.pass("params")
            .write(&fbuf)
            .update(bytemuck::bytes_of(&params));
        rec.pass("clear").write(&dst).fill(0);
        rec.pass("scatter")
            .read(&fbuf)
            .read(&src)
            .write(&dst)
            .dispatch(&pipe, &[&session.scene_gpu.set, &set], &[], groups);
        let t = rec.finish()?;
        if i > 0 {
            total += t
                .iter()
                .filter(|p| p.name == "scatter")
                .map(|p| p.ms)
                .sum::<f64>();
        }
    }
    Ok(total / (cameras.len().saturating_sub(1)).max(1) as f64)
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

/// Steady-state mean GPU ms per frame of `method` over `cameras` (frame 0 excluded).
pub fn steady_frame_ms(
    session: &Session,
    method: &str,
    settings: &crate::methods::RenderSettings,
    cameras: &[crate::camera::StereoCamera],
) -> Result<f64> {
    let mut m = session.method(method, settings)?;
    let stats = run_frames(m.as_mut(), cameras)?;
    Ok(stats.iter().map(|s| s.gpu_ms()).sum::<f64>() / stats.len().max(1) as f64)
}
