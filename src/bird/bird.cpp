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

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__SANITIZE_ADDRESS__)
#define SOMM_TARGET_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define SOMM_TARGET_CLONES
#endif

SOMM_TARGET_CLONES
void batchKernel(const float* __restrict u, const float* __restrict v, size_t count, uint32_t level,
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
    uint32_t iu = uint32_t(su), iv = uint32_t(sv);
    iu = iu < mask ? iu : mask;
    iv = iv < mask ? iv : mask;
    const uint32_t iuv = iu + iv;
    iu = iuv >= n ? mask - iv : iu;
    const uint32_t upper = (uf + vf >= 1.0f) & (iuv < mask);
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

}  // namespace

void baryToIndexBatch(const float* u, const float* v, size_t count, uint32_t level, uint32_t* out) noexcept {
  batchKernel(u, v, count, level, out);
}

const char* baryToIndexBatchIsa() noexcept {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__SANITIZE_ADDRESS__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("x86-64-v4")) return "avx512";
  if (__builtin_cpu_supports("x86-64-v3")) return "avx2";
#endif
  return "scalar";
}

}  // namespace somm
