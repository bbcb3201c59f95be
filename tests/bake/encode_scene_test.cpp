// SPDX-License-Identifier: MIT
// Every encoding of scene-wide arrays of real scenes (bake per geometry, mergeToSceneArray) against the flat
// array: random lookups, exact decode, serialize → parse. The bundled oak tree always; the foliage scenes of
// ../shared/assets/foliage (or $SOMM_FOLIAGE_DIR) when present, skipped otherwise.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "somm/bake.h"
#include "somm/encode.h"
#include "somm/omm_array.h"
#include "somm/scene.h"

namespace somm {
namespace {

std::string foliageDir() {
  const char* env = std::getenv("SOMM_FOLIAGE_DIR");
  return env ? env : SOMM_FOLIAGE_DIR;
}

// The scene-wide array of `files` baked at `level` (geometries of every file in order); at most `maxGeometries`
// alpha-tested geometries per file to keep the suite fast.
OmmArray sceneArray(const std::vector<std::string>& files, uint32_t level, Format f, size_t maxGeometries) {
  std::vector<OmmArray> perGeometry;
  for (const std::string& file : files) {
    auto scene = loadScene(file);
    EXPECT_TRUE(scene.ok()) << (scene.ok() ? "" : scene.error().message);
    if (!scene) continue;
    size_t n = 0;
    for (const Geometry& g : scene->geometries) {
      if (g.material >= scene->materials.size() || !scene->materials[g.material].alphaTested()) continue;
      if (n++ == maxGeometries) break;
      BakeOptions o;
      o.level = level;
      o.format = f;
      auto baked = bakeGeometry(g, scene->materials[g.material], o);
      EXPECT_TRUE(baked.ok());
      if (baked) perGeometry.push_back(std::move(baked->array));
    }
  }
  if (perGeometry.empty()) return {};
  return mergeToSceneArray(perGeometryMicromaps(std::move(perGeometry))).arrays[0];
}

void checkEveryEncoding(const OmmArray& flat, const std::string& what) {
  ASSERT_FALSE(flat.descriptors.empty()) << what;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> uf(0.f, 1.f);
  std::vector<uint32_t> withMap;
  for (uint32_t t = 0; t < flat.indices.size(); ++t)
    if (flat.indices[t] >= 0) withMap.push_back(t);
  uint64_t bytes[kEncodingCount] = {};
  for (Encoding e : kAllEncodings) {
    const EncodedArray a = EncodedArray::build(flat, e).value();
    bytes[size_t(e)] = a.byteSize();
    uint64_t bad = 0;
    const int n = e == Encoding::Dfs ? 300 : 20000;
    for (int k = 0; k < n; ++k) {
      const uint32_t t = withMap[rng() % withMap.size()];
      float u = uf(rng), v = uf(rng);
      if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
      bad += a.stateUV(t, u, v) != flat.stateUV(t, u, v);
    }
    EXPECT_EQ(bad, 0u) << what << " " << encodingName(e);
    const OmmArray back = a.decode();
    EXPECT_TRUE(back.data == flat.data && back.descriptors == flat.descriptors &&
                back.indices == flat.indices && back.histogram == flat.histogram &&
                back.triangleHistogram == flat.triangleHistogram)
        << what << " " << encodingName(e);
    auto parsed = EncodedArray::parse(a.serialize(), what);
    ASSERT_TRUE(parsed.ok()) << parsed.error().message;
    EXPECT_TRUE(*parsed == a) << what << " " << encodingName(e);
  }
  // Sizes are deterministic: the succinct DAG is below csm and dfs, never above flat + its header; hybrid
  // considers it.
  const uint64_t sdag = bytes[size_t(Encoding::Sdag)];
  EXPECT_LT(sdag, bytes[size_t(Encoding::Csm)]) << what;
  EXPECT_LT(sdag, bytes[size_t(Encoding::Dfs)]) << what;
  EXPECT_LE(sdag, bytes[size_t(Encoding::Flat)] + encode::kSdagDirectoryBytes + encode::kTailPadding) << what;
  EXPECT_LE(bytes[size_t(Encoding::Hybrid)], sdag) << what;
  EXPECT_EQ(bytes[size_t(Encoding::Dfs)], bytes[size_t(Encoding::DfsFast)]) << what;
}

TEST(EncodeScene, OakTreeSceneWideArray) {
  for (Format f : {Format::FourState, Format::TwoState})
    checkEveryEncoding(sceneArray({std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf"}, 7, f, 1000),
                       "oak tree");
}

TEST(EncodeScene, RealFoliageSceneWideArrays) {
  const std::string d = foliageDir();
  if (!std::filesystem::exists(d + "/torcs-forza/forza.obj")) GTEST_SKIP() << "no foliage assets in " << d;
  std::vector<std::string> redeclipse;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(d + "/redeclipse/obj", ec))
    if (e.path().extension() == ".obj") redeclipse.push_back(e.path().string());
  std::sort(redeclipse.begin(), redeclipse.end());
  checkEveryEncoding(sceneArray(redeclipse, 6, Format::FourState, 1000), "redeclipse");
  checkEveryEncoding(sceneArray({d + "/torcs-forza/forza.obj"}, 6, Format::FourState, 40), "forza");
  checkEveryEncoding(sceneArray({d + "/zeroad/flora-quarter.obj"}, 5, Format::TwoState, 40), "0 A.D.");
}

}  // namespace
}  // namespace somm
