// SPDX-License-Identifier: MIT
// Bad-input suite, part 2: corrupt, truncated, foreign and hostile .somm files through `somm info / query /
// export`. Hostile files are made from a valid one, with the header's declared size and every checksum
// recomputed after the edit so that the structural validation (not just the checksum) is what rejects them.
#if __has_include("somm/somm_file.h")
#include "somm/somm_file.h"

#include <gtest/gtest.h>
#include <xxhash.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "hardening_util.h"
#include "somm_test_arrays.h"

namespace somm {
namespace {

using testing::expectRejected;
using testing::GuardedResult;
using testing::quote;
using testing::runGuarded;
using testing::TempDir;

uint64_t load64(const std::string& b, size_t at) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= uint64_t(uint8_t(b[at + size_t(i)])) << (8 * i);
  return v;
}
uint32_t load32(const std::string& b, size_t at) {
  return uint32_t(load64(b + std::string(8, '\0'), at));
}
void store64(std::string& b, size_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) b[at + size_t(i)] = char(uint8_t(v >> (8 * i)));
}
void store32(std::string& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + size_t(i)] = char(uint8_t(v >> (8 * i)));
}
void store16(std::string& b, size_t at, uint16_t v) {
  for (int i = 0; i < 2; ++i) b[at + size_t(i)] = char(uint8_t(v >> (8 * i)));
}

struct Chunk {
  size_t off;  // of the 24-byte chunk header; the payload follows
  uint32_t type, geometry;
  uint64_t size;
};

// The chunk list of a valid file (docs/somm-format.md).
std::vector<Chunk> chunks(const std::string& b) {
  std::vector<Chunk> out;
  for (size_t off = 32; off + 24 <= b.size();) {
    const Chunk c{off, load32(b, off), load32(b, off + 4), load64(b, off + 8)};
    out.push_back(c);
    off += 24 + ((c.size + 7) & ~uint64_t(7));
  }
  return out;
}

// Declared size, header checksum and every chunk checksum recomputed.
std::string fixChecksums(std::string b) {
  store64(b, 16, b.size());
  store64(b, 24, XXH3_64bits(b.data(), 24));
  for (const Chunk& c : chunks(b)) {
    if (c.off + 24 + c.size > b.size()) break;
    store64(b, c.off + 16,
            XXH3_64bits_withSeed(b.data() + c.off + 24, c.size, XXH3_64bits(b.data() + c.off, 16)));
  }
  return b;
}

const Chunk& find(const std::vector<Chunk>& cs, const char (&id)[5], uint32_t geometry = 0) {
  for (const Chunk& c : cs)
    if (c.type == sectionId(id) && (c.geometry == geometry || c.type == sectionId("META"))) return c;
  static Chunk none{};
  ADD_FAILURE() << "no chunk " << id;
  return none;
}

class BadSomm : public ::testing::Test {
 protected:
  void SetUp() override {
    good_ = dir_.file("good.somm");
    ASSERT_TRUE(writeSommFile(good_, testing::sampleFile(12, 7)).ok());
    bytes_ = testing::readFile(good_);
    cs_ = chunks(bytes_);
  }
  std::string write(const std::string& name, const std::string& data) {
    const std::string p = dir_.file(name);
    testing::writeFile(p, data);
    return p;
  }
  // Runs info, query and export on `path`; each must fail with exit 1 naming the file and containing
  // `needle`.
  void expectAllReject(const std::string& path, const std::string& needle, const std::string& what) {
    const std::string exportDir = dir_.file("export-out");
    for (const std::string cmd : {"info", "query", "export"}) {
      std::string args = cmd + " " + quote(path);
      if (cmd == "query") args += " --geometry 0 --triangle 0";
      if (cmd == "export") args += " --dir " + quote(exportDir);
      const GuardedResult r = runGuarded(args, "0.25 0.25\n");
      expectRejected(r, 1, {"somm " + cmd + ": " + path + ": ", needle}, what + " / " + cmd);
      EXPECT_LT(r.maxRssKiB, (testing::kSanitized ? 400 : 64) * 1024) << what << ": peak RSS (KiB)";
      EXPECT_FALSE(std::filesystem::exists(exportDir)) << what << ": export left a directory behind";
    }
  }

