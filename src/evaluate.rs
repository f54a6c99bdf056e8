//! Frames against a reference: the reference renders (cached on disk) and
//! the per-frame metrics `compare` reports for every method: the paper's (§5:
//! RSE, sharpness by CPBD, temporal instability and stereo discrepancy as
//! reprojected differences, Figs. 10, 12, 15) and the project's additions
//! (MSE, PSNR, SSIM, HDR-FLIP at the eye's pixels per degree,
//! [`crate::metrics::ppd`]). Temporal instability (frame t−1 reprojected
//! into t) and stereo discrepancy (left reprojected into right) are
//! reported with the reference's own figure on the same mask beside them,
//! so view-dependent effects are not counted as error. The
//! reference is rendered as two independent halves; their difference
//! estimates its own error (`rse_reference`, `mse_reference`,
//! [`crate::metrics::reference_noise`]), which every method's measured error
//! contains, and their HDR-FLIP against each other (`flip_reference_halves`)
//! is what FLIP scores the reference's noise alone at.
//!
//! **One mask for every method.** The temporal and stereo metrics reproject
//! through a [`Covisibility`] built from the *reference's* pixel-centre
//! geometry (its depth and first-hit ids, which do not depend on the seed
//! and are cached with its radiance), never from a method's own hits: every
//! method — and the reference's own instability and discrepancy beside it —
//! is scored on the same pixels, `temporal_covisible` and `stereo_covisible`
//! of them. An eye or frame with no co-visible pixel has no temporal /
//! stereo value (absent, not 0): the means and standard errors are over the
//! frames that have one, the same frames for every method. On a scene with moving instances the same holds for the pixels
//! a moving object has just left (`ghost_pixels`, both eyes together, and
//! the error on them, `ghost_rse`; [`crate::metrics::ghosting`]).

use crate::camera::{Eye, StereoCamera};
use crate::error::{Error, Result};
use crate::methods::{
    EyeImage, FrameInput, FrameStats, Method, MethodKind, RenderSettings, StereoFrame,
};
use crate::metrics::ghosting::{ghost_mask, rse_on_mask};
use crate::metrics::{
    eye_pixels_per_degree, flip_hdr, half_split_error, mean_of_halves, stereo_discrepancy_masked,
    temporal_instability_masked, Covisibility, Geometry, ImageMetrics, LinearImage, ReferenceNoise,
    DEFAULT_PPD, RSE_EPSILON,
};
use crate::replay::NON_FINITE_SAMPLES;
use crate::scene::fnv1a;
use crate::session::Session;
use glam::{DMat4, Mat4};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Relative depth tolerance of co-visibility in the reprojection metrics.
pub const DEPTH_TOLERANCE: f32 = 0.01;

/// The seeds of the two half references of a reference drawn with `seed`
/// (itself [`crate::compare::reference_seed`] of the methods' seed). Both
/// differ from the methods' seed and from each other (xor with distinct
/// non-zero constants), and the shaders hash the seed before use
/// (`rng_init`), so the halves' random numbers are independent.
pub fn half_seeds(seed: u32) -> [u32; 2] {
    [seed, seed ^ 0x85EB_CA6B]
}

/// A reference frame as the metrics use it: the mean of two independent
/// half-sample references (`spp/2` each, [`half_seeds`]), and the error of
/// that mean against the converged image, estimated from the halves
/// ([`crate::metrics::reference_noise`]; mean over both eyes).
#[derive(Clone)]
pub struct ReferenceFrame {
    /// `(A + B)/2`: radiance is the halves' mean; depth and first hits are
    /// the pixel-centre primary hits, which do not depend on the seed.
    pub frame: StereoFrame,
    pub noise: ReferenceNoise,
    /// HDR-FLIP of half A against half B (mean over both eyes) at the PPD
    /// the methods are scored at: what FLIP scores the noise of two
    /// independent `spp/2` references at. `(A + B)/2` has half their
    /// variance, so this is a scale for the floor the reference's noise puts
    /// under every method's FLIP (FLIP is not additive in the noise as RSE
    /// is, so it is not subtracted from anything).
    pub flip_halves: f64,
    /// Pixels holding ∞ or NaN in some channel, counted in both halves of
    /// both eyes (metric `non_finite_reference_pixels`). The path tracer
    /// drops non-finite samples itself ([`Self::non_finite_samples`]), so
    /// this fires only where a pixel's sum overflowed; the mean would hide
    /// it — where one half is finite its value alone is the reference
    /// ([`mean_of_halves`]), where neither is each non-finite channel counts
    /// as 0 in the mean.
    pub non_finite_half_pixels: usize,
    /// Samples the path tracer dropped because their radiance was ∞ or NaN
    /// (counted as black, `reference/trace.comp`), both halves and eyes
    /// (metric `non_finite_reference_samples`): where a half's pixels are
    /// all finite, a bug shows only here.
    pub non_finite_samples: f64,
}

