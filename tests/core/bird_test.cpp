// SPDX-License-Identifier: MIT
#include "somm/bird.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <vector>

#include "bird_reference.h"

namespace somm {
namespace {

using reference::BarycentricsToSpaceFillingCurveIndex;

// All three implementations must agree with the reference on (u, v).
void expectAllMatch(float u, float v, uint32_t level) {
  const uint32_t want = BarycentricsToSpaceFillingCurveIndex(u, v, level);
  ASSERT_EQ(baryToIndex(u, v, level), want) << "u=" << u << " v=" << v << " level=" << level;
  ASSERT_EQ(baryToIndexDescent(u, v, level), want) << "u=" << u << " v=" << v << " level=" << level;
  uint32_t batch = ~0u;
  baryToIndexBatch(&u, &v, 1, level, &batch);
  ASSERT_EQ(batch, want) << "u=" << u << " v=" << v << " level=" << level;
}

TEST(Bird, HandComputedVectors) {
  EXPECT_EQ(baryToIndex(0.5f, 0.25f, 2), 11u);
  EXPECT_EQ(baryToIndex(0.25f, 0.5f, 2), 12u);
  EXPECT_EQ(baryToIndex(0.7f, 0.7f, 2), 12u);
  // Level 1: the four children by their centroids.
  EXPECT_EQ(baryToIndex(1.f / 6, 1.f / 6, 1), 0u);
  EXPECT_EQ(baryToIndex(1.f / 3, 1.f / 3, 1), 1u);
  EXPECT_EQ(baryToIndex(2.f / 3, 1.f / 6, 1), 2u);
  EXPECT_EQ(baryToIndex(1.f / 6, 2.f / 3, 1), 3u);
  // Level 0 has one micro-triangle whatever the input.
  EXPECT_EQ(baryToIndex(0.9f, 0.9f, 0), 0u);
  EXPECT_EQ(baryToIndex(NAN, -INFINITY, 0), 0u);
}

TEST(Bird, ExhaustiveCentroidsRoundTripAndBijection) {
  for (uint32_t level = 0; level <= 8; ++level) {
    const uint32_t count = microTriangleCount(level);
    std::vector<bool> seen(count, false);
    for (uint32_t i = 0; i < count; ++i) {
      const MicroTriangle t = indexToMicroTriangle(i, level);
      // Centroid in grid units ×3 → float barycentrics (exact enough: strictly inside the micro-triangle).
      const double cu = (double(t.v[0].u) + t.v[1].u + t.v[2].u) / 3.0 / double(1u << level);
      const double cv = (double(t.v[0].v) + t.v[1].v + t.v[2].v) / 3.0 / double(1u << level);
      const float u = float(cu), v = float(cv);
      const uint32_t idx = baryToIndex(u, v, level);
      ASSERT_EQ(idx, i) << "level " << level;
      ASSERT_EQ(BarycentricsToSpaceFillingCurveIndex(u, v, level), i);
      ASSERT_EQ(baryToIndexDescent(u, v, level), i);
      ASSERT_FALSE(seen[idx]);
      seen[idx] = true;
      // Each micro-triangle is a non-degenerate triangle of side one grid unit.
      const int64_t area2 = (int64_t(t.v[1].u) - t.v[0].u) * (int64_t(t.v[2].v) - t.v[0].v) -
                            (int64_t(t.v[2].u) - t.v[0].u) * (int64_t(t.v[1].v) - t.v[0].v);
      ASSERT_EQ(std::abs(area2), 1);
      if (level > 0) {
        // The parent (i >> 2) at level - 1 contains this micro-triangle: every vertex, scaled, lies in the parent.
        const MicroTriangle p = indexToMicroTriangle(i >> 2, level - 1);
        for (const GridPoint& q : t.v) {
          // Barycentric containment test in integer arithmetic (parent vertices doubled to the child's grid).
          auto cross = [](int64_t ax, int64_t ay, int64_t bx, int64_t by, int64_t px, int64_t py) {
            return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
          };
          const int64_t x0 = 2 * p.v[0].u, y0 = 2 * p.v[0].v, x1 = 2 * p.v[1].u, y1 = 2 * p.v[1].v,
                        x2 = 2 * p.v[2].u, y2 = 2 * p.v[2].v;
          const int64_t d0 = cross(x0, y0, x1, y1, q.u, q.v), d1 = cross(x1, y1, x2, y2, q.u, q.v),
                        d2 = cross(x2, y2, x0, y0, q.u, q.v);
          ASSERT_TRUE((d0 >= 0 && d1 >= 0 && d2 >= 0) || (d0 <= 0 && d1 <= 0 && d2 <= 0))
              << "level " << level << " index " << i;
        }
      }
    }
  }
}

TEST(Bird, ChildrenFollowTheDocumentedSubdivision) {
  // Child 0 = (v0, m01, m02), 1 = (m02, m12, m01), 2 = (m01, v1, m12), 3 = (m12, m02, v2) at level 1 (units of 1/2).
  EXPECT_EQ(indexToMicroTriangle(0, 1), (MicroTriangle{{{0, 0}, {1, 0}, {0, 1}}}));
  EXPECT_EQ(indexToMicroTriangle(1, 1), (MicroTriangle{{{0, 1}, {1, 1}, {1, 0}}}));
  EXPECT_EQ(indexToMicroTriangle(2, 1), (MicroTriangle{{{1, 0}, {2, 0}, {1, 1}}}));
  EXPECT_EQ(indexToMicroTriangle(3, 1), (MicroTriangle{{{1, 1}, {0, 1}, {0, 2}}}));
  EXPECT_EQ(indexToMicroTriangle(0, 0), (MicroTriangle{{{0, 0}, {1, 0}, {0, 1}}}));
  // Level 2, index 11 = child 2 then child 3: (m12, m02, v2) of (m01, v1, m12) in quarter units.
  EXPECT_EQ(indexToMicroTriangle(11, 2), (MicroTriangle{{{3, 1}, {2, 1}, {2, 2}}}));
  const MicroTriangleF f = indexToMicroTriangleF(11, 2);
  EXPECT_EQ(f.u[0], 0.75f);
  EXPECT_EQ(f.v[2], 0.5f);
}

TEST(Bird, CellDescentMatchesBitTrickOnEveryCell) {
  for (uint32_t level = 0; level <= 9; ++level) {
    const uint32_t n = 1u << level;
    for (uint32_t iu = 0; iu < n; ++iu)
      for (uint32_t iv = 0; iu + iv < n; ++iv)
        for (uint32_t up = 0; up < 2 && iu + iv + up < n; ++up)
          ASSERT_EQ(cellToIndexDescent(iu, iv, up != 0, level), detail::cellToIndex(iu, iv, up, level));
  }
}

// Every point of the dyadic grid at resolution 2^-(level+2): vertices, edge points and interiors of every micro-triangle,
// including the outer edge u + v = 1 and points beyond it.
TEST(Bird, DyadicGridTies) {
  for (uint32_t level = 0; level <= 6; ++level) {
    const uint32_t steps = 1u << (level + 2);
    for (uint32_t a = 0; a <= steps + 2; ++a)
      for (uint32_t b = 0; b <= steps + 2; ++b) {
        const float u = float(a) / float(steps), v = float(b) / float(steps);
        expectAllMatch(u, v, level);
        // Neighbouring floats on each side of every grid point.
        expectAllMatch(std::nextafter(u, 2.f), v, level);
        expectAllMatch(std::nextafter(u, -1.f), v, level);
        expectAllMatch(u, std::nextafter(v, -1.f), level);
        expectAllMatch(std::nextafter(u, 2.f), std::nextafter(v, -1.f), level);
      }
  }
}

TEST(Bird, SpecialValues) {
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float specials[] = {0.f,
                            -0.f,
                            1.f,
                            -1.f,
                            2.f,
                            0.5f,
                            inf,
                            -inf,
                            nan,
                            -nan,
                            std::numeric_limits<float>::denorm_min(),
                            std::numeric_limits<float>::max(),
                            std::nextafter(1.f, 0.f),
                            std::nextafter(1.f, 2.f),
                            1e-30f,
                            -1e-30f};
  for (uint32_t level = 0; level <= kMaxLevel; ++level)
    for (float u : specials)
      for (float v : specials) expectAllMatch(u, v, level);
  // NaN clamps to 0, like the reference with IEEE min/max.
  EXPECT_EQ(baryToIndex(nan, nan, 5), baryToIndex(0.f, 0.f, 5));
  EXPECT_EQ(baryToIndex(nan, 0.3f, 5), baryToIndex(0.f, 0.3f, 5));
}

// The reference's `uf + vf >= 1.0f` is a float addition: fractions whose exact sum is just below 1 round up to 1 and
// select the upper triangle of the cell. Hunt for such inputs and check we follow the rounding, not exact arithmetic.
TEST(Bird, FloatRoundingOfFractionSum) {
  int roundedUp = 0;
  for (uint32_t level : {0u, 1u, 4u, 8u, 12u}) {
    const float n = float(1u << level);
    for (int k = 1; k < 2000; ++k) {
      // u·n = i + 0.5 + tiny, v·n = j + 0.5 - 2·tiny: exact sum of fractions < 1, float sum rounds to 1.
      const float uf = 0.5f + std::ldexp(float(k), -40);
      const float vf = std::nextafter(1.0f - uf, 0.0f);
      const float u = (0.0f + uf) / n, v = (0.0f + vf) / n;
      if (u * n != uf || v * n != vf) continue;  // keep only exactly representable cases
      const double exactSum = double(uf) + double(vf);
      if (exactSum < 1.0 && uf + vf >= 1.0f) ++roundedUp;
      expectAllMatch(u, v, level);
    }
  }
  EXPECT_GT(roundedUp, 100);  // the test really exercises the rounding case
}

TEST(Bird, RandomPointsAllLevels) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<float> d(-0.25f, 1.25f);
  std::uniform_int_distribution<uint32_t> bits;
  for (uint32_t level = 0; level <= kMaxLevel; ++level) {
    for (int i = 0; i < 200000; ++i) expectAllMatch(d(rng), d(rng), level);
    // Arbitrary bit patterns: every float class.
    for (int i = 0; i < 50000; ++i)
      expectAllMatch(std::bit_cast<float>(bits(rng)), std::bit_cast<float>(bits(rng)), level);
  }
}

TEST(Bird, RandomMicroTrianglesHighLevels) {
  std::mt19937 rng(777);
  for (uint32_t level = 9; level <= kMaxLevel; ++level) {
    std::uniform_int_distribution<uint32_t> pick(0, microTriangleCount(level) - 1);
    for (int k = 0; k < 100000; ++k) {
      const uint32_t i = pick(rng);
      const MicroTriangle t = indexToMicroTriangle(i, level);
      const double s = 1.0 / double(1u << level);
      const float u = float((double(t.v[0].u) + t.v[1].u + t.v[2].u) / 3.0 * s);
      const float v = float((double(t.v[0].v) + t.v[1].v + t.v[2].v) / 3.0 * s);
      ASSERT_EQ(baryToIndex(u, v, level), i);
      ASSERT_EQ(baryToIndexDescent(u, v, level), i);
      ASSERT_EQ(baryToIndex(u, v, level - 1), i >> 2);  // the parent contains the child's centroid
    }
  }
}

TEST(Bird, BatchMatchesScalarOnLongArrays) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<float> d(-0.1f, 1.1f);
  const size_t n = 10007;  // not a multiple of any vector width
  std::vector<float> u(n), v(n);
  for (size_t i = 0; i < n; ++i) {
    u[i] = d(rng);
    v[i] = d(rng);
  }
  u[5] = std::numeric_limits<float>::quiet_NaN();
  v[6] = std::numeric_limits<float>::infinity();
  // Special values across the vector lanes too.
  const float specials[] = {0.f,
                            -0.f,
                            1.f,
                            2.f,
                            -1.f,
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            std::numeric_limits<float>::quiet_NaN(),
                            std::numeric_limits<float>::denorm_min(),
                            0.5f,
                            0.25f,
                            0.75f};
  for (size_t i = 0; i < 144; ++i) {
    u[100 + i] = specials[i % 12];
    v[100 + i] = specials[i / 12];
  }
  std::vector<uint32_t> out(n);
  int variants = 0;
  for (BatchIsa isa : {BatchIsa::Scalar, BatchIsa::Sse2, BatchIsa::Avx2, BatchIsa::Avx512}) {
    if (!batchIsaSupported(isa)) continue;
    ++variants;
    for (uint32_t level = 0; level <= kMaxLevel; ++level) {
      std::fill(out.begin(), out.end(), ~0u);
      baryToIndexBatch(isa, u.data(), v.data(), n, level, out.data());
      for (size_t i = 0; i < n; ++i)
        ASSERT_EQ(out[i], BarycentricsToSpaceFillingCurveIndex(u[i], v[i], level)) << batchIsaName(isa);
    }
  }
  EXPECT_GE(variants, 2);  // scalar and SSE2 exist everywhere on x86-64
  baryToIndexBatch(u.data(), v.data(), n, 7, out.data());
  for (size_t i = 0; i < n; ++i) ASSERT_EQ(out[i], BarycentricsToSpaceFillingCurveIndex(u[i], v[i], 7));
}

}  // namespace
}  // namespace somm
