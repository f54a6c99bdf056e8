//! What a method's recorded frame leaves on the GPU for the shared frame
//! loop to read back: its per-pixel images and its typed counters
//! ([`FrameOutputs`], returned by [`super::Method::record`]).

use super::frame::{EyeImage, RayCounts};
use crate::gpu::{Buffer, HostReadback, ReadbackRange};
use crate::interface::CounterSlot;
use std::collections::BTreeMap;

/// The buffers of a method that writes one first hit per pixel and eye:
/// the frame parameters (`FrameParams`), first hits (Listing 1, 16 B), view
/// depth (4 B), base colour (16 B), each `[eye][pixel]`, and its
/// `uint counters[]`. Named `PREFIX.frame`, `PREFIX.first_hit`, … (the names
/// out-of-range errors and debuggers show).
pub struct PixelOutputs {
    pub frame: Buffer,
    pub first_hit: Buffer,
    pub depth: Buffer,
    pub albedo: Buffer,
    pub counters: Buffer,
}

impl PixelOutputs {
    /// `pixels`: both eyes' pixels; `counter_slots`: the method's counter enum's length.
    pub fn new(
        ctx: &std::sync::Arc<crate::gpu::GpuContext>,
        prefix: &str,
        pixels: u64,
        counter_slots: usize,
    ) -> crate::gpu::GpuResult<Self> {
        let buf = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("{prefix}.{name}"), bytes);
        Ok(PixelOutputs {
            frame: buf("frame", std::mem::size_of::<super::FrameParams>() as u64)?,
            first_hit: buf("first_hit", pixels * 16)?,
            depth: buf("depth", pixels * 4)?,
            albedo: buf("albedo", pixels * 16)?,
            counters: buf("counters", 4 * counter_slots as u64)?,
        })
    }
}

