//! Compute pipelines from SPIR-V with specialization constants.

use super::context::GpuContext;
use super::descriptors::DescriptorLayout;
use super::error::{vk_err, GpuError, GpuResult};
use super::reflect::{self, PassUse};
use crate::interface::{Interface, PushBlock};
use ash::vk;
use std::sync::Arc;

/// Specialization constants as (constant_id, 32-bit value); bools are 0/1.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SpecConstants(pub Vec<(u32, u32)>);

impl SpecConstants {
    pub fn set(&mut self, id: u32, value: u32) -> &mut Self {
        self.0.retain(|(i, _)| *i != id);
        self.0.push((id, value));
        self
    }
    pub fn flag(&mut self, id: u32, on: bool) -> &mut Self {
        self.set(id, on as u32)
    }
}

/// How a pipeline binds its per-pass buffers (set `interface.set`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PassBinding {
    /// Push descriptors where VK_KHR_push_descriptor is enabled and
    /// `STEREOCACHE_NO_PUSH_DESCRIPTOR` is not `1`, else descriptor sets.
    #[default]
    Default,
    /// A descriptor set per pass from the recorder's pools, even where push
    /// descriptors exist: tests compare the two paths in one process
    /// without changing the environment (which other threads read).
    DescriptorSets,
}

pub struct ComputePipeline {
    ctx: Arc<GpuContext>,
    pub name: String,
    pub raw: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub push_size: u32,
    /// The shader interface the pass builder checks declarations against.
    pub interface: &'static Interface,
    /// What the shader does with each of `interface`'s bindings, reflected
    /// from its SPIR-V (src/gpu/reflect.rs): the pass builder binds and
    /// tracks only the bindings it uses, with the access it really makes.
    pub uses: Vec<PassUse>,
    /// The shader writes bindings of a persistent set (the scene's
    /// memoization table, `reflect::persistent_writable`): its passes add
    /// the set's written buffers to their hazards.
    pub writes_persistent: bool,
    /// Number of persistent sets before the per-pass set.
    pub shared_sets: u32,
    /// The per-pass set is pushed (VK_KHR_push_descriptor), else allocated
    /// per pass from the recorder's pools.
    pub(crate) push_descriptors: bool,
    _set_layouts: Vec<Arc<DescriptorLayout>>,
}

impl ComputePipeline {
    /// A pipeline whose per-pass buffers (set `interface.set`) are bound by
    /// the pass builder (`Recorder::compute`) from the pass's declarations;
    /// `shared` are the persistent sets before it (the scene's set 0), and
    /// `push` the push-constant block (its size is the pipeline's).
    pub fn with_interface(
        ctx: &Arc<GpuContext>,
        name: &str,
        spirv: &[u8],
        shared: &[Arc<DescriptorLayout>],
        interface: &'static Interface,
        push: Option<&'static PushBlock>,
        spec: &SpecConstants,
    ) -> GpuResult<ComputePipeline> {
        Self::with_interface_binding(
            ctx,
            name,
            spirv,
            shared,
            interface,
            push,
            spec,
            PassBinding::Default,
        )
    }

    /// `with_interface` with the per-pass binding path chosen by the caller.
    #[allow(clippy::too_many_arguments)]
    pub fn with_interface_binding(
        ctx: &Arc<GpuContext>,
        name: &str,
        spirv: &[u8],
        shared: &[Arc<DescriptorLayout>],
        interface: &'static Interface,
        push: Option<&'static PushBlock>,
        spec: &SpecConstants,
        binding: PassBinding,
    ) -> GpuResult<ComputePipeline> {
        if interface.set as usize != shared.len() {
            return Err(GpuError::Interface(format!(
                "pipeline {name}: interface {} binds its buffers at set {}, after {} shared set(s)",
                interface.name,
                interface.set,
                shared.len()
            )));
        }
        if let Some(p) = push {
            if !interface.push.iter().any(|q| q.name == p.name) {
                return Err(GpuError::Interface(format!(
                    "pipeline {name}: push block {} is not part of interface {}",
                    p.name, interface.name
                )));
            }
        }
        // The shader's real accesses against the Rust interface: a binding
        // it writes must be declared written, every one it uses must exist.
        let used = reflect::reflect(spirv)
            .map_err(|e| GpuError::Unsupported(format!("shader {name}: {e}")))?;
        let uses = reflect::check_interface(name, &used, interface).map_err(GpuError::Interface)?;
        let writes_persistent = reflect::writes_persistent(&used, interface);
        let push_descriptors =
            binding == PassBinding::Default && super::descriptors::use_push_descriptors(ctx);
        let mut layouts = shared.to_vec();
        layouts.push(DescriptorLayout::pass_buffers(
            ctx,
            interface.bindings.len(),
            push_descriptors,
        )?);
        let (raw, layout) = create(
            ctx,
            name,
            spirv,
            &layouts,
            push.map_or(0, |p| p.size()),
            spec,
        )?;
        Ok(ComputePipeline {
            ctx: ctx.clone(),
            name: name.into(),
            raw,
            layout,
            push_size: push.map_or(0, |p| p.size()),
            interface,
            uses,
            writes_persistent,
            shared_sets: shared.len() as u32,
            push_descriptors,
            _set_layouts: layouts,
        })
    }
}

