// SPDX-License-Identifier: MIT
// somm render / somm bench end to end on the bundled oak tree.
#include <gtest/gtest.h>
#include <stb_image.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "cli_util.h"
#include "somm/bake.h"
#include "somm/scene.h"
#include "somm/somm_file.h"

namespace somm {
namespace {

using testing::runSomm;
using testing::TempDir;

const std::string kOak = std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf";
const std::string kSmall = " --width 64 --height 48 --level 5";

std::vector<unsigned char> loadPng(const std::string& path, int& w, int& h) {
  int c = 0;
  unsigned char* p = stbi_load(path.c_str(), &w, &h, &c, 4);
  std::vector<unsigned char> v;
  if (p) v.assign(p, p + size_t(w) * h * 4);
  stbi_image_free(p);
  return v;
}

TEST(TraceCli, RenderWritesPngAndJson) {
  TempDir d;
  const auto r = runSomm("render " + kOak + kSmall + " --method omm4-rank -o " + d.file("a.png") + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["method"], "omm4-rank");
  EXPECT_EQ(j["width"], 64);
  EXPECT_EQ(j["primary_rays"], 64 * 48);
  EXPECT_GT(j["micromap_bytes"].get<uint64_t>(), 0u);
  EXPECT_EQ(j["rays"].get<uint64_t>(), j["primary_rays"].get<uint64_t>() + j["shadow_rays"].get<uint64_t>());
  int w = 0, h = 0;
  const auto a = loadPng(d.file("a.png"), w, h);
  EXPECT_EQ(w, 64);
  EXPECT_EQ(h, 48);
  // The same image as the ground truth.
  ASSERT_EQ(runSomm("render " + kOak + kSmall + " --method texture -o " + d.file("t.png")).exitCode, 0);
  EXPECT_EQ(loadPng(d.file("t.png"), w, h), a);
}

TEST(TraceCli, BenchTableAndJson) {
  const auto r = runSomm("bench " + kOak + kSmall + " --repeat 2 --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["repeat"], 2);
  std::set<std::string> names;
  for (const auto& m : j["methods"]) {
    names.insert(m["method"].get<std::string>());
    EXPECT_EQ(m["mrays_per_s_runs"].size(), 2u);
    if (m["exact_required"].get<bool>()) {
      EXPECT_EQ(m["pct_pixels_differing"].get<double>(), 0.0) << m["method"];
    }
    EXPECT_EQ(m["ratio_to_texture_runs"].size(), 2u);
    EXPECT_LE(m["ratio_min"].get<double>(), m["ratio_to_texture"].get<double>());
    EXPECT_GE(m["ratio_max"].get<double>(), m["ratio_to_texture"].get<double>());
    if (m["method"] == "texture") {
      EXPECT_DOUBLE_EQ(m["ratio_to_texture"].get<double>(), 1.0);
    }
    if (m["method"].get<std::string>().starts_with("omm2-")) {
      EXPECT_EQ(m["texture_tests_per_ray"].get<double>(), 0.0);
    }
  }
  for (const char* n : {"texture", "opaque", "bitmask", "omm2-flat", "omm4-flat", "omm4-dfs", "omm4-dfs-fast",
                        "omm4-rank", "omm4-hybrid", "omm2-hybrid"})
    EXPECT_TRUE(names.count(n)) << n;
  const auto t = runSomm("bench " + kOak + kSmall + " --repeat 1 --methods omm4-flat,opaque");
  ASSERT_EQ(t.exitCode, 0) << t.err;
  EXPECT_NE(t.out.find("omm4-flat"), std::string::npos);
  EXPECT_NE(t.out.find("vs texture"), std::string::npos);
  EXPECT_EQ(t.out.find("bitmask"), std::string::npos);
  // texture listed after other methods still runs first: it is the reference image and the ratios' denominator.
  const auto late =
      runSomm("bench " + kOak + kSmall + " --repeat 1 --json --methods omm4-flat,texture,omm4-sdag");
  ASSERT_EQ(late.exitCode, 0) << late.err;
  const auto lj = nlohmann::json::parse(late.out);
  ASSERT_EQ(lj["methods"].size(), 3u);
  EXPECT_EQ(lj["methods"][0]["method"], "texture");
  for (const auto& m : lj["methods"]) {
    EXPECT_EQ(m["pct_pixels_differing"].get<double>(), 0.0) << m["method"];
  }
  EXPECT_DOUBLE_EQ(lj["methods"][0]["ratio_to_texture"].get<double>(), 1.0);
  const auto twice = runSomm("bench " + kOak + kSmall + " --repeat 1 --methods omm4-flat,omm4-flat");
  EXPECT_EQ(twice.exitCode, 2);
  EXPECT_NE(twice.err.find("twice"), std::string::npos) << twice.err;
}

// An exactness check that hits no alpha-tested geometry tests nothing: bench fails unless --allow-empty.
TEST(TraceCli, BenchRefusesAnEmptyComparison) {
  const std::string away = " --camera 0,1000,0,0,2000,0,1,0,0,45 --methods omm4-flat --repeat 1";
  auto r = runSomm("bench " + kOak + kSmall + away);
  EXPECT_EQ(r.exitCode, 1) << r.out;
  EXPECT_NE(r.err.find("alpha-tested"), std::string::npos) << r.err;
  r = runSomm("bench " + kOak + kSmall + away + " --allow-empty --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["alpha_tested_pixels"], 0);
  r = runSomm("bench " + kOak + kSmall + " --methods omm4-flat --repeat 1 --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_GT(nlohmann::json::parse(r.out)["alpha_tested_pixels"].get<uint64_t>(), 100u);
}

TEST(TraceCli, BadInput) {
  TempDir d;
  const std::string out = d.file("x.png");
  auto r = runSomm("render " + kOak + kSmall + " --method omm5-flat -o " + out);
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("omm5-flat"), std::string::npos);
  r = runSomm("render " + kOak + kSmall + " --camera 1,2,3 -o " + out);
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--camera"), std::string::npos);
  r = runSomm("render " + kOak + kSmall + " --camera 0,0,0,0,0,0,0,1,0,45 -o " + out);
  EXPECT_EQ(r.exitCode, 2);
  r = runSomm("render " + d.file("missing.gltf") + " -o " + out);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("missing.gltf"), std::string::npos);
  r = runSomm("render " + kOak + kSmall + " --omm " + d.file("missing.somm") + " --method omm4-flat -o " +
              out);
  EXPECT_EQ(r.exitCode, 1);
  r = runSomm("render " + kOak + kSmall + " -o " + d.file("no-such-dir/x.png"));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_FALSE(std::filesystem::exists(out));
  r = runSomm("bench " + kOak + kSmall + " --methods state-overlay");
  EXPECT_EQ(r.exitCode, 2);
  r = runSomm("render " + kOak + " --width 0 -o " + out);
  EXPECT_EQ(r.exitCode, 2);
}

TEST(TraceCli, CameraOptionChangesTheView) {
  TempDir d;
  ASSERT_EQ(runSomm("render " + kOak + kSmall + " -o " + d.file("a.png")).exitCode, 0);
  ASSERT_EQ(
      runSomm("render " + kOak + kSmall + " --camera 0.8,3.3,2.2,0.1,3.2,0.15,0,1,0,60 -o " + d.file("b.png"))
          .exitCode,
      0);
  int w, h;
  EXPECT_NE(loadPng(d.file("a.png"), w, h), loadPng(d.file("b.png"), w, h));
}

}  // namespace
}  // namespace somm

// A .somm file written by the file library, baked for a different cutoff than the material's: `--omm` traces
// against the alpha test the file was baked for, exactly.
namespace somm {
namespace {

TEST(TraceCli, RendersFromSommFile) {
  TempDir d;
  auto scene = loadScene(kOak);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  SommFile f;
  f.sourcePath = kOak;
  f.toolVersion = "test";
  BakeOptions o;
  o.level = 5;
  o.cutoff = 0.3f;
  std::vector<OmmArray> arrays;
  for (const Geometry& g : scene->geometries) {
    const Material& m = scene->materials[g.material];
    auto baked = bakeGeometry(g, m, o);
    ASSERT_TRUE(baked.ok()) << baked.error().message;
    GeometryInfo sg;
    sg.name = g.name;
    sg.material = m.name;
    sg.triangleCount = g.triangleCount();
    sg.format = Format::FourState;
    sg.minLevel = baked->stats.minLevel;
    sg.maxLevel = baked->stats.maxLevel;
    sg.cutoff = 0.3f;
    sg.sampler = m.sampler;
    f.geometries.push_back(std::move(sg));
    arrays.push_back(baked->array);
  }
  f.micromaps = mergeToSceneArray(perGeometryMicromaps(arrays));
  f.encodings.assign(1, {});
  const std::string somm = d.file("oak.somm");
  const Status w = writeSommFile(somm, f);
  ASSERT_TRUE(w.ok()) << w.error().message;
  const std::string view = " --width 64 --height 48 --camera 0.8,3.3,2.2,0.1,3.2,0.15,0,1,0,60";
  ASSERT_EQ(runSomm("render " + kOak + view + " --cutoff 0.3 -o " + d.file("t.png")).exitCode, 0);
  ASSERT_EQ(runSomm("render " + kOak + view + " -o " + d.file("t5.png")).exitCode, 0);
  const auto r = runSomm("render " + kOak + view + " --omm " + somm + " --method omm4-hybrid --json -o " +
                         d.file("o.png"));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["micromaps"], somm);
  int w1, h1;
  EXPECT_EQ(loadPng(d.file("o.png"), w1, h1), loadPng(d.file("t.png"), w1, h1));
  EXPECT_NE(loadPng(d.file("t5.png"), w1, h1), loadPng(d.file("t.png"), w1, h1));  // the cutoff matters here
  // 2-state methods from a 4-state file: the spec's demotion, never a texture test.
  const auto two = runSomm("render " + kOak + view + " --omm " + somm + " --method omm2-rank --json -o " +
                           d.file("two.png"));
  ASSERT_EQ(two.exitCode, 0) << two.err;
  EXPECT_EQ(nlohmann::json::parse(two.out)["texture_tests"], 0);
  // A file for another scene is rejected.
  f.geometries.pop_back();
  arrays.pop_back();
  f.micromaps = perGeometryMicromaps(arrays);
  f.encodings.assign(1, {});
  ASSERT_TRUE(writeSommFile(d.file("short.somm"), f).ok());
  const auto bad = runSomm("render " + kOak + view + " --omm " + d.file("short.somm") +
                           " --method omm4-flat -o " + d.file("b.png"));
  EXPECT_EQ(bad.exitCode, 1);
  EXPECT_NE(bad.err.find("geometries"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(d.file("b.png")));
}

}  // namespace
}  // namespace somm
