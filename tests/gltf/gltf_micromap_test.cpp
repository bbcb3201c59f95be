// SPDX-License-Identifier: MIT
// EXT_mesh_opacity_micromap: bake → glTF → read equals the .somm bake; a hand-written file from the draft; every MUST
// violated once (our reader and the independent Python validator both reject it); preservation of a glTF input.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "somm/gltf.h"
#include "somm/procedural.h"
#include "somm/scene.h"
#include "somm/somm_file.h"

namespace {

using nlohmann::json;
using somm::testing::readFile;
using somm::testing::runSomm;
using somm::testing::shellQuote;
using somm::testing::TempDir;
using somm::testing::writeFile;
namespace fs = std::filesystem;

const std::string kData = SOMM_DATA_DIR;
const std::string kValidator = std::string(SOMM_TESTS_DIR) + "/gltf/validate_micromap_gltf.py";

bool havePython() {
  static const bool ok = std::system("python3 -c 'import json, struct' > /dev/null 2>&1") == 0;
  return ok;
}

// Runs the independent validator; returns its exit code (0 = valid) and output.
int runValidator(const std::string& args, std::string* output = nullptr) {
  TempDir d;
  const std::string cmd =
      "python3 " + shellQuote(kValidator) + " " + args + " > " + shellQuote(d / "out") + " 2>&1";
  const int st = std::system(cmd.c_str());
  if (output) *output = readFile(d / "out");
  return WIFEXITED(st) ? WEXITSTATUS(st) : 128;
}

// Every micro-triangle of every triangle: the glTF's states equal the .somm's.
void expectSameStates(const somm::SommFile& somm, const somm::GltfMicromaps& g, bool gltfInput) {
  const somm::SceneMicromaps& sm = somm.micromaps;
  ASSERT_EQ(sm.geometries.size(), g.micromaps.geometries.size());
  ASSERT_EQ(somm.geometries.size(), g.geometries.size());
  uint64_t checked = 0;
  for (uint32_t gi = 0; gi < sm.geometries.size(); ++gi) {
    const uint32_t n = sm.geometries[gi].triangleCount;
    ASSERT_EQ(n, g.micromaps.geometries[gi].triangleCount) << "geometry " << gi;
    const somm::OmmArray& a = sm.arrayOf(gi);
    const int32_t* ai = sm.indices(gi);
    const somm::OmmArray& b = g.micromaps.arrayOf(gi);
    const int32_t* bi = g.micromaps.indices(gi);
    for (uint32_t t = 0; t < n; ++t) {
      const uint32_t la = ai[t] >= 0 ? a.descriptors[size_t(ai[t])].subdivisionLevel : 0;
      const uint32_t lb = bi[t] >= 0 ? b.descriptors[size_t(bi[t])].subdivisionLevel : 0;
      const uint32_t level = std::max(la, lb);
      if (ai[t] >= 0 && bi[t] >= 0) {
        ASSERT_EQ(la, lb) << "geometry " << gi << " triangle " << t;
      }
      for (uint32_t i = 0; i < (1u << (2 * level)); ++i) {
        ASSERT_EQ(int(sm.state(gi, t, i)), int(g.micromaps.state(gi, t, i)))
            << "geometry " << gi << " triangle " << t << " micro-triangle " << i;
        ++checked;
      }
    }
    EXPECT_EQ(somm.geometries[gi].format, g.geometries[gi].format) << gi;
    EXPECT_EQ(somm.geometries[gi].cutoff, g.geometries[gi].cutoff) << gi;
    EXPECT_EQ(somm.geometries[gi].sampler, g.geometries[gi].sampler) << gi;
    bool usesRecords = false;
    for (uint32_t t = 0; t < n; ++t) usesRecords = usesRecords || bi[t] >= 0;
    if (usesRecords) {  // without records the glTF has no levels (the .somm keeps the bake's)
      EXPECT_EQ(somm.geometries[gi].minLevel, g.geometries[gi].minLevel) << gi;
      EXPECT_EQ(somm.geometries[gi].maxLevel, g.geometries[gi].maxLevel) << gi;
    }
    if (gltfInput) {
      EXPECT_EQ(somm.geometries[gi].name, g.geometries[gi].name) << gi;
    }
  }
  // The default bake's scene-wide array is stored as it is: same records, data and index buffers.
  ASSERT_EQ(sm.arrays.size(), g.micromaps.arrays.size());
  for (size_t k = 0; k < sm.arrays.size(); ++k) {
    if (sm.arrays[k].descriptors.empty()) continue;  // written with one unused record
    EXPECT_EQ(sm.arrays[k].descriptors, g.micromaps.arrays[k].descriptors) << k;
    EXPECT_EQ(sm.arrays[k].data, g.micromaps.arrays[k].data) << k;
    EXPECT_EQ(sm.arrays[k].indices, g.micromaps.arrays[k].indices) << k;
  }
  EXPECT_GT(checked, 0u);
}

// Bakes `scene` to .somm and to .glb and .gltf with the same options and compares them.
void roundTrip(const std::string& scene, const std::string& opts = "") {
  TempDir d;
  auto r = runSomm("bake " + shellQuote(scene) + " -o " + shellQuote(d / "a.somm") + " " + opts);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto somm = somm::readSommFile(d / "a.somm");
  ASSERT_TRUE(somm.ok()) << somm.error().message;
  fs::create_directories(d / "sub");
  for (const std::string& out : {d / "a.glb", d / "sub/a.gltf"}) {
    r = runSomm("bake " + shellQuote(scene) + " -o " + shellQuote(out) + " " + opts);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto g = somm::readGltfMicromaps(out);
    ASSERT_TRUE(g.ok()) << g.error().message;
    ASSERT_TRUE(g->present);
    expectSameStates(*somm, g->value, somm::isGltfPath(scene));
    // The scene in the output is the input scene: same geometry, loadable, same numbering.
    auto in = somm::loadScene(scene), back = somm::loadScene(out);
    ASSERT_TRUE(in.ok() && back.ok()) << (back.ok() ? "" : back.error().message);
    ASSERT_EQ(in->geometries.size(), back->geometries.size());
    for (size_t gi = 0; gi < in->geometries.size(); ++gi) {
      EXPECT_EQ(in->geometries[gi].indices, back->geometries[gi].indices) << gi;
      EXPECT_EQ(in->geometries[gi].positions, back->geometries[gi].positions) << gi;
      EXPECT_EQ(in->geometries[gi].uvs, back->geometries[gi].uvs) << gi;
    }
    // `somm info` reads it and the commands agree with the .somm.
    r = runSomm("info " + shellQuote(out));
    EXPECT_EQ(r.exitCode, 0) << r.err;
    if (havePython()) {
      std::string msg;
      EXPECT_EQ(runValidator("--strict " + shellQuote(out), &msg), 0) << msg;
    }
  }
}

TEST(GltfMicromap, OakRoundTripEqualsSommBake) {
  roundTrip(kData + "/oak-tree/oaktree.gltf");
}

TEST(GltfMicromap, AlphaBlendModeTestRoundTrip) {
  roundTrip(kData + "/alpha-blend-mode-test/AlphaBlendModeTest.gltf", "--level 5");
  roundTrip(kData + "/alpha-blend-mode-test/AlphaBlendModeTest.gltf",
            "--format 2 --blend-as-mask --cutoff 0.3");
}

TEST(GltfMicromap, AdaptiveLevelsRoundTrip) {
  roundTrip(kData + "/oak-tree/oaktree.gltf", "--max-level 8 --texels-per-microtri 2");
}

// A small OBJ with an alpha-masked texture, written here.
std::string writeObj(const TempDir& d) {
  auto disc = somm::makeDiscTexture(64);
  std::string pgm = "P5 64 64 255\n";
  // PNG would need an encoder: a binary PGM is read by stb_image too.
  for (float a : disc.alpha) pgm.push_back(char(uint8_t(a * 255.0f + 0.5f)));
  writeFile(d / "mask.pgm", pgm);
  writeFile(d / "quad.mtl", "newmtl leaf\nKd 0.2 0.8 0.2\nmap_d mask.pgm\n");
  writeFile(d / "quad.obj",
            "mtllib quad.mtl\no card\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
            "usemtl leaf\nf 1/1 2/2 3/3 4/4\n");
  return d / "quad.obj";
}

TEST(GltfMicromap, ObjBecomesGltfWithMaskMaterials) {
  TempDir d;
  const std::string obj = writeObj(d);
  auto scene = somm::loadScene(obj);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  roundTrip(obj);
  roundTrip(obj, "--cutoff 0.25 --filter nearest");
  auto r = runSomm("bake " + shellQuote(obj) + " -o " + shellQuote(d / "q.glb") + " --cutoff 0.25");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto back = somm::loadScene(d / "q.glb");
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->materials.size(), 1u);
  EXPECT_EQ(back->materials[0].alphaMode, somm::AlphaMode::Mask);
  EXPECT_EQ(back->materials[0].alphaCutoff, 0.25f);  // the cutoff the micromaps were baked with
  ASSERT_TRUE(back->materials[0].alpha);             // the texture is embedded
}

