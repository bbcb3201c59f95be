// SPDX-License-Identifier: MIT
#include "somm/bird.h"

namespace somm {

uint32_t cellToIndexDescent(uint32_t iu, uint32_t iv, bool upper, uint32_t level) noexcept {
  // The paper's descent. The current triangle has side `half * 2` in grid units; (iu, iv) is the cell relative to the
  // current triangle's own vertex frame (v0 at the origin, v1 along u, v2 along v), `up` its orientation in that frame.
  uint32_t up = upper ? 1u : 0u;
  uint32_t index = 0;
  for (uint32_t l = level; l-- > 0;) {
    const uint32_t half = 1u << l;
    uint32_t digit;
    if (iu >= half) {  // right child (near v1): a translation
      digit = 2;
      iu -= half;
    } else if (iv >= half) {  // top child (near v2), mirrored: its v0 = m12, v1 = m02, so left and right swap
      digit = 3;
      iu = 2 * half - 1 - iu - iv - up;
      iv -= half;
    } else if (iu + iv + up >= half) {  // middle child, inverted: v0 = m02, v1 = m12, v2 = m01
      digit = 1;
      const uint32_t nu = iu + iv + up - half;
      iv = half - 1 - iv;
      iu = nu;
      up ^= 1u;
    } else {  // left child (near v0)
      digit = 0;
    }
    index = (index << 2) | digit;
  }
  return index;
}

uint32_t baryToIndexDescent(float u, float v, uint32_t level) noexcept {
  // Quantise exactly as the reference does, then descend on integers.
  u = u > 0.0f ? u : 0.0f;
  v = v > 0.0f ? v : 0.0f;
  u = u < 1.0f ? u : 1.0f;
  v = v < 1.0f ? v : 1.0f;
  const uint32_t n = 1u << level;
  const float fu = u * float(n);
  const float fv = v * float(n);
  uint32_t iu = uint32_t(fu);
  uint32_t iv = uint32_t(fv);
  const float uf = fu - float(iu);
  const float vf = fv - float(iv);
  if (iu >= n) iu = n - 1;
  if (iv >= n) iv = n - 1;
  const uint32_t iuv = iu + iv;
  if (iuv >= n) iu = n - 1 - iv;
  const bool upper = uf + vf >= 1.0f && iuv < n - 1;
  return cellToIndexDescent(iu, iv, upper, level);
}

namespace {

// 32-bit-lane form of the index computation for the vectoriser (no 64-bit lanes, no branches).
inline uint32_t spread16(uint32_t x) noexcept {
  x = (x | (x << 8)) & 0x00ff00ffu;
  x = (x | (x << 4)) & 0x0f0f0f0fu;
  x = (x | (x << 2)) & 0x33333333u;
  x = (x | (x << 1)) & 0x55555555u;
  return x;
}

// The kernel body, inlined into one function per instruction set. Written branch-free in 32-bit lanes so that GCC
// vectorises it (float→int32 conversion is exact here because the values lie in [0, 4096]).
__attribute__((always_inline)) inline void batchKernel(const float* __restrict u, const float* __restrict v,
                                                       size_t count, uint32_t level,
                                                       uint32_t* __restrict out) noexcept {
  const uint32_t n = 1u << level;
  const float fn = float(n);
  const uint32_t mask = n - 1u;
  for (size_t i = 0; i < count; ++i) {
    float a = u[i], b = v[i];
    a = a > 0.0f ? a : 0.0f;
    b = b > 0.0f ? b : 0.0f;
    a = a < 1.0f ? a : 1.0f;
    b = b < 1.0f ? b : 1.0f;
    const float fu = a * fn;
    const float fv = b * fn;
    const int32_t su = int32_t(fu);
    const int32_t sv = int32_t(fv);
    const float uf = fu - float(su);
    const float vf = fv - float(sv);
    // Integer part as arithmetic instead of selects (the vectoriser's if-conversion is fragile):
    // su, sv are in [0, n]; su >> level is 1 exactly when su == n.
    uint32_t iu = uint32_t(su) - (uint32_t(su) >> level);
    const uint32_t iv = uint32_t(sv) - (uint32_t(sv) >> level);
    const uint32_t iuv = iu + iv;                  // < 2n
    const uint32_t outside = 0u - (iuv >> level);  // all ones when iuv >= n
    iu -= (iuv - mask) & outside;
    const uint32_t belowDiagonal = uint32_t(int32_t(iuv - mask) >> 31) & 1u;  // iuv < n - 1
    const uint32_t upper = (uf + vf >= 1.0f ? 1u : 0u) & belowDiagonal;
    const uint32_t iw = ~(iu + iv + upper);
    const uint32_t b0 = ~(iu ^ iw) & mask;
    const uint32_t t = (iu ^ iv) & b0;
    uint32_t f = t;
    f ^= f >> 1;
    f ^= f >> 2;
    f ^= f >> 4;
    f ^= f >> 8;
    const uint32_t b1 = ((f ^ iu) & ~b0) | t;
    out[i] = spread16(b0) | (spread16(b1) << 1);
  }
}

void batchBaseline(const float* u, const float* v, size_t count, uint32_t level, uint32_t* out) noexcept {
  batchKernel(u, v, count, level, out);  // SSE2 on x86-64
}

void batchScalar(const float* u, const float* v, size_t count, uint32_t level, uint32_t* out) noexcept {
  for (size_t i = 0; i < count; ++i) out[i] = baryToIndex(u[i], v[i], level);
}

#if defined(__x86_64__) && defined(__GNUC__)
#define SOMM_HAVE_X86_CLONES 1
__attribute__((target("avx2,bmi,bmi2,popcnt"))) void batchAvx2(const float* u, const float* v, size_t count,
                                                               uint32_t level, uint32_t* out) noexcept {
  batchKernel(u, v, count, level, out);
}
__attribute__((target("avx512f,avx512vl,avx512bw,avx512dq,avx2,bmi,bmi2,popcnt"))) void batchAvx512(
    const float* u, const float* v, size_t count, uint32_t level, uint32_t* out) noexcept {
  batchKernel(u, v, count, level, out);
}
#endif

BatchIsa detectIsa() noexcept {
#ifdef SOMM_HAVE_X86_CLONES
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
      __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq"))
    return BatchIsa::Avx512;
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi2")) return BatchIsa::Avx2;
#endif
  return BatchIsa::Sse2;
}

}  // namespace

bool batchIsaSupported(BatchIsa isa) noexcept {
  static const BatchIsa best = detectIsa();
  return uint32_t(isa) <= uint32_t(best);
}

void baryToIndexBatch(BatchIsa isa, const float* u, const float* v, size_t count, uint32_t level,
                      uint32_t* out) noexcept {
  switch (isa) {
#ifdef SOMM_HAVE_X86_CLONES
    case BatchIsa::Avx512:
      batchAvx512(u, v, count, level, out);
      return;
    case BatchIsa::Avx2:
      batchAvx2(u, v, count, level, out);
      return;
#endif
    case BatchIsa::Sse2:
      batchBaseline(u, v, count, level, out);
      return;
    default:
      batchScalar(u, v, count, level, out);
      return;
  }
}

void baryToIndexBatch(const float* u, const float* v, size_t count, uint32_t level, uint32_t* out) noexcept {
  static const BatchIsa best = detectIsa();
  baryToIndexBatch(best, u, v, count, level, out);
}

const char* batchIsaName(BatchIsa isa) noexcept {
  switch (isa) {
    case BatchIsa::Scalar:
      return "scalar";
    case BatchIsa::Sse2:
      return "sse2";
    case BatchIsa::Avx2:
      return "avx2";
    case BatchIsa::Avx512:
      return "avx512";
  }
  return "?";
}

const char* baryToIndexBatchIsa() noexcept {
  return batchIsaName(detectIsa());
}

}  // namespace somm
