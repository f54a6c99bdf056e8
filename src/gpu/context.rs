//! The GPU context: opens the device in three steps, **probe → choose →
//! open** (`probe.rs`: every physical device's capabilities as plain data;
//! `choose.rs`: the device to use, every other one rejected with its reason;
//! `open.rs`: the logical device with exactly the requested features), then
//! holds the memory allocator, the command pool and one-shot submission
//! with the GPU watchdog.
#![deny(clippy::undocumented_unsafe_blocks)]

use super::caps::{DeviceCaps, Features};
use super::choose::{choose, Rejection};
use super::error::{vk_err, GpuError, GpuResult};
use super::instance::Instance;
use super::open::{open, FeatureRequest, Opened};
use super::probe::{probe_all, type_name, Probed};
use super::validation::ValidationLog;
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::CString;
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex};

/// How to open the GPU.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Enable the Khronos validation layer (when installed) and collect its messages.
    pub validate: bool,
    /// Also enable synchronization validation (slower).
    pub sync_validation: bool,
    /// Pick the first device whose name contains this (case-insensitive).
    pub device: Option<String>,
    /// Enable VK_KHR_ray_query when the device has it (only then: the
    /// software backend needs none of it).
    pub want_ray_query: bool,
    /// Features a device must support to be chosen (default: none; the
    /// optional ones of `FeatureRequest::new` are enabled where supported).
    pub require: Features,
    /// Longest wait for one submission; past it the device counts as hung
    /// and is abandoned (`None`: wait forever). See `with_env`.
    pub timeout: Option<std::time::Duration>,
    /// Fault injection: the submission after this many successful ones
    /// reports a lost device, as a driver would (tests of the error path).
    pub lose_device_after: Option<u64>,
    /// Debugging: canary-filled guard bands after every storage buffer,
    /// checked after every frame (src/gpu/guard.rs; `with_env`:
    /// `STEREOCACHE_GUARD_BANDS=1`). Adds a fill per buffer and a check
    /// submission per frame.
    pub guard_bands: bool,
}

impl GpuOptions {
    /// Default GPU watchdog of the command line, in seconds.
    pub const DEFAULT_TIMEOUT_S: f64 = 600.0;

