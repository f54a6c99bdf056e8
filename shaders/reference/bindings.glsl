// Descriptor set 1 of the reference path tracer (src/methods/reference.rs).
#include "common/camera.glsl"
layout(set = 1, binding = 1, std430) buffer Accum { vec4 accum[]; };          // rgb sum, sample count
layout(set = 1, binding = 2, std430) buffer FirstHits { uvec4 first_hit[]; }; // Listing 1 encoding
layout(set = 1, binding = 3, std430) buffer Depth { float depth[]; };         // view depth, 0 = no hit
layout(set = 1, binding = 4, std430) buffer Albedo { vec4 albedo[]; };
layout(set = 1, binding = 5, std430) buffer Counters { uint counters[]; };    // primary, bounce, shadow rays
