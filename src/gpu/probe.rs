//! Probe: what each physical device offers, read into plain data
//! ([`DeviceCaps`]) before anything is chosen or enabled.
#![deny(clippy::undocumented_unsafe_blocks)]

use super::caps::{DeviceCaps, Features, MemoryHeap};
use super::error::{vk_err, GpuResult};
use ash::vk;
use std::ffi::{c_char, CStr};

/// The extensions behind `Features::ray_query`, all enabled together.
pub(crate) const RAY_QUERY_EXTENSIONS: [&CStr; 3] = [
    ash::khr::acceleration_structure::NAME,
    ash::khr::ray_query::NAME,
    ash::khr::deferred_host_operations::NAME,
];

/// One physical device and what it offers.
pub(crate) struct Probed {
    pub physical: vk::PhysicalDevice,
    pub caps: DeviceCaps,
}

pub(crate) fn type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

fn cstr_field(raw: &[c_char]) -> String {
    let bytes: Vec<u8> = raw
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Probes every physical device of `instance`. `instance_debug_utils`: the
/// instance has VK_EXT_debug_utils enabled (reported as a supported feature
/// of every device, since labels and names work on all of them).
pub(crate) fn probe_all(
    instance: &ash::Instance,
    instance_debug_utils: bool,
) -> GpuResult<Vec<Probed>> {
    // SAFETY: `instance` is a live instance created by this process.
    let physicals = unsafe { instance.enumerate_physical_devices() }
        .map_err(vk_err("vkEnumeratePhysicalDevices"))?;
    physicals
        .into_iter()
        .map(|p| probe(instance, p, instance_debug_utils))
        .collect()
}

fn probe(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    instance_debug_utils: bool,
) -> GpuResult<Probed> {
    // SAFETY: `physical` was enumerated from `instance`, which is live.
    let props = unsafe { instance.get_physical_device_properties(physical) };
    let api = (
        vk::api_version_major(props.api_version),
        vk::api_version_minor(props.api_version),
    );
    let name = cstr_field(&props.device_name);
    // SAFETY: as above.
    let qprops = unsafe { instance.get_physical_device_queue_family_properties(physical) };
    let compute_queue_family = qprops
        .iter()
        .position(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE))
        .map(|i| i as u32);
    let mut caps = DeviceCaps {
        name,
        device_type: type_name(props.device_type).into(),
        vendor_id: props.vendor_id,
        api_version: format!(
            "{}.{}.{}",
            api.0,
            api.1,
            vk::api_version_patch(props.api_version)
        ),
        api,
        compute_queue_family,
        timestamp_period_ns: props.limits.timestamp_period,
        timestamp_valid_bits: compute_queue_family
            .map_or(0, |f| qprops[f as usize].timestamp_valid_bits),
        max_storage_buffer_range: props.limits.max_storage_buffer_range as u64,
        max_push_constants_size: props.limits.max_push_constants_size,
        max_compute_work_group_invocations: props.limits.max_compute_work_group_invocations,
        sub_texel_precision_bits: props.limits.sub_texel_precision_bits,
        mipmap_precision_bits: props.limits.mipmap_precision_bits,
        ..Default::default()
    };
    if api < (1, 2) {
        // The *2 queries and the 1.2 feature structs need Vulkan 1.2:
        // `choose` rejects the device with what is known so far.
        return Ok(Probed { physical, caps });
    }

    // SAFETY: as above.
    let exts = unsafe { instance.enumerate_device_extension_properties(physical) }
        .map_err(vk_err("vkEnumerateDeviceExtensionProperties"))?;
    let has_ext = |name: &CStr| {
        exts.iter()
            .any(|e| e.extension_name_as_c_str().ok() == Some(name))
    };
    let rq_exts = RAY_QUERY_EXTENSIONS.iter().all(|n| has_ext(n));
    let push_descriptor = has_ext(ash::khr::push_descriptor::NAME);

    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut f_as = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default();
    let mut f_rq = vk::PhysicalDeviceRayQueryFeaturesKHR::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
    if rq_exts {
        f2 = f2.push_next(&mut f_as).push_next(&mut f_rq);
    }
    // SAFETY: the device supports Vulkan 1.2 (checked above), so
    // vkGetPhysicalDeviceFeatures2 and the 1.2 feature struct are valid; the
    // ray-query structs are chained only when their extensions exist.
    unsafe { instance.get_physical_device_features2(physical, &mut f2) };
    let core = f2.features;

    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut push = vk::PhysicalDevicePushDescriptorPropertiesKHR::default();
    let mut p2 = vk::PhysicalDeviceProperties2::default()
        .push_next(&mut subgroup)
        .push_next(&mut driver);
    if push_descriptor {
        p2 = p2.push_next(&mut push);
    }
    // SAFETY: Vulkan 1.2 device; the push-descriptor struct is chained only
    // when the extension exists.
    unsafe { instance.get_physical_device_properties2(physical, &mut p2) };
    // SAFETY: as above.
    let mem = unsafe { instance.get_physical_device_memory_properties(physical) };

    caps.driver_name = cstr_field(&driver.driver_name);
    caps.driver_info = cstr_field(&driver.driver_info);
    caps.subgroup_size = subgroup.subgroup_size;
    for (flag, name) in [
        (vk::SubgroupFeatureFlags::BASIC, "basic"),
        (vk::SubgroupFeatureFlags::VOTE, "vote"),
        (vk::SubgroupFeatureFlags::ARITHMETIC, "arithmetic"),
        (vk::SubgroupFeatureFlags::BALLOT, "ballot"),
        (vk::SubgroupFeatureFlags::SHUFFLE, "shuffle"),
        (
            vk::SubgroupFeatureFlags::SHUFFLE_RELATIVE,
            "shuffle_relative",
        ),
        (vk::SubgroupFeatureFlags::CLUSTERED, "clustered"),
        (vk::SubgroupFeatureFlags::QUAD, "quad"),
    ] {
        if subgroup.supported_operations.contains(flag)
            && subgroup
                .supported_stages
                .contains(vk::ShaderStageFlags::COMPUTE)
        {
            caps.subgroup_ops.push(name.to_string());
        }
    }
    caps.max_push_descriptors = if push_descriptor {
        push.max_push_descriptors
    } else {
        0
    };
    caps.memory_heaps = mem.memory_heaps[..mem.memory_heap_count as usize]
        .iter()
        .map(|h| MemoryHeap {
            bytes: h.size,
            device_local: h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL),
        })
        .collect();
    caps.device_local_bytes = caps
        .memory_heaps
        .iter()
        .filter(|h| h.device_local)
        .map(|h| h.bytes)
        .max()
        .unwrap_or(0);
    let on = |b: vk::Bool32| b == vk::TRUE;
    caps.supported = Features {
        ray_query: rq_exts
            && on(f_as.acceleration_structure)
            && on(f_rq.ray_query)
            && on(f12.buffer_device_address),
        buffer_int64_atomics: on(f12.shader_buffer_int64_atomics),
        shader_int64: on(core.shader_int64),
        storage_image_write_without_format: on(core.shader_storage_image_write_without_format),
        descriptor_indexing: on(f12.runtime_descriptor_array)
            && on(f12.shader_sampled_image_array_non_uniform_indexing),
        partially_bound: on(f12.descriptor_binding_partially_bound),
        scalar_block_layout: on(f12.scalar_block_layout),
        host_query_reset: on(f12.host_query_reset),
        push_descriptor,
        debug_utils: instance_debug_utils,
    };
    Ok(Probed { physical, caps })
}
