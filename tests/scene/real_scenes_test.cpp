// Exact facts of the two real scenes in data/ (see their README.md files).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "somm/scene.h"

namespace {

const std::string kData = SOMM_DATA_DIR;

TEST(RealScenes, OakTree) {
  auto r = somm::loadScene(kData + "/oak-tree/oaktree.gltf");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::Scene& s = *r;
  ASSERT_EQ(s.geometries.size(), 2u);
  EXPECT_EQ(s.geometries[0].name, "oak/0");
  EXPECT_EQ(s.geometries[1].name, "oak.004/0");
  EXPECT_EQ(s.geometries[0].triangleCount(), 127u);
  EXPECT_EQ(s.geometries[1].triangleCount(), 428u);
  EXPECT_EQ(s.geometries[0].positions.size(), 381u * 3);
  EXPECT_EQ(s.geometries[0].uvs.size(), 381u * 2);
  ASSERT_EQ(s.materials.size(), 2u);
  const somm::Material& leaves = s.materials[s.geometries[0].material];
  EXPECT_EQ(leaves.name, "leaves");
  EXPECT_EQ(leaves.alphaMode, somm::AlphaMode::Mask);
  EXPECT_TRUE(leaves.alphaTested());
  EXPECT_FLOAT_EQ(leaves.alphaCutoff, 0.5f);
  EXPECT_TRUE(leaves.doubleSided);
  ASSERT_TRUE(leaves.alpha);
  EXPECT_EQ(leaves.alpha->width, 256u);
  EXPECT_EQ(leaves.alpha->height, 256u);
  EXPECT_EQ(leaves.sampler.filter, somm::Filter::Linear);
  EXPECT_EQ(leaves.sampler.wrapS, somm::Wrap::Repeat);
  const somm::Material& bark = s.materials[s.geometries[1].material];
  EXPECT_EQ(bark.name, "bark");
  EXPECT_EQ(bark.alphaMode, somm::AlphaMode::Opaque);
  EXPECT_FALSE(bark.alphaTested());
  ASSERT_EQ(s.instances.size(), 2u);
  EXPECT_FALSE(s.camera.has_value());
}

TEST(RealScenes, AlphaBlendModeTest) {
  auto r = somm::loadScene(kData + "/alpha-blend-mode-test/AlphaBlendModeTest.gltf");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::Scene& s = *r;
  ASSERT_EQ(s.geometries.size(), 9u);
  EXPECT_EQ(s.geometries[0].name, "TestCutoff25Mesh/0");
  EXPECT_EQ(s.materials[s.geometries[0].material].alphaCutoff, 0.25f);
}

}  // namespace
