// SPDX-License-Identifier: MIT
// somm gpu-check / gpu-bench kernel (HLSL, compiled for Vulkan by glslang's HLSL front end): the same bindings
// and results as check.comp.
[[vk::binding(0, 0)]] ByteAddressBuffer sommBuffer;
#define SOMM_WORD(i) sommBuffer.Load((i) * 4u)
#include "somm.hlsl"

[[vk::binding(1, 0)]] StructuredBuffer<uint4> queries;
[[vk::binding(2, 0)]] RWStructuredBuffer<uint> results;

struct Params {
  uint base;
  uint count;
  uint mode;
  uint stride;
};
[[vk::push_constant]] ConstantBuffer<Params> params;

[numthreads(64, 1, 1)] void main(uint3 gid : SV_DispatchThreadID) {
  uint id = gid.x + gid.y * params.stride;
  if (id >= params.count) return;
  uint4 q = queries[id];
  float u = asfloat(q.y);
  float v = asfloat(q.z);
  uint r;
  if (params.mode == 1u) {
    r = sommBaryToIndex(u, v, q.w);
  } else {
    // StateUV: the array at params.base + q.w (one dispatch covers several arrays); StateIndex: index q.w.
    // if / else, not ?: — HLSL would run both lookups (the old dfs mismatches; docs/shaders.md).
    if (params.mode == 0u) r = sommStateUV(sommArray(params.base + q.w), q.x, u, v);
    else r = sommState(sommArray(params.base), q.x, q.w);
  }
  results[id] = r;
}
