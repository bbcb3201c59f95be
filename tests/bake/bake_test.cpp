// SPDX-License-Identifier: MIT
// Baker behaviour: tightness, levels, maxBytes, determinism across thread counts, special cases, estimate.
#include "somm/bake.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "bake/bake_test_util.h"

namespace somm {
namespace {

using testing::makeTexture;

// A random rectangle [x0, x1] × [y0, y1] inside a w × h texture (corners in either order, sorted).
struct Rect {
  int64_t x0, x1, y0, y1;
};
Rect randomRect(std::mt19937& rng, uint32_t w, uint32_t h) {
  std::uniform_int_distribution<int64_t> dx(0, w - 1), dy(0, h - 1);
  Rect r{dx(rng), dx(rng), dy(rng), dy(rng)};
  if (r.x0 > r.x1) std::swap(r.x0, r.x1);
  if (r.y0 > r.y1) std::swap(r.y0, r.y1);
  return r;
}

// Brute force over every texel of the wrapped rectangle.
TEST(AlphaMask, CountMatchesBruteForceForEveryWrap) {
  const AlphaTexture tex =
      makeTexture(7, 5, [](uint32_t x, uint32_t y) { return (x * 3 + y * 5) % 4 == 0 ? 1.0 : 0.2; });
  std::mt19937 rng(5);
  std::uniform_int_distribution<int64_t> d(-30, 30), len(0, 20);
  for (Wrap ws : {Wrap::Repeat, Wrap::ClampToEdge, Wrap::MirroredRepeat})
    for (Wrap wt : {Wrap::Repeat, Wrap::ClampToEdge, Wrap::MirroredRepeat}) {
      const Sampler smp{ws, wt, Filter::Nearest};
      const AlphaMask mask(tex, smp, 0.5f);
      for (int k = 0; k < 300; ++k) {
        const int64_t x0 = d(rng), x1 = x0 + len(rng), y0 = d(rng), y1 = y0 + len(rng);
        bool anyPass = false, anyFail = false;
        for (int64_t y = y0; y <= y1; ++y)
          for (int64_t x = x0; x <= x1; ++x) {
            const bool p =
                tex.at(uint32_t(testing::refWrap(x, 7, ws)), uint32_t(testing::refWrap(y, 5, wt))) >= 0.5f;
            (p ? anyPass : anyFail) = true;
          }
        const AlphaMask::Count c = mask.count(x0, x1, y0, y1);
        EXPECT_EQ(c.pass > 0, anyPass) << x0 << ".." << x1 << " × " << y0 << ".." << y1;
        EXPECT_EQ(c.pass < c.total, anyFail) << x0 << ".." << x1 << " × " << y0 << ".." << y1;
        EXPECT_EQ(mask.passFail(x0, x1, y0, y1), (anyPass ? 1u : 0u) | (anyFail ? 2u : 0u))
            << x0 << ".." << x1 << " × " << y0 << ".." << y1;
      }
    }
}

// Exact pass counts and passFail of rectangles inside 8-bit and 16-bit textures (8-bit pass bits by a threshold
// compare 16 texels at a time, 16-bit through a pass table; counts from the word table and the end words) for widths
// around the 64-bit word size and several words wide, against brute force.
TEST(AlphaMask, CountsOfIntegerTexturesAreExact) {
  std::mt19937 rng(17);
  for (uint32_t w : {1u, 3u, 4u, 5u, 8u, 63u, 64u, 65u, 130u, 300u})
    for (AlphaStorage st : {AlphaStorage::UInt8, AlphaStorage::UInt16}) {
      const uint32_t h = st == AlphaStorage::UInt16 ? 600 : 9;  // 16-bit: above 65,536 texels for the widest
      AlphaTexture tex;
      tex.width = w;
      tex.height = h;
      tex.storage = st;
      tex.lut = AlphaTexture::table(st, 1.0f);
      std::uniform_int_distribution<uint32_t> v(0, st == AlphaStorage::UInt8 ? 255 : 65535);
      for (size_t i = 0; i < size_t(w) * h; ++i) {
        if (st == AlphaStorage::UInt8)
          tex.alpha8.push_back(uint8_t(v(rng)));
        else
          tex.alpha16.push_back(uint16_t(v(rng)));
      }
      ASSERT_TRUE(tex.consistent());
      const AlphaMask mask(tex, Sampler{}, 0.37f);
      for (int k = 0; k < 200; ++k) {
        const auto [x0, x1, y0, y1] = randomRect(rng, w, h);
        uint64_t pass = 0;
        for (int64_t y = y0; y <= y1; ++y)
          for (int64_t x = x0; x <= x1; ++x) pass += tex.at(uint32_t(x), uint32_t(y)) >= 0.37f;
        const AlphaMask::Count c = mask.count(x0, x1, y0, y1);
        const uint64_t total = uint64_t(x1 - x0 + 1) * uint64_t(y1 - y0 + 1);
        EXPECT_EQ(c.pass, pass) << w << " " << x0 << ".." << x1 << " × " << y0 << ".." << y1;
        EXPECT_EQ(c.total, total);
        EXPECT_EQ(mask.passFail(x0, x1, y0, y1), (pass > 0 ? 1u : 0u) | (pass < total ? 2u : 0u))
            << w << " " << x0 << ".." << x1 << " × " << y0 << ".." << y1;
      }
    }
}

// passFail of tall rectangles (more rows than rectPassFail reads one by one) over textures whose 64-texel word
// columns are mostly of one class, with a few texels of the other class: the end words are then decided by their
// whole column's count or read row by row (a speck inside the rectangle, outside it, or in the column only).
// Widths with a partial last word and a multiple of 64; against brute force.
TEST(AlphaMask, PassFailOfTallRectanglesOverUniformColumns) {
  std::mt19937 rng(23);
  for (uint32_t w : {70u, 128u, 200u, 300u}) {
    const uint32_t h = 90;
    std::vector<uint8_t> a(size_t(w) * h);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x)
        a[size_t(y) * w + x] = ((x >> 6) + (y >= 45 ? 1u : 0u)) % 3 == 0 ? 255 : 0;
    std::uniform_int_distribution<uint32_t> sx(0, w - 1), sy(0, h - 1);
    for (int s = 0; s < 6; ++s) {
      uint8_t& t = a[size_t(sy(rng)) * w + sx(rng)];
      t = uint8_t(255 - t);
    }
    const AlphaTexture tex =
        makeTexture(w, h, [&](uint32_t x, uint32_t y) { return a[size_t(y) * w + x] / 255.0; });
    const AlphaMask mask(tex, Sampler{}, 0.5f);
    for (int k = 0; k < 3000; ++k) {
      auto [x0, x1, y0, y1] = randomRect(rng, w, h);
      if (k % 2 == 0) y1 = std::min<int64_t>(h - 1, y0 + 8 + k % 40);  // tall
      bool anyPass = false, anyFail = false;
      for (int64_t y = y0; y <= y1; ++y)
        for (int64_t x = x0; x <= x1; ++x) (a[size_t(y) * w + size_t(x)] >= 128 ? anyPass : anyFail) = true;
      EXPECT_EQ(mask.passFail(x0, x1, y0, y1), (anyPass ? 1u : 0u) | (anyFail ? 2u : 0u))
          << w << " " << x0 << ".." << x1 << " × " << y0 << ".." << y1;
    }
  }
}

// A hard vertical edge between texel columns 31 and 32 (opaque left). Exactly the micro-triangles whose
// texel-space x-extent reaches across the edge are unknown; all others are known.
// The pass bits against the alpha test of every texel, for widths around the 64-bit word size.
TEST(AlphaMask, PassBitsMatchTheAlphaTest) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> d(0.f, 1.f);
  for (uint32_t w : {1u, 3u, 63u, 64u, 65u, 127u, 128u, 130u}) {
    const uint32_t h = 3;
    std::vector<float> a(size_t(w) * h);
    for (float& v : a) v = d(rng);
    const AlphaTexture tex = makeTexture(w, h, [&](uint32_t x, uint32_t y) { return a[size_t(y) * w + x]; });
    const AlphaMask mask(tex, Sampler{Wrap::Repeat, Wrap::Repeat, Filter::Linear}, 0.5f);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        const uint64_t bits = mask.passBits(x, y);
        for (uint32_t k = 0; k < 64 && x + k < w; ++k)
          ASSERT_EQ((bits >> k) & 1u, uint64_t(alphaTestPasses(tex.at(x + k, y), 0.5f)))
              << w << " " << x << "+" << k;
      }
  }
}

