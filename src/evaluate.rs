//! Frames against a reference: the reference renders (cached on disk) and
//! the per-frame metrics `compare` reports for every method (§5 of the paper):
//! error (RSE, MSE, PSNR, SSIM, HDR-FLIP), sharpness (CPBD), temporal
//! instability (frame t−1 reprojected into t, method minus reference) and
//! stereo discrepancy (left reprojected into right, with the reference
//! pair's own discrepancy beside it so view-dependent effects are not
//! counted as error).

use crate::camera::{Eye, StereoCamera};
use crate::error::{Error, Result};
use crate::methods::{EyeImage, FrameInput, Method, RenderSettings, StereoFrame};
use crate::metrics::{
    stereo::stereo_discrepancy, temporal::temporal_instability, ImageMetrics, LinearImage,
    ViewBuffers,
};
use crate::session::Session;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Relative depth tolerance of co-visibility in the reprojection metrics.
pub const DEPTH_TOLERANCE: f32 = 0.01;

/// Reference frames rendered by the `reference` method at `spp`, cached in
/// `dir` under a key of scene, pose, size and settings, so a compare run
/// does not recompute them.
pub struct ReferenceCache {
    pub dir: PathBuf,
    pub settings: RenderSettings,
}

impl ReferenceCache {
    /// FNV-1a hash of everything that determines the image.
    fn key(&self, session: &Session, cam: &StereoCamera, index: u32) -> String {
        let s = &self.settings;
        let text = format!(
            "v1|{}|{}|{:?}|{:?}|{:?}|{}|{}|{}x{}|spp{}|b{}|seed{}|frame{}|{}",
            session.scene.source.display(),
            session.scene_gpu.triangle_count,
            cam.world_position().to_array().map(f64::to_bits),
            cam.head.orientation.to_array().map(f32::to_bits),
            [cam.ipd, cam.yfov, cam.aspect].map(f32::to_bits),
            session.scene.lights.len(),
            session.scene.environment.is_some(),
            s.width,
            s.height,
            s.spp,
            s.max_bounces,
            s.seed,
            index,
            env!("CARGO_PKG_VERSION"),
        );
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in text.bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01B3);
        }
        format!("{h:016x}")
    }

    /// The reference for frame `index` at `cam`: read from the cache, or rendered and stored.
    pub fn get(
        &self,
        session: &Session,
        method: &mut dyn Method,
        cam: &StereoCamera,
        index: u32,
    ) -> Result<StereoFrame> {
        let path = self
            .dir
            .join(format!("{}.ref", self.key(session, cam, index)));
        if let Some(f) = read_frame(&path, self.settings.width, self.settings.height) {
            return Ok(f);
        }
        let f = method.render_frame(&FrameInput {
            index,
            camera: *cam,
            prev_camera: None,
        })?;
        std::fs::create_dir_all(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
        write_frame(&path, &f)?;
        Ok(f)
    }
}

const MAGIC: &[u8; 8] = b"SCREF01\n";

fn write_frame(path: &Path, f: &StereoFrame) -> Result<()> {
    let mut bytes = Vec::new();
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&f.width.to_le_bytes());
    bytes.extend_from_slice(&f.height.to_le_bytes());
    for e in &f.eyes {
        bytes.extend_from_slice(bytemuck::cast_slice(&e.radiance));
        bytes.extend_from_slice(bytemuck::cast_slice(&e.depth));
        bytes.extend_from_slice(bytemuck::cast_slice(&e.first_hit));
    }
    crate::output::write_file(path, &bytes)?;
    Ok(())
}

/// Reads a cached reference; `None` when absent, truncated or of another size.
fn read_frame(path: &Path, width: u32, height: u32) -> Option<StereoFrame> {
    let bytes = std::fs::read(path).ok()?;
    let n = (width * height) as usize;
    let per_eye = n * (16 + 4 + 16);
    if bytes.len() != 16 + 2 * per_eye || &bytes[..8] != MAGIC {
        return None;
    }
    let w = u32::from_le_bytes(bytes[8..12].try_into().ok()?);
    let h = u32::from_le_bytes(bytes[12..16].try_into().ok()?);
    if (w, h) != (width, height) {
        return None;
    }
    let eye = |k: usize| {
        let b = &bytes[16 + k * per_eye..16 + (k + 1) * per_eye];
        EyeImage {
            radiance: bytemuck::pod_collect_to_vec(&b[..n * 16]),
            depth: bytemuck::pod_collect_to_vec(&b[n * 16..n * 20]),
            first_hit: bytemuck::pod_collect_to_vec(&b[n * 20..]),
            albedo: Vec::new(),
            debug: Vec::new(),
        }
    };
    Some(StereoFrame {
        width,
        height,
        eyes: [eye(0), eye(1)],
        stats: Default::default(),
    })
}