impl ReferenceFrame {
    /// The mean of `halves` and its estimated error; FLIP at `flip_ppd`.
    pub fn from_halves(halves: [StereoFrame; 2], flip_ppd: f32) -> Result<Self> {
        let non_finite_samples = dropped_samples(&halves[0]) + dropped_samples(&halves[1]);
        let [a, b] = halves;
        let (w, h) = (a.width, a.height);
        if (b.width, b.height) != (w, h) {
            return Err(Error::Usage(format!(
                "reference halves of different sizes: {w}x{h} and {}x{}",
                b.width, b.height
            )));
        }
        let m = |e: crate::metrics::MetricsError| Error::Usage(format!("metrics: {e}"));
        let mut noise = Vec::new();
        let mut flip_halves = 0.0;
        let mut frame = a.clone();
        let mut non_finite_half_pixels = 0;
        for e in 0..2 {
            let (ia, ib) = (image(&a.eyes[e], w, h)?, image(&b.eyes[e], w, h)?);
            non_finite_half_pixels += ia.non_finite_count() + ib.non_finite_count();
            noise.push(half_split_error(&ia, &ib, RSE_EPSILON).map_err(m)?);
            flip_halves += 0.5 * flip_hdr(&ia, &ib, flip_ppd).map_err(m)?.flip.mean as f64;
            let mean = mean_of_halves(&ia, &ib).map_err(m)?;
            frame.eyes[e].radiance = mean.rgb.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect();
        }
        frame.stats.rays.primary += b.stats.rays.primary;
        frame.stats.rays.bounce += b.stats.rays.bounce;
        frame.stats.rays.shadow += b.stats.rays.shadow;
        Ok(ReferenceFrame {
            frame,
            noise: ReferenceNoise::mean(&noise),
            flip_halves,
            non_finite_half_pixels,
            non_finite_samples,
        })
    }
}

/// Reference frames rendered by the `reference` method at `settings.spp`
/// samples per pixel as two independent halves of `spp/2` ([`half_seeds`] of
/// `settings.seed`), cached in `dir` (both halves) under a key of scene,
/// pose, size and settings, so a compare run does not recompute them.
pub struct ReferenceCache {
    pub dir: PathBuf,
    pub settings: RenderSettings,
    /// FLIP's pixels per degree for `flip_halves` (`None`: each frame's
    /// [`flip_ppd`]).
    pub flip_ppd: Option<f32>,
    /// The two half renderers, created on the first frame not in the cache.
    renderers: Option<[Box<dyn Method>; 2]>,
}

impl ReferenceCache {
    /// A cache for references of `settings` (`spp` even and at least 2).
    /// The references never go through `--taa-output` (`settings.taa_output`
    /// is dropped): they are the path-traced truth every method is scored
    /// against, and the cache key does not hold the TAA's options. Until
    /// session 50 a compare with `--taa-output` (fig12-13) scored every
    /// method against TAA-resolved references, each frame's history
    /// reprojected at the current pose, and shared their cache entries with
    /// plain references of the same key.
    pub fn new(dir: PathBuf, settings: RenderSettings) -> Result<Self> {
        check_reference_spp(settings.spp)?;
        check_reference_cache_dir(&dir)?;
        Ok(ReferenceCache {
            dir,
            settings: RenderSettings {
                taa_output: None,
                ..settings
            },
            flip_ppd: None,
            renderers: None,
        })
    }

    /// FNV-1a hash of everything that determines the image, the renderer's
    /// own code included: the SPIR-V of the reference shaders (so a change of
    /// the integrator never reuses references rendered by the old one) and
    /// the loaded scene's content (`Scene::content_hash`: geometry,
    /// materials, textures, lights, environment, graphs — so another
    /// `--lighting`, an edited `.bin`, texture, `.mtlx` or environment map
    /// is a new scene; until session 47 the key held the scene file's
    /// length and time, its triangle count and its lights' count instead).
    fn key(&self, session: &Session, cam: &StereoCamera, index: u32) -> String {
        let s = &self.settings;
        let code = fnv1a(
            crate::gpu::shaders::SHADERS
                .iter()
                .filter(|(name, _)| name.starts_with("reference/"))
                .flat_map(|(name, spv)| name.bytes().chain(spv.iter().copied())),
        );
        // A moving scene's frame depends on the instances' pose too (the
        // animation selection and the replay's fps set it); static: no part.
        let pose = if session.scene.is_animated() {
            let h = fnv1a(
                session
                    .scene_gpu
                    .posed_transforms()
                    .iter()
                    .flat_map(|m| m.to_cols_array())
                    .flat_map(f32::to_le_bytes),
            );
            format!("|pose{h:016x}")
        } else {
            String::new()
        };
        // Perspective keys are those of before orthographic cameras existed.
        let projection = match cam.projection {
            crate::camera::Projection::Perspective => String::new(),
            crate::camera::Projection::Orthographic { ymag } => {
                format!("|ortho{:08x}", ymag.to_bits())
            }
        };
        // v4 (session 50): v3 entries of a `--taa-output` run held
        // TAA-resolved references under the plain key.
        let text = format!(
            "v4-halves|{code:016x}|{:016x}|{}|{:?}|{:?}|{:?}|{}x{}|spp{}|b{}|seed{}|frame{}|{}{pose}{projection}",
            session.scene_content_hash(),
            session.scene.source.display(),
            cam.world_position().to_array().map(f64::to_bits),
            cam.head.orientation.to_array().map(f32::to_bits),
            [cam.ipd, cam.yfov, cam.aspect].map(f32::to_bits),
            s.width,
            s.height,
            s.spp,
            s.max_bounces,
            s.seed,
            index,
            env!("CARGO_PKG_VERSION"),
        );
        format!("{:016x}", fnv1a(text.bytes()))
    }

