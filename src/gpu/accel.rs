//! Acceleration structures for the ray-query backend: one BLAS per mesh and
//! a TLAS over the instances (VK_KHR_acceleration_structure, built on the device).
#![deny(clippy::undocumented_unsafe_blocks)]

use super::buffer::Buffer;
use super::context::GpuContext;
use super::error::{vk_err, GpuError, GpuResult};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// One mesh's triangles for a BLAS.
pub struct BlasInput<'a> {
    pub positions: &'a [[f32; 3]],
    pub indices: &'a [u32],
    /// Opaque geometry skips the any-hit (alpha test) step of traversal.
    pub opaque: bool,
}

/// The facing flags of an instance. glTF's front faces are counter-clockwise
/// in object space (a mirroring node transform keeps the object-space
/// winding: glTF §3.7.2.1's determinant rule), and Vulkan decides facing in
/// object space too, with the same counter-clockwise front unless the flip
/// bit is set (tests/culling.rs checks this on lavapipe, mirrored instances
/// included): culling instances get no facing flag, the others
/// TRIANGLE_FACING_CULL_DISABLE.
fn facing_flags(inst: &TlasInstance) -> vk::GeometryInstanceFlagsKHR {
    if inst.cull_back_faces {
        vk::GeometryInstanceFlagsKHR::empty()
    } else {
        vk::GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE
    }
}

/// One TLAS instance.
pub struct TlasInstance {
    /// Row-major 3×4 object-to-world matrix.
    pub transform: [[f32; 4]; 3],
    /// Returned by `rayQueryGetIntersectionInstanceCustomIndexEXT` (24 bits).
    pub custom_index: u32,
    pub blas: usize,
    /// Rays with `gl_RayFlagsCullBackFacingTrianglesEXT` pass through the
    /// back faces (glTF's: counter-clockwise front in object space, where
    /// Vulkan decides facing).
    pub cull_back_faces: bool,
}

struct Accel {
    raw: vk::AccelerationStructureKHR,
    _buffer: Buffer,
}

pub struct AccelStructures {
    ctx: Arc<GpuContext>,
    blases: Vec<Accel>,
    tlas: Accel,
    /// Instances the TLAS was built for (a rebuild keeps the count).
    tlas_count: u32,
    scratch_align: u64,
}

impl AccelStructures {
    pub fn tlas(&self) -> vk::AccelerationStructureKHR {
        self.tlas.raw
    }

    pub fn build(
        ctx: &Arc<GpuContext>,
        meshes: &[BlasInput<'_>],
        instances: &[TlasInstance],
    ) -> GpuResult<AccelStructures> {
        let Some(ext) = ctx.accel.as_ref() else {
            return Err(GpuError::Unsupported(
                "ray queries are not enabled on this device; use --rt software".into(),
            ));
        };
        let build_usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let mut as_props = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
        let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut as_props);
        // SAFETY: ray queries are enabled, so VK_KHR_acceleration_structure
        // exists and its properties struct may be chained.
        unsafe {
            ctx.instance
                .get_physical_device_properties2(ctx.physical, &mut p2)
        };
        let scratch_align = as_props
            .min_acceleration_structure_scratch_offset_alignment
            .max(1) as u64;

        let mut blases = Vec::with_capacity(meshes.len());
        let mut inputs = Vec::new();
        for (i, m) in meshes.iter().enumerate() {
            let pos = Buffer::with_data(
                ctx,
                &format!("blas{i}.positions"),
                bytemuck::cast_slice(m.positions),
                build_usage,
            )?;
            let idx = Buffer::with_data(
                ctx,
                &format!("blas{i}.indices"),
                bytemuck::cast_slice(m.indices),
                build_usage,
            )?;
            inputs.push((pos, idx));
        }
        // Build every BLAS in one submission.
        let mut scratch_buffers = Vec::new();
        let mut builds: Vec<(
            vk::AccelerationStructureGeometryKHR,
            u32,
            vk::AccelerationStructureKHR,
            u64,
        )> = Vec::new();
        for (i, (m, (pos, idx))) in meshes.iter().zip(&inputs).enumerate() {
            let tris = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
                .vertex_format(vk::Format::R32G32B32_SFLOAT)
                .vertex_data(vk::DeviceOrHostAddressConstKHR {
                    device_address: pos.device_address(),
                })
                .vertex_stride(12)
                .max_vertex(m.positions.len().saturating_sub(1) as u32)
                .index_type(vk::IndexType::UINT32)
                .index_data(vk::DeviceOrHostAddressConstKHR {
                    device_address: idx.device_address(),
                });
            let geometry = vk::AccelerationStructureGeometryKHR::default()
                .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
                .geometry(vk::AccelerationStructureGeometryDataKHR { triangles: tris })
                .flags(if m.opaque {
                    vk::GeometryFlagsKHR::OPAQUE
                } else {
                    vk::GeometryFlagsKHR::NO_DUPLICATE_ANY_HIT_INVOCATION
                });
            let prim_count = (m.indices.len() / 3) as u32;
            let (accel, scratch_addr, scratch) = Self::create(
                ctx,
                ext,
                &format!("blas{i}"),
                vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                &geometry,
                prim_count,
                scratch_align,
            )?;
            scratch_buffers.push(scratch);
            builds.push((geometry, prim_count, accel.raw, scratch_addr));
            blases.push(accel);
        }
        ctx.submit_once("BLAS build", |cb| {
            for (geometry, prim_count, dst, scratch) in &builds {
                let geoms = [*geometry];
                let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                    .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
                    .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
                    .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
                    .dst_acceleration_structure(*dst)
                    .geometries(&geoms)
                    .scratch_data(vk::DeviceOrHostAddressKHR {
                        device_address: *scratch,
                    });
                let range = [vk::AccelerationStructureBuildRangeInfoKHR::default()
                    .primitive_count(*prim_count)];
                // SAFETY: `cb` is recording; the vertex/index buffers, the
                // destination and the scratch (sized by
                // vkGetAccelerationStructureBuildSizesKHR, aligned) live
                // until submit_once has waited.
                unsafe { ext.cmd_build_acceleration_structures(cb, &[info], &[&range]) };
            }
        })?;
        drop(scratch_buffers);

        // Instances and the TLAS.
        let inst_buf = Self::instance_buffer(ctx, ext, &blases, instances)?;
        let geometry = Self::tlas_geometry(&inst_buf);
        let count = instances.len() as u32;
        let (tlas, scratch_addr, scratch) = Self::create(
            ctx,
            ext,
            "tlas",
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            &geometry,
            count,
            scratch_align,
        )?;
        Self::record_tlas_build(ctx, ext, &geometry, count, tlas.raw, scratch_addr)?;
        drop(scratch);
        drop(inst_buf);
        drop(inputs);
        Ok(AccelStructures {
            ctx: ctx.clone(),
            blases,
            tlas,
            tlas_count: count,
            scratch_align,
        })
    }

