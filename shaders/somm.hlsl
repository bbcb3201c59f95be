// SPDX-License-Identifier: MIT
// somm — software opacity micromap lookups for HLSL (DXR, or Vulkan through glslang / DXC), bit-identical to
// include/somm/bird.h and include/somm/encode.h. Layouts and binding example: docs/shaders.md.
//
// The same functions, names and results as shaders/somm.glsl: both include somm_lookup.inc (keep it next to
// this file). Include this file after defining how to read 32-bit word i (little endian, byte address 4·i) of
// the buffer that holds the serialized EncodedArray bytes, e.g.
//   ByteAddressBuffer sommBuffer : register(t0);          // Vulkan: [[vk::binding(0, 0)]]
//   #define SOMM_WORD(i) sommBuffer.Load((i) * 4u)
//   #include "somm.hlsl"
// Only Shader Model 5 integer operations: 32-bit integers, asuint, countbits. No 64-bit or 16-bit types.
#ifndef SOMM_HLSL
#define SOMM_HLSL

#ifndef SOMM_WORD
#error "define SOMM_WORD(i) (read 32-bit word i of the micromap buffer) before including somm.hlsl"
#endif

#define SOMM_CONST static const
#define SOMM_FLOAT_BITS(x) asuint(x)
#define SOMM_POPCOUNT(x) uint(countbits(x))
#include "somm_lookup.inc"

#endif  // SOMM_HLSL
