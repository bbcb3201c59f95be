// SPDX-License-Identifier: MIT
// OBJ/MTL loading: geometry numbering and fanning, the v flip, map_d / map_Kd alpha sources, -imfchan,
// -clamp, image formats, missing textures and malformed files.
#include <gtest/gtest.h>
#include <stb_image.h>

#include <algorithm>
#include <cmath>

#include "scene_test_util.h"
#include "somm/scene.h"

namespace {

using scenetest::TempDir;
using scenetest::writeFile;

const somm::Sampler kNearest{somm::Wrap::Repeat, somm::Wrap::Repeat, somm::Filter::Nearest};

const char* kQuadObj =
    "mtllib q.mtl\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "usemtl leaf\n"
    "f 1/1 2/2 3/3 4/4\n";

somm::Result<somm::Scene> loadQuad(const TempDir& dir, const std::string& mtlBody) {
  writeFile(dir.file("q.obj"), kQuadObj);
  writeFile(dir.file("q.mtl"), "newmtl leaf\nKd 0.5 0.25 1\n" + mtlBody);
  return somm::loadScene(dir.file("q.obj"));
}

// 4×2 RGBA: top image row opaque, bottom row transparent.
std::vector<uint8_t> topOpaque() {
  std::vector<uint8_t> px;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x)
      px.insert(px.end(), {uint8_t(10 * x), uint8_t(100 + y), 7, uint8_t(y == 0 ? 255 : 0)});
  return px;
}

TEST(Obj, QuadIsFannedAndUvsAreKept) {
  TempDir dir;
  auto r = loadQuad(dir, "");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->geometries.size(), 1u);
  const somm::Geometry& g = r->geometries[0];
  EXPECT_EQ(g.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}));
  EXPECT_EQ(g.uvs, (std::vector<float>{0, 0, 1, 0, 1, 1, 0, 1}));
  EXPECT_EQ(g.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  const somm::Material& m = r->materials[g.material];
  EXPECT_EQ(m.name, "leaf");
  EXPECT_EQ(m.alphaMode, somm::AlphaMode::Opaque);  // no texture: opaque
  EXPECT_FALSE(m.alpha);
  EXPECT_EQ(m.baseColorFactor, (std::array<float, 4>{0.5f, 0.25f, 1.0f, 1.0f}));
  ASSERT_EQ(r->instances.size(), 1u);
  EXPECT_FALSE(r->camera.has_value());
}

