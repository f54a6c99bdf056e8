//! The Vulkan instance and device: device choice (discrete GPU first, then
//! integrated, then CPU; `--device` overrides), feature probing, the memory
//! allocator and one-shot command submission.

use super::caps::DeviceCaps;
use super::error::{vk_err, GpuError, GpuResult};
use super::validation::{debug_callback, ValidationLog};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{c_char, CStr, CString};
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to open the GPU.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Enable the Khronos validation layer (when installed) and collect its messages.
    pub validate: bool,
    /// Also enable synchronization validation (slower).
    pub sync_validation: bool,
    /// Pick the first device whose name contains this (case-insensitive).
    pub device: Option<String>,
    /// Enable VK_KHR_ray_query when the device has it.
    pub want_ray_query: bool,
    /// Longest wait for one submission; past it the device counts as hung
    /// and is abandoned (`None`: wait forever). See `with_env`.
    pub timeout: Option<std::time::Duration>,
    /// Fault injection: the submission after this many successful ones
    /// reports a lost device, as a driver would (tests of the error path).
    pub lose_device_after: Option<u64>,
}

impl GpuOptions {
    /// Default GPU watchdog of the command line, in seconds.
    pub const DEFAULT_TIMEOUT_S: f64 = 600.0;

    /// Reads `STEREOCACHE_GPU_TIMEOUT_S` (seconds, default 600; 0 = wait
    /// forever) and `STEREOCACHE_FAULT_DEVICE_LOST_AFTER` (a submission
    /// count). A malformed value is an error naming the variable.
    pub fn with_env(mut self) -> Result<Self, String> {
        let read = |name: &str| std::env::var(name).ok().map(|v| (name.to_string(), v));
        let timeout_s = match read("STEREOCACHE_GPU_TIMEOUT_S") {
            None => Self::DEFAULT_TIMEOUT_S,
            Some((n, v)) => match v.trim().parse::<f64>() {
                Ok(s) if s.is_finite() && s >= 0.0 => s,
                _ => return Err(format!("{n}={v}: expected a number of seconds ≥ 0")),
            },
        };
        self.timeout = (timeout_s > 0.0).then(|| std::time::Duration::from_secs_f64(timeout_s));
        if let Some((n, v)) = read("STEREOCACHE_FAULT_DEVICE_LOST_AFTER") {
            self.lose_device_after = Some(
                v.trim()
                    .parse()
                    .map_err(|_| format!("{n}={v}: expected a submission count"))?,
            );
        }
        Ok(self)
    }
}

pub struct GpuContext {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Messages from the validation layer (empty when it is off).
    pub validation: Arc<ValidationLog>,
    pub validation_enabled: bool,
    pub physical: vk::PhysicalDevice,
    pub caps: DeviceCaps,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub(crate) allocator: ManuallyDrop<Mutex<Allocator>>,
    pub(crate) command_pool: vk::CommandPool,
    pub(crate) accel: Option<ash::khr::acceleration_structure::Device>,
    timeout: Option<std::time::Duration>,
    lose_device_after: Option<u64>,
    submits: std::sync::atomic::AtomicU64,
    /// A submission outlived the watchdog: its work may still run, so no
    /// object is destroyed any more (every `Drop` in src/gpu/ leaks instead
    /// of freeing memory the device may still write).
    abandoned: std::sync::atomic::AtomicBool,
    lost: std::sync::atomic::AtomicBool,
    pub(crate) debug_utils_device: Option<ash::ext::debug_utils::Device>,
    /// VK_KHR_push_descriptor, enabled where the device has it (the pass
    /// builder's per-pass bindings; src/gpu/compute_pass.rs falls back to
    /// per-pass descriptor sets without it).
    pub(crate) push_descriptor: Option<ash::khr::push_descriptor::Device>,
    pub(crate) allocated_bytes: std::sync::atomic::AtomicU64,
}

fn type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

fn type_name(t: vk::PhysicalDeviceType) -> &'static str {
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

/// A device that qualifies: Vulkan 1.2 and a queue family with compute.
struct Candidate {
    physical: vk::PhysicalDevice,
    name: String,
    kind: vk::PhysicalDeviceType,
    queue_family: u32,
}

impl GpuContext {
    pub fn new(options: &GpuOptions) -> GpuResult<Self> {
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loader(e.to_string()))?;
        let validation = Arc::new(ValidationLog::default());

        let layer_present = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(vk_err("vkEnumerateInstanceLayerProperties"))?
            .iter()
            .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
        let validate = options.validate && layer_present;
        if options.validate && !layer_present {
            eprintln!("warning: --validate asked for VK_LAYER_KHRONOS_validation, which is not installed; running without it");
        }

