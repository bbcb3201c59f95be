// SPDX-License-Identifier: MIT
// Bad-input suite, part 3: hostile OBJ/MTL, glTF/GLB and images through the scene loader (and `somm bake`
// when this build has it). Every case: the documented error code, one line naming the file and the problem,
// no crash, bounded memory; for the CLI also exit code 1 and no output file (an existing one untouched).
#if __has_include("somm/scene.h") && __has_include("scene/image_io.h")
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "hardening_util.h"
#include "scene/image_io.h"
#include "somm/scene.h"

namespace somm {
namespace {

using testing::quote;
using testing::TempDir;

// A real PNG (the bundled oak leaf texture).
std::string tinyPng() {
  const std::string p = std::string(SOMM_DATA_DIR) + "/oak-tree/oakleaf_light.png";
  return testing::readFile(p);
}

long peakRssKiB() {
  struct rusage ru {};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss;
}

// loadScene must fail with `code` and a one-line message starting with the path and containing every needle.
void expectLoadFails(const std::string& path, ErrorCode code, std::initializer_list<std::string> needles) {
  SCOPED_TRACE(path);
  const long before = peakRssKiB();
  const Result<Scene> s = loadScene(path);
  ASSERT_FALSE(s.ok()) << "loaded";
  EXPECT_EQ(int(s.error().code), int(code)) << s.error().message;
  const std::string& m = s.error().message;
  EXPECT_EQ(m.rfind(path + ": ", 0), 0u) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  for (const std::string& n : needles)
    EXPECT_NE(m.find(n), std::string::npos) << "missing '" << n << "' in: " << m;
  EXPECT_LT(peakRssKiB() - before, (testing::kSanitized ? 400 : 160) * 1024) << "peak RSS grew (KiB)";
}

const char* kQuadObj =
    "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl leaf\nf 1/1 "
    "2/2 3/3 "
    "4/4\n";

TEST(BadScene, ObjIndicesOutOfRange) {
  TempDir d;
  const std::string p = d.file("a.obj");
  testing::writeFile(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  expectLoadFails(p, ErrorCode::CorruptFile, {"face 1", "3 vertices"});
  testing::writeFile(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/5 3/1\n");
  expectLoadFails(p, ErrorCode::CorruptFile, {"face 1", "texture coordinate"});
  testing::writeFile(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -7\n");
  expectLoadFails(p, ErrorCode::CorruptFile, {"vertex"});
}

TEST(BadScene, ObjMissingAndBrokenTextures) {
  TempDir d;
  const std::string p = d.file("a.obj");
  testing::writeFile(p, kQuadObj);
  testing::writeFile(d.file("m.mtl"), "newmtl leaf\nmap_d missing.png\n");
  expectLoadFails(p, ErrorCode::IoError, {"leaf", "missing.png"});
  const std::string png = tinyPng();
  testing::writeFile(d.file("cut.png"), png.substr(0, png.size() / 2));
  testing::writeFile(d.file("m.mtl"), "newmtl leaf\nmap_d cut.png\n");
  expectLoadFails(p, ErrorCode::CorruptFile, {"leaf", "cut.png"});
  // Found by fuzz_obj: a directory as texture threw out of the loader (std::terminate); a device never ends.
  for (const char* dirLike : {"/", ".", "/dev/zero"}) {
    testing::writeFile(d.file("m.mtl"), std::string("newmtl leaf\nmap_Kd ") + dirLike + "\n");
    expectLoadFails(p, ErrorCode::IoError, {"leaf"});
  }
  testing::writeFile(d.file("text.png"), "this is not an image");
  testing::writeFile(d.file("m.mtl"), "newmtl leaf\nmap_Kd text.png\n");
  expectLoadFails(p, ErrorCode::CorruptFile, {"leaf", "text.png"});
}

TEST(BadScene, ObjNanInfAndNonTriangles) {
  TempDir d;
  const std::string p = d.file("a.obj");
  // NaN/inf positions and UVs load (the baker classifies such triangles unknown); lines and points are
  // skipped.
  testing::writeFile(
      p,
      "v nan 0 0\nv inf 1 0\nv 0 -inf 1e40\nvt nan inf\nvt -inf 0\nvt 1e39 1\nf 1/1 2/2 3/3\nl 1 2\np "
      "3\nf 1 2\n");
  const Result<Scene> s = loadScene(p);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(s->geometries.size(), 1u);
  EXPECT_EQ(s->geometries[0].triangleCount(), 1u);
  EXPECT_EQ(s->geometries[0].positions.size(), 9u);
  EXPECT_EQ(s->geometries[0].uvs.size(), 6u);
}

// A minimal glTF around one triangle, with the buffer as a data URI; `patch` edits the JSON text.
std::string gltf(const std::string& extra = "", const std::string& accessors = "") {
  // 3 positions (36 bytes) + 3 uvs (24 bytes) + 3 u16 indices (6 bytes) + 2 padding = 68 bytes, all zero but
  // the positions (1, 0, 0) and (0, 1, 0): base64 of that buffer.
  std::string buf(68, '\0');
  const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  std::memcpy(buf.data(), pos, 36);
  const uint16_t idx[3] = {0, 1, 2};
  std::memcpy(buf.data() + 60, idx, 6);
  static const char* b64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string enc;
  for (size_t i = 0; i < buf.size(); i += 3) {
    uint32_t v = uint32_t(uint8_t(buf[i])) << 16;
    if (i + 1 < buf.size()) v |= uint32_t(uint8_t(buf[i + 1])) << 8;
    if (i + 2 < buf.size()) v |= uint32_t(uint8_t(buf[i + 2]));
    enc += b64[(v >> 18) & 63];
    enc += b64[(v >> 12) & 63];
    enc += i + 1 < buf.size() ? b64[(v >> 6) & 63] : '=';
    enc += i + 2 < buf.size() ? b64[v & 63] : '=';
  }
  const std::string acc = accessors.empty()
                              ? R"([{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},
                                   {"bufferView":1,"componentType":5126,"count":3,"type":"VEC2"},
                                   {"bufferView":2,"componentType":5123,"count":3,"type":"SCALAR"}])"
                              : accessors;
  return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1},"indices":2,"material":0}]}],
    "materials":[{"alphaMode":"MASK","pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
    "textures":[{"source":0}],"images":[{"uri":"t.png"}],
    "buffers":[{"byteLength":68,"uri":"data:application/octet-stream;base64,)" +
         enc + R"("}],
    "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":24},
                   {"buffer":0,"byteOffset":60,"byteLength":6}],
    "accessors":)" +
         acc + extra + "}";
}