// An OBJ baked to .glb keeps its look: each material's base colour texture is the OBJ's colour image with its
// alpha (not a white image holding the alpha alone), the two materials of the bundled Red Eclipse tree share one
// image (they name the same file), and the 8-bit alpha is stored in an 8-bit PNG that reads back exactly.
TEST(GltfMicromap, ObjColoursAndSharedImagesSurvive) {
  TempDir d;
  const std::string obj = kData + "/redeclipse-tree01/tree01.obj";
  auto r = runSomm("bake " + shellQuote(obj) + " -o " + shellQuote(d / "t.glb") + " --level 4");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto src = somm::loadScene(obj);
  auto back = somm::loadScene(d / "t.glb");
  ASSERT_TRUE(src.ok()) << src.error().message;
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(src->materials.size(), 2u);
  ASSERT_EQ(back->materials.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE(src->materials[i].name);
    const somm::Material &a = src->materials[i], &b = back->materials[i];
    ASSERT_TRUE(a.baseColor && b.baseColor && a.alpha && b.alpha);
    EXPECT_EQ(a.baseColor->width, b.baseColor->width);
    EXPECT_EQ(a.baseColor->rgba, b.baseColor->rgba);  // RGB and the alpha channel the material tests
    EXPECT_EQ(a.alpha->values(), b.alpha->values());
    EXPECT_EQ(b.alpha->storage, somm::AlphaStorage::UInt8);
  }
  const std::string bytes = readFile(d / "t.glb");
  ASSERT_GT(bytes.size(), 20u);
  uint32_t jlen = 0;
  std::memcpy(&jlen, bytes.data() + 12, 4);
  const json j = json::parse(bytes.substr(20, jlen));
  ASSERT_EQ(j["images"].size(), 1u);
  ASSERT_EQ(j["textures"].size(), 1u);
  EXPECT_EQ(j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"], 0);
  EXPECT_EQ(j["materials"][1]["pbrMetallicRoughness"]["baseColorTexture"]["index"], 0);
  // The PNG's IHDR: 8 bits per sample, RGBA.
  const json& view = j["bufferViews"][j["images"][0]["bufferView"].get<size_t>()];
  uint32_t binStart = 20 + jlen + 8;
  const std::string png = bytes.substr(binStart + view.value("byteOffset", size_t(0)), view["byteLength"]);
  ASSERT_GT(png.size(), 26u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  EXPECT_EQ(int(uint8_t(png[24])), 8);
  EXPECT_EQ(int(uint8_t(png[25])), 6);
}

TEST(GltfMicromap, RealSharedScenes) {
  const std::string dir = "/work/shared/assets/foliage/redeclipse/obj/";
  if (!fs::exists(dir + "tree07.obj")) GTEST_SKIP() << "../shared is absent";
  roundTrip(dir + "tree07.obj");
  roundTrip(dir + "hanging_greens02.obj", "--level 4");
}

TEST(GltfMicromap, SmallestIndexTypeAndBaseTriangle) {
  TempDir d;
  // 400 leaf cards: more than 252 distinct maps, so the leaves need 16-bit micromapIndices.
  somm::Scene s = somm::makeLeafCardScene(400, 7);
  ASSERT_TRUE(somm::writeGlb(s, d / "cards.glb").ok());
  auto r =
      runSomm("bake " + shellQuote(d / "cards.glb") + " -o " + shellQuote(d / "out.gltf") + " --level 4");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const json j = json::parse(readFile(d / "out.gltf"));
  const json& x = j["meshes"][0]["primitives"][0]["extensions"]["EXT_mesh_opacity_micromap"];
  auto g = somm::readGltfMicromaps(d / "out.gltf");
  ASSERT_TRUE(g.ok()) << g.error().message;
  const somm::OmmArray& a = g->value.micromaps.arrays[0];
  int32_t hi = -1, lo = INT32_MAX;
  for (int32_t v : a.indices)
    if (v >= 0) hi = std::max(hi, v), lo = std::min(lo, v);
  ASSERT_GT(hi - lo, 251);
  ASSERT_TRUE(x.contains("micromapIndices"));
  const int expected = hi - lo <= 0xFFFB ? 5123 : 5125;
  EXPECT_EQ(j["accessors"][x["micromapIndices"].get<size_t>()]["componentType"].get<int>(), expected);
  EXPECT_EQ(x.value("micromapBaseTriangle", 0), lo);
  EXPECT_FALSE(j.contains("extensionsRequired"));
  // Oak: both primitives fit in bytes (leaves: 6 maps; bark: special indices only).
  r = runSomm("bake " + shellQuote(kData + "/oak-tree/oaktree.gltf") + " -o " + shellQuote(d / "oak.gltf"));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const json o = json::parse(readFile(d / "oak.gltf"));
  for (const json& m : o["meshes"])
    for (const json& p : m["primitives"]) {
      const json& e = p["extensions"]["EXT_mesh_opacity_micromap"];
      if (e.contains("micromapIndices")) {
        EXPECT_EQ(o["accessors"][e["micromapIndices"].get<size_t>()]["componentType"].get<int>(), 5121);
      }
    }
  EXPECT_EQ(o["extensions"]["EXT_mesh_opacity_micromap"]["micromaps"].size(), 1u);  // one scene-wide array
}

// ---- the draft's example, written by hand ----

std::string base64(const std::vector<uint8_t>& b) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string s;
  for (size_t i = 0; i < b.size(); i += 3) {
    uint32_t v = uint32_t(b[i]) << 16 | (i + 1 < b.size() ? uint32_t(b[i + 1]) << 8 : 0) |
                 (i + 2 < b.size() ? b[i + 2] : 0);
    s += k[v >> 18 & 63];
    s += k[v >> 12 & 63];
    s += i + 1 < b.size() ? k[v >> 6 & 63] : '=';
    s += i + 2 < b.size() ? k[v & 63] : '=';
  }
  return s;
}

template <class T>
void put(std::vector<uint8_t>& b, T v) {
  uint8_t x[sizeof(T)];
  std::memcpy(x, &v, sizeof(T));
  b.insert(b.end(), x, x + sizeof(T));
}

// Two primitives of one mesh sharing micromap 0 (2 records: level 1 4-state at offset 0, level 0 2-state at 1):
//  primitive 0: 2 triangles, micromapIndices UNSIGNED_BYTE [0, 254 (= -2, opaque)];
//  primitive 1: 1 triangle, no micromapIndices, micromapBaseTriangle 1 → record 1.
// bufferViews: 0 data, 1 triangles, 2 positions, 3 indices u8, 4 int16 values [-2, 0] (for the SHORT variant).
json draftExample() {
  std::vector<uint8_t> b;
  b.push_back(0xE4);  // level 1, states 0, 1, 2, 3
  b.push_back(0x01);  // level 0, 2-state: opaque
  while (b.size() % 4) b.push_back(0);
  const size_t tri = b.size();
  put<uint32_t>(b, 0), put<uint16_t>(b, 1), put<uint16_t>(b, 2);
  put<uint32_t>(b, 1), put<uint16_t>(b, 0), put<uint16_t>(b, 1);
  const size_t pos = b.size();
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 1.f, 1.f, 0.f}) put<float>(b, f);
  const size_t idx = b.size();
  b.push_back(0), b.push_back(254);  // micromapIndices of primitive 0: record 0, special -2
  b.push_back(0), b.push_back(0);
  const size_t sh = b.size();
  put<int16_t>(b, -2), put<int16_t>(b, 0);  // the same as SHORT, -2 stored signed
  const size_t tris = b.size();
  for (uint8_t v : {0, 1, 2, 1, 3, 2, 0, 1, 2}) b.push_back(v);  // primitive 0: 2 triangles; primitive 1: 1
  json j = json::parse(R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["EXT_mesh_opacity_micromap"],
    "extensions": {"EXT_mesh_opacity_micromap": {"micromaps": [
      {"data": 0, "triangles": 1, "usageCounts": [1, 1], "usageLevels": [1, 0], "usageFormats": [2, 1]}]}},
    "meshes": [{"primitives": [
      {"attributes": {"POSITION": 0}, "indices": 1, "mode": 4,
       "extensions": {"EXT_mesh_opacity_micromap": {"micromap": 0, "micromapIndices": 2}}},
      {"attributes": {"POSITION": 0}, "indices": 3,
       "extensions": {"EXT_mesh_opacity_micromap": {"micromap": 0, "micromapBaseTriangle": 1}}}]}],
    "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0
  })");
  j["buffers"] = {{{"byteLength", b.size()}, {"uri", "data:application/octet-stream;base64," + base64(b)}}};
  j["bufferViews"] = {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 2}},
                      {{"buffer", 0}, {"byteOffset", tri}, {"byteLength", 16}},
                      {{"buffer", 0}, {"byteOffset", pos}, {"byteLength", 48}},
                      {{"buffer", 0}, {"byteOffset", idx}, {"byteLength", 4}},
                      {{"buffer", 0}, {"byteOffset", sh}, {"byteLength", 4}},
                      {{"buffer", 0}, {"byteOffset", tris}, {"byteLength", 9}}};
  j["accessors"] = {
      {{"bufferView", 2},
       {"componentType", 5126},
       {"count", 4},
       {"type", "VEC3"},
       {"min", {0, 0, 0}},
       {"max", {1, 1, 0}}},
      {{"bufferView", 5}, {"componentType", 5121}, {"count", 6}, {"type", "SCALAR"}},
      {{"bufferView", 3}, {"componentType", 5121}, {"count", 2}, {"type", "SCALAR"}},
      {{"bufferView", 5}, {"byteOffset", 6}, {"componentType", 5121}, {"count", 3}, {"type", "SCALAR"}}};
  return j;
}