  TempDir dir_;
  std::string good_, bytes_;
  std::vector<Chunk> cs_;
};

TEST_F(BadSomm, GoodFileIsAccepted) {
  const GuardedResult r = runGuarded("info " + quote(good_));
  EXPECT_EQ(r.exitCode, 0) << r.err;
}

TEST_F(BadSomm, TruncatedAnywhere) {
  for (size_t cut :
       {size_t(0), size_t(1), size_t(7), size_t(8), size_t(31), size_t(32), size_t(40), size_t(56),
        bytes_.size() / 3, bytes_.size() / 2, bytes_.size() - 9, bytes_.size() - 1}) {
    const std::string p = write("cut" + std::to_string(cut) + ".somm", bytes_.substr(0, cut));
    const GuardedResult r = runGuarded("info " + quote(p));
    expectRejected(r, 1, {p + ": "}, "cut at " + std::to_string(cut));
    if (cut >= 8) {
      EXPECT_NE(r.err.find("truncated"), std::string::npos) << r.err;
    }
  }
}

TEST_F(BadSomm, BitFlipsAnywhere) {
  std::mt19937 rng(6);
  for (int k = 0; k < 24; ++k) {
    std::string b = bytes_;
    const size_t at = rng() % b.size();
    b[at] = char(uint8_t(b[at]) ^ uint8_t(1u << (rng() % 8)));
    const std::string p = write("flip.somm", b);
    const GuardedResult r = runGuarded("info " + quote(p));
    // A flip inside padding or a checksum field is still caught (padding must be zero; the checksum then
    // differs).
    expectRejected(r, 1, {p + ": "}, "flip at byte " + std::to_string(at));
  }
}

TEST_F(BadSomm, ForeignWrongMagicAndVersion) {
  expectAllReject(write("foreign.somm", "glTF\x02\0\0\0 not a somm file at all, just some bytes"),
                  "not a .somm file", "foreign");
  expectAllReject(write("empty.somm", ""), "not a .somm file", "empty file");
  std::string b = bytes_;
  b[0] = 's';
  expectAllReject(write("magic.somm", b), "bad magic", "wrong magic");
  b = bytes_;
  store32(b, 8, 3);
  expectAllReject(write("v3.somm", fixChecksums(b)), "version 3 is not supported", "version 3");
  store32(b, 8, 0xffffffffu);
  expectAllReject(write("vmax.somm", fixChecksums(b)), "is not supported", "version 2^32-1");
  b = bytes_;
  store32(b, 12, 1);
  expectAllReject(write("flags.somm", fixChecksums(b)), "unknown header flags", "header flags");
  expectAllReject(write("trailing.somm", bytes_ + std::string(8, '\0')), "unexpected bytes",
                  "trailing bytes");
}

