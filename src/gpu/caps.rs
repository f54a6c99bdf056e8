//! What a device can do, as plain data: the result of `probe` for each
//! physical device, read by `choose` and `open` and printed by
//! `stereocache info`. No Vulkan handles here, so tests can build a
//! `DeviceCaps` by hand and ask `choose` about it.
//!
//! The same [`Features`] type says what a device *supports*
//! (`caps.supported`) and what a context *enabled* (`ctx.enabled`); the two
//! are never the same field.
#![deny(clippy::undocumented_unsafe_blocks)]

use serde::Serialize;

/// Optional device (and instance) features stereocache can use. In
/// `DeviceCaps::supported` a flag means "the device offers it"; in
/// `GpuContext::enabled` it means "it was enabled at `vkCreateDevice`" and
/// code may rely on it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Features {
    /// VK_KHR_ray_query + VK_KHR_acceleration_structure (+ deferred host
    /// operations) with `rayQuery`, `accelerationStructure` and
    /// `bufferDeviceAddress`: the `query` ray backend.
    pub ray_query: bool,
    /// `shaderBufferInt64Atomics` (64-bit atomics in storage buffers).
    pub buffer_int64_atomics: bool,
    /// `shaderInt64`.
    pub shader_int64: bool,
    /// `shaderStorageImageWriteWithoutFormat`.
    pub storage_image_write_without_format: bool,
    /// `runtimeDescriptorArray` + `shaderSampledImageArrayNonUniformIndexing`.
    pub descriptor_indexing: bool,
    /// `descriptorBindingPartiallyBound`.
    pub partially_bound: bool,
    /// `scalarBlockLayout`.
    pub scalar_block_layout: bool,
    /// `hostQueryReset`.
    pub host_query_reset: bool,
    /// VK_KHR_push_descriptor (per-pass bindings without descriptor sets).
    pub push_descriptor: bool,
    /// VK_EXT_debug_utils on the instance (object names, command labels).
    pub debug_utils: bool,
}

impl Features {
    /// `(name, flag)` for every feature, in declaration order (for printing
    /// and for naming what is missing).
    pub fn list(&self) -> [(&'static str, bool); 10] {
        [
            ("ray_query", self.ray_query),
            ("buffer_int64_atomics", self.buffer_int64_atomics),
            ("shader_int64", self.shader_int64),
            (
                "storage_image_write_without_format",
                self.storage_image_write_without_format,
            ),
            ("descriptor_indexing", self.descriptor_indexing),
            ("partially_bound", self.partially_bound),
            ("scalar_block_layout", self.scalar_block_layout),
            ("host_query_reset", self.host_query_reset),
            ("push_descriptor", self.push_descriptor),
            ("debug_utils", self.debug_utils),
        ]
    }

    /// Names of the features set in `self` but not in `other`.
    pub fn missing_from(&self, other: &Features) -> Vec<&'static str> {
        self.list()
            .iter()
            .zip(other.list())
            .filter(|((_, want), (_, have))| *want && !have)
            .map(|((name, _), _)| *name)
            .collect()
    }

    /// The features set in both.
    pub fn intersect(&self, o: &Features) -> Features {
        Features {
            ray_query: self.ray_query && o.ray_query,
            buffer_int64_atomics: self.buffer_int64_atomics && o.buffer_int64_atomics,
            shader_int64: self.shader_int64 && o.shader_int64,
            storage_image_write_without_format: self.storage_image_write_without_format
                && o.storage_image_write_without_format,
            descriptor_indexing: self.descriptor_indexing && o.descriptor_indexing,
            partially_bound: self.partially_bound && o.partially_bound,
            scalar_block_layout: self.scalar_block_layout && o.scalar_block_layout,
            host_query_reset: self.host_query_reset && o.host_query_reset,
            push_descriptor: self.push_descriptor && o.push_descriptor,
            debug_utils: self.debug_utils && o.debug_utils,
        }
    }

    /// The features set in either.
    pub fn union(&self, o: &Features) -> Features {
        Features {
            ray_query: self.ray_query || o.ray_query,
            buffer_int64_atomics: self.buffer_int64_atomics || o.buffer_int64_atomics,
            shader_int64: self.shader_int64 || o.shader_int64,
            storage_image_write_without_format: self.storage_image_write_without_format
                || o.storage_image_write_without_format,
            descriptor_indexing: self.descriptor_indexing || o.descriptor_indexing,
            partially_bound: self.partially_bound || o.partially_bound,
            scalar_block_layout: self.scalar_block_layout || o.scalar_block_layout,
            host_query_reset: self.host_query_reset || o.host_query_reset,
            push_descriptor: self.push_descriptor || o.push_descriptor,
            debug_utils: self.debug_utils || o.debug_utils,
        }
    }

    /// Names of the set features, comma-separated ("none" when empty).
    pub fn names(&self) -> String {
        let v: Vec<&str> = self
            .list()
            .iter()
            .filter(|(_, on)| *on)
            .map(|(n, _)| *n)
            .collect();
        if v.is_empty() {
            "none".into()
        } else {
            v.join(", ")
        }
    }
}

/// One memory heap of a device.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct MemoryHeap {
    pub bytes: u64,
    pub device_local: bool,
}

/// Everything `probe` learns about one physical device.
#[derive(Clone, Debug, Default, Serialize)]
pub struct DeviceCaps {
    pub name: String,
    pub device_type: String,
    pub vendor_id: u32,
    pub driver_name: String,
    pub driver_info: String,
    /// The device's Vulkan version, "major.minor.patch".
    pub api_version: String,
    /// The device's Vulkan version as `(major, minor)` (stereocache needs 1.2).
    #[serde(skip)]
    pub api: (u32, u32),
    /// The first queue family with compute (`None`: the device is unusable).
    pub compute_queue_family: Option<u32>,
    /// What the device offers (not what a context enabled: see
    /// `GpuContext::enabled`).
    pub supported: Features,
    pub subgroup_size: u32,
    /// Names of the supported subgroup operation classes in compute shaders.
    pub subgroup_ops: Vec<String>,
    /// `timestampPeriod` of the device.
    pub timestamp_period_ns: f32,
    /// `timestampValidBits` of the compute queue family (0: no timestamps).
    pub timestamp_valid_bits: u32,
    pub max_storage_buffer_range: u64,
    pub max_push_constants_size: u32,
    /// `maxPushDescriptors` (0 without VK_KHR_push_descriptor).
    pub max_push_descriptors: u32,
    pub max_compute_work_group_invocations: u32,
    /// `subTexelPrecisionBits`: linear filter weights are exact to
    /// 2^-bits (tests derive their tolerances from it; ≥ 4 by the spec).
    #[serde(skip)]
    pub sub_texel_precision_bits: u32,
    /// `mipmapPrecisionBits`: the fraction that blends two mip levels is
    /// snapped to 2^-bits (≥ 4 by the spec).
    #[serde(skip)]
    pub mipmap_precision_bits: u32,
    /// The largest device-local heap.
    pub device_local_bytes: u64,
    pub memory_heaps: Vec<MemoryHeap>,
}

impl DeviceCaps {
    /// True when compute shaders support every named subgroup operation
    /// class (`arithmetic`, `ballot`, … as in [`Self::subgroup_ops`]).
    pub fn has_subgroup_ops(&self, classes: &[&str]) -> bool {
        classes
            .iter()
            .all(|c| self.subgroup_ops.iter().any(|s| s == c))
    }

    /// True when compute queue timestamps can be written.
    pub fn has_timestamps(&self) -> bool {
        self.timestamp_valid_bits > 0
    }
}