somm::Result<somm::GltfMicromapsRead> readJson(const json& j) {
  const std::string s = j.dump();
  return somm::parseGltfMicromaps(std::vector<uint8_t>(s.begin(), s.end()), false, "example.gltf");
}

TEST(GltfMicromap, DraftExampleReadsExactly) {
  auto r = readJson(draftExample());
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_TRUE(r->present);
  const somm::SceneMicromaps& m = r->value.micromaps;
  ASSERT_EQ(m.geometries.size(), 2u);
  ASSERT_EQ(m.geometries[0].triangleCount, 2u);
  ASSERT_EQ(m.geometries[1].triangleCount, 1u);
  using S = somm::State;
  EXPECT_EQ(m.state(0, 0, 0), S::Transparent);
  EXPECT_EQ(m.state(0, 0, 1), S::Opaque);
  EXPECT_EQ(m.state(0, 0, 2), S::UnknownTransparent);
  EXPECT_EQ(m.state(0, 0, 3), S::UnknownOpaque);
  EXPECT_EQ(m.indices(0)[1], -2);  // 254 in UNSIGNED_BYTE
  EXPECT_EQ(m.state(0, 1, 0), S::Opaque);
  EXPECT_EQ(m.indices(1)[0], 1);  // identity lookup + micromapBaseTriangle 1
  EXPECT_EQ(m.state(1, 0, 0), S::Opaque);
  EXPECT_EQ(r->value.geometries[0].format, somm::Format::FourState);
  EXPECT_EQ(r->value.geometries[1].format, somm::Format::TwoState);
  EXPECT_EQ(r->value.geometries[0].maxLevel, 1u);
  ASSERT_EQ(m.arrays[0].histogram.size(), 2u);
  // Signed SHORT with -2 stored directly.
  json j = draftExample();
  j["accessors"][2]["componentType"] = 5122;
  j["accessors"][2]["bufferView"] = 4;
  auto s = readJson(j);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->value.micromaps.indices(0)[0], -2);
  EXPECT_EQ(s->value.micromaps.indices(0)[1], 0);
  // A file without the extension: not present, no error.
  json plain = draftExample();
  plain.erase("extensions");
  plain.erase("extensionsUsed");
  for (json& p : plain["meshes"][0]["primitives"]) p.erase("extensions");
  auto n = readJson(plain);
  ASSERT_TRUE(n.ok()) << n.error().message;
  EXPECT_FALSE(n->present);
  if (havePython()) {
    TempDir d;
    writeFile(d / "ex.gltf", draftExample().dump());
    writeFile(d / "sh.gltf", j.dump());
    std::string msg;
    EXPECT_EQ(runValidator("--strict " + shellQuote(d / "ex.gltf") + " " + shellQuote(d / "sh.gltf"), &msg),
              0)
        << msg;
  }
}