    /// Reads `STEREOCACHE_GPU_TIMEOUT_S` (seconds, default 600; 0 = wait
    /// forever), `STEREOCACHE_FAULT_DEVICE_LOST_AFTER` (a submission
    /// count) and `STEREOCACHE_GUARD_BANDS` (`1` turns guard bands on). A
    /// malformed value is an error naming the variable.
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
        if let Some((n, v)) = read("STEREOCACHE_GUARD_BANDS") {
            self.guard_bands |= match v.trim() {
                "1" => true,
                "0" | "" => false,
                _ => return Err(format!("{n}={v}: expected 1 or 0")),
            };
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
    /// What the chosen device supports (`caps.supported`), its limits and
    /// identity. What was enabled is `enabled`.
    pub caps: DeviceCaps,
    /// The features the device was created with (and, for `debug_utils`,
    /// the instance): code relies on these, never on `caps.supported`.
    pub enabled: Features,
    /// Every physical device probed, the chosen one included (`info`).
    pub devices: Vec<DeviceCaps>,
    /// The devices not chosen, each with its reason.
    pub rejected: Vec<Rejection>,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub(crate) allocator: ManuallyDrop<Mutex<Allocator>>,
    /// `submit_once`'s command pool; `command_buffer_lock` is held while it
    /// is used (a pool needs external synchronisation). Recorders own their
    /// pools.
    pub(crate) command_pool: vk::CommandPool,
    /// `command_buffer_lock`'s mutex.
    command_lock: Mutex<()>,
    /// Held around vkQueueSubmit (the queue needs external synchronisation):
    /// with it and `command_buffer_lock` a context may be shared between
    /// threads.
    queue_lock: Mutex<()>,
    /// VK_KHR_acceleration_structure (with `enabled.ray_query`).
    pub(crate) accel: Option<ash::khr::acceleration_structure::Device>,
    /// VK_KHR_push_descriptor (with `enabled.push_descriptor`).
    pub(crate) push_descriptor: Option<ash::khr::push_descriptor::Device>,
    timeout: Option<std::time::Duration>,
    lose_device_after: Option<u64>,
    submits: std::sync::atomic::AtomicU64,
    /// Submissions of guard-band work (not in `submit_count`).
    guard_submits: std::sync::atomic::AtomicU64,
    /// A submission outlived the watchdog: its work may still run, so no
    /// object is destroyed any more (every `Drop` in src/gpu/ leaks instead
    /// of freeing memory the device may still write).
    abandoned: std::sync::atomic::AtomicBool,
    lost: std::sync::atomic::AtomicBool,
    /// VK_EXT_debug_utils device functions (with `enabled.debug_utils`):
    /// object names and command-buffer labels.
    pub(crate) debug_utils_device: Option<ash::ext::debug_utils::Device>,
    pub(crate) allocated_bytes: std::sync::atomic::AtomicU64,
    /// The live guard bands by buffer handle (`Some` with
    /// `GpuOptions::guard_bands`; src/gpu/guard.rs).
    pub(crate) guards: Option<Mutex<std::collections::HashMap<u64, super::guard::Band>>>,
}

impl GpuContext {
    /// Probes every device, chooses one (`--device`, else discrete GPU
    /// first … CPU last; unusable devices are rejected with a reason, printed
    /// as a warning) and opens it with `FeatureRequest::new(want_ray_query,
    /// require)` resolved against what it supports.
    pub fn new(options: &GpuOptions) -> GpuResult<Self> {
        let validation = Arc::new(ValidationLog::default());
        let request = FeatureRequest::new(options.want_ray_query, options.require);
        let _serial = lifecycle_lock();
        let mut inst = super::instance::create(
            options.validate,
            options.sync_validation,
            request.optional.debug_utils || request.required.debug_utils,
            &validation,
        )?;
        match Self::open_device(&inst, options, &request) {
            Ok(parts) => Ok(Self::assemble(inst, validation, options, parts)),
            Err(e) => {
                // SAFETY: `open_device` destroys whatever it created before
                // failing, so nothing made from the instance is alive.
                unsafe { inst.destroy() };
                Err(e)
            }
        }
    }

    /// Probe, choose, open, then the allocator and the command pool.
    fn open_device(
        inst: &Instance,
        options: &GpuOptions,
        request: &FeatureRequest,
    ) -> GpuResult<DeviceParts> {
        let mut probed = probe_all(&inst.instance, inst.debug_utils)?;
        let devices: Vec<DeviceCaps> = probed.iter().map(|p| p.caps.clone()).collect();
        let choice = choose(&devices, options.device.as_deref(), &request.required)?;
        for r in choice.rejected.iter().filter(|r| r.unusable) {
            eprintln!(
                "warning: Vulkan device {} is not usable: {}",
                r.device, r.reason
            );
        }
        let chosen: Probed = probed.swap_remove(choice.chosen);
        let enabled = request.resolve(&chosen.caps.supported);
        let opened = open(&inst.instance, &chosen, &enabled)?;
        let device = opened.device.clone();
        let rest = (|| {
            let allocator = Allocator::new(&AllocatorCreateDesc {
                instance: inst.instance.clone(),
                device: device.clone(),
                physical_device: chosen.physical,
                debug_settings: Default::default(),
                buffer_device_address: enabled.ray_query,
                allocation_sizes: Default::default(),
            })
            .map_err(|e| GpuError::Alloc {
                what: "allocator".into(),
                message: e.to_string(),
            })?;
            let pool_info = vk::CommandPoolCreateInfo::default()
                .queue_family_index(opened.queue_family)
                .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
            // SAFETY: `device` is live and `queue_family` is one of its queues' family.
            let command_pool = unsafe { device.create_command_pool(&pool_info, None) }
                .map_err(vk_err("vkCreateCommandPool"))?;
            Ok((allocator, command_pool))
        })();
        match rest {
            Ok((allocator, command_pool)) => Ok(DeviceParts {
                physical: chosen.physical,
                caps: chosen.caps,
                enabled,
                devices,
                rejected: choice.rejected,
                opened,
                allocator,
                command_pool,
            }),
            Err(e) => {
                // SAFETY: nothing was submitted; the allocator (if it was
                // made) was dropped inside the closure.
                unsafe { device.destroy_device(None) };
                Err(e)
            }
        }
    }