    /// Rebuilds the TLAS in place for moved instances (same count and BLAS
    /// references; the BLAS are untouched). The TLAS handle stays the same,
    /// so descriptor sets that bind it stay valid. Call between frames: it
    /// submits and waits.
    pub fn rebuild_tlas(&mut self, instances: &[TlasInstance]) -> GpuResult<()> {
        let ctx = self.ctx.clone();
        let Some(ext) = ctx.accel.as_ref() else {
            return Err(GpuError::Unsupported(
                "ray queries are not enabled on this device".into(),
            ));
        };
        if instances.len() as u32 != self.tlas_count {
            return Err(GpuError::Unsupported(format!(
                "TLAS rebuild with {} instances; it was built for {}",
                instances.len(),
                self.tlas_count
            )));
        }
        let inst_buf = Self::instance_buffer(&ctx, ext, &self.blases, instances)?;
        let geometry = Self::tlas_geometry(&inst_buf);
        let sizes = Self::build_sizes(
            ext,
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            &geometry,
            self.tlas_count,
        );
        let scratch = Buffer::new(
            &ctx,
            "tlas.rebuild.scratch",
            sizes.build_scratch_size + self.scratch_align,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        )?;
        let addr = scratch.device_address().div_ceil(self.scratch_align) * self.scratch_align;
        Self::record_tlas_build(&ctx, ext, &geometry, self.tlas_count, self.tlas.raw, addr)?;
        drop(scratch);
        drop(inst_buf);
        Ok(())
    }