// Triangle p and its copy s shifted by whole periods (exact float UVs): when their margins agree (the same magnitude
// bracket), both are baked at `level` and must give identical maps. Returns p's unknown micro-triangles, or -1 when
// the margins differ (nothing compared).
int64_t expectSameMapsShifted(const AlphaMask& mask, const std::array<float, 2> p[3],
                              const std::array<float, 2> s[3], uint32_t level) {
  const double W = mask.width(), H = mask.height();
  double X[3], Y[3], SX[3], SY[3];
  for (int k = 0; k < 3; ++k) {
    X[k] = double(p[k][0]) * W;
    Y[k] = double(p[k][1]) * H;
    SX[k] = double(s[k][0]) * W;
    SY[k] = double(s[k][1]) * H;
  }
  if (bakeMarginTexels(X, Y) != bakeMarginTexels(SX, SY)) return -1;
  const TriangleBake a = bakeTriangle(mask, p[0], p[1], p[2], level, Format::FourState);
  const TriangleBake b = bakeTriangle(mask, s[0], s[1], s[2], level, Format::FourState);
  EXPECT_EQ(a.unknownCount, b.unknownCount) << "level " << level;
  EXPECT_TRUE(a.map.bytes().size() == b.map.bytes().size() &&
              std::equal(a.map.bytes().begin(), a.map.bytes().end(), b.map.bytes().begin()))
      << "level " << level;
  return int64_t(a.unknownCount);
}

