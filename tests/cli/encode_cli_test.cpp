// SPDX-License-Identifier: MIT
// somm query --encoding, somm info --json encoding sizes, somm compare.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "cli_util.h"
#include "somm/encode.h"
#include "somm/somm_file.h"
#include "somm_test_arrays.h"

namespace somm {
namespace {

using testing::RunResult;
using testing::runSomm;
using testing::sampleFile;
using testing::shellQuote;
using testing::TempDir;

constexpr std::pair<Encoding, const char*> kStored[] = {{Encoding::Dfs, "dfs "},
                                                        {Encoding::DfsFast, "dfsf"},
                                                        {Encoding::Rank, "rank"},
                                                        {Encoding::Hybrid, "hybr"}};

// The sample file with every encoding of every array stored as its section (docs/encodings.md).
SommFile encodedSample(testing::Layout layout = testing::Layout::Scene) {
  SommFile f = sampleFile(300, 5, layout);
  for (size_t a = 0; a < f.micromaps.arrays.size(); ++a) {
    f.encodings[a].clear();
    for (const auto& [e, id] : kStored) {
      char name[5] = {id[0], id[1], id[2], id[3], 0};
      f.encodings[a].push_back(
          EncodedSection{sectionId(name), EncodedArray::build(f.micromaps.arrays[a], e).value().serialize()});
    }
  }
  return f;
}

std::string writeFile(const TempDir& dir, const SommFile& f) {
  const std::string p = dir / "enc.somm";
  EXPECT_TRUE(writeSommFile(p, f).ok());
  return p;
}

TEST(CliEncode, QueryAnswersFromEveryEncoding) {
  for (testing::Layout layout : {testing::Layout::Scene, testing::Layout::PerGeometry}) {
    TempDir dir;
    const SommFile f = encodedSample(layout);
    const std::string p = writeFile(dir, f);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> d(0, 1);
    std::string input;
    std::vector<std::pair<float, float>> uv;
    for (int i = 0; i < 300; ++i) {
      float u = d(rng), v = d(rng);
      if (u + v > 1) u = 1 - u, v = 1 - v;
      char buf[64];
      std::snprintf(buf, sizeof buf, "%a %a\n", double(u), double(v));
      input += buf;
      uv.emplace_back(u, v);
    }
    testing::writeFile(dir / "uv.txt", input);
    for (uint32_t g = 0; g < 2; ++g)
      for (uint32_t t : {0u, 7u, 42u, 299u}) {
        std::string want;
        for (const auto& [u, v] : uv) {
          State s = f.micromaps.stateUV(g, t, u, v);
          if (f.geometries[g].format == Format::TwoState) s = toTwoState(s);
          want += char('0' + int(s));
          want += '\n';
        }
        for (const char* e : {"flat", "dfs", "dfs-fast", "rank", "hybrid"}) {
          const RunResult r = runSomm(dir,
                                      "query " + shellQuote(p) + " -g " + std::to_string(g) + " -t " +
                                          std::to_string(t) + " --encoding " + e,
                                      dir / "uv.txt");
          ASSERT_EQ(r.exitCode, 0) << e << ": " << r.err;
          EXPECT_EQ(r.out, want) << e << " geometry " << g << " triangle " << t;
        }
      }
  }
}

TEST(CliEncode, QueryErrors) {
  TempDir dir;
  SommFile f = encodedSample(testing::Layout::PerGeometry);
  f.encodings[0].erase(f.encodings[0].begin() + 2);  // no rank in array 0 (geometry 0's)
  f.encodings[1][0].bytes[0] ^= 0xff;                // corrupt dfs in array 1 (geometry 1's)
  const std::string p = writeFile(dir, f);
  testing::writeFile(dir / "uv.txt", "0.1 0.2\n");
  RunResult r = runSomm(dir, "query " + shellQuote(p) + " -g 0 -t 0 --encoding rank", dir / "uv.txt");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("array 0 stores no 'rank' encoding"), std::string::npos) << r.err;
  r = runSomm(dir, "query " + shellQuote(p) + " -g 1 -t 0 --encoding dfs", dir / "uv.txt");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("bad magic"), std::string::npos) << r.err;
  r = runSomm(dir, "query " + shellQuote(p) + " -g 0 -t 0 --encoding zip", dir / "uv.txt");
  EXPECT_EQ(r.exitCode, 2);
  // info still describes the file and reports the unreadable section.
  r = runSomm(dir, "info " + shellQuote(p) + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["arrays"][1]["encoding_sizes"]["dfs"].contains("error"));
  EXPECT_FALSE(j["arrays"][0]["encoding_sizes"].contains("rank"));
}

