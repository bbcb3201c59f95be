// SPDX-License-Identifier: MIT
// Procedural textures and scenes: exact values, determinism, invariants.
#include "somm/procedural.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <set>
#include <vector>

namespace {

double coverage(const somm::AlphaTexture& t) {
  double s = 0;
  for (float a : t.alpha) s += a;
  return s / double(t.alpha.size());
}

TEST(Procedural, Disc) {
  const somm::AlphaTexture t = somm::makeDiscTexture(64);
  ASSERT_EQ(t.width, 64u);
  ASSERT_EQ(t.height, 64u);
  EXPECT_EQ(t.at(32, 32), 1.0f);
  EXPECT_EQ(t.at(0, 0), 0.0f);
  EXPECT_EQ(t.at(63, 63), 0.0f);
  EXPECT_EQ(t.at(32, 2), 0.0f);  // above the disc (radius 24)
  EXPECT_EQ(t.at(32, 12), 1.0f);
  // Area close to pi r^2 and the edge has intermediate values.
  EXPECT_NEAR(coverage(t) * 64 * 64, std::numbers::pi * 24 * 24, 20.0);
  size_t partial = 0;
  for (float a : t.alpha) partial += a > 0.0f && a < 1.0f;
  EXPECT_GT(partial, 0u);
}

TEST(Procedural, CheckerStripesSpecks) {
  const somm::AlphaTexture c = somm::makeCheckerTexture(16, 4);
  EXPECT_EQ(c.at(0, 0), 1.0f);
  EXPECT_EQ(c.at(4, 0), 0.0f);
  EXPECT_EQ(c.at(4, 4), 1.0f);
  EXPECT_EQ(c.at(3, 7), 0.0f);
  EXPECT_DOUBLE_EQ(coverage(c), 0.5);
  const somm::AlphaTexture s = somm::makeStripeTexture(16, 4);
  for (uint32_t y = 0; y < 16; ++y) {
    EXPECT_EQ(s.at(0, y), 1.0f);
    EXPECT_EQ(s.at(1, y), 1.0f);
    EXPECT_EQ(s.at(2, y), 0.0f);
    EXPECT_EQ(s.at(7, y), 0.0f);
  }
  const somm::AlphaTexture p = somm::makeSpeckTexture(32, 10, 7);
  size_t ones = 0, zeros = 0;
  for (float a : p.alpha) (a == 1.0f ? ones : zeros) += 1;
  EXPECT_EQ(ones, 10u);
  EXPECT_EQ(zeros, 32u * 32u - 10u);
  EXPECT_EQ(somm::makeSpeckTexture(32, 10, 7).alpha, p.alpha);
  EXPECT_NE(somm::makeSpeckTexture(32, 10, 8).alpha, p.alpha);
}

TEST(Procedural, NoiseIsDeterministicSmoothAndInRange) {
  const somm::AlphaTexture a = somm::makeNoiseTexture(64, 1, 8);
  EXPECT_EQ(a.alpha, somm::makeNoiseTexture(64, 1, 8).alpha);
  EXPECT_NE(a.alpha, somm::makeNoiseTexture(64, 2, 8).alpha);
  float lo = 1, hi = 0, maxStep = 0;
  for (uint32_t y = 0; y < 64; ++y)
    for (uint32_t x = 0; x < 64; ++x) {
      lo = std::min(lo, a.at(x, y)), hi = std::max(hi, a.at(x, y));
      maxStep = std::max(maxStep, std::abs(a.at(x, y) - a.at((x + 1) % 64, y)));  // includes the tiling seam
      maxStep = std::max(maxStep, std::abs(a.at(x, y) - a.at(x, (y + 1) % 64)));
    }
  EXPECT_GE(lo, 0.0f);
  EXPECT_LE(hi, 1.0f);
  EXPECT_GT(hi - lo, 0.3f);
  EXPECT_LT(maxStep, 0.35f);  // smooth, and seamless across the wrap
}

TEST(Procedural, LeafSilhouettes) {
  const somm::AlphaTexture leaf = somm::makeLeafTexture(128);
  const double cov = coverage(leaf);
  EXPECT_GT(cov, 0.25);
  EXPECT_LT(cov, 0.55);
  for (float a : leaf.alpha) EXPECT_TRUE(a == 0.0f || a == 1.0f);
  EXPECT_EQ(leaf.at(64, 64), 1.0f);  // centre of the blade
  EXPECT_EQ(leaf.at(0, 0), 0.0f);
  EXPECT_EQ(leaf.at(127, 64), 0.0f);
  EXPECT_EQ(leaf.at(64, 2), 0.0f);    // above the tip
  EXPECT_EQ(leaf.at(64, 115), 1.0f);  // stem
  const somm::AlphaTexture atlas = somm::makeLeafAtlasTexture(256);
  EXPECT_GT(coverage(atlas), 0.2);
  // The four quadrants differ.
  auto quadrant = [&](uint32_t q) {
    std::vector<float> v;
    for (uint32_t y = 0; y < 128; ++y)
      for (uint32_t x = 0; x < 128; ++x) v.push_back(atlas.at((q % 2) * 128 + x, (q / 2) * 128 + y));
    return v;
  };
  for (uint32_t i = 0; i < 4; ++i)
    for (uint32_t j = i + 1; j < 4; ++j) EXPECT_NE(quadrant(i), quadrant(j));
}

TEST(Procedural, QuadScene) {
  auto tex = std::make_shared<const somm::AlphaTexture>(somm::makeStripeTexture(8, 2));
  const somm::Sampler smp{somm::Wrap::ClampToEdge, somm::Wrap::Repeat, somm::Filter::Nearest};
  const somm::Scene s = somm::makeQuadScene(tex, smp, 0.25f, {0, 0, 2, 1});
  ASSERT_EQ(s.geometries.size(), 1u);
  ASSERT_EQ(s.materials.size(), 1u);
  ASSERT_EQ(s.instances.size(), 1u);
  const somm::Geometry& g = s.geometries[0];
  EXPECT_EQ(g.triangleCount(), 2u);
  EXPECT_EQ(g.positions.size(), 12u);
  EXPECT_EQ(g.uvs.size(), 8u);
  const somm::Material& m = s.materials[0];
  EXPECT_TRUE(m.alphaTested());
  EXPECT_EQ(m.alphaCutoff, 0.25f);
  EXPECT_EQ(m.sampler, smp);
  EXPECT_EQ(m.alpha.get(), tex.get());
  // Corner (-1, 1) has uv (0, 0); corner (1, -1) has uv (2, 1).
  for (uint32_t v = 0; v < 4; ++v) {
    const float x = g.positions[v * 3], y = g.positions[v * 3 + 1];
    EXPECT_EQ(g.uvs[v * 2], x < 0 ? 0.0f : 2.0f);
    EXPECT_EQ(g.uvs[v * 2 + 1], y > 0 ? 0.0f : 1.0f);
  }
  ASSERT_TRUE(s.camera.has_value());
  EXPECT_EQ(s.camera->eye[2], 2.5f);
}

TEST(Procedural, LeafCardScene) {
  const somm::Scene s = somm::makeLeafCardScene(100, 42);
  ASSERT_EQ(s.geometries.size(), 1u);
  const somm::Geometry& g = s.geometries[0];
  EXPECT_EQ(g.triangleCount(), 200u);
  EXPECT_EQ(g.positions.size(), 400u * 3);
  EXPECT_EQ(g.uvs.size(), 400u * 2);
  for (uint32_t i : g.indices) EXPECT_LT(i, 400u);
  for (float p : g.positions) EXPECT_LT(std::abs(p), 1.0f + 0.3f * std::sqrt(2.0f) + 1e-5f);
  const somm::Material& m = s.materials[g.material];
  EXPECT_TRUE(m.alphaTested());
  ASSERT_TRUE(m.alpha);
  EXPECT_EQ(m.alpha->width, 512u);
  ASSERT_TRUE(s.camera.has_value());
  // Deterministic, seed-dependent; cards have distinct UVs.
  const somm::Scene s2 = somm::makeLeafCardScene(100, 42);
  EXPECT_EQ(s2.geometries[0].positions, g.positions);
  EXPECT_EQ(s2.geometries[0].uvs, g.uvs);
  EXPECT_NE(somm::makeLeafCardScene(100, 43).geometries[0].positions, g.positions);
  std::set<std::vector<float>> cardUvs;
  for (uint32_t c = 0; c < 100; ++c)
    cardUvs.insert(std::vector<float>(g.uvs.begin() + c * 8, g.uvs.begin() + c * 8 + 8));
  EXPECT_EQ(cardUvs.size(), 100u);
  // Every card is a planar square: both triangles have the same area.
  for (uint32_t t = 0; t < 200; t += 2) {
    auto area = [&](uint32_t tri) {
      const float* a = &g.positions[g.indices[tri * 3] * 3];
      const float* b = &g.positions[g.indices[tri * 3 + 1] * 3];
      const float* c = &g.positions[g.indices[tri * 3 + 2] * 3];
      const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]},
                   v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      const double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2],
                   z = u[0] * v[1] - u[1] * v[0];
      return 0.5 * std::sqrt(x * x + y * y + z * z);
    };
    EXPECT_NEAR(area(t), area(t + 1), 1e-5);
    EXPECT_GT(area(t), 0.5 * 0.25 * 0.25 - 1e-4);
  }
}

}  // namespace