/// The pipeline and its layout: `set_layouts` in order, one push-constant
/// range of `push_size` bytes (none when 0), `spec` as specialization constants.
fn create(
    ctx: &Arc<GpuContext>,
    name: &str,
    spirv: &[u8],
    set_layouts: &[Arc<DescriptorLayout>],
    push_size: u32,
    spec: &SpecConstants,
) -> GpuResult<(vk::Pipeline, vk::PipelineLayout)> {
    let words =
        reflect::words(spirv).map_err(|e| GpuError::Unsupported(format!("shader {name}: {e}")))?;
    let module_info = vk::ShaderModuleCreateInfo::default().code(&words);
    // SAFETY: `words` is whole 32-bit SPIR-V words (checked above) that outlive
    // the call; the device is alive while `ctx` is.
    let module = unsafe { ctx.device.create_shader_module(&module_info, None) }
        .map_err(vk_err("vkCreateShaderModule"))?;

    let raw_layouts: Vec<vk::DescriptorSetLayout> = set_layouts.iter().map(|l| l.raw).collect();
    let ranges = [vk::PushConstantRange::default()
        .stage_flags(vk::ShaderStageFlags::COMPUTE)
        .offset(0)
        .size(push_size)];
    let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&raw_layouts);
    if push_size > 0 {
        layout_info = layout_info.push_constant_ranges(&ranges);
    }
    // SAFETY: the set layouts are alive (`set_layouts` is borrowed and kept by
    // the pipeline) and `ranges` outlives the call.
    let layout = unsafe { ctx.device.create_pipeline_layout(&layout_info, None) }
        .map_err(vk_err("vkCreatePipelineLayout"))?;

    let entries: Vec<vk::SpecializationMapEntry> = spec
        .0
        .iter()
        .enumerate()
        .map(|(i, (id, _))| vk::SpecializationMapEntry {
            constant_id: *id,
            offset: (i * 4) as u32,
            size: 4,
        })
        .collect();
    let data: Vec<u8> = spec.0.iter().flat_map(|(_, v)| v.to_le_bytes()).collect();
    let spec_info = vk::SpecializationInfo::default()
        .map_entries(&entries)
        .data(&data);
    let stage = vk::PipelineShaderStageCreateInfo::default()
        .stage(vk::ShaderStageFlags::COMPUTE)
        .module(module)
        .name(c"main")
        .specialization_info(&spec_info);
    let info = [vk::ComputePipelineCreateInfo::default()
        .stage(stage)
        .layout(layout)];
    // SAFETY: `module` and `layout` were just created on this device; the
    // specialization entries and data (4 bytes per entry) outlive the call.
    let result = unsafe {
        ctx.device
            .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
    };
    // SAFETY: the module is only needed while the pipeline is created, which
    // has returned; nothing else holds it.
    unsafe { ctx.device.destroy_shader_module(module, None) };
    let raw = match result {
        Ok(p) => p[0],
        Err((_, e)) => {
            // SAFETY: pipeline creation failed, so no pipeline uses the layout.
            unsafe { ctx.device.destroy_pipeline_layout(layout, None) };
            return Err(vk_err("vkCreateComputePipelines")(e));
        }
    };
    ctx.set_name(raw, name);
    Ok((raw, layout))
}

impl ComputePipeline {
    /// True when the per-pass buffers are bound with push descriptors
    /// (false: per-pass descriptor sets).
    pub fn uses_push_descriptors(&self) -> bool {
        self.push_descriptors
    }

    /// The per-pass set's layout (the last one).
    pub(crate) fn pass_layout_raw(&self) -> vk::DescriptorSetLayout {
        self._set_layouts.last().map(|l| l.raw).unwrap_or_default()
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        if self.ctx.is_abandoned() {
            return;
        }
        // SAFETY: recorders borrow the pipelines they record for their whole
        // life and wait for their submission, so no pending command buffer
        // uses this pipeline or its layout any more (an abandoned context,
        // whose work may still run, returned above).
        unsafe {
            self.ctx.device.destroy_pipeline(self.raw, None);
            self.ctx.device.destroy_pipeline_layout(self.layout, None);
        }
    }
}
