// SPDX-License-Identifier: MIT
// Test helpers for the baker: procedural alpha textures and an alpha sampler written independently of
// texture.h.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "somm/bird.h"
#include "somm/micromap.h"
#include "somm/texture.h"

namespace somm::testing {

// Texel index → [0, n) by the wrap rules, with floor division rather than texture.h's remainder arithmetic.
inline int64_t refWrap(int64_t i, int64_t n, Wrap w) {
  const auto floorDiv = [](int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); };
  switch (w) {
    case Wrap::Repeat:
      return i - floorDiv(i, n) * n;
    case Wrap::ClampToEdge:
      return i < 0 ? 0 : (i > n - 1 ? n - 1 : i);
    case Wrap::MirroredRepeat: {
      const int64_t k = floorDiv(i, n), r = i - k * n;
      return (k & 1) ? n - 1 - r : r;
    }
  }
  return 0;
}

// The alpha at texture coordinate (s, t): nearest = the texel containing (s·W, t·H); linear = the bilinear
// blend of the four texels around (s·W − ½, t·H − ½), as a weighted sum of four products, rounded to float at
// the end.
inline float refAlpha(const AlphaTexture& tex, const Sampler& smp, float s, float t) {
  const double x = double(s) * tex.width, y = double(t) * tex.height;
  const int64_t W = tex.width, H = tex.height;
  auto texel = [&](int64_t i, int64_t j) {
    return double(tex.texel(size_t(refWrap(j, H, smp.wrapT) * W + refWrap(i, W, smp.wrapS))));
  };
  if (smp.filter == Filter::Nearest) return float(texel(int64_t(std::floor(x)), int64_t(std::floor(y))));
  const double gx = std::floor(x - 0.5), gy = std::floor(y - 0.5);
  const double fx = (x - 0.5) - gx, fy = (y - 0.5) - gy;
  const int64_t i = int64_t(gx), j = int64_t(gy);
  const double v = texel(i, j) * (1 - fx) * (1 - fy) + texel(i + 1, j) * fx * (1 - fy) +
                   texel(i, j + 1) * (1 - fx) * fy + texel(i + 1, j + 1) * fx * fy;
  return float(v);
}

struct NamedTexture {
  std::string name;
  AlphaTexture tex;
};

inline AlphaTexture makeTexture(uint32_t w, uint32_t h, auto&& f) {
  AlphaTexture t;
  t.width = w;
  t.height = h;
  t.alpha.resize(size_t(w) * h);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) t.alpha[size_t(y) * w + x] = float(f(x, y));
  return t;
}

// Discs, noise, single-texel specks, hard stripes, checkerboards; odd sizes so that wrap seams matter.
inline std::vector<NamedTexture> proceduralTextures() {
  std::vector<NamedTexture> v;
  v.push_back({"disc", makeTexture(32, 24, [](uint32_t x, uint32_t y) {
                 const double dx = (x + 0.5) / 32 - 0.45, dy = (y + 0.5) / 24 - 0.55;
                 const double r = std::sqrt(dx * dx + dy * dy);
                 return std::clamp(1.0 - (r - 0.25) * 8, 0.0, 1.0);  // soft rim: intermediate alphas
               })});
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> d(0.f, 1.f);
  std::vector<float> noise(17 * 13);
  for (float& a : noise) a = d(rng);
  v.push_back({"noise", makeTexture(17, 13, [&](uint32_t x, uint32_t y) { return noise[y * 17 + x]; })});
  v.push_back({"specks", makeTexture(20, 20, [](uint32_t x, uint32_t y) {
                 return ((x == 3 && y == 4) || (x == 19 && y == 0) || (x == 10 && y == 17)) ? 1.0 : 0.0;
               })});
  v.push_back({"holes", makeTexture(16, 16, [](uint32_t x, uint32_t y) {
                 return ((x == 0 && y == 0) || (x == 9 && y == 5) || (x == 15 && y == 15)) ? 0.0 : 1.0;
               })});
  v.push_back({"stripes", makeTexture(24, 8, [](uint32_t x, uint32_t) { return (x / 3) % 2 ? 1.0 : 0.0; })});
  v.push_back({"checker", makeTexture(8, 8, [](uint32_t x, uint32_t y) { return (x + y) % 2 ? 1.0 : 0.0; })});
  v.push_back({"cutoff-exact", makeTexture(9, 7, [](uint32_t x, uint32_t y) {
                 return (x * 7 + y * 3) % 5 == 0
                            ? 0.5
                            : ((x + y) % 3 ? 0.75 : 0.25);  // texels exactly at the cutoff
               })});
  return v;
}

