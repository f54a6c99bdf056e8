//! The per-pixel buffers of the table's passes (bindings 3–11 and 13 of
//! `shaders/hash_table/table.glsl`), each `[eye][pixel]`: the lookup
//! requests the update pass reads and the method's outputs.

use crate::gpu::{Buffer, GpuContext, GpuResult};
use crate::methods::taa::TaaInputs;
use crate::methods::Color;
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
    /// Hit point with w = 1; miss: direction with w = 0 (written for the
    /// debuggers; TAA rebuilds points from `depth`).
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

    /// The buffers the one TAA ([`crate::methods::TaaPass`]) resolves:
    /// the resolved colour, the first hits and their view depth.
    pub fn taa_inputs(&self) -> TaaInputs<'_> {
        TaaInputs {
            color: Color::Radiance(&self.color),
            depth: &self.depth,
            first_hit: &self.first_hit,
        }
    }
}
