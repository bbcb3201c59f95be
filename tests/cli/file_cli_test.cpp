// SPDX-License-Identifier: MIT
// somm info / query / export on .somm files built from Micromaps in the test.
#include <gtest/gtest.h>

#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

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

// Counters of geometry g recomputed from the scene's micromaps (independent of the CLI's summary code).
struct Expected {
  uint64_t special[4] = {}, perLevel[13] = {}, mapTris = 0, micro = 0, unknown = 0;
  std::set<int32_t> distinct;
};
Expected expectedOf(const SommFile& f, uint32_t g) {
  Expected e;
  const SceneMicromaps& m = f.micromaps;
  for (uint32_t t = 0; t < m.geometries[g].triangleCount; ++t) {
    const int32_t i = m.indices(g)[t];
    if (i < 0) {
      ++e.special[-1 - i];
      continue;
    }
    const uint32_t level = m.arrayOf(g).descriptors[size_t(i)].subdivisionLevel;
    ++e.mapTris, ++e.perLevel[level];
    e.distinct.insert(i);
    e.micro += microTriangleCount(level);
    for (uint32_t k = 0; k < microTriangleCount(level); ++k) e.unknown += isKnown(m.state(g, t, k)) ? 0 : 1;
  }
  return e;
}

TEST(CliInfo, JsonMatchesTheArrays) {
  for (testing::Layout layout : {testing::Layout::Scene, testing::Layout::PerGeometry}) {
    TempDir dir;
    const SommFile f = sampleFile(200, 21, layout);
    const SceneMicromaps& m = f.micromaps;
    const std::string p = writeSample(dir, f);
    const RunResult r = runSomm("info " + shellQuote(p) + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["file"], p);
    EXPECT_EQ(j["version"], 2);
    EXPECT_EQ(j["source"], f.sourcePath);
    EXPECT_EQ(j["tool_version"], f.toolVersion);
    EXPECT_EQ(j["bake_options"]["level"], "3");
    ASSERT_EQ(j["arrays"].size(), m.arrays.size());
    uint64_t totalMaps = 0, totalData = 0;
    for (size_t a = 0; a < m.arrays.size(); ++a) {
      const OmmArray& arr = m.arrays[a];
      const nlohmann::json& x = j["arrays"][a];
      EXPECT_EQ(x["index"], a);
      EXPECT_EQ(x["triangles"], arr.indices.size());
      EXPECT_EQ(x["unique_micromaps"], arr.descriptors.size());
      EXPECT_EQ(x["bytes"]["data"], arr.data.size());
      EXPECT_EQ(x["bytes"]["descriptors"], 8 * arr.descriptors.size());
      uint64_t levelMaps = 0;
      for (const auto& h : x["level_histogram"]) levelMaps += h["micromaps"].get<uint64_t>();
      EXPECT_EQ(levelMaps, arr.descriptors.size());
      ASSERT_EQ(x["encodings"].size(), f.encodings[a].size());
      for (size_t e = 0; e < f.encodings[a].size(); ++e)
        EXPECT_EQ(x["encodings"][e]["section_bytes"], f.encodings[a][e].bytes.size());
      // Encodings by name, never by section id; no reference compressors unless asked.
      const std::string text = x.dump();
      EXPECT_EQ(text.find("\"dfsf\""), std::string::npos);
      EXPECT_EQ(text.find("\"hybr\""), std::string::npos);
      EXPECT_FALSE(x["encoding_sizes"].contains("zstd-19"));
      totalMaps += arr.descriptors.size();
      totalData += arr.data.size();
    }
    if (layout == testing::Layout::Scene) {
      EXPECT_EQ(j["arrays"][0]["encodings"][0]["name"], "dfs");
      EXPECT_EQ(j["arrays"][0]["encodings"][2]["name"], "hybrid");
      EXPECT_EQ(j["arrays"][0]["geometry_indices"], nlohmann::json({0, 1, 2}));
    }
    ASSERT_EQ(j["geometries"].size(), f.geometries.size());
    uint64_t totalTriangles = 0, totalSpecial[4] = {}, totalMicro = 0, totalUnknown = 0;
    for (uint32_t g = 0; g < f.geometries.size(); ++g) {
      const GeometryInfo& geo = f.geometries[g];
      const nlohmann::json& x = j["geometries"][g];
      const Expected e = expectedOf(f, g);
      EXPECT_EQ(x["index"], g);
      EXPECT_EQ(x["name"], geo.name);
      EXPECT_EQ(x["material"], geo.material);
      EXPECT_EQ(x["array"], m.geometries[g].array);
      EXPECT_EQ(x["first_triangle"], m.geometries[g].firstTriangle);
      EXPECT_EQ(x["states"], geo.format == Format::TwoState ? 2 : 4);
      EXPECT_EQ(x["min_level"], geo.minLevel);
      EXPECT_EQ(x["max_level"], geo.maxLevel);
      EXPECT_EQ(x["cutoff"].get<float>(), geo.cutoff);
      EXPECT_EQ(x["triangles"], geo.triangleCount);
      EXPECT_EQ(x["special"]["transparent"], e.special[0]);
      EXPECT_EQ(x["special"]["opaque"], e.special[1]);
      EXPECT_EQ(x["special"]["unknown_transparent"], e.special[2]);
      EXPECT_EQ(x["special"]["unknown_opaque"], e.special[3]);
      EXPECT_EQ(x["micromap_triangles"], e.mapTris);
      EXPECT_EQ(x["distinct_micromaps"], e.distinct.size());
      uint64_t histTris = 0;
      for (const auto& h : x["level_histogram"]) {
        EXPECT_EQ(h["triangles"], e.perLevel[h["level"].get<uint32_t>()]);
        histTris += h["triangles"].get<uint64_t>();
      }
      EXPECT_EQ(histTris, e.mapTris);
      // Unknown: over the micro-triangles of the triangles with micromaps, from the stored states.
      EXPECT_EQ(x["micro_triangles"], e.micro);
      EXPECT_EQ(x["unknown_micro_triangles"], e.unknown);
      if (geo.format == Format::FourState && e.micro > 0) {
        EXPECT_GT(e.unknown, 0u);
      }
      EXPECT_DOUBLE_EQ(x["unknown_fraction"].get<double>(),
                       e.micro ? double(e.unknown) / double(e.micro) : 0.0);
      EXPECT_EQ(x["bake_stats"]["classified_micro_triangles"], geo.stats.microTriangles);
      EXPECT_EQ(x["bake_stats"]["classified_unknown_micro_triangles"], geo.stats.unknownMicroTriangles);
      EXPECT_EQ(x["bake_stats"]["invalid_uv_triangles"], geo.stats.invalidUvTriangles);
      EXPECT_EQ(x["index_type"], 16);
      EXPECT_EQ(x["index_buffer_bytes"], 2 * geo.triangleCount);
      totalTriangles += geo.triangleCount;
      totalMicro += e.micro;
      totalUnknown += e.unknown;
      for (int k = 0; k < 4; ++k) totalSpecial[k] += e.special[k];
    }
    const nlohmann::json& t = j["total"];
    EXPECT_EQ(t["geometries"], f.geometries.size());
    EXPECT_EQ(t["arrays"], m.arrays.size());
    EXPECT_EQ(t["triangles"], totalTriangles);
    EXPECT_EQ(t["unique_micromaps"], totalMaps);
    EXPECT_EQ(t["bytes"]["data"], totalData);
    EXPECT_EQ(t["bytes"]["index_buffers"], 2 * totalTriangles);
    EXPECT_EQ(t["micro_triangles"], totalMicro);
    EXPECT_EQ(t["unknown_micro_triangles"], totalUnknown);
    EXPECT_EQ(t["special"]["opaque"], totalSpecial[1]);
    EXPECT_EQ(t["special"]["unknown_opaque"], totalSpecial[3]);
  }
}