    /// The reference for frame `index` at `cam`: read from the cache, or
    /// rendered (both halves) and stored.
    pub fn get(
        &mut self,
        session: &Session,
        cam: &StereoCamera,
        index: u32,
    ) -> Result<ReferenceFrame> {
        let path = self
            .dir
            .join(format!("{}.ref", self.key(session, cam, index)));
        let cached =
            read_halves(&path, self.settings.width, self.settings.height).unwrap_or_else(|why| {
                eprintln!(
                    "warning: {}: unusable reference cache entry ({why}); rendering it again",
                    path.display()
                );
                None
            });
        let halves = match cached {
            Some(h) => h,
            None => {
                if self.renderers.is_none() {
                    let [sa, sb] = half_seeds(self.settings.seed);
                    let half = |seed| RenderSettings {
                        spp: self.settings.spp / 2,
                        seed,
                        ..self.settings.clone()
                    };
                    self.renderers = Some([
                        session.create(MethodKind::Reference, &half(sa))?,
                        session.create(MethodKind::Reference, &half(sb))?,
                    ]);
                }
                let input = FrameInput {
                    index,
                    camera: *cam,
                    prev_camera: None,
                };
                let [ra, rb] = self.renderers.as_mut().expect("created above");
                let halves = [ra.render_frame(&input)?, rb.render_frame(&input)?];
                std::fs::create_dir_all(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
                write_halves(&path, &halves)?;
                halves
            }
        };
        let ppd = self
            .flip_ppd
            .unwrap_or_else(|| flip_ppd(cam, self.settings.width));
        ReferenceFrame::from_halves(halves, ppd)
    }
}

/// `--reference-spp` must split into two equal halves.
pub fn check_reference_spp(spp: u32) -> Result<()> {
    if spp >= 2 && spp % 2 == 0 {
        Ok(())
    } else {
        Err(Error::Usage(format!(
            "bad --reference-spp {spp}: expected an even number of at least 2 (the reference is rendered as two independent halves of spp/2 samples, whose difference estimates its own error)"
        )))
    }
}

const MAGIC: &[u8; 8] = b"SCREF03\n";

/// The reference path tracer's count of dropped (∞ or NaN) samples, as its
/// frames report it (`reference/trace.comp`).
fn dropped_samples(f: &StereoFrame) -> f64 {
    f.stats
        .counters
        .get(NON_FINITE_SAMPLES)
        .copied()
        .unwrap_or(0.0)
}

/// Both halves: header (magic, width, height, each half's dropped
/// non-finite samples as u64 — `SCREF03` since session 55), radiance of
/// half A (left, right), of half B (left, right), then depth and first hits
/// (left, right) once — they come from the pixel-centre primary rays and
/// are the same in both halves.
fn write_halves(path: &Path, f: &[StereoFrame; 2]) -> Result<()> {
    let mut bytes = Vec::new();
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&f[0].width.to_le_bytes());
    bytes.extend_from_slice(&f[0].height.to_le_bytes());
    for half in f {
        bytes.extend_from_slice(&(dropped_samples(half) as u64).to_le_bytes());
    }
    for half in f {
        for e in &half.eyes {
            bytes.extend_from_slice(bytemuck::cast_slice(&e.radiance));
        }
    }
    for e in &f[0].eyes {
        bytes.extend_from_slice(bytemuck::cast_slice(&e.depth));
        bytes.extend_from_slice(bytemuck::cast_slice(&e.first_hit));
    }
    crate::output::write_file(path, &bytes)?;
    Ok(())
}

/// Refuses a `--reference-cache` that cannot be a folder (a file, a path
/// below a file, an unwritable place) before anything renders: it used to
/// fail when the first reference was stored, after every method rendered.
pub fn check_reference_cache_dir(dir: &Path) -> Result<()> {
    crate::values::check_output_dir(dir)
        .map_err(|m| Error::Usage(format!("bad --reference-cache: {m}")))
}

