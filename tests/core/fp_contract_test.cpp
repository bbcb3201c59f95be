// SPDX-License-Identifier: MIT
// The public inline baryToIndex does not need somm's -ffp-contract=off: compiled with contraction and FMA (as a
// consumer might), it equals the library's (unfused) scalar path on random, edge and near-edge inputs at every level.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "somm/bird.h"

uint32_t baryToIndexContracted(float u, float v, uint32_t level) noexcept;

TEST(FpContract, BaryToIndexIsIndependentOfContraction) {
#if defined(__x86_64__) || defined(__i386__)
  if (!__builtin_cpu_supports("fma")) GTEST_SKIP() << "this CPU has no FMA";
#endif
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> d(-0.1f, 1.1f);
  std::vector<float> us, vs;
  for (int i = 0; i < 20000; ++i) {
    us.push_back(d(rng));
    vs.push_back(d(rng));
  }
  for (uint32_t level = 0; level <= somm::kMaxLevel; ++level) {  // grid lines and their float neighbours
    const float n = float(1u << level);
    for (uint32_t k = 0; k <= (1u << std::min(level, 6u)); ++k)
      for (float x : {float(k) / n, std::nextafter(float(k) / n, 0.0f), std::nextafter(float(k) / n, 2.0f)}) {
        us.push_back(x);
        vs.push_back(1.0f - x);
        us.push_back(x);
        vs.push_back(std::nextafter(1.0f - x, 0.0f));
      }
  }
  std::vector<uint32_t> ref(us.size());
  for (uint32_t level = 0; level <= somm::kMaxLevel; ++level) {
    somm::baryToIndexBatch(somm::BatchIsa::Scalar, us.data(), vs.data(), us.size(), level, ref.data());
    for (size_t i = 0; i < us.size(); ++i)
      ASSERT_EQ(baryToIndexContracted(us[i], vs[i], level), ref[i])
          << us[i] << " " << vs[i] << " level " << level;
  }
}
