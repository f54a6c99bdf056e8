//! Open: create the logical device with exactly the enabled features.
//!
//! What is enabled is decided first, as data ([`FeatureRequest::resolve`]):
//! the required features (which `choose` checked) plus the optional ones the
//! device supports. `open` then builds `vkCreateDevice`'s extension list and
//! feature structs from that `Features` value alone, so `ctx.enabled` is
//! precisely what the device was created with.
#![deny(clippy::undocumented_unsafe_blocks)]

use super::caps::Features;
use super::error::{vk_err, GpuResult};
use super::probe::{Probed, RAY_QUERY_EXTENSIONS};
use ash::vk;
use std::ffi::c_char;

/// What a context asks of its device: `required` features must be
/// supported (else `choose` rejects the device), `optional` ones are enabled
/// where supported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FeatureRequest {
    pub required: Features,
    pub optional: Features,
}

impl FeatureRequest {
    /// stereocache's request: every feature its shaders and passes use when
    /// the device has it (64-bit atomics, descriptor indexing, push
    /// descriptors, debug-utils labels, …); ray queries only when the
    /// ray-query backend may run (`want_ray_query`); `required` as given.
    pub fn new(want_ray_query: bool, required: Features) -> Self {
        FeatureRequest {
            required,
            optional: Features {
                ray_query: want_ray_query,
                buffer_int64_atomics: true,
                shader_int64: true,
                storage_image_write_without_format: true,
                descriptor_indexing: true,
                partially_bound: true,
                scalar_block_layout: true,
                host_query_reset: true,
                push_descriptor: true,
                debug_utils: true,
            },
        }
    }

    /// The features to enable on a device that supports `supported`:
    /// the required ones plus the supported optional ones.
    pub fn resolve(&self, supported: &Features) -> Features {
        self.required
            .union(&self.optional.intersect(supported))
            .intersect(supported)
    }
}

/// A created device and the extension loaders its enabled features need.
pub(crate) struct Opened {
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub accel: Option<ash::khr::acceleration_structure::Device>,
    pub push_descriptor: Option<ash::khr::push_descriptor::Device>,
    pub debug_utils: Option<ash::ext::debug_utils::Device>,
}

/// Creates the device of `probed` with exactly `enabled` (a subset of its
/// supported features, as `FeatureRequest::resolve` returns) and one queue
/// of its compute family.
pub(crate) fn open(
    instance: &ash::Instance,
    probed: &Probed,
    enabled: &Features,
) -> GpuResult<Opened> {
    let queue_family = probed
        .caps
        .compute_queue_family
        .expect("choose only picks devices with a compute queue");
    let mut extensions: Vec<*const c_char> = Vec::new();
    if enabled.ray_query {
        extensions.extend(RAY_QUERY_EXTENSIONS.iter().map(|n| n.as_ptr()));
    }
    if enabled.push_descriptor {
        extensions.push(ash::khr::push_descriptor::NAME.as_ptr());
    }
    let core = vk::PhysicalDeviceFeatures::default()
        .shader_int64(enabled.shader_int64)
        .shader_storage_image_write_without_format(enabled.storage_image_write_without_format);
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default()
        .shader_buffer_int64_atomics(enabled.buffer_int64_atomics)
        .buffer_device_address(enabled.ray_query)
        .runtime_descriptor_array(enabled.descriptor_indexing)
        .shader_sampled_image_array_non_uniform_indexing(enabled.descriptor_indexing)
        .descriptor_binding_partially_bound(enabled.partially_bound)
        .scalar_block_layout(enabled.scalar_block_layout)
        .host_query_reset(enabled.host_query_reset);
    let mut f_as =
        vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default().acceleration_structure(true);
    let mut f_rq = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
    let priorities = [1.0f32];
    let queue_infos = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&priorities)];
    let mut info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queue_infos)
        .enabled_extension_names(&extensions)
        .enabled_features(&core)
        .push_next(&mut f12);
    if enabled.ray_query {
        info = info.push_next(&mut f_as).push_next(&mut f_rq);
    }
    // SAFETY: `probed.physical` belongs to the live `instance`; every
    // extension and feature in `info` was reported supported by `probe`
    // (`enabled` ⊆ supported) and the pointers in `info` outlive the call.
    let device = unsafe { instance.create_device(probed.physical, &info, None) }
        .map_err(vk_err("vkCreateDevice"))?;
    // SAFETY: the device was created with one queue of `queue_family`.
    let queue = unsafe { device.get_device_queue(queue_family, 0) };
    Ok(Opened {
        accel: enabled
            .ray_query
            .then(|| ash::khr::acceleration_structure::Device::new(instance, &device)),
        push_descriptor: enabled
            .push_descriptor
            .then(|| ash::khr::push_descriptor::Device::new(instance, &device)),
        debug_utils: enabled
            .debug_utils
            .then(|| ash::ext::debug_utils::Device::new(instance, &device)),
        device,
        queue,
        queue_family,
    })
}