/// Reads cached halves: `Ok(None)` when absent; an error (the reason) when
/// the file is there but unusable — truncated, another size or format, or
/// holding non-finite radiance or NaN depth (a corrupt body behind a valid
/// header was used as the reference) — and the caller renders it again.
fn read_halves(
    path: &Path,
    width: u32,
    height: u32,
) -> std::result::Result<Option<[StereoFrame; 2]>, String> {
    let bytes = match crate::input::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("cannot read: {e}")),
    };
    let n = (width as usize) * (height as usize);
    let rad = n * 16;
    let geo = n * (4 + 16);
    let head = 32;
    let want = head + 4 * rad + 2 * geo;
    if bytes.len() < head || &bytes[..8] != MAGIC {
        return Err("not a SCREF03 reference file".into());
    }
    let w = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    let h = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes"));
    if (w, h) != (width, height) {
        return Err(format!("{w}x{h} per eye, not {width}x{height}"));
    }
    if bytes.len() != want {
        return Err(format!("{} bytes, not {want}", bytes.len()));
    }
    let dropped =
        [16, 24].map(|o| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes")));
    let body = &bytes[head..];
    let floats = |b: &[u8]| -> Vec<f32> { bytemuck::pod_collect_to_vec(b) };
    if !floats(&body[..4 * rad]).iter().all(|v| v.is_finite()) {
        return Err("non-finite radiance".into());
    }
    for e in 0..2 {
        let g = &body[4 * rad + e * geo..4 * rad + e * geo + n * 4];
        if floats(g).iter().any(|v| v.is_nan()) {
            return Err("NaN depth".into());
        }
    }
    let eye = |half: usize, e: usize| {
        let r = &body[(2 * half + e) * rad..(2 * half + e + 1) * rad];
        let g = &body[4 * rad + e * geo..4 * rad + (e + 1) * geo];
        EyeImage {
            radiance: bytemuck::pod_collect_to_vec(r),
            depth: bytemuck::pod_collect_to_vec(&g[..n * 4]),
            first_hit: bytemuck::pod_collect_to_vec(&g[n * 4..]),
            albedo: Vec::new(),
            debug: Vec::new(),
        }
    };
    let frame = |half: usize| {
        let mut stats = FrameStats::default();
        stats
            .counters
            .insert(NON_FINITE_SAMPLES.into(), dropped[half] as f64);
        StereoFrame {
            width,
            height,
            eyes: [eye(half, 0), eye(half, 1)],
            stats,
        }
    };
    Ok(Some([frame(0), frame(1)]))
}

fn image(e: &EyeImage, w: u32, h: u32) -> Result<LinearImage> {
    LinearImage::from_rgba(&e.radiance, w as usize, h as usize)
        .map_err(|e| Error::Usage(format!("metrics: {e}")))
}

/// FLIP's pixels per degree for eye images `width` pixels wide seen through
/// `cam`: the exact angle of one pixel at the image centre
/// ([`crate::metrics::ppd`]; both eyes share one frustum), or
/// [`DEFAULT_PPD`] for a degenerate camera.
pub fn flip_ppd(cam: &StereoCamera, width: u32) -> f32 {
    eye_pixels_per_degree(&cam.eye(Eye::Left), width).unwrap_or(DEFAULT_PPD)
}

/// Every metric [`Evaluator::frame`] can give a frame (the keys of a
/// summary row's `metrics`), for checking names before anything renders.
pub const METRIC_NAMES: &[&str] = &[
    "rse",
    "mse",
    "psnr",
    "ssim",
    "flip",
    "cpbd",
    "cpbd_reference",
    "non_finite_pixels",
    "non_finite_reference_pixels",
    "non_finite_reference_samples",
    "rse_reference",
    "mse_reference",
    "flip_reference_halves",
    "temporal",
    "temporal_reference",
    "temporal_excess",
    "temporal_covisible",
    "ghost_pixels",
    "ghost_rse",
    "stereo_covisible",
    "stereo_mean",
    "stereo_p95",
    "stereo_mean_reference",
    "stereo_p95_reference",
    "stereo_excess",
];

/// Per-method running evaluation: call `frame` for every frame in order.
#[derive(Default)]
pub struct Evaluator {
    /// The method's previous frame.
    prev: Option<StereoFrame>,
    /// The previous reference frame and camera: the geometry of the temporal mask.
    prev_ref: Option<(StereoFrame, StereoCamera)>,
    /// FLIP's pixels per degree (`None`: [`flip_ppd`] of each frame's camera).
    pub flip_ppd: Option<f32>,
    /// Which instances move (`Scene::instance_moves`; empty: none): where one
    /// does, each frame from the second on also reports `ghost_pixels` and
    /// `ghost_rse` ([`crate::metrics::ghosting`]).
    pub moving: Vec<bool>,
    /// The instances' object-to-world transforms at the frame the next
    /// [`Self::frame`] call scores (`Scene::instance_transforms_at`; the
    /// caller sets it before each call where an instance moves; empty: a
    /// still scene): the temporal mask follows a moving instance's surface
    /// points from the previous frame's pose to this one's.
    pub pose: Vec<Mat4>,
    /// `pose` at the previous frame.
    prev_pose: Vec<Mat4>,
    /// Every metric's per-frame values, in frame order.
    series: BTreeMap<String, Vec<f64>>,
}

