// SPDX-License-Identifier: MIT
// The Vulkan reference function, transcribed as the test oracle.
//
// Source: Vulkan specification, appendix for VK_EXT_opacity_micromap ("Reference Code"),
// BarycentricsToSpaceFillingCurveIndex. Copyright The Khronos Group Inc., CC-BY-4.0.
// The only addition is `clamp`, which the spec leaves undefined: min(max(x, lo), hi) with IEEE-754 minNum/maxNum
// semantics, under which any NaN (quiet or signalling) clamps to the lower bound, as GPU min/max instructions do. The float → uint32 casts are then always
// in range (the inputs are in [0, 2^level]), so the transcription has no undefined behaviour.
#pragma once

#include <cmath>
#include <cstdint>

namespace somm::reference {

inline float clamp(float x, float lo, float hi) {
  if (std::isnan(x)) return lo;  // glibc's fmax returns NaN for a signalling NaN; maxNum returns the number
  return std::fmin(std::fmax(x, lo), hi);
}

inline uint32_t BarycentricsToSpaceFillingCurveIndex(float u, float v, uint32_t level) {
  u = clamp(u, 0.0f, 1.0f);
  v = clamp(v, 0.0f, 1.0f);

  uint32_t iu, iv, iw;

  // Quantize barycentric coordinates
  float fu = u * (1u << level);
  float fv = v * (1u << level);

  iu = (uint32_t)fu;
  iv = (uint32_t)fv;

  float uf = fu - float(iu);
  float vf = fv - float(iv);

  if (iu >= (1u << level)) iu = (1u << level) - 1u;
  if (iv >= (1u << level)) iv = (1u << level) - 1u;

  uint32_t iuv = iu + iv;

  if (iuv >= (1u << level)) iu -= iuv - (1u << level) + 1u;

  iw = ~(iu + iv);

  if (uf + vf >= 1.0f && iuv < (1u << level) - 1u) --iw;

  uint32_t b0 = ~(iu ^ iw);
  b0 &= ((1u << level) - 1u);
  uint32_t t = (iu ^ iv) & b0;

  uint32_t f = t;
  f ^= f >> 1u;
  f ^= f >> 2u;
  f ^= f >> 4u;
  f ^= f >> 8u;
  uint32_t b1 = ((f ^ iu) & ~b0) | t;

  // Interleave bits
  b0 = (b0 | (b0 << 8u)) & 0x00ff00ffu;
  b0 = (b0 | (b0 << 4u)) & 0x0f0f0f0fu;
  b0 = (b0 | (b0 << 2u)) & 0x33333333u;
  b0 = (b0 | (b0 << 1u)) & 0x55555555u;
  b1 = (b1 | (b1 << 8u)) & 0x00ff00ffu;
  b1 = (b1 | (b1 << 4u)) & 0x0f0f0f0fu;
  b1 = (b1 | (b1 << 2u)) & 0x33333333u;
  b1 = (b1 | (b1 << 1u)) & 0x55555555u;

  return b0 | (b1 << 1u);
}

}  // namespace somm::reference