// Materials that use the same image file share one converted alpha texture and colour image (loaded once per path).
TEST(Obj, MaterialsShareImagesOfOneFile) {
  TempDir dir;
  scenetest::writePng8(dir.file("tex.png"), 4, 2, 4, topOpaque());
  writeFile(dir.file("q.obj"),
            "mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
            "usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 3/3 2/2\nusemtl c\nf 2/2 1/1 3/3\n");
  writeFile(dir.file("q.mtl"),
            "newmtl a\nmap_Kd tex.png\nnewmtl b\nmap_Kd tex.png\nnewmtl c\nmap_Kd tex.png\nmap_d -imfchan r "
            "tex.png\n");
  auto r = somm::loadScene(dir.file("q.obj"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->materials.size(), 3u);
  const auto &a = r->materials[0], &b = r->materials[1], &c = r->materials[2];
  ASSERT_TRUE(a.alpha && b.alpha && c.alpha);
  EXPECT_EQ(a.alpha.get(), b.alpha.get());
  EXPECT_EQ(a.baseColor.get(), b.baseColor.get());
  EXPECT_EQ(a.baseColor.get(), c.baseColor.get());
  EXPECT_NE(a.alpha.get(), c.alpha.get());  // another channel of the same file
  EXPECT_EQ(c.alpha->at(1, 0), 10 / 255.0f);
}

// The same asymmetric image through OBJ (v = 0 at the bottom row) and glTF (v = 0 at the top row).
TEST(Obj, VFlipAgainstGltf) {
  TempDir dir;
  scenetest::writePng8(dir.file("tex.png"), 4, 2, 4, topOpaque());
  auto r = loadQuad(dir, "map_Kd tex.png\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::Material& m = r->materials[0];
  EXPECT_EQ(m.alphaMode, somm::AlphaMode::Mask);  // map_Kd has alpha
  EXPECT_EQ(m.alphaCutoff, 0.5f);
  EXPECT_EQ(m.sampler, (somm::Sampler{somm::Wrap::Repeat, somm::Wrap::Repeat, somm::Filter::Linear}));
  EXPECT_EQ(m.alphaSource, dir.file("tex.png"));
  ASSERT_TRUE(m.alpha);
  for (uint32_t x = 0; x < 4; ++x) {
    EXPECT_EQ(m.alpha->at(x, 0), 0.0f);  // texture row 0 = v in [0, 1/2] = bottom image row
    EXPECT_EQ(m.alpha->at(x, 1), 1.0f);
  }
  // OBJ: v near 1 is the top of the image (opaque).
  EXPECT_EQ(somm::sampleAlpha(*m.alpha, kNearest, 0.6f, 0.9f), 1.0f);
  EXPECT_EQ(somm::sampleAlpha(*m.alpha, kNearest, 0.6f, 0.1f), 0.0f);
  // The colour image is flipped the same way: texture row 0 = image row 1 (green 101).
  ASSERT_TRUE(m.baseColor);
  EXPECT_EQ(m.baseColor->rgba[1], 101);
  EXPECT_EQ(m.baseColor->rgba[(1 * 4 + 2) * 4 + 0], 20);
  EXPECT_EQ(m.baseColor->rgba[(1 * 4 + 2) * 4 + 1], 100);

  // glTF with the same image: v near 0 is the top of the image.
  scenetest::GltfBuilder b = scenetest::quadGltf();
  b.j["textures"] = {{{"source", b.imageFile("tex.png")}}};
  b.j["materials"] = {{{"name", "leaf"},
                       {"alphaMode", "MASK"},
                       {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
  b.writeGltf(dir.file("q.gltf"));
  auto g = somm::loadScene(dir.file("q.gltf"));
  ASSERT_TRUE(g.ok()) << g.error().message;
  const somm::AlphaTexture& ga = *g->materials[0].alpha;
  EXPECT_EQ(somm::sampleAlpha(ga, kNearest, 0.6f, 0.1f), 1.0f);
  EXPECT_EQ(somm::sampleAlpha(ga, kNearest, 0.6f, 0.9f), 0.0f);
  // Both conventions describe the same picture: OBJ (u, v) and glTF (u, 1 - v) agree at texel centres.
  for (float u : {0.125f, 0.375f, 0.625f, 0.875f})
    for (float v : {0.25f, 0.75f})
      EXPECT_EQ(somm::sampleAlpha(*m.alpha, kNearest, u, v), somm::sampleAlpha(ga, kNearest, u, 1.0f - v));
}

TEST(Obj, GeometryPerShapeAndMaterialInOrderOfFirstAppearance) {
  TempDir dir;
  writeFile(dir.file("m.mtl"), "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n");
  writeFile(dir.file("m.obj"),
            "mtllib m.mtl\n"
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 2 0\nv 3 3 0\n"
            "o A\n"
            "usemtl red\nf 1 2 3\n"
            "usemtl blue\nf 1 3 4\n"
            "usemtl red\nf 2 3 4 5 6\n"
            "o B\n"
            "usemtl red\nf 4 5 6\nf 1 2 3 4\n"
            "usemtl nosuch\nf 1 2 3\n");
  auto r = somm::loadScene(dir.file("m.obj"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::Scene& s = *r;
  ASSERT_EQ(s.geometries.size(), 4u);
  EXPECT_EQ(s.geometries[0].name, "A/red");
  EXPECT_EQ(s.geometries[1].name, "A/blue");
  EXPECT_EQ(s.geometries[2].name, "B/red");
  EXPECT_EQ(s.geometries[3].name, "B/default");
  // A/red: (1 2 3), then the pentagon fanned (2 3 4) (2 4 5) (2 5 6); local vertices in order of first use.
  EXPECT_EQ(s.geometries[0].indices, (std::vector<uint32_t>{0, 1, 2, 1, 2, 3, 1, 3, 4, 1, 4, 5}));
  EXPECT_EQ(s.geometries[0].positions,
            (std::vector<float>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 2, 0, 3, 3, 0}));
  EXPECT_EQ(s.geometries[1].triangleCount(), 1u);
  // B/red: (4 5 6), then the quad (1 2 3) (1 3 4).
  EXPECT_EQ(s.geometries[2].indices, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5, 3, 5, 0}));
  EXPECT_EQ(s.geometries[2].positions,
            (std::vector<float>{0, 1, 0, 2, 2, 0, 3, 3, 0, 0, 0, 0, 1, 0, 0, 1, 1, 0}));
  EXPECT_EQ(s.geometries[2].uvs, std::vector<float>(12, 0.0f));  // no vt: zeros
  ASSERT_EQ(s.materials.size(), 3u);
  EXPECT_EQ(s.materials[s.geometries[0].material].name, "red");
  EXPECT_EQ(s.materials[s.geometries[1].material].name, "blue");
  EXPECT_EQ(s.geometries[2].material, s.geometries[0].material);
  EXPECT_EQ(s.materials[s.geometries[3].material].name, "default");
  ASSERT_EQ(s.instances.size(), 4u);
  for (uint32_t i = 0; i < 4; ++i) EXPECT_EQ(s.instances[i].geometry, i);
}

TEST(Obj, MapDChannels) {
  TempDir dir;
  // 1×2 images (top row first). RGBA with alpha unlike its luminance; RGB; grey.
  scenetest::writePng8(dir.file("rgba.png"), 1, 2, 4, {255, 0, 0, 10, 0, 255, 0, 200});
  scenetest::writePng8(dir.file("rgb.png"), 1, 2, 3, {255, 0, 0, 0, 0, 255});
  scenetest::writePng8(dir.file("grey.png"), 1, 2, 1, {51, 204});
  scenetest::writePng8(dir.file("ga.png"), 1, 2, 2, {51, 7, 204, 250});
  struct Case {
    std::string mtl;
    float bottom, top;  // expected alpha of the bottom (texture row 0) and top image rows
  };
  const std::vector<Case> cases = {
      {"map_d rgba.png", 200 / 255.0f, 10 / 255.0f},                   // alpha channel
      {"map_d -imfchan m rgba.png", 200 / 255.0f, 10 / 255.0f},        // m: the alpha (matte) channel
      {"map_d -imfchan r rgba.png", 0.0f, 1.0f},                       // red channel
      {"map_d -imfchan g rgba.png", 1.0f, 0.0f},                       // green channel
      {"map_d rgb.png", float(0.0722), float(0.2126)},                 // no alpha: Rec. 709 luminance
      {"map_d grey.png", 204 / 255.0f, 51 / 255.0f},                   // grey: the grey value
      {"map_d ga.png", 250 / 255.0f, 7 / 255.0f},                      // grey+alpha: alpha
      {"map_d -imfchan l ga.png", 204 / 255.0f, 51 / 255.0f},          // l: luminance even with alpha
      {"map_Kd rgba.png\nmap_d grey.png", 204 / 255.0f, 51 / 255.0f},  // map_d wins over map_Kd alpha
      {"map_Kd ga.png", 250 / 255.0f, 7 / 255.0f},                     // map_Kd alpha when no map_d
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.mtl);
    auto r = loadQuad(dir, c.mtl + "\n");
    ASSERT_TRUE(r.ok()) << r.error().message;
    const somm::Material& m = r->materials[0];
    EXPECT_EQ(m.alphaMode, somm::AlphaMode::Mask);
    ASSERT_TRUE(m.alpha);
    ASSERT_EQ(m.alpha->width, 1u);
    ASSERT_EQ(m.alpha->height, 2u);
    EXPECT_NEAR(m.alpha->at(0, 0), c.bottom, 1e-6);
    EXPECT_NEAR(m.alpha->at(0, 1), c.top, 1e-6);
  }
  // map_Kd without an alpha channel and no map_d: opaque.
  auto r = loadQuad(dir, "map_Kd rgb.png\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->materials[0].alphaMode, somm::AlphaMode::Opaque);
  EXPECT_FALSE(r->materials[0].alpha);
  EXPECT_TRUE(r->materials[0].baseColor);
}

TEST(Obj, ClampOption) {
  TempDir dir;
  scenetest::writePng8(dir.file("ga.png"), 1, 2, 2, {51, 7, 204, 250});
  auto r = loadQuad(dir, "map_d -clamp on ga.png\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->materials[0].sampler,
            (somm::Sampler{somm::Wrap::ClampToEdge, somm::Wrap::ClampToEdge, somm::Filter::Linear}));
  auto r2 = loadQuad(dir, "map_d -clamp off ga.png\n");
  ASSERT_TRUE(r2.ok()) << r2.error().message;
  EXPECT_EQ(r2->materials[0].sampler,
            (somm::Sampler{somm::Wrap::Repeat, somm::Wrap::Repeat, somm::Filter::Linear}));
  auto r3 = loadQuad(dir, "map_Kd -clamp on ga.png\n");
  ASSERT_TRUE(r3.ok()) << r3.error().message;
  EXPECT_EQ(r3->materials[0].sampler.wrapS, somm::Wrap::ClampToEdge);
}

TEST(Obj, SixteenBitPng) {
  TempDir dir;
  scenetest::writeBytes(dir.file("a16.png"),
                        scenetest::encodePng16(2, 2, 2, {0, 32768, 0, 1, 65535, 65534, 9, 0}));
  auto r = loadQuad(dir, "map_d a16.png\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::AlphaTexture& a = *r->materials[0].alpha;
  EXPECT_EQ(a.storage, somm::AlphaStorage::UInt16);  // kept at the image's precision
  EXPECT_EQ(a.alpha16, (std::vector<uint16_t>{65534, 0, 32768, 1}));
  EXPECT_EQ(a.values(),
            (std::vector<float>{float(65534 / 65535.0), 0.0f, float(32768 / 65535.0), float(1 / 65535.0)}));
}

// An 8-bit PNG's alpha stays 8-bit (one byte per texel) with the loader's floats exactly; a luminance of a colour
// image is no stored value and stays float.
TEST(Obj, EightBitAlphaStaysEightBit) {
  TempDir dir;
  scenetest::writeBytes(dir.file("a8.png"), scenetest::encodePng8(2, 2, 2, {0, 0, 9, 128, 7, 255, 1, 1}));
  auto r = loadQuad(dir, "map_d a8.png\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::AlphaTexture& a = *r->materials[0].alpha;
  EXPECT_EQ(a.storage, somm::AlphaStorage::UInt8);
  EXPECT_TRUE(a.alpha.empty());
  EXPECT_EQ(a.alpha8, (std::vector<uint8_t>{255, 1, 0, 128}));  // rows flipped (OBJ)
  EXPECT_EQ(a.memoryBytes(), 4u);
  EXPECT_EQ(a.values(), (std::vector<float>{1.0f, float(1 / 255.0), 0.0f, float(128 / 255.0)}));
  scenetest::writeBytes(dir.file("c8.png"), scenetest::encodePng8(1, 1, 3, {10, 20, 30}));
  auto c = loadQuad(dir, "map_d -imfchan l c8.png\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->materials[0].alpha->storage, somm::AlphaStorage::Float32);
}

// Every kind of image the loaders meet gives the alpha the decoder stores, at the image's precision: 8-bit RGBA,
// grey+alpha and palette+tRNS stay 8-bit, 16-bit RGBA and grey+alpha stay 16-bit (rows flipped for OBJ). The oracle
// is stb_image's own decode of the file. A JPEG (no alpha channel) as map_Kd leaves the material opaque.
TEST(Obj, ImageKindsKeepTheDecodersAlpha) {
  TempDir dir;
  const uint32_t w = 3, h = 2;
  std::vector<uint8_t> rgba8, ga8;
  std::vector<uint16_t> rgba16, ga16;
  for (uint32_t i = 0; i < w * h; ++i) {
    rgba8.insert(rgba8.end(), {uint8_t(40 * i), uint8_t(7 + i), uint8_t(200 - i), uint8_t(51 * i + 1)});
    ga8.insert(ga8.end(), {uint8_t(30 * i), uint8_t(250 - 37 * i)});
    rgba16.insert(rgba16.end(), {uint16_t(1000 * i), 7, 9, uint16_t(13107 * i + 257 * i + 1)});
    ga16.insert(ga16.end(), {uint16_t(999 * i), uint16_t(65535 - 12345 * i)});
  }
  scenetest::writeBytes(dir.file("rgba8.png"), scenetest::encodePng8(int(w), int(h), 4, rgba8));
  scenetest::writeBytes(dir.file("ga8.png"), scenetest::encodePng8(int(w), int(h), 2, ga8));
  scenetest::writeBytes(dir.file("rgba16.png"), scenetest::encodePng16(w, h, 4, rgba16));
  scenetest::writeBytes(dir.file("ga16.png"), scenetest::encodePng16(w, h, 2, ga16));
  // Palette of 3 entries with tRNS alphas 0, 128, 255; rows of indices (filter byte 0 first).
  scenetest::writeBytes(
      dir.file("pal.png"),
      scenetest::encodePngRaw(w, h, 8, 3, {0, 0, 1, 2, 0, 2, 2, 1},
                              {{"PLTE", {255, 0, 0, 0, 255, 0, 0, 0, 255}}, {"tRNS", {0, 128, 255}}}));
  struct Case {
    const char* file;
    somm::AlphaStorage storage;
  };
  for (const Case& c :
       {Case{"rgba8.png", somm::AlphaStorage::UInt8}, Case{"ga8.png", somm::AlphaStorage::UInt8},
        Case{"pal.png", somm::AlphaStorage::UInt8}, Case{"rgba16.png", somm::AlphaStorage::UInt16},
        Case{"ga16.png", somm::AlphaStorage::UInt16}}) {
    SCOPED_TRACE(c.file);
    const std::string path = dir.file(c.file);
    int sw = 0, sh = 0, comp = 0;
    const bool sixteen = c.storage == somm::AlphaStorage::UInt16;
    // stb's alpha of texture texel (x, y) = image row h - 1 - y (the last channel), decoded at the file's precision.
    void* px = sixteen ? static_cast<void*>(stbi_load_16(path.c_str(), &sw, &sh, &comp, 0))
                       : static_cast<void*>(stbi_load(path.c_str(), &sw, &sh, &comp, 0));
    ASSERT_TRUE(px);
    std::vector<uint16_t> expect;
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        const size_t i = ((h - 1 - y) * w + x) * uint32_t(comp) + uint32_t(comp) - 1;
        expect.push_back(sixteen ? static_cast<const uint16_t*>(px)[i] : static_cast<const uint8_t*>(px)[i]);
      }
    stbi_image_free(px);
    ASSERT_EQ(sw, int(w));
    ASSERT_EQ(sh, int(h));
    ASSERT_TRUE(comp == 2 || comp == 4) << comp;
    for (const char* role : {"map_Kd ", "map_d "}) {
      auto r = loadQuad(dir, role + std::string(c.file) + "\n");
      ASSERT_TRUE(r.ok()) << r.error().message;
      const somm::Material& m = r->materials[0];
      EXPECT_EQ(m.alphaMode, somm::AlphaMode::Mask);
      ASSERT_TRUE(m.alpha);
      const somm::AlphaTexture& a = *m.alpha;
      EXPECT_EQ(a.storage, c.storage);
      ASSERT_TRUE(a.consistent());
      for (uint32_t i = 0; i < w * h; ++i) {
        EXPECT_EQ(sixteen ? uint32_t(a.alpha16[i]) : uint32_t(a.alpha8[i]), expect[i]) << i;
        EXPECT_EQ(a.texel(i), float(double(expect[i]) / (sixteen ? 65535.0 : 255.0))) << i;
      }
    }
  }
  // The palette's tRNS alphas exactly (texture row 0 = image row 1: indices 2, 2, 1; row 1: 0, 1, 2).
  auto p = loadQuad(dir, "map_Kd pal.png\n");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_EQ(p->materials[0].alpha->alpha8, (std::vector<uint8_t>{255, 255, 128, 0, 128, 255}));
  ASSERT_TRUE(p->materials[0].baseColor);
  EXPECT_EQ(p->materials[0].baseColor->rgba[4 * 2 + 1], 255);  // texel (2, 0): index 1, green
  // A JPEG has no alpha channel: as map_Kd the material stays opaque, with its colour.
  std::vector<uint8_t> rgb(8 * 8 * 3, 90);
  ASSERT_TRUE(stbi_write_jpg(dir.file("c.jpg").c_str(), 8, 8, 3, rgb.data(), 95));
  auto j = loadQuad(dir, "map_Kd c.jpg\n");
  ASSERT_TRUE(j.ok()) << j.error().message;
  EXPECT_EQ(j->materials[0].alphaMode, somm::AlphaMode::Opaque);
  EXPECT_FALSE(j->materials[0].alpha);
  ASSERT_TRUE(j->materials[0].baseColor);
  EXPECT_EQ(j->materials[0].baseColor->rgba[3], 255);
}

TEST(Obj, ImageFormats) {
  TempDir dir;
  // 8×4 image, alpha = 255 on the left half, 0 on the right; colour luminance the same.
  std::vector<uint8_t> rgba, grey;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) {
      const uint8_t v = x < 4 ? 255 : 0;
      rgba.insert(rgba.end(), {v, v, v, v});
      grey.push_back(v);
    }
  ASSERT_TRUE(stbi_write_tga(dir.file("a.tga").c_str(), 8, 4, 4, rgba.data()));
  ASSERT_TRUE(stbi_write_bmp(dir.file("a.bmp").c_str(), 8, 4, 4, rgba.data()));
  ASSERT_TRUE(stbi_write_jpg(dir.file("a.jpg").c_str(), 8, 4, 1, grey.data(), 100));
  for (const char* f : {"a.tga", "a.bmp", "a.jpg"}) {
    SCOPED_TRACE(f);
    auto r = loadQuad(dir, std::string("map_d ") + f + "\n");
    ASSERT_TRUE(r.ok()) << r.error().message;
    const somm::AlphaTexture& a = *r->materials[0].alpha;
    ASSERT_EQ(a.width, 8u);
    ASSERT_EQ(a.height, 4u);
    for (uint32_t y = 0; y < 4; ++y)
      for (uint32_t x = 0; x < 8; ++x) EXPECT_NEAR(a.at(x, y), x < 4 ? 1.0 : 0.0, 0.04) << x << "," << y;
  }
}

// TGA has no signature and stb reads zeros past the end of its data: a truncated TGA, or a few bytes that parse as
// a TGA header declaring millions of texels, is refused (not decoded to a zero-padded image).
TEST(Obj, TruncatedTgaIsAnError) {
  TempDir dir;
  auto header = [](uint8_t type, uint16_t w, uint16_t h) {
    std::string t(18, '\0');
    t[2] = char(type);
    t[12] = char(w & 255), t[13] = char(w >> 8), t[14] = char(h & 255), t[15] = char(h >> 8);
    t[16] = 32, t[17] = 8 | 0x20;  // BGRA, 8 alpha bits, top-left origin
    return t;
  };
  // Uncompressed 8×4 BGRA: alpha 255 on the left half, 0 on the right.
  std::string tga = header(2, 8, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) tga += std::string(3, '\x80') + char(x < 4 ? 255 : 0);
  writeFile(dir.file("whole.tga"), tga);
  auto r = loadQuad(dir, "map_d whole.tga\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->materials[0].alpha->at(0, 0), 1.0f);
  EXPECT_EQ(r->materials[0].alpha->at(7, 3), 0.0f);
  writeFile(dir.file("cut.tga"), tga.substr(0, tga.size() - 1));
  // Run-length encoded, 4096×4096 declared in 30 bytes: at least 131,072 packets of 5 bytes needed.
  writeFile(dir.file("rle.tga"), header(10, 4096, 4096) + std::string(12, '\x7f'));
  for (const char* f : {"cut.tga", "rle.tga"}) {
    SCOPED_TRACE(f);
    auto bad = loadQuad(dir, std::string("map_d ") + f + "\n");
    ASSERT_FALSE(bad.ok());
    const std::string& m = bad.error().message;
    EXPECT_NE(m.find(dir.file(f)), std::string::npos) << m;
    EXPECT_NE(m.find("truncated TGA"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

TEST(Obj, MissingTextureNamesMaterialAndPath) {
  TempDir dir;
  for (const char* line : {"map_Kd gone.png", "map_d gone.png"}) {
    auto r = loadQuad(dir, std::string(line) + "\n");
    ASSERT_FALSE(r.ok());
    const std::string& m = r.error().message;
    EXPECT_NE(m.find("q.obj"), std::string::npos) << m;
    EXPECT_NE(m.find("'leaf'"), std::string::npos) << m;
    EXPECT_NE(m.find(dir.file("gone.png")), std::string::npos) << m;
    EXPECT_EQ(r.error().code, somm::ErrorCode::IoError);
  }
  writeFile(dir.file("junk.png"), std::string(100, 'x'));
  auto r = loadQuad(dir, "map_d junk.png\n");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("junk.png"), std::string::npos);
  EXPECT_NE(r.error().message.find("decode"), std::string::npos);
}

// The file streams to the parser in 64 KiB chunks and its face/line/point indices are checked on the way: an index
// above 2^31 - 1 is found wherever it lies — split across two chunks, at the very end without a newline, in a
// line that starts with spaces or tabs — and named with its line; large indices elsewhere (a vertex coordinate, a
// comment, an "fo" line) are not indices.
TEST(Obj, IndexOverflowFoundAcrossChunks) {
  TempDir dir;
  std::string head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n# 99999999999\nv 99999999999 0 0\nfo 99999999999\n";
  while (head.size() < 65536 - 100) head += "# padding padding padding padding\n";
  const auto lineCount = [](const std::string& t) { return size_t(std::count(t.begin(), t.end(), '\n')); };
  for (size_t split : {0u, 3u, 6u, 10u}) {
    // The token starts `split` bytes before the first chunk ends (0: at the start of the second chunk).
    const std::string prefix = "\t f 1 2 ";
    std::string text = head;
    const size_t pad = 65536 - split - prefix.size() - text.size();
    text.push_back('#');
    text.append(pad - 2, ' ');
    text.push_back('\n');
    const size_t line = lineCount(text) + 1;
    ASSERT_EQ(text.size() + prefix.size(), 65536 - split);
    text += prefix + "21474836480 3\nf 1 2 3\n";
    SCOPED_TRACE(split);
    writeFile(dir.file("big.obj"), text);
    auto r = somm::loadScene(dir.file("big.obj"));
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().message, dir.file("big.obj") + ": line " + std::to_string(line) +
                                     ": index 21474836480 is out of range (at most 2^31 - 1)");
  }
  writeFile(dir.file("end.obj"), head + "p 1 2147483648");  // the last line, no newline
  auto r = somm::loadScene(dir.file("end.obj"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, dir.file("end.obj") + ": line " + std::to_string(lineCount(head) + 1) +
                                   ": index 2147483648 is out of range (at most 2^31 - 1)");
  writeFile(dir.file("ok.obj"), head + "f 1 2 2147483647\n");  // in range: the face check rejects it instead
  auto ok = somm::loadScene(dir.file("ok.obj"));
  ASSERT_FALSE(ok.ok());
  EXPECT_NE(ok.error().message.find("refers to vertex 2147483647 but the file has 4 vertices"),
            std::string::npos)
      << ok.error().message;
  writeFile(dir.file("fine.obj"), head + "f 1 2 3");
  auto fine = somm::loadScene(dir.file("fine.obj"));
  ASSERT_TRUE(fine.ok()) << fine.error().message;
  ASSERT_EQ(fine->geometries.size(), 1u);
  EXPECT_EQ(fine->geometries[0].indices.size(), 3u);
}

TEST(Obj, MalformedFilesGiveErrors) {
  TempDir dir;
  const std::vector<std::string> bad = {
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 9\n",                // vertex index past the end
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3/5\n",  // texcoord index past the end
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nf -1 -2 -7\n",             // relative index before the start
  };
  for (const std::string& text : bad) {
    SCOPED_TRACE(text);
    writeFile(dir.file("bad.obj"), text);
    auto r = somm::loadScene(dir.file("bad.obj"));
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().message.rfind(dir.file("bad.obj") + ": ", 0), 0u) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
  }
  // Binary garbage: either an error or an empty scene, never a crash.
  std::string junk;
  for (int i = 0; i < 4096; ++i) junk += char((i * 7919) & 0xFF);
  writeFile(dir.file("junk.obj"), junk);
  auto r = somm::loadScene(dir.file("junk.obj"));
  if (r.ok()) {
    EXPECT_EQ(r->geometries.size(), 0u);
  }
  // A missing .mtl is a warning, not an error.
  writeFile(dir.file("nomtl.obj"), "mtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl x\nf 1 2 3\n");
  auto r2 = somm::loadScene(dir.file("nomtl.obj"));
  ASSERT_TRUE(r2.ok()) << r2.error().message;
  EXPECT_EQ(r2->geometries.size(), 1u);
  EXPECT_FALSE(r2->warnings.empty());
}

}  // namespace