TEST(CliEncode, InfoReportsExactSizesAndRatios) {
  for (testing::Layout layout : {testing::Layout::Scene, testing::Layout::PerGeometry}) {
    TempDir dir;
    const SommFile f = encodedSample(layout);
    const std::string p = writeFile(dir, f);
    const RunResult r = runSomm(dir, "info " + shellQuote(p) + " --json --reference-compressors");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    uint64_t totalFlat = 0, totalRank = 0;
    for (size_t a = 0; a < f.micromaps.arrays.size(); ++a) {
      const nlohmann::json& s = j["arrays"][a]["encoding_sizes"];
      const uint64_t flat = EncodedArray::build(f.micromaps.arrays[a], Encoding::Flat).value().byteSize();
      EXPECT_EQ(s["flat"]["bytes"], flat);
      EXPECT_EQ(s["flat"]["ratio_to_flat"], 1.0);
      for (const auto& [e, id] : kStored) {
        const uint64_t bytes = EncodedArray::build(f.micromaps.arrays[a], e).value().byteSize();
        EXPECT_EQ(s[encodingName(e)]["bytes"], bytes);
        EXPECT_DOUBLE_EQ(s[encodingName(e)]["ratio_to_flat"].get<double>(), double(bytes) / double(flat));
        if (e == Encoding::Rank) totalRank += bytes;
      }
      EXPECT_LE(s["hybrid"]["bytes"].get<uint64_t>(), flat + encode::kTailPadding);
      EXPECT_EQ(s["zstd-19"]["random_access"], false);
      EXPECT_GT(s["zstd-19"]["bytes"].get<uint64_t>(), 0u);
      EXPECT_GT(s["xz-9"]["bytes"].get<uint64_t>(), 0u);
      totalFlat += flat;
    }
    EXPECT_EQ(j["total"]["encoding_sizes"]["flat"]["bytes"], totalFlat);
    EXPECT_EQ(j["total"]["encoding_sizes"]["rank"]["bytes"], totalRank);
    // The text form prints the ratios too, by encoding name.
    const RunResult t = runSomm(dir, "info " + shellQuote(p));
    ASSERT_EQ(t.exitCode, 0) << t.err;
    EXPECT_NE(
        t.out.find("encodings (whole array serialized: header, index buffer, descriptors, data): flat "),
        std::string::npos)
        << t.out;
    EXPECT_NE(t.out.find(", dfs-fast "), std::string::npos) << t.out;
    EXPECT_EQ(t.out.find("dfsf"), std::string::npos) << t.out;
  }
}

TEST(CliEncode, CompareTableJsonAndPlot) {
  TempDir dir;
  RunResult r = runSomm(dir, "compare procedural:leaf-cards:6 --levels 2,5 --formats 2,4 --json --plot " +
                                 shellQuote(dir / "plot.png"));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["rows"].size(), 4u);
  for (const auto& row : j["rows"]) {
    EXPECT_EQ(row["flat"]["ratio_to_flat"], 1.0);
    EXPECT_EQ(row["dfs"]["bytes"], row["dfs-fast"]["bytes"]);
    EXPECT_LE(row["hybrid"]["bytes"].get<uint64_t>(),
              row["flat"]["bytes"].get<uint64_t>() + encode::kTailPadding);
    EXPECT_LE(row["hybrid"]["bytes"].get<uint64_t>(), row["rank"]["bytes"].get<uint64_t>());
  }
  EXPECT_EQ(j["rows"][0]["level"], 2);
  EXPECT_EQ(j["rows"][0]["format"], 2);
  EXPECT_EQ(j["rows"][3]["level"], 5);
  EXPECT_EQ(j["rows"][3]["format"], 4);
  const std::string png = testing::readFile(dir / "plot.png");
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  r = runSomm(dir, "compare procedural:leaf-cards:6 --levels 2,13");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--levels"), std::string::npos);
  r = runSomm(dir, "compare procedural:leaf-cards:6 --formats 3");
  EXPECT_EQ(r.exitCode, 2);
  r = runSomm(dir, "compare " + shellQuote(dir / "missing.gltf"));
  EXPECT_EQ(r.exitCode, 1);
}