    /// The instance records of `instances` in a build-input buffer.
    fn instance_buffer(
        ctx: &Arc<GpuContext>,
        ext: &ash::khr::acceleration_structure::Device,
        blases: &[Accel],
        instances: &[TlasInstance],
    ) -> GpuResult<Buffer> {
        let raw_instances: Vec<vk::AccelerationStructureInstanceKHR> = instances
            .iter()
            .map(|inst| {
                let addr_info = vk::AccelerationStructureDeviceAddressInfoKHR::default()
                    .acceleration_structure(blases[inst.blas].raw);
                // SAFETY: the BLAS was created on this device and is live.
                let addr = unsafe { ext.get_acceleration_structure_device_address(&addr_info) };
                let t = inst.transform;
                vk::AccelerationStructureInstanceKHR {
                    transform: vk::TransformMatrixKHR {
                        matrix: [
                            t[0][0], t[0][1], t[0][2], t[0][3], t[1][0], t[1][1], t[1][2], t[1][3],
                            t[2][0], t[2][1], t[2][2], t[2][3],
                        ],
                    },
                    instance_custom_index_and_mask: vk::Packed24_8::new(inst.custom_index, 0xff),
                    instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
                        0,
                        facing_flags(inst).as_raw() as u8,
                    ),
                    acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
                        device_handle: addr,
                    },
                }
            })
            .collect();
        // SAFETY: AccelerationStructureInstanceKHR is #[repr(C)] of
        // 12 f32, two u32 and a u64 (the union's device_handle, which is
        // set): 64 bytes, no padding, all initialised; the slice borrows
        // `raw_instances` for its size exactly.
        let inst_bytes: &[u8] = unsafe {
            std::slice::from_raw_parts(
                raw_instances.as_ptr() as *const u8,
                std::mem::size_of_val(raw_instances.as_slice()),
            )
        };
        Buffer::with_data(
            ctx,
            "tlas.instances",
            inst_bytes,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
        )
    }

    /// The TLAS's one geometry: the instance records in `inst_buf`.
    fn tlas_geometry(inst_buf: &Buffer) -> vk::AccelerationStructureGeometryKHR<'static> {
        let inst_data = vk::AccelerationStructureGeometryInstancesDataKHR::default()
            .array_of_pointers(false)
            .data(vk::DeviceOrHostAddressConstKHR {
                device_address: inst_buf.device_address(),
            });
        vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::INSTANCES)
            .geometry(vk::AccelerationStructureGeometryDataKHR {
                instances: inst_data,
            })
    }

    /// Builds the TLAS `dst` from `geometry` in one submission and waits.
    fn record_tlas_build(
        ctx: &Arc<GpuContext>,
        ext: &ash::khr::acceleration_structure::Device,
        geometry: &vk::AccelerationStructureGeometryKHR,
        count: u32,
        dst: vk::AccelerationStructureKHR,
        scratch_addr: u64,
    ) -> GpuResult<()> {
        ctx.submit_once("TLAS build", |cb| {
            let geoms = [*geometry];
            let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                .ty(vk::AccelerationStructureTypeKHR::TOP_LEVEL)
                .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
                .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
                .dst_acceleration_structure(dst)
                .geometries(&geoms)
                .scratch_data(vk::DeviceOrHostAddressKHR {
                    device_address: scratch_addr,
                });
            let range =
                [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count)];
            // SAFETY: `cb` is recording after the BLAS build completed (its
            // own submission); the instance buffer behind `geometry`, the
            // TLAS (sized for `count` instances) and the scratch live until
            // submit_once has waited.
            unsafe { ext.cmd_build_acceleration_structures(cb, &[info], &[&range]) };
        })
    }

    /// Sizes the driver asks for to build `geometry` with `prim_count` primitives.
    fn build_sizes(
        ext: &ash::khr::acceleration_structure::Device,
        ty: vk::AccelerationStructureTypeKHR,
        geometry: &vk::AccelerationStructureGeometryKHR,
        prim_count: u32,
    ) -> vk::AccelerationStructureBuildSizesInfoKHR<'static> {
        let geoms = [*geometry];
        let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(ty)
            .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&geoms);
        let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
        // SAFETY: `info` describes `geoms` with `prim_count` primitives
        // (one geometry, one count); a query without side effects.
        unsafe {
            ext.get_acceleration_structure_build_sizes(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &info,
                &[prim_count],
                &mut sizes,
            )
        };
        sizes
    }

    /// Creates an acceleration structure sized for `geometry` and a scratch buffer;
    /// returns the structure, the aligned scratch address and the scratch buffer.
    fn create(
        ctx: &Arc<GpuContext>,
        ext: &ash::khr::acceleration_structure::Device,
        name: &str,
        ty: vk::AccelerationStructureTypeKHR,
        geometry: &vk::AccelerationStructureGeometryKHR,
        prim_count: u32,
        scratch_align: u64,
    ) -> GpuResult<(Accel, u64, Buffer)> {
        let sizes = Self::build_sizes(ext, ty, geometry, prim_count);
        let buffer = Buffer::new(
            ctx,
            &format!("{name}.storage"),
            sizes.acceleration_structure_size,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        )?;
        let create = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(buffer.raw)
            .size(sizes.acceleration_structure_size)
            .ty(ty);
        // SAFETY: `buffer` has ACCELERATION_STRUCTURE_STORAGE usage, bound
        // memory and the size the driver asked for; it is kept in the Accel.
        let raw = unsafe { ext.create_acceleration_structure(&create, None) }
            .map_err(vk_err("vkCreateAccelerationStructureKHR"))?;
        ctx.set_name(raw, name);
        let scratch = Buffer::new(
            ctx,
            &format!("{name}.scratch"),
            sizes.build_scratch_size + scratch_align,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        )?;
        let addr = scratch.device_address().div_ceil(scratch_align) * scratch_align;
        Ok((
            Accel {
                raw,
                _buffer: buffer,
            },
            addr,
            scratch,
        ))
    }
}

impl Drop for AccelStructures {
    fn drop(&mut self) {
        if self.ctx.is_abandoned() {
            return;
        }
        if let Some(ext) = self.ctx.accel.as_ref() {
            // SAFETY: the session holding these structures is dropping, so
            // no pending work traces against them (an abandoned context
            // returned above); the storage buffers are dropped after.
            unsafe {
                ext.destroy_acceleration_structure(self.tlas.raw, None);
                for b in &self.blases {
                    ext.destroy_acceleration_structure(b.raw, None);
                }
            }
        }
    }
}