// Inside the texture the classifier reads pass bits (rect, the cells' corners); across a repeat seam it reads the
// word table (AlphaMask::passFail) and wraps. A triangle and its copy one period to the left (same margin: same magnitude bracket,
// exact float UVs) must get identical maps.
TEST(Classifier, PassBitsAndWrappedPathsAgree) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> d(0.f, 1.f);
  std::uniform_int_distribution<int> qu(19661, 45875), qv(6554, 52428);  // u in [0.3, 0.7], v in [0.1, 0.8]
  for (Filter f : {Filter::Linear, Filter::Nearest})
    for (uint32_t size : {40u, 96u}) {
      // Blobs with long edges (as leaf textures) plus some noise.
      const AlphaTexture tex = makeTexture(size, size, [&](uint32_t x, uint32_t y) {
        const double v = std::sin(x * 0.37) * std::cos(y * 0.23) + 0.3 * d(rng) - 0.1;
        return std::clamp(0.5 + v, 0.0, 1.0);
      });
      const AlphaMask mask(tex, Sampler{Wrap::Repeat, Wrap::Repeat, f}, 0.5f);
      int compared = 0;
      for (int t = 0; t < 200; ++t) {
        // Multiples of 2^-16, so u − 1 is exact.
        std::array<float, 2> p[3], s[3];
        for (int k = 0; k < 3; ++k) {
          p[k] = {float(qu(rng)) * 0x1p-16f, float(qv(rng)) * 0x1p-16f};
          s[k] = {p[k][0] - 1.0f, p[k][1]};
        }
        SCOPED_TRACE(t);
        const int64_t unknown = expectSameMapsShifted(mask, p, s, 2 + uint32_t(t % 5));
        ASSERT_FALSE(HasFailure());
        if (unknown < 0) continue;  // another magnitude bracket
        ++compared;
      }
      EXPECT_GT(compared, 50);
    }
}

// A size × size 8-bit texture of leaf-like blobs with soft one-texel rims and binary interiors:
// sin(fx·x + phase)·cos(fy·y)·3 plus noise, around the cutoff 0.5.
std::vector<uint8_t> leafBlobTexels(uint32_t size, double fx, double phase, double fy, std::mt19937& rng) {
  std::uniform_real_distribution<double> d(0.0, 1.0);
  std::vector<uint8_t> texels(size_t(size) * size);
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) {
      const double v = std::sin(x * fx + phase) * std::cos(y * fy) * 3.0 + 0.6 * d(rng) - 0.3;
      texels[size_t(y) * size + x] = uint8_t(std::lround(std::clamp(0.5 + v, 0.0, 1.0) * 255));
    }
  return texels;
}

// The in-texture sampler (a node whose samples all read texels inside the texture: no wrapping, truncation as the
// floor) against the general one: small triangles (0.3–6 texels, as leaves of real foliage at levels 3–7) anywhere
// in an 8-bit leaf-like texture, including within a texel of its border, and their copies one period to the left and
// one period up, whose samples all wrap (the general path), must get identical maps. Coordinates are multiples of
// 2^-16 so the shifted copies are exact.
TEST(Classifier, InTextureSamplerAgreesWithWrappedSampler) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> d(0.0, 1.0);
  const uint32_t size = 64;
  const std::vector<uint8_t> texels = leafBlobTexels(size, 0.31, 0.4, 0.27, rng);
  const AlphaTexture tex = AlphaTexture::fromUInt8(size, size, texels);
  for (Filter f : {Filter::Linear, Filter::Nearest}) {
    const AlphaMask mask(tex, Sampler{Wrap::Repeat, Wrap::Repeat, f}, 0.5f);
    int compared = 0, interior = 0;
    for (int t = 0; t < 4000; ++t) {
      const double scale = 0.3 + 5.7 * d(rng) * d(rng);  // texels
      const double cx = 0.2 + (size - 0.4) * d(rng), cy = 0.2 + (size - 0.4) * d(rng);
      std::array<float, 2> p[3], s[3];
      double X[3], Y[3];
      for (int k = 0; k < 3; ++k) {
        const double x = std::clamp(cx + scale * (d(rng) - 0.5), 0.05, size - 0.05);
        const double y = std::clamp(cy + scale * (d(rng) - 0.5), 0.05, size - 0.05);
        p[k] = {float(std::round(x / size * 65536) / 65536), float(std::round(y / size * 65536) / 65536)};
        s[k] = {p[k][0] - 1.0f, p[k][1] - 1.0f};
        X[k] = double(p[k][0]) * size;
        Y[k] = double(p[k][1]) * size;
      }
      SCOPED_TRACE(t);
      const int64_t unknown = expectSameMapsShifted(mask, p, s, 3 + uint32_t(t % 5));
      ASSERT_FALSE(HasFailure());
      if (unknown < 0) continue;  // another magnitude bracket
      ++compared;
      interior += unknown > 0 && std::min({X[0], X[1], X[2]}) > 1 && std::min({Y[0], Y[1], Y[2]}) > 1 &&
                  std::max({X[0], X[1], X[2]}) < size - 2 && std::max({Y[0], Y[1], Y[2]}) < size - 2;
    }
    EXPECT_GT(compared, 1500);
    EXPECT_GT(interior, 200);  // triangles with unknown leaves, away from the border: the in-texture path
  }
}