// The UV point a ray tracer computes from hit barycentrics (b1, b2): weighted sum of the three UVs in float.
inline void interpolateUV(const float uv[3][2], float b1, float b2, float& s, float& t) {
  const float b0 = 1.0f - b1 - b2;
  s = b0 * uv[0][0] + b1 * uv[1][0] + b2 * uv[2][0];
  t = b0 * uv[0][1] + b1 * uv[1][1] + b2 * uv[2][1];
}

// Barycentric points of the closed micro-triangle `index`: its vertices, points on its edges and random
// interior points.
inline std::vector<std::pair<float, float>> pointsIn(uint32_t index, uint32_t level, std::mt19937& rng,
                                                     int interior) {
  const MicroTriangle m = indexToMicroTriangle(index, level);
  const double s = 1.0 / double(1u << level);
  double u[3], v[3];
  for (int k = 0; k < 3; ++k) {
    u[k] = m.v[k].u * s;
    v[k] = m.v[k].v * s;
  }
  std::vector<std::pair<float, float>> p;
  std::uniform_real_distribution<double> d(0, 1);
  for (int k = 0; k < 3; ++k) {
    p.emplace_back(float(u[k]), float(v[k]));
    const int k1 = (k + 1) % 3;
    const double a = d(rng);
    p.emplace_back(float(u[k] + a * (u[k1] - u[k])), float(v[k] + a * (v[k1] - v[k])));
  }
  for (int i = 0; i < interior; ++i) {
    double a = d(rng), b = d(rng);
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    p.emplace_back(float(u[0] + a * (u[1] - u[0]) + b * (u[2] - u[0])),
                   float(v[0] + a * (v[1] - v[0]) + b * (v[2] - v[0])));
  }
  return p;
}

struct CheckCounts {
  uint64_t known = 0, unknown = 0, points = 0, failures = 0;
};

// Every point of every known micro-triangle must agree with the alpha test, evaluated both by the independent
// sampler and by texture.h; the state a tracer reads at the point's barycentrics (baryToIndex) must agree
// too.
inline void checkMap(const AlphaTexture& tex, const Sampler& smp, float cutoff, const float uv[3][2],
                     const Micromap& map, std::mt19937& rng, int interior, const std::string& what,
                     CheckCounts& counts) {
  const uint32_t level = map.level();
  for (uint32_t i = 0; i < map.size(); ++i) {
    const State s = map.get(i);
    if (!isKnown(s)) {
      ++counts.unknown;
      continue;
    }
    ++counts.known;
    for (const auto& [b1, b2] : pointsIn(i, level, rng, interior)) {
      float S, T;
      interpolateUV(uv, b1, b2, S, T);
      const bool ref = refAlpha(tex, smp, S, T) >= cutoff;
      const bool lib = alphaTestPasses(sampleAlpha(tex, smp, S, T), cutoff);
      const State traced = map.get(baryToIndex(b1, b2, level));
      ++counts.points;
      const bool bad =
          ref != (s == State::Opaque) || lib != ref || (isKnown(traced) && (traced == State::Opaque) != ref);
      if (bad && ++counts.failures <= 5)
        ADD_FAILURE() << what << ": micro-triangle " << i << " (level " << level << ") is " << int(s)
                      << " but the alpha test at bary (" << b1 << ", " << b2 << ") uv (" << S << ", " << T
                      << ") gives ref " << ref << " lib " << lib << ", traced state " << int(traced);
    }
  }
}

}  // namespace somm::testing
