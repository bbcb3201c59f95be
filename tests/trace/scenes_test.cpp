// SPDX-License-Identifier: MIT
// Exactness on the bundled scenes and the procedural leaf-card scene, with micromaps from the real baker
// (somm_bake): every 4-state method renders pixel-identical to `texture`.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "somm/bake.h"
#include "somm/procedural.h"
#include "somm/trace.h"

namespace somm {
namespace {

// One scene-wide array (as `somm bake` stores it): geometries' filters read global triangles.
std::shared_ptr<const SceneMicromaps> bakeAll(const Scene& scene, BakeOptions options) {
  std::vector<OmmArray> arrays;
  for (const Geometry& g : scene.geometries) {
    auto baked = bakeGeometry(g, scene.materials[g.material], options);
    EXPECT_TRUE(baked.ok()) << (baked.ok() ? "" : baked.error().message);
    arrays.push_back(baked.ok() ? baked->array : OmmArray{});
  }
  return std::make_shared<const SceneMicromaps>(mergeToSceneArray(perGeometryMicromaps(std::move(arrays))));
}

// Renders `texture`, omm4-flat and bitmask (exact) and omm2-flat from several views; returns omm2's worst
// diff.
double checkExact(const std::shared_ptr<const Scene>& scene, uint32_t level, uint32_t size) {
  auto world = TraceWorld::create(scene);
  EXPECT_TRUE(world.ok()) << (world.ok() ? "" : world.error().message);
  if (!world.ok()) return 100;
  BakeOptions o;
  o.level = level;
  MicromapSet m;
  m.flat4 = bakeAll(*scene, o);
  o.format = Format::TwoState;
  m.flat2 = bakeAll(*scene, o);
  m.bitmaskLevel = level;
  auto texture = makeTextureTracer(*world).value();
  auto omm4 = makeTracer(*world, parseMethod("omm4-flat").value(), m).value();
  std::vector<std::unique_ptr<Tracer>> encoded;  // every compressed encoding, 4-state
  for (const std::string& e : traceEncodings())
    if (e != "flat") encoded.push_back(makeTracer(*world, parseMethod("omm4-" + e).value(), m).value());
  EXPECT_GE(encoded.size(), 4u);
  auto omm2 = makeTracer(*world, parseMethod("omm2-flat").value(), m).value();
  auto bitmask = makeTracer(*world, parseMethod("bitmask").value(), m).value();
  // The default view, then views around the scene centre: oblique, grazing (nearly edge-on) and close up.
  const Camera base = (*world)->camera(RenderSettings{});
  const Bounds& b = (*world)->bounds();
  const std::array<float, 3> c{(b.lower[0] + b.upper[0]) / 2, (b.lower[1] + b.upper[1]) / 2,
                               (b.lower[2] + b.upper[2]) / 2};
  const float r = std::max({b.upper[0] - b.lower[0], b.upper[1] - b.lower[1], b.upper[2] - b.lower[2]});
  std::vector<Camera> cams = {base};
  cams.push_back(Camera{{c[0] + r * 0.9f, c[1] + r * 0.02f, c[2] + r * 0.1f}, c, {0, 1, 0}, 0.9f});
  cams.push_back(Camera{{c[0] + r * 0.01f, c[1] + r * 1.2f, c[2] + r * 0.01f}, c, {0, 0, 1}, 0.7f});
  cams.push_back(Camera{{c[0] + r * 0.15f, c[1] + r * 0.1f, c[2] + r * 0.2f}, c, {0, 1, 0}, 1.2f});
  double worst2 = 0;
  for (const Camera& cam : cams) {
    RenderSettings rs;
    rs.width = size;
    rs.height = size * 3 / 4;
    rs.spp = 2;
    rs.camera = cam;
    const RenderResult ref = texture->render(rs);
    const RenderResult r4 = omm4->render(rs);
    EXPECT_EQ(r4.image.rgba, ref.image.rgba) << scene->sourcePath << " level " << level;
    EXPECT_LE(r4.counters.textureTests, ref.counters.textureTests);
    for (const auto& t : encoded) {
      const RenderResult re = t->render(rs);
      EXPECT_EQ(re.image.rgba, ref.image.rgba)
          << scene->sourcePath << " " << t->method() << " level " << level;
      EXPECT_EQ(re.counters, r4.counters) << t->method();  // same lookups, same states as flat
    }
    EXPECT_EQ(bitmask->render(rs).image.rgba, ref.image.rgba)
        << scene->sourcePath << " bitmask level " << level;
    const RenderResult r2 = omm2->render(rs);
    EXPECT_EQ(r2.counters.textureTests, 0u);
    worst2 = std::max(worst2, percentPixelsDiffering(r2.image, ref.image));
  }
  return worst2;
}

TEST(TraceScenes, OakTreeFourStateIsExact) {
  auto s = loadScene(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf");
  ASSERT_TRUE(s.ok()) << s.error().message;
  auto scene = std::make_shared<const Scene>(std::move(s).value());
  for (uint32_t level : {4u, 8u}) checkExact(scene, level, 160);
}

TEST(TraceScenes, AlphaBlendModeTestFourStateIsExact) {
  const std::string dir = std::string(SOMM_DATA_DIR) + "/alpha-blend-mode-test/";
  auto s = loadScene(dir + "AlphaBlendModeTest.gltf", LoadOptions{true});
  ASSERT_TRUE(s.ok()) << s.error().message;
  auto scene = std::make_shared<const Scene>(std::move(s).value());
  checkExact(scene, 6, 160);
}

TEST(TraceScenes, ProceduralLeafCardsFourStateIsExact) {
  auto scene = std::make_shared<const Scene>(makeLeafCardScene(300, 5));
  const double diff2 = checkExact(scene, 6, 160);
  EXPECT_LT(diff2, 5.0);  // 2-state at level 6 on a 512² atlas: a close approximation of the silhouette
}

}  // namespace
}  // namespace somm