        let app_name = c"stereocache";
        let app_info = vk::ApplicationInfo::default()
            .application_name(app_name)
            .application_version(1)
            .engine_name(app_name)
            .api_version(vk::API_VERSION_1_2);
        let mut layers: Vec<*const c_char> = Vec::new();
        let mut extensions: Vec<*const c_char> = Vec::new();
        if validate {
            layers.push(VALIDATION_LAYER.as_ptr());
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);
        let mut instance_info = vk::InstanceCreateInfo::default()
            .application_info(&app_info)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if validate && options.sync_validation {
            instance_info = instance_info.push_next(&mut validation_features);
        }
        let instance = unsafe { entry.create_instance(&instance_info, None) }
            .map_err(vk_err("vkCreateInstance"))?;

        let debug = if validate {
            let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(Arc::as_ptr(&validation) as *mut std::ffi::c_void);
            let messenger = unsafe { du.create_debug_utils_messenger(&info, None) }
                .map_err(vk_err("vkCreateDebugUtilsMessengerEXT"))?;
            Some((du, messenger))
        } else {
            None
        };

        let candidate = match Self::choose_device(&instance, options.device.as_deref()) {
            Ok(c) => c,
            Err(e) => {
                unsafe {
                    if let Some((du, m)) = &debug {
                        du.destroy_debug_utils_messenger(*m, None);
                    }
                    instance.destroy_instance(None);
                }
                return Err(e);
            }
        };
        let physical = candidate.physical;

        // Probe extensions and features.
        let exts = unsafe { instance.enumerate_device_extension_properties(physical) }
            .map_err(vk_err("vkEnumerateDeviceExtensionProperties"))?;
        let has_ext = |name: &CStr| {
            exts.iter()
                .any(|e| e.extension_name_as_c_str().ok() == Some(name))
        };
        let rq_exts = [
            ash::khr::acceleration_structure::NAME,
            ash::khr::ray_query::NAME,
            ash::khr::deferred_host_operations::NAME,
        ];
        let rq_ext_ok = rq_exts.iter().all(|n| has_ext(n));

        let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut f_as = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default();
        let mut f_rq = vk::PhysicalDeviceRayQueryFeaturesKHR::default();
        let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
        if rq_ext_ok {
            f2 = f2.push_next(&mut f_as).push_next(&mut f_rq);
        }
        unsafe { instance.get_physical_device_features2(physical, &mut f2) };
        let core = f2.features;
        let ray_query_ok = rq_ext_ok
            && f_as.acceleration_structure == vk::TRUE
            && f_rq.ray_query == vk::TRUE
            && f12.buffer_device_address == vk::TRUE;

        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut driver = vk::PhysicalDeviceDriverProperties::default();
        let mut p2 = vk::PhysicalDeviceProperties2::default()
            .push_next(&mut subgroup)
            .push_next(&mut driver);
        unsafe { instance.get_physical_device_properties2(physical, &mut p2) };
        let props = p2.properties;
        let mem_props = unsafe { instance.get_physical_device_memory_properties(physical) };
        let device_local_bytes = mem_props.memory_heaps[..mem_props.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0);
        let qprops = unsafe { instance.get_physical_device_queue_family_properties(physical) };

