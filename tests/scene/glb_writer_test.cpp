// SPDX-License-Identifier: MIT
// writeGlb → loadScene round trips: same numbering, geometry, materials, samplers, alpha, instances and
// camera.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <memory>

#include "scene_test_util.h"
#include "somm/procedural.h"
#include "somm/scene.h"

namespace {

using scenetest::TempDir;

void expectSameGeometry(const somm::Scene& a, const somm::Scene& b) {
  ASSERT_EQ(a.geometries.size(), b.geometries.size());
  for (size_t i = 0; i < a.geometries.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(a.geometries[i].positions, b.geometries[i].positions);
    EXPECT_EQ(a.geometries[i].uvs, b.geometries[i].uvs);
    EXPECT_EQ(a.geometries[i].indices, b.geometries[i].indices);
    EXPECT_EQ(a.geometries[i].material, b.geometries[i].material);
  }
  ASSERT_EQ(a.instances.size(), b.instances.size());
  for (size_t i = 0; i < a.instances.size(); ++i) {
    EXPECT_EQ(a.instances[i].geometry, b.instances[i].geometry);
    EXPECT_EQ(a.instances[i].transform, b.instances[i].transform);
  }
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t i = 0; i < a.materials.size(); ++i) {
    SCOPED_TRACE(a.materials[i].name);
    const somm::Material &x = a.materials[i], &y = b.materials[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.alphaMode, y.alphaMode);
    EXPECT_EQ(x.alphaCutoff, y.alphaCutoff);
    EXPECT_EQ(x.doubleSided, y.doubleSided);
    EXPECT_EQ(bool(x.alpha), bool(y.alpha));
    if (x.alpha && y.alpha) {
      EXPECT_EQ(x.sampler, y.sampler);
    }
  }
}

TEST(GlbWriter, LeafCardsRoundTripExactly) {
  TempDir dir;
  const somm::Scene s = somm::makeLeafCardScene(60, 5);
  ASSERT_TRUE(somm::writeGlb(s, dir.file("cards.glb")).ok());
  auto r = somm::loadScene(dir.file("cards.glb"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->warnings.empty());
  expectSameGeometry(s, *r);
  EXPECT_EQ(r->geometries[0].name, "cards/0");
  EXPECT_EQ(r->materials[0].alpha->values(), s.materials[0].alpha->values());  // binary alpha: exact
  ASSERT_TRUE(r->camera.has_value());
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(r->camera->eye[size_t(k)], s.camera->eye[size_t(k)], 1e-6);
    EXPECT_NEAR(r->camera->up[size_t(k)], s.camera->up[size_t(k)], 1e-6);
  }
  // target = eye + unit view direction: (0, 0, 3.5) looking at the origin → (0, 0, 2.5).
  EXPECT_NEAR(r->camera->target[2], 2.5, 1e-6);
  EXPECT_NEAR(r->camera->yfovRadians, s.camera->yfovRadians, 1e-7);
}

TEST(GlbWriter, QuadSamplersAndSoftAlpha) {
  TempDir dir;
  for (const somm::Sampler smp :
       {somm::Sampler{somm::Wrap::ClampToEdge, somm::Wrap::MirroredRepeat, somm::Filter::Nearest},
        somm::Sampler{somm::Wrap::MirroredRepeat, somm::Wrap::Repeat, somm::Filter::Linear}}) {
    auto tex = std::make_shared<const somm::AlphaTexture>(somm::makeNoiseTexture(32, 9, 4));
    const somm::Scene s = somm::makeQuadScene(tex, smp, 0.3f, {-1, -0.5f, 2, 3});
    ASSERT_TRUE(somm::writeGlb(s, dir.file("q.glb")).ok());
    auto r = somm::loadScene(dir.file("q.glb"));
    ASSERT_TRUE(r.ok()) << r.error().message;
    expectSameGeometry(s, *r);
    EXPECT_EQ(r->materials[0].sampler, smp);
    const somm::AlphaTexture& a = *r->materials[0].alpha;
    ASSERT_TRUE(a.consistent());
    ASSERT_EQ(a.texelCount(), tex->alpha.size());
    for (size_t i = 0; i < a.texelCount(); ++i) EXPECT_NEAR(a.texel(i), tex->alpha[i], 0.5 / 65535 + 1e-7);
  }
}

