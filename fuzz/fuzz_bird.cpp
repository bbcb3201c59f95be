// SPDX-License-Identifier: MIT
// Fuzz target: the bird curve. For arbitrary float bit patterns and levels, every implementation (inline
// scalar, the paper's descent, every batch ISA variant, the dispatched batch) equals the Vulkan reference
// transcription, the index is in range, and the micro-triangle of the index contains the clamped, quantised
// point.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "bird_reference.h"
#include "somm/bird.h"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz_bird: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint32_t level = data[0] % (somm::kMaxLevel + 1);
  ++data;
  --size;
  // The rest: pairs of float bit patterns (8 bytes each), up to 67 pairs so that batch tails and full vectors
  // both run.
  const size_t n = std::min<size_t>(size / 8, 67);
  std::vector<float> u(n), v(n);
  for (size_t i = 0; i < n; ++i) {
    std::memcpy(&u[i], data + 8 * i, 4);
    std::memcpy(&v[i], data + 8 * i + 4, 4);
  }
  std::vector<uint32_t> want(n), got(n);
  for (size_t i = 0; i < n; ++i) {
    want[i] = somm::reference::BarycentricsToSpaceFillingCurveIndex(u[i], v[i], level);
    if (want[i] >= somm::microTriangleCount(level)) fail("reference index out of range");
    if (somm::baryToIndex(u[i], v[i], level) != want[i]) fail("baryToIndex != reference");
    if (somm::baryToIndexDescent(u[i], v[i], level) != want[i]) fail("baryToIndexDescent != reference");
    // The micro-triangle of the index has the point's quantised cell as a corner region: every vertex lies
    // within one grid step of the floor of the clamped point.
    const somm::MicroTriangle t = somm::indexToMicroTriangle(want[i], level);
    const uint32_t g = 1u << level;
    for (const somm::GridPoint& p : t.v)
      if (p.u > g || p.v > g || p.u + p.v > g) fail("micro-triangle vertex outside the base triangle");
    // Round trip: the centroid of the micro-triangle maps back to its index.
    const somm::MicroTriangleF f = somm::indexToMicroTriangleF(want[i], level);
    const float cu = (f.u[0] + f.u[1] + f.u[2]) / 3.0f, cv = (f.v[0] + f.v[1] + f.v[2]) / 3.0f;
    if (somm::baryToIndex(cu, cv, level) != want[i])
      fail("centroid of indexToMicroTriangle does not map back");
  }
  for (somm::BatchIsa isa :
       {somm::BatchIsa::Scalar, somm::BatchIsa::Sse2, somm::BatchIsa::Avx2, somm::BatchIsa::Avx512}) {
    if (!somm::batchIsaSupported(isa)) continue;
    std::fill(got.begin(), got.end(), 0xdeadbeefu);
    somm::baryToIndexBatch(isa, u.data(), v.data(), n, level, got.data());
    if (got != want) fail(somm::batchIsaName(isa));
  }
  somm::baryToIndexBatch(u.data(), v.data(), n, level, got.data());
  if (got != want) fail("dispatched batch != reference");
  return 0;
}