    fn assemble(
        inst: Instance,
        validation: Arc<ValidationLog>,
        options: &GpuOptions,
        p: DeviceParts,
    ) -> Self {
        let Instance {
            entry,
            instance,
            messenger,
            validate,
            ..
        } = inst;
        GpuContext {
            entry,
            instance,
            debug: messenger,
            validation,
            validation_enabled: validate,
            physical: p.physical,
            caps: p.caps,
            enabled: p.enabled,
            devices: p.devices,
            rejected: p.rejected,
            device: p.opened.device,
            queue: p.opened.queue,
            queue_family: p.opened.queue_family,
            allocator: ManuallyDrop::new(Mutex::new(p.allocator)),
            command_pool: p.command_pool,
            command_lock: Mutex::new(()),
            queue_lock: Mutex::new(()),
            accel: p.opened.accel,
            push_descriptor: p.opened.push_descriptor,
            timeout: options.timeout,
            lose_device_after: options.lose_device_after,
            submits: Default::default(),
            guard_submits: Default::default(),
            abandoned: Default::default(),
            lost: Default::default(),
            debug_utils_device: p.opened.debug_utils,
            allocated_bytes: Default::default(),
            guards: options.guard_bands.then(Default::default),
        }
    }

    /// Submit-and-wait rounds so far on this device (tests: the shared
    /// frame loop submits once per frame).
    /// Guard-band fills and checks (src/gpu/guard.rs) are not counted.
    pub fn submit_count(&self) -> u64 {
        use std::sync::atomic::Ordering::SeqCst;
        self.submits.load(SeqCst) - self.guard_submits.load(SeqCst)
    }

    /// `submit_once` for guard-band work: not counted in `submit_count`, so
    /// the one-submit-per-frame checks hold with guard bands on.
    pub(crate) fn submit_once_uncounted<F: FnOnce(vk::CommandBuffer)>(
        &self,
        what: &str,
        f: F,
    ) -> GpuResult<()> {
        self.guard_submits
            .fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        self.submit_once(what, f)
    }

    /// True when VK_KHR_push_descriptor is enabled (`push_descriptor_fns`).
    pub fn push_descriptor_enabled(&self) -> bool {
        self.push_descriptor.is_some()
    }

    /// The VK_KHR_push_descriptor functions, when enabled.
    pub fn push_descriptor_fns(&self) -> Option<&ash::khr::push_descriptor::Device> {
        self.push_descriptor.as_ref()
    }