// Nodes and leaves whole periods to the right of / below the texture (non-negative coordinates, as repeating UVs of
// real foliage and ground quads are) are sampled in the texture, moved back by whole periods (exact, so the same
// texels, weights and rounding). Oracle: the same texel coordinates in a texture holding four periods of the first
// (texel (x, y) = the first's texel at the wrapped (x, y); UVs / 4), where they lie inside and nothing is moved:
// identical maps, for repeat and mirrored repeat, both filters.
TEST(Classifier, PeriodShiftedSamplerAgreesWithTiledTexture) {
  std::mt19937 rng(59);
  std::uniform_real_distribution<double> d(0.0, 1.0);
  const uint32_t size = 64, big = 4 * size;
  const std::vector<uint8_t> texels = leafBlobTexels(size, 0.29, 0.2, 0.33, rng);
  const AlphaTexture tex = AlphaTexture::fromUInt8(size, size, texels);
  for (Wrap w : {Wrap::Repeat, Wrap::MirroredRepeat}) {
    std::vector<uint8_t> tiled(size_t(big) * big);
    for (uint32_t y = 0; y < big; ++y)
      for (uint32_t x = 0; x < big; ++x)
        tiled[size_t(y) * big + x] = texels[size_t(wrapTexel(y, size, w)) * size + wrapTexel(x, size, w)];
    const AlphaTexture bigTex = AlphaTexture::fromUInt8(big, big, tiled);
    for (Filter f : {Filter::Linear, Filter::Nearest}) {
      const AlphaMask mask(tex, Sampler{w, w, f}, 0.5f);
      const AlphaMask bigMask(bigTex, Sampler{Wrap::Repeat, Wrap::Repeat, f}, 0.5f);
      const float period = w == Wrap::Repeat ? 1.0f : 2.0f;  // in UV units of the first texture
      int unknown = 0;
      for (int t = 0; t < 1500; ++t) {
        const double scale = 0.3 + 5.7 * d(rng) * d(rng);  // texels
        const double cx = 0.2 + (size - 0.4) * d(rng), cy = 0.2 + (size - 0.4) * d(rng);
        std::array<float, 2> right[3], quarter[3];
        for (int k = 0; k < 3; ++k) {
          const double x = std::clamp(cx + scale * (d(rng) - 0.5), 0.05, size - 0.05);
          const double y = std::clamp(cy + scale * (d(rng) - 0.5), 0.05, size - 0.05);
          const float u = float(std::round(x / size * 65536) / 65536),
                      v = float(std::round(y / size * 65536) / 65536);
          right[k] = {u + period, v + period * float(t % 2)};  // exact: multiples of 2^-16 below 8
          quarter[k] = {right[k][0] / 4, right[k][1] / 4};     // exact: the same texel coordinates in bigTex
        }
        SCOPED_TRACE(::testing::Message() << "wrap " << int(w) << " filter " << int(f) << " triangle " << t);
        const uint32_t level = 3 + uint32_t(t % 5);
        const TriangleBake a = bakeTriangle(mask, right[0], right[1], right[2], level, Format::FourState);
        const TriangleBake b =
            bakeTriangle(bigMask, quarter[0], quarter[1], quarter[2], level, Format::FourState);
        ASSERT_EQ(a.unknownCount, b.unknownCount);
        ASSERT_TRUE(a.map.bytes().size() == b.map.bytes().size() &&
                    std::equal(a.map.bytes().begin(), a.map.bytes().end(), b.map.bytes().begin()));
        unknown += a.unknownCount > 0;
      }
      EXPECT_GT(unknown, 150);  // maps with unknown leaves: classified below the root, where the samples are
    }
  }
}

