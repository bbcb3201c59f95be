// SPDX-License-Identifier: MIT
// somm info / query / export on .somm files built from Micromaps in the test.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <random>

#include "cli_util.h"
#include "somm/somm_file.h"
#include "somm_test_arrays.h"

namespace somm {
namespace {

using testing::RunResult;
using testing::runSomm;
using testing::sampleFile;
using testing::TempDir;

std::string shellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string writeSample(const TempDir& dir, const SommFile& f, const std::string& name = "in.somm") {
  const std::string p = dir.file(name);
  const Status s = writeSommFile(p, f);
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
  return p;
}

TEST(CliInfo, JsonMatchesTheArrays) {
  TempDir dir;
  const SommFile f = sampleFile(200, 21);
  const std::string p = writeSample(dir, f);
  const RunResult r = runSomm("info " + shellQuote(p) + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["file"], p);
  EXPECT_EQ(j["version"], 1);
  EXPECT_EQ(j["source"], f.sourcePath);
  EXPECT_EQ(j["tool_version"], f.toolVersion);
  EXPECT_EQ(j["bake_options"]["level"], "3");
  ASSERT_EQ(j["geometries"].size(), f.geometries.size());
  uint64_t totalTriangles = 0, totalData = 0, totalSpecial[4] = {};
  for (size_t g = 0; g < f.geometries.size(); ++g) {
    const SommGeometry& geo = f.geometries[g];
    const nlohmann::json& x = j["geometries"][g];
    EXPECT_EQ(x["index"], g);
    EXPECT_EQ(x["name"], geo.info.name);
    EXPECT_EQ(x["material"], geo.info.material);
    EXPECT_EQ(x["format"], geo.info.format == Format::TwoState ? 2 : 4);
    EXPECT_EQ(x["min_level"], geo.info.minLevel);
    EXPECT_EQ(x["max_level"], geo.info.maxLevel);
    EXPECT_EQ(x["cutoff"].get<float>(), geo.info.cutoff);
    EXPECT_EQ(x["triangles"], geo.flat.indices.size());
    uint64_t special[4] = {}, perLevel[13] = {}, mapTris = 0;
    for (int32_t i : geo.flat.indices)
      if (i < 0)
        ++special[-1 - i];
      else
        ++mapTris, ++perLevel[geo.flat.descriptors[size_t(i)].subdivisionLevel];
    EXPECT_EQ(x["special"]["transparent"], special[0]);
    EXPECT_EQ(x["special"]["opaque"], special[1]);
    EXPECT_EQ(x["special"]["unknown_transparent"], special[2]);
    EXPECT_EQ(x["special"]["unknown_opaque"], special[3]);
    EXPECT_EQ(x["micromap_triangles"], mapTris);
    EXPECT_EQ(x["unique_micromaps"], geo.flat.descriptors.size());
    uint64_t histTris = 0;
    for (const auto& h : x["level_histogram"]) {
      EXPECT_EQ(h["triangles"], perLevel[h["level"].get<uint32_t>()]);
      histTris += h["triangles"].get<uint64_t>();
    }
    EXPECT_EQ(histTris, mapTris);
    EXPECT_EQ(x["micro_triangles"], geo.info.stats.microTriangles);
    EXPECT_EQ(x["unknown_micro_triangles"], geo.info.stats.unknownMicroTriangles);
    EXPECT_DOUBLE_EQ(x["unknown_fraction"].get<double>(), geo.info.stats.microTriangles
                                                              ? double(geo.info.stats.unknownMicroTriangles) /
                                                                    double(geo.info.stats.microTriangles)
                                                              : 0.0);
    EXPECT_EQ(x["bytes"]["data"], geo.flat.data.size());
    EXPECT_EQ(x["bytes"]["descriptors"], 8 * geo.flat.descriptors.size());
    EXPECT_EQ(x["bytes"]["index_buffer"], geo.flat.indexBufferBytes().size());
    EXPECT_EQ(x["index_type"], 16);
    ASSERT_EQ(x["encodings"].size(), geo.extra.size());
    for (size_t e = 0; e < geo.extra.size(); ++e) {
      EXPECT_EQ(x["encodings"][e]["id"], sectionIdName(geo.extra[e].id));
      EXPECT_EQ(x["encodings"][e]["bytes"], geo.extra[e].bytes.size());
    }
    totalTriangles += geo.flat.indices.size();
    totalData += geo.flat.data.size();
    for (int s = 0; s < 4; ++s) totalSpecial[s] += special[s];
  }
  EXPECT_EQ(j["total"]["geometries"], f.geometries.size());
  EXPECT_EQ(j["total"]["triangles"], totalTriangles);
  EXPECT_EQ(j["total"]["bytes"]["data"], totalData);
  EXPECT_EQ(j["total"]["special"]["opaque"], totalSpecial[1]);
  EXPECT_EQ(j["total"]["special"]["unknown_opaque"], totalSpecial[3]);
  ASSERT_EQ(j["total"]["encodings"].size(), 3u);
  EXPECT_EQ(j["total"]["encodings"][0]["id"], "dfs");
}

TEST(CliInfo, TextNamesGeometries) {
  TempDir dir;
  const std::string p = writeSample(dir, sampleFile(20, 2));
  const RunResult r = runSomm("info " + shellQuote(p));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("geometry 0 'leaves'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("geometry 2 'empty' (material 'empty-material'): 0 triangles"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("total: 3 geometries, 40 triangles"), std::string::npos) << r.out;
}

TEST(CliQuery, MatchesStateUV) {
  TempDir dir;
  const SommFile f = sampleFile(30, 8);
  const std::string p = writeSample(dir, f);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> uni(0.0f, 1.0f);
  for (size_t g = 0; g < 2; ++g) {
    const SommGeometry& geo = f.geometries[g];
    for (uint32_t t = 0; t < geo.flat.indices.size(); t += 3) {
      std::string input, expected;
      for (int k = 0; k < 200; ++k) {
        float u = uni(rng), v = uni(rng);
        if (k % 10 == 0) u = 0.0f;  // edges and vertices
        if (k % 7 == 0) v = 1.0f - u;
        if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
        char line[80];
        std::snprintf(line, sizeof line, "%a %a\n", double(u), double(v));
        input += line;
        State s = geo.flat.stateUV(t, u, v);
        if (geo.info.format == Format::TwoState) s = toTwoState(s);
        expected += char('0' + int(s));
        expected += '\n';
      }
      const RunResult r = runSomm(
          "query " + shellQuote(p) + " --geometry " + std::to_string(g) + " --triangle " + std::to_string(t),
          input);
      ASSERT_EQ(r.exitCode, 0) << r.err;
      ASSERT_EQ(r.out, expected) << "geometry " << g << " triangle " << t;
    }
  }
}

TEST(CliQuery, Errors) {
  TempDir dir;
  const std::string p = writeSample(dir, sampleFile(10, 1));
  RunResult r = runSomm("query " + shellQuote(p) + " --geometry 3 --triangle 0");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--geometry 3 is out of range"), std::string::npos) << r.err;
  r = runSomm("query " + shellQuote(p) + " --geometry 1 --triangle 10");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--triangle 10 is out of range: geometry 1 has 10 triangles"), std::string::npos)
      << r.err;
  r = runSomm("query " + shellQuote(p) + " --geometry 0 --triangle 0", "0.1 0.2\n0.3 x\n");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("stdin line 2"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1);
}

TEST(CliFile, CorruptAndTruncatedFilesAreRejected) {
  TempDir dir;
  const std::string p = writeSample(dir, sampleFile(25, 4));
  const std::string bytes = testing::readFile(p);
  const std::string cut = dir.file("cut.somm"), flipped = dir.file("flip.somm"),
                    foreign = dir.file("foreign.somm");
  testing::writeFile(cut, bytes.substr(0, bytes.size() / 2));
  std::string f = bytes;
  f[f.size() / 3] ^= 0x10;
  testing::writeFile(flipped, f);
  testing::writeFile(foreign, "glTF not a somm file at all");
  const struct {
    std::string path, needle;
  } cases[] = {{cut, "truncated"},
               {flipped, "checksum mismatch"},
               {foreign, "not a .somm file"},
               {dir.file("missing.somm"), "cannot open"}};
  for (const auto& c : cases)
    for (const std::string cmd : {"info", "query", "export"}) {
      std::string args = cmd + " " + shellQuote(c.path);
      if (cmd == "query") args += " --geometry 0 --triangle 0";
      if (cmd == "export") args += " --dir " + shellQuote(dir.file("exp"));
      const RunResult r = runSomm(args);
      EXPECT_EQ(r.exitCode, 1) << args;
      EXPECT_EQ(r.err.rfind("somm " + cmd + ": " + c.path + ": ", 0), 0u) << r.err;
      EXPECT_NE(r.err.find(c.needle), std::string::npos) << r.err;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      EXPECT_TRUE(r.out.empty()) << r.out;
      EXPECT_FALSE(std::filesystem::exists(dir.file("exp")));
    }
}

TEST(CliExport, WritesTheSpecBuffers) {
  TempDir dir;
  const SommFile f = sampleFile(60, 12);
  const std::string p = writeSample(dir, f);
  const std::string out = dir.file("export");
  const RunResult r = runSomm("export " + shellQuote(p) + " --dir " + shellQuote(out));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  for (size_t g = 0; g < f.geometries.size(); ++g) {
    const OmmArray& a = f.geometries[g].flat;
    const std::string sub = out + "/geometry-" + std::to_string(g) + "/";
    auto asBytes = [](const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); };
    EXPECT_EQ(asBytes(testing::readFile(sub + "data.bin")), a.data);
    EXPECT_EQ(asBytes(testing::readFile(sub + "triangles.bin")), a.descriptorBytes());
    EXPECT_EQ(asBytes(testing::readFile(sub + "index.bin")), a.indexBufferBytes());
    const nlohmann::json u = nlohmann::json::parse(testing::readFile(sub + "usage.json"));
    EXPECT_EQ(u["format"], f.geometries[g].info.format == Format::TwoState ? 2 : 4);
    EXPECT_EQ(u["index_type"], "uint16");
    EXPECT_EQ(u["index_stride"], 2);
    EXPECT_EQ(u["triangles"], a.indices.size());
    EXPECT_EQ(u["micromaps"], a.descriptors.size());
    ASSERT_EQ(u["usage_counts"].size(), a.histogram.size());
    for (size_t i = 0; i < a.histogram.size(); ++i) {
      EXPECT_EQ(u["usage_counts"][i]["count"], a.histogram[i].count);
      EXPECT_EQ(u["usage_counts"][i]["subdivisionLevel"], a.histogram[i].subdivisionLevel);
      EXPECT_EQ(u["usage_counts"][i]["format"], a.histogram[i].format);
    }
    ASSERT_EQ(u["triangle_usage_counts"].size(), a.triangleHistogram.size());
  }
  // Only the expected files, no temporaries.
  size_t files = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(out)) files += e.is_regular_file();
  EXPECT_EQ(files, 4 * f.geometries.size());
}

}  // namespace
}  // namespace somm
