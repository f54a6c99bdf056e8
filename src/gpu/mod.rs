//! Every line of unsafe Vulkan lives here: the device (instance → probe →
//! choose → open → context), memory, descriptors, pipelines, the pass
//! recorder with its timestamps, and acceleration structures. The crate
//! root denies `unsafe_code` everywhere else; every unsafe block here says
//! why it is sound (`// SAFETY:`, enforced by the lint below).
#![deny(clippy::undocumented_unsafe_blocks)]

pub mod accel;
pub mod buffer;
pub mod caps;
pub mod choose;
pub mod compute_pass;
pub mod context;
pub mod descriptors;
pub mod error;
pub mod guard;
pub mod info;
mod instance;
pub mod open;
pub mod pass;
pub mod pipeline;
mod probe;
pub mod readback;
pub mod reflect;
pub mod shaders;
pub mod texture;
pub mod validation;

pub use buffer::Buffer;
pub use caps::{DeviceCaps, Features, MemoryHeap};
pub use choose::{choose, Choice, Rejection};
pub use compute_pass::ComputePass;
pub use context::{GpuContext, GpuOptions};
pub use descriptors::{BindingKind, DescriptorLayout, DescriptorSet, Resource};
pub use error::{GpuError, GpuResult};
pub use open::FeatureRequest;
pub use pass::{groups_for, PassTiming, Recorder};
pub use pipeline::{ComputePipeline, PassBinding, SpecConstants};
pub use readback::{HostReadback, ReadbackRange};
pub use texture::{GpuTexture, Sampler};
