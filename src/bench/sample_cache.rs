//! `bench sample-cache`: the sample cache per retrace mode and reprojection
//! variant against a plain scatter and 1 spp path tracing.

use super::interleave::{
    check_frame_poses, mean_pass_ms, pose_frame, report_pose_ms, run_interleaved,
};
use crate::error::Result;
use crate::gpu::{shaders, Buffer, ComputePipeline, GpuError, Recorder};
use crate::interface::bench;
use crate::methods::MethodKind;
use crate::methods::{FrameInput, FrameParams};
use crate::session::Session;
use serde::Serialize;

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

/// `stereocache bench sample-cache`: in one run on the same frames, the
/// sample cache with each retrace mode and both reprojection variants, the
/// plain one-sample scatter, and the 1 spp path tracer. `cameras` are
/// frames at `fps`: an animated scene is posed at each frame's time (its
/// poses checked before anything renders), as replay poses it.
pub fn bench_sample_cache(
    session: &Session,
    cameras: &[crate::camera::StereoCamera],
    fps: f64,
    base: &crate::methods::RenderSettings,
    cache: &crate::methods::SampleCacheSettings,
) -> Result<(Vec<CacheBenchRow>, ScatterBaselines)> {
    use crate::methods::sample_cache::{Reproject, Retrace, SampleCacheSettings};
    check_frame_poses(session, cameras.len(), fps)?;
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
                        // "frame": the table's frame time (`gpu_ms`, without
                        // the diagnostic passes listed above it).
                        if *name == "frame" {
                            f.gpu_ms()
                        } else {
                            f.passes
                                .iter()
                                .filter(|p| p.name == *name)
                                .map(|p| p.ms)
                                .sum()
                        }
                    })
                    .collect();
                ms.sort_by(f64::total_cmp);
                let mean = ms.iter().sum::<f64>() / n;
                let k = ms.len() / 2;
                let median = if ms.is_empty() {
                    f64::NAN
                } else if ms.len() % 2 == 0 {
                    (ms[k - 1] + ms[k]) / 2.0
                } else {
                    ms[k]
                };
                format!("{name} {mean:.2}/{median:.2}")
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
             {:.2} visible, {:.2} shaded; retrace rays per pixel: {:.3} \
             ({:.3} background, {:.3} occlusion queries of visible samples, \
             {:.3} found occluded)",
            profile.join(", "),
            per_pixel("reprojected_samples"),
            per_pixel("reprojected_visible"),
            per_pixel("shaded_samples"),
            per_pixel("retrace_rays"),
            per_pixel("retrace_background_rays"),
            per_pixel("retrace_occlusion_rays"),
            per_pixel("retrace_occluded"),
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
            subgroup_ops,
            ..base.clone()
        };
        let config = crate::methods::MethodConfig::SampleCache(SampleCacheSettings {
            retrace,
            reproject,
            ..cache.clone()
        });
        methods.push(session.create(config, &settings)?);
        labels.push(label);
    }
    // 1 spp path tracing: the reference method with one jittered sample.
    let naive = crate::methods::RenderSettings {
        spp: 1,
        ..base.clone()
    };
    methods.push(session.create(MethodKind::Reference, &naive)?);
    labels.push("1 spp path tracing");
    let run = run_interleaved(session, &mut methods, cameras, fps)?;
    drop(methods);
    report_pose_ms("sample-cache rows and 1 spp", &run.pose_ms);
    let all = run.stats;
    let n_cache = labels.len() - 1;
    for (k, (label, stats)) in labels.into_iter().zip(all).enumerate() {
        let n = stats.len().max(1) as f64;
        let naive = k == n_cache;
        profile(label, &stats);
        let (trace_ms, shade_ms) = if naive {
            // First hit and path in one pass (`reference.trace`), as the
            // paper's 1 spp; the pixel-centre pass is diagnostic (not in
            // the frame time: `Reference::with_centre_hits_as_cost`).
            (mean_pass_ms(&stats, "reference.trace"), 0.0)
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
    Ok((rows, scatter_baselines(session, cameras, fps, base, cache)?))
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
/// frame 0 and a sample cache (`cache`) after up to 10 frames. Every frame
/// (those of the sources too) poses an animated scene at its time at `fps`.
fn scatter_baselines(
    session: &Session,
    cameras: &[crate::camera::StereoCamera],
    fps: f64,
    base: &crate::methods::RenderSettings,
    cache: &crate::methods::SampleCacheSettings,
) -> Result<ScatterBaselines> {
    let ctx = &session.ctx;
    let (w, h) = (base.width, base.height);
    let n = (w * h * 2) as u64;
    let slots = cache.slots;
    // First hits of frame 0 from the reference's pixel-centre rays.
    let mut reference = session.create(
        MethodKind::Reference,
        &crate::methods::RenderSettings {
            spp: 1,
            ..base.clone()
        },
    )?;
    pose_frame(session, 0, fps)?;
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
            cache,
        )?;
        use crate::methods::Method;
        let warm = cameras.len().min(11);
        for (i, cam) in cameras[..warm].iter().enumerate() {
            pose_frame(session, i, fps)?;
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
        pose_frame(session, i, fps)?;
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
