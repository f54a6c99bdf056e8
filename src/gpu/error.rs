//! Errors from the GPU layer: one line that says what failed and what to do.
#![deny(clippy::undocumented_unsafe_blocks)]

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "cannot load the Vulkan loader (libvulkan.so.1): {0}; run scripts/setup.sh to install it"
    )]
    Loader(String),
    #[error(
        "no Vulkan 1.2 device with a compute queue{0}; run scripts/setup.sh to install lavapipe"
    )]
    NoDevice(String),
    #[error("Vulkan call {call} failed: {result}")]
    Vk {
        call: &'static str,
        result: ash::vk::Result,
    },
    #[error("GPU out of memory while allocating {what} ({bytes} bytes): reduce --size or the cache capacity")]
    OutOfMemory { what: String, bytes: u64 },
    /// A buffer bound as a storage descriptor must not exceed the device's
    /// `maxStorageBufferRange` (VUID-VkWriteDescriptorSet-descriptorType-00333).
    #[error("storage buffer {what} needs {bytes} bytes, more than device '{device}' binds ({limit} bytes, maxStorageBufferRange): {hint}")]
    StorageRange {
        what: String,
        bytes: u64,
        limit: u64,
        device: String,
        hint: &'static str,
    },
    #[error("GPU memory allocation for {what} failed: {message}")]
    Alloc { what: String, message: String },
    #[error("the GPU device was lost (driver crash or timeout) during {0}")]
    DeviceLost(String),
    #[error("the GPU did not finish {what} within {seconds} s (hung device or shader; STEREOCACHE_GPU_TIMEOUT_S sets the limit)")]
    Hung { what: String, seconds: f64 },
    #[error("{0}")]
    Unsupported(String),
    /// A pass's declarations differ from its pipeline's shader interface
    /// (src/interface/): a programming error, caught at record time.
    #[error("shader interface: {0}")]
    Interface(String),
    /// A guard band after a storage buffer was overwritten (src/gpu/guard.rs):
    /// a shader wrote past the end of that buffer.
    #[error("out-of-bounds GPU write past the end of storage buffer(s): {0}")]
    OutOfBounds(String),
}

pub type GpuResult<T> = Result<T, GpuError>;

/// Maps a `vk::Result` of the named call into a `GpuError`, singling out device loss.
pub(crate) fn vk_err(call: &'static str) -> impl Fn(ash::vk::Result) -> GpuError {
    move |result| match result {
        ash::vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost(call.to_string()),
        ash::vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | ash::vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
            GpuError::OutOfMemory {
                what: call.to_string(),
                bytes: 0,
            }
        }
        _ => GpuError::Vk { call, result },
    }
}