std::string replaceOnce(std::string s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

TEST(BadScene, GltfBaseCaseLoads) {
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  testing::writeFile(d.file("a.gltf"), gltf());
  const Result<Scene> s = loadScene(d.file("a.gltf"));
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->geometries.at(0).triangleCount(), 1u);
}

TEST(BadScene, GltfBrokenAccessorsAndViews) {
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  const std::string p = d.file("a.gltf");
  const std::string base = gltf();
  const struct {
    std::string json;
    ErrorCode code;
    std::string needle;
  } cases[] = {
      {replaceOnce(base, R"("count":3,"type":"VEC3")", R"("count":4,"type":"VEC3")"), ErrorCode::CorruptFile,
       "extend past the end"},
      {replaceOnce(base, R"("count":3,"type":"VEC3")", R"("count":3000000000,"type":"VEC3")"),
       ErrorCode::CorruptFile, "past the end"},
      {replaceOnce(base, R"("byteOffset":36,"byteLength":24)", R"("byteOffset":60,"byteLength":24)"),
       ErrorCode::CorruptFile, "past the end"},
      {replaceOnce(base, R"("byteOffset":60,"byteLength":6)", R"("byteOffset":4294967290,"byteLength":6)"),
       ErrorCode::CorruptFile, "past the end"},
      {replaceOnce(base, R"("POSITION":0)", R"("POSITION":7)"), ErrorCode::CorruptFile, "accessor 7"},
      {replaceOnce(base, R"({"bufferView":0,)", R"({"bufferView":9,)"), ErrorCode::CorruptFile,
       "buffer view 9"},
      {replaceOnce(base, R"("componentType":5126,"count":3,"type":"VEC3")",
                   R"("componentType":5126,"count":3,"type":"VEC2")"),
       ErrorCode::CorruptFile, "wrong accessor type"},
      {replaceOnce(base, R"("componentType":5123)", R"("componentType":5122)"), ErrorCode::CorruptFile,
       "must be unsigned"},
      {replaceOnce(base, R"("uri":"t.png")", R"("uri":"missing.png")"), ErrorCode::IoError, "missing.png"},
      {replaceOnce(base, R"("images":[{"uri":"t.png"}])", R"("images":[])"), ErrorCode::CorruptFile,
       "image 0"},
      // A zero-filled accessor (no buffer view) claiming 2^31 vertices: rejected before allocating.
      {replaceOnce(base, R"({"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"})",
                   R"({"componentType":5126,"count":2147483648,"type":"VEC3"})"),
       ErrorCode::LimitExceeded, "too many elements"},
      {"{\"asset\":{\"version\":\"2.0\"}, \"meshes\":[{]}", ErrorCode::CorruptFile, ""},
      {"", ErrorCode::CorruptFile, ""},
  };
  for (const auto& c : cases) {
    testing::writeFile(p, c.json);
    expectLoadFails(p, c.code, {c.needle});
  }
}

// Many primitives sharing one big accessor: the materialised scene is bounded by a multiple of the buffer
// bytes.
TEST(BadScene, GltfSharedAccessorAmplificationIsBounded) {
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  const size_t verts = 1 << 18;  // 3 MiB of positions in an external buffer
  testing::writeFile(d.file("b.bin"), std::string(verts * 12, '\0'));
  std::string prims;
  for (int i = 0; i < 4000; ++i) prims += std::string(i ? "," : "") + R"({"attributes":{"POSITION":0}})";
  const std::string json = R"({"asset":{"version":"2.0"},"meshes":[{"primitives":[)" + prims + R"(]}],
    "buffers":[{"byteLength":)" +
                           std::to_string(verts * 12) +
                           R"(,"uri":"b.bin"}],"bufferViews":[{"buffer":0,"byteLength":)" +
                           std::to_string(verts * 12) + R"(}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":)" +
                           std::to_string(verts) + R"(,"type":"VEC3"}]})";
  testing::writeFile(d.file("amp.gltf"), json);
  // Unbounded, this would materialise 4000 × 2^18 vertices (≈ 30 GB).
  expectLoadFails(d.file("amp.gltf"), ErrorCode::LimitExceeded, {"buffer bytes"});
}

