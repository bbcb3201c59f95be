// SPDX-License-Identifier: MIT
// somm — the bird curve: barycentrics → micro-triangle index and back.
//
// (u, v) are the barycentric weights of triangle vertices 1 and 2. Level L in 0..12 splits the triangle into 4^L
// micro-triangles ordered along the space-filling "bird" curve of VK_EXT_opacity_micromap / DXR 1.2. Base-4 digits of an
// index, most significant first, name the child taken at each level: 0 near vertex 0, 1 the middle (inverted) child,
// 2 near vertex 1, 3 near vertex 2 (mirrored).
#pragma once

#include <cstddef>
#include <cstdint>

// The index is the lookup's first step on every hot path (filters, shaders' CPU twins): forced inline, so that
// a caller's template (e.g. a lookup that learns the level from a memo) never pays a call for it.
#if defined(__GNUC__) || defined(__clang__)
#define SOMM_BIRD_INLINE __attribute__((always_inline)) inline
#elif defined(_MSC_VER)
#define SOMM_BIRD_INLINE __forceinline
#else
#define SOMM_BIRD_INLINE inline
#endif

namespace somm {

inline constexpr uint32_t kMaxLevel = 12;

constexpr uint32_t microTriangleCount(uint32_t level) noexcept {
  return 1u << (2u * level);
}

namespace detail {

// Spread the low 16 bits of two words so that bit k lands on bit 2k, both halves at once in one 64-bit word.
SOMM_BIRD_INLINE uint32_t interleave2(uint32_t even, uint32_t odd) noexcept {
  uint64_t x = uint64_t(even) | (uint64_t(odd) << 32);
  x = (x | (x << 8)) & 0x00ff00ff00ff00ffull;
  x = (x | (x << 4)) & 0x0f0f0f0f0f0f0f0full;
  x = (x | (x << 2)) & 0x3333333333333333ull;
  x = (x | (x << 1)) & 0x5555555555555555ull;
  return uint32_t(x) | uint32_t(x >> 31);
}

// Index of the micro-triangle in integer grid cell (iu, iv) of level `level`; `upper` (0 or 1) selects the inverted
// triangle of the cell, the one whose vertices sum to iu + iv + 2. Requires iu + iv + upper < 2^level.
SOMM_BIRD_INLINE uint32_t cellToIndex(uint32_t iu, uint32_t iv, uint32_t upper, uint32_t level) noexcept {
  const uint32_t iw = ~(iu + iv + upper);
  const uint32_t b0 = ~(iu ^ iw) & ((1u << level) - 1u);
  const uint32_t t = (iu ^ iv) & b0;
  uint32_t f = t;  // prefix xor from the top: bit k of f = xor of the bits of t at k and above
  f ^= f >> 1;
  f ^= f >> 2;
  f ^= f >> 4;
  f ^= f >> 8;
  const uint32_t b1 = ((f ^ iu) & ~b0) | t;
  return interleave2(b0, b1);
}

}  // namespace detail

// Barycentrics → bird-curve index. Bit-identical to the Vulkan reference BarycentricsToSpaceFillingCurveIndex for every
// float input. u and v are clamped to [0, 1] first; NaN clamps to 0 (IEEE maxNum/minNum, as GPU min/max do). A point on
// a shared edge or vertex goes where the reference's quantisation sends it: cell (floor(u·2^L), floor(v·2^L)) reduced
// into the triangle, and the upper triangle of the cell when the float sum frac(u·2^L) + frac(v·2^L) >= 1.
SOMM_BIRD_INLINE uint32_t baryToIndex(float u, float v, uint32_t level) noexcept {
  u = u > 0.0f ? u : 0.0f;  // NaN → 0
  v = v > 0.0f ? v : 0.0f;
  u = u < 1.0f ? u : 1.0f;
  v = v < 1.0f ? v : 1.0f;
  const uint32_t n = 1u << level;
  const float fu = u * float(n);  // exact: a power-of-two scale of a value in [0, 1]
  const float fv = v * float(n);
  uint32_t iu = uint32_t(int32_t(fu));  // fu in [0, 4096]: the signed conversion is exact and vectorises
  uint32_t iv = uint32_t(int32_t(fv));
  const float uf = fu - float(iu);  // exact
  const float vf = fv - float(iv);
  iu = iu < n - 1u ? iu : n - 1u;
  iv = iv < n - 1u ? iv : n - 1u;
  const uint32_t iuv = iu + iv;
  // Outside the triangle (iuv >= n): the reference moves iu back so that iu + iv = n - 1, lower triangle.
  iu = iuv >= n ? n - 1u - iv : iu;
  // Upper triangle of the cell when the fractions' float sum reaches 1 and the cell is not on the diagonal edge.
  const uint32_t upper = (uf + vf >= 1.0f) & (iuv < n - 1u);
  return detail::cellToIndex(iu, iv, upper, level);
}

// The paper's uv2index (Waldemarson & Doggett 2024): descend the subdivision choosing the left / middle / right / top
// child per level. Quantised with the reference's rule first, then recursed on integers so that it equals baryToIndex
// everywhere (a float descent drifts on ordinary inputs).
uint32_t baryToIndexDescent(float u, float v, uint32_t level) noexcept;

// The integer descent on its own: cell (iu, iv) of level `level`, `upper` = inverted triangle of the cell.
uint32_t cellToIndexDescent(uint32_t iu, uint32_t iv, bool upper, uint32_t level) noexcept;

// Batch form: out[i] = baryToIndex(u[i], v[i], level). Vectorised for the best instruction set of this CPU (AVX-512,
// AVX2, else baseline SSE2), chosen once at run time; identical results on every path.
void baryToIndexBatch(const float* u, const float* v, size_t count, uint32_t level, uint32_t* out) noexcept;

// Instruction-set variants of the batch form, for tests and benchmarks. Scalar is the one-at-a-time loop.
enum class BatchIsa : uint8_t { Scalar = 0, Sse2 = 1, Avx2 = 2, Avx512 = 3 };
bool batchIsaSupported(BatchIsa isa) noexcept;
void baryToIndexBatch(BatchIsa isa, const float* u, const float* v, size_t count, uint32_t level,
                      uint32_t* out) noexcept;
const char* batchIsaName(BatchIsa isa) noexcept;
// Name of the variant baryToIndexBatch dispatches to on this CPU: "avx512", "avx2" or "sse2".
const char* baryToIndexBatchIsa() noexcept;

// Integer barycentric grid point (u, v) in units of 2^-level.
struct GridPoint {
  uint32_t u = 0, v = 0;
  friend bool operator==(const GridPoint& a, const GridPoint& b) noexcept { return a.u == b.u && a.v == b.v; }
  friend bool operator!=(const GridPoint& a, const GridPoint& b) noexcept { return !(a == b); }
};

// The three vertices of a micro-triangle in the curve's winding.
struct MicroTriangle {
  GridPoint v[3];
  friend bool operator==(const MicroTriangle& a, const MicroTriangle& b) noexcept {
    return a.v[0] == b.v[0] && a.v[1] == b.v[1] && a.v[2] == b.v[2];
  }
  friend bool operator!=(const MicroTriangle& a, const MicroTriangle& b) noexcept { return !(a == b); }
};

struct MicroTriangleF {
  float u[3], v[3];
};

// Micro-triangle `index` (< 4^level) of level `level`: applied recursively from the base triangle (v0, v1, v2) with
// child 0 = (v0, m01, m02), 1 = (m02, m12, m01), 2 = (m01, v1, m12), 3 = (m12, m02, v2).
inline MicroTriangle indexToMicroTriangle(uint32_t index, uint32_t level) noexcept {
  // Work at the finest scale: vertices in units of 2^-level, base triangle (0,0), (n,0), (0,n).
  const uint32_t n = 1u << level;
  GridPoint a{0, 0}, b{n, 0}, c{0, n};
  for (uint32_t l = level; l-- > 0;) {
    const uint32_t digit = (index >> (2 * l)) & 3u;
    const GridPoint ab{(a.u + b.u) >> 1, (a.v + b.v) >> 1};
    const GridPoint ac{(a.u + c.u) >> 1, (a.v + c.v) >> 1};
    const GridPoint bc{(b.u + c.u) >> 1, (b.v + c.v) >> 1};
    switch (digit) {
      case 0:
        b = ab;
        c = ac;
        break;
      case 1:
        a = ac;
        b = bc;
        c = ab;
        break;
      case 2:
        a = ab;
        c = bc;
        break;
      default:
        a = bc;
        b = ac;
        break;  // c stays
    }
  }
  return MicroTriangle{{a, b, c}};
}

inline MicroTriangleF indexToMicroTriangleF(uint32_t index, uint32_t level) noexcept {
  const MicroTriangle t = indexToMicroTriangle(index, level);
  const float s = 1.0f / float(1u << level);
  MicroTriangleF r{};
  for (int i = 0; i < 3; ++i) {
    r.u[i] = float(t.v[i].u) * s;
    r.v[i] = float(t.v[i].v) * s;
  }
  return r;
}

}  // namespace somm
