// The one ray-tracing interface every method uses (DESIGN.md "Shaders"):
//   bool rt_closest_hit(vec3 o, vec3 d, float tmin, float tmax, out RtHit h)
//   bool rt_occluded(vec3 o, vec3 d, float tmin, float tmax)
// Compiled once with -DRT_QUERY (VK_KHR_ray_query against a TLAS) and once
// with -DRT_SOFTWARE (obvhs CWBVH traversed from storage buffers).
// Instance = index into `instances`, prim = triangle index within its mesh,
// bary = weights of the triangle's 2nd and 3rd vertices, t = ray parameter.
#ifndef RT_GLSL
#define RT_GLSL
#include "common/scene.glsl"

struct RtHit { float t; uint instance; uint prim; vec2 bary; };

#if defined(RT_QUERY)
#include "common/rt_query.glsl"
#elif defined(RT_SOFTWARE)
#include "common/rt_software.glsl"
#else
#error "define RT_QUERY or RT_SOFTWARE"
#endif
#endif