TEST(BadScene, GlbTruncatedAndLying) {
  TempDir d;
  const std::string p = d.file("a.glb");
  const std::string json = gltf();
  std::string glb = "glTF";
  auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  std::string js = json + std::string((4 - json.size() % 4) % 4, ' ');
  glb += u32(2) + u32(uint32_t(12 + 8 + js.size())) + u32(uint32_t(js.size())) + u32(0x4E4F534A) + js;
  for (size_t cut : {size_t(3), size_t(11), size_t(19), glb.size() / 2, glb.size() - 1}) {
    testing::writeFile(p, glb.substr(0, cut));
    expectLoadFails(p, ErrorCode::CorruptFile, {});
  }
  std::string lying = glb;
  std::memcpy(lying.data() + 12, u32(0x7ffffff0u).data(), 4);  // JSON chunk length far past the end
  testing::writeFile(p, lying);
  expectLoadFails(p, ErrorCode::CorruptFile, {});
}

// Images that are truncated or claim huge sizes: refused before their pixels are allocated.
TEST(BadScene, ImagesTruncatedOrClaimingHugeSizes) {
  const std::string png = tinyPng();
  for (size_t cut : {size_t(0), size_t(8), size_t(20), size_t(33), png.size() / 2, png.size() - 12}) {
    const auto r = detail::decodeImage(reinterpret_cast<const uint8_t*>(png.data()), cut);
    EXPECT_FALSE(r.ok()) << "cut at " << cut;
  }
  // A valid 1x1 PNG header patched to claim 30000 x 30000 RGBA (3.6 G samples) or 16000 x 16000 (1 G
  // samples). stb_image itself refuses more than 2^30 bytes (30000, 16000); the loader's own bound refuses
  // the others, which stb would accept and allocate.
  for (uint32_t side : {30000u, 16000u, 12000u, 8192u}) {
    std::string huge = png;
    for (int i = 0; i < 4; ++i) {
      huge[16 + size_t(i)] = char(uint8_t(side >> (24 - 8 * i)));
      huge[20 + size_t(i)] = char(uint8_t(side >> (24 - 8 * i)));
    }
    const long before = peakRssKiB();
    const auto r = detail::decodeImage(reinterpret_cast<const uint8_t*>(huge.data()), huge.size());
    ASSERT_FALSE(r.ok()) << side;
    if (side < 16000) {
      EXPECT_EQ(int(r.error().code), int(ErrorCode::LimitExceeded)) << r.error().message;
    }
    EXPECT_LT(peakRssKiB() - before, 64 * 1024) << "peak RSS grew (KiB) for a " << side << "^2 claim";
  }
}

// Found by fuzz_image: a PNG chunk declaring 2 GB made stb_image allocate 2 GB before reading it; a JPEG
// Huffman table with more than 256 codes made the Debian stb_image write past its tables (heap buffer
// overflow).
TEST(BadScene, ImagesWithLyingChunksAndTables) {
  std::string png = tinyPng();
  const size_t idat = png.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  for (int i = 0; i < 4; ++i) png[idat - 4 + size_t(i)] = char(uint8_t(0x7ff00000u >> (24 - 8 * i)));
  const long before = peakRssKiB();
  auto r = detail::decodeImage(reinterpret_cast<const uint8_t*>(png.data()), png.size());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(int(r.error().code), int(ErrorCode::CorruptFile));
  EXPECT_NE(r.error().message.find("truncated PNG"), std::string::npos) << r.error().message;
  EXPECT_LT(peakRssKiB() - before, 64 * 1024);

  std::string jpg = testing::readFile(std::string(SOMM_DATA_DIR) + "/oak-tree/oakbark.jpg");
  ASSERT_TRUE(detail::decodeImage(reinterpret_cast<const uint8_t*>(jpg.data()), jpg.size()).ok());
  const size_t dht = jpg.find("\xff\xc4");
  ASSERT_NE(dht, std::string::npos);
  jpg[dht + 5] = char(0xff);  // the first two of the 16 code counts: 510 codes
  jpg[dht + 6] = char(0xff);
  r = detail::decodeImage(reinterpret_cast<const uint8_t*>(jpg.data()), jpg.size());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("Huffman table"), std::string::npos) << r.error().message;
  jpg = "\xff\xff\xff" + jpg;  // stb skips 0xFF fill bytes before SOI (found by fuzz_image)
  r = detail::decodeImage(reinterpret_cast<const uint8_t*>(jpg.data()), jpg.size());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("Huffman table"), std::string::npos) << r.error().message;
}