TEST(GlbWriter, RealScenesRoundTrip) {
  TempDir dir;
  for (const char* f : {"/oak-tree/oaktree.gltf", "/alpha-blend-mode-test/AlphaBlendModeTest.gltf"}) {
    SCOPED_TRACE(f);
    auto a = somm::loadScene(std::string(SOMM_DATA_DIR) + f);
    ASSERT_TRUE(a.ok()) << a.error().message;
    ASSERT_TRUE(somm::writeGlb(*a, dir.file("r.glb")).ok());
    auto b = somm::loadScene(dir.file("r.glb"));
    ASSERT_TRUE(b.ok()) << b.error().message;
    expectSameGeometry(*a, *b);
    for (size_t i = 0; i < a->geometries.size(); ++i) EXPECT_EQ(a->geometries[i].name, b->geometries[i].name);
    for (size_t i = 0; i < a->materials.size(); ++i) {
      const somm::Material &x = a->materials[i], &y = b->materials[i];
      if (x.alpha) {
        EXPECT_EQ(x.alpha->values(),
                  y.alpha->values());  // 8-bit source alpha survives 16-bit storage exactly
      }
      ASSERT_EQ(bool(x.baseColor), bool(y.baseColor));
      if (x.baseColor && !x.alpha) {
        EXPECT_EQ(x.baseColor->rgba, y.baseColor->rgba);
      }
    }
  }
}

// Materials sharing an alpha texture share one image; an 8-bit alpha without a factor is written as an 8-bit PNG
// (exact), any other alpha as a 16-bit one.
TEST(GlbWriter, SharedTexturesAndSampleDepth) {
  TempDir dir;
  std::vector<uint8_t> v8(64 * 32);
  for (size_t i = 0; i < v8.size(); ++i) v8[i] = uint8_t((i * 37) % 256);
  auto a8 = std::make_shared<somm::AlphaTexture>(somm::AlphaTexture::fromUInt8(64, 32, v8));
  auto a8scaled = std::make_shared<somm::AlphaTexture>(somm::AlphaTexture::fromUInt8(64, 32, v8, 0.5f));
  somm::Scene s = somm::makeQuadScene(a8, somm::Sampler{}, 0.5f);
  ASSERT_EQ(s.materials.size(), 1u);
  ASSERT_EQ(s.geometries.size(), 1u);
  s.materials.resize(3, s.materials[0]);
  s.materials[1].name = "same texture";
  s.materials[2].name = "scaled";
  s.materials[2].alpha = a8scaled;
  s.geometries.resize(3, s.geometries[0]);
  for (uint32_t g = 0; g < 3; ++g) {
    s.geometries[g].material = g;
    s.geometries[g].name = "quad" + std::to_string(g);
    if (g) s.instances.push_back(somm::Instance{g, s.instances[0].transform});
  }
  auto bytes = somm::encodeGlb(s, dir.file("x.glb"));
  ASSERT_TRUE(bytes.ok()) << bytes.error().message;
  ASSERT_TRUE(somm::writeGlb(s, dir.file("x.glb")).ok());
  auto back = somm::loadScene(dir.file("x.glb"));
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->materials.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    SCOPED_TRACE(i);
    ASSERT_TRUE(back->materials[i].alpha);
    const somm::AlphaTexture& b = *back->materials[i].alpha;
    EXPECT_EQ(b.storage, i < 2 ? somm::AlphaStorage::UInt8 : somm::AlphaStorage::UInt16);
    const somm::AlphaTexture& a = *s.materials[i].alpha;
    for (size_t t = 0; t < a.texelCount(); ++t)
      ASSERT_NEAR(b.texel(t), a.texel(t), i < 2 ? 0.0 : 0.5 / 65535 + 1e-7) << t;
  }
  // Two images: the shared 8-bit one and the scaled alpha's.
  const std::vector<uint8_t>& glb = *bytes;
  uint32_t jlen = 0;
  std::memcpy(&jlen, glb.data() + 12, 4);
  const std::string json(reinterpret_cast<const char*>(glb.data()) + 20, jlen);
  size_t images = 0;
  for (size_t at = json.find("image/png"); at != std::string::npos; at = json.find("image/png", at + 1))
    ++images;
  EXPECT_EQ(images, 2u);
}