// A row over a limit (here the bake's micro-triangle budget, as somm bake checks it) is reported with its error
// and the other rows still run; the exit code is 1.
TEST(CliEncode, CompareKeepsTheRowsWithinLimits) {
  TempDir dir;
  const std::string base = "compare procedural:leaf-cards:6 --levels 2,5 --formats 4 --lookups 0";
  const nlohmann::json full = nlohmann::json::parse(runSomm(dir, base + " --json").out);
  RunResult r =
      runSomm(dir, base + " --json --limit micro-triangles=1000 --plot " + shellQuote(dir / "p.png"));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("level 5, 4-state"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("micro-triangles"), std::string::npos) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["rows"].size(), 2u);
  EXPECT_EQ(j["rows"][0]["level"], 2);
  EXPECT_FALSE(j["rows"][0].contains("error"));
  EXPECT_EQ(j["rows"][0]["sdag"]["bytes"], full["rows"][0]["sdag"]["bytes"]);
  EXPECT_EQ(j["rows"][1]["level"], 5);
  EXPECT_NE(j["rows"][1]["error"].get<std::string>().find("micro-triangles"), std::string::npos);
  EXPECT_FALSE(j["rows"][1].contains("sdag"));
  EXPECT_TRUE(std::filesystem::exists(dir / "p.png"));
  r = runSomm(dir, base + " --limit micro-triangles=1000");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.out.find("error: "), std::string::npos) << r.out;
  r = runSomm(dir, base + " --limit micro-triangles=100000");
  EXPECT_EQ(r.exitCode, 0) << r.err;
}

// --sdag-stats reads the sdag records of an array with leaf transforms (version 8: the real tree at level 8 takes
// them): the leaf references it follows carry T in their low bits (it crashed on them before reading them as such).
TEST(CliEncode, CompareSdagStatsWithLeafTransforms) {
  TempDir dir;
  const std::string scene = shellQuote(std::string(SOMM_DATA_DIR) + "/redeclipse-tree01/tree01.obj");
  const RunResult r =
      runSomm(dir, "compare " + scene + " --levels 8 --formats 4 --cutoff 0.7 --lookups 0 --sdag-stats");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("sdag L8: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("with leaf transforms)"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("leaf refs: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("h3: "), std::string::npos) << r.err;
}

// compare takes bake's material overrides (--cutoff, --filter): its bytes per encoding are those of the array
// `somm bake` stores with the same options (info --json encoding_sizes), and the cutoff changes them.
TEST(CliEncode, CompareTakesBakesMaterialOverrides) {
  TempDir dir;
  const std::string scene = shellQuote(std::string(SOMM_DATA_DIR) + "/redeclipse-tree01/tree01.obj");
  std::map<std::string, uint64_t> dfsBytes;
  for (const char* opts : {" --cutoff 0.2", " --cutoff 0.7", " --cutoff 0.7 --filter nearest"}) {
    RunResult c = runSomm(dir, "compare " + scene + " --levels 5 --formats 4 --json --lookups 0" + opts);
    ASSERT_EQ(c.exitCode, 0) << c.err;
    const nlohmann::json row = nlohmann::json::parse(c.out)["rows"][0];
    const std::string out = dir / "t.somm";
    RunResult b = runSomm(dir, "bake " + scene + " --level 5 --encoding all -o " + shellQuote(out) + opts);
    ASSERT_EQ(b.exitCode, 0) << b.err;
    RunResult i = runSomm(dir, "info " + shellQuote(out) + " --json");
    ASSERT_EQ(i.exitCode, 0) << i.err;
    const nlohmann::json sizes = nlohmann::json::parse(i.out)["arrays"][0]["encoding_sizes"];
    for (const char* e : {"flat", "dfs", "rank", "hybrid", "csm", "sdag"}) {
      EXPECT_EQ(row[e]["bytes"], sizes[e]["bytes"]) << opts << " " << e;
    }
    dfsBytes[opts] = row["dfs"]["bytes"].get<uint64_t>();
  }
  EXPECT_NE(dfsBytes[" --cutoff 0.2"], dfsBytes[" --cutoff 0.7"]);
  RunResult r = runSomm(dir, "compare " + scene + " --levels 4 --cutoff 1.5");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--cutoff"), std::string::npos) << r.err;
  r = runSomm(dir, "compare " + scene + " --levels 4 --filter cubic");
  EXPECT_EQ(r.exitCode, 2);
}

