// Scene features as specialization constants (ids from src/interface/scene.rs):
// a pipeline compiles only the code the scene needs (DESIGN.md, "Shaders").
#ifndef FEATURES_GLSL
#define FEATURES_GLSL
#include "interface/scene.glsl"
layout(constant_id = SPEC_SC_TEXTURES) const bool SC_TEXTURES = true;
layout(constant_id = SPEC_SC_NORMAL_MAPS) const bool SC_NORMAL_MAPS = true;
layout(constant_id = SPEC_SC_ALPHA_MASK) const bool SC_ALPHA_MASK = true;
layout(constant_id = SPEC_SC_TRANSMISSION) const bool SC_TRANSMISSION = true;
layout(constant_id = SPEC_SC_EMISSIVE) const bool SC_EMISSIVE = true;
layout(constant_id = SPEC_SC_PUNCTUAL) const bool SC_PUNCTUAL = true;
layout(constant_id = SPEC_SC_DIRECTIONAL) const bool SC_DIRECTIONAL = true;
// 0 none (black), 1 constant, 2 Preetham sky, 3 equirectangular map
layout(constant_id = SPEC_SC_ENV_KIND) const uint SC_ENV_KIND = 2;
// Maximum scattering events along a path (pbrt's maxdepth convention).
layout(constant_id = SPEC_SC_MAX_BOUNCES) const uint SC_MAX_BOUNCES = 3;
layout(constant_id = SPEC_SC_TEXTURE_COUNT) const uint SC_TEXTURE_COUNT = 1;
// false: every material is Lambertian (metallic 0, specular layer 0): the
// opaque BSDF's GGX lobe and Fresnel terms are compiled out (they evaluate
// to exactly 0 for such materials, and the random numbers are drawn alike).
layout(constant_id = SPEC_SC_VIEW_DEPENDENT) const bool SC_VIEW_DEPENDENT = true;
// How emissive triangles and the environment map are sampled (integrator.glsl;
// src/methods/specialize.rs `LightSampling`): 0 both strategies combined by
// MIS (the renderer), 1 next-event estimation only, 2 BSDF sampling only
// (the estimator without light sampling; tests and benchmarks).
layout(constant_id = SPEC_SC_LIGHT_STRATEGY) const uint SC_LIGHT_STRATEGY = 0;
const uint LIGHT_STRATEGY_MIS = 0u;
const uint LIGHT_STRATEGY_NEE = 1u;
const uint LIGHT_STRATEGY_BSDF = 2u;
// Software backend only: true = the two-level BVH (per-mesh BLAS + TLAS over
// instances, src/rt/two_level.rs), false = the flattened world-space BVH.
layout(constant_id = SPEC_SC_TWO_LEVEL) const bool SC_TWO_LEVEL = false;
// An instance moves (src/scene/features.rs `animated`): code that reads the
// previous frame's instance transforms (InstanceInfo.prev_object_to_world,
// motion vectors) is compiled in. Off for a static scene, which then renders
// exactly as without animation support.
layout(constant_id = SPEC_SC_ANIMATED) const bool SC_ANIMATED = false;
// A mesh has vertex colours (glTF COLOR_0, src/scene/features.rs
// `vertex_colors`): they multiply the base colour and its alpha.
layout(constant_id = SPEC_SC_VERTEX_COLORS) const bool SC_VERTEX_COLORS = true;
// A material has a clearcoat (KHR_materials_clearcoat, src/scene/features.rs
// `clearcoat`): the coat lobe of the opaque BSDF and the coat reflection
// over transmission are compiled in.
layout(constant_id = SPEC_SC_CLEARCOAT) const bool SC_CLEARCOAT = true;
// A mesh has a single-sided material (src/scene/features.rs
// `backface_culling`): the traversals pass through its back faces.
layout(constant_id = SPEC_SC_BACKFACE_CULLING) const bool SC_BACKFACE_CULLING = true;
// A mesh has a second uv channel (src/scene/features.rs `second_uv`): the
// texture slots in MaterialGpu.tex3.y read it (material.glsl `slot_uv`).
layout(constant_id = SPEC_SC_SECOND_UV) const bool SC_SECOND_UV = true;
// A material's texture slot reads its uv channel through a map
// (src/scene/features.rs `uv_affine`: a third KHR_texture_transform of a
// channel's uv set): the slots in MaterialGpu.tex3.z apply uv_affine.
layout(constant_id = SPEC_SC_UV_AFFINE) const bool SC_UV_AFFINE = true;
#endif
