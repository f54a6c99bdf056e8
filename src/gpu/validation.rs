//! The Khronos validation layer's messages, collected so tests can fail on any.
#![deny(clippy::undocumented_unsafe_blocks)]

use ash::vk;
use std::ffi::CStr;
use std::sync::Mutex;

/// Messages received from `VK_EXT_debug_utils` (warnings and errors only).
#[derive(Default)]
pub struct ValidationLog {
    messages: Mutex<Vec<String>>,
}

impl ValidationLog {
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().unwrap().clone()
    }
    pub fn count(&self) -> usize {
        self.messages.lock().unwrap().len()
    }
    pub(crate) fn push(&self, m: String) {
        self.messages.lock().unwrap().push(m);
    }
}

/// # Safety
/// Called by the Vulkan loader with a valid callback-data pointer and the
/// `user_data` pointer we registered (a `ValidationLog` that outlives the messenger).
pub(crate) unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut std::ffi::c_void,
) -> vk::Bool32 {
    if data.is_null() || user_data.is_null() {
        return vk::FALSE;
    }
    // SAFETY: non-null (checked) and valid for the callback (the loader's contract).
    let data = unsafe { &*data };
    let msg = if data.p_message.is_null() {
        String::from("(no message)")
    } else {
        // SAFETY: non-null (checked); the loader passes a NUL-terminated string.
        unsafe { CStr::from_ptr(data.p_message) }
            .to_string_lossy()
            .into_owned()
    };
    // SAFETY: `user_data` is the `Arc<ValidationLog>` pointer registered in
    // instance.rs; the context keeps that Arc alive while the messenger is
    // registered (and leaks it when it leaves the instance alive).
    let log = unsafe { &*(user_data as *const ValidationLog) };
    let line = format!("[{severity:?} {kind:?}] {msg}");
    eprintln!("vulkan validation: {line}");
    log.push(line);
    vk::FALSE
}
