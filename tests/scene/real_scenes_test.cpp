// SPDX-License-Identifier: MIT
// Exact facts of the two real scenes in data/ (their README.md files, and texel values and counts obtained
// with an independent PNG decoder).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>

#include "somm/scene.h"

namespace {

const std::string kData = SOMM_DATA_DIR;

struct AlphaCounts {
  size_t zero = 0, one = 0, partial = 0;
};
AlphaCounts countAlpha(const somm::AlphaTexture& t) {
  AlphaCounts c;
  for (float a : t.values()) (a == 0.0f ? c.zero : a == 1.0f ? c.one : c.partial) += 1;
  return c;
}

void expectValidGeometry(const somm::Geometry& g) {
  const size_t n = g.positions.size() / 3;
  EXPECT_EQ(g.positions.size(), n * 3);
  EXPECT_EQ(g.uvs.size(), n * 2);
  EXPECT_EQ(g.indices.size() % 3, 0u);
  for (uint32_t i : g.indices) ASSERT_LT(i, n);
  for (float v : g.positions) ASSERT_TRUE(std::isfinite(v));
  for (float v : g.uvs) ASSERT_TRUE(std::isfinite(v));
}

TEST(RealScenes, OakTree) {
  auto r = somm::loadScene(kData + "/oak-tree/oaktree.gltf");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::Scene& s = *r;
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  ASSERT_EQ(s.geometries.size(), 2u);
  EXPECT_EQ(s.geometries[0].name, "oak/0");
  EXPECT_EQ(s.geometries[1].name, "oak.004/0");
  EXPECT_EQ(s.geometries[0].triangleCount(), 127u);  // leaves
  EXPECT_EQ(s.geometries[1].triangleCount(), 428u);  // bark
  EXPECT_EQ(s.geometries[0].triangleCount() + s.geometries[1].triangleCount(), 555u);
  EXPECT_EQ(s.geometries[0].positions.size(), 381u * 3);
  EXPECT_EQ(s.geometries[1].positions.size(), 376u * 3);
  for (const auto& g : s.geometries) expectValidGeometry(g);

  ASSERT_EQ(s.materials.size(), 2u);
  const somm::Material& leaves = s.materials[s.geometries[0].material];
  EXPECT_EQ(leaves.name, "leaves");
  EXPECT_EQ(leaves.alphaMode, somm::AlphaMode::Mask);
  EXPECT_TRUE(leaves.alphaTested());
  EXPECT_EQ(leaves.alphaCutoff, 0.5f);
  EXPECT_TRUE(leaves.doubleSided);
  EXPECT_EQ(leaves.sampler, (somm::Sampler{somm::Wrap::Repeat, somm::Wrap::Repeat, somm::Filter::Linear}));
  EXPECT_EQ(leaves.alphaSource, kData + "/oak-tree/oakleaf_light.png");
  ASSERT_TRUE(leaves.alpha);
  const somm::AlphaTexture& a = *leaves.alpha;
  ASSERT_EQ(a.width, 256u);
  ASSERT_EQ(a.height, 256u);
  const AlphaCounts c = countAlpha(a);  // binary alpha, 56% transparent
  EXPECT_EQ(c.zero, 36857u);
  EXPECT_EQ(c.one, 28679u);
  EXPECT_EQ(c.partial, 0u);
  EXPECT_EQ(a.at(0, 0), 0.0f);  // image row 0 is v = 0 in glTF: no flip
  EXPECT_EQ(a.at(0, 255), 1.0f);
  EXPECT_EQ(a.at(128, 128), 1.0f);
  EXPECT_EQ(a.at(64, 200), 0.0f);
  ASSERT_TRUE(leaves.baseColor);
  EXPECT_EQ(leaves.baseColor->width, 256u);
  EXPECT_EQ(leaves.baseColor->rgba[(255 * 256 + 0) * 4 + 3], 255);

  const somm::Material& bark = s.materials[s.geometries[1].material];
  EXPECT_EQ(bark.name, "bark");
  EXPECT_EQ(bark.alphaMode, somm::AlphaMode::Opaque);
  EXPECT_FALSE(bark.alphaTested());
  EXPECT_FALSE(bark.alpha);
  ASSERT_TRUE(bark.baseColor);  // oakbark.jpg, 512², RGB
  EXPECT_EQ(bark.baseColor->width, 512u);
  EXPECT_EQ(bark.baseColor->height, 512u);
  EXPECT_EQ(bark.baseColor->rgba[3], 255);

  // Scene: node "oak" (mesh 1) with child "leaves" (mesh 0), no transforms.
  ASSERT_EQ(s.instances.size(), 2u);
  EXPECT_EQ(s.instances[0].geometry, 1u);
  EXPECT_EQ(s.instances[1].geometry, 0u);
  const std::array<float, 16> identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  EXPECT_EQ(s.instances[0].transform, identity);
  EXPECT_EQ(s.instances[1].transform, identity);
  EXPECT_FALSE(s.camera.has_value());
  // Vertical extent of the leaves equals the POSITION accessor's min/max.
  float lo = 1e9f, hi = -1e9f;
  for (size_t i = 1; i < s.geometries[0].positions.size(); i += 3)
    lo = std::min(lo, s.geometries[0].positions[i]), hi = std::max(hi, s.geometries[0].positions[i]);
  EXPECT_FLOAT_EQ(lo, 1.938339114189148f);
  EXPECT_FLOAT_EQ(hi, 4.492341995239258f);
}

TEST(RealScenes, AlphaBlendModeTest) {
  const std::string path = kData + "/alpha-blend-mode-test/AlphaBlendModeTest.gltf";
  auto r = somm::loadScene(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::Scene& s = *r;
  const char* names[9] = {"TestCutoff25Mesh/0", "TestCutoff75Mesh/0", "BedMesh/0",
                          "TestBlendMesh/0",    "GreenArrowsMesh/0",  "DecalOpaqueMesh/0",
                          "TestOpaqueMesh/0",   "DecalBlendMesh/0",   "TestCutoffDefaultMesh/0"};
  const uint32_t tris[9] = {2, 2, 30, 2, 3, 16, 2, 2, 2};
  const char* mats[9] = {"MatCutoff25", "MatCutoff75", "MatBed",   "MatBlend",        "MatOpaque",
                         "MatOpaque",   "MatOpaque",   "MatBlend", "MatCutoffDefault"};
  ASSERT_EQ(s.geometries.size(), 9u);
  for (size_t i = 0; i < 9; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(s.geometries[i].name, names[i]);
    EXPECT_EQ(s.geometries[i].triangleCount(), tris[i]);
    EXPECT_EQ(s.materials[s.geometries[i].material].name, mats[i]);
    expectValidGeometry(s.geometries[i]);
  }
  ASSERT_EQ(s.materials.size(), 6u);
  const somm::Material& m25 = s.materials[s.geometries[0].material];
  const somm::Material& m75 = s.materials[s.geometries[1].material];
  const somm::Material& m50 = s.materials[s.geometries[8].material];
  const somm::Material& blend = s.materials[s.geometries[3].material];
  EXPECT_EQ(m25.alphaCutoff, 0.25f);
  EXPECT_EQ(m75.alphaCutoff, 0.75f);
  EXPECT_EQ(m50.alphaCutoff, 0.5f);  // glTF default
  for (const somm::Material* m : {&m25, &m75, &m50}) {
    EXPECT_EQ(m->alphaMode, somm::AlphaMode::Mask);
    EXPECT_TRUE(m->doubleSided);
    EXPECT_EQ(m->sampler, (somm::Sampler{somm::Wrap::Repeat, somm::Wrap::Repeat, somm::Filter::Linear}));
    ASSERT_TRUE(m->alpha);
    EXPECT_EQ(m->alpha.get(), m25.alpha.get());  // one shared texture
  }
  EXPECT_EQ(blend.alphaMode, somm::AlphaMode::Blend);
  EXPECT_FALSE(blend.alphaTested());
  EXPECT_EQ(s.materials[s.geometries[2].material].alphaMode, somm::AlphaMode::Opaque);
  EXPECT_EQ(s.materials[s.geometries[4].material].alphaMode, somm::AlphaMode::Opaque);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("MatBlend"), std::string::npos);

  const somm::AlphaTexture& a = *m25.alpha;
  ASSERT_EQ(a.width, 1024u);
  ASSERT_EQ(a.height, 1024u);
  const AlphaCounts c = countAlpha(a);  // soft alpha: 29% partial texels
  EXPECT_EQ(c.zero, 509663u);
  EXPECT_EQ(c.one, 232876u);
  EXPECT_EQ(c.partial, 306037u);
  struct Texel {
    uint32_t x, y, alpha8;
  };
  for (const Texel& t :
       {Texel{512, 512, 128}, Texel{287, 148, 11}, Texel{287, 875, 245}, Texel{820, 0, 255},
        Texel{283, 362, 80}, Texel{283, 424, 100}, Texel{283, 735, 200}, Texel{283, 828, 230}})
    EXPECT_EQ(a.at(t.x, t.y), float(t.alpha8 / 255.0)) << t.x << "," << t.y;
  // The three cutoffs classify the same texels differently: alpha 80/255 passes only 0.25, 200/255 all three.
  const somm::Sampler nearest{somm::Wrap::Repeat, somm::Wrap::Repeat, somm::Filter::Nearest};
  const float a80 = somm::sampleAlpha(a, nearest, 283.5f / 1024, 362.5f / 1024);
  const float a128 = somm::sampleAlpha(a, nearest, 512.5f / 1024, 512.5f / 1024);
  const float a200 = somm::sampleAlpha(a, nearest, 283.5f / 1024, 735.5f / 1024);
  EXPECT_TRUE(somm::alphaTestPasses(a80, m25.alphaCutoff));
  EXPECT_FALSE(somm::alphaTestPasses(a80, m50.alphaCutoff));
  EXPECT_TRUE(somm::alphaTestPasses(a128, m50.alphaCutoff));
  EXPECT_FALSE(somm::alphaTestPasses(a128, m75.alphaCutoff));
  EXPECT_TRUE(somm::alphaTestPasses(a200, m75.alphaCutoff));

  // Instances in scene node order [3, 1, 2, 6, 7, 5, 4, 8, 0] → meshes [4, 7, 5, 1, 8, 0, 3, 6, 2].
  ASSERT_EQ(s.instances.size(), 9u);
  const uint32_t geoms[9] = {4, 7, 5, 1, 8, 0, 3, 6, 2};
  for (size_t i = 0; i < 9; ++i) EXPECT_EQ(s.instances[i].geometry, geoms[i]);
  EXPECT_FLOAT_EQ(s.instances[3].transform[12], 3.0f);   // TestCutoff75 at x = 3
  EXPECT_FLOAT_EQ(s.instances[4].transform[12], 1.5f);   // TestCutoffDefault at x = 1.5
  EXPECT_FLOAT_EQ(s.instances[7].transform[12], -3.0f);  // TestOpaque at x = -3
  // DecalBlend: rotation quaternion (-0.4718585, 0, 0, 0.8816744) about x, translation z = 0.409.
  const double qx = -0.47185850143432617, qw = 0.8816744089126587;
  const auto& m = s.instances[1].transform;
  EXPECT_NEAR(m[5], 1 - 2 * qx * qx, 1e-6);  // R(1,1)
  EXPECT_NEAR(m[6], 2 * qx * qw, 1e-6);      // R(2,1): y axis → (0, cos, sin)
  EXPECT_NEAR(m[9], -2 * qx * qw, 1e-6);     // R(1,2)
  EXPECT_NEAR(m[14], 0.4090209901332855, 1e-6);
  EXPECT_EQ(m[0], 1.0f);

  // --blend-as-mask: MatBlend becomes MASK with the default cutoff and gets the shared alpha texture.
  somm::LoadOptions opt;
  opt.blendAsMask = true;
  auto r2 = somm::loadScene(path, opt);
  ASSERT_TRUE(r2.ok()) << r2.error().message;
  const somm::Material& b2 = r2->materials[r2->geometries[3].material];
  EXPECT_EQ(b2.alphaMode, somm::AlphaMode::Mask);
  EXPECT_EQ(b2.alphaCutoff, 0.5f);
  ASSERT_TRUE(b2.alpha);
  EXPECT_EQ(b2.alpha->values(), a.values());
  EXPECT_TRUE(r2->warnings.empty());
}

}  // namespace
