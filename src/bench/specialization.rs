//! `bench specialization`: what pipelines specialized to a scene's features
//! and skipped passes save against the all-features build.

use super::interleave::{check_frame_poses, paired_ratio, report_pose_ms, run_interleaved};
use crate::error::Result;
use crate::methods::MethodKind;
use crate::output::csv_field;
use crate::session::Session;
use serde::Serialize;

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
    "vertex_colors",
    "clearcoat",
    "backface_culling",
    "second_uv",
    "uv_affine",
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
        "vertex_colors" => &mut f.vertex_colors,
        "clearcoat" => &mut f.clearcoat,
        "backface_culling" => &mut f.backface_culling,
        "second_uv" => &mut f.second_uv,
        "uv_affine" => &mut f.uv_affine,
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
    /// Standard error of `ratio`, a ratio of the means (frames paired): the
    /// delta method widened for lag-1 autocorrelation (`interleave::paired_ratio`;
    /// until session 48 the error of the mean per-frame ratio).
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
/// the same frames interleaved (frame by frame, in a carry-over balanced order) so drift
/// of a shared machine hits them alike. `cameras` are frames at `fps`: an
/// animated scene is posed at each frame's time (its poses checked before
/// anything renders), as replay poses it.
#[allow(clippy::too_many_arguments)]
pub fn bench_specialization(
    session: &Session,
    scene_label: &str,
    methods: &[MethodKind],
    bounce_counts: &[u32],
    cameras: &[crate::camera::StereoCamera],
    fps: f64,
    base: &crate::methods::RenderSettings,
) -> Result<Vec<SpecBenchRow>> {
    use crate::methods::RenderSettings;
    check_frame_poses(session, cameras.len(), fps)?;
    let used = session.scene_gpu.features;
    let max_bounces = bounce_counts.iter().copied().max().unwrap_or(0);
    let mut rows = Vec::new();
    for &method in methods {
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
                instances.push(session.create(method, s)?);
            }
            // times[build][frame], pass counts per build.
            let run = run_interleaved(session, &mut instances, cameras, fps)?;
            drop(instances);
            report_pose_ms(
                &format!("{scene_label}, {}, {bounces} bounces", method.name()),
                &run.pose_ms,
            );
            let stats = run.stats;
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
                    method: method.name().to_string(),
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
            csv_field(&r.scene),
            csv_field(&r.method),
            r.bounces,
            csv_field(&r.build),
            r.passes,
            r.frame_ms,
            r.ratio,
            r.ratio_se,
            csv_field(&r.against)
        ));
    }
    c
}