fn image(e: &EyeImage, w: u32, h: u32) -> Result<LinearImage> {
    LinearImage::from_rgba(&e.radiance, w as usize, h as usize)
        .map_err(|e| Error::Usage(format!("metrics: {e}")))
}

/// Per-method running evaluation: call `frame` for every frame in order.
#[derive(Default)]
pub struct Evaluator {
    prev: Option<(StereoFrame, StereoCamera)>,
    prev_ref: Option<(StereoFrame, StereoCamera)>,
    sums: BTreeMap<String, (f64, usize)>,
}

fn views<'a>(
    f: &'a StereoFrame,
    img: &'a LinearImage,
    cam: &'a crate::camera::EyeView,
    eye: usize,
) -> ViewBuffers<'a> {
    ViewBuffers {
        image: img,
        depth: &f.eyes[eye].depth,
        view: cam,
        first_hits: Some(&f.eyes[eye].first_hit),
    }
}

impl Evaluator {
    /// Metrics of `frame` (rendered at `cam`) against `reference`, averaged over both eyes.
    pub fn frame(
        &mut self,
        cam: &StereoCamera,
        frame: &StereoFrame,
        reference: &StereoFrame,
    ) -> Result<BTreeMap<String, f64>> {
        let (w, h) = (frame.width, frame.height);
        let m = |e: crate::metrics::MetricsError| Error::Usage(format!("metrics: {e}"));
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
        for e in 0..2 {
            let im = ImageMetrics::compute(&imgs[e], &refs[e]).map_err(m)?;
            add("rse", im.rse as f64);
            add("mse", im.mse as f64);
            add(
                "psnr",
                if im.psnr.is_finite() {
                    im.psnr as f64
                } else {
                    100.0
                },
            );
            add("ssim", im.ssim as f64);
            add("flip", im.flip as f64);
            add("cpbd", im.cpbd as f64);
            add("cpbd_reference", im.cpbd_reference as f64);
        }
        // Temporal instability: t−1 reprojected into t, for the method and the reference.
        if let (Some((pf, pc)), Some((rf, rc))) = (&self.prev, &self.prev_ref) {
            let pviews = pc.eyes();
            let rviews = rc.eyes();
            for e in 0..2 {
                let pimg = image(&pf.eyes[e], w, h)?;
                let rimg = image(&rf.eyes[e], w, h)?;
                let tm = temporal_instability(
                    &views(pf, &pimg, &pviews[e], e),
                    &views(frame, &imgs[e], &views_now[e], e),
                    DEPTH_TOLERANCE,
                )
                .map_err(m)?;
                let tr = temporal_instability(
                    &views(rf, &rimg, &rviews[e], e),
                    &views(reference, &refs[e], &views_now[e], e),
                    DEPTH_TOLERANCE,
                )
                .map_err(m)?;
                add("temporal", tm.mean as f64);
                add("temporal_reference", tr.mean as f64);
                add("temporal_excess", (tm.mean - tr.mean) as f64);
            }
        }
        // Stereo discrepancy: left into right.
        let (l, r) = (Eye::Left.index(), Eye::Right.index());
        let sm = stereo_discrepancy(
            &views(frame, &imgs[l], &views_now[l], l),
            &views(frame, &imgs[r], &views_now[r], r),
            DEPTH_TOLERANCE,
        )
        .map_err(m)?;
        let sr = stereo_discrepancy(
            &views(reference, &refs[l], &views_now[l], l),
            &views(reference, &refs[r], &views_now[r], r),
            DEPTH_TOLERANCE,
        )
        .map_err(m)?;
        out.insert("stereo_mean".into(), sm.mean as f64);
        out.insert("stereo_p95".into(), sm.p95 as f64);
        out.insert("stereo_covisible".into(), sm.covisible_fraction as f64);
        out.insert("stereo_mean_reference".into(), sr.mean as f64);
        out.insert("stereo_p95_reference".into(), sr.p95 as f64);
        out.insert("stereo_excess".into(), (sm.mean - sr.mean) as f64);
        for (k, v) in &out {
            let s = self.sums.entry(k.clone()).or_insert((0.0, 0));
            s.0 += v;
            s.1 += 1;
        }
        self.prev = Some((frame.clone(), *cam));
        self.prev_ref = Some((reference.clone(), *cam));
        Ok(out)
    }

    /// Means over the frames evaluated so far.
    pub fn means(&self) -> BTreeMap<String, f64> {
        self.sums
            .iter()
            .map(|(k, (s, n))| (k.clone(), s / *n as f64))
            .collect()
    }
}
