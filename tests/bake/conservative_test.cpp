// SPDX-License-Identifier: MIT
// Conservativeness property tests: points of every micro-triangle (vertices, edges, interior), sampled like a
// ray tracer would (float UV interpolation) and evaluated with an independent sampler, never contradict a
// known state.
#include <gtest/gtest.h>

#include <random>

#include "bake/bake_test_util.h"
#include "somm/bake.h"

namespace somm {
namespace {

using testing::CheckCounts;
using testing::checkMap;
using testing::interpolateUV;
using testing::pointsIn;
using testing::refAlpha;

struct Tri {
  const char* name;
  float uv[3][2];
  uint32_t maxLevel;
};

std::vector<Tri> triangles(std::mt19937& rng, uint32_t W, uint32_t H) {
  std::uniform_real_distribution<float> d(-1.2f, 2.2f), c(0.f, 1.f);
  std::vector<Tri> v;
  for (int k = 0; k < 3; ++k)
    v.push_back({"random", {{d(rng), d(rng)}, {d(rng), d(rng)}, {d(rng), d(rng)}}, 5});
  v.push_back({"corner-seam", {{0.93f, 0.95f}, {1.11f, 0.91f}, {1.02f, 1.13f}}, 5});
  v.push_back({"negative-seam", {{-0.07f, 0.4f}, {0.08f, 0.35f}, {0.01f, 0.52f}}, 5});
  v.push_back({"huge", {{-6.3f, -4.1f}, {8.7f, -3.9f}, {0.2f, 9.4f}}, 5});
  const float cx = c(rng), cy = c(rng), tx = 0.3f / float(W), ty = 0.3f / float(H);
  v.push_back({"tiny", {{cx, cy}, {cx + tx, cy + 0.2f * ty}, {cx + 0.4f * tx, cy + ty}}, 4});
  v.push_back({"on-texel-lines", {{0.f, 0.f}, {4.f / float(W), 0.f}, {0.f, 4.f / float(H)}}, 5});
  v.push_back({"sliver", {{0.1f, 0.2f}, {1.7f, 0.9f}, {0.1f + 1e-4f, 0.2f + 2e-4f}}, 5});
  v.push_back({"segment", {{-0.3f, 0.1f}, {1.4f, 0.8f}, {0.55f, 0.45f}}, 5});
  v.push_back({"point", {{0.37f, 0.61f}, {0.37f, 0.61f}, {0.37f, 0.61f}}, 2});
  v.push_back({"point-on-edge", {{0.5f, 0.25f}, {0.5f, 0.25f}, {0.5f, 0.25f}}, 1});
  return v;
}

void runTexture(const testing::NamedTexture& nt, Filter filter, float cutoff, CheckCounts& counts) {
  const Wrap wraps[][2] = {{Wrap::Repeat, Wrap::Repeat},
                           {Wrap::ClampToEdge, Wrap::ClampToEdge},
                           {Wrap::MirroredRepeat, Wrap::MirroredRepeat},
                           {Wrap::Repeat, Wrap::MirroredRepeat},
                           {Wrap::MirroredRepeat, Wrap::ClampToEdge}};
  std::mt19937 rng(1234);
  for (const auto& w : wraps) {
    const Sampler smp{w[0], w[1], filter};
    const AlphaMask mask(nt.tex, smp, cutoff);
    for (const Tri& t : triangles(rng, nt.tex.width, nt.tex.height)) {
      for (uint32_t level = 0; level <= t.maxLevel; ++level) {
        const TriangleBake b = bakeTriangle(mask, {t.uv[0][0], t.uv[0][1]}, {t.uv[1][0], t.uv[1][1]},
                                            {t.uv[2][0], t.uv[2][1]}, level, Format::FourState);
        uint64_t unknown = 0;
        for (uint32_t i = 0; i < b.map.size(); ++i) unknown += !isKnown(b.map.get(i));
        EXPECT_EQ(unknown, b.unknownCount) << nt.name << " " << t.name;
        const std::string what =
            nt.name + " " + t.name + (filter == Filter::Linear ? " linear" : " nearest") + " wrap " +
            std::to_string(int(w[0])) + std::to_string(int(w[1])) + " cutoff " + std::to_string(cutoff);
        checkMap(nt.tex, smp, cutoff, t.uv, b.map, rng, level >= 4 ? 3 : 8, what, counts);
      }
    }
  }
}

class Conservative : public ::testing::TestWithParam<Filter> {};

TEST_P(Conservative, ProceduralTexturesEveryWrapMode) {
  CheckCounts counts;
  for (const auto& nt : testing::proceduralTextures()) runTexture(nt, GetParam(), 0.5f, counts);
  EXPECT_EQ(counts.failures, 0u);
  // The test must have something to check: plenty of known micro-triangles and some unknown ones.
  EXPECT_GT(counts.known, 100000u);
  EXPECT_GT(counts.unknown, 10000u);
  EXPECT_GT(counts.points, 500000u);
}

TEST_P(Conservative, NoiseAtSeveralCutoffs) {
  CheckCounts counts;
  const auto textures = testing::proceduralTextures();
  for (float cutoff : {0.0f, 0.05f, 0.3f, 0.75f, 0.999f, 1.0f, 1.5f})
    runTexture(textures[1], GetParam(), cutoff, counts);
  EXPECT_EQ(counts.failures, 0u);
  EXPECT_GT(counts.known, 50000u);
}

INSTANTIATE_TEST_SUITE_P(Filters, Conservative, ::testing::Values(Filter::Nearest, Filter::Linear),
                         [](const auto& info) {
                           return info.param == Filter::Nearest ? "Nearest" : "Linear";
                         });

// Rays near micro-triangle boundaries: barycentrics a hair outside the micro-triangle (and the triangle)
// still land on a state the alpha test agrees with.
TEST(Conservative, BarycentricsSlightlyOutside) {
  const auto textures = testing::proceduralTextures();
  std::mt19937 rng(99);
  std::uniform_real_distribution<float> d(-0.5f, 1.5f), e(-3e-7f, 3e-7f);
  uint64_t checked = 0;
  for (const auto& nt : textures) {
    for (Filter f : {Filter::Nearest, Filter::Linear}) {
      const Sampler smp{Wrap::Repeat, Wrap::Repeat, f};
      const AlphaMask mask(nt.tex, smp, 0.5f);
      for (int k = 0; k < 20; ++k) {
        const float uv[3][2] = {{d(rng), d(rng)}, {d(rng), d(rng)}, {d(rng), d(rng)}};
        const uint32_t level = 5;
        const TriangleBake b = bakeTriangle(mask, {uv[0][0], uv[0][1]}, {uv[1][0], uv[1][1]},
                                            {uv[2][0], uv[2][1]}, level, Format::FourState);
        for (uint32_t i = 0; i < b.map.size(); ++i) {
          for (const auto& [b1, b2] : pointsIn(i, level, rng, 2)) {
            const float p1 = b1 + e(rng), p2 = b2 + e(rng);
            const State s = b.map.get(baryToIndex(p1, p2, level));
            if (!isKnown(s)) continue;
            float S, T;
            interpolateUV(uv, p1, p2, S, T);
            ASSERT_EQ(refAlpha(nt.tex, smp, S, T) >= 0.5f, s == State::Opaque) << nt.name << " micro " << i;
            ++checked;
          }
        }
      }
    }
  }
  EXPECT_GT(checked, 100000u);
}

}  // namespace
}  // namespace somm
