//! Every line of unsafe Vulkan lives here: the device, memory, descriptors,
//! pipelines, the pass recorder with its timestamps, and acceleration structures.

pub mod accel;
pub mod buffer;
pub mod caps;
pub mod compute_pass;
pub mod context;
pub mod descriptors;
pub mod error;
pub mod pass;
pub mod pipeline;
pub mod readback;
pub mod shaders;
pub mod texture;
pub mod validation;

pub use buffer::Buffer;
pub use caps::DeviceCaps;
pub use compute_pass::ComputePass;
pub use context::{GpuContext, GpuOptions};
pub use descriptors::{BindingKind, DescriptorLayout, DescriptorSet, Resource};
pub use error::{GpuError, GpuResult};
pub use pass::{groups_for, PassTiming, Recorder};
pub use pipeline::{ComputePipeline, SpecConstants};
pub use readback::{HostReadback, ReadbackRange};
pub use texture::{GpuTexture, Sampler};
