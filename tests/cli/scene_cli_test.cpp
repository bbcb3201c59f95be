// SPDX-License-Identifier: MIT
// somm scene-info and somm gen-scene, run as a user would.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_util.h"

namespace somm {
namespace {

using testing::RunResult;
using testing::runSomm;
using testing::shellQuote;
using testing::TempDir;

const std::string kData = SOMM_DATA_DIR;

TEST(CliSceneInfo, AlphaBlendModeTestJson) {
  TempDir dir;
  const RunResult r = runSomm(
      dir, "scene-info " + shellQuote(kData + "/alpha-blend-mode-test/AlphaBlendModeTest.gltf") + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["geometries"].size(), 9u);
  EXPECT_EQ(j["geometries"][0]["name"], "TestCutoff25Mesh/0");
  EXPECT_EQ(j["geometries"][2]["triangles"], 30);
  EXPECT_EQ(j["triangles"], 61);
  EXPECT_EQ(j["alpha_tested_triangles"], 6);
  const auto& m25 = j["materials"][size_t(j["geometries"][0]["material"])];
  EXPECT_EQ(m25["alpha_mode"], "mask");
  EXPECT_EQ(m25["cutoff"], 0.25);
  EXPECT_EQ(m25["alpha_texture"]["width"], 1024);
  ASSERT_EQ(j["warnings"].size(), 1u);
  // --blend-as-mask: 4 more alpha-tested triangles, no warning.
  const RunResult r2 =
      runSomm(dir, "scene-info " + shellQuote(kData + "/alpha-blend-mode-test/AlphaBlendModeTest.gltf") +
                       " --json --blend-as-mask");
  ASSERT_EQ(r2.exitCode, 0) << r2.err;
  const nlohmann::json j2 = nlohmann::json::parse(r2.out);
  EXPECT_EQ(j2["alpha_tested_triangles"], 10);
  EXPECT_EQ(j2["warnings"].size(), 0u);
}

TEST(CliSceneInfo, TextAndErrors) {
  TempDir dir;
  const RunResult r = runSomm(dir, "scene-info " + shellQuote(kData + "/oak-tree/oaktree.gltf"));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("0  oak/0: 127 triangles"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1  oak.004/0: 428 triangles"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("'leaves': mask, cutoff 0.5, alpha 256x256"), std::string::npos) << r.out;
  const RunResult missing = runSomm(dir, "scene-info " + shellQuote(dir / "nope.gltf"));
  EXPECT_EQ(missing.exitCode, 1);
  EXPECT_NE(missing.err.find("nope.gltf"), std::string::npos);
  testing::writeFile(dir / "bad.obj", "v 0 0 0\nf 1 2 3\n");
  const RunResult bad = runSomm(dir, "scene-info " + shellQuote(dir / "bad.obj"));
  EXPECT_EQ(bad.exitCode, 1);  // a corrupt scene file is a failed operation, not a usage error (issue 12)
  EXPECT_NE(bad.err.find("bad.obj"), std::string::npos);
  EXPECT_EQ(runSomm(dir, "scene-info").exitCode, 2);
}

TEST(CliGenScene, LeafCardsAndQuad) {
  TempDir dir;
  const RunResult g =
      runSomm(dir, "gen-scene leaf-cards --cards 25 --seed 3 -o " + shellQuote(dir / "c.glb"));
  ASSERT_EQ(g.exitCode, 0) << g.err;
  const RunResult r = runSomm(dir, "scene-info " + shellQuote(dir / "c.glb") + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["triangles"], 50);
  EXPECT_EQ(j["alpha_tested_triangles"], 50);
  EXPECT_FALSE(j["camera"].is_null());
  EXPECT_EQ(j["materials"][0]["alpha_texture"]["width"], 512);  // the default leaf atlas
  // --size sets the leaf atlas.
  ASSERT_EQ(
      runSomm(dir, "gen-scene leaf-cards --cards 5 --size 128 -o " + shellQuote(dir / "s.glb")).exitCode, 0);
  const RunResult si = runSomm(dir, "scene-info " + shellQuote(dir / "s.glb") + " --json");
  ASSERT_EQ(si.exitCode, 0) << si.err;
  EXPECT_EQ(nlohmann::json::parse(si.out)["materials"][0]["alpha_texture"]["height"], 128);
  // Same seed → same bytes.
  ASSERT_EQ(runSomm(dir, "gen-scene leaf-cards --cards 25 --seed 3 -o " + shellQuote(dir / "d.glb")).exitCode,
            0);
  EXPECT_EQ(testing::readFile(dir / "c.glb"), testing::readFile(dir / "d.glb"));

  const RunResult q =
      runSomm(dir,
              "gen-scene quad --texture disc --size 64 --filter nearest --wrap mirror --cutoff 0.25 "
              "--uv-scale 2 -o " +
                  shellQuote(dir / "q.glb"));
  ASSERT_EQ(q.exitCode, 0) << q.err;
  const RunResult qi = runSomm(dir, "scene-info " + shellQuote(dir / "q.glb") + " --json");
  ASSERT_EQ(qi.exitCode, 0) << qi.err;
  const nlohmann::json k = nlohmann::json::parse(qi.out);
  EXPECT_EQ(k["triangles"], 2);
  EXPECT_EQ(k["materials"][0]["filter"], "nearest");
  EXPECT_EQ(k["materials"][0]["wrap"][0], "mirror");
  EXPECT_EQ(k["materials"][0]["cutoff"], 0.25);
  EXPECT_EQ(k["materials"][0]["alpha_texture"]["width"], 64);
  EXPECT_EQ(runSomm(dir, "gen-scene cube -o " + shellQuote(dir / "x.glb")).exitCode, 2);
  EXPECT_EQ(runSomm(dir, "gen-scene leaf-cards -o " + shellQuote(dir / "no/dir/x.glb")).exitCode, 1);
}

}  // namespace
}  // namespace somm
