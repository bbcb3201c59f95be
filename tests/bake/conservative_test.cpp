// SPDX-License-Identifier: MIT
// Conservativeness property tests: points of every micro-triangle (vertices, edges, interior), sampled like a
// ray tracer would (float UV interpolation) and evaluated with an independent sampler, never contradict a
// known state.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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

// The margin's derivation (docs/baking.md "Safety margin"), tested at its bound: (1) the float UV interpolation
// error of the tracer, measured against exact arithmetic, stays below the margin's interpolation term 6·2^-24·P and
// comes within a factor of 6 of it (so the term is not vacuous); (2) the hit points with the largest interpolation
// errors, and barycentrics pushed 2^-20 (the margin's barycentric slack) outside their micro-triangle, never land on
// a known state the alpha test contradicts — on UVs far from the origin (large float errors) and small triangles.
TEST(Conservative, MarginAtItsBound) {
  const auto textures = testing::proceduralTextures();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0, 1);
  double worst = 0;  // largest error / (2^-24 · max |X|)
  uint64_t checked = 0;
  const float offsets[] = {0.0f, 3.37f, -21.6f, 117.2f, 1000.3f};
  const float sizes[] = {0.5f, 2.0f, 9.0f};  // texels
  for (const auto& nt : textures) {
    const double W = nt.tex.width, H = nt.tex.height;
    for (Filter f : {Filter::Nearest, Filter::Linear}) {
      const Sampler smp{Wrap::Repeat, Wrap::MirroredRepeat, f};
      const AlphaMask mask(nt.tex, smp, 0.5f);
      for (float off : offsets)
        for (float size : sizes)
          for (int k = 0; k < 4; ++k) {
            float uv[3][2];
            const double cx = off + unit(rng), cy = off * 0.5 + unit(rng);
            for (int c = 0; c < 3; ++c) {
              uv[c][0] = float(cx + (unit(rng) - 0.5) * size / W);
              uv[c][1] = float(cy + (unit(rng) - 0.5) * size / H);
            }
            double X[3], Y[3], mag = 0;
            for (int c = 0; c < 3; ++c) {
              X[c] = double(uv[c][0]) * W;
              Y[c] = double(uv[c][1]) * H;
              mag = std::max({mag, std::fabs(X[c]), std::fabs(Y[c])});
            }
            int e = 0;
            std::frexp(mag, &e);
            const double interpTerm = 6 * 0x1p-24 * std::ldexp(1.0, e);
            const uint32_t level = 5;
            const TriangleBake b = bakeTriangle(mask, {uv[0][0], uv[0][1]}, {uv[1][0], uv[1][1]},
                                                {uv[2][0], uv[2][1]}, level, Format::FourState);
            // (1) + the points with the largest errors.
            std::vector<std::pair<double, std::pair<float, float>>> errs;
            for (int i = 0; i < 4000; ++i) {
              double a = unit(rng), c = unit(rng);
              if (a + c > 1) a = 1 - a, c = 1 - c;
              const float b1 = float(a), b2 = float(c);
              float S, T;
              interpolateUV(uv, b1, b2, S, T);
              const long double w = 1.0L - (long double)b1 - (long double)b2;
              const long double s = w * uv[0][0] + (long double)b1 * uv[1][0] + (long double)b2 * uv[2][0];
              const long double t = w * uv[0][1] + (long double)b1 * uv[1][1] + (long double)b2 * uv[2][1];
              const double err =
                  double(std::max(std::fabs((long double)S - s) * W, std::fabs((long double)T - t) * H));
              ASSERT_LE(err, interpTerm) << nt.name << " offset " << off;
              worst = std::max(worst, err / (0x1p-24 * mag));
              errs.push_back({err, {b1, b2}});
            }
            std::partial_sort(errs.begin(), errs.begin() + 200, errs.end(),
                              [](const auto& x, const auto& y) { return x.first > y.first; });
            std::vector<std::pair<float, float>> points;
            for (int i = 0; i < 200; ++i) points.push_back(errs[size_t(i)].second);
            // (2) barycentrics 2^-20 outside micro-triangle edges (each vertex pushed away from the centroid).
            for (uint32_t i = 0; i < b.map.size(); ++i) {
              const MicroTriangle m = indexToMicroTriangle(i, level);
              const double sc = 1.0 / double(1u << level);
              double cu = 0, cv = 0;
              for (int c = 0; c < 3; ++c) cu += m.v[c].u * sc / 3, cv += m.v[c].v * sc / 3;
              for (int c = 0; c < 3; ++c) {
                const double u = m.v[c].u * sc, v = m.v[c].v * sc;
                const double du = u - cu, dv = v - cv, len = std::max(std::fabs(du), std::fabs(dv));
                points.emplace_back(float(u + du / len * 0x1p-20), float(v + dv / len * 0x1p-20));
              }
            }
            for (const auto& [b1, b2] : points) {
              const State st = b.map.get(baryToIndex(b1, b2, level));
              if (!isKnown(st)) continue;
              float S, T;
              interpolateUV(uv, b1, b2, S, T);
              ASSERT_EQ(refAlpha(nt.tex, smp, S, T) >= 0.5f, st == State::Opaque)
                  << nt.name << " offset " << off << " bary " << b1 << " " << b2;
              ++checked;
            }
          }
    }
  }
  EXPECT_GT(worst, 1.0);  // the measured error reaches > 1/6 of the margin's interpolation term
  EXPECT_GT(checked, 20000u);
}

}  // namespace
}  // namespace somm
