//! The Vulkan instance: the loader, the validation layer (when asked for and
//! installed), VK_EXT_debug_utils (whenever the instance offers it: object
//! names and pass labels) and the validation messenger.
#![deny(clippy::undocumented_unsafe_blocks)]

use super::error::{vk_err, GpuError, GpuResult};
use super::validation::{debug_callback, ValidationLog};
use ash::vk;
use std::ffi::{c_char, CStr};
use std::sync::Arc;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// A created instance and what it has enabled.
pub(crate) struct Instance {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    /// The validation messenger (only with the validation layer).
    pub messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// The validation layer is on.
    pub validate: bool,
    /// VK_EXT_debug_utils is enabled on the instance.
    pub debug_utils: bool,
}

/// Creates the instance. `validate`: enable the validation layer when
/// installed (a warning otherwise) and route its messages to `log`;
/// `sync_validation` adds synchronization validation; `debug_utils`:
/// enable VK_EXT_debug_utils when the instance offers it.
pub(crate) fn create(
    validate: bool,
    sync_validation: bool,
    debug_utils: bool,
    log: &Arc<ValidationLog>,
) -> GpuResult<Instance> {
    // SAFETY: loading libvulkan runs its initialisers; the Entry keeps the
    // library loaded for as long as any object made from it lives (it is
    // stored in the GpuContext next to the instance).
    let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loader(e.to_string()))?;
    // SAFETY: a global query on a loaded entry.
    let layer_present = unsafe { entry.enumerate_instance_layer_properties() }
        .map_err(vk_err("vkEnumerateInstanceLayerProperties"))?
        .iter()
        .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
    let validate_on = validate && layer_present;
    if validate && !layer_present {
        eprintln!("warning: --validate asked for VK_LAYER_KHRONOS_validation, which is not installed; running without it");
    }
    // SAFETY: a global query on a loaded entry (no layer: the loader's and
    // the drivers' instance extensions).
    let has_debug_utils = unsafe { entry.enumerate_instance_extension_properties(None) }
        .map_err(vk_err("vkEnumerateInstanceExtensionProperties"))?
        .iter()
        .any(|e| e.extension_name_as_c_str().ok() == Some(ash::ext::debug_utils::NAME));
    // The validation layer provides debug utils itself.
    let debug_utils_on = validate_on || (debug_utils && has_debug_utils);

    let app_name = c"stereocache";
    let app_info = vk::ApplicationInfo::default()
        .application_name(app_name)
        .application_version(1)
        .engine_name(app_name)
        .api_version(vk::API_VERSION_1_2);
    let mut layers: Vec<*const c_char> = Vec::new();
    let mut extensions: Vec<*const c_char> = Vec::new();
    if validate_on {
        layers.push(VALIDATION_LAYER.as_ptr());
    }
    if debug_utils_on {
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut validation_features =
        vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);
    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app_info)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions);
    if validate_on && sync_validation {
        info = info.push_next(&mut validation_features);
    }
    // SAFETY: the layer and extension names were listed by the loader and
    // every pointer in `info` outlives the call.
    let instance =
        unsafe { entry.create_instance(&info, None) }.map_err(vk_err("vkCreateInstance"))?;

    let messenger = if validate_on {
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
            .user_data(Arc::as_ptr(log) as *mut std::ffi::c_void);
        // SAFETY: debug utils is enabled (validation on); `user_data` points
        // to the ValidationLog the GpuContext keeps alive (an Arc) until
        // after the messenger is destroyed.
        match unsafe { du.create_debug_utils_messenger(&info, None) } {
            Ok(m) => Some((du, m)),
            Err(e) => {
                // SAFETY: nothing was created from the instance yet.
                unsafe { instance.destroy_instance(None) };
                return Err(vk_err("vkCreateDebugUtilsMessengerEXT")(e));
            }
        }
    } else {
        None
    };
    Ok(Instance {
        entry,
        instance,
        messenger,
        validate: validate_on,
        debug_utils: debug_utils_on,
    })
}

impl Instance {
    /// Destroys the messenger and the instance.
    ///
    /// # Safety
    /// Every object created from the instance (devices included) must be
    /// destroyed already, and neither may be used afterwards.
    pub(crate) unsafe fn destroy(&mut self) {
        // SAFETY: by the contract of this function nothing created from the
        // instance is alive; the messenger is taken so it is destroyed once.
        unsafe {
            if let Some((du, m)) = self.messenger.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}