// A colour image of another size than the alpha is resampled to the alpha's size (the alpha the bake tested stays
// exact): bilinear when enlarged, wrapped as the material's sampler wraps; the mean of the texels under each target
// texel when reduced.
TEST(GlbWriter, ColourOfAnotherSizeIsResampled) {
  TempDir dir;
  std::vector<uint8_t> v8(4 * 2);
  for (size_t i = 0; i < v8.size(); ++i) v8[i] = uint8_t(30 * i + 7);
  auto a8 = std::make_shared<somm::AlphaTexture>(somm::AlphaTexture::fromUInt8(4, 2, v8));
  auto red_blue =
      std::make_shared<somm::ColorImage>(somm::ColorImage{2, 1, {255, 0, 0, 255, 0, 0, 255, 255}});
  auto wide = std::make_shared<somm::ColorImage>(somm::ColorImage{8, 2, {}});
  for (uint32_t t = 0; t < 16; ++t) {
    const uint8_t x = uint8_t(t % 8), y = uint8_t(t / 8);
    wide->rgba.insert(wide->rgba.end(), {uint8_t(10 * x), uint8_t(100 + 50 * y), uint8_t(x * x), 255});
  }
  somm::Scene s = somm::makeQuadScene(
      a8, somm::Sampler{somm::Wrap::ClampToEdge, somm::Wrap::ClampToEdge, somm::Filter::Linear}, 0.5f);
  s.materials.resize(3, s.materials[0]);
  s.materials[0].baseColor = red_blue;
  s.materials[1].baseColor = red_blue;
  s.materials[1].name = "repeat";
  s.materials[1].sampler.wrapS = somm::Wrap::Repeat;
  s.materials[2].baseColor = wide;
  s.materials[2].name = "reduced";
  s.geometries.resize(3, s.geometries[0]);
  for (uint32_t g = 0; g < 3; ++g) {
    s.geometries[g].material = g;
    s.geometries[g].name = "quad" + std::to_string(g);
    if (g) s.instances.push_back(somm::Instance{g, s.instances[0].transform});
  }
  ASSERT_TRUE(somm::writeGlb(s, dir.file("c.glb")).ok());
  auto back = somm::loadScene(dir.file("c.glb"));
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->materials.size(), 3u);
  // Enlarged 2 → 4 columns (1 → 2 rows: both rows read row 0): source coordinate (x + ½)·2/4 − ½ = −¼, ¼, ¾, 1¼.
  const std::array<std::array<int, 3>, 4> clamp = {{{255, 0, 0}, {191, 0, 64}, {64, 0, 191}, {0, 0, 255}}};
  std::array<std::array<int, 3>, 4> repeat = clamp;
  repeat[0] = {191, 0, 64};  // −¼: ¾ of texel 0, ¼ of texel −1 = texel 1
  repeat[3] = {64, 0, 191};  // 1¼: ¾ of texel 1, ¼ of texel 2 = texel 0
  for (size_t mi = 0; mi < 3; ++mi) {
    SCOPED_TRACE(mi);
    const somm::Material& m = back->materials[mi];
    ASSERT_TRUE(m.baseColor && m.alpha);
    ASSERT_EQ(m.baseColor->width, 4u);
    ASSERT_EQ(m.baseColor->height, 2u);
    EXPECT_EQ(m.alpha->values(), a8->values());  // the tested alpha, exact
    for (uint32_t y = 0; y < 2; ++y)
      for (uint32_t x = 0; x < 4; ++x) {
        const uint8_t* p = &m.baseColor->rgba[(size_t(y) * 4 + x) * 4];
        std::array<int, 3> want;
        if (mi == 2) {
          // Reduced 8 → 4 columns: texels 2x and 2x + 1 (rows 2 → 2: the row itself).
          const int x0 = int(2 * x), x1 = x0 + 1;
          want = {5 * (x0 + x1), 100 + 50 * int(y), int(std::lround((x0 * x0 + x1 * x1) / 2.0))};
        } else {
          want = (mi == 0 ? clamp : repeat)[x];
        }
        EXPECT_EQ((std::array<int, 3>{p[0], p[1], p[2]}), want) << x << "," << y;
        EXPECT_EQ(p[3], v8[size_t(y) * 4 + x]);
      }
  }
}

TEST(GlbWriter, ErrorsAndAtomicity) {
  TempDir dir;
  const somm::Scene s = somm::makeLeafCardScene(3, 1);
  auto st = somm::writeGlb(s, dir.file("no/such/dir/x.glb"));
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, somm::ErrorCode::IoError);
  EXPECT_NE(st.error().message.find("x.glb"), std::string::npos);
  somm::Scene bad = s;
  bad.geometries[0].indices.push_back(9999);
  bad.geometries[0].indices.push_back(0);
  bad.geometries[0].indices.push_back(0);
  auto st2 = somm::writeGlb(bad, dir.file("bad.glb"));
  ASSERT_FALSE(st2.ok());
  EXPECT_EQ(st2.error().code, somm::ErrorCode::InvalidArgument);
  EXPECT_FALSE(std::filesystem::exists(dir.file("bad.glb")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("bad.glb.tmp")));
  // An empty geometry keeps its number.
  somm::Scene e = s;
  e.geometries.insert(e.geometries.begin(), somm::Geometry{"empty", 0, {}, {}, {}});
  for (auto& inst : e.instances) ++inst.geometry;
  ASSERT_TRUE(somm::writeGlb(e, dir.file("e.glb")).ok());
  auto r = somm::loadScene(dir.file("e.glb"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->geometries.size(), 2u);
  EXPECT_EQ(r->geometries[0].triangleCount(), 0u);
  EXPECT_EQ(r->geometries[1].triangleCount(), 6u);
}

}  // namespace
