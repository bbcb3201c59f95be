// SPDX-License-Identifier: MIT
// Real scenes (data/): the oak tree's leaves and glTF's AlphaBlendModeTest, baked and checked point by point.
#include <gtest/gtest.h>

#include <random>

#include "bake/bake_test_util.h"
#include "somm/bake.h"
#include "somm/scene.h"

namespace somm {
namespace {

using testing::CheckCounts;
using testing::checkMap;

const Scene& loadOrDie(const std::string& relative) {
  static std::map<std::string, Scene> cache;
  auto it = cache.find(relative);
  if (it == cache.end()) {
    auto s = loadScene(std::string(SOMM_DATA_DIR) + "/" + relative);
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
    it = cache.emplace(relative, s.ok() ? std::move(s.value()) : Scene{}).first;
  }
  return it->second;
}

// Every micro-triangle of every triangle of the geometry, checked against the alpha test at its vertices,
// edge points and random interior points. Returns the counts.
CheckCounts checkGeometry(const Geometry& g, const Material& m, const BakedGeometry& baked, float cutoff,
                          const Sampler& smp, int interior) {
  CheckCounts counts;
  std::mt19937 rng(17);
  for (uint32_t t = 0; t < g.triangleCount(); ++t) {
    float uv[3][2];
    for (int k = 0; k < 3; ++k) {
      uv[k][0] = g.uvs[2 * size_t(g.indices[3 * t + k])];
      uv[k][1] = g.uvs[2 * size_t(g.indices[3 * t + k]) + 1];
    }
    const uint32_t level = baked.levels[t];
    Micromap map(level, Format::FourState);
    for (uint32_t i = 0; i < map.size(); ++i) map.set(i, baked.array.state(t, i));
    checkMap(*m.alpha, smp, cutoff, uv, map, rng, interior, g.name + " triangle " + std::to_string(t),
             counts);
    if (counts.failures) break;
  }
  return counts;
}

TEST(RealScene, OakTreeLeavesAreConservative) {
  const Scene& s = loadOrDie("oak-tree/oaktree.gltf");
  ASSERT_FALSE(s.geometries.empty());
  bool baked = false;
  for (const Geometry& g : s.geometries) {
    const Material& m = s.materials[g.material];
    if (!m.alphaTested() || !m.alpha) continue;
    for (Filter f : {Filter::Linear, Filter::Nearest}) {
      BakeOptions o;
      o.level = 5;
      o.filter = f;
      auto r = bakeGeometry(g, m, o);
      ASSERT_TRUE(r.ok()) << r.error().message;
      Sampler smp = m.sampler;
      smp.filter = f;
      const CheckCounts c = checkGeometry(g, m, *r, m.alphaCutoff, smp, 2);
      EXPECT_EQ(c.failures, 0u) << g.name;
      EXPECT_GT(c.known, c.unknown) << g.name;
      EXPECT_GT(c.unknown, 0u) << g.name;
      EXPECT_EQ(c.unknown, r->stats.unknownMicroTriangles);
      // Leaves on a card: some triangles are entirely transparent or opaque, many need maps.
      EXPECT_GT(r->stats.uniqueMaps, 0u);
      baked = true;
    }
  }
  EXPECT_TRUE(baked) << "no alpha-tested geometry with a texture in the oak tree";
}

TEST(RealScene, OakTreeAdaptiveAndTwoState) {
  const Scene& s = loadOrDie("oak-tree/oaktree.gltf");
  for (const Geometry& g : s.geometries) {
    const Material& m = s.materials[g.material];
    if (!m.alphaTested() || !m.alpha) continue;
    BakeOptions o;
    o.texelsPerMicroTri = 2;
    o.maxLevel = 9;
    auto four = bakeGeometry(g, m, o);
    ASSERT_TRUE(four.ok());
    EXPECT_LE(four->stats.maxLevel, 9u);
    o.format = Format::TwoState;
    o.threads = 1;
    auto two = bakeGeometry(g, m, o);
    ASSERT_TRUE(two.ok());
    EXPECT_EQ(two->levels, four->levels);
    EXPECT_EQ(two->stats.unknownMicroTriangles, four->stats.unknownMicroTriangles);
    for (uint32_t t = 0; t < g.triangleCount(); t += 7)
      for (uint32_t i = 0; i < microTriangleCount(four->levels[t]); i += 3)
        ASSERT_EQ(two->array.state(t, i), toTwoState(four->array.state(t, i))) << t << " " << i;
  }
}

TEST(RealScene, AlphaBlendModeTestCutoffsGiveDifferentBakes) {
  const Scene& s = loadOrDie("alpha-blend-mode-test/AlphaBlendModeTest.gltf");
  // The three MASK test meshes (cutoffs 0.25, 0.75 and the default 0.5).
  std::vector<const Geometry*> masked;
  for (const Geometry& g : s.geometries)
    if (s.materials[g.material].alphaTested() && s.materials[g.material].alpha) masked.push_back(&g);
  ASSERT_EQ(masked.size(), 3u);
  std::vector<float> cutoffs;
  for (const Geometry* g : masked) cutoffs.push_back(s.materials[g->material].alphaCutoff);
  std::sort(cutoffs.begin(), cutoffs.end());
  EXPECT_EQ(cutoffs, (std::vector<float>{0.25f, 0.5f, 0.75f}));

  // Each mesh with its own material: conservative everywhere.
  for (const Geometry* g : masked) {
    const Material& m = s.materials[g->material];
    BakeOptions o;
    o.level = 6;
    auto r = bakeGeometry(*g, m, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const CheckCounts c = checkGeometry(*g, m, *r, m.alphaCutoff, m.sampler, 2);
    EXPECT_EQ(c.failures, 0u) << g->name;
    EXPECT_GT(c.known, 0u);
  }

  // One mesh baked with the three cutoffs: three different bakes, with opaque coverage shrinking as the
  // cutoff rises.
  const Geometry& g = *masked[0];
  const Material& m = s.materials[g.material];
  std::vector<OmmArray> arrays;
  std::vector<uint64_t> opaque;
  for (float cutoff : {0.25f, 0.5f, 0.75f}) {
    BakeOptions o;
    o.level = 6;
    o.cutoff = cutoff;
    auto r = bakeGeometry(g, m, o);
    ASSERT_TRUE(r.ok());
    uint64_t n = 0;
    for (uint32_t t = 0; t < g.triangleCount(); ++t)
      for (uint32_t i = 0; i < microTriangleCount(r->levels[t]); ++i)
        n += r->array.state(t, i) == State::Opaque;
    opaque.push_back(n);
    arrays.push_back(std::move(r->array));
  }
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      EXPECT_FALSE(arrays[a].data == arrays[b].data && arrays[a].indices == arrays[b].indices)
          << a << " vs " << b;
  EXPECT_GT(opaque[0], opaque[1]);
  EXPECT_GT(opaque[1], opaque[2]);
}

}  // namespace
}  // namespace somm
