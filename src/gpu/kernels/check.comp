// SPDX-License-Identifier: MIT
// somm gpu-check / gpu-bench kernel (GLSL): one lookup per invocation. Bindings: docs/shaders.md.
#version 460
#extension GL_GOOGLE_include_directive : require  // compile-time only (glslang): no SPIR-V extension
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer SommArrays { uint sommWords[]; };
#define SOMM_WORD(i) sommWords[i]
#include "somm.glsl"

// Per query: triangle, the bits of u and v, and w: the array's byte offset from params.base (stateUV), the level
// (bird index) or the micro-triangle index (state by index).
layout(std430, set = 0, binding = 1) readonly buffer Queries { uvec4 queries[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Results { uint results[]; };
layout(push_constant) uniform Params {
  uint base;    // byte address of the serialized EncodedArray
  uint count;   // queries
  uint mode;    // 0 stateUV, 1 bird index, 2 state by index
  uint stride;  // invocations per row of the 2-D dispatch
} params;

void main() {
  uint id = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * params.stride;
  if (id >= params.count) return;
  uvec4 q = queries[id];
  float u = uintBitsToFloat(q.y);
  float v = uintBitsToFloat(q.z);
  uint r;
  if (params.mode == 1u) {
    r = sommBaryToIndex(u, v, q.w);
  } else {
    // StateUV: the array at params.base + q.w (one dispatch covers several arrays); StateIndex: index q.w.
    if (params.mode == 0u) r = sommStateUV(sommArray(params.base + q.w), q.x, u, v);
    else r = sommState(sommArray(params.base), q.x, q.w);
  }
  results[id] = r;
}
