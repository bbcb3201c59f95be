// SPDX-License-Identifier: MIT
// Bad-input suite, round two (issue 12): .somm files with shared descriptors or encodings contradicting flat,
// outputs that are inputs, FIFOs, devices or symlinked temporary names, export whole or not at all, stdout
// write errors, option ranges.
#if __has_include("somm/somm_file.h")
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "hardening_util.h"
#include "somm/encode.h"
#include "somm/somm_file.h"
#include "somm_test_arrays.h"

namespace somm {
namespace {

using testing::expectRejected;
using testing::quote;
using testing::runGuarded;
using testing::TempDir;

// One geometry of `n` triangles whose descriptors all share one level-9 4-state map (legal: the spec lets
// descriptors overlap). 128 KiB of map + 8 bytes per descriptor; expanded per descriptor it would be n × 128 KiB.
SommFile sharedDescriptorFile(uint32_t n) {
  testing::TestGeometry g;
  g.info.name = "shared";
  g.info.triangleCount = n;
  g.info.format = Format::FourState;
  g.info.minLevel = g.info.maxLevel = 9;
  Micromap m(9, Format::FourState);
  std::mt19937 rng(5);
  for (uint32_t i = 0; i < m.size(); ++i) m.set(i, State(rng() % 4));
  g.flat.data.assign(m.bytes().begin(), m.bytes().end());
  for (uint32_t t = 0; t < n; ++t) {
    TriangleDescriptor d{};
    d.dataOffset = 0;
    d.subdivisionLevel = 9;
    d.format = uint16_t(Format::FourState);
    g.flat.descriptors.push_back(d);
    g.flat.indices.push_back(int32_t(t));
  }
  computeUsageHistograms(g.flat);
  g.info.stats.microTriangles = uint64_t(n) << 18;
  auto dfs = EncodedArray::build(g.flat, Encoding::Dfs);
  EXPECT_TRUE(dfs.ok());
  if (dfs.ok()) g.extra.push_back(EncodedSection{sectionId("dfs "), dfs->serialize()});
  SommFile f = testing::singleGeometryFile(std::move(g));
  f.sourcePath = "scene.gltf";
  f.toolVersion = "somm test";
  return f;
}

TEST(BadSommRound2, SharedDescriptorsStayBounded) {
  TempDir d;
  const std::string p = d.file("shared.somm");
  ASSERT_TRUE(writeSommFile(p, sharedDescriptorFile(16000)).ok());
  EXPECT_LT(std::filesystem::file_size(p), 600u * 1024);
  const long cap = (testing::kSanitized ? 600 : 120) * 1024;  // KiB; expanded it would be 2 GB
  for (const std::string args : {"info", "info --json", "query --geometry 0 --triangle 15999",
                                 "query --geometry 0 --triangle 7 --encoding dfs"}) {
    SCOPED_TRACE(args);
    const auto r =
        runGuarded(args.substr(0, args.find(' ') == std::string::npos ? args.size() : args.find(' ')) + " " +
                       quote(p) + (args.find(' ') == std::string::npos ? "" : args.substr(args.find(' '))),
                   "0.25 0.25\n0.1 0.7\n", 60);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.err.find("bad_alloc"), std::string::npos) << r.err;
    EXPECT_LT(r.maxRssKiB, cap);
  }
}

// A stored encoding whose checksums are valid but whose states contradict flat: refused, never answered.
TEST(BadSommRound2, EncodingContradictingFlatIsRefused) {
  TempDir d;
  SommFile f = testing::sampleFile(30, 3, testing::Layout::PerGeometry);
  OmmArray& flat0 = f.micromaps.arrays[0];
  f.encodings[0].clear();
  OmmArray other = flat0;
  size_t mapIndex = 0;
  while (mapIndex < other.descriptors.size() && other.descriptors[mapIndex].subdivisionLevel < 2) ++mapIndex;
  ASSERT_LT(mapIndex, other.descriptors.size());
  other.data[other.descriptors[mapIndex].dataOffset] ^= 0x0C;  // micro-triangle 1 of that map changes state
  auto dfs = EncodedArray::build(other, Encoding::Dfs);
  ASSERT_TRUE(dfs.ok());
  f.encodings[0].push_back(EncodedSection{sectionId("dfs "), dfs->serialize()});
  const std::string p = d.file("contra.somm");
  ASSERT_TRUE(writeSommFile(p, f).ok());
  // Some triangle uses that map: query it through dfs.
  uint32_t tri = 0;
  while (tri < flat0.indices.size() && flat0.indices[tri] != int32_t(mapIndex)) ++tri;
  ASSERT_LT(tri, flat0.indices.size());
  const auto r =
      runGuarded("query " + quote(p) + " --geometry 0 --triangle " + std::to_string(tri) + " --encoding dfs",
                 "0.1 0.1\n");
  expectRejected(r, 1, {p, "differs from flat"}, "query through a contradicting dfs");
  const auto flat =
      runGuarded("query " + quote(p) + " --geometry 0 --triangle " + std::to_string(tri), "0.1 0.1\n");
  EXPECT_EQ(flat.exitCode, 0) << flat.err;
  const auto info = runGuarded("info " + quote(p));
  EXPECT_EQ(info.exitCode, 0) << info.err;
  EXPECT_NE(info.out.find("dfs unreadable"), std::string::npos) << info.out;
}

TEST(BadSommRound2, StdoutWriteErrorsFail) {
  TempDir d;
  const std::string p = d.file("good.somm");
  ASSERT_TRUE(writeSommFile(p, testing::sampleFile(40, 1)).ok());
  for (const std::string& cmd : {"info " + quote(p), "info --json " + quote(p)}) {
    const std::string full =
        "exec " + quote(SOMM_CLI_PATH) + " " + cmd + " > /dev/full 2> " + quote(d.file("err"));
    const int status = std::system(full.c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 1) << cmd;
    const std::string err = testing::readFile(d.file("err"));
    EXPECT_NE(err.find("cannot write to standard output"), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  }
}

// export: whole or not at all. An existing non-empty directory is refused and keeps its files (it used to
// be overwritten file by file); a new one appears complete, with no temporary directory left next to it.
TEST(BadSommRound2, ExportIsWholeOrNothing) {
  TempDir d;
  const std::string p = d.file("good.somm");
  ASSERT_TRUE(writeSommFile(p, testing::sampleFile(40, 1)).ok());
  const std::string out = d.file("out");
  std::filesystem::create_directories(out + "/geometry-0");
  testing::writeFile(out + "/geometry-0/index.bin", "precious");
  const auto before = testing::listDir(d.path().string());
  const auto r = runGuarded("export " + quote(p) + " --dir " + quote(out));
  expectRejected(r, 1, {out, "not empty"}, "export into a non-empty directory");
  EXPECT_EQ(testing::readFile(out + "/geometry-0/index.bin"), "precious");
  EXPECT_EQ(testing::listDir(d.path().string()), before);
  const std::string fresh = d.file("fresh");
  const auto ok = runGuarded("export " + quote(p) + " --dir " + quote(fresh));
  ASSERT_EQ(ok.exitCode, 0) << ok.err;
  EXPECT_TRUE(std::filesystem::exists(fresh + "/geometry-2/usage.json"));
  for (const auto& e : std::filesystem::directory_iterator(d.path()))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  // An empty existing directory is filled.
  const std::string empty = d.file("empty");
  std::filesystem::create_directories(empty);
  EXPECT_EQ(runGuarded("export " + quote(p) + " --dir " + quote(empty)).exitCode, 0);
  EXPECT_TRUE(std::filesystem::exists(empty + "/array-0/data.bin"));
  EXPECT_TRUE(std::filesystem::exists(empty + "/geometry-0/index.bin"));
  // A corrupt file leaves no directory.
  testing::writeFile(d.file("bad.somm"), "SOMM but not really");
  const auto bad = runGuarded("export " + quote(d.file("bad.somm")) + " --dir " + quote(d.file("never")));
  EXPECT_EQ(bad.exitCode, 1);
  EXPECT_FALSE(std::filesystem::exists(d.file("never")));
}

// Outputs that are inputs, FIFOs or devices are refused; temporary names are unique (a user's OUT.tmp, or a
// symlink of that name, is never touched).
TEST(BadSommRound2, OutputsAreSafe) {
  if (!testing::hasCommand("bake") || !testing::hasCommand("view")) GTEST_SKIP();
  TempDir d;
  testing::writeFile(d.file("t.png"),
                     testing::readFile(std::string(SOMM_DATA_DIR) + "/oak-tree/oakleaf_light.png"));
  const std::string obj = d.file("q.obj");
  testing::writeFile(
      obj, "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl leaf\nf 1/1 2/2 3/3\n");
  testing::writeFile(d.file("m.mtl"), "newmtl leaf\nmap_d t.png\n");
  const std::string original = testing::readFile(obj);
  auto r = runGuarded("bake " + quote(obj) + " -o " + quote(obj));
  expectRejected(r, 2, {"is the input"}, "bake -o the input");
  EXPECT_EQ(testing::readFile(obj), original);
  ASSERT_EQ(runGuarded("bake " + quote(obj) + " -o " + quote(d.file("q.somm")) + " --level 3").exitCode, 0);
  const std::string somm = testing::readFile(d.file("q.somm"));
  r = runGuarded("view " + quote(d.file("q.somm")) + " -g 0 -o " + quote(d.file("q.somm")));
  expectRejected(r, 2, {"is the input"}, "view -o the input");
  EXPECT_EQ(testing::readFile(d.file("q.somm")), somm);
  ::symlink(d.file("q.somm").c_str(), d.file("link.png").c_str());
  r = runGuarded("view " + quote(d.file("q.somm")) + " -g 0 -o " + quote(d.file("link.png")));
  expectRejected(r, 2, {"is the input"}, "view -o a symlink to the input");
  ASSERT_EQ(::mkfifo(d.file("fifo.somm").c_str(), 0600), 0);
  r = runGuarded("bake " + quote(obj) + " -o " + quote(d.file("fifo.somm")), "", 20);
  expectRejected(r, 2, {"FIFO"}, "bake -o a FIFO");
  struct stat st;
  ASSERT_EQ(::stat(d.file("fifo.somm").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  r = runGuarded("view " + quote(d.file("q.somm")) + " -g 0 -o /dev/null");
  expectRejected(r, 2, {"character device"}, "view -o /dev/null");
  // A user's out.png.tmp and a symlink named like a fixed temporary file stay as they are.
  testing::writeFile(d.file("victim"), "victim");
  testing::writeFile(d.file("v.png.tmp"), "mine");
  ::symlink(d.file("victim").c_str(), d.file("w.png.tmp").c_str());
  EXPECT_EQ(runGuarded("view " + quote(d.file("q.somm")) + " -g 0 -o " + quote(d.file("v.png"))).exitCode, 0);
  EXPECT_EQ(runGuarded("view " + quote(d.file("q.somm")) + " -g 0 -o " + quote(d.file("w.png"))).exitCode, 0);
  EXPECT_EQ(testing::readFile(d.file("v.png.tmp")), "mine");
  EXPECT_EQ(testing::readFile(d.file("victim")), "victim");
  if (testing::hasCommand("render")) {
    r = runGuarded("render " + quote(d.file("missing.obj")) + " -o " + quote(d.file("v.png")) +
                   " --width 8 --height 8");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(testing::readFile(d.file("v.png.tmp")), "mine");
    r = runGuarded("render " + quote(obj) + " -o " + quote(d.file("w.png")) + " --width 8 --height 8");
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(testing::readFile(d.file("victim")), "victim");
    r = runGuarded("render " + quote(obj) + " -o " + quote(obj) + " --width 8 --height 8");
    expectRejected(r, 2, {"is the input"}, "render -o the scene");
    EXPECT_EQ(testing::readFile(obj), original);
  }
}

// `bake IN.gltf -o OUT.gltf` also writes OUT.bin. When OUT.bin was one of IN.gltf's own buffers (IN.gltf written
// by an earlier bake into OUT.gltf), it was rewritten with the new data appended and the input scene no longer
// loaded ("File size mismatch"). Now refused, nothing written; a FIFO as OUT.bin is refused too (it was replaced).
TEST(BadSommRound2, GltfOutputBufferIsNeverAnInput) {
  if (!testing::hasCommand("bake") || !testing::hasCommand("gen-scene")) GTEST_SKIP();
  TempDir d;
  ASSERT_EQ(runGuarded("gen-scene quad --size 16 -o " + quote(d.file("q.glb"))).exitCode, 0);
  ASSERT_EQ(runGuarded("bake " + quote(d.file("q.glb")) + " -l 2 -o " + quote(d.file("out.gltf"))).exitCode,
            0);
  auto r = runGuarded("bake " + quote(d.file("out.gltf")) + " -l 2 -o " + quote(d.file("a.gltf")));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  ASSERT_NE(testing::readFile(d.file("a.gltf")).find("out.bin"), std::string::npos)
      << "a.gltf should keep its geometry in out.bin";
  const std::string outGltf = testing::readFile(d.file("out.gltf")),
                    outBin = testing::readFile(d.file("out.bin"));
  const auto before = testing::listDir(d.path().string());
  r = runGuarded("bake " + quote(d.file("a.gltf")) + " -l 3 -o " + quote(d.file("out.gltf")));
  expectRejected(r, 1, {d.file("out.bin"), "input"}, "bake a.gltf -o out.gltf (out.bin is a.gltf's buffer)");
  EXPECT_EQ(testing::readFile(d.file("out.bin")), outBin);
  EXPECT_EQ(testing::readFile(d.file("out.gltf")), outGltf);
  EXPECT_EQ(testing::listDir(d.path().string()), before);
  EXPECT_EQ(runGuarded("scene-info " + quote(d.file("a.gltf"))).exitCode, 0);
  // The same through a symlink named like the output's buffer.
  ::symlink(d.file("out.bin").c_str(), d.file("b.bin").c_str());
  r = runGuarded("bake " + quote(d.file("a.gltf")) + " -l 3 -o " + quote(d.file("b.gltf")));
  expectRejected(r, 1, {"b.bin", "input"}, "bake -o b.gltf, b.bin a symlink to an input buffer");
  EXPECT_EQ(testing::readFile(d.file("out.bin")), outBin);
  // A FIFO as the output's buffer.
  ASSERT_EQ(::mkfifo(d.file("f.bin").c_str(), 0600), 0);
  r = runGuarded("bake " + quote(d.file("a.gltf")) + " -l 3 -o " + quote(d.file("f.gltf")), "", 20);
  expectRejected(r, 1, {"f.bin", "FIFO"}, "bake -o f.gltf, f.bin a FIFO");
  struct stat st;
  ASSERT_EQ(::stat(d.file("f.bin").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  EXPECT_FALSE(std::filesystem::exists(d.file("f.gltf")));
}

// An output naming one of the files the scene was read from: the scene's texture, its glTF buffer, an OBJ's
// material library or texture. `render scene.gltf -o leaf.png` overwrote the scene's own texture and exited 0.
// Refused with exit 2 before any work; the file is untouched.
TEST(BadSommRound2, OutputsNeverReplaceSceneFiles) {
  if (!testing::hasCommand("bake") || !testing::hasCommand("view")) GTEST_SKIP();
  TempDir d;
  const std::string src = std::string(SOMM_DATA_DIR) + "/oak-tree/";
  for (const char* f : {"oaktree.gltf", "oaktree.bin", "oakleaf_light.png", "oakbark.jpg"})
    testing::writeFile(d.file(f), testing::readFile(src + f));
  testing::writeFile(d.file("q.obj"),
                     "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl "
                     "leaf\nf 1/1 2/2 3/3\n");
  testing::writeFile(d.file("m.mtl"), "newmtl leaf\nmap_d oakleaf_light.png\n");
  const std::string gltf = d.file("oaktree.gltf"), obj = d.file("q.obj");
  ASSERT_EQ(runGuarded("bake " + quote(gltf) + " -l 2 -o " + quote(d.file("o.somm"))).exitCode, 0);
  std::vector<std::pair<std::string, std::string>> cases = {
      {"bake " + quote(gltf) + " -l 2 -o ", d.file("oakleaf_light.png")},
      {"bake " + quote(gltf) + " -l 2 -o ", d.file("oaktree.bin")},
      {"bake " + quote(obj) + " -l 2 -o ", d.file("m.mtl")},
      {"view " + quote(d.file("o.somm")) + " -g 0 -o ", d.file("oakleaf_light.png")},
      {"view " + quote(d.file("o.somm")) + " -g 0 -o ", d.file("oaktree.bin")},
  };
  if (testing::hasCommand("render")) {
    cases.push_back({"render " + quote(gltf) + " --width 8 --height 8 -o ", d.file("oakleaf_light.png")});
    cases.push_back({"render " + quote(gltf) + " --width 8 --height 8 -o ", d.file("oakbark.jpg")});
    cases.push_back({"render " + quote(obj) + " --width 8 --height 8 -o ", d.file("oakleaf_light.png")});
  }
  for (const auto& [cmd, target] : cases) {
    const std::string before = testing::readFile(target);
    const auto r = runGuarded(cmd + quote(target));
    expectRejected(r, 2, {target, "is the input"}, cmd + target);
    EXPECT_EQ(testing::readFile(target), before) << target;
  }
  EXPECT_EQ(runGuarded("scene-info " + quote(gltf)).exitCode, 0);
}

// A GLB whose declared total length is below its 20-byte headers: the micromap reader computed `total - 20` in
// unsigned arithmetic, so a huge JSON chunk length passed the check and the JSON parser read past the file
// (ASan: heap-buffer-overflow; found by fuzz_gltf). Every command that opens micromaps refuses it cleanly.
TEST(BadSommRound2, GlbLengthBelowHeader) {
  TempDir d;
  for (uint32_t total : {0u, 12u, 19u}) {
    std::string glb("glTF", 4);
    auto u32 = [&](uint32_t v) {
      for (int i = 0; i < 4; ++i) glb += char((v >> (8 * i)) & 0xffu);
    };
    u32(2);
    u32(total);
    u32(0x9b073c00u);  // JSON chunk length: far past the file
    glb += "JSON";
    glb += R"({"asset":{"version":"2.0"},"extensionsUsed":["EXT_mesh_opacity_micromap"]})";
    testing::writeFile(d.file("x.glb"), glb);
    for (const char* cmd : {"info", "export"}) {
      const std::string extra = std::string(cmd) == "export" ? " --dir " + quote(d.file("out")) : "";
      const auto r = runGuarded(std::string(cmd) + " " + quote(d.file("x.glb")) + extra);
      expectRejected(r, 1, {d.file("x.glb"), "less than its headers"},
                     std::string(cmd) + " on a GLB of declared length " + std::to_string(total));
    }
    EXPECT_FALSE(std::filesystem::exists(d.file("out")));
  }
}

// gen-scene -o and export --dir naming something that cannot be the output (a device, a FIFO, a regular file as the
// directory): exit 2 like bake / render / view, before the work (gen-scene built a million-card scene first, then
// failed with exit 1).
TEST(BadSommRound2, NonRegularOutputsAreUsageErrors) {
  if (!testing::hasCommand("gen-scene") || !testing::hasCommand("export")) GTEST_SKIP();
  TempDir d;
  auto r = runGuarded("gen-scene leaf-cards --cards 1000000 -o /dev/null");
  expectRejected(r, 2, {"/dev/null", "character device"}, "gen-scene -o /dev/null");
  ASSERT_EQ(::mkfifo(d.file("f.glb").c_str(), 0600), 0);
  r = runGuarded("gen-scene quad -o " + quote(d.file("f.glb")), "", 20);
  expectRejected(r, 2, {"f.glb", "FIFO"}, "gen-scene -o a FIFO");
  ASSERT_EQ(runGuarded("gen-scene quad --size 16 -o " + quote(d.file("q.glb"))).exitCode, 0);
  ASSERT_EQ(runGuarded("bake " + quote(d.file("q.glb")) + " -l 2 -o " + quote(d.file("q.somm"))).exitCode, 0);
  const std::string somm = testing::readFile(d.file("q.somm"));
  const auto before = testing::listDir(d.path().string());
  for (const std::string& dir : {std::string("/dev/null"), d.file("q.somm"), d.file("f.glb")}) {
    r = runGuarded("export " + quote(d.file("q.somm")) + " --dir " + quote(dir), "", 20);
    expectRejected(r, 2, {dir, "not a directory"}, "export --dir " + dir);
  }
  EXPECT_EQ(testing::readFile(d.file("q.somm")), somm);
  EXPECT_EQ(testing::listDir(d.path().string()), before);
}

// Options: threads beyond what oneTBB accepts (65537 crashed inside it), sizes beyond 2^63, NaN, absurd
// counts that would run out of memory, unknown or malformed --limit.
TEST(BadSommRound2, OptionRanges) {
  if (!testing::hasCommand("bake")) GTEST_SKIP();
  TempDir d;
  testing::writeFile(d.file("a.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string scene = quote(d.file("a.obj"));
  const std::string out = " -o " + quote(d.file("o.somm"));
  for (const std::string& args :
       {"bake " + scene + out + " --threads 65537",
        "bake " + scene + out + " --max-bytes 18446744073709551616",
        "bake " + scene + out + " --max-bytes 9223372036854775809", "bake " + scene + out + " --limit nodes",
        "bake " + scene + out + " --limit no-such=5", "bake " + scene + out + " --limit nodes=-1",
        "bake " + scene + out + " --limit nodes=99999999999999999999",
        "compare " + scene + " --threads 65537",
        "gen-scene quad -o " + quote(d.file("g.glb")) + " --cutoff nan",
        "gen-scene leaf-cards -o " + quote(d.file("g.glb")) + " --cards 50000000",
        "scene-info " + scene + " --limit instances=1.5"}) {
    SCOPED_TRACE(args);
    const auto r = runGuarded(args);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_EQ(r.err.rfind("somm", 0), 0u) << r.err;
    EXPECT_EQ(r.err.find("internal error"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(d.file("o.somm")));
  }
  EXPECT_EQ(runGuarded("bake " + scene + out + " --threads 1024 --limit nodes=5M --limit micro-triangles=1G")
                .exitCode,
            0);
  // The total micro-triangle work is checked before the bake starts.
  testing::writeFile(d.file("t.png"),
                     testing::readFile(std::string(SOMM_DATA_DIR) + "/oak-tree/oakleaf_light.png"));
  testing::writeFile(
      d.file("q.obj"),
      "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl leaf\nf 1/1 2/2 3/3\n");
  testing::writeFile(d.file("m.mtl"), "newmtl leaf\nmap_d t.png\n");
  const auto r = runGuarded("bake " + quote(d.file("q.obj")) + " -o " + quote(d.file("w.somm")) +
                            " --level 12 --limit micro-triangles=1M");
  expectRejected(r, 1, {"micro-triangles", "--limit micro-triangles="}, "micro-triangle limit");
  EXPECT_FALSE(std::filesystem::exists(d.file("w.somm")));
}

// Names stored in a .somm (its source path, geometry and material names) are printed escaped by `info`.
TEST(BadSommRound2, InfoEscapesStoredNames) {
  TempDir d;
  SommFile f = testing::sampleFile(10, 2);
  f.sourcePath = "evil\nsomm info: forged \x1b[2J";
  f.geometries[0].name = "g\r\x07";
  const std::string p = d.file("names.somm");
  ASSERT_TRUE(writeSommFile(p, f).ok());
  const auto r = runGuarded("info " + quote(p));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("evil\\x0asomm info: forged \\x1b[2J"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("'g\\x0d\\x07'"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos);
  EXPECT_EQ(r.out.find('\r'), std::string::npos);
}

}  // namespace
}  // namespace somm
#endif