TEST(Tightness, HalfPlaneNearestLeavesOnlyStraddlersUnknown) {
  const AlphaTexture tex = makeTexture(64, 64, [](uint32_t x, uint32_t) { return x < 32 ? 1.0 : 0.0; });
  const AlphaMask mask(tex, Sampler{Wrap::ClampToEdge, Wrap::ClampToEdge, Filter::Nearest}, 0.5f);
  const double P[3][2] = {{3.06, 4.99}, {61.42, 12.51}, {18.9, 60.3}};  // texel space
  const uint32_t level = 6;
  const TriangleBake b = bakeTriangle(mask, {float(P[0][0] / 64), float(P[0][1] / 64)},
                                      {float(P[1][0] / 64), float(P[1][1] / 64)},
                                      {float(P[2][0] / 64), float(P[2][1] / 64)}, level, Format::FourState);
  uint64_t straddlers = 0;
  for (uint32_t i = 0; i < b.map.size(); ++i) {
    const MicroTriangle m = indexToMicroTriangle(i, level);
    double lo = 1e9, hi = -1e9;
    for (const GridPoint& g : m.v) {
      const double u = g.u / 64.0, v = g.v / 64.0;
      const double x = P[0][0] + u * (P[1][0] - P[0][0]) + v * (P[2][0] - P[0][0]);
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    // No micro-vertex lies within 0.01 texel of the edge, so "straddles" does not depend on the margin.
    ASSERT_FALSE(std::fabs(lo - 32) < 0.01 || std::fabs(hi - 32) < 0.01) << i;
    const bool straddles = lo < 32 && hi > 32;
    straddlers += straddles;
    const State s = b.map.get(i);
    EXPECT_EQ(!isKnown(s), straddles) << i;
    if (!straddles) {
      EXPECT_EQ(s, hi < 32 ? State::Opaque : State::Transparent) << i;
    }
  }
  EXPECT_EQ(b.unknownCount, straddlers);
  EXPECT_GT(straddlers, 60u);
  EXPECT_LT(straddlers, 200u);  // ~2^level along the edge, out of 4096
}

// Linear: the blend ramps from 1 to 0 between the texel centres 31.5 and 32.5 and crosses the cutoff 0.5 at x
// = 32. The exact bilinear bound leaves exactly the micro-triangles whose x-extent straddles 32 unknown (a
// bound by the four corner texels alone would leave every micro-triangle touching the ramp [31.5, 32.5]
// unknown).
TEST(Tightness, HalfPlaneLinearUnknownOnlyAcrossTheIsoLine) {
  const AlphaTexture tex = makeTexture(64, 64, [](uint32_t x, uint32_t) { return x < 32 ? 1.0 : 0.0; });
  const AlphaMask mask(tex, Sampler{Wrap::ClampToEdge, Wrap::ClampToEdge, Filter::Linear}, 0.5f);
  const double P[3][2] = {{3.06, 4.99}, {61.42, 12.51}, {18.9, 60.3}};
  const uint32_t level = 6;
  const TriangleBake b = bakeTriangle(mask, {float(P[0][0] / 64), float(P[0][1] / 64)},
                                      {float(P[1][0] / 64), float(P[1][1] / 64)},
                                      {float(P[2][0] / 64), float(P[2][1] / 64)}, level, Format::FourState);
  uint64_t straddlers = 0, onRamp = 0;
  for (uint32_t i = 0; i < b.map.size(); ++i) {
    const MicroTriangle m = indexToMicroTriangle(i, level);
    double lo = 1e9, hi = -1e9;
    for (const GridPoint& g : m.v) {
      const double x = P[0][0] + g.u / 64.0 * (P[1][0] - P[0][0]) + g.v / 64.0 * (P[2][0] - P[0][0]);
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    ASSERT_FALSE(std::fabs(lo - 32) < 0.01 || std::fabs(hi - 32) < 0.01) << i;
    const bool straddles = lo < 32 && hi > 32;
    straddlers += straddles;
    onRamp += hi > 31.5 && lo < 32.5;
    const State s = b.map.get(i);
    EXPECT_EQ(!isKnown(s), straddles) << i;
    if (!straddles) {
      EXPECT_EQ(s, hi < 32 ? State::Opaque : State::Transparent) << i;
    }
  }
  EXPECT_EQ(b.unknownCount, straddlers);
  EXPECT_LT(2 * straddlers, onRamp);
}

TEST(Tightness, UnknownMajorityFollowsCoverage) {
  // Micro-triangles straddling the edge mostly on the opaque side are unknown-opaque, and vice versa.
  const AlphaTexture tex = makeTexture(8, 8, [](uint32_t x, uint32_t) { return x < 4 ? 1.0 : 0.0; });
  const AlphaMask mask(tex, Sampler{Wrap::ClampToEdge, Wrap::ClampToEdge, Filter::Nearest}, 0.5f);
  // Level 0: one micro-triangle = the whole triangle, in texel space x from 1 to 4.2 (mostly opaque) or 3.8
  // to 7.
  EXPECT_EQ(bakeTriangle(mask, {1 / 8.f, 0}, {4.2f / 8, 0}, {1 / 8.f, 1}, 0, Format::FourState).map.get(0),
            State::UnknownOpaque);
  EXPECT_EQ(bakeTriangle(mask, {3.8f / 8, 0}, {7 / 8.f, 0}, {7 / 8.f, 1}, 0, Format::FourState).map.get(0),
            State::UnknownTransparent);
}

Geometry randomGeometry(uint32_t triangles, uint32_t seed, float spread = 0.15f) {
  Geometry g;
  g.name = "random";
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> c(-0.2f, 1.2f), d(-spread, spread);
  for (uint32_t t = 0; t < triangles; ++t) {
    const float x = c(rng), y = c(rng);
    for (int k = 0; k < 3; ++k) {
      g.uvs.push_back(x + d(rng));
      g.uvs.push_back(y + d(rng));
      g.positions.insert(g.positions.end(), {0, 0, 0});
      g.indices.push_back(3 * t + uint32_t(k));
    }
  }
  return g;
}

Material discMaterial(uint32_t size = 64, Filter f = Filter::Linear) {
  Material m;
  m.name = "disc";
  m.alphaMode = AlphaMode::Mask;
  m.alphaCutoff = 0.5f;
  m.sampler = Sampler{Wrap::Repeat, Wrap::MirroredRepeat, f};
  m.alpha = std::make_shared<AlphaTexture>(makeTexture(size, size, [size](uint32_t x, uint32_t y) {
    const double dx = (x + 0.5) / size - 0.5, dy = (y + 0.5) / size - 0.5;
    const double r = std::sqrt(dx * dx + dy * dy) + 0.03 * std::sin(x * 0.7) * std::cos(y * 1.3);
    return std::clamp(1.0 - (r - 0.3) * 10, 0.0, 1.0);
  }));
  return m;
}

TEST(BakeGeometry, IdenticalBytesForAnyThreadCount) {
  const Geometry g = randomGeometry(3000, 11);
  const Material m = discMaterial();
  for (Format f : {Format::FourState, Format::TwoState}) {
    BakeOptions o;
    o.level = 5;
    o.format = f;
    o.threads = 1;
    auto one = bakeGeometry(g, m, o);
    ASSERT_TRUE(one.ok()) << one.error().message;
    EXPECT_GT(one->stats.uniqueMaps, 100u);
    EXPECT_GT(
        one->stats.specialCount[size_t(State::Opaque)] + one->stats.specialCount[size_t(State::Transparent)],
        100u);
    for (uint32_t threads : {2u, 4u, 0u}) {
      o.threads = threads;
      auto many = bakeGeometry(g, m, o);
      ASSERT_TRUE(many.ok());
      EXPECT_EQ(many->array.data, one->array.data) << threads;
      EXPECT_EQ(many->array.descriptorBytes(), one->array.descriptorBytes()) << threads;
      EXPECT_EQ(many->array.indexBufferBytes(), one->array.indexBufferBytes()) << threads;
      EXPECT_EQ(many->stats.unknownMicroTriangles, one->stats.unknownMicroTriangles);
    }
  }
}

TEST(BakeGeometry, ArrayMatchesPerTriangleBakeAndStats) {
  const Geometry g = randomGeometry(500, 3);
  const Material m = discMaterial(32, Filter::Nearest);
  BakeOptions o;
  o.level = 4;
  auto r = bakeGeometry(g, m, o);
  ASSERT_TRUE(r.ok());
  const AlphaMask mask(*m.alpha, m.sampler, m.alphaCutoff);
  uint64_t unknown = 0;
  std::array<uint64_t, 4> special{};
  for (uint32_t t = 0; t < g.triangleCount(); ++t) {
    const TriangleBake b =
        bakeTriangle(mask, {g.uvs[6 * t], g.uvs[6 * t + 1]}, {g.uvs[6 * t + 2], g.uvs[6 * t + 3]},
                     {g.uvs[6 * t + 4], g.uvs[6 * t + 5]}, 4, Format::FourState);
    unknown += b.unknownCount;
    for (uint32_t i = 0; i < b.map.size(); ++i)
      ASSERT_EQ(r->array.state(t, i), b.map.get(i)) << t << " " << i;
    if (auto u = b.map.uniformState()) ++special[size_t(*u)];
  }
  EXPECT_EQ(r->stats.unknownMicroTriangles, unknown);
  EXPECT_EQ(r->stats.specialCount, special);
  EXPECT_EQ(r->stats.triangles, 500u);
  EXPECT_EQ(r->stats.microTriangles, 500u * 256);
  EXPECT_EQ(r->stats.dataBytes, r->array.data.size());
  EXPECT_EQ(r->stats.uniqueMaps, r->array.descriptors.size());
  EXPECT_EQ(r->stats.minLevel, 4u);
  EXPECT_EQ(r->stats.maxLevel, 4u);
}

TEST(BakeGeometry, TwoStateIsFourStateDemoted) {
  const Geometry g = randomGeometry(400, 8);
  const Material m = discMaterial();
  const AlphaMask mask(*m.alpha, m.sampler, m.alphaCutoff);
  uint64_t unknownSeen = 0;
  for (uint32_t t = 0; t < g.triangleCount(); ++t) {
    const std::array<float, 2> a{g.uvs[6 * t], g.uvs[6 * t + 1]}, b{g.uvs[6 * t + 2], g.uvs[6 * t + 3]},
        c{g.uvs[6 * t + 4], g.uvs[6 * t + 5]};
    const Micromap four = bakeTriangle(mask, a, b, c, 4, Format::FourState).map;
    EXPECT_EQ(bakeTriangle(mask, a, b, c, 4, Format::TwoState).map, four.toTwoStateMap());
    const Micromap asOpaque = bakeTriangle(mask, a, b, c, 4, Format::TwoState, UnknownAs::Opaque).map;
    const Micromap asTransparent =
        bakeTriangle(mask, a, b, c, 4, Format::TwoState, UnknownAs::Transparent).map;
    for (uint32_t i = 0; i < four.size(); ++i) {
      const State s = four.get(i);
      unknownSeen += !isKnown(s);
      EXPECT_EQ(asOpaque.get(i), isKnown(s) ? s : State::Opaque);
      EXPECT_EQ(asTransparent.get(i), isKnown(s) ? s : State::Transparent);
    }
  }
  EXPECT_GT(unknownSeen, 1000u);
}

TEST(BakeGeometry, AdaptiveLevelsExact) {
  // 64×64 texture, S = 4 texels: level L when area ≤ 4·4^L. Right triangles with legs a texels have area
  // a²/2.
  Material m = discMaterial(64);
  Geometry g;
  auto add = [&](float legTexels, float x0) {
    const float l = legTexels / 64, x = x0 / 64;
    const uint32_t base = uint32_t(g.uvs.size() / 2);
    g.uvs.insert(g.uvs.end(), {x, 0.1f, x + l, 0.1f, x, 0.1f + l});
    g.indices.insert(g.indices.end(), {base, base + 1, base + 2});
  };
  add(1, 0);                                                        // area 0.5  → 0
  add(2.9f, 5);                                                     // 4.2 → 1
  add(8, 9);                                                        // 32 → 2 (16 < 32 ≤ 64)
  add(16, 20);                                                      // 128 → 3
  add(45, 3);                                                       // 1012.5 → 4 (≤ 1024)
  add(64, 0);                                                       // 2048 → 5, capped at 4
  g.uvs.insert(g.uvs.end(), {0.2f, 0.2f, 0.4f, 0.4f, 0.6f, 0.6f});  // zero area → 0
  g.indices.insert(g.indices.end(), {18, 19, 20});
  BakeOptions o;
  o.texelsPerMicroTri = 4;
  o.maxLevel = 4;
  auto r = bakeGeometry(g, m, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->levels, (std::vector<uint8_t>{0, 1, 2, 3, 4, 4, 0}));
  EXPECT_EQ(adaptiveLevel({0, 0}, {1, 0}, {0, 1}, 64, 64, 4, 12), 5u);         // 2048 texels
  EXPECT_EQ(adaptiveLevel({0, 0}, {0.5f, 0}, {0, 0.25f}, 64, 64, 4, 12), 3u);  // 256 = 4·4^3 exactly
  EXPECT_EQ(adaptiveLevel({0, 0}, {NAN, 0}, {0, 1}, 64, 64, 4, 12), 0u);
  for (uint32_t t = 0; t < g.triangleCount(); ++t) {
    const int32_t i = r->array.indices[t];
    if (i >= 0) {
      EXPECT_EQ(r->array.descriptors[size_t(i)].subdivisionLevel, r->levels[t]);
    }
  }
  auto e = estimateBake(g, m, o);
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->dataBytes, micromapDataBytes(1, Format::FourState) + micromapDataBytes(2, Format::FourState) +
                              micromapDataBytes(3, Format::FourState) +
                              2 * micromapDataBytes(4, Format::FourState));
  EXPECT_EQ(e->mapTriangles, 5u);
}

TEST(BakeGeometry, MaxBytesRespected) {
  const Geometry g = randomGeometry(800, 21, 0.3f);
  const Material m = discMaterial(128);
  BakeOptions o;
  o.level = 6;
  auto full = bakeGeometry(g, m, o);
  ASSERT_TRUE(full.ok());
  auto est = estimateBake(g, m, o);
  ASSERT_TRUE(est.ok());
  EXPECT_LE(full->stats.dataBytes, est->dataBytes);
  EXPECT_EQ(full->stats.levelCap, kMaxLevel);
  for (uint64_t budget : {full->stats.dataBytes, full->stats.dataBytes / 3, uint64_t(5000), uint64_t(1)}) {
    o.maxBytes = budget;
    auto r = bakeGeometry(g, m, o);
    ASSERT_TRUE(r.ok());
    EXPECT_LE(r->array.data.size(), budget);
    for (uint8_t l : r->levels) EXPECT_LE(l, r->stats.levelCap);
    if (budget == full->stats.dataBytes) {
      EXPECT_EQ(r->array.data, full->array.data);  // already fits: unchanged
    } else {
      EXPECT_LT(r->stats.levelCap, 6u);
      // The highest cap that fits: one level more would not.
      BakeOptions more = o;
      more.maxBytes = 0;
      more.level = r->stats.levelCap + 1;
      auto above = bakeGeometry(g, m, more);
      ASSERT_TRUE(above.ok());
      EXPECT_GT(above->array.data.size(), budget);
    }
  }
}

TEST(BakeGeometry, ConstantAlphaAndOpaqueMaterials) {
  const Geometry g = randomGeometry(10, 1);
  Material m;
  m.alphaMode = AlphaMode::Mask;
  m.baseColorFactor = {1, 1, 1, 0.4f};
  BakeOptions o;
  auto r = bakeGeometry(g, m, o);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->array.indices, std::vector<int32_t>(10, specialIndexFor(State::Transparent)));
  o.cutoff = 0.4f;
  r = bakeGeometry(g, m, o);
  EXPECT_EQ(r->array.indices, std::vector<int32_t>(10, specialIndexFor(State::Opaque)));
  m = discMaterial();
  m.alphaMode = AlphaMode::Opaque;
  r = bakeGeometry(g, m, o);
  EXPECT_EQ(r->array.indices, std::vector<int32_t>(10, specialIndexFor(State::Opaque)));
  EXPECT_TRUE(r->array.data.empty());
  EXPECT_EQ(r->stats.specialCount[size_t(State::Opaque)], 10u);
}

