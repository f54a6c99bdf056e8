// Descriptor set 1 of the reference path tracer: the per-pass buffers of
// src/interface/reference.rs (generated header), bound by the pass builder.
#include "interface/reference.glsl"
#include "common/camera.glsl"
layout(set = SET_REFERENCE, binding = B_REFERENCE_ACCUM, std430) buffer Accum { vec4 accum[]; };          // rgb sum, sample count
layout(set = SET_REFERENCE, binding = B_REFERENCE_FIRST_HIT, std430) buffer FirstHits { uvec4 first_hit[]; }; // Listing 1 encoding
layout(set = SET_REFERENCE, binding = B_REFERENCE_DEPTH, std430) buffer Depth { float depth[]; };         // view depth, 0 = no hit
layout(set = SET_REFERENCE, binding = B_REFERENCE_ALBEDO, std430) buffer Albedo { vec4 albedo[]; };
layout(set = SET_REFERENCE, binding = B_REFERENCE_COUNTERS, std430) buffer Counters { uint counters[]; };    // ReferenceCounter slots