    /// The VK_EXT_debug_utils device functions (object names, command
    /// labels), when enabled.
    pub fn debug_utils_fns(&self) -> Option<&ash::ext::debug_utils::Device> {
        self.debug_utils_device.as_ref()
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
        // The shared pool, one caller at a time while its buffer is
        // allocated, recorded and freed (a pool needs external
        // synchronisation for those, not while its buffer executes); the
        // lock is not held during the wait, so other threads' waits do not
        // queue behind it. A poisoned lock guards no state of its own.
        let pool = || self.command_buffer_lock();
        let recorded = {
            let _pool = pool();
            let alloc = vk::CommandBufferAllocateInfo::default()
                .command_pool(self.command_pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            // SAFETY: the pool belongs to this device; its lock is held.
            let cb = unsafe { self.device.allocate_command_buffers(&alloc) }
                .map_err(vk_err("vkAllocateCommandBuffers"))?[0];
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            let r = (|| {
                // SAFETY: `cb` was just allocated and is in the initial state.
                unsafe { self.device.begin_command_buffer(cb, &begin) }
                    .map_err(vk_err("vkBeginCommandBuffer"))?;
                f(cb);
                // SAFETY: `cb` is recording (begun above).
                unsafe { self.device.end_command_buffer(cb) }.map_err(vk_err("vkEndCommandBuffer"))
            })();
            (cb, r)
        };
        let (cb, recorded) = recorded;
        let result = recorded.and_then(|_| self.submit_and_wait(cb, what));
        // After a watchdog timeout `cb` is still pending: freeing it would
        // let the driver run freed commands (a crash at exit, the validation
        // error VUID-vkFreeCommandBuffers-pCommandBuffers-00047). Leak it,
        // like everything else once the context is abandoned.
        if !self.is_abandoned() {
            let _pool = pool();
            // SAFETY: `cb` is not pending (the wait completed, failed or
            // the submission never happened) and came from this pool;
            // its lock is held.
            unsafe { self.device.free_command_buffers(self.command_pool, &[cb]) };
        }
        result
    }

    /// The context's lock around every call that creates, begins or
    /// destroys a command buffer's debug-label state in the validation
    /// layer: vkCreateCommandPool (recorders' pools; the context's own is
    /// made before any other thread can reach the context),
    /// vkAllocateCommandBuffers, vkBeginCommandBuffer,
    /// vkFreeCommandBuffers, vkDestroyCommandPool and
    /// vkCmdBegin/EndDebugUtilsLabelEXT (and around `submit_once`'s
    /// recording into the shared pool, which the spec requires);
    /// vkQueueSubmit is not among them, nor vkEndCommandBuffer by design
    /// (it falls under the lock in `submit_once` and a recorder's drop,
    /// not in `Recorder::finish`). For the
    /// recorders' own pools the spec asks for nothing, but the Khronos
    /// validation layer installed here (1.3.239) keeps the labels of every
    /// command buffer of an instance (each context has its own) in one map
    /// and corrupts its heap when one thread labels its command buffer
    /// while another frees or begins one (test
    /// `passes::threads_share_a_context`, measured: "malloc(): unaligned
    /// tcache chunk detected" or a SIGSEGV inside the layer, 24 runs in 300
    /// with labels and no lock, 3 in 300 with the lifetime calls locked and
    /// the label calls not, none in 400 without labels, none in 600 with
    /// one such lock for the whole process, none in 300 with this one per
    /// context; docs/ROBUSTNESS.md §5). The calls are cheap (two labels
    /// per pass): serialising them costs nothing measurable. Poisoning is
    /// ignored: the lock guards no data of ours.
    pub(crate) fn command_buffer_lock(&self) -> std::sync::MutexGuard<'_, ()> {
        self.command_lock.lock().unwrap_or_else(|e| e.into_inner())
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
        // SAFETY: a plain fence on the live device.
        let fence = unsafe {
            self.device
                .create_fence(&vk::FenceCreateInfo::default(), None)
        }
        .map_err(vk_err("vkCreateFence"))?;
        let cbs = [cb];
        let submit = [vk::SubmitInfo::default().command_buffers(&cbs)];
        let submitted = {
            let _queue = self.queue_lock.lock().unwrap_or_else(|e| e.into_inner());
            // SAFETY: `cb` is executable (ended) and its resources are kept
            // alive by the caller until this returns; the fence is
            // unsignalled; `queue_lock` serialises the queue's use.
            unsafe { self.device.queue_submit(self.queue, &submit, fence) }
        };
        // SAFETY: the fence was created above on this device.
        let r = submitted
            .and_then(|_| unsafe { self.device.wait_for_fences(&[fence], true, timeout_ns) });
        // A wait that failed after a successful submit (a timeout, or out of
        // host/device memory) leaves the submission possibly pending: the
        // fence, command buffer and resources may not be destroyed
        // (VUID-vkDestroyFence-fence-01120), so they are leaked as after a
        // timeout. Until session 50 only a timeout did; a lost device needs
        // no wait.
        let pending = submitted.is_ok() && r.is_err() && r != Err(vk::Result::ERROR_DEVICE_LOST);
        if pending && r != Err(vk::Result::TIMEOUT) {
            self.abandoned.store(true, SeqCst);
            return Err(GpuError::Vk {
                call: "vkWaitForFences",
                result: r.unwrap_err(),
            });
        }
        if r == Err(vk::Result::TIMEOUT) {
            // The fence is still pending: leak it with everything else.
            self.abandoned.store(true, SeqCst);
            return Err(GpuError::Hung {
                what: what.to_string(),
                seconds: self.timeout.map_or(0.0, |t| t.as_secs_f64()),
            });
        }
        // SAFETY: the fence is signalled (or the submission failed), so no
        // queue operation still refers to it.
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

    /// Gives a Vulkan object a name visible in validation messages and
    /// captures (when VK_EXT_debug_utils is enabled).
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(du) = &self.debug_utils_device {
            if let Ok(cname) = CString::new(name) {
                let info = vk::DebugUtilsObjectNameInfoEXT::default()
                    .object_handle(handle)
                    .object_name(&cname);
                // SAFETY: `handle` is a live object of this device (callers
                // name what they just created) and `cname` outlives the call.
                let _ = unsafe { du.set_debug_utils_object_name(&info) };
            }
        }
    }