TEST(BakeGeometry, NonFiniteUvsAreWholeTriangleUnknown) {
  Geometry g = randomGeometry(6, 2);
  g.uvs[0] = NAN;
  g.uvs[9] = INFINITY;
  g.uvs[17] = -INFINITY;
  const Material m = discMaterial();
  BakeOptions o;
  o.level = 3;
  auto r = bakeGeometry(g, m, o);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->stats.nonFiniteUvTriangles, 3u);
  for (uint32_t t : {0u, 1u, 2u}) EXPECT_EQ(r->array.indices[t], specialIndexFor(State::UnknownOpaque));
  EXPECT_NE(r->array.indices[3], specialIndexFor(State::UnknownOpaque));
  EXPECT_GE(r->stats.unknownMicroTriangles, 3u * 64);
  o.format = Format::TwoState;
  o.unknownAs = UnknownAs::Transparent;
  r = bakeGeometry(g, m, o);
  EXPECT_EQ(r->array.indices[0], specialIndexFor(State::Transparent));
  // Finite but absurdly large UVs (beyond the texel range sampleAlpha interpolates in) are unknown too.
  const AlphaMask mask(*m.alpha, m.sampler, 0.5f);
  const TriangleBake big =
      bakeTriangle(mask, {3e12f, 0}, {3e12f + 1e6f, 0}, {3e12f, 1}, 2, Format::FourState);
  EXPECT_TRUE(big.nonFiniteUv);
  EXPECT_EQ(big.map.uniformState(), State::UnknownOpaque);
  EXPECT_EQ(big.unknownCount, 16u);
}

