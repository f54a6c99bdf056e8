//! What a method receives per frame and what it returns.

use crate::camera::{Eye, EyeView, StereoCamera};
use crate::gpu::PassTiming;
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use serde::Serialize;

/// One frame to render: its index along the trace and the stereo camera
/// (and the previous frame's, for methods that reproject).
#[derive(Clone, Debug)]
pub struct FrameInput {
    pub index: u32,
    pub camera: StereoCamera,
    pub prev_camera: Option<StereoCamera>,
}

/// Per-eye outputs, row-major from the top-left pixel.
#[derive(Clone, Debug, Default)]
pub struct EyeImage {
    /// Linear radiance (rgb; alpha unused).
    pub radiance: Vec<[f32; 4]>,
    /// View depth of the first hit, 0 where the ray escaped.
    pub depth: Vec<f32>,
    /// First hits in the Listing 1 encoding; w = u32::MAX for a miss.
    pub first_hit: Vec<[u32; 4]>,
    /// Base colour at the first hit.
    pub albedo: Vec<[f32; 4]>,
    /// Named debug views (e.g. `trace-mask`, `spp`, `shaded`, `occupancy`),
    /// linear RGBA meant to be shown as is.
    pub debug: Vec<(String, Vec<[f32; 4]>)>,
}

#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct RayCounts {
    pub primary: u64,
    pub bounce: u64,
    pub shadow: u64,
}

impl RayCounts {
    pub fn total(&self) -> u64 {
        self.primary + self.bounce + self.shadow
    }
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameStats {
    pub passes: Vec<PassTiming>,
    pub rays: RayCounts,
    /// Method-specific per-frame counters (visible samples per pixel, holes
    /// filled, slots purged, ...), written as they are into frames.jsonl.
    pub counters: std::collections::BTreeMap<String, f64>,
}

/// Prefix of passes that only measure (counters for the statistics, e.g. the
/// hash table's live entries): they are timed and listed per pass, but are
/// not part of a method's cost, so `gpu_ms` leaves them out.
pub const DIAGNOSTIC_PASS_PREFIX: &str = "diag.";

impl FrameStats {
    /// GPU time of the method's own passes (diagnostic passes excluded).
    pub fn gpu_ms(&self) -> f64 {
        self.passes
            .iter()
            .filter(|p| !p.name.starts_with(DIAGNOSTIC_PASS_PREFIX))
            .map(|p| p.ms)
            .sum()
    }
}

#[derive(Clone, Debug)]
pub struct StereoFrame {
    pub width: u32,
    pub height: u32,
    pub eyes: [EyeImage; 2],
    pub stats: FrameStats,
}

impl StereoFrame {
    pub fn eye(&self, e: Eye) -> &EyeImage {
        &self.eyes[e.index()]
    }
}

/// `EyeGpu` of shaders/common/camera.glsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
pub struct EyeGpu {
    pub pos_tanx: [f32; 4],
    pub right_tany: [f32; 4],
    pub up: [f32; 4],
    pub fwd: [f32; 4],
}

impl EyeGpu {
    /// The eye with its position relative to the render origin
    /// (`SceneGpu::origin`, subtracted in f64).
    pub fn from_view(v: &EyeView, origin: DVec3) -> Self {
        let t = v.tan_half_fov();
        let p = (v.world - origin).as_vec3();
        let r = v.orientation * glam::Vec3::X;
        let u = v.orientation * glam::Vec3::Y;
        let f = v.orientation * glam::Vec3::NEG_Z;
        EyeGpu {
            pos_tanx: [p.x, p.y, p.z, t.x],
            right_tany: [r.x, r.y, r.z, t.y],
            up: [u.x, u.y, u.z, 0.0],
            fwd: [f.x, f.y, f.z, 0.0],
        }
    }
}

/// The `FrameBuf` block of shaders/common/camera.glsl (set 1, binding 0).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
pub struct FrameParams {
    pub eyes: [EyeGpu; 2],
    pub prev_eyes: [EyeGpu; 2],
    pub size_seed: [u32; 4],
    pub misc: [u32; 4],
}

impl FrameParams {
    /// `origin`: the scene's render origin (`SceneGpu::origin`).
    pub fn new(frame: &FrameInput, width: u32, height: u32, seed: u32, origin: DVec3) -> Self {
        let eyes = frame.camera.eyes().map(|v| EyeGpu::from_view(&v, origin));
        let prev = frame
            .prev_camera
            .as_ref()
            .map(|c| c.eyes().map(|v| EyeGpu::from_view(&v, origin)))
            .unwrap_or(eyes);
        FrameParams {
            eyes,
            prev_eyes: prev,
            size_seed: [width, height, seed, frame.index],
            misc: [0; 4],
        }
    }
}

/// A method's per-pixel output buffers, each `[eye][pixel]`, and its
/// optional debug views (`[view][eye][pixel]`, with their names).
pub struct OutputBuffers<'a> {
    /// RGBA32F; alpha is ignored.
    pub color: &'a crate::gpu::Buffer,
    pub depth: &'a crate::gpu::Buffer,
    pub first_hit: &'a crate::gpu::Buffer,
    pub albedo: &'a crate::gpu::Buffer,
    pub debug: Option<(&'a crate::gpu::Buffer, &'a [&'a str])>,
}

impl OutputBuffers<'_> {
    /// Reads both eyes of an image of `npix` pixels per eye back from the GPU.
    pub fn read(&self, npix: usize) -> crate::gpu::GpuResult<[EyeImage; 2]> {
        let color: Vec<[f32; 4]> = self.color.download_pod()?;
        let depth: Vec<f32> = self.depth.download_pod()?;
        let fh: Vec<[u32; 4]> = self.first_hit.download_pod()?;
        let albedo: Vec<[f32; 4]> = self.albedo.download_pod()?;
        let debug: Option<(Vec<[f32; 4]>, &[&str])> = match self.debug {
            Some((b, names)) => Some((b.download_pod()?, names)),
            None => None,
        };
        let eye = |e: usize| EyeImage {
            radiance: color[e * npix..(e + 1) * npix]
                .iter()
                .map(|c| [c[0], c[1], c[2], 1.0])
                .collect(),
            depth: depth[e * npix..(e + 1) * npix].to_vec(),
            first_hit: fh[e * npix..(e + 1) * npix].to_vec(),
            albedo: albedo[e * npix..(e + 1) * npix].to_vec(),
            debug: match &debug {
                None => Vec::new(),
                Some((d, names)) => names
                    .iter()
                    .enumerate()
                    .map(|(v, name)| {
                        (
                            name.to_string(),
                            d[(v * 2 + e) * npix..(v * 2 + e + 1) * npix].to_vec(),
                        )
                    })
                    .collect(),
            },
        };
        Ok([eye(0), eye(1)])
    }
}

/// Counter values by report name, from a counter buffer read back from the GPU.
pub fn named_counters(
    values: &[u32],
    names: &[(usize, &str)],
) -> std::collections::BTreeMap<String, f64> {
    names
        .iter()
        .map(|(i, n)| (n.to_string(), values.get(*i).copied().unwrap_or(0) as f64))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_ms_leaves_out_diagnostic_passes() {
        let pass = |name: &str, ms| PassTiming {
            name: name.into(),
            ms,
        };
        let s = FrameStats {
            passes: vec![
                pass("primary", 1.5),
                pass("diag.count", 10.0),
                pass("taa", 0.25),
            ],
            ..Default::default()
        };
        assert_eq!(s.gpu_ms(), 1.75);
    }
}
