// SPDX-License-Identifier: MIT
// somm view: PNG output coloured by state, scene lookup, errors.
#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <filesystem>

#include "cli_util.h"
#include "somm/somm_file.h"

namespace somm {
namespace {

using testing::RunResult;
using testing::runSomm;
using testing::TempDir;

const std::string kBlend = std::string(SOMM_DATA_DIR) + "/alpha-blend-mode-test/AlphaBlendModeTest.gltf";
std::string q(const std::string& s) {
  return "'" + s + "'";
}

struct Image {
  int w = 0, h = 0;
  std::vector<uint8_t> rgb;
};

Image load(const std::string& path) {
  Image im;
  int n = 0;
  uint8_t* p = stbi_load(path.c_str(), &im.w, &im.h, &n, 3);
  if (!p) return im;
  im.rgb.assign(p, p + size_t(im.w) * size_t(im.h) * 3);
  stbi_image_free(p);
  return im;
}

// Pixels whose colour is dominated by one channel (the state overlays), by channel r/g/b.
std::array<size_t, 3> dominant(const Image& im) {
  std::array<size_t, 3> n{};
  for (size_t i = 0; i < im.rgb.size(); i += 3) {
    const int r = im.rgb[i], g = im.rgb[i + 1], b = im.rgb[i + 2];
    if (r > g + 30 && r > b + 30) ++n[0];
    if (g > r + 30 && g > b + 30) ++n[1];
    if (b > r + 30 && b > g + 30) ++n[2];
  }
  return n;
}

TEST(CliView, ColoursFollowTheStates) {
  TempDir dir;
  const std::string somm = dir.file("ab.somm");
  ASSERT_EQ(runSomm("bake " + q(kBlend) + " -o " + q(somm) + " --level 5").exitCode, 0);
  auto file = readSommFile(somm);
  ASSERT_TRUE(file.ok());
  // Find an all-opaque geometry (special index -2 everywhere) and the BLEND one (unknown-opaque everywhere).
  int opaque = -1, blend = -1, mixed = -1;
  for (size_t g = 0; g < file->geometries.size(); ++g) {
    const std::vector<int32_t> idx(file->micromaps.indices(uint32_t(g)),
                                   file->micromaps.indices(uint32_t(g)) + file->geometries[g].triangleCount);
    if (idx.empty()) continue;
    if (std::all_of(idx.begin(), idx.end(), [](int32_t i) { return i == -2; }) && opaque < 0) opaque = int(g);
    if (std::all_of(idx.begin(), idx.end(), [](int32_t i) { return i == -4; }) && blend < 0) blend = int(g);
    if (std::any_of(idx.begin(), idx.end(), [](int32_t i) { return i >= 0; }) && mixed < 0) mixed = int(g);
  }
  ASSERT_GE(opaque, 0);
  ASSERT_GE(blend, 0);
  ASSERT_GE(mixed, 0);
  const std::string png = dir.file("v.png");
  RunResult r =
      runSomm("view " + q(somm) + " --geometry " + std::to_string(opaque) + " -o " + q(png) + " --size 256");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  Image im = load(png);
  ASSERT_GT(im.w, 0);
  EXPECT_EQ(std::max(im.w, im.h), 256);
  auto d = dominant(im);
  EXPECT_GT(d[1], 100u);  // green: opaque
  EXPECT_EQ(d[0] + d[2], 0u);
  r = runSomm("view " + q(somm) + " --geometry " + std::to_string(blend) + " -o " + q(png) + " --size 256");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  d = dominant(load(png));
  EXPECT_GT(d[0], 100u);  // red: unknown-opaque
  EXPECT_EQ(d[1] + d[2], 0u);
  r = runSomm("view " + q(somm) + " --geometry " + std::to_string(mixed) + " --triangles 0-1 -o " + q(png));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  d = dominant(load(png));
  EXPECT_GT(d[1], 0u);  // a cutoff test card: opaque and transparent parts
  EXPECT_GT(d[2], 0u);
}

TEST(CliView, SceneLookupAndErrors) {
  TempDir dir;
  const std::string somm = dir.file("ab.somm"), png = dir.file("v.png");
  ASSERT_EQ(runSomm("bake " + q(kBlend) + " -o " + q(somm) + " --level 3").exitCode, 0);
  RunResult r = runSomm("view " + q(somm) + " --geometry 99 -o " + q(png));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--geometry 99 is out of range"), std::string::npos) << r.err;
  r = runSomm("view " + q(somm) + " --geometry 0 --triangles 1-5 -o " + q(png));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--triangles 1-5 is out of range"), std::string::npos) << r.err;
  r = runSomm("view " + q(somm) + " --geometry 0 --triangles 1-x -o " + q(png));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_FALSE(std::filesystem::exists(png));
  // A .somm whose source scene is gone: an error naming it; --scene fixes it.
  auto file = readSommFile(somm);
  ASSERT_TRUE(file.ok());
  file->sourcePath = dir.file("moved.gltf");
  ASSERT_TRUE(writeSommFile(somm, *file).ok());
  r = runSomm("view " + q(somm) + " --geometry 0 -o " + q(png));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("moved.gltf"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--scene"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(png));
  r = runSomm("view " + q(somm) + " --geometry 0 -o " + q(png) + " --scene " + q(kBlend));
  EXPECT_EQ(r.exitCode, 0) << r.err;
  EXPECT_GT(load(png).w, 0);
  // Corrupt input: exit 1, the previous image untouched.
  const std::string before = testing::readFile(png);
  std::string bytes = testing::readFile(somm);
  bytes[bytes.size() / 2] ^= 4;
  testing::writeFile(somm, bytes);
  r = runSomm("view " + q(somm) + " --geometry 0 -o " + q(png) + " --scene " + q(kBlend));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_EQ(r.err.rfind("somm view: " + somm + ": ", 0), 0u) << r.err;
  EXPECT_EQ(testing::readFile(png), before);
}

}  // namespace
}  // namespace somm