// Overwrites bytes of bufferView `view` (at byte `at` of it) in the example's data URI buffer.
json withViewBytes(json j, size_t view, size_t at, std::vector<uint8_t> bytes) {
  const std::string uri = j["buffers"][0]["uri"];
  const std::string enc = uri.substr(uri.find(',') + 1);
  std::vector<uint8_t> b;
  uint32_t acc = 0;
  int bits = 0;
  const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  for (char c : enc) {
    if (c == '=') break;
    acc = acc << 6 | uint32_t(std::strchr(k, c) - k);
    bits += 6;
    if (bits >= 8) bits -= 8, b.push_back(uint8_t(acc >> bits));
  }
  const size_t off = j["bufferViews"][view]["byteOffset"];
  for (size_t i = 0; i < bytes.size(); ++i) b[off + at + i] = bytes[i];
  j["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(b);
  return j;
}
json withRecordBytes(json j, size_t r, size_t at, std::vector<uint8_t> bytes) {
  return withViewBytes(std::move(j), 1, 8 * r + at, std::move(bytes));
}

TEST(GltfMicromap, EveryMustViolationIsRejected) {
  struct Case {
    const char* rule;
    std::function<void(json&)> edit;
    const char* message;
  };
  const json ex = draftExample();
  auto root = [](json& j) -> json& { return j["extensions"]["EXT_mesh_opacity_micromap"]["micromaps"][0]; };
  auto prim = [](json& j, int p) -> json& {
    return j["meshes"][0]["primitives"][p]["extensions"]["EXT_mesh_opacity_micromap"];
  };
  const std::vector<Case> cases = {
      {"usage arrays same length", [&](json& j) { root(j)["usageLevels"] = {1}; },
       "MUST have the same length"},
      {"usageCounts >= 1", [&](json& j) { root(j)["usageCounts"][0] = 0; }, "MUST be >= 1"},
      {"usageLevels in [0,12]", [&](json& j) { root(j)["usageLevels"][0] = 13; },
       "usageLevels[0] = 13: MUST be in [0, 12]"},
      {"usageFormats 1|2", [&](json& j) { root(j)["usageFormats"][0] = 3; },
       "usageFormats[0] = 3: MUST be 1 or 2"},
      {"usage sums match records", [&](json& j) { root(j)["usageCounts"][0] = 2; }, "the sums MUST be equal"},
      {"usage pair matches records", [&](json& j) { root(j)["usageLevels"][0] = 2; },
       "the sums MUST be equal"},
      {"data required", [&](json& j) { root(j).erase("data"); }, "data is required"},
      {"triangles required", [&](json& j) { root(j).erase("triangles"); }, "triangles is required"},
      {"usageCounts required", [&](json& j) { root(j).erase("usageCounts"); }, "usageCounts is required"},
      {"data a bufferView", [&](json& j) { root(j)["data"] = 99; }, "bufferView 99 does not exist"},
      {"data no byteStride", [&](json& j) { j["bufferViews"][0]["byteStride"] = 4; },
       "data bufferView 0 MUST NOT define byteStride"},
      {"triangles no byteStride", [&](json& j) { j["bufferViews"][1]["byteStride"] = 8; },
       "triangles bufferView 1 MUST NOT define byteStride"},
      {"triangles multiple of 8", [&](json& j) { j["bufferViews"][1]["byteLength"] = 12; },
       "MUST be a multiple of 8"},
      {"record level <= 12",
       [&](json& j) {
         j = withRecordBytes(j, 0, 4, {13, 0});
       },
       "subdivisionLevel 13 MUST be in [0, 12]"},
      {"record format 1|2",
       [&](json& j) {
         j = withRecordBytes(j, 1, 6, {3, 0});
       },
       "format 3 MUST be 1 or 2"},
      {"region inside data",
       [&](json& j) {
         j = withRecordBytes(j, 1, 0, {2, 0, 0, 0});
       },
       "MUST lie within the data bufferView"},
      {"regions do not overlap",
       [&](json& j) {
         j = withRecordBytes(j, 1, 0, {0, 0, 0, 0});
       },
       "overlap (MUST NOT overlap)"},
      {"mode TRIANGLES", [&](json& j) { j["meshes"][0]["primitives"][0]["mode"] = 0; },
       "(MUST be 4, TRIANGLES)"},
      {"micromap required", [&](json& j) { prim(j, 0).erase("micromap"); }, "micromap is required"},
      {"micromap index valid", [&](json& j) { prim(j, 0)["micromap"] = 1; },
       "MUST be an index into the root micromaps"},
      {"micromapBaseTriangle >= 0", [&](json& j) { prim(j, 1)["micromapBaseTriangle"] = -1; },
       "micromapBaseTriangle MUST be an integer >= 0"},
      {"index + base < records", [&](json& j) { prim(j, 1)["micromapBaseTriangle"] = 2; },
       "MUST be less than the 2 triangle records"},
      // Numbers beyond int64_t as JSON floats (the range is checked before the conversion: fuzz_gltf found 8.9e25).
      {"base triangle beyond int64", [&](json& j) { prim(j, 1)["micromapBaseTriangle"] = 8.9e25; },
       "micromapBaseTriangle MUST be an integer >= 0"},
      {"byteLength beyond int64", [&](json& j) { j["buffers"][0]["byteLength"] = -8.9e25; },
       "byteLength MUST be an integer >= 1"},
      {"micromapIndices an accessor", [&](json& j) { prim(j, 0)["micromapIndices"] = 40; },
       "micromapIndices MUST be a valid accessor index"},
      {"micromapIndices SCALAR", [&](json& j) { j["accessors"][2]["type"] = "VEC2"; }, "type MUST be SCALAR"},
      {"micromapIndices componentType", [&](json& j) { j["accessors"][2]["componentType"] = 5120; },
       "componentType 5120 MUST be"},
      {"micromapIndices not normalized", [&](json& j) { j["accessors"][2]["normalized"] = true; },
       "normalized MUST NOT be true"},
      {"micromapIndices count", [&](json& j) { j["accessors"][2]["count"] = 1; },
       "MUST equal the primitive's triangle count 2"},
      {"micromapIndices no byteStride", [&](json& j) { j["bufferViews"][3]["byteStride"] = 4; },
       "MUST NOT define byteStride"},
      {"signed >= -4",
       [&](json& j) {
         j["accessors"][2]["componentType"] = 5122;
         j["accessors"][2]["bufferView"] = 4;
         j = withViewBytes(j, 4, 0, {0xFB, 0xFF});  // -5
       },
       "MUST be >= -4"},
      {"extensionsUsed", [&](json& j) { j.erase("extensionsUsed"); }, "MUST be listed"},
      {"micromaps an array", [&](json& j) { j["extensions"]["EXT_mesh_opacity_micromap"]["micromaps"] = 3; },
       "micromaps is required and MUST be an array"},
  };
  TempDir d;
  std::string files;
  int k = 0;
  for (const Case& c : cases) {
    json j = ex;
    c.edit(j);
    auto r = readJson(j);
    ASSERT_FALSE(r.ok()) << c.rule << ": accepted";
    const std::string& msg = r.error().message;
    EXPECT_NE(msg.find(c.message), std::string::npos) << c.rule << ": " << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    EXPECT_EQ(msg.rfind("example.gltf: ", 0), 0u) << msg;
    std::string name = std::to_string(k++);
    name += ".gltf";
    const std::string f = d / name;
    writeFile(f, j.dump());
    // The commands reject it with the same one-line message.
    auto cli = runSomm("info " + shellQuote(f));
    EXPECT_NE(cli.exitCode, 0) << c.rule;
    EXPECT_NE(cli.err.find(c.message), std::string::npos) << c.rule << ": " << cli.err;
    if (havePython()) {
      std::string out;
      EXPECT_NE(runValidator(shellQuote(f), &out), 0) << c.rule << ": the independent validator accepted it";
    }
  }
}

// ---- preservation of a glTF input ----

TEST(GltfMicromap, InputGltfIsPreserved) {
  TempDir d;
  for (const char* f : {"oaktree.bin", "oakbark.jpg", "oakleaf_light.png"})
    fs::copy_file(kData + "/oak-tree/" + f, d / f);
  json in = json::parse(readFile(kData + "/oak-tree/oaktree.gltf"));
  in["extensionsUsed"].push_back("EXT_somm_test_unknown");
  in["extensions"]["EXT_somm_test_unknown"] = {{"answer", 42}};
  in["nodes"][0]["extras"] = {{"keep", "me"}};
  in["materials"][0]["extensions"]["EXT_somm_test_unknown"] = {{"x", {1, 2, 3}}};
  in["extras"] = {{"root", true}};
  // A stale micromap extension in extensionsRequired is removed (never required).
  in["extensionsRequired"] = {"EXT_mesh_opacity_micromap"};
  in["extensionsUsed"].push_back("EXT_mesh_opacity_micromap");
  writeFile(d / "in.gltf", in.dump(2));
  in.erase("extensionsRequired");
  fs::create_directories(d / "out");
  for (const std::string& out : {d / "out/x.glb", d / "out/x.gltf"}) {
    auto r = runSomm("bake " + shellQuote(d / "in.gltf") + " -o " + shellQuote(out));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    json o;
    if (out.size() > 4 && out.substr(out.size() - 4) == ".glb") {
      const std::string bytes = readFile(out);
      uint32_t len;
      std::memcpy(&len, bytes.data() + 12, 4);
      o = json::parse(bytes.substr(20, len));
    } else {
      o = json::parse(readFile(out));
      EXPECT_TRUE(fs::exists(d / "out/x.bin"));
    }
    for (const char* key :
         {"nodes", "materials", "samplers", "textures", "scenes", "scene", "asset", "extras"})
      EXPECT_EQ(o[key], in[key]) << key;
    EXPECT_EQ(o["extensions"]["EXT_somm_test_unknown"], in["extensions"]["EXT_somm_test_unknown"]);
    EXPECT_FALSE(o.contains("extensionsRequired"));
    // Old buffer views and accessors are a prefix of the new ones; meshes only gain the extension.
    for (size_t i = 0; i < in["bufferViews"].size(); ++i)
      EXPECT_EQ(o["bufferViews"][i], in["bufferViews"][i]) << i;
    for (size_t i = 0; i < in["accessors"].size(); ++i) EXPECT_EQ(o["accessors"][i], in["accessors"][i]) << i;
    json meshes = o["meshes"];
    for (json& m : meshes)
      for (json& p : m["primitives"]) p.erase("extensions");
    EXPECT_EQ(meshes, in["meshes"]);
    // Images are found from the new place.
    for (const json& im : o["images"]) EXPECT_EQ(im["uri"].get<std::string>().rfind("../", 0), 0u) << im;
    size_t used = 0;
    for (const json& e : o["extensionsUsed"]) used += e == "EXT_mesh_opacity_micromap";
    EXPECT_EQ(used, 1u);
    auto back = somm::loadScene(out);
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_TRUE(back->materials[0].alpha);
  }
  // The .glb keeps the input's buffer bytes at their offsets.
  const std::string bytes = readFile(d / "out/x.glb");
  uint32_t jlen;
  std::memcpy(&jlen, bytes.data() + 12, 4);
  const std::string bin = bytes.substr(20 + jlen + 8);
  const std::string orig = readFile(kData + "/oak-tree/oaktree.bin");
  EXPECT_EQ(bin.substr(0, orig.size()), orig);
}

TEST(GltfMicromap, RebakeReplacesTheExtension) {
  TempDir d;
  auto r = runSomm("bake " + shellQuote(kData + "/oak-tree/oaktree.gltf") + " -o " + shellQuote(d / "a.glb"));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = runSomm("bake " + shellQuote(d / "a.glb") + " -o " + shellQuote(d / "b.glb") + " --level 3");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto g = somm::readGltfMicromaps(d / "b.glb");
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->value.geometries[0].maxLevel, 3u);
  const std::string bytes = readFile(d / "b.glb");
  uint32_t jlen;
  std::memcpy(&jlen, bytes.data() + 12, 4);
  const json o = json::parse(bytes.substr(20, jlen));
  EXPECT_EQ(o["extensions"]["EXT_mesh_opacity_micromap"]["micromaps"].size(), 1u);
}