TEST(CliInfo, ReferenceCompressorsOnlyWhenAsked) {
  TempDir dir;
  const std::string p = writeSample(dir, sampleFile(50, 3));
  RunResult r = runSomm("info " + shellQuote(p) + " --json --reference-compressors");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["arrays"][0]["encoding_sizes"]["zstd-19"]["bytes"].get<uint64_t>(), 0u);
  EXPECT_GT(j["arrays"][0]["encoding_sizes"]["xz-9"]["bytes"].get<uint64_t>(), 0u);
  EXPECT_EQ(j["arrays"][0]["encoding_sizes"]["xz-9"]["random_access"], false);
  r = runSomm("info " + shellQuote(p));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.out.find("zstd"), std::string::npos) << r.out;
  r = runSomm("info " + shellQuote(p) + " --reference-compressors");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("zstd -19 "), std::string::npos) << r.out;
}

TEST(CliInfo, TextNamesArraysAndGeometries) {
  TempDir dir;
  const std::string p = writeSample(dir, sampleFile(20, 2));
  const RunResult r = runSomm("info " + shellQuote(p));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find(".somm version 2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("array 0: 3 geometries, 40 triangles"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("geometry 0 'leaves'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("geometry 1 'bark' (material 'bark-material'): 20 triangles at 20 in array 0"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("geometry 2 'empty' (material 'empty-material'): 0 triangles"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("total: 3 geometries, 1 array, 40 triangles"), std::string::npos) << r.out;
  // Encodings by name (the sample's sections are opaque test bytes: listed as unreadable, never as ids).
  EXPECT_NE(r.out.find("dfs unreadable"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("hybrid unreadable"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("hybr "), std::string::npos) << r.out;
}

// A version-1 file (one array per geometry; the fuzz seed written by the version-1 library) is read by every command.
TEST(CliFile, Version1FilesAreRead) {
  TempDir dir;
  const std::string v1 = std::string(SOMM_DATA_DIR) + "/../fuzz/corpus/fuzz_somm_file/v1_one_2state";
  RunResult r = runSomm("info " + shellQuote(v1) + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["version"], 1);
  ASSERT_EQ(j["arrays"].size(), 1u);
  EXPECT_EQ(j["geometries"][0]["array"], 0);
  EXPECT_EQ(j["geometries"][0]["first_triangle"], 0);
  auto f = readSommFile(v1);
  ASSERT_TRUE(f.ok()) << f.error().message;
  std::string want;
  for (uint32_t t = 0; t < f->geometries[0].triangleCount; ++t)
    want += char('0' + int(toTwoState(f->micromaps.stateUV(0, t, 0.2f, 0.3f)))), want += '\n';
  std::string got;
  for (uint32_t t = 0; t < f->geometries[0].triangleCount; ++t) {
    r = runSomm("query " + shellQuote(v1) + " -g 0 -t " + std::to_string(t), "0.2 0.3\n");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    got += r.out;
  }
  EXPECT_EQ(got, want);
  r = runSomm("export " + shellQuote(v1) + " --dir " + shellQuote(dir.file("x")));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(testing::readFile(dir.file("x") + "/array-0/data.bin").size(),
            f->micromaps.arrays[0].data.size());
}

TEST(CliQuery, MatchesStateUV) {
  for (testing::Layout layout : {testing::Layout::Scene, testing::Layout::PerGeometry}) {
    TempDir dir;
    const SommFile f = sampleFile(30, 8, layout);
    const std::string p = writeSample(dir, f);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> uni(0.0f, 1.0f);
    for (uint32_t g = 0; g < 2; ++g) {
      for (uint32_t t = 0; t < f.geometries[g].triangleCount; t += 3) {
        std::string input, expected;
        for (int k = 0; k < 200; ++k) {
          float u = uni(rng), v = uni(rng);
          if (k % 10 == 0) u = 0.0f;  // edges and vertices
          if (k % 7 == 0) v = 1.0f - u;
          if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
          char line[80];
          std::snprintf(line, sizeof line, "%a %a\n", double(u), double(v));
          input += line;
          State s = f.micromaps.stateUV(g, t, u, v);
          if (f.geometries[g].format == Format::TwoState) s = toTwoState(s);
          expected += char('0' + int(s));
          expected += '\n';
        }
        const RunResult r = runSomm("query " + shellQuote(p) + " --geometry " + std::to_string(g) +
                                        " --triangle " + std::to_string(t),
                                    input);
        ASSERT_EQ(r.exitCode, 0) << r.err;
        ASSERT_EQ(r.out, expected) << "geometry " << g << " triangle " << t;
      }
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

// The exported buffers, read back as a Vulkan / DXR build would: every (geometry, triangle, micro-triangle) state
// from geometry-<g>/index.bin into array-<a>/{triangles.bin, data.bin} equals the file's.
TEST(CliExport, WritesTheBuildInputsPerArrayAndGeometry) {
  for (testing::Layout layout : {testing::Layout::Scene, testing::Layout::PerGeometry}) {
    TempDir dir;
    const SommFile f = sampleFile(60, 12, layout);
    const SceneMicromaps& m = f.micromaps;
    const std::string p = writeSample(dir, f);
    const std::string out = dir.file("export");
    const RunResult r = runSomm("export " + shellQuote(p) + " --dir " + shellQuote(out));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto asBytes = [](const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); };
    for (size_t a = 0; a < m.arrays.size(); ++a) {
      const OmmArray& arr = m.arrays[a];
      const std::string sub = out + "/array-" + std::to_string(a) + "/";
      EXPECT_EQ(asBytes(testing::readFile(sub + "data.bin")), arr.data);
      EXPECT_EQ(asBytes(testing::readFile(sub + "triangles.bin")), arr.descriptorBytes());
      const nlohmann::json u = nlohmann::json::parse(testing::readFile(sub + "usage.json"));
      EXPECT_EQ(u["array"], a);
      EXPECT_EQ(u["micromaps"], arr.descriptors.size());
      EXPECT_EQ(u["data_bytes"], arr.data.size());
      ASSERT_EQ(u["usage_counts"].size(), arr.histogram.size());
      for (size_t i = 0; i < arr.histogram.size(); ++i) {
        EXPECT_EQ(u["usage_counts"][i]["count"], arr.histogram[i].count);
        EXPECT_EQ(u["usage_counts"][i]["subdivisionLevel"], arr.histogram[i].subdivisionLevel);
        EXPECT_EQ(u["usage_counts"][i]["format"], arr.histogram[i].format);  // Vulkan value 1 / 2
        EXPECT_EQ(u["usage_counts"][i]["states"], arr.histogram[i].format == 1 ? 2 : 4);
      }
    }
    for (uint32_t g = 0; g < f.geometries.size(); ++g) {
      const std::string sub = out + "/geometry-" + std::to_string(g) + "/";
      const nlohmann::json u = nlohmann::json::parse(testing::readFile(sub + "usage.json"));
      const bool two = f.geometries[g].format == Format::TwoState;
      EXPECT_EQ(u["array"], m.geometries[g].array);
      EXPECT_EQ(u["format"], two ? 1 : 2);
      EXPECT_EQ(u["states"], two ? 2 : 4);
      EXPECT_EQ(u["index_type"], "uint16");
      EXPECT_EQ(u["index_stride"], 2);
      EXPECT_EQ(u["triangles"], f.geometries[g].triangleCount);
      // The geometry's own triangle usage counts.
      std::map<std::pair<uint32_t, uint32_t>, uint32_t> usage;
      for (uint32_t t = 0; t < m.geometries[g].triangleCount; ++t)
        if (const int32_t i = m.indices(g)[t]; i >= 0) {
          const TriangleDescriptor& d = m.arrayOf(g).descriptors[size_t(i)];
          ++usage[{d.format, d.subdivisionLevel}];
        }
      ASSERT_EQ(u["triangle_usage_counts"].size(), usage.size());
      size_t k = 0;
      for (const auto& [key, count] : usage) {
        EXPECT_EQ(u["triangle_usage_counts"][k]["format"], key.first);
        EXPECT_EQ(u["triangle_usage_counts"][k]["subdivisionLevel"], key.second);
        EXPECT_EQ(u["triangle_usage_counts"][k]["count"], count);
        ++k;
      }
      // Decode every state from the exported bytes.
      const std::string arrDir = out + "/array-" + std::to_string(u["array"].get<uint32_t>()) + "/";
      const auto index = asBytes(testing::readFile(sub + "index.bin"));
      const auto desc = asBytes(testing::readFile(arrDir + "triangles.bin"));
      const auto data = asBytes(testing::readFile(arrDir + "data.bin"));
      ASSERT_EQ(index.size(), 2 * size_t(f.geometries[g].triangleCount));
      for (uint32_t t = 0; t < f.geometries[g].triangleCount; ++t) {
        const uint16_t v = uint16_t(index[2 * t] | index[2 * t + 1] << 8);
        if (v >= 0xfffc) {
          ASSERT_EQ(m.indices(g)[t], int32_t(v) - 0x10000);
          continue;
        }
        const uint8_t* d = &desc[8 * size_t(v)];
        const uint32_t offset = uint32_t(d[0] | d[1] << 8 | d[2] << 16 | uint32_t(d[3]) << 24);
        const uint32_t level = d[4], format = d[6];
        for (uint32_t i = 0; i < microTriangleCount(level); ++i)
          ASSERT_EQ(readPackedState(&data[offset], Format(format), i), m.state(g, t, i))
              << g << " " << t << " " << i;
      }
    }
    // Only the expected files, no temporaries.
    size_t files = 0;
    for (const auto& e : std::filesystem::recursive_directory_iterator(out)) files += e.is_regular_file();
    EXPECT_EQ(files, 3 * m.arrays.size() + 2 * f.geometries.size());
  }
}

}  // namespace
}  // namespace somm