TEST(BakeGeometry, ZeroAreaTrianglesClassifiedFromWhatTheyTouch) {
  const AlphaTexture tex =
      makeTexture(4, 4, [](uint32_t x, uint32_t y) { return (x == 1 && y == 1) ? 1.0 : 0.0; });
  const AlphaMask mask(tex, Sampler{Wrap::Repeat, Wrap::Repeat, Filter::Nearest}, 0.5f);
  // A point inside the opaque texel, a point in a transparent one, a segment inside texel (1,1), one leaving
  // it.
  EXPECT_EQ(
      bakeTriangle(mask, {0.3f, 0.3f}, {0.3f, 0.3f}, {0.3f, 0.3f}, 3, Format::FourState).map.uniformState(),
      State::Opaque);
  EXPECT_EQ(
      bakeTriangle(mask, {0.8f, 0.3f}, {0.8f, 0.3f}, {0.8f, 0.3f}, 3, Format::FourState).map.uniformState(),
      State::Transparent);
  EXPECT_EQ(
      bakeTriangle(mask, {0.26f, 0.3f}, {0.49f, 0.3f}, {0.4f, 0.3f}, 3, Format::FourState).map.uniformState(),
      State::Opaque);
  const Micromap seg = bakeTriangle(mask, {0.3f, 0.3f}, {0.7f, 0.3f}, {0.5f, 0.3f}, 2, Format::FourState).map;
  EXPECT_FALSE(seg.uniformState().has_value());
  EXPECT_EQ(seg.get(0), State::Opaque);  // the micro-triangle at vertex 0 stays inside texel (1, 1)
}