/// How the colour buffer (`[eye][pixel]` vec4) encodes radiance.
#[derive(Clone, Copy)]
pub enum Color<'a> {
    /// rgb = radiance; alpha ignored (read back as 1).
    Radiance(&'a Buffer),
    /// rgb = sum of samples, w = their count: radiance = rgb / w (0 where w = 0).
    SampleSum(&'a Buffer),
}

/// Counter slots summed into the frame's [`RayCounts`] (the mapping every
/// method shares: primary rays, bounce rays, shadow rays).
#[derive(Clone, Debug, Default)]
pub struct RaySlots {
    pub primary: Vec<usize>,
    pub bounce: Vec<usize>,
    pub shadow: Vec<usize>,
}

impl RaySlots {
    pub fn of<C: CounterSlot>(primary: &[C], bounce: &[C], shadow: &[C]) -> Self {
        let slots = |cs: &[C]| cs.iter().map(|c| c.slot()).collect();
        RaySlots {
            primary: slots(primary),
            bounce: slots(bounce),
            shadow: slots(shadow),
        }
    }
}

/// One `uint counters[]` buffer with its typed slots.
pub struct CounterOutput<'a> {
    pub buffer: &'a Buffer,
    /// (slot, report name) written as they are into the frame's counters.
    pub report: Vec<(usize, &'static str)>,
    /// (slot, report name) divided by the pixel count of both eyes.
    pub per_pixel: Vec<(usize, &'static str)>,
    /// (slot, report name, divisor) reported as slot / divisor (e.g. the
    /// hash table's occupancy: live entries / capacity).
    pub ratios: Vec<(usize, &'static str, f64)>,
    pub rays: Option<RaySlots>,
}

impl<'a> CounterOutput<'a> {
    /// The counters of enum `C` in `buffer`: every slot with a report name
    /// is reported as it is.
    pub fn of<C: CounterSlot>(buffer: &'a Buffer) -> Self {
        CounterOutput {
            buffer,
            report: C::ALL
                .iter()
                .filter_map(|c| c.report_name().map(|n| (c.slot(), n)))
                .collect(),
            per_pixel: Vec::new(),
            ratios: Vec::new(),
            rays: None,
        }
    }

    /// These slots are the frame's ray counts.
    pub fn rays(mut self, rays: RaySlots) -> Self {
        self.rays = Some(rays);
        self
    }

    /// Reports `slot` / (2 · width · height) as `name` (a mean per pixel).
    pub fn per_pixel<C: CounterSlot>(mut self, slot: C, name: &'static str) -> Self {
        self.per_pixel.push((slot.slot(), name));
        self
    }

    /// Reports `slot` / `divisor` as `name`.
    pub fn ratio<C: CounterSlot>(mut self, slot: C, name: &'static str, divisor: f64) -> Self {
        self.ratios.push((slot.slot(), name, divisor));
        self
    }
}

/// Everything the shared frame loop reads back after a method's `record`.
pub struct FrameOutputs<'a> {
    pub width: u32,
    pub height: u32,
    pub color: Color<'a>,
    /// View depth of the first hit (f32), 0 = miss.
    pub depth: &'a Buffer,
    /// First hits in the Listing 1 encoding (uvec4).
    pub first_hit: &'a Buffer,
    /// Base colour at the first hit (vec4).
    pub albedo: &'a Buffer,
    /// Debug views `[view][eye][pixel]` (vec4) with their names.
    pub debug: Option<(&'a Buffer, &'a [&'a str])>,
    /// Counter buffers, decoded in order: where two report the same name,
    /// the later one's value is the frame's.
    pub counters: Vec<CounterOutput<'a>>,
    /// Values the method knows on the host (added to the frame's counters).
    pub host_counters: BTreeMap<String, f64>,
    /// The method's persistent staging buffer.
    pub readback: &'a HostReadback,
}

impl<'a> FrameOutputs<'a> {
    /// The buffers to copy, in the order [`FrameOutputs::decode`] expects.
    pub(crate) fn sources(&self) -> Vec<&'a Buffer> {
        let color = match self.color {
            Color::Radiance(b) | Color::SampleSum(b) => b,
        };
        let mut v = vec![color, self.depth, self.first_hit, self.albedo];
        if let Some((d, _)) = self.debug {
            v.push(d);
        }
        v.extend(self.counters.iter().map(|c| c.buffer));
        v
    }

    /// The eyes and counters from the staging buffer, `ranges` as
    /// `Recorder::read_back` returned them for [`FrameOutputs::sources`].
    pub(crate) fn decode(
        &self,
        ranges: &[ReadbackRange],
    ) -> ([EyeImage; 2], RayCounts, BTreeMap<String, f64>) {
        let rb = self.readback;
        let npix = (self.width * self.height) as usize;
        let color: Vec<[f32; 4]> = rb.pod(ranges[0]);
        let radiance: Vec<[f32; 4]> = match self.color {
            Color::Radiance(_) => color.iter().map(|c| [c[0], c[1], c[2], 1.0]).collect(),
            Color::SampleSum(_) => color
                .iter()
                .map(|a| {
                    if a[3] > 0.0 {
                        [a[0] / a[3], a[1] / a[3], a[2] / a[3], 1.0]
                    } else {
                        [0.0; 4]
                    }
                })
                .collect(),
        };
        let depth: Vec<f32> = rb.pod(ranges[1]);
        let first_hit: Vec<[u32; 4]> = rb.pod(ranges[2]);
        let albedo: Vec<[f32; 4]> = rb.pod(ranges[3]);
        let mut next = 4;
        let debug: Option<(Vec<[f32; 4]>, &[&str])> = self.debug.map(|(_, names)| {
            next += 1;
            (rb.pod(ranges[4]), names)
        });
        let eye = |e: usize| EyeImage {
            radiance: radiance[e * npix..(e + 1) * npix].to_vec(),
            depth: depth[e * npix..(e + 1) * npix].to_vec(),
            first_hit: first_hit[e * npix..(e + 1) * npix].to_vec(),
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
        let mut rays = RayCounts::default();
        let mut counters = self.host_counters.clone();
        for (c, range) in self.counters.iter().zip(&ranges[next..]) {
            let values: Vec<u32> = rb.pod(*range);
            let at = |slot: usize| values.get(slot).copied().unwrap_or(0) as u64;
            for (slot, name) in &c.report {
                counters.insert(name.to_string(), at(*slot) as f64);
            }
            for (slot, name) in &c.per_pixel {
                counters.insert(name.to_string(), at(*slot) as f64 / (2 * npix) as f64);
            }
            for (slot, name, divisor) in &c.ratios {
                counters.insert(name.to_string(), at(*slot) as f64 / divisor);
            }
            if let Some(r) = &c.rays {
                rays.primary += r.primary.iter().map(|s| at(*s)).sum::<u64>();
                rays.bounce += r.bounce.iter().map(|s| at(*s)).sum::<u64>();
                rays.shadow += r.shadow.iter().map(|s| at(*s)).sum::<u64>();
            }
        }
        ([eye(0), eye(1)], rays, counters)
    }
}