    /// True when storage buffers get guard bands (`GpuOptions::guard_bands`).
    pub fn guard_bands_enabled(&self) -> bool {
        self.guards.is_some()
    }

    /// Whether sampled images of `format` (optimal tiling) can be filtered
    /// linearly on this device (optional for 32-bit float formats).
    pub fn can_filter_linear(&self, format: vk::Format) -> bool {
        // SAFETY: `physical` is the device this instance enumerated.
        let props = unsafe {
            self.instance
                .get_physical_device_format_properties(self.physical, format)
        };
        props
            .optimal_tiling_features
            .contains(vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR)
    }

    /// Bytes currently allocated through this context's buffers and images.
    pub fn allocated_bytes(&self) -> u64 {
        self.allocated_bytes
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    pub fn wait_idle(&self) {
        // vkDeviceWaitIdle needs every queue externally synchronised.
        let _queue = self.queue_lock.lock().unwrap_or_else(|e| e.into_inner());
        // SAFETY: a live device; its queue is held (`queue_lock`).
        let _ = unsafe { self.device.device_wait_idle() };
    }
}

/// Serialises the creation and destruction of instances and devices in the
/// process. The Khronos validation layer installed here (1.3.239) keeps every
/// instance's and device's state in one global map that it reads on every
/// call and inserts into / erases from at vkCreateInstance, vkCreateDevice,
/// vkDestroyDevice and vkDestroyInstance without a lock (`GetLayerDataPtr`,
/// "TODO: We probably should lock here"; Vulkan-ValidationLayers issue
/// 4391). Test binaries open and close one context per test on parallel
/// threads, so two of those calls could modify the map at once, a heap
/// corruption. This lock makes the modifications one at a time; a lookup
/// by another thread's ordinary call during one of them is still that
/// layer's race (docs/ROBUSTNESS.md §5). Poisoning is ignored: the lock
/// guards no data of ours.
fn lifecycle_lock() -> std::sync::MutexGuard<'static, ()> {
    static LIFECYCLE: Mutex<()> = Mutex::new(());
    LIFECYCLE.lock().unwrap_or_else(|e| e.into_inner())
}

/// What `open_device` made, before it becomes a `GpuContext`.
struct DeviceParts {
    physical: vk::PhysicalDevice,
    caps: DeviceCaps,
    enabled: Features,
    devices: Vec<DeviceCaps>,
    rejected: Vec<Rejection>,
    opened: Opened,
    allocator: Allocator,
    command_pool: vk::CommandPool,
}

impl Drop for GpuContext {
    fn drop(&mut self) {
        if self.is_abandoned() {
            // Waiting could hang and destroying could free memory in use:
            // the process is about to report the error and exit. The
            // messenger stays registered, so the log its `user_data` points
            // to must outlive this struct: leak one reference. Likewise keep
            // libvulkan loaded (the Entry's library) under the live instance.
            std::mem::forget(self.validation.clone());
            std::mem::forget(self.entry.clone());
            return;
        }
        let _serial = lifecycle_lock();
        // SAFETY: every Buffer, image, pipeline and recorder holds an
        // `Arc<GpuContext>`, so all of them are gone; after the idle wait no
        // work is pending. Objects are destroyed children first, the
        // messenger before the instance, and `debug` is taken so nothing is
        // destroyed twice.
        unsafe {
            let _ = self.device.device_wait_idle();
            let pools = self.command_buffer_lock();
            self.device.destroy_command_pool(self.command_pool, None);
            drop(pools);
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some((du, m)) = self.debug.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}
