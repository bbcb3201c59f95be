// SPDX-License-Identifier: MIT
// glTF loading: .gltf (external and data-URI buffers), .glb, images of every layout, materials, samplers,
// KHR_texture_transform, node hierarchy, camera, and malformed files.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>

#include "scene_test_util.h"
#include "somm/scene.h"

namespace {

using scenetest::GltfBuilder;
using scenetest::quadGltf;
using scenetest::TempDir;

// 4×2 RGBA image: row 0 (top) alpha 255, row 1 alpha 0; colours distinct per texel.
std::vector<uint8_t> topOpaqueImage() {
  std::vector<uint8_t> px;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x)
      px.insert(px.end(), {uint8_t(10 * x), uint8_t(100 + y), 7, uint8_t(y == 0 ? 255 : 0)});
  return scenetest::encodePng8(4, 2, 4, px);
}

void maskMaterial(GltfBuilder& b, int image, double cutoff = 0.5) {
  b.j["textures"] = {{{"source", image}}};
  b.j["materials"] = {{{"name", "leaf"},
                       {"alphaMode", "MASK"},
                       {"alphaCutoff", cutoff},
                       {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
}

void expectQuadGeometry(const somm::Scene& s) {
  ASSERT_EQ(s.geometries.size(), 1u);
  const somm::Geometry& g = s.geometries[0];
  EXPECT_EQ(g.name, "quad/0");
  EXPECT_EQ(g.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}));
  EXPECT_EQ(g.uvs, (std::vector<float>{0, 0, 1, 0, 1, 1, 0, 1}));
  EXPECT_EQ(g.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  ASSERT_EQ(s.instances.size(), 1u);
  EXPECT_EQ(s.instances[0].geometry, 0u);
}

void expectTopOpaqueMaterial(const somm::Scene& s) {
  ASSERT_EQ(s.materials.size(), 1u);
  const somm::Material& m = s.materials[0];
  EXPECT_EQ(m.name, "leaf");
  EXPECT_TRUE(m.alphaTested());
  ASSERT_TRUE(m.alpha);
  ASSERT_EQ(m.alpha->width, 4u);
  ASSERT_EQ(m.alpha->height, 2u);
  for (uint32_t x = 0; x < 4; ++x) {
    EXPECT_EQ(m.alpha->at(x, 0), 1.0f);  // glTF: image row 0 is v = 0
    EXPECT_EQ(m.alpha->at(x, 1), 0.0f);
  }
  const somm::Sampler nearest{somm::Wrap::Repeat, somm::Wrap::Repeat, somm::Filter::Nearest};
  EXPECT_EQ(somm::sampleAlpha(*m.alpha, nearest, 0.3f, 0.25f), 1.0f);
  EXPECT_EQ(somm::sampleAlpha(*m.alpha, nearest, 0.3f, 0.75f), 0.0f);
  ASSERT_TRUE(m.baseColor);
  EXPECT_EQ(m.baseColor->width, 4u);
  EXPECT_EQ(m.baseColor->rgba[(1 * 4 + 3) * 4 + 0], 30);   // texel (3, 1) red
  EXPECT_EQ(m.baseColor->rgba[(1 * 4 + 3) * 4 + 1], 101);  // green encodes the row
}

TEST(Gltf, DataUriBufferAndImage) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  maskMaterial(b, b.imageDataUri(topOpaqueImage()));
  b.writeGltf(dir.file("q.gltf"));
  auto r = somm::loadScene(dir.file("q.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  expectQuadGeometry(*r);
  expectTopOpaqueMaterial(*r);
  EXPECT_EQ(r->sourcePath, dir.file("q.gltf"));
}

TEST(Gltf, ExternalBufferAndImage) {
  TempDir dir;
  scenetest::writeBytes(dir.file("tex.png"), topOpaqueImage());
  GltfBuilder b = quadGltf();
  maskMaterial(b, b.imageFile("tex.png"));
  b.writeGltf(dir.file("q.gltf"), "q.bin");
  auto r = somm::loadScene(dir.file("q.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  expectQuadGeometry(*r);
  expectTopOpaqueMaterial(*r);
  EXPECT_EQ(r->materials[0].alphaSource, dir.file("tex.png"));
}

TEST(Gltf, GlbWithImageInBuffer) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  maskMaterial(b, b.imageInBuffer(topOpaqueImage()));
  b.writeGlb(dir.file("q.GLB"));  // extension case does not matter
  auto r = somm::loadScene(dir.file("q.GLB"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  expectQuadGeometry(*r);
  expectTopOpaqueMaterial(*r);
}

TEST(Gltf, SixteenBitAndChannelLayouts) {
  TempDir dir;
  // 16-bit grey+alpha: alpha values only representable in 16 bits.
  const std::vector<uint16_t> ga = {0, 32768, 65535, 1, 1000, 65535, 5, 0};
  struct Case {
    std::vector<uint8_t> png;
    std::vector<float> alpha;
  };
  std::vector<Case> cases;
  cases.push_back(
      {scenetest::encodePng16(2, 2, 2, ga), {float(32768 / 65535.0), float(1 / 65535.0), 1.0f, 0.0f}});
  cases.push_back({scenetest::encodePng16(2, 1, 4, {1, 2, 3, 40000, 4, 5, 6, 7}),
                   {float(40000 / 65535.0), float(7 / 65535.0)}});
  cases.push_back({scenetest::encodePng16(2, 1, 1, {0, 65535}), {1.0f, 1.0f}});  // grey: no alpha → 1
  cases.push_back({scenetest::encodePng8(2, 1, 2, {0, 128, 255, 3}), {float(128 / 255.0), float(3 / 255.0)}});
  cases.push_back({scenetest::encodePng8(2, 1, 3, {0, 1, 2, 3, 4, 5}), {1.0f, 1.0f}});  // RGB → 1
  cases.push_back({scenetest::encodePng8(1, 1, 1, {9}), {1.0f}});
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE(i);
    GltfBuilder b = quadGltf();
    maskMaterial(b, b.imageDataUri(cases[i].png));
    b.writeGltf(dir.file("c.gltf"));
    auto r = somm::loadScene(dir.file("c.gltf"));
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(r->materials[0].alpha);
    EXPECT_EQ(r->materials[0].alpha->values(), cases[i].alpha);
  }
}

TEST(Gltf, BaseColorFactorMultipliesAlpha) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  maskMaterial(b, b.imageDataUri(scenetest::encodePng8(2, 1, 4, {0, 0, 0, 255, 0, 0, 0, 128})));
  b.j["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {1.0, 0.5, 1.0, 0.5};
  b.writeGltf(dir.file("f.gltf"));
  auto r = somm::loadScene(dir.file("f.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::Material& m = r->materials[0];
  EXPECT_EQ(m.baseColorFactor, (std::array<float, 4>{1.0f, 0.5f, 1.0f, 0.5f}));
  ASSERT_TRUE(m.alpha);
  EXPECT_FLOAT_EQ(m.alpha->at(0, 0), 0.5f);
  EXPECT_NEAR(m.alpha->at(1, 0), 128.0 / 255.0 * 0.5, 1e-7);
  // The colour image is the texture as stored (the factor is applied when shading).
  EXPECT_EQ(m.baseColor->rgba[7], 128);

  // No texture: alpha is the constant factor alone.
  GltfBuilder c = quadGltf();
  c.j["materials"] = {{{"name", "const"},
                       {"alphaMode", "MASK"},
                       {"pbrMetallicRoughness", {{"baseColorFactor", {1, 1, 1, 0.25}}}}}};
  c.writeGltf(dir.file("c.gltf"));
  auto r2 = somm::loadScene(dir.file("c.gltf"));
  ASSERT_TRUE(r2.ok()) << r2.error().message;
  EXPECT_FALSE(r2->materials[0].alpha);
  EXPECT_FALSE(r2->materials[0].baseColor);
  EXPECT_EQ(r2->materials[0].baseColorFactor[3], 0.25f);
  EXPECT_EQ(r2->materials[0].alphaCutoff, 0.5f);  // default
  EXPECT_TRUE(r2->materials[0].alphaTested());
}

TEST(Gltf, SamplerModes) {
  TempDir dir;
  struct Case {
    nlohmann::json sampler;
    somm::Sampler expect;
  };
  const std::vector<Case> cases = {
      {{{"magFilter", 9728}, {"wrapS", 33071}, {"wrapT", 33648}},
       {somm::Wrap::ClampToEdge, somm::Wrap::MirroredRepeat, somm::Filter::Nearest}},
      {{{"magFilter", 9729}, {"minFilter", 9728}, {"wrapS", 33648}, {"wrapT", 10497}},
       {somm::Wrap::MirroredRepeat, somm::Wrap::Repeat, somm::Filter::Linear}},
      {nlohmann::json::object(), {somm::Wrap::Repeat, somm::Wrap::Repeat, somm::Filter::Linear}},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE(i);
    GltfBuilder b = quadGltf();
    maskMaterial(b, b.imageDataUri(topOpaqueImage()));
    b.j["samplers"] = {cases[i].sampler};
    b.j["textures"][0]["sampler"] = 0;
    b.writeGltf(dir.file("s.gltf"));
    auto r = somm::loadScene(dir.file("s.gltf"));
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->materials[0].sampler, cases[i].expect);
  }
}

TEST(Gltf, AlphaModes) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  const int img = b.imageDataUri(topOpaqueImage());
  b.j["textures"] = {{{"source", img}}};
  auto tex = nlohmann::json{{"baseColorTexture", {{"index", 0}}}};
  b.j["materials"] = {
      {{"name", "blend"}, {"alphaMode", "BLEND"}, {"alphaCutoff", 0.3}, {"pbrMetallicRoughness", tex}},
      {{"name", "opaque"}, {"pbrMetallicRoughness", tex}},
      {{"name", "mask"}, {"alphaMode", "MASK"}, {"alphaCutoff", 0.75}, {"pbrMetallicRoughness", tex}}};
  b.writeGltf(dir.file("m.gltf"));
  auto r = somm::loadScene(dir.file("m.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->materials.size(), 3u);
  EXPECT_EQ(r->materials[0].alphaMode, somm::AlphaMode::Blend);
  EXPECT_FALSE(r->materials[0].alphaTested());
  bool noted = false;
  for (const auto& w : r->warnings)
    noted |= w.find("blend") != std::string::npos && w.find("BLEND") != std::string::npos;
  EXPECT_TRUE(noted);
  EXPECT_EQ(r->materials[1].alphaMode, somm::AlphaMode::Opaque);
  EXPECT_FALSE(r->materials[1].alpha);  // only alpha-tested materials carry an alpha texture
  EXPECT_TRUE(r->materials[1].baseColor);
  EXPECT_EQ(r->materials[2].alphaMode, somm::AlphaMode::Mask);
  EXPECT_EQ(r->materials[2].alphaCutoff, 0.75f);

  somm::LoadOptions opt;
  opt.blendAsMask = true;
  auto r2 = somm::loadScene(dir.file("m.gltf"), opt);
  ASSERT_TRUE(r2.ok()) << r2.error().message;
  EXPECT_EQ(r2->materials[0].alphaMode, somm::AlphaMode::Mask);
  EXPECT_TRUE(r2->materials[0].alphaTested());
  EXPECT_EQ(r2->materials[0].alphaCutoff, 0.3f);
  ASSERT_TRUE(r2->materials[0].alpha);
  EXPECT_EQ(r2->materials[0].alpha.get(), r2->materials[2].alpha.get());  // same image, same factor: shared
}

TEST(Gltf, KhrTextureTransform) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  const std::vector<float> uv1 = {0.1f, 0.2f, 0.9f, 0.3f, 0.7f, 0.8f, -0.4f, 1.5f};
  b.j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"] = b.floats(uv1, "VEC2", 2);
  maskMaterial(b, b.imageDataUri(topOpaqueImage()));
  const double off[2] = {0.5, 0.25}, sc[2] = {2, 3}, rot = 0.3;
  b.j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = {
      {"KHR_texture_transform",
       {{"offset", {off[0], off[1]}}, {"rotation", rot}, {"scale", {sc[0], sc[1]}}, {"texCoord", 1}}}};
  b.j["extensionsUsed"] = {"KHR_texture_transform"};
  b.writeGltf(dir.file("t.gltf"));
  auto r = somm::loadScene(dir.file("t.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto& uv = r->geometries[0].uvs;
  ASSERT_EQ(uv.size(), 8u);
  // The extension's matrix: T(offset) · R(rotation) · S(scale), R = [cos sin; -sin cos].
  const double T[3][3] = {{1, 0, off[0]}, {0, 1, off[1]}, {0, 0, 1}};
  const double R[3][3] = {{std::cos(rot), std::sin(rot), 0}, {-std::sin(rot), std::cos(rot), 0}, {0, 0, 1}};
  const double S[3][3] = {{sc[0], 0, 0}, {0, sc[1], 0}, {0, 0, 1}};
  double TR[3][3] = {}, M[3][3] = {};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) TR[i][j] += T[i][k] * R[k][j];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) M[i][j] += TR[i][k] * S[k][j];
  for (int v = 0; v < 4; ++v) {
    const double u0 = uv1[size_t(v) * 2], v0 = uv1[size_t(v) * 2 + 1];
    EXPECT_NEAR(uv[size_t(v) * 2], M[0][0] * u0 + M[0][1] * v0 + M[0][2], 1e-6);
    EXPECT_NEAR(uv[size_t(v) * 2 + 1], M[1][0] * u0 + M[1][1] * v0 + M[1][2], 1e-6);
  }
  // Offset only, spec example: offset (0.5, 0) moves u by 0.5 and keeps TEXCOORD_0.
  b.j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = {
      {"KHR_texture_transform", {{"offset", {0.5, 0.0}}}}};
  b.writeGltf(dir.file("t2.gltf"));
  auto r2 = somm::loadScene(dir.file("t2.gltf"));
  ASSERT_TRUE(r2.ok()) << r2.error().message;
  EXPECT_EQ(r2->geometries[0].uvs, (std::vector<float>{0.5f, 0, 1.5f, 0, 1.5f, 1, 0.5f, 1}));
}

TEST(Gltf, UvSetFromTexCoord) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  const std::vector<float> uv1 = {0.25f, 0.25f, 0.5f, 0.25f, 0.5f, 0.5f, 0.25f, 0.5f};
  b.j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"] = b.floats(uv1, "VEC2", 2);
  maskMaterial(b, b.imageDataUri(topOpaqueImage()));
  b.j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 1;
  b.writeGltf(dir.file("u.gltf"));
  auto r = somm::loadScene(dir.file("u.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->geometries[0].uvs, uv1);
  // Normalised unsigned byte UVs.
  GltfBuilder c = quadGltf();
  const uint8_t q[8] = {0, 0, 255, 0, 255, 51, 0, 102};
  c.j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = c.accessor(c.view(q, 8), 5121, 4, "VEC2");
  c.j["accessors"].back()["normalized"] = true;
  maskMaterial(c, c.imageDataUri(topOpaqueImage()));
  c.writeGltf(dir.file("n.gltf"));
  auto r2 = somm::loadScene(dir.file("n.gltf"));
  ASSERT_TRUE(r2.ok()) << r2.error().message;
  EXPECT_EQ(r2->geometries[0].uvs, (std::vector<float>{0, 0, 1, 0, 1, 0.2f, 0, 0.4f}));
}

TEST(Gltf, PrimitivesModesAndDefaultMaterial) {
  TempDir dir;
  GltfBuilder b;
  const int pos = b.floats({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 2, 2, 3, 3, 3}, "VEC3", 3);
  const int idx32 = b.indices32({3, 2, 1});
  b.j["meshes"] = {{{"name", "first"},
                    {"primitives",
                     {{{"attributes", {{"POSITION", pos}}}},  // non-indexed: 6 vertices → 2 triangles
                      {{"attributes", {{"POSITION", pos}}}, {"mode", 5}},  // triangle strip: skipped
                      {{"attributes", {{"POSITION", pos}}}, {"indices", idx32}}}}},  // 32-bit indices
                   {{"primitives", {{{"attributes", {{"POSITION", pos}}}, {"mode", 0}}}}}};
  b.j["nodes"] = {{{"mesh", 0}}, {{"mesh", 1}}, {{"mesh", 0}, {"translation", {0, 0, 1}}}};
  b.j["scenes"] = {{{"nodes", {0, 1, 2}}}};
  b.writeGltf(dir.file("p.gltf"));
  auto r = somm::loadScene(dir.file("p.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::Scene& s = *r;
  ASSERT_EQ(s.geometries.size(), 4u);
  EXPECT_EQ(s.geometries[0].name, "first/0");
  EXPECT_EQ(s.geometries[1].name, "first/1");
  EXPECT_EQ(s.geometries[2].name, "first/2");
  EXPECT_EQ(s.geometries[3].name, "mesh1/0");
  EXPECT_EQ(s.geometries[0].indices, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(s.geometries[1].triangleCount(), 0u);
  EXPECT_EQ(s.geometries[2].indices, (std::vector<uint32_t>{3, 2, 1}));
  EXPECT_EQ(s.geometries[3].triangleCount(), 0u);
  size_t modeWarnings = 0;
  for (const auto& w : s.warnings) modeWarnings += w.find("not TRIANGLES") != std::string::npos;
  EXPECT_EQ(modeWarnings, 2u);
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].name, "default");
  EXPECT_EQ(s.materials[0].alphaMode, somm::AlphaMode::Opaque);
  for (const auto& g : s.geometries) EXPECT_EQ(g.material, 0u);
  EXPECT_EQ(s.geometries[0].uvs, std::vector<float>(12, 0.0f));  // no TEXCOORD_0: zeros
  // Instances: node 0 (mesh 0: geometries 0..2), node 1 (geometry 3), node 2 (mesh 0 again, translated).
  ASSERT_EQ(s.instances.size(), 7u);
  const uint32_t expectGeom[7] = {0, 1, 2, 3, 0, 1, 2};
  for (size_t i = 0; i < 7; ++i) EXPECT_EQ(s.instances[i].geometry, expectGeom[i]);
  EXPECT_EQ(s.instances[4].transform[14], 1.0f);
  EXPECT_EQ(s.instances[0].transform[14], 0.0f);
}

// Rotates v by the unit quaternion q = (x, y, z, w): v + 2w(q×v) + 2q×(q×v).
std::array<double, 3> rotate(const double q[4], const std::array<double, 3>& v) {
  auto cross = [](const double a[3], const std::array<double, 3>& b) {
    return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                 a[0] * b[1] - a[1] * b[0]};
  };
  const auto c1 = cross(q, v);
  const auto c2 = cross(q, c1);
  return {v[0] + 2 * q[3] * c1[0] + 2 * c2[0], v[1] + 2 * q[3] * c1[1] + 2 * c2[1],
          v[2] + 2 * q[3] * c1[2] + 2 * c2[2]};
}

TEST(Gltf, NodeHierarchyAndCamera) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  const double s45 = std::sin(std::numbers::pi / 4), c45 = std::cos(std::numbers::pi / 4);
  const double q[4] = {0.2, 0.4, -0.3, 0.0};
  const double qn = std::sqrt(0.04 + 0.16 + 0.09 + 0.7 * 0.7);
  const double qu[4] = {q[0] / qn, q[1] / qn, q[2] / qn, 0.7 / qn};
  b.j["nodes"] = {
      {{"translation", {1, 2, 3}}, {"children", {1, 3}}},
      {{"scale", {2, 2, 2}}, {"rotation", {qu[0], qu[1], qu[2], qu[3]}}, {"mesh", 0}},
      {{"mesh", 0}, {"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 7, 8, 9, 1}}},
      {{"rotation", {0, s45, 0, c45}}, {"children", {4}}},
      {{"camera", 0}, {"translation", {0, 0, 5}}},
  };
  b.j["scenes"] = {{{"nodes", {0, 2}}}};
  b.j["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.6}, {"znear", 0.1}}}}};
  b.j["materials"] = {{{"name", "m"}}};
  b.writeGltf(dir.file("h.gltf"));
  auto r = somm::loadScene(dir.file("h.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  const somm::Scene& s = *r;
  ASSERT_EQ(s.instances.size(), 2u);
  // Instance 0: world = T(1,2,3) · R(q) · S(2); check by transforming points.
  for (const auto& p : std::vector<std::array<double, 3>>{{1, 0, 0}, {0, 1, 0}, {0.5, -2, 3}}) {
    const auto rp = rotate(qu, {2 * p[0], 2 * p[1], 2 * p[2]});
    const auto& m = s.instances[0].transform;
    for (int row = 0; row < 3; ++row) {
      const double got =
          m[size_t(row)] * p[0] + m[size_t(4 + row)] * p[1] + m[size_t(8 + row)] * p[2] + m[size_t(12 + row)];
      EXPECT_NEAR(got, rp[size_t(row)] + (row + 1), 1e-5);
    }
    EXPECT_EQ(m[3], 0.0f);
    EXPECT_EQ(m[15], 1.0f);
  }
  EXPECT_EQ(s.instances[1].transform,
            (std::array<float, 16>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 7, 8, 9, 1}));
  EXPECT_EQ(s.instances[0].geometry, 0u);
  EXPECT_EQ(s.instances[1].geometry, 0u);  // instances share the geometry
  // Camera: T(1,2,3) · Ry(90°) · T(0,0,5): eye (1+5, 2, 3), looking along -x.
  ASSERT_TRUE(s.camera.has_value());
  const somm::Camera& c = *s.camera;
  EXPECT_NEAR(c.eye[0], 6, 1e-5);
  EXPECT_NEAR(c.eye[1], 2, 1e-5);
  EXPECT_NEAR(c.eye[2], 3, 1e-5);
  EXPECT_NEAR(c.target[0], 5, 1e-5);
  EXPECT_NEAR(c.target[1], 2, 1e-5);
  EXPECT_NEAR(c.target[2], 3, 1e-5);
  EXPECT_NEAR(c.up[0], 0, 1e-6);
  EXPECT_NEAR(c.up[1], 1, 1e-6);
  EXPECT_NEAR(c.up[2], 0, 1e-6);
  EXPECT_FLOAT_EQ(c.yfovRadians, 0.6f);
}

TEST(Gltf, NonFinitePositionsAndUvsAreKeptAndCounted) {
  TempDir dir;
  GltfBuilder b;
  const float nan = std::nanf(""), inf = INFINITY;
  const int pos = b.floats({0, 0, 0, nan, 0, 0, 1, 1, 0}, "VEC3", 3);
  const int uv = b.floats({0, inf, 1, 0, 1, 1}, "VEC2", 2);
  b.j["meshes"] = {{{"primitives", {{{"attributes", {{"POSITION", pos}, {"TEXCOORD_0", uv}}}}}}}};
  b.j["nodes"] = {{{"mesh", 0}}};
  b.j["scenes"] = {{{"nodes", {0}}}};
  b.writeGltf(dir.file("nan.gltf"));
  auto r = somm::loadScene(dir.file("nan.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(std::isnan(r->geometries[0].positions[3]));
  EXPECT_TRUE(std::isinf(r->geometries[0].uvs[1]));
  bool counted = false;
  for (const auto& w : r->warnings)
    counted |= w.find("1 non-finite position and 1 non-finite texture coordinate") != std::string::npos;
  EXPECT_TRUE(counted);
}

TEST(Gltf, MissingAndCorruptTexturesNameMaterialAndPath) {
  TempDir dir;
  {
    GltfBuilder b = quadGltf();
    maskMaterial(b, b.imageFile("nope.png"));
    b.writeGltf(dir.file("miss.gltf"));
    auto r = somm::loadScene(dir.file("miss.gltf"));
    ASSERT_FALSE(r.ok());
    const std::string& m = r.error().message;
    EXPECT_NE(m.find("miss.gltf"), std::string::npos) << m;
    EXPECT_NE(m.find("'leaf'"), std::string::npos) << m;
    EXPECT_NE(m.find(dir.file("nope.png")), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  {
    scenetest::writeFile(dir.file("bad.png"), "this is not an image at all");
    GltfBuilder b = quadGltf();
    maskMaterial(b, b.imageFile("bad.png"));
    b.writeGltf(dir.file("bad.gltf"));
    auto r = somm::loadScene(dir.file("bad.gltf"));
    ASSERT_FALSE(r.ok());
    const std::string& m = r.error().message;
    EXPECT_NE(m.find("'leaf'"), std::string::npos) << m;
    EXPECT_NE(m.find("bad.png"), std::string::npos) << m;
    EXPECT_NE(m.find("decode"), std::string::npos) << m;
  }
}

// The images are decoded in parallel after the materials are read: the same textures and errors at one and two
// threads, an image shared by materials decoded once (one texture per alpha factor), a decode error reported at the
// first material that takes the image (before a later material's error, after an earlier one's), and an opaque
// material's image not decoded when colours are not loaded.
TEST(Gltf, ImagesDecodedInParallelAsIfInMaterialOrder) {
  TempDir dir;
  // Three images of distinct sizes and alphas (largest first is the decode order, not the material order).
  auto image = [](int w, uint8_t base) {
    std::vector<uint8_t> px;
    for (int x = 0; x < w; ++x) px.insert(px.end(), {uint8_t(x), 2, 3, uint8_t(base + 7 * x)});
    return scenetest::encodePng8(w, 1, 4, px);
  };
  const std::vector<std::pair<int, uint8_t>> shapes = {{3, 10}, {9, 40}, {5, 90}};
  // Image 1 with a valid header but a corrupt stream (the first deflate block of the reserved type 3): it fails
  // when decoded, not when its header is checked.
  std::vector<uint8_t> corrupt = image(shapes[1].first, shapes[1].second);
  for (size_t i = 8; i + 8 < corrupt.size(); ++i)
    if (std::memcmp(corrupt.data() + i, "IDAT", 4) == 0) {
      corrupt[i + 4 + 2] = 0xff;
      break;
    }
  auto build = [&](bool corruptSecond) {
    GltfBuilder b = quadGltf();
    for (size_t k = 0; k < shapes.size(); ++k)
      b.imageDataUri(k == 1 && corruptSecond ? corrupt : image(shapes[k].first, shapes[k].second));
    b.j["textures"] = {{{"source", 0}}, {{"source", 1}}, {{"source", 2}}};
    auto mat = [](const char* name, int tex, double factor, const char* mode) {
      return nlohmann::json{
          {"name", name},
          {"alphaMode", mode},
          {"pbrMetallicRoughness",
           {{"baseColorTexture", {{"index", tex}}}, {"baseColorFactor", {1, 1, 1, factor}}}}};
    };
    // m0 and m2 share image 2 with one factor, m3 takes it with another; m1 takes image 1, m4 image 0 (opaque).
    b.j["materials"] = {mat("m0", 2, 1.0, "MASK"), mat("m1", 1, 1.0, "MASK"), mat("m2", 2, 1.0, "MASK"),
                        mat("m3", 2, 0.5, "MASK"), mat("m4", 0, 1.0, "OPAQUE")};
    return b;
  };
  build(false).writeGltf(dir.file("ok.gltf"));
  build(true).writeGltf(dir.file("bad1.gltf"));
  {
    GltfBuilder b = build(true);
    b.j["materials"][3]["alphaCutoff"] = -1;  // a later material's error: image 1's (at m1) comes first
    b.writeGltf(dir.file("bad1late.gltf"));
  }
  {
    GltfBuilder b = build(true);
    b.j["materials"][0]["alphaCutoff"] = -1;  // an earlier material's error comes first
    b.writeGltf(dir.file("bad1early.gltf"));
  }
  {
    GltfBuilder b = build(false);
    b.j["images"][0] = {{"uri", "data:image/png;base64,AAAA"}};  // only the opaque m4 takes it
    b.writeGltf(dir.file("opaquebad.gltf"));
  }
  for (int threads : {1, 2}) {
    SCOPED_TRACE(std::to_string(threads) + " threads");
    tbb::global_control cap(tbb::global_control::max_allowed_parallelism, size_t(threads));
    for (bool color : {false, true}) {
      somm::LoadOptions o;
      o.loadColor = color;
      auto r = somm::loadScene(dir.file("ok.gltf"), o);
      ASSERT_TRUE(r.ok()) << r.error().message;
      const auto& ms = r->materials;
      ASSERT_EQ(ms.size(), 5u);
      auto expectAlpha = [](const somm::Material& m, int w, uint8_t base, float factor) {
        ASSERT_TRUE(m.alpha) << m.name;
        ASSERT_EQ(m.alpha->width, uint32_t(w));
        for (int x = 0; x < w; ++x)
          EXPECT_EQ(m.alpha->at(uint32_t(x), 0), float(uint8_t(base + 7 * x)) / 255.0f * factor)
              << m.name << x;
      };
      expectAlpha(ms[0], 5, 90, 1.0f);
      expectAlpha(ms[1], 9, 40, 1.0f);
      expectAlpha(ms[3], 5, 90, 0.5f);
      EXPECT_EQ(ms[0].alpha, ms[2].alpha);  // one conversion per (image, factor)
      EXPECT_NE(ms[0].alpha, ms[3].alpha);
      EXPECT_FALSE(ms[4].alpha);  // opaque
      if (color) {
        ASSERT_TRUE(ms[4].baseColor);
        EXPECT_EQ(ms[4].baseColor->width, 3u);
        EXPECT_EQ(ms[0].baseColor, ms[3].baseColor);
        ASSERT_TRUE(ms[1].baseColor);
        EXPECT_EQ(ms[1].baseColor->width, 9u);
      } else {
        for (const somm::Material& m : ms) EXPECT_FALSE(m.baseColor) << m.name;
      }
    }
    auto error = [&](const char* file, bool color) {
      somm::LoadOptions o;
      o.loadColor = color;
      auto r = somm::loadScene(dir.file(file), o);
      return r.ok() ? std::string("(loaded)") : r.error().message;
    };
    for (const char* f : {"bad1.gltf", "bad1late.gltf"}) {
      const std::string m = error(f, false);
      EXPECT_NE(m.find("material 'm1': texture image 1 (data URI): cannot decode image"), std::string::npos)
          << m;
    }
    EXPECT_NE(error("bad1early.gltf", false).find("material 'm0': invalid alphaCutoff"), std::string::npos)
        << error("bad1early.gltf", false);
    EXPECT_EQ(error("opaquebad.gltf", false), "(loaded)");  // nothing is taken from m4's image
    EXPECT_NE(error("opaquebad.gltf", true).find("material 'm4': texture image 0 (data URI)"),
              std::string::npos)
        << error("opaquebad.gltf", true);
  }
}

// Every malformed variant must give a one-line error naming the file, never a crash.
TEST(Gltf, MalformedFilesGiveErrors) {
  TempDir dir;
  std::vector<std::pair<std::string, std::function<void(GltfBuilder&)>>> mutations = {
      {"view past end", [](GltfBuilder& b) { b.j["bufferViews"][0]["byteLength"] = 100000; }},
      {"view offset past end", [](GltfBuilder& b) { b.j["bufferViews"][1]["byteOffset"] = 1u << 30; }},
      {"accessor count", [](GltfBuilder& b) { b.j["accessors"][0]["count"] = 1000; }},
      {"accessor huge count", [](GltfBuilder& b) { b.j["accessors"][1]["count"] = 1ull << 62; }},
      {"dataless huge accessor",
       [](GltfBuilder& b) {
         b.j["accessors"][0].erase("bufferView");
         b.j["accessors"][0]["count"] = 1u << 30;
       }},
      {"negative cutoff", [](GltfBuilder& b) { b.j["materials"][0]["alphaCutoff"] = -0.5; }},
      {"infinite factor",
       [](GltfBuilder& b) {
         b.j["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {1, 1, 1, 1e300};
       }},
      {"accessor offset", [](GltfBuilder& b) { b.j["accessors"][2]["byteOffset"] = 2; }},
      {"accessor missing view", [](GltfBuilder& b) { b.j["accessors"][0]["bufferView"] = 17; }},
      {"missing accessor", [](GltfBuilder& b) { b.j["meshes"][0]["primitives"][0]["indices"] = 99; }},
      {"index out of range",
       [](GltfBuilder& b) {
         const int v = b.view(std::vector<uint16_t>{0, 1, 4}.data(), 6);
         b.j["meshes"][0]["primitives"][0]["indices"] = b.accessor(v, 5123, 3, "SCALAR");
       }},
      {"float indices", [](GltfBuilder& b) { b.j["meshes"][0]["primitives"][0]["indices"] = 1; }},
      {"vec2 positions",
       [](GltfBuilder& b) { b.j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 1; }},
      {"bad component type", [](GltfBuilder& b) { b.j["accessors"][0]["componentType"] = 5130; }},
      {"stride too small", [](GltfBuilder& b) { b.j["bufferViews"][0]["byteStride"] = 4; }},
      {"no position",
       [](GltfBuilder& b) { b.j["meshes"][0]["primitives"][0]["attributes"].erase("POSITION"); }},
      {"missing material", [](GltfBuilder& b) { b.j["meshes"][0]["primitives"][0]["material"] = 3; }},
      {"missing texture",
       [](GltfBuilder& b) { b.j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = 4; }},
      {"missing image", [](GltfBuilder& b) { b.j["textures"][0]["source"] = 9; }},
      {"missing sampler", [](GltfBuilder& b) { b.j["textures"][0]["sampler"] = 2; }},
      {"image view past end",
       [](GltfBuilder& b) {
         b.j["images"][0] = {{"bufferView", 0}, {"mimeType", "image/png"}};
         b.j["bufferViews"][0]["byteLength"] = 1u << 20;
       }},
      {"image view garbage",
       [](GltfBuilder& b) {
         b.j["images"][0] = {{"bufferView", 0}, {"mimeType", "image/png"}};
       }},
      {"node cycle",
       [](GltfBuilder& b) {
         b.j["nodes"] = {{{"mesh", 0}, {"children", {1}}}, {{"children", {0}}}};
       }},
      {"node self",
       [](GltfBuilder& b) {
         b.j["nodes"] = {{{"mesh", 0}, {"children", {0}}}};
       }},
      {"missing child",
       [](GltfBuilder& b) {
         b.j["nodes"] = {{{"mesh", 0}, {"children", {5}}}};
       }},
      {"missing mesh",
       [](GltfBuilder& b) {
         b.j["nodes"] = {{{"mesh", 3}}};
       }},
      {"missing scene node",
       [](GltfBuilder& b) {
         b.j["scenes"] = {{{"nodes", {4}}}};
       }},
      {"bad transform",
       [](GltfBuilder& b) {
         b.j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = {
             {"KHR_texture_transform", {{"offset", {1}}}}};
       }},
      {"sparse",
       [](GltfBuilder& b) {
         b.j["accessors"][0]["sparse"] = {{"count", 1},
                                          {"indices", {{"bufferView", 2}, {"componentType", 5123}}},
                                          {"values", {{"bufferView", 0}}}};
       }},
  };
  for (const auto& [name, mutate] : mutations) {
    SCOPED_TRACE(name);
    for (int glb = 0; glb < 2; ++glb) {
      GltfBuilder b = quadGltf();
      maskMaterial(b, b.imageDataUri(topOpaqueImage()));
      mutate(b);
      const std::string path = dir.file(glb ? "m.glb" : "m.gltf");
      if (glb)
        b.writeGlb(path);
      else
        b.writeGltf(path);
      auto r = somm::loadScene(path);
      ASSERT_FALSE(r.ok());
      EXPECT_EQ(r.error().message.rfind(path + ": ", 0), 0u) << r.error().message;
      EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
    }
  }
}

TEST(Gltf, GarbageAndTruncatedFiles) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  maskMaterial(b, b.imageInBuffer(topOpaqueImage()));
  b.writeGlb(dir.file("ok.glb"));
  b.writeGltf(dir.file("ok.gltf"), "ok.bin");
  const std::vector<uint8_t> glb = scenetest::readBytes(dir.file("ok.glb"));
  const std::vector<uint8_t> gltf = scenetest::readBytes(dir.file("ok.gltf"));
  ASSERT_TRUE(somm::loadScene(dir.file("ok.glb")).ok());
  // Every truncation of the .glb and some of the .gltf fail cleanly.
  for (size_t n = 0; n < glb.size(); n += (n < 64 ? 1 : 97)) {
    scenetest::writeBytes(dir.file("t.glb"), std::vector<uint8_t>(glb.begin(), glb.begin() + long(n)));
    auto r = somm::loadScene(dir.file("t.glb"));
    EXPECT_FALSE(r.ok()) << n;
  }
  for (size_t n = 0; n < gltf.size(); n += 53) {
    scenetest::writeBytes(dir.file("t.gltf"), std::vector<uint8_t>(gltf.begin(), gltf.begin() + long(n)));
    auto r = somm::loadScene(dir.file("t.gltf"));
    EXPECT_FALSE(r.ok()) << n;
  }
  // Truncated external buffer.
  std::vector<uint8_t> bin = scenetest::readBytes(dir.file("ok.bin"));
  bin.resize(bin.size() / 2);
  scenetest::writeBytes(dir.file("ok.bin"), bin);
  EXPECT_FALSE(somm::loadScene(dir.file("ok.gltf")).ok());
  // Random garbage with a glTF magic.
  std::vector<uint8_t> junk = {'g', 'l', 'T', 'F', 2, 0, 0,   0,   255, 255,
                               255, 127, 8,   0,   0, 0, 'J', 'S', 'O', 'N'};
  scenetest::writeBytes(dir.file("j.glb"), junk);
  EXPECT_FALSE(somm::loadScene(dir.file("j.glb")).ok());
  for (const char* text :
       {"not json",
        "{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": 10, \"uri\": \"gone.bin\"}]}",
        "{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": 10, \"uri\": "
        "\"data:application/octet-stream;base64,AAAA\"}]}",
        "[1, 2, 3]", ""}) {
    scenetest::writeFile(dir.file("j.gltf"), text);
    auto r = somm::loadScene(dir.file("j.gltf"));
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.error().message.rfind(dir.file("j.gltf") + ": ", 0), 0u) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
  }
  // A structurally valid file without meshes loads as an empty scene, with a warning.
  scenetest::writeFile(dir.file("e.gltf"), "{\"asset\": {\"version\": \"2.0\"}}");
  auto e = somm::loadScene(dir.file("e.gltf"));
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_TRUE(e->geometries.empty());
  ASSERT_FALSE(e->warnings.empty());
  EXPECT_NE(e->warnings.back().find("no geometry"), std::string::npos);
}

TEST(SceneFiles, UnknownExtensionAndMissingFile) {
  TempDir dir;
  auto r = somm::loadScene(dir.file("none.gltf"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, somm::ErrorCode::IoError);
  EXPECT_NE(r.error().message.find("none.gltf"), std::string::npos);
  scenetest::writeFile(dir.file("x.fbx"), "x");
  auto r2 = somm::loadScene(dir.file("x.fbx"));
  ASSERT_FALSE(r2.ok());
  EXPECT_EQ(r2.error().code, somm::ErrorCode::UnsupportedFormat);
  auto r3 = somm::loadScene(dir.file(""));
  EXPECT_FALSE(r3.ok());
}

}  // namespace

namespace {

TEST(Gltf, RequiredExtensions) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  maskMaterial(b, b.imageDataUri(topOpaqueImage()));
  b.j["extensionsUsed"] = {"KHR_draco_mesh_compression", "KHR_texture_transform"};
  b.j["extensionsRequired"] = {"KHR_texture_transform", "KHR_materials_unlit"};
  b.writeGltf(dir.file("ok.gltf"));
  auto r = somm::loadScene(dir.file("ok.gltf"));
  EXPECT_TRUE(r.ok()) << r.error().message;
  b.j["extensionsRequired"] = {"KHR_draco_mesh_compression"};
  b.writeGltf(dir.file("draco.gltf"));
  auto r2 = somm::loadScene(dir.file("draco.gltf"));
  ASSERT_FALSE(r2.ok());
  EXPECT_EQ(r2.error().code, somm::ErrorCode::UnsupportedFormat);
  EXPECT_NE(r2.error().message.find("KHR_draco_mesh_compression"), std::string::npos);
}

TEST(Gltf, MissingUvSetOfAlphaTextureWarns) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  maskMaterial(b, b.imageDataUri(topOpaqueImage()));
  b.j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 2;
  b.writeGltf(dir.file("uv.gltf"));
  auto r = somm::loadScene(dir.file("uv.gltf"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->geometries[0].uvs, std::vector<float>(8, 0.0f));
  ASSERT_EQ(r->warnings.size(), 1u);
  EXPECT_NE(r->warnings[0].find("TEXCOORD_2"), std::string::npos);
}

// Random byte mutations of valid files: loading must fail cleanly or succeed with consistent data, never
// crash (run under ASan/UBSan in CI).
TEST(SceneFiles, MutatedFilesNeverCrash) {
  TempDir dir;
  GltfBuilder b = quadGltf();
  maskMaterial(b, b.imageInBuffer(topOpaqueImage()));
  b.writeGlb(dir.file("ok.glb"));
  b.writeGltf(dir.file("ok.gltf"));
  scenetest::writeFile(dir.file("ok.obj"),
                       "mtllib ok.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                       "usemtl leaf\nf 1/1 2/2 3/3 4/4\nf 4/4 3/3 2/2\n");
  scenetest::writePng8(dir.file("t.png"), 2, 2, 2, {0, 0, 255, 255, 0, 128, 7, 9});
  scenetest::writeFile(dir.file("ok.mtl"), "newmtl leaf\nmap_d -clamp on t.png\n");
  uint64_t state = 12345;
  auto next = [&]() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return uint32_t(state >> 33);
  };
  for (const char* name : {"ok.glb", "ok.gltf", "ok.obj"}) {
    const std::vector<uint8_t> orig = scenetest::readBytes(dir.file(name));
    const std::string ext = std::string(name).substr(2);
    for (int iter = 0; iter < 150; ++iter) {
      std::vector<uint8_t> m = orig;
      const int edits = 1 + int(next() % 4);
      for (int e = 0; e < edits; ++e) {
        const size_t pos = next() % m.size();
        switch (next() % 3) {
          case 0:
            m[pos] = uint8_t(next());
            break;
          case 1:
            m[pos] = "0123456789-.e,[]{}\":"[next() % 20];
            break;
          default:
            m.resize(pos + 1);
            break;
        }
      }
      const std::string path = dir.file("mut" + ext);
      scenetest::writeBytes(path, m);
      auto r = somm::loadScene(path);
      if (!r.ok()) {
        EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
        continue;
      }
      for (const auto& g : r->geometries) {
        ASSERT_EQ(g.positions.size() / 3 * 2, g.uvs.size());
        for (uint32_t i : g.indices) ASSERT_LT(i, g.positions.size() / 3);
        ASSERT_LT(g.material, r->materials.size());
      }
      for (const auto& inst : r->instances) ASSERT_LT(inst.geometry, r->geometries.size());
      for (const auto& mat : r->materials)
        if (mat.alpha) {
          ASSERT_TRUE(mat.alpha->consistent());
        }
    }
  }
}

}  // namespace