        let mut subgroup_ops = Vec::new();
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
                subgroup_ops.push(name.to_string());
            }
        }
        let descriptor_indexing = f12.runtime_descriptor_array == vk::TRUE
            && f12.shader_sampled_image_array_non_uniform_indexing == vk::TRUE;
        let caps = DeviceCaps {
            name: candidate.name.clone(),
            device_type: type_name(candidate.kind).into(),
            vendor_id: props.vendor_id,
            driver_name: cstr_field(&driver.driver_name),
            driver_info: cstr_field(&driver.driver_info),
            api_version: format!(
                "{}.{}.{}",
                vk::api_version_major(props.api_version),
                vk::api_version_minor(props.api_version),
                vk::api_version_patch(props.api_version)
            ),
            ray_query: ray_query_ok,
            buffer_int64_atomics: f12.shader_buffer_int64_atomics == vk::TRUE,
            shader_int64: core.shader_int64 == vk::TRUE,
            subgroup_size: subgroup.subgroup_size,
            subgroup_ops,
            descriptor_indexing,
            timestamp_period_ns: props.limits.timestamp_period,
            timestamp_valid_bits: qprops[candidate.queue_family as usize].timestamp_valid_bits,
            max_storage_buffer_range: props.limits.max_storage_buffer_range as u64,
            device_local_bytes,
        };

        // Enable what we use.
        let use_rq = options.want_ray_query && ray_query_ok;
        let mut dev_exts: Vec<*const c_char> = Vec::new();
        if use_rq {
            dev_exts.extend(rq_exts.iter().map(|n| n.as_ptr()));
        }
        let use_push_descriptor = has_ext(ash::khr::push_descriptor::NAME);
        if use_push_descriptor {
            dev_exts.push(ash::khr::push_descriptor::NAME.as_ptr());
        }
        let core_enable = vk::PhysicalDeviceFeatures::default()
            .shader_int64(core.shader_int64 == vk::TRUE)
            .shader_storage_image_write_without_format(
                core.shader_storage_image_write_without_format == vk::TRUE,
            );
        let mut e12 = vk::PhysicalDeviceVulkan12Features::default()
            .shader_buffer_int64_atomics(caps.buffer_int64_atomics)
            .buffer_device_address(use_rq)
            .runtime_descriptor_array(descriptor_indexing)
            .shader_sampled_image_array_non_uniform_indexing(descriptor_indexing)
            .descriptor_binding_partially_bound(f12.descriptor_binding_partially_bound == vk::TRUE)
            .scalar_block_layout(f12.scalar_block_layout == vk::TRUE)
            .host_query_reset(f12.host_query_reset == vk::TRUE);
        let mut e_as = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default()
            .acceleration_structure(true);
        let mut e_rq = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
        let priorities = [1.0f32];
        let queue_infos = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(candidate.queue_family)
            .queue_priorities(&priorities)];
        let mut dev_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_infos)
            .enabled_extension_names(&dev_exts)
            .enabled_features(&core_enable)
            .push_next(&mut e12);
        if use_rq {
            dev_info = dev_info.push_next(&mut e_as).push_next(&mut e_rq);
        }
        let device = unsafe { instance.create_device(physical, &dev_info, None) }
            .map_err(vk_err("vkCreateDevice"))?;
        let queue = unsafe { device.get_device_queue(candidate.queue_family, 0) };

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: use_rq,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| GpuError::Alloc {
            what: "allocator".into(),
            message: e.to_string(),
        })?;

        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(candidate.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let command_pool = unsafe { device.create_command_pool(&pool_info, None) }
            .map_err(vk_err("vkCreateCommandPool"))?;
        let accel =
            use_rq.then(|| ash::khr::acceleration_structure::Device::new(&instance, &device));
        let debug_utils_device =
            validate.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let push_descriptor =
            use_push_descriptor.then(|| ash::khr::push_descriptor::Device::new(&instance, &device));

        let mut caps = caps;
        caps.ray_query = use_rq || (ray_query_ok && !options.want_ray_query);
        Ok(GpuContext {
            entry,
            instance,
            debug,
            validation,
            validation_enabled: validate,
            physical,
            caps,
            device,
            queue,
            queue_family: candidate.queue_family,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            command_pool,
            accel,
            timeout: options.timeout,
            lose_device_after: options.lose_device_after,
            submits: Default::default(),
            abandoned: Default::default(),
            lost: Default::default(),
            debug_utils_device,
            push_descriptor,
            allocated_bytes: Default::default(),
        })
    }

    fn choose_device(instance: &ash::Instance, filter: Option<&str>) -> GpuResult<Candidate> {
        let physicals = unsafe { instance.enumerate_physical_devices() }
            .map_err(vk_err("vkEnumeratePhysicalDevices"))?;
        let mut all = Vec::new();
        for p in physicals {
            let props = unsafe { instance.get_physical_device_properties(p) };
            let name = cstr_field(&props.device_name);
            if props.api_version < vk::API_VERSION_1_2 {
                continue;
            }
            let qf = unsafe { instance.get_physical_device_queue_family_properties(p) };
            let Some(family) = qf
                .iter()
                .position(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE))
            else {
                continue;
            };
            all.push(Candidate {
                physical: p,
                name,
                kind: props.device_type,
                queue_family: family as u32,
            });
        }
        if let Some(f) = filter {
            let fl = f.to_lowercase();
            let names: Vec<String> = all.iter().map(|c| c.name.clone()).collect();
            return all
                .into_iter()
                .find(|c| c.name.to_lowercase().contains(&fl))
                .ok_or_else(|| {
                    GpuError::NoDevice(format!(
                        " whose name contains '{f}' (devices: {})",
                        names.join(", ")
                    ))
                });
        }
        all.sort_by_key(|c| type_rank(c.kind));
        all.into_iter()
            .next()
            .ok_or_else(|| GpuError::NoDevice(String::new()))
    }

    /// True when ray queries are enabled on this device (the `query` backend can run).
    pub fn ray_query_enabled(&self) -> bool {
        self.accel.is_some()
    }

    /// True for CPU implementations (lavapipe, SwiftShader), whose ray
    /// queries are software too.
    pub fn is_cpu_device(&self) -> bool {
        self.caps.device_type == type_name(vk::PhysicalDeviceType::CPU)
    }

    /// Records commands with `f` into a one-time command buffer, submits and waits.
    pub fn submit_once<F: FnOnce(vk::CommandBuffer)>(&self, what: &str, f: F) -> GpuResult<()> {
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let cb = unsafe { self.device.allocate_command_buffers(&alloc) }
            .map_err(vk_err("vkAllocateCommandBuffers"))?[0];
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        let result = (|| {
            unsafe { self.device.begin_command_buffer(cb, &begin) }
                .map_err(vk_err("vkBeginCommandBuffer"))?;
            f(cb);
            unsafe { self.device.end_command_buffer(cb) }.map_err(vk_err("vkEndCommandBuffer"))?;
            self.submit_and_wait(cb, what)
        })();
        unsafe { self.device.free_command_buffers(self.command_pool, &[cb]) };
        result
    }

    /// True once a submission outlived the watchdog (see `abandoned`).
    pub fn is_abandoned(&self) -> bool {
        self.abandoned.load(std::sync::atomic::Ordering::SeqCst)
    }

    /// Submits and waits at most the watchdog time. A lost device, a hung
    /// one (timeout) and every later submission give an error, never a hang.
    pub(crate) fn submit_and_wait(&self, cb: vk::CommandBuffer, what: &str) -> GpuResult<()> {
        use std::sync::atomic::Ordering::SeqCst;
        if self.lost.load(SeqCst) || self.is_abandoned() {
            return Err(GpuError::DeviceLost(format!(
                "{what} (the device was lost earlier)"
            )));
        }
        let n = self.submits.fetch_add(1, SeqCst);
        if self.lose_device_after.is_some_and(|k| n >= k) {
            self.lost.store(true, SeqCst);
            return Err(GpuError::DeviceLost(format!("{what} (injected fault)")));
        }
        let timeout_ns = self
            .timeout
            .map_or(u64::MAX, |t| t.as_nanos().min(u64::MAX as u128) as u64);
        let fence = unsafe {
            self.device
                .create_fence(&vk::FenceCreateInfo::default(), None)
        }
        .map_err(vk_err("vkCreateFence"))?;
        let cbs = [cb];
        let submit = [vk::SubmitInfo::default().command_buffers(&cbs)];
        let r = unsafe { self.device.queue_submit(self.queue, &submit, fence) }
            .and_then(|_| unsafe { self.device.wait_for_fences(&[fence], true, timeout_ns) });
        if r == Err(vk::Result::TIMEOUT) {
            // The fence is still pending: leak it with everything else.
            self.abandoned.store(true, SeqCst);
            return Err(GpuError::Hung {
                what: what.to_string(),
                seconds: self.timeout.map_or(0.0, |t| t.as_secs_f64()),
            });
        }
        unsafe { self.device.destroy_fence(fence, None) };
        r.map_err(|e| match e {
            vk::Result::ERROR_DEVICE_LOST => {
                self.lost.store(true, SeqCst);
                GpuError::DeviceLost(what.to_string())
            }
            other => GpuError::Vk {
                call: "vkQueueSubmit/vkWaitForFences",
                result: other,
            },
        })
    }

    /// Gives a Vulkan object a name visible in validation messages.
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(du) = &self.debug_utils_device {
            if let Ok(cname) = CString::new(name) {
                let info = vk::DebugUtilsObjectNameInfoEXT::default()
                    .object_handle(handle)
                    .object_name(&cname);
                let _ = unsafe { du.set_debug_utils_object_name(&info) };
            }
        }
    }

    /// Bytes currently allocated through this context's buffers and images.
    pub fn allocated_bytes(&self) -> u64 {
        self.allocated_bytes
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    pub fn wait_idle(&self) {
        let _ = unsafe { self.device.device_wait_idle() };
    }
}

impl Drop for GpuContext {
    fn drop(&mut self) {
        if self.is_abandoned() {
            // Waiting could hang and destroying could free memory in use:
            // the process is about to report the error and exit.
            return;
        }
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_command_pool(self.command_pool, None);
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some((du, m)) = self.debug.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}