TEST(BakeGeometry, RejectsBadInput) {
  const Material m = discMaterial();
  Geometry g = randomGeometry(3, 1);
  BakeOptions o;
  o.level = 13;
  auto r = bakeGeometry(g, m, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("level 13 is out of range (0..12)"), std::string::npos);
  o.level = 2;
  g.indices.push_back(99);
  g.indices.push_back(0);
  g.indices.push_back(1);
  r = bakeGeometry(g, m, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("out of range"), std::string::npos);
  g.indices.pop_back();
  r = bakeGeometry(g, m, o);
  ASSERT_FALSE(r.ok());
  Material bad = m;
  auto tex = std::make_shared<AlphaTexture>(*m.alpha);
  tex->alpha.pop_back();
  bad.alpha = tex;
  r = bakeGeometry(randomGeometry(3, 1), bad, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("material 'disc'"), std::string::npos);
}

TEST(BakeGeometry, SharedMaskGivesTheSameBake) {
  const Geometry g = randomGeometry(300, 6);
  const Material m = discMaterial();
  BakeOptions o;
  o.level = 4;
  o.filter = Filter::Nearest;
  o.cutoff = 0.3f;
  auto own = bakeGeometry(g, m, o);
  ASSERT_TRUE(own.ok());
  Sampler smp = m.sampler;
  smp.filter = Filter::Nearest;
  const AlphaMask mask(*m.alpha, smp, 0.3f);
  auto shared = bakeGeometry(g, m, &mask, o);
  ASSERT_TRUE(shared.ok());
  EXPECT_EQ(shared->array.data, own->array.data);
  EXPECT_EQ(shared->array.indices, own->array.indices);
  auto missing = bakeGeometry(g, m, nullptr, o);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("material 'disc'"), std::string::npos);
}

TEST(BakeGeometry, ProgressReachesOne) {
  const Geometry g = randomGeometry(9000, 4);
  const Material m = discMaterial();
  BakeOptions o;
  o.level = 2;
  std::vector<double> seen;
  o.progress = [&](double f) { seen.push_back(f); };
  ASSERT_TRUE(bakeGeometry(g, m, o).ok());
  ASSERT_GE(seen.size(), 2u);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(seen.back(), 1.0);
  // With re-bakes for maxBytes the progress stays monotone and ends at 1.
  seen.clear();
  o.level = 5;
  o.maxBytes = 2000;
  auto r = bakeGeometry(g, m, o);
  ASSERT_TRUE(r.ok());
  EXPECT_LT(r->stats.levelCap, 4u);  // several passes
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(seen.back(), 1.0);
  EXPECT_LE(r->array.data.size(), 2000u);
}

}  // namespace
}  // namespace somm
