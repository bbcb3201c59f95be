// SPDX-License-Identifier: MIT
// somm — software opacity micromap lookups for GLSL 4.60 (Vulkan), bit-identical to include/somm/bird.h and
// include/somm/encode.h. Layouts and binding example: docs/shaders.md.
//
// Include this file after defining how to read 32-bit word i (little endian, byte address 4·i) of the storage
// buffer that holds the serialized EncodedArray bytes, e.g.
//   #extension GL_GOOGLE_include_directive : require
//   layout(std430, set = 0, binding = 0) readonly buffer SommArrays { uint sommWords[]; };
//   #define SOMM_WORD(i) sommWords[i]
//   #include "somm.glsl"
// Only core GLSL 4.60: 32-bit integers, floatBitsToUint, bitCount. No extension in the SPIR-V, no 64-bit or
// 8/16-bit types. The lookups themselves are in somm_lookup.inc (shared with somm.hlsl; keep it next to this file).
#ifndef SOMM_GLSL
#define SOMM_GLSL

#ifndef SOMM_WORD
#error "define SOMM_WORD(i) (read 32-bit word i of the micromap buffer) before including somm.glsl"
#endif

#define SOMM_CONST const
#define SOMM_FLOAT_BITS(x) floatBitsToUint(x)
#define SOMM_POPCOUNT(x) uint(bitCount(x))
#include "somm_lookup.inc"

#endif  // SOMM_GLSL