/// The reference's geometry of eye `eye`: what every method's mask is built from.
fn geometry<'a>(
    reference: &'a StereoFrame,
    view: &'a crate::camera::EyeView,
    eye: usize,
) -> Geometry<'a> {
    Geometry {
        depth: &reference.eyes[eye].depth,
        view,
        first_hits: Some(&reference.eyes[eye].first_hit),
    }
}

impl Evaluator {
    /// An evaluator scoring FLIP at `flip_ppd` (`None`: derived per frame).
    pub fn new(flip_ppd: Option<f32>) -> Self {
        Evaluator {
            flip_ppd,
            ..Default::default()
        }
    }

    /// Metrics of `frame` (rendered at `cam`) against `reference`, averaged
    /// over both eyes, with the reference's own estimated error beside them
    /// (`rse_reference`, `mse_reference`: the floor under `rse` and `mse`;
    /// `flip_reference_halves`). The temporal and stereo metrics use masks
    /// from the reference's geometry only (module documentation): the
    /// method's own depth and first hits are not read.
    pub fn frame(
        &mut self,
        cam: &StereoCamera,
        frame: &StereoFrame,
        reference_frame: &ReferenceFrame,
    ) -> Result<BTreeMap<String, f64>> {
        let reference = &reference_frame.frame;
        let (w, h) = (frame.width, frame.height);
        if (reference.width, reference.height) != (w, h) {
            return Err(Error::Usage(format!(
                "metrics: a {w}x{h} frame against a {}x{} reference",
                reference.width, reference.height
            )));
        }
        let (wu, hu) = (w as usize, h as usize);
        let m = |e: crate::metrics::MetricsError| Error::Usage(format!("metrics: {e}"));
        let ppd = self.flip_ppd.unwrap_or_else(|| flip_ppd(cam, w));
        let views_now = cam.eyes();
        let imgs: Vec<LinearImage> = frame
            .eyes
            .iter()
            .map(|e| image(e, w, h))
            .collect::<Result<_>>()?;
        let refs: Vec<LinearImage> = reference
            .eyes
            .iter()
            .map(|e| image(e, w, h))
            .collect::<Result<_>>()?;
        let mut out: BTreeMap<String, f64> = BTreeMap::new();
        let mut add = |k: &str, v: f64| *out.entry(k.to_string()).or_insert(0.0) += v * 0.5;
        // PSNR of the stereo pair: of the two eyes' display-image MSE
        // together (each eye's 10^(−PSNR/10)), +∞ only when both eyes are
        // identical to the reference. (Until session 48 an identical eye
        // counted as 100 dB in a mean of the eyes' dB: [∞, 30] gave 65.)
        let mut display_mse = 0.0;
        // CPBD of the eyes that have edges to measure (ImageMetrics: none
        // in a flat image); the mean over those, absent when neither has
        // one. (Until session 49 a flat eye counted as CPBD 0 in the mean:
        // a sky-only eye beside one at 0.9 gave 0.45.)
        let (mut cpbd_x, mut cpbd_r) = (Vec::new(), Vec::new());
        for e in 0..2 {
            let im = ImageMetrics::compute_at(&imgs[e], &refs[e], ppd).map_err(m)?;
            add("rse", im.rse as f64);
            add("mse", im.mse as f64);
            display_mse += 0.5 * 10f64.powf(-(im.psnr as f64) / 10.0);
            add("ssim", im.ssim as f64);
            add("flip", im.flip as f64);
            cpbd_x.extend(im.cpbd.map(f64::from));
            cpbd_r.extend(im.cpbd_reference.map(f64::from));
            // Pixels holding ∞ or NaN in some channel, both eyes together
            // (2 × the eyes' mean): every metric scores those channels as 0
            // (LinearImage::sanitized), so they are counted here and named
            // by compare's warning.
            add("non_finite_pixels", 2.0 * im.non_finite as f64);
        }
        for (k, v) in [("cpbd", &cpbd_x), ("cpbd_reference", &cpbd_r)] {
            if !v.is_empty() {
                out.insert(k.to_string(), v.iter().sum::<f64>() / v.len() as f64);
            }
        }
        out.insert(
            "psnr".to_string(),
            if display_mse > 0.0 {
                -10.0 * display_mse.log10()
            } else {
                f64::INFINITY
            },
        );
        // Temporal instability: t−1 reprojected into t, for the method and
        // the reference, through one mask from the reference's geometry.
        // An eye with an empty mask has no value: the others are the mean
        // over the eyes that have one, and a frame where neither has one has
        // none (the keys are absent, not 0, and the frame is left out of the
        // means). `temporal_covisible` is a fraction, 0 included.
        if let (Some(pf), Some((rf, rc))) = (&self.prev, &self.prev_ref) {
            let rviews = rc.eyes();
            let mut scored: Vec<[f64; 3]> = Vec::new();
            let mut covisible = 0.0;
            // Each moving instance's motion from this frame's pose back to
            // the previous one's (f64: a small motion of a far object).
            let motion: Vec<Option<DMat4>> = self
                .moving
                .iter()
                .enumerate()
                .map(|(k, &mv)| {
                    let (now, before) = (self.pose.get(k)?, self.prev_pose.get(k)?);
                    mv.then(|| before.as_dmat4() * now.as_dmat4().inverse())
                })
                .collect();
            for e in 0..2 {
                let cov = Covisibility::with_motion(
                    geometry(rf, &rviews[e], e),
                    geometry(reference, &views_now[e], e),
                    wu,
                    hu,
                    DEPTH_TOLERANCE,
                    &motion,
                )
                .map_err(m)?;
                covisible += 0.5 * cov.fraction() as f64;
                if cov.is_empty() {
                    continue;
                }
                let pimg = image(&pf.eyes[e], w, h)?;
                let rimg = image(&rf.eyes[e], w, h)?;
                let tm = temporal_instability_masked(&pimg, &imgs[e], &cov).map_err(m)?;
                let tr = temporal_instability_masked(&rimg, &refs[e], &cov).map_err(m)?;
                scored.push([tm.mean, tr.mean, tm.mean - tr.mean].map(f64::from));
            }
            out.insert("temporal_covisible".into(), covisible);
            if !scored.is_empty() {
                // Per eye as before (the excess in f32): a frame with both
                // eyes scored has the same figures as when every frame was.
                let n = scored.len() as f64;
                let mean = |c: usize| scored.iter().map(|s| s[c]).sum::<f64>() / n;
                out.insert("temporal".into(), mean(0));
                out.insert("temporal_reference".into(), mean(1));
                out.insert("temporal_excess".into(), mean(2));
            }
        }
        // Ghosting: the error on the pixels a moving instance has just left
        // (reference geometry of t−1 and t), both eyes' pixels pooled;
        // `ghost_rse` only on frames that have such pixels.
        if let (true, Some((rf, rc))) = (self.moving.contains(&true), &self.prev_ref) {
            let rviews = rc.eyes();
            let (mut sum, mut count) = (0.0, 0usize);
            for e in 0..2 {
                let mask = ghost_mask(
                    geometry(rf, &rviews[e], e),
                    geometry(reference, &views_now[e], e),
                    &self.moving,
                    wu,
                    hu,
                )
                .map_err(m)?;
                let (s, c) = rse_on_mask(&imgs[e], &refs[e], &mask, RSE_EPSILON).map_err(m)?;
                sum += s;
                count += c;
            }
            out.insert("ghost_pixels".into(), count as f64);
            if count > 0 {
                out.insert("ghost_rse".into(), sum / (3 * count) as f64);
            }
        }
        // Stereo discrepancy: left into right, one mask from the reference pair.
        let (l, r) = (Eye::Left.index(), Eye::Right.index());
        let cov = Covisibility::new(
            geometry(reference, &views_now[l], l),
            geometry(reference, &views_now[r], r),
            wu,
            hu,
            DEPTH_TOLERANCE,
        )
        .map_err(m)?;
        // An empty mask: no stereo value this frame (keys absent, not 0).
        out.insert("stereo_covisible".into(), cov.fraction() as f64);
        if !cov.is_empty() {
            let sm = stereo_discrepancy_masked(&imgs[l], &imgs[r], &cov).map_err(m)?;
            let sr = stereo_discrepancy_masked(&refs[l], &refs[r], &cov).map_err(m)?;
            out.insert("stereo_mean".into(), sm.mean as f64);
            out.insert("stereo_p95".into(), sm.p95 as f64);
            out.insert("stereo_mean_reference".into(), sr.mean as f64);
            out.insert("stereo_p95_reference".into(), sr.p95 as f64);
            out.insert("stereo_excess".into(), (sm.mean - sr.mean) as f64);
        }
        // The reference's own error: the floor under `rse` and `mse`; FLIP's scale.
        out.insert("rse_reference".into(), reference_frame.noise.rse);
        out.insert("mse_reference".into(), reference_frame.noise.mse);
        out.insert("flip_reference_halves".into(), reference_frame.flip_halves);
        out.insert(
            "non_finite_reference_pixels".into(),
            reference_frame.non_finite_half_pixels as f64,
        );
        out.insert(
            "non_finite_reference_samples".into(),
            reference_frame.non_finite_samples,
        );
        for (k, v) in &out {
            self.series.entry(k.clone()).or_default().push(*v);
        }
        self.prev = Some(frame.clone());
        self.prev_ref = Some((reference.clone(), *cam));
        self.prev_pose = std::mem::take(&mut self.pose);
        Ok(out)
    }