TEST_F(BadSomm, AbsurdCountsAndOffsets) {
  const Chunk& meta = find(cs_, "META");
  const Chunk& flat = find(cs_, "FLAT");
  const size_t fp =
      flat.off + 24;  // FLAT payload: triangles, descriptors, index type, hist, tri-hist, 0, data u64
  struct Case {
    std::string name, needle;
    std::function<void(std::string&)> edit;
  };
  const std::vector<Case> cases = {
      {"geometries", "geometries cannot fit",
       [&](std::string& b) { store32(b, meta.off + 24, 0xffffffffu); }},
      {"arrays", "arrays cannot fit", [&](std::string& b) { store32(b, meta.off + 28, 0xffffffffu); }},
      {"array of a geometry", "does not exist",
       [&](std::string& b) {
         const Chunk& geom = find(cs_, "GEOM");
         const size_t p = geom.off + 24, name = load32(b, p), material = load32(b, p + 4 + name);
         store32(b, p + 8 + name + material + 4, 0xfffffff0u);
       }},
      {"triangles", "need", [&](std::string& b) { store32(b, fp, 0xffffffffu); }},
      {"descriptors", "need", [&](std::string& b) { store32(b, fp + 4, 0x7fffffffu); }},
      {"histogram", "need", [&](std::string& b) { store32(b, fp + 12, 0xffffffffu); }},
      {"data size", "exceeds the payload", [&](std::string& b) { store64(b, fp + 24, ~uint64_t(0)); }},
      {"index type", "index type 3", [&](std::string& b) { store32(b, fp + 8, 3); }},
      {"chunk size", "extends past the end",
       [&](std::string& b) { store64(b, flat.off + 8, uint64_t(1) << 62); }},
      {"chunk type", "unknown chunk type", [&](std::string& b) { store32(b, flat.off, sectionId("ZZZZ")); }},
      {"level 13", "level 13 (must be at most 12)", [&](std::string& b) { store16(b, fp + 32 + 4, 13); }},
      {"level 65535", "(must be at most 12)", [&](std::string& b) { store16(b, fp + 32 + 4, 0xffff); }},
      {"format 3", "format 3 (must be 1 or 2)", [&](std::string& b) { store16(b, fp + 32 + 6, 3); }},
      {"format 0", "format 0 (must be 1 or 2)", [&](std::string& b) { store16(b, fp + 32 + 6, 0); }},
      {"data offset", "extends past the", [&](std::string& b) { store32(b, fp + 32, 0xfffffff0u); }},
  };
  for (const Case& c : cases) {
    std::string b = bytes_;
    c.edit(b);
    expectAllReject(write("absurd.somm", fixChecksums(b)), c.needle, c.name);
  }
}

// A failing command never clobbers existing output: export into an existing directory with files in it.
TEST_F(BadSomm, ExistingOutputIsNotClobbered) {
  const std::string out = dir_.file("existing");
  std::filesystem::create_directories(out + "/geometry-0");
  testing::writeFile(out + "/geometry-0/data.bin", "precious");
  std::string b = bytes_;
  b[b.size() / 2] ^= 0x40;
  const std::string p = write("bad.somm", b);
  const GuardedResult r = runGuarded("export " + quote(p) + " --dir " + quote(out));
  expectRejected(r, 1, {p + ": "}, "export of a corrupt file into an existing directory");
  EXPECT_EQ(testing::readFile(out + "/geometry-0/data.bin"), "precious");
  EXPECT_EQ(testing::listDir(out), (std::set<std::string>{"geometry-0", "geometry-0/data.bin"}));
}

// `somm view` renders a PNG from a .somm file and its scene: a corrupt file writes nothing, keeps an existing
// image.
TEST_F(BadSomm, ViewOfCorruptFileWritesNothing) {
  if (!testing::hasCommand("view")) GTEST_SKIP() << "this build has no `somm view`";
  std::string b = bytes_;
  b[b.size() / 2] ^= 0x04;
  const std::string p = write("bad.somm", b);
  const std::string png = dir_.file("view.png");
  testing::writeFile(png, "precious");
  const auto before = testing::listDir(dir_.path().string());
  const GuardedResult r = runGuarded("view " + quote(p) + " --geometry 0 -o " + quote(png));
  expectRejected(r, 1, {p + ": "}, "view of a corrupt file");
  EXPECT_EQ(testing::readFile(png), "precious");
  EXPECT_EQ(testing::listDir(dir_.path().string()), before);
}

TEST_F(BadSomm, QueryOptionsOutOfRange) {
  for (const std::string& opts :
       {std::string("--geometry 3 --triangle 0"), std::string("--geometry 0 --triangle 12"),
        std::string("--geometry 4294967296 --triangle 0"), std::string("--geometry 0 --triangle -1")}) {
    const GuardedResult r = runGuarded("query " + quote(good_) + " " + opts, "0.1 0.1\n");
    SCOPED_TRACE(opts);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_EQ(r.err.rfind("somm", 0), 0u) << r.err;
    EXPECT_EQ(r.out, "");
  }
  const GuardedResult r =
      runGuarded("query " + quote(good_) + " --geometry 0 --triangle 0", "0.1 0.1\n0.2 \x01\n");
  expectRejected(r, 2, {"stdin line 2"}, "query: malformed stdin", true);
}

}  // namespace
}  // namespace somm
#endif
