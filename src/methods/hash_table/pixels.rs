//! The per-pixel buffers of the table's passes (bindings 3–11 and 13 of
//! `shaders/hash_table/table.glsl`), each `[eye][pixel]`: the lookup
//! requests the update pass reads and the method's outputs.

use crate::gpu::{Buffer, DescriptorSet, GpuContext, GpuResult, Recorder};
use crate::methods::hash_cache::taa::{Taa, TaaInputs};
use crate::rt::SceneGpu;
use std::sync::Arc;

pub struct PixelBuffers {
    /// Entries per buffer (2 × width × height).
    pub count: u64,
    /// First hit of the pixel's lookup: barycentrics (bits), primitive, instance.
    pub hit: Buffer,
    /// Direction to the first hit and its distance t (< 0: miss).
    pub ray: Buffer,
    /// Slot, status | winner << 4, checksum, meta.
    pub cell: Buffer,
    /// Miss: the environment; failed lookup: the pixel's own path.
    pub fallback: Buffer,
    /// Resolved colour before TAA.
    pub color: Buffer,
    pub depth: Buffer,
    pub first_hit: Buffer,
    pub albedo: Buffer,
    /// Hit point with w = 1; miss: direction with w = 0 (TAA's reprojection).
    pub position: Buffer,
}

impl PixelBuffers {
    /// Buffers for `pixels` entries (both eyes), named `{label}.{buffer}`.
    pub(super) fn new(ctx: &Arc<GpuContext>, label: &str, pixels: u64) -> GpuResult<Self> {
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("{label}.{name}"), bytes);
        Ok(PixelBuffers {
            count: pixels,
            hit: b("pix_hit", pixels * 16)?,
            ray: b("pix_ray", pixels * 16)?,
            cell: b("pix_cell", pixels * 16)?,
            fallback: b("fallback", pixels * 16)?,
            color: b("color", pixels * 16)?,
            depth: b("depth", pixels * 4)?,
            first_hit: b("first_hit", pixels * 16)?,
            albedo: b("albedo", pixels * 16)?,
            position: b("position", pixels * 16)?,
        })
    }

    /// In binding order (3..=11).
    pub(super) fn all(&self) -> [&Buffer; 9] {
        [
            &self.hit,
            &self.ray,
            &self.cell,
            &self.fallback,
            &self.color,
            &self.depth,
            &self.first_hit,
            &self.albedo,
            &self.position,
        ]
    }

    /// TAA history for these buffers.
    pub fn taa(&self, ctx: &Arc<GpuContext>, scene: &SceneGpu) -> GpuResult<Taa> {
        Taa::new(ctx, scene, self.count)
    }

    /// Records `taa` over these buffers' colour, position and depth when
    /// `on` (after [`Taa::begin_frame`]); returns the colour the frame shows.
    pub fn record_taa<'a>(
        &'a self,
        taa: &'a Taa,
        on: bool,
        rec: &mut Recorder<'a>,
        scene_set: &'a DescriptorSet,
        frame: &'a Buffer,
        groups: [u32; 3],
    ) -> GpuResult<&'a Buffer> {
        if !on {
            return Ok(&self.color);
        }
        let inputs = TaaInputs {
            frame,
            color: &self.color,
            position: &self.position,
            depth: &self.depth,
        };
        taa.record(rec, scene_set, inputs, groups)
    }
}