    /// Means over the frames evaluated so far that have the metric (the
    /// temporal ones from the second frame on; the temporal and stereo ones
    /// only where the co-visible mask is not empty; `ghost_rse` only where
    /// there are ghost pixels); [`Self::counts`] says over how many.
    pub fn means(&self) -> BTreeMap<String, f64> {
        self.series
            .iter()
            .map(|(k, v)| (k.clone(), v.iter().sum::<f64>() / v.len() as f64))
            .collect()
    }

    /// Standard errors of [`Self::means`] over the frames
    /// ([`crate::metrics::uncertainty`]; `∞` below two frames).
    pub fn stderrs(&self) -> BTreeMap<String, f64> {
        self.series
            .iter()
            .filter_map(|(k, v)| crate::metrics::mean_stderr(v).map(|s| (k.clone(), s.stderr)))
            .collect()
    }

    /// Every metric's per-frame values in frame order, over the frames that
    /// have it ([`Self::means`]). The temporal and stereo masks come from
    /// the reference's geometry, so every method has the same frames.
    pub fn series(&self) -> &BTreeMap<String, Vec<f64>> {
        &self.series
    }

    /// How many frames each metric was scored on (the length of its series).
    pub fn counts(&self) -> BTreeMap<String, usize> {
        self.series
            .iter()
            .map(|(k, v)| (k.clone(), v.len()))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cache entry for 2×1 pixels per eye: zero body, radiance 1.
    fn entry(w: u32, h: u32) -> Vec<u8> {
        let n = (w * h) as usize;
        let mut b = MAGIC.to_vec();
        b.extend(w.to_le_bytes());
        b.extend(h.to_le_bytes());
        b.extend(3u64.to_le_bytes());
        b.extend(0u64.to_le_bytes());
        b.extend(std::iter::repeat_n(1f32.to_le_bytes(), 4 * n * 4).flatten());
        b.extend(std::iter::repeat_n(0u8, 2 * n * 20));
        b
    }

    /// A valid header with NaN in the body was used as the reference
    /// (`"rse": null` downstream); now it is refused, with the reason, and
    /// `get` renders it again with a warning naming the file.
    #[test]
    fn corrupt_reference_entries_are_misses_with_a_reason() {
        let dir = std::env::temp_dir().join(format!("stereocache-refcache-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.ref");
        assert!(read_halves(&p, 2, 1).unwrap().is_none(), "absent");
        std::fs::write(&p, entry(2, 1)).unwrap();
        let [a, b] = read_halves(&p, 2, 1).unwrap().unwrap();
        assert_eq!(a.eyes[1].radiance, vec![[1.0; 4]; 2]);
        // The halves' dropped-sample counts come back.
        assert_eq!((dropped_samples(&a), dropped_samples(&b)), (3.0, 0.0));
        let mut nan = entry(2, 1);
        nan[32 + 8..32 + 12].copy_from_slice(&f32::NAN.to_le_bytes());
        std::fs::write(&p, &nan).unwrap();
        assert_eq!(read_halves(&p, 2, 1).unwrap_err(), "non-finite radiance");
        let mut inf = entry(2, 1);
        let end = inf.len();
        inf[end - 40 * 2 + 4..end - 40 * 2 + 8].copy_from_slice(&f32::NAN.to_le_bytes());
        std::fs::write(&p, &inf).unwrap();
        assert_eq!(read_halves(&p, 2, 1).unwrap_err(), "NaN depth");
        std::fs::write(&p, &entry(2, 1)[..40]).unwrap();
        assert!(read_halves(&p, 2, 1).unwrap_err().contains("bytes, not"));
        std::fs::write(&p, entry(2, 1)).unwrap();
        assert_eq!(read_halves(&p, 4, 1).unwrap_err(), "2x1 per eye, not 4x1");
        std::fs::write(&p, b"SCREF01\n").unwrap();
        assert!(read_halves(&p, 2, 1).unwrap_err().contains("not a SCREF03"));
        // A SCREF02 entry (no counts) is another format: rendered again.
        let mut old = entry(2, 1);
        old[..8].copy_from_slice(b"SCREF02\n");
        std::fs::write(&p, &old).unwrap();
        assert!(read_halves(&p, 2, 1).unwrap_err().contains("not a SCREF03"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_reference_cache_that_is_a_file_is_refused() {
        let f =
            std::env::temp_dir().join(format!("stereocache-refcache-file-{}", std::process::id()));
        std::fs::write(&f, b"x").unwrap();
        let settings = RenderSettings {
            spp: 2,
            ..Default::default()
        };
        let e = ReferenceCache::new(f.clone(), settings)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.starts_with("bad --reference-cache: ") && e.contains("is a file"),
            "{e}"
        );
        let _ = std::fs::remove_file(&f);
    }
    /// A frame or eye whose co-visible mask is empty (here: the reference
    /// sees only sky there) contributes no temporal / stereo value — not a
    /// 0 that reads as perfectly stable. Uniform grey images make every
    /// scored value exact: eye `e` of frame `k` is `L[k]` / `R[k]`. Frame 2's
    /// right eye and all of frame 3 see sky; so stereo is scored on frames
    /// 0, 1, 4 (|L − R| = 0.1, 0.2, 0.3), temporal on frame 1 (both eyes:
    /// (0.1 + 0.4)/2) and frame 2 (left eye only: 0.3); frames 3 and 4 have
    /// no temporal value (sky at t or at t − 1).
    #[test]
    fn empty_covisible_masks_are_skipped_not_zero() {
        use crate::camera::HeadPose;
        const N: usize = 32;
        let cam = StereoCamera::new(
            HeadPose::new(glam::Vec3::new(0.0, 1.0, 0.0), glam::Quat::IDENTITY),
            90f32.to_radians(),
            1.0,
        );
        let grey = |v: f32| vec![[v, v, v, 1.0]; N * N];
        let eye = |radiance, sky: bool| EyeImage {
            radiance,
            depth: vec![if sky { 0.0 } else { 1.0 }; N * N],
            first_hit: (0..N * N).map(|i| [i as u32, 0, 3, 1]).collect(),
            albedo: Vec::new(),
            debug: Vec::new(),
        };
        let frame = |eyes| StereoFrame {
            width: N as u32,
            height: N as u32,
            eyes,
            stats: Default::default(),
        };
        let (l, r) = ([0.5, 0.6, 0.9, 0.3, 0.4], [0.4, 0.8, 0.1, 0.7, 0.7]);
        let sky = [[false; 2], [false; 2], [false, true], [true; 2], [false; 2]];
        let mut ev = Evaluator::new(None);
        let per_frame: Vec<_> = (0..5)
            .map(|k| {
                let reference = || frame([eye(grey(0.5), sky[k][0]), eye(grey(0.5), sky[k][1])]);
                let reference =
                    ReferenceFrame::from_halves([reference(), reference()], 10.0).unwrap();
                let method = frame([eye(grey(l[k]), false), eye(grey(r[k]), false)]);
                ev.frame(&cam, &method, &reference).unwrap()
            })
            .collect();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-6;
        // Every key a frame gives is a listed metric name (claims check
        // names against the list before rendering).
        for k in per_frame.iter().flat_map(|f| f.keys()) {
            assert!(
                METRIC_NAMES.contains(&k.as_str()),
                "{k} not in METRIC_NAMES"
            );
        }
        // Which frames carry a value (absent, not 0, where the mask is empty).
        let has = |k: &str| -> Vec<bool> { per_frame.iter().map(|f| f.contains_key(k)).collect() };
        assert_eq!(has("temporal"), [false, true, true, false, false]);
        assert_eq!(has("temporal_excess"), has("temporal"));
        assert_eq!(has("stereo_mean"), [true, true, false, false, true]);
        assert_eq!(has("stereo_excess"), has("stereo_mean"));
        // The fractions are true values, 0 included, on every frame.
        assert_eq!(has("temporal_covisible"), [false, true, true, true, true]);
        assert_eq!(per_frame[3]["temporal_covisible"], 0.0);
        assert_eq!(per_frame[2]["stereo_covisible"], 0.0);
        // Frame 2: the left eye's value alone, not halved by the empty right eye.
        assert!(close(per_frame[2]["temporal"], 0.3), "{per_frame:?}");
        let (means, se) = (ev.means(), ev.stderrs());
        // Two temporal values, 0.25 and 0.3: mean 0.275, standard error 0.025.
        assert_eq!(ev.series()["temporal"].len(), 2);
        assert!(close(means["temporal"], 0.275), "{means:?}");
        assert!(close(se["temporal"], 0.025), "{se:?}");
        assert!(close(means["temporal_excess"], 0.275), "{means:?}");
        // Three stereo values, 0.1, 0.2, 0.3: mean 0.2, standard error 0.1/√3.
        assert_eq!(ev.series()["stereo_mean"].len(), 3);
        assert!(close(means["stereo_mean"], 0.2), "{means:?}");
        assert!(close(se["stereo_mean"], 0.1 / 3f64.sqrt()), "{se:?}");
        assert!(close(means["stereo_excess"], 0.2), "{means:?}");
        // PSNR of the pair: frame 0's left eye is the reference (0.5), its
        // right eye 0.1 off: the pair's display MSE is (0 + 0.01) / 2, so
        // 23.01 dB (not the mean of 100 and 20 dB); frame 1: (0.01 + 0.09) / 2.
        assert!(
            (per_frame[0]["psnr"] + 10.0 * 0.005f64.log10()).abs() < 1e-4,
            "{per_frame:?}"
        );
        assert!(
            (per_frame[1]["psnr"] + 10.0 * 0.05f64.log10()).abs() < 1e-4,
            "{per_frame:?}"
        );
    }
}