// Through the CLI: `somm bake` on every bad scene above fails with exit 1, writes nothing and keeps an
// existing output.
TEST(BadScene, BakeFailsCleanly) {
  if (!testing::hasCommand("bake")) GTEST_SKIP() << "this build has no `somm bake`";
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  testing::writeFile(d.file("idx.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  testing::writeFile(d.file("tex.obj"), kQuadObj);
  testing::writeFile(d.file("m.mtl"), "newmtl leaf\nmap_d missing.png\n");
  testing::writeFile(d.file("acc.gltf"),
                     replaceOnce(gltf(), R"("count":3,"type":"VEC3")", R"("count":4,"type":"VEC3")"));
  testing::writeFile(d.file("img.gltf"), replaceOnce(gltf(), R"("uri":"t.png")", R"("uri":"missing.png")"));
  testing::writeFile(d.file("empty.glb"), "");
  const std::string out = d.file("out.somm");
  testing::writeFile(out, "precious");
  for (const std::string scene :
       {"idx.obj", "tex.obj", "acc.gltf", "img.gltf", "empty.glb", "does-not-exist.gltf", "scene.fbx"}) {
    const auto before = testing::listDir(d.path().string());
    const auto r = testing::runGuarded("bake " + quote(d.file(scene)) + " -o " + quote(out) + " --level 3");
    testing::expectRejected(r, scene == "scene.fbx" ? r.exitCode : 1, {d.file(scene)}, "bake " + scene);
    EXPECT_EQ(testing::readFile(out), "precious") << scene;
    EXPECT_EQ(testing::listDir(d.path().string()), before) << scene << ": bake left files behind";
  }
}

// `somm bake` options out of range: usage errors (exit 2), nothing written, an existing output untouched.
TEST(BadScene, BakeOptionsOutOfRange) {
  if (!testing::hasCommand("bake")) GTEST_SKIP() << "this build has no `somm bake`";
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  testing::writeFile(d.file("good.gltf"), gltf());
  const std::string out = d.file("out.somm");
  testing::writeFile(out, "precious");
  for (const std::string opts :
       {"--level 13", "--level -1", "--max-level 13 --texels-per-microtri 4", "--format 3", "--cutoff nan",
        "--cutoff 1.5", "--cutoff -0.1", "--max-level 4 --texels-per-microtri nan",
        "--max-level 4 --texels-per-microtri -1", "--max-level 4 --texels-per-microtri inf",
        "--unknown-as maybe", "--filter cubic", "--level 4 --max-level 6 --texels-per-microtri 1",
        "--max-level 6", "--max-bytes -5", "--threads -1"}) {
    const auto before = testing::listDir(d.path().string());
    const auto r =
        testing::runGuarded("bake " + quote(d.file("good.gltf")) + " -o " + quote(out) + " " + opts);
    SCOPED_TRACE(opts);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_EQ(r.err.rfind("somm", 0), 0u) << r.err;
    EXPECT_EQ(r.err.find("Sanitizer"), std::string::npos) << r.err;
    EXPECT_EQ(testing::readFile(out), "precious");
    EXPECT_EQ(testing::listDir(d.path().string()), before);
  }
  // A good bake replaces the output atomically (the control case).
  const auto ok =
      testing::runGuarded("bake " + quote(d.file("good.gltf")) + " -o " + quote(out) + " --level 3");
  EXPECT_EQ(ok.exitCode, 0) << ok.err;
  EXPECT_NE(testing::readFile(out), "precious");
}

// `somm render` (ray tracing) reads scenes and .somm files and writes a PNG: bad inputs fail with exit 1 and
// leave no image; out-of-range options are usage errors.
TEST(BadScene, RenderFailsCleanly) {
  if (!testing::hasCommand("render")) GTEST_SKIP() << "this build has no `somm render`";
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  testing::writeFile(d.file("good.gltf"), gltf());
  testing::writeFile(d.file("acc.gltf"),
                     replaceOnce(gltf(), R"("count":3,"type":"VEC3")", R"("count":4,"type":"VEC3")"));
  testing::writeFile(d.file("bad.somm"), "SOMM\r\n\x1a\n but then garbage");
  const std::string out = d.file("out.png");
  testing::writeFile(out, "precious");
  const struct {
    std::string args;
    int code;
    std::string needle;
  } cases[] = {
      {quote(d.file("acc.gltf")), 1, d.file("acc.gltf")},
      {quote(d.file("missing.obj")), 1, d.file("missing.obj")},
      {quote(d.file("good.gltf")) + " --method omm4-flat --omm " + quote(d.file("bad.somm")), 1,
       d.file("bad.somm")},
      {quote(d.file("good.gltf")) + " --method no-such-method", 2, "no-such-method"},
      {quote(d.file("good.gltf")) + " --texels-per-microtri nan --max-level 4", 2, "--texels-per-microtri"},
      {quote(d.file("good.gltf")) + " --width 0", 2, "--width"},
      {quote(d.file("good.gltf")) + " --width 16385", 2, "--width"},
      {quote(d.file("good.gltf")) + " --spp 0", 2, "--spp"},
      {quote(d.file("good.gltf")) + " --cutoff 1.5", 2, "--cutoff"},
      {quote(d.file("good.gltf")) + " --cutoff nan", 2, "--cutoff"},
      {quote(d.file("good.gltf")) + " --level 13", 2, "--level"},
      {quote(d.file("good.gltf")) + " --filter cubic", 2, "--filter"},
  };
  for (const auto& c : cases) {
    const auto before = testing::listDir(d.path().string());
    const std::string size =
        c.args.find("--width") == std::string::npos ? " --width 8 --height 8" : " --height 8";
    const auto r = testing::runGuarded("render " + c.args + " -o " + quote(out) + size, "", 120);
    SCOPED_TRACE(c.args);
    EXPECT_EQ(r.exitCode, c.code) << r.err;
    EXPECT_EQ(r.err.rfind("somm", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.needle), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("Sanitizer"), std::string::npos) << r.err;
    EXPECT_EQ(testing::readFile(out), "precious");
    EXPECT_EQ(testing::listDir(d.path().string()), before) << "render left files behind";
  }
}

// ---- Round two (issue 12): the reproductions of the adversarial corpus ----

std::string glbOf(const std::string& json, uint32_t version = 2) {
  auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  std::string js = json + std::string((4 - json.size() % 4) % 4, ' ');
  return "glTF" + u32(version) + u32(uint32_t(12 + 8 + js.size())) + u32(uint32_t(js.size())) +
         u32(0x4E4F534A) + js;
}

// ~30,000 levels of nesting overflowed the stack inside tinygltf's JSON parser (a crash); now refused by a
// pre-scan of the bytes, for .gltf and .glb, naming the limit and the option.
TEST(BadSceneRound2, DeeplyNestedJson) {
  TempDir d;
  const size_t n = 30000;
  const std::string json =
      "{\"asset\":{\"version\":\"2.0\"},\"extras\":" + std::string(n, '[') + std::string(n, ']') + "}";
  testing::writeFile(d.file("d.gltf"), json);
  expectLoadFails(d.file("d.gltf"), ErrorCode::LimitExceeded, {"json-depth", "--limit json-depth="});
  testing::writeFile(d.file("d.glb"), glbOf(json));
  expectLoadFails(d.file("d.glb"), ErrorCode::LimitExceeded, {"json-depth"});
  // Brackets inside strings do not count; a normal file still loads.
  testing::writeFile(d.file("t.png"), tinyPng());
  testing::writeFile(d.file("s.gltf"),
                     replaceOnce(gltf(), R"("version":"2.0")",
                                 R"("version":"2.0","extras":")" + std::string(1000, '[') + "\""));
  EXPECT_TRUE(loadScene(d.file("s.gltf")).ok());
  const auto r = testing::runGuarded("scene-info " + quote(d.file("d.gltf")));
  testing::expectRejected(r, 1, {d.file("d.gltf"), "json-depth"}, "scene-info deep JSON");
}

// GLB container versions other than 2, asset.version 3.0, negative byte offsets: refused, not guessed.
TEST(BadSceneRound2, GltfVersionsAndNegativeOffsets) {
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  for (uint32_t v : {1u, 3u}) {
    testing::writeFile(d.file("v.glb"), glbOf(gltf(), v));
    expectLoadFails(d.file("v.glb"), ErrorCode::UnsupportedFormat, {"version " + std::to_string(v)});
  }
  testing::writeFile(d.file("v.gltf"), replaceOnce(gltf(), R"("version":"2.0")", R"("version":"3.0")"));
  expectLoadFails(d.file("v.gltf"), ErrorCode::UnsupportedFormat, {"asset.version '3.0'"});
  testing::writeFile(d.file("n.gltf"), replaceOnce(gltf(), R"("byteOffset":36,)", R"("byteOffset":-36,)"));
  expectLoadFails(d.file("n.gltf"), ErrorCode::CorruptFile, {"bufferViews[1].byteOffset", "negative"});
  testing::writeFile(d.file("n.gltf"),
                     replaceOnce(gltf(), R"("count":3,"type":"VEC2")", R"("count":-3,"type":"VEC2")"));
  expectLoadFails(d.file("n.gltf"), ErrorCode::CorruptFile, {"accessors[1].count"});
}

// FIFOs, devices and directories as the scene, a buffer URI, an image URI or an mtllib: refused at once
// (a FIFO hung, /dev/urandom and /dev/zero read forever, a directory gave "std::bad_alloc").
TEST(BadSceneRound2, OnlyRegularFilesAreRead) {
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  ASSERT_EQ(::mkfifo(d.file("fifo").c_str(), 0600), 0);
  ::mkdir(d.file("dir").c_str(), 0700);
  for (const std::string& target : {d.file("fifo"), std::string("/dev/zero"), d.file("dir")}) {
    SCOPED_TRACE(target);
    // The buffer URI: the target (relative to the glTF: tinygltf looks URIs up there) instead of the data URI.
    std::string j = gltf();
    const size_t a = j.find("data:application"), b = j.find('"', a);
    const std::string rel = target[0] == '/' && target.rfind(d.path().string(), 0) == 0
                                ? target.substr(d.path().string().size() + 1)
                                : target;
    j.replace(a, b - a, rel);
    testing::writeFile(d.file("b.gltf"), j);
    expectLoadFails(d.file("b.gltf"), ErrorCode::IoError, {"buffer " + target + ": not a regular file"});
    testing::writeFile(d.file("i.gltf"),
                       replaceOnce(gltf(), R"("uri":"t.png")", "\"uri\":\"" + target + "\""));
    const Result<Scene> s = loadScene(d.file("i.gltf"));
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("regular file"), std::string::npos) << s.error().message;
    EXPECT_EQ(s.error().message.find("bad_alloc"), std::string::npos) << s.error().message;
    testing::writeFile(d.file("m.obj"), "mtllib " + target + "\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    expectLoadFails(d.file("m.obj"), ErrorCode::IoError, {"mtllib", "regular file"});
  }
  testing::writeFile(d.file("m.obj"), "mtllib /dev/urandom\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  expectLoadFails(d.file("m.obj"), ErrorCode::IoError, {"/dev/urandom", "character device"});
  for (const std::string fifoScene : {"f.gltf", "f.glb", "f.obj"}) {
    ASSERT_EQ(::mkfifo(d.file(fifoScene).c_str(), 0600), 0);
    expectLoadFails(d.file(fifoScene), ErrorCode::IoError, {"regular file"});
  }
  const auto r = testing::runGuarded("info " + quote(d.file("fifo")), "", 20);
  testing::expectRejected(r, 1, {d.file("fifo"), "FIFO"}, "info on a FIFO");
}

// Absolute buffer URIs naming devices were joined to the glTF's directory by tinygltf, not found there, and
// then looked up in the current directory: "File not found : /dev/zero" (or a file of the current directory was
// read). Now every URI is resolved once (absolute as is, relative against the glTF's directory) and the read
// names the file and says what it is.
TEST(BadSceneRound2, DeviceBufferUrisAreNamed) {
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  for (const std::string dev : {"/dev/zero", "/dev/null", "/dev/urandom", "/dev/stdin"}) {
    std::string j = gltf();
    const size_t a = j.find("data:application"), b = j.find('"', a);
    j.replace(a, b - a, dev);
    testing::writeFile(d.file("dev.gltf"), j);
    struct stat st;
    if (dev == "/dev/stdin" && (::stat(dev.c_str(), &st) != 0 || S_ISREG(st.st_mode)))
      continue;  // this test's stdin is a regular file: nothing to refuse
    expectLoadFails(d.file("dev.gltf"), ErrorCode::IoError, {"buffer " + dev + ": not a regular file ("});
    if (dev == "/dev/stdin") continue;  // runGuarded gives the CLI a regular file as stdin
    const auto r = testing::runGuarded("scene-info " + quote(d.file("dev.gltf")), "", 20);
    testing::expectRejected(r, 1, {d.file("dev.gltf"), dev, "not a regular file (a character device)"},
                            "scene-info, buffer " + dev);
  }
  // A relative URI is looked up next to the glTF only, never in the current directory.
  ::mkdir(d.file("sub").c_str(), 0700);
  testing::writeFile(d.file("sub/t.png"), tinyPng());
  std::string j = gltf();
  const size_t a = j.find("data:application"), b = j.find('"', a);
  j.replace(a, b - a, "cwd.bin");
  testing::writeFile(d.file("sub/a.gltf"), j);
  std::string bin(68, '\0');  // the bytes of gltf()'s data URI
  const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  std::memcpy(bin.data(), pos, 36);
  const uint16_t idx[3] = {0, 1, 2};
  std::memcpy(bin.data() + 60, idx, 6);
  testing::writeFile(d.file("cwd.bin"), bin);
  const auto cwd = std::filesystem::current_path();
  std::filesystem::current_path(d.path());
  const Result<Scene> s = loadScene(d.file("sub/a.gltf"));
  std::filesystem::current_path(cwd);
  ASSERT_FALSE(s.ok()) << "read cwd.bin from the current directory";
  EXPECT_NE(s.error().message.find("buffer " + d.file("sub/cwd.bin") + ": cannot open"), std::string::npos)
      << s.error().message;
  // Next to the glTF it is found and the scene loads.
  testing::writeFile(d.file("sub/cwd.bin"), bin);
  EXPECT_TRUE(loadScene(d.file("sub/a.gltf")).ok());
}

// A 1 KB node DAG expanded to 1.1 GB of instances; a million instances of one mesh. Refused before the
// work, naming the limit; raising the limit loads it.
TEST(BadSceneRound2, NodeAndInstanceCountsAreLimited) {
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  // 24 levels, each node referencing the next one twice: 2^24 paths, 16 Mi instances of mesh 0.
  std::string nodes;
  for (int i = 0; i < 24; ++i)
    nodes += "{\"children\":[" + std::to_string(i + 1) + "," + std::to_string(i + 1) + "]},";
  nodes += "{\"mesh\":0}";
  std::string j = replaceOnce(gltf(), R"("nodes":[{"mesh":0}])", "\"nodes\":[" + nodes + "]");
  testing::writeFile(d.file("dag.gltf"), j);
  expectLoadFails(d.file("dag.gltf"), ErrorCode::LimitExceeded, {"--limit"});
  // 2^10 leaves: within the node limit, above an instance limit of 1000.
  nodes.clear();
  for (int i = 0; i < 10; ++i)
    nodes += "{\"children\":[" + std::to_string(i + 1) + "," + std::to_string(i + 1) + "]},";
  nodes += "{\"mesh\":0}";
  j = replaceOnce(gltf(), R"("nodes":[{"mesh":0}])", "\"nodes\":[" + nodes + "]");
  testing::writeFile(d.file("inst.gltf"), j);
  LoadOptions lo;
  ASSERT_TRUE(loadScene(d.file("inst.gltf"), lo).ok());
  EXPECT_EQ(loadScene(d.file("inst.gltf"), lo)->instances.size(), 1024u);
  lo.limits.instances = 1000;
  const Result<Scene> s = loadScene(d.file("inst.gltf"), lo);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("--limit instances="), std::string::npos) << s.error().message;
  lo.limits.instances = 1 << 20;
  lo.limits.nodes = 100;
  ASSERT_FALSE(loadScene(d.file("inst.gltf"), lo).ok());
  const auto r = testing::runGuarded("scene-info " + quote(d.file("dag.gltf")));
  testing::expectRejected(r, 1, {d.file("dag.gltf"), "--limit"}, "scene-info DAG");
  EXPECT_LT(r.maxRssKiB, (testing::kSanitized ? 400 : 100) * 1024);
  const auto raised =
      testing::runGuarded("scene-info " + quote(d.file("inst.gltf")) + " --limit instances=2000");
  EXPECT_EQ(raised.exitCode, 0) << raised.err;
}

// A 20-digit face index (tinyobjloader overflows silently) and a corrupt OBJ: exit 1 (was 2) everywhere.
TEST(BadSceneRound2, ObjIndexOverflowAndExitCodes) {
  TempDir d;
  testing::writeFile(d.file("big.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 18446744073709551619\n");
  expectLoadFails(d.file("big.obj"), ErrorCode::CorruptFile, {"line 4", "out of range"});
  testing::writeFile(d.file("a.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  for (const std::string cmd : {"scene-info", "render", "bench"}) {
    if (!testing::hasCommand(cmd)) continue;
    std::string args = cmd + " " + quote(d.file("a.obj"));
    if (cmd == "render") args += " -o " + quote(d.file("r.png")) + " --width 8 --height 8";
    if (cmd == "bench") args += " --width 8 --height 8";
    const auto r = testing::runGuarded(args);
    testing::expectRejected(r, 1, {d.file("a.obj"), "face 1"}, cmd);
    EXPECT_FALSE(std::filesystem::exists(d.file("r.png")));
  }
}

// Images: a pixel limit checked on the declared size (zlib bombs of 65 KB needed 0.8 GB), and palette
// indices beyond PLTE read as opaque black instead of stb_image's uninitialised palette memory.
std::string pngChunk(const std::string& type, const std::string& data) {
  auto be = [](uint32_t v) {
    std::string s(4, '\0');
    for (int i = 0; i < 4; ++i) s[size_t(i)] = char(uint8_t(v >> (24 - 8 * i)));
    return s;
  };
  uint32_t c = 0xFFFFFFFFu;
  const std::string td = type + data;
  for (unsigned char ch : td) {
    c ^= ch;
    for (int k = 0; k < 8; ++k) c = c & 1 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
  }
  return be(uint32_t(data.size())) + td + be(c ^ 0xFFFFFFFFu);
}
// An 8-bit PNG with stored (uncompressed) deflate blocks: rows of `width` bytes after a 0 filter byte each.
std::string storedPng(uint32_t width, uint32_t height, uint8_t colourType, const std::string& plte,
                      const std::string& rows) {
  auto be = [](uint32_t v) {
    std::string s(4, '\0');
    for (int i = 0; i < 4; ++i) s[size_t(i)] = char(uint8_t(v >> (24 - 8 * i)));
    return s;
  };
  std::string z = "\x78\x01";
  uint32_t a = 1, b = 0;
  for (unsigned char ch : rows) a = (a + ch) % 65521, b = (b + a) % 65521;
  for (size_t i = 0; i < rows.size() || i == 0; i += 65535) {
    const size_t n = std::min<size_t>(65535, rows.size() - i);
    z += char(i + n >= rows.size() ? 1 : 0);
    z += char(n & 0xFF), z += char(n >> 8), z += char(~n & 0xFF), z += char((~n >> 8) & 0xFF);
    z += rows.substr(i, n);
    if (rows.empty()) break;
  }
  z += be(b << 16 | a);
  std::string ihdr =
      be(width) + be(height) + std::string("\x08", 1) + char(colourType) + std::string(3, '\0');
  return std::string("\x89PNG\r\n\x1a\n", 8) + pngChunk("IHDR", ihdr) +
         (plte.empty() ? "" : pngChunk("PLTE", plte)) + pngChunk("IDAT", z) + pngChunk("IEND", "");
}

TEST(BadSceneRound2, ImagePixelLimitAndPaletteIndices) {
  // A grey image of 6000 x 6000 (36 Mi texels > the 32 Mi default), stored: declared size refused at once.
  const std::string bomb = storedPng(6000, 6000, 0, "", std::string(16, '\0'));
  Limits lim;
  auto r = detail::decodeImage(reinterpret_cast<const uint8_t*>(bomb.data()), bomb.size(), lim);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("image-pixels"), std::string::npos) << r.error().message;
  // Decoded bytes over a scene: a second image beyond the budget is refused.
  const std::string small = storedPng(64, 64, 0, "", std::string(64 * 65, '\0'));
  lim.decodedImageBytes = 64 * 64 * 11 + 10;
  uint64_t used = 0;
  EXPECT_TRUE(
      detail::decodeImage(reinterpret_cast<const uint8_t*>(small.data()), small.size(), lim, &used).ok());
  r = detail::decodeImage(reinterpret_cast<const uint8_t*>(small.data()), small.size(), lim, &used);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("decoded-bytes"), std::string::npos) << r.error().message;

  // Palette of 2 entries (red, green); pixels use indices 0, 1, 2 and 255.
  const std::string plte = std::string("\xff\x00\x00\x00\xff\x00", 6);
  const std::string rows = std::string("\x00\x00\x01\x02\xff", 5);
  const std::string pal = storedPng(4, 1, 3, plte, rows);
  for (int k = 0; k < 2; ++k) {  // twice: the result must not depend on earlier stack contents
    auto p = detail::decodeImage(reinterpret_cast<const uint8_t*>(pal.data()), pal.size());
    ASSERT_TRUE(p.ok()) << p.error().message;
    ASSERT_EQ(p->width, 4u);
    ASSERT_EQ(p->channels, 3u);
    const uint16_t expect[12] = {65535, 0, 0, 0, 65535, 0, 0, 0, 0, 0, 0, 0};
    for (int i = 0; i < 12; ++i) EXPECT_EQ(p->sample(size_t(i)), expect[i]) << "sample " << i;
  }
}

// Names from files are printed escaped: a newline in a material name cannot forge a second `somm` line,
// an escape sequence never reaches the terminal.
TEST(BadSceneRound2, NamesFromFilesAreEscaped) {
  if (!testing::hasCommand("bake")) GTEST_SKIP();
  TempDir d;
  const std::string j =
      replaceOnce(replaceOnce(gltf(), R"("materials":[{)",
                              "\"materials\":[{\"name\":\"evil\\nsomm bake: forged \\u001b[31m\","),
                  R"("uri":"t.png")", R"("uri":"missing.png")");
  testing::writeFile(d.file("n.gltf"), j);
  const auto r = testing::runGuarded("bake " + quote(d.file("n.gltf")) + " -o " + quote(d.file("o.somm")));
  testing::expectRejected(r, 1, {"evil\\x0asomm bake: forged \\x1b[31m"}, "escaped material name");
}

// Tiny legal scenes that cost unbounded CPU: 20 sliver triangles at level 12 (> 20 s), 3000 triangles with
// huge UVs at level 8 (52 s to bake, 58 s in view). The per-triangle work bound makes them quick (here: well
// inside the 60 s hang limit on a loaded machine; the bound itself is checked exactly in tests/bake).
TEST(BadSceneRound2, SliversAndHugeUvsAreBounded) {
  if (!testing::hasCommand("bake")) GTEST_SKIP();
  TempDir d;
  testing::writeFile(d.file("t.png"), tinyPng());
  std::string obj = "mtllib m.mtl\nusemtl leaf\n";
  for (int i = 0; i < 20; ++i) {
    obj +=
        "v 0 0 " + std::to_string(i) + "\nv 1 0 " + std::to_string(i) + "\nv 0 1 " + std::to_string(i) + "\n";
    obj += "vt " + std::to_string(-3000 - i) + " 0.1\nvt 3000 0.1000001\nvt 3000.5 0.1000002\n";
    obj += "f " + std::to_string(3 * i + 1) + "/" + std::to_string(3 * i + 1) + " " +
           std::to_string(3 * i + 2) + "/" + std::to_string(3 * i + 2) + " " + std::to_string(3 * i + 3) +
           "/" + std::to_string(3 * i + 3) + "\n";
  }
  testing::writeFile(d.file("m.mtl"), "newmtl leaf\nmap_d t.png\n");
  testing::writeFile(d.file("s.obj"), obj);
  auto r = testing::runGuarded(
      "bake " + quote(d.file("s.obj")) + " -o " + quote(d.file("s.somm")) + " --level 12 --format 2", "", 60);
  EXPECT_EQ(r.exitCode, 0) << r.err;
  std::string huge = "mtllib m.mtl\nusemtl leaf\n";
  for (int i = 0; i < 3000; ++i) {
    huge +=
        "v 0 0 " + std::to_string(i) + "\nv 1 0 " + std::to_string(i) + "\nv 0 1 " + std::to_string(i) + "\n";
    huge += "vt -20000 -20000\nvt 20000 -20000\nvt 0 20000\n";
    const int b = 3 * i;
    huge += "f " + std::to_string(b + 1) + "/" + std::to_string(b + 1) + " " + std::to_string(b + 2) + "/" +
            std::to_string(b + 2) + " " + std::to_string(b + 3) + "/" + std::to_string(b + 3) + "\n";
  }
  testing::writeFile(d.file("h.obj"), huge);
  r = testing::runGuarded("bake " + quote(d.file("h.obj")) + " -o " + quote(d.file("h.somm")) + " --level 8",
                          "", 60);
  EXPECT_EQ(r.exitCode, 0) << r.err;
  r = testing::runGuarded("view " + quote(d.file("h.somm")) + " -g 0 -o " + quote(d.file("h.png")), "", 60);
  EXPECT_EQ(r.exitCode, 0) << r.err;
}

}  // namespace
}  // namespace somm
#endif
