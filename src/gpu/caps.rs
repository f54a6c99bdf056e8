//! What the chosen device can do, probed once and reported by `stereocache info`.

use serde::Serialize;

/// Device capabilities that change which code paths stereocache uses.
#[derive(Clone, Debug, Default, Serialize)]
pub struct DeviceCaps {
    pub name: String,
    pub device_type: String,
    pub vendor_id: u32,
    pub driver_name: String,
    pub driver_info: String,
    pub api_version: String,
    /// VK_KHR_ray_query + VK_KHR_acceleration_structure with their features.
    pub ray_query: bool,
    /// `shaderBufferInt64Atomics` (64-bit atomics in storage buffers).
    pub buffer_int64_atomics: bool,
    pub shader_int64: bool,
    pub subgroup_size: u32,
    /// Names of the supported subgroup operation classes in compute shaders.
    pub subgroup_ops: Vec<String>,
    /// `runtimeDescriptorArray` + non-uniform sampled-image indexing.
    pub descriptor_indexing: bool,
    pub timestamp_period_ns: f32,
    pub timestamp_valid_bits: u32,
    pub max_storage_buffer_range: u64,
    pub device_local_bytes: u64,
}

impl DeviceCaps {
    /// True when compute shaders support every named subgroup operation
    /// class (`arithmetic`, `ballot`, … as in [`Self::subgroup_ops`]).
    pub fn has_subgroup_ops(&self, classes: &[&str]) -> bool {
        classes
            .iter()
            .all(|c| self.subgroup_ops.iter().any(|s| s == c))
    }
}