TEST(CliEncode, BakeStoresEncodings) {
  TempDir dir;
  const std::string out = dir / "oak.somm";
  RunResult r = runSomm(dir, "bake " + shellQuote(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf") +
                                 " -o " + shellQuote(out) + " --level 5 --format 2 --encoding rank,hybrid");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto f = readSommFile(out);
  ASSERT_TRUE(f.ok());
  ASSERT_EQ(f->micromaps.arrays.size(), 1u);  // one scene-wide array: one section per encoding
  ASSERT_EQ(f->encodings[0].size(), 2u);
  EXPECT_EQ(f->encodings[0][0].id, sectionId("rank"));
  EXPECT_EQ(f->encodings[0][1].id, sectionId("hybr"));
  EXPECT_EQ(f->encodings[0][0].bytes,
            EncodedArray::build(f->micromaps.arrays[0], Encoding::Rank).value().serialize());
  testing::writeFile(dir / "uv.txt", "0.1 0.2\n0.3 0.3\n0.7 0.1\n0.05 0.9\n");
  const RunResult flat = runSomm(dir, "query " + shellQuote(out) + " -g 0 -t 1", dir / "uv.txt");
  const RunResult rank =
      runSomm(dir, "query " + shellQuote(out) + " -g 0 -t 1 --encoding rank", dir / "uv.txt");
  ASSERT_EQ(rank.exitCode, 0) << rank.err;
  EXPECT_EQ(rank.out, flat.out);
  r = runSomm(dir, "bake " + shellQuote(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf") + " -o " +
                       shellQuote(dir / "x.somm") + " --encoding rank,zip");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("unknown encoding 'zip'"), std::string::npos) << r.err;
}

// dfs-fast is served by the one dfs section (no second copy); csm and sdag are stored and answer queries.
TEST(CliEncode, DfsFastSharesTheDfsSectionAndDagsAnswer) {
  TempDir dir;
  const std::string out = dir / "oak.somm";
  RunResult r =
      runSomm(dir, "bake " + shellQuote(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf") + " -o " +
                       shellQuote(out) + " --level 5 --format 4 --encoding dfs-fast,csm,sdag");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto f = readSommFile(out);
  ASSERT_TRUE(f.ok());
  ASSERT_EQ(f->micromaps.arrays.size(), 1u);  // one scene-wide array: the DAGs share across the scene
  ASSERT_EQ(f->encodings[0].size(), 3u);
  EXPECT_EQ(f->encodings[0][0].id, sectionId("dfs "));
  EXPECT_EQ(f->encodings[0][1].id, sectionId("csm "));
  EXPECT_EQ(f->encodings[0][2].id, sectionId("sdag"));
  EXPECT_EQ(f->encodings[0][2].bytes,
            EncodedArray::build(f->micromaps.arrays[0], Encoding::Sdag).value().serialize());
  testing::writeFile(dir / "uv.txt", "0.1 0.2\n0.3 0.3\n0.7 0.1\n0.05 0.9\n0.4 0.41\n");
  const RunResult flat = runSomm(dir, "query " + shellQuote(out) + " -g 0 -t 1", dir / "uv.txt");
  ASSERT_EQ(flat.exitCode, 0) << flat.err;
  for (const char* e : {"dfs", "dfs-fast", "csm", "sdag"}) {
    const RunResult q =
        runSomm(dir, "query " + shellQuote(out) + " -g 0 -t 1 --encoding " + e, dir / "uv.txt");
    ASSERT_EQ(q.exitCode, 0) << e << ": " << q.err;
    EXPECT_EQ(q.out, flat.out) << e;
  }
  r = runSomm(dir, "info " + shellQuote(out) + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  const nlohmann::json& s = j["total"]["encoding_sizes"];
  EXPECT_EQ(s["dfs-fast"]["bytes"], s["dfs"]["bytes"]);
  EXPECT_TRUE(s.contains("csm"));
  EXPECT_TRUE(s.contains("sdag"));
}

}  // namespace
}  // namespace somm
