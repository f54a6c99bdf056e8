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
    /// `pos_tanx.w`, `right_tany.w`: [`EyeView::half_extents`]; `up.w`: 1
    /// for an orthographic eye, 0 for a perspective one.
    pub fn from_view(v: &EyeView, origin: DVec3) -> Self {
        let t = v.half_extents();
        let p = (v.world - origin).as_vec3();
        let r = v.orientation * glam::Vec3::X;
        let u = v.orientation * glam::Vec3::Y;
        let f = v.orientation * glam::Vec3::NEG_Z;
        EyeGpu {
            pos_tanx: [p.x, p.y, p.z, t.x],
            right_tany: [r.x, r.y, r.z, t.y],
            up: [u.x, u.y, u.z, if v.is_orthographic() { 1.0 } else { 0.0 }],
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
