// SPDX-License-Identifier: MIT
// somm bake → .somm → info / query round trips on the bundled scenes, determinism, failures leave nothing
// behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "cli_util.h"
#include "somm/bake.h"
#include "somm/scene.h"
#include "somm/somm_file.h"

namespace somm {
namespace {

using testing::RunResult;
using testing::runSomm;
using testing::TempDir;

const std::string kOak = std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf";
const std::string kBlend = std::string(SOMM_DATA_DIR) + "/alpha-blend-mode-test/AlphaBlendModeTest.gltf";

std::string q(const std::string& s) {
  return "'" + s + "'";
}

TEST(CliBake, FileMatchesTheLibraryAndQueryMatchesStateUV) {
  TempDir dir;
  const std::string out = dir.file("oak.somm");
  const RunResult r = runSomm("bake " + q(kOak) + " -o " + q(out) + " --level 5 --threads 2");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find(out + ": 2 geometries, 555 triangles"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("into one scene-wide OMM array"), std::string::npos) << r.out;
  auto file = readSommFile(out);
  ASSERT_TRUE(file.ok()) << file.error().message;
  EXPECT_EQ(file->sourcePath, kOak);
  ASSERT_EQ(file->micromaps.arrays.size(), 1u);
  // The same bake with one array per geometry: each array is exactly the library's per-geometry bake.
  const std::string perGeometry = dir.file("oak-g.somm");
  ASSERT_EQ(runSomm("bake " + q(kOak) + " -o " + q(perGeometry) + " --level 5 --arrays geometry").exitCode,
            0);
  auto fileG = readSommFile(perGeometry);
  ASSERT_TRUE(fileG.ok()) << fileG.error().message;
  ASSERT_EQ(fileG->micromaps.arrays.size(), 2u);
  auto scene = loadScene(kOak);
  ASSERT_TRUE(scene.ok());
  ASSERT_EQ(file->geometries.size(), scene->geometries.size());
  BakeOptions bo;
  bo.level = 5;
  for (size_t g = 0; g < scene->geometries.size(); ++g) {
    const Geometry& geo = scene->geometries[g];
    auto baked = bakeGeometry(geo, scene->materials[geo.material], bo);
    ASSERT_TRUE(baked.ok());
    const GeometryInfo& sg = file->geometries[g];
    EXPECT_EQ(sg.name, geo.name);
    EXPECT_EQ(sg.triangleCount, geo.triangleCount());
    EXPECT_EQ(sg.stats.microTriangles, baked->stats.microTriangles);
    EXPECT_EQ(sg.stats.unknownMicroTriangles, baked->stats.unknownMicroTriangles);
    EXPECT_EQ(fileG->geometries[g], sg);
    const OmmArray& own = fileG->micromaps.arrays[g];
    EXPECT_EQ(own.data, baked->array.data);
    EXPECT_EQ(own.descriptors, baked->array.descriptors);
    EXPECT_EQ(own.indices, baked->array.indices);
    // In the scene-wide array: the same maps (standalone rebuilds the geometry's own array in order of first use).
    const OmmArray alone = file->micromaps.standalone(uint32_t(g));
    EXPECT_EQ(alone.data, baked->array.data);
    EXPECT_EQ(alone.descriptors, baked->array.descriptors);
    EXPECT_EQ(alone.indices, baked->array.indices);
  }
  // Query: every 9th triangle of the leaves, random barycentrics plus the vertices, against stateUV.
  const OmmArray& a = fileG->micromaps.arrays[0];
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> uni(0.0f, 1.0f);
  for (uint32_t t = 0; t < a.indices.size(); t += 9) {
    std::string input, expected;
    for (int k = 0; k < 300; ++k) {
      float u = uni(rng), v = uni(rng);
      if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
      if (k < 3) u = k == 1 ? 1.0f : 0.0f, v = k == 2 ? 1.0f : 0.0f;
      char line[64];
      std::snprintf(line, sizeof line, "%.9g %.9g\n", double(u), double(v));
      input += line;
      expected += char('0' + int(a.stateUV(t, u, v)));
      expected += '\n';
    }
    const RunResult qr = runSomm("query " + q(out) + " --geometry 0 --triangle " + std::to_string(t), input);
    ASSERT_EQ(qr.exitCode, 0) << qr.err;
    ASSERT_EQ(qr.out, expected) << "triangle " << t;
  }
}

TEST(CliBake, IdenticalBytesForAnyThreadCount) {
  TempDir dir;
  const std::string a = dir.file("a.somm"), b = dir.file("b.somm");
  ASSERT_EQ(runSomm("bake " + q(kOak) + " -o " + q(a) + " --max-level 7 --texels-per-microtri 2 --threads 1")
                .exitCode,
            0);
  ASSERT_EQ(runSomm("bake " + q(kOak) + " -o " + q(b) + " --max-level 7 --texels-per-microtri 2 --threads 2")
                .exitCode,
            0);
  const std::string x = testing::readFile(a), y = testing::readFile(b);
  ASSERT_GT(x.size(), 1000u);
  EXPECT_TRUE(x == y) << "bakes with 1 and 2 threads differ";
}

TEST(CliBake, JsonSummaryAndEstimate) {
  TempDir dir;
  const std::string out = dir.file("blend.somm");
  RunResult r = runSomm("bake " + q(kBlend) + " -o " + q(out) + " --level 4 --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("note: material 'MatBlend' uses alphaMode BLEND"), std::string::npos) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  for (const char* key : {"scene", "output", "seconds", "arrays", "geometries", "total"})
    EXPECT_TRUE(j.contains(key)) << key;
  const nlohmann::json& t = j["total"];
  for (const char* key : {"triangles", "special", "micromap_triangles", "unique_micromaps", "level_histogram",
                          "micro_triangles", "unknown_micro_triangles", "unknown_fraction", "bytes",
                          "geometries", "arrays", "bake_stats"})
    EXPECT_TRUE(t.contains(key)) << key;
  EXPECT_EQ(t["arrays"], 1);
  auto file = readSommFile(out);
  ASSERT_TRUE(file.ok());
  uint64_t tris = 0, data = 0, opaque = 0;
  for (const OmmArray& a : file->micromaps.arrays) {
    tris += a.indices.size();
    data += a.data.size();
    for (int32_t i : a.indices) opaque += i == specialIndexFor(State::Opaque);
  }
  EXPECT_EQ(t["triangles"], tris);
  EXPECT_EQ(t["bytes"]["data"], data);
  EXPECT_EQ(t["special"]["opaque"], opaque);
  // `info --json` reports the same counters.
  r = runSomm("info " + q(out) + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json info = nlohmann::json::parse(r.out);
  for (const char* key : {"triangles", "special", "unique_micromaps", "level_histogram", "micro_triangles",
                          "unknown_micro_triangles", "unknown_fraction", "bytes", "arrays", "bake_stats"})
    EXPECT_EQ(info["total"][key], t[key]) << key;
  EXPECT_EQ(info["bake_options"]["level"], "4");
  // --estimate: an upper bound of the baked data, written nowhere.
  r = runSomm("bake " + q(kBlend) + " --level 4 --estimate --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json e = nlohmann::json::parse(r.out);
  EXPECT_GE(e["data_bytes"].get<uint64_t>(), data);
  EXPECT_EQ(e["triangles"], tris);
}

TEST(CliBake, MaxBytesAndTwoState) {
  TempDir dir;
  const std::string out = dir.file("small.somm");
  RunResult r =
      runSomm("bake " + q(kOak) + " -o " + q(out) + " --level 8 --max-bytes 20000 --format 2 --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_LE(j["total"]["bytes"]["data"].get<uint64_t>(), 20000u);
  EXPECT_GT(j["total"]["bytes"]["data"].get<uint64_t>(), 0u);
  auto file = readSommFile(out);
  ASSERT_TRUE(file.ok());
  EXPECT_EQ(file->geometries[0].format, Format::TwoState);
  EXPECT_LT(file->geometries[0].maxLevel, 8u);
  std::string input;
  for (int k = 0; k <= 100; ++k)
    input += std::to_string(k / 100.0) + " " + std::to_string((100 - k) / 200.0) + "\n";
  r = runSomm("query " + q(out) + " --geometry 0 --triangle 0", input);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.out.find_first_not_of("01\n"), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 101);
}

// Scene-wide and per-geometry arrays give identical states for every (geometry, triangle, micro-triangle); returns
// the unique maps of both.
void expectSameStates(const SommFile& scene, const SommFile& perGeometry, uint64_t& sceneMaps,
                      uint64_t& sumMaps) {
  ASSERT_EQ(scene.micromaps.arrays.size(), 1u);
  ASSERT_EQ(perGeometry.micromaps.arrays.size(), perGeometry.geometries.size());
  ASSERT_EQ(scene.geometries, perGeometry.geometries);
  for (uint32_t g = 0; g < scene.geometries.size(); ++g) {
    const SceneMicromaps &a = scene.micromaps, &b = perGeometry.micromaps;
    ASSERT_EQ(a.geometries[g].array, 0u);
    ASSERT_EQ(b.geometries[g].array, g);
    ASSERT_EQ(a.geometries[g].triangleCount, b.geometries[g].triangleCount);
    for (uint32_t t = 0; t < a.geometries[g].triangleCount; ++t) {
      const int32_t i = b.indices(g)[t];
      const uint32_t level = i < 0 ? 0 : b.arrayOf(g).descriptors[size_t(i)].subdivisionLevel;
      ASSERT_EQ(a.indices(g)[t] < 0, i < 0) << g << " " << t;
      for (uint32_t k = 0; k < microTriangleCount(level); ++k)
        ASSERT_EQ(a.state(g, t, k), b.state(g, t, k)) << g << " " << t << " " << k;
    }
  }
  sceneMaps = scene.micromaps.arrays[0].descriptors.size();
  sumMaps = 0;
  for (const OmmArray& x : perGeometry.micromaps.arrays) sumMaps += x.descriptors.size();
}

TEST(CliBake, SceneWideArrayMatchesPerGeometryArrays) {
  struct Case {
    std::string scene, level;
    bool multiGeometry;
  };
  std::vector<Case> cases = {{kOak, "6", false}};
  const char* env = std::getenv("SOMM_SHARED_DIR");  // default: ../shared next to the checkout
  for (const std::string& root : {std::string(env ? env : ""), std::string(SOMM_DATA_DIR) + "/../../shared",
                                  std::string("/work/shared")}) {
    if (root.empty()) continue;
    const std::string p = root + "/assets/foliage/torcs-forza/forza.obj";
    if (std::filesystem::exists(p)) {
      cases.push_back({p, "3", true});
      break;
    }
  }
  if (cases.size() == 1)
    std::fprintf(stderr, "note: ../shared/assets/foliage/torcs-forza not present: oak only\n");
  for (const Case& c : cases) {
    TempDir dir;
    const std::string a = dir.file("scene.somm"), b = dir.file("geometry.somm");
    RunResult r = runSomm("bake " + q(c.scene) + " -o " + q(a) + " --level " + c.level + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json ja = nlohmann::json::parse(r.out);
    r = runSomm("bake " + q(c.scene) + " -o " + q(b) + " --level " + c.level + " --arrays geometry --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json jb = nlohmann::json::parse(r.out);
    auto fa = readSommFile(a), fb = readSommFile(b);
    ASSERT_TRUE(fa.ok() && fb.ok());
    uint64_t sceneMaps = 0, sumMaps = 0;
    expectSameStates(*fa, *fb, sceneMaps, sumMaps);
    EXPECT_EQ(ja["total"]["unique_micromaps"], sceneMaps);
    EXPECT_EQ(jb["total"]["unique_micromaps"], sumMaps);
    // Per-geometry counters do not depend on the layout.
    for (const char* key :
         {"triangles", "special", "micro_triangles", "unknown_micro_triangles", "micromap_triangles"})
      EXPECT_EQ(ja["total"][key], jb["total"][key]) << key;
    if (c.multiGeometry) {
      // Identical maps of different geometries are stored once.
      EXPECT_LT(sceneMaps, sumMaps) << c.scene;
      EXPECT_LT(ja["total"]["bytes"]["data"].get<uint64_t>(), jb["total"]["bytes"]["data"].get<uint64_t>());
    } else {
      EXPECT_LE(sceneMaps, sumMaps);
    }
  }
}

TEST(CliBake, EncodingsPerArray) {
  TempDir dir;
  const std::string out = dir.file("oak.somm");
  ASSERT_EQ(runSomm("bake " + q(kOak) + " -o " + q(out) + " --level 4 --encoding rank,dfs-fast").exitCode, 0);
  auto f = readSommFile(out);
  ASSERT_TRUE(f.ok());
  ASSERT_EQ(f->encodings.size(), 1u);
  ASSERT_EQ(f->encodings[0].size(), 2u);  // one section per encoding for the whole scene
  const std::string outG = dir.file("oak-g.somm");
  ASSERT_EQ(
      runSomm("bake " + q(kOak) + " -o " + q(outG) + " --level 4 --encoding rank --arrays geometry").exitCode,
      0);
  auto g = readSommFile(outG);
  ASSERT_TRUE(g.ok());
  ASSERT_EQ(g->encodings.size(), 2u);
  for (const auto& e : g->encodings) EXPECT_EQ(e.size(), 1u);
  // Query through a stored encoding of the scene-wide array answers like flat, for both geometries.
  for (const char* geometry : {"0", "1"}) {
    const std::string input = "0.1 0.2\n0.5 0.25\n0 0\n0.9 0.05\n";
    const RunResult flat = runSomm("query " + q(out) + " --geometry " + geometry + " --triangle 3", input);
    const RunResult rank =
        runSomm("query " + q(out) + " --geometry " + geometry + " --triangle 3 --encoding rank", input);
    ASSERT_EQ(flat.exitCode, 0) << flat.err;
    ASSERT_EQ(rank.exitCode, 0) << rank.err;
    EXPECT_EQ(flat.out, rank.out);
  }
}

TEST(CliBake, FailuresLeaveNothingBehind) {
  TempDir dir;
  const std::string out = dir.file("out.somm");
  const struct {
    std::string args;
    int exitCode;
    std::string needle;
  } cases[] = {
      {"bake " + q(dir.file("missing.gltf")) + " -o " + q(out), 1, "missing.gltf"},
      {"bake " + q(kOak) + " -o " + q(dir.file("no/such/dir/out.somm")), 1, "no/such/dir/out.somm"},
      {"bake " + q(kOak) + " -o " + q(out) + " --level 13", 2, "--level"},
      {"bake " + q(kOak) + " -o " + q(out) + " --level 3 --max-level 5 --texels-per-microtri 1", 2,
       "cannot be combined"},
      {"bake " + q(kOak) + " -o " + q(out) + " --max-level 5", 2, "go together"},
      {"bake " + q(kOak) + " -o " + q(out) + " --format 3", 2, "--format"},
      {"bake " + q(kOak) + " -o " + q(out) + " --cutoff 1.5", 2, "--cutoff"},
      {"bake " + q(kOak), 2, "-o OUT.somm is required"},
      {"bake " + q(kOak) + " -o " + q(out) + " --arrays material", 2, "--arrays"},
  };
  for (const auto& c : cases) {
    const RunResult r = runSomm(c.args);
    EXPECT_EQ(r.exitCode, c.exitCode) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.needle), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    size_t entries = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++entries;
    EXPECT_EQ(entries, 0u) << c.args;
  }
  // A failing bake never clobbers an existing output.
  testing::writeFile(out, "previous contents");
  const RunResult r = runSomm("bake " + q(dir.file("missing.obj")) + " -o " + q(out));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_EQ(testing::readFile(out), "previous contents");
}

}  // namespace
}  // namespace somm
