//! A compute-shader harness that evaluates graphs on the GPU at a list of
//! surface points (the generated GLSL, compiled at run time like a scene's
//! graphs): the test of the code generator and node library against the CPU
//! evaluator (tests/material_graphs.rs).

use super::codegen::{self, Layout};
use super::compile::{self, Compiled};
use super::eval::Geom;
use super::graph::Graph;
use crate::gpu::{Buffer, ComputePipeline, GpuContext, Recorder};
use crate::interface::{read, write, Interface, PushBlock, PushType};
use std::sync::Arc;

/// Push constants of the harness kernel.
pub const PUSH: PushBlock = PushBlock {
    name: "MATERIAL_HARNESS",
    fields: &[("count", PushType::U32), ("stride", PushType::U32)],
};

/// The harness kernel's interface: POINT_FLOATS floats per point in, `stride` floats per point out.
pub const INTERFACE: Interface = Interface {
    name: "material_harness",
    set: 0,
    bindings: &[read("points"), write("outs")],
    push: &[PUSH],
    counters: &[],
    spec: &[],
};

/// Floats per input point: uv (2), position (3), normal (3), tangent (3),
/// tangent sign (1), then the object frame's position, normal, tangent (3
/// each) and tangent sign (1), then uv set 1 (2) and ∂uv1/∂uv (4, by
/// columns).
pub const POINT_FLOATS: usize = 28;

/// The harness's GLSL for `graphs`, and each graph's layout and offset in a point's outputs.
pub fn source(graphs: &[Graph]) -> (String, Vec<(Layout, usize)>) {
    let mut s = String::from("#version 460\n");
    s.push_str(&crate::interface::glsl::header(&INTERFACE));
    s.push_str(&compile::library());
    let mut layouts = Vec::new();
    let mut off = 0;
    let mut calls = String::new();
    for (i, g) in graphs.iter().enumerate() {
        let sym = codegen::symbol(g, i);
        s.push_str(&codegen::glsl(g, &sym, &[]));
        let l = Layout::of(g);
        let n = l.floats.max(1);
        calls.push_str(&format!(
            "    {{ float o[{n}]; mxg_{sym}(g, o); for (uint k = 0u; k < {n}u; ++k) outs[i * pc.stride + {off}u + k] = o[k]; }}\n"
        ));
        layouts.push((l, off));
        off += n;
    }
    s.push_str(
        "layout(local_size_x = 64) in;\n\
         layout(set = SET_MATERIAL_HARNESS, binding = B_MATERIAL_HARNESS_POINTS, std430) readonly buffer Points { float pts[]; };\n\
         layout(set = SET_MATERIAL_HARNESS, binding = B_MATERIAL_HARNESS_OUTS, std430) writeonly buffer Outs { float outs[]; };\n\
         layout(push_constant) uniform Push { MATERIAL_HARNESS_PUSH } pc;\n\
         void main() {\n\
         \x20   uint i = gl_GlobalInvocationID.x;\n\
         \x20   if (i >= pc.count) return;\n",
    );
    s.push_str(&format!("    uint b = i * {POINT_FLOATS}u;\n"));
    s.push_str(
        "    MxGeom g;\n\
         \x20   g.uv = vec2(pts[b], pts[b + 1u]);\n\
         \x20   g.position = vec3(pts[b + 2u], pts[b + 3u], pts[b + 4u]);\n\
         \x20   g.normal = vec3(pts[b + 5u], pts[b + 6u], pts[b + 7u]);\n\
         \x20   g.tangent = vec3(pts[b + 8u], pts[b + 9u], pts[b + 10u]);\n\
         \x20   g.tangent_sign = pts[b + 11u];\n\
         \x20   g.footprint = 0.0;\n\
         \x20   g.position_object = vec3(pts[b + 12u], pts[b + 13u], pts[b + 14u]);\n\
         \x20   g.normal_object = vec3(pts[b + 15u], pts[b + 16u], pts[b + 17u]);\n\
         \x20   g.tangent_object = vec3(pts[b + 18u], pts[b + 19u], pts[b + 20u]);\n\
         \x20   g.tangent_sign_object = pts[b + 21u];\n\
         \x20   g.uv1 = vec2(pts[b + 22u], pts[b + 23u]);\n\
         \x20   g.uv1_per_uv = mat2(pts[b + 24u], pts[b + 25u], pts[b + 26u], pts[b + 27u]);\n",
    );
    s.push_str(&calls);
    s.push_str("}\n");
    (s, layouts)
}

/// `values[graph][point]`: a graph's output floats at one point (Layout order).
pub type GraphValues = Vec<Vec<Vec<f32>>>;

/// GPU values of every graph at every point: `result[graph][point]` = the
/// graph's output floats (Layout order). Also returns the compile outcome.
pub fn evaluate(
    ctx: &Arc<GpuContext>,
    graphs: &[Graph],
    points: &[Geom],
) -> Result<(GraphValues, Compiled), String> {
    if let Some(g) = graphs.iter().find(|g| !g.images.is_empty()) {
        return Err(format!(
            "{}: graph `{}` has image nodes; the harness binds no textures (they are checked through rendering, tests/material_images.rs)",
            g.file, g.name
        ));
    }
    let (src, layouts) = source(graphs);
    let stride: usize = layouts.iter().map(|(l, _)| l.floats.max(1)).sum();
    let compiled = compile::compile("material graph harness", &src)?;
    let pipe = ComputePipeline::with_interface(
        ctx,
        "material_harness",
        &compiled.spirv,
        &[],
        &INTERFACE,
        Some(&PUSH),
        &Default::default(),
    )
    .map_err(|e| e.to_string())?;
    let mut flat = Vec::with_capacity(points.len() * POINT_FLOATS);
    for p in points {
        flat.extend_from_slice(&p.uv);
        flat.extend_from_slice(&p.position);
        flat.extend_from_slice(&p.normal);
        flat.extend_from_slice(&p.tangent);
        flat.push(p.tangent_sign);
        flat.extend_from_slice(&p.object.position);
        flat.extend_from_slice(&p.object.normal);
        flat.extend_from_slice(&p.object.tangent);
        flat.push(p.object.tangent_sign);
        flat.extend_from_slice(&p.uv1);
        flat.extend_from_slice(&p.uv1_per_uv[0]);
        flat.extend_from_slice(&p.uv1_per_uv[1]);
    }
    let n = points.len() as u32;
    let pts = Buffer::with_data(
        ctx,
        "harness.points",
        bytemuck::cast_slice(&flat),
        Default::default(),
    )
    .map_err(|e| e.to_string())?;
    let outs = Buffer::storage(
        ctx,
        "harness.outs",
        (points.len() * stride * 4).max(4) as u64,
    )
    .map_err(|e| e.to_string())?;
    let mut rec = Recorder::new(ctx, 1).map_err(|e| e.to_string())?;
    rec.compute("material_harness", &pipe)
        .read(&pts)
        .write(&outs)
        .push(&[n, stride as u32])
        .dispatch([n.div_ceil(64), 1, 1])
        .map_err(|e| e.to_string())?;
    rec.finish().map_err(|e| e.to_string())?;
    let got: Vec<f32> = outs.download_pod().map_err(|e| e.to_string())?;
    let result = layouts
        .iter()
        .map(|(l, off)| {
            (0..points.len())
                .map(|i| got[i * stride + off..i * stride + off + l.floats].to_vec())
                .collect()
        })
        .collect();
    Ok((result, compiled))
}