TEST(GltfMicromap, UnwritableOutputLeavesNothing) {
  TempDir d;
  auto r = runSomm("bake " + shellQuote(kData + "/oak-tree/oaktree.gltf") + " -o " +
                   shellQuote(d / "no/dir/x.gltf"));
  EXPECT_NE(r.exitCode, 0);
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
  EXPECT_FALSE(fs::exists(d / "no"));
}

TEST(GltfMicromap, RenderUsesEmbeddedMicromaps) {
  TempDir d;
  auto r =
      runSomm("bake " + shellQuote(kData + "/oak-tree/oaktree.gltf") + " -o " + shellQuote(d / "oak.glb"));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = runSomm("render " + shellQuote(d / "oak.glb") + " --method omm4-flat --width 96 --height 72 -o " +
              shellQuote(d / "omm.png") + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_NE(j["micromaps"].get<std::string>().find("EXT_mesh_opacity_micromap"), std::string::npos) << r.out;
  r = runSomm("render " + shellQuote(d / "oak.glb") + " --method texture --width 96 --height 72 -o " +
              shellQuote(d / "tex.png"));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(readFile(d / "omm.png"), readFile(d / "tex.png"));  // 4-state micromaps are exact
  // query reads the glTF like the .somm.
  r = runSomm("bake " + shellQuote(kData + "/oak-tree/oaktree.gltf") + " -o " + shellQuote(d / "oak.somm"));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto a = runSomm("query " + shellQuote(d / "oak.glb") + " -g 0 -t 5");
  auto b = runSomm("query " + shellQuote(d / "oak.somm") + " -g 0 -t 5");
  EXPECT_EQ(a.exitCode, b.exitCode);
  EXPECT_EQ(a.out, b.out);
}

}  // namespace

namespace {

// Hostile counts: a tiny file cannot make the reader allocate for billions of triangles.
TEST(GltfMicromap, TriangleCountsAreBoundedByTheFile) {
  json j = draftExample();
  j["accessors"][1] = {
      {"componentType", 5125}, {"count", 3000000000LL}, {"type", "SCALAR"}};  // no buffer view
  auto r = readJson(j);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("too many elements"), std::string::npos) << r.error().message;
  j = draftExample();
  j["accessors"][1]["count"] = 1000;  // more than its 9-byte buffer view holds
  r = readJson(j);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("do not fit its buffer view"), std::string::npos) << r.error().message;
  // 100000 primitives sharing one accessor of 2^20 zero indices: 3.5e10 triangles from a few MB of JSON.
  j = draftExample();
  j["accessors"][1] = {{"componentType", 5121}, {"count", 1 << 20}, {"type", "SCALAR"}};
  json p = j["meshes"][0]["primitives"][0];
  p.erase("extensions");
  for (int i = 0; i < 2000; ++i) j["meshes"][0]["primitives"].push_back(p);
  r = readJson(j);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, somm::ErrorCode::LimitExceeded) << r.error().message;
}

}  // namespace
