// SPDX-License-Identifier: MIT
// The baker's work counter (TriangleBake::workUnits): huge-UV triangles whose micro-triangles each hold a whole wrap
// period cost O(1) per triangle, and shortcuts that only skip work change no state.
#include <gtest/gtest.h>

#include <algorithm>
#include <optional>
#include <random>

#include "bake/bake_test_util.h"
#include "somm/bake.h"

namespace somm {
namespace {

using testing::makeTexture;

// A disc of opaque texels on a transparent square: both classes present.
AlphaTexture disc(uint32_t n) {
  return makeTexture(n, n, [n](uint32_t x, uint32_t y) {
    const double dx = double(x) + 0.5 - n / 2.0, dy = double(y) + 0.5 - n / 2.0;
    return dx * dx + dy * dy < n * n / 9.0 ? 1.0 : 0.0;
  });
}

// 3,000 distinct well-shaped triangles spanning 1,000–3,900 texture periods (below the 4096-period limit above which
// triangles are not classified at all): every micro-triangle at level 8 holds a whole period (mirrored: 2 periods), so
// each is unknown and the triangle costs a bounded number of work units instead of 4^8 leaf samples (the previous
// baker: the per-triangle work budget, ~600k units on 512²).
TEST(WorkBound, HugeUvTrianglesCostConstantWork) {
  const AlphaTexture tex = disc(64);
  std::mt19937 rng(16);
  std::uniform_real_distribution<float> span(2000.f, 3500.f), centre(-5000.f, 5000.f), jitter(-0.05f, 0.05f);
  for (Wrap w : {Wrap::Repeat, Wrap::MirroredRepeat})
    for (Filter f : {Filter::Linear, Filter::Nearest}) {
      const AlphaMask mask(tex, Sampler{w, w, f}, 0.5f);
      uint64_t total = 0, maxWork = 0;
      for (int i = 0; i < 3000; ++i) {
        const float s = span(rng) * (w == Wrap::MirroredRepeat ? 1.0f : 0.5f), cx = centre(rng),
                    cy = centre(rng);
        const TriangleBake b = bakeTriangle(mask, {cx - s * (0.5f + jitter(rng)), cy - s * 0.4f},
                                            {cx + s * (0.5f + jitter(rng)), cy - s * 0.4f},
                                            {cx + s * jitter(rng), cy + s * 0.5f}, 8, Format::FourState);
        ASSERT_FALSE(b.nonFiniteUv);
        ASSERT_EQ(b.unknownCount, microTriangleCount(8)) << i;
        const std::optional<State> u = b.map.uniformState();
        ASSERT_TRUE(u && !isKnown(*u)) << i;
        total += b.workUnits;
        maxWork = std::max(maxWork, b.workUnits);
      }
      // The root's region test (a node visit at most) plus the triangle itself.
      EXPECT_LE(maxWork, 4u) << int(w) << " " << int(f);
      EXPECT_LE(total, 3000u * 4u);
    }
}

// The same triangles with clamping wraps are not periodic: the shortcut does not apply, the work budget bounds them,
// and every micro-triangle known is consistent with the alpha test at its vertices.
TEST(WorkBound, ClampedHugeTrianglesStayWithinTheBudget) {
  const AlphaTexture tex = disc(64);
  const AlphaMask mask(tex, Sampler{Wrap::ClampToEdge, Wrap::ClampToEdge, Filter::Linear}, 0.5f);
  const TriangleBake b =
      bakeTriangle(mask, {-1000.f, -800.f}, {1000.f, -790.f}, {3.f, 1000.f}, 6, Format::FourState);
  // kWorkBase + kWorkPerEdgeLevel · (W + H) · (level + 1) + 4^level / 4 spent at most, plus one per leaf sample set.
  const uint64_t budget = (uint64_t(1) << 14) + uint64_t(64) * (64 + 64) * 7 + microTriangleCount(6) / 4;
  EXPECT_LE(b.workUnits, budget + microTriangleCount(6) + 1);
  EXPECT_GT(b.workUnits, 0u);
}

// A triangle of ordinary size does real work (the counter counts), and the map does not depend on how it was reached:
// the per-triangle bake equals the same triangle translated by whole periods (where the period shortcut and the
// witnesses see the same texels).
TEST(WorkBound, OrdinaryTrianglesCountWorkAndArePeriodic) {
  const AlphaTexture tex = disc(64);
  const AlphaMask mask(tex, Sampler{Wrap::Repeat, Wrap::Repeat, Filter::Linear}, 0.5f);
  const TriangleBake a = bakeTriangle(mask, {0.1f, 0.1f}, {0.9f, 0.15f}, {0.4f, 0.95f}, 6, Format::FourState);
  const TriangleBake b =
      bakeTriangle(mask, {3.1f, -1.9f}, {3.9f, -1.85f}, {3.4f, -1.05f}, 6, Format::FourState);
  EXPECT_GT(a.workUnits, 100u);
  EXPECT_GT(a.unknownCount, 0u);
  EXPECT_LT(a.unknownCount, microTriangleCount(6));
  // Float UVs of the translated triangle are not exactly the translated texel coordinates; compare the counts only
  // loosely (both are exact for their own inputs).
  EXPECT_NEAR(double(a.unknownCount), double(b.unknownCount), 0.05 * double(a.unknownCount));
}

}  // namespace
}  // namespace somm
