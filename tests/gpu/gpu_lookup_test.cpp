// SPDX-License-Identifier: MIT
// The shader lookups (shaders/somm.glsl, somm.hlsl) on the Vulkan device against the CPU: every micro-triangle
// of random arrays in every encoding (EncodedArray::state), and the bird index (baryToIndex) on stress points.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "gpu_test_util.h"
#include "somm/bird.h"
#include "somm/encode.h"
#include "somm/gpu.h"
#include "somm_test_arrays.h"

namespace {

using somm::gpu::LookupMode;
using somm::gpu::Query;
using somm::gpu::ShaderLanguage;

constexpr ShaderLanguage kLanguages[] = {ShaderLanguage::Glsl, ShaderLanguage::Hlsl};

// Every (triangle, index) of the array (all indices of every map level ≤ 6, a sample above).
std::vector<Query> allIndices(const somm::EncodedArray& a, uint32_t perMapCap, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<Query> q;
  for (uint32_t t = 0; t < a.triangleCount(); ++t) {
    const int32_t i = a.indices()[t];
    const uint32_t level = i >= 0 ? a.maps()[size_t(i)].level : 0;
    const uint32_t n = somm::microTriangleCount(level);
    if (n <= perMapCap) {
      for (uint32_t k = 0; k < n; ++k) q.push_back(Query{t, 0.0f, 0.0f, k});
    } else {
      for (uint32_t k = 0; k < perMapCap; ++k) q.push_back(Query{t, 0.0f, 0.0f, uint32_t(rng() % n)});
    }
  }
  return q;
}

void expectStatesMatch(somm::gpu::Device& device, const somm::OmmArray& flat, const char* what,
                       uint32_t perMapCap) {
  for (somm::Encoding e : somm::kAllEncodings) {
    auto a = somm::EncodedArray::build(flat, e);
    ASSERT_TRUE(a) << a.error().message;
    // Put the array at an odd-looking but word-aligned offset after another array, as a scene buffer would.
    std::vector<uint8_t> buffer(52, 0xa5);
    const uint32_t base = uint32_t(buffer.size());
    const std::vector<uint8_t> bytes = a->serialize();
    buffer.insert(buffer.end(), bytes.begin(), bytes.end());
    const std::vector<Query> q = allIndices(*a, perMapCap, 7);
    for (ShaderLanguage l : kLanguages) {
      auto r = device.run(l, LookupMode::StateIndex, buffer, base, q);
      ASSERT_TRUE(r) << r.error().message;
      uint64_t bad = 0;
      for (size_t i = 0; i < q.size(); ++i) {
        const uint32_t cpu = uint32_t(a->state(q[i].triangle, q[i].w));
        if ((*r)[i] != cpu && bad++ < 3)
          ADD_FAILURE() << what << " " << somm::encodingName(e) << " " << somm::gpu::shaderLanguageName(l)
                        << ": triangle " << q[i].triangle << " index " << q[i].w << ": cpu " << cpu
                        << ", gpu " << (*r)[i];
      }
      EXPECT_EQ(bad, 0u) << what << " " << somm::encodingName(e) << " " << somm::gpu::shaderLanguageName(l)
                         << " (" << q.size() << " lookups)";
    }
  }
}

TEST(GpuLookup, EveryMicroTriangleOfRandomArrays) {
  SOMM_OPEN_DEVICE_OR_SKIP(device);
  for (somm::Format f : {somm::Format::TwoState, somm::Format::FourState}) {
    // Levels 0..6: every index of every map; 300 maps, so rank maps with and without a directory.
    const somm::OmmArray a = somm::testing::randomOmmArray(300, f, 0, 6, 11 + uint32_t(f));
    expectStatesMatch(*device, a, f == somm::Format::TwoState ? "2-state 0..6" : "4-state 0..6", 1u << 12);
    // Large trees: 32-bit rank counters (≥ 65536 internal nodes) and 32-bit index buffers.
    const somm::OmmArray big = somm::testing::randomOmmArray(6, f, 9, 10, 5 + uint32_t(f));
    expectStatesMatch(*device, big, f == somm::Format::TwoState ? "2-state 9..10" : "4-state 9..10", 300);
  }
}

TEST(GpuLookup, ThirtyTwoBitIndexBuffer) {
  SOMM_OPEN_DEVICE_OR_SKIP(device);
  // More than 0xfffb distinct maps force 32-bit indices.
  somm::OmmArrayBuilder b;
  for (uint32_t t = 0; t < 90000; ++t) {
    somm::Micromap m(3, somm::Format::FourState, somm::State::Opaque);
    for (uint32_t k = 0; k < 64; ++k)
      m.set(k, somm::State(k < 17 ? ((t >> k) & 1u) * 2 + (k & 1u) : (k * 7) & 3u));
    if (t % 7 == 0) m = somm::Micromap(3, somm::Format::FourState, somm::State(t % 4));
    b.add(m);
  }
  const somm::OmmArray a = b.finish();
  ASSERT_EQ(a.indexType(), somm::IndexType::UInt32);
  // Every encoding in both languages. This array found the HLSL dfs mismatches (docs/shaders.md, "Fixed: the HLSL
  // dfs mismatches"): from triangle 57 973 on, the kernel's not-chosen ?: operand used up lavapipe's loop budget.
  expectStatesMatch(*device, a, "32-bit indices", 2);
}

// Mostly special indices (as on real foliage, where most triangles are opaque): arrays with the sdag directory
// store the rank-packed index buffer (group words + the listed triangles' entries), which the shader reads too.
// 3000 triangles, so several groups, a partial last group and listed runs that cross group boundaries.
TEST(GpuLookup, RankPackedIndexBuffer) {
  SOMM_OPEN_DEVICE_OR_SKIP(device);
  somm::OmmArrayBuilder b;
  std::mt19937 rng(17);
  for (uint32_t t = 0; t < 3003; ++t) {
    somm::Micromap m(3, somm::Format::FourState,
                     t % 50 == 0 ? somm::State::Transparent : somm::State::Opaque);
    if (t % 9 == 4 || (t >= 1000 && t < 1070)) {
      for (uint32_t k = 0; k < 64; ++k) m.set(k, somm::State(rng() % 4));
    }
    b.add(m);
  }
  const somm::OmmArray a = b.finish();
  for (somm::Encoding e : {somm::Encoding::Sdag, somm::Encoding::Hybrid}) {
    const auto enc = somm::EncodedArray::build(a, e);
    ASSERT_TRUE(enc) << enc.error().message;
    if (enc->hasDirectory()) {
      EXPECT_TRUE(enc->indexRankPacked()) << somm::encodingName(e);
    }
  }
  expectStatesMatch(*device, a, "rank-packed indices", 64);
}

// sdag's three-class references (short / mid / long, flags F and G): a leaf region with a mid class.
TEST(GpuLookup, SdagMidReferenceClass) {
  SOMM_OPEN_DEVICE_OR_SKIP(device);
  const somm::OmmArray a = somm::testing::randomOmmArray(200, somm::Format::FourState, 6, 8, 1);
  const auto enc = somm::EncodedArray::build(a, somm::Encoding::Sdag);
  ASSERT_TRUE(enc) << enc.error().message;
  ASSERT_NE(enc->directory().mid[somm::encode::sdagRegion(somm::Format::FourState, 1)], 0u);
  expectStatesMatch(*device, a, "sdag mid references", 400);
}

// A dfs skip close to lavapipe's loop budget (65 535 loop iterations per invocation, shared by all loops;
// docs/shaders.md): a level-11 map whose first two quadrants are random (2 × 349 525 internal nodes, ~2.8 M tree
// bits) and whose last two are uniform. A lookup in quadrant 3 skips both random subtrees: ~58 000 iterations of
// 48 bits, inside the budget once, outside it if anything else loops as long in the same invocation (as when
// HLSL's ?: ran both the dfs and the dfs-fast skip for every dfs map).
TEST(GpuLookup, LongDfsSkipsWithinTheLoopBudget) {
  SOMM_OPEN_DEVICE_OR_SKIP(device);
  constexpr uint32_t kLevel = 11, kQuadrant = 1u << 20;
  somm::Micromap m(kLevel, somm::Format::FourState, somm::State::Opaque);
  std::mt19937 rng(5);
  for (uint32_t k = 0; k < 2 * kQuadrant; ++k) m.set(k, somm::State(rng() & 3u));
  for (uint32_t k = 3 * kQuadrant; k < 4 * kQuadrant; ++k) m.set(k, somm::State::UnknownTransparent);
  somm::OmmArrayBuilder b;
  b.add(m);
  const somm::OmmArray flat = b.finish();
  std::vector<Query> q;
  for (uint32_t quadrant = 0; quadrant < 4; ++quadrant)
    for (uint32_t i = 0; i < 32; ++i)
      q.push_back(Query{0, 0.0f, 0.0f, quadrant * kQuadrant + uint32_t(rng() % kQuadrant)});
  q.push_back(Query{0, 0.0f, 0.0f, 4 * kQuadrant - 1});  // the longest skip
  for (somm::Encoding e : {somm::Encoding::Dfs, somm::Encoding::DfsFast, somm::Encoding::Hybrid}) {
    auto a = somm::EncodedArray::build(flat, e);
    ASSERT_TRUE(a) << a.error().message;
    const std::vector<uint8_t> buffer = a->serialize();
    for (ShaderLanguage l : kLanguages) {
      auto r = device->run(l, LookupMode::StateIndex, buffer, 0, q);
      ASSERT_TRUE(r) << r.error().message;
      uint64_t bad = 0;
      for (size_t i = 0; i < q.size(); ++i) {
        const uint32_t cpu = uint32_t(a->state(0, q[i].w));
        if ((*r)[i] != cpu && bad++ < 3)
          ADD_FAILURE() << somm::encodingName(e) << " " << somm::gpu::shaderLanguageName(l) << ": index "
                        << q[i].w << ": cpu " << cpu << ", gpu " << (*r)[i];
      }
      EXPECT_EQ(bad, 0u) << somm::encodingName(e) << " " << somm::gpu::shaderLanguageName(l);
    }
  }
}

TEST(GpuLookup, BirdIndexOnStressPoints) {
  SOMM_OPEN_DEVICE_OR_SKIP(device);
  std::mt19937_64 rng(3);
  std::vector<Query> q;
  auto push = [&](float u, float v, uint32_t level) { q.push_back(Query{0, u, v, level}); };
  for (uint32_t level = 0; level <= somm::kMaxLevel; ++level) {
    const uint32_t n = 1u << level;
    // Every grid point of levels ≤ 5 and its neighbours one ulp away.
    if (level <= 5)
      for (uint32_t iu = 0; iu <= n; ++iu)
        for (uint32_t iv = 0; iv <= n; ++iv) {
          const float u = float(iu) / float(n), v = float(iv) / float(n);
          for (float du : {-1.0f, 0.0f, 1.0f})
            for (float dv : {-1.0f, 0.0f, 1.0f})
              push(du == 0 ? u : std::nextafter(u, du * 2.0f), dv == 0 ? v : std::nextafter(v, dv * 2.0f),
                   level);
        }
    // Random bit patterns (NaNs, infinities, denormals, negatives included).
    for (int i = 0; i < 20000; ++i) {
      const uint32_t a = uint32_t(rng()), b = uint32_t(rng());
      float u, v;
      std::memcpy(&u, &a, 4);
      std::memcpy(&v, &b, 4);
      push(u, v, level);
    }
    // Fractions whose float sum rounds to 1 (cell 0 of u has the finest fractions).
    for (int i = 0; i < 20000; ++i) {
      const float v = float(rng() >> 40) * 0x1p-24f;
      const double fv = double(v) * n, vf = fv - std::floor(fv);
      const double t = 1.0 - vf - 0x1p-25 + double(int(rng() % 7) - 3) * 0x1p-26;
      const float u = t >= 0 && t < 1 ? float(t / n) : 0.0f;
      if (i % 2)
        push(u, v, level);
      else
        push(v, u, level);
    }
  }
  for (ShaderLanguage l : kLanguages) {
    auto r = device->run(l, LookupMode::BirdIndex, {}, 0, q);
    ASSERT_TRUE(r) << r.error().message;
    uint64_t bad = 0;
    for (size_t i = 0; i < q.size(); ++i) {
      const uint32_t cpu = somm::baryToIndex(q[i].u, q[i].v, q[i].w);
      if ((*r)[i] != cpu && bad++ < 5)
        ADD_FAILURE() << somm::gpu::shaderLanguageName(l) << ": u=" << q[i].u << " v=" << q[i].v << " level "
                      << q[i].w << ": cpu " << cpu << ", gpu " << (*r)[i];
    }
    EXPECT_EQ(bad, 0u) << somm::gpu::shaderLanguageName(l) << " (" << q.size() << " lookups)";
  }
}

}  // namespace
