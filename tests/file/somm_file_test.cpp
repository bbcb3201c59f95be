// SPDX-License-Identifier: MIT
#include "somm/somm_file.h"

#include <gtest/gtest.h>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>

#include "somm_test_arrays.h"

namespace somm {
namespace {

using testing::randomGeometry;
using testing::sampleFile;

std::vector<uint8_t> serialize(const SommFile& f) {
  auto r = serializeSomm(f);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? *r : std::vector<uint8_t>{};
}

void expectEqual(const SommFile& a, const SommFile& b) {
  EXPECT_EQ(a.sourcePath, b.sourcePath);
  EXPECT_EQ(a.toolVersion, b.toolVersion);
  EXPECT_EQ(a.bakeOptions, b.bakeOptions);
  ASSERT_EQ(a.geometries.size(), b.geometries.size());
  for (size_t g = 0; g < a.geometries.size(); ++g) {
    const SommGeometry &x = a.geometries[g], &y = b.geometries[g];
    EXPECT_EQ(x.info, y.info);
    EXPECT_EQ(x.flat.data, y.flat.data);
    EXPECT_EQ(x.flat.descriptors, y.flat.descriptors);
    EXPECT_EQ(x.flat.indices, y.flat.indices);
    EXPECT_EQ(x.flat.histogram, y.flat.histogram);
    EXPECT_EQ(x.flat.triangleHistogram, y.flat.triangleHistogram);
    EXPECT_EQ(x.extra, y.extra);
  }
}

// ---- an independent view of the layout (docs/somm-format.md) used to craft corrupt files ----

uint64_t le64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= uint64_t(p[i]) << (8 * i);
  return v;
}
uint32_t le32(const uint8_t* p) {
  return p[0] | p[1] << 8 | p[2] << 16 | uint32_t(p[3]) << 24;
}
void put32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = uint8_t(v >> (8 * i));
}
void put64(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = uint8_t(v >> (8 * i));
}

struct ChunkPos {
  size_t offset;  // of the 24-byte chunk header
  uint32_t type, geometry;
  uint64_t size;
};

std::vector<ChunkPos> chunks(const std::vector<uint8_t>& f) {
  std::vector<ChunkPos> out;
  size_t off = 32;
  while (off + 24 <= f.size()) {
    ChunkPos c{off, le32(&f[off]), le32(&f[off + 4]), le64(&f[off + 8])};
    out.push_back(c);
    off += 24 + ((c.size + 7) & ~uint64_t(7));
  }
  return out;
}

// Recomputes every chunk checksum, the file size and the header checksum: the result is "well-formed" except
// for whatever was changed on purpose.
void reseal(std::vector<uint8_t>& f, bool fixSize = true) {
  for (const ChunkPos& c : chunks(f)) {
    if (c.offset + 24 + c.size > f.size()) break;
    const uint64_t seed = XXH3_64bits(&f[c.offset], 16);
    put64(&f[c.offset + 16], XXH3_64bits_withSeed(&f[c.offset + 24], c.size, seed));
  }
  if (fixSize) put64(&f[16], f.size());
  put64(&f[24], XXH3_64bits(f.data(), 24));
}

const ChunkPos& find(const std::vector<ChunkPos>& cs, const char (&type)[5], uint32_t geometry = 0) {
  for (const ChunkPos& c : cs)
    if (c.type == sectionId(type) &&
        (c.type == sectionId("META") || c.type == sectionId("END ") || c.geometry == geometry))
      return c;
  ADD_FAILURE() << "no chunk " << type;
  return cs.front();
}

std::string parseError(const std::vector<uint8_t>& bytes) {
  auto r = parseSomm(bytes, "x.somm");
  if (r.ok()) return "";
  return r.error().message;
}

void expectRejected(const std::vector<uint8_t>& bytes, const std::string& needle) {
  const std::string m = parseError(bytes);
  ASSERT_FALSE(m.empty()) << "accepted a corrupt file, expected: " << needle;
  EXPECT_EQ(m.rfind("x.somm: ", 0), 0u) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  EXPECT_NE(m.find(needle), std::string::npos) << "message: " << m << "\nexpected to contain: " << needle;
}

// ---- round trips ----

TEST(SommFile, RoundTripIsByteExact) {
  const SommFile f = sampleFile(300, 7);
  const std::vector<uint8_t> bytes = serialize(f);
  ASSERT_EQ(bytes.size() % 8, 0u);
  auto back = parseSomm(bytes, "mem");
  ASSERT_TRUE(back.ok()) << back.error().message;
  expectEqual(f, *back);
  EXPECT_EQ(serialize(*back), bytes);
  // Deterministic: a second serialisation of the same input is identical.
  EXPECT_EQ(serialize(f), bytes);
}

TEST(SommFile, RoundTripEmptyFileAndLargeArrays) {
  SommFile empty;
  const auto eb = serialize(empty);
  auto e = parseSomm(eb, "mem");
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_TRUE(e->geometries.empty());
  EXPECT_EQ(serialize(*e), eb);

  // More than 0xfffb unique micromaps: a 32-bit index buffer.
  SommFile big;
  big.geometries.push_back(randomGeometry("big", 150000, Format::FourState, 3, 4, 99));
  ASSERT_GT(big.geometries[0].flat.descriptors.size(), 0xfffcu);
  ASSERT_EQ(big.geometries[0].flat.indexType(), IndexType::UInt32);
  const auto bytes = serialize(big);
  auto back = parseSomm(bytes, "mem");
  ASSERT_TRUE(back.ok()) << back.error().message;
  expectEqual(big, *back);
  EXPECT_EQ(serialize(*back), bytes);
}

TEST(SommFile, StatesSurviveTheRoundTrip) {
  std::vector<Micromap> maps;
  SommFile f;
  f.geometries.push_back(randomGeometry("g", 200, Format::FourState, 0, 5, 3, &maps));
  auto back = parseSomm(serialize(f), "mem");
  ASSERT_TRUE(back.ok());
  const OmmArray& a = back->geometries[0].flat;
  for (uint32_t t = 0; t < maps.size(); ++t)
    for (uint32_t i = 0; i < maps[t].size(); ++i) ASSERT_EQ(a.state(t, i), maps[t].get(i)) << t << " " << i;
}

TEST(SommFile, LayoutMatchesTheDocumentation) {
  SommFile f;
  f.sourcePath = "s";
  f.geometries.push_back(randomGeometry("g", 5, Format::TwoState, 1, 1, 4));
  const auto b = serialize(f);
  EXPECT_EQ(std::memcmp(b.data(), "SOMM\r\n\x1a\n", 8), 0);
  EXPECT_EQ(le32(&b[8]), 1u);
  EXPECT_EQ(le32(&b[12]), 0u);
  EXPECT_EQ(le64(&b[16]), b.size());
  EXPECT_EQ(le64(&b[24]), XXH3_64bits(b.data(), 24));
  const auto cs = chunks(b);
  ASSERT_EQ(cs.size(), 4u);
  EXPECT_EQ(cs[0].type, sectionId("META"));
  EXPECT_EQ(cs[0].geometry, 0xffffffffu);
  EXPECT_EQ(cs[1].type, sectionId("GEOM"));
  EXPECT_EQ(cs[2].type, sectionId("FLAT"));
  EXPECT_EQ(cs[3].type, sectionId("END "));
  EXPECT_EQ(cs[3].offset + 24, b.size());
  // FLAT: header, then descriptors, histograms, index buffer and data exactly as the OmmArray's spec buffers.
  const OmmArray& a = f.geometries[0].flat;
  const uint8_t* p = &b[cs[2].offset + 24];
  EXPECT_EQ(le32(p), 5u);
  EXPECT_EQ(le32(p + 4), a.descriptors.size());
  EXPECT_EQ(le32(p + 8), 2u);
  EXPECT_EQ(le64(p + 24), a.data.size());
  const auto desc = a.descriptorBytes();
  EXPECT_EQ(std::memcmp(p + 32, desc.data(), desc.size()), 0);
  const size_t histBytes = 12 * (a.histogram.size() + a.triangleHistogram.size());
  const auto idx = a.indexBufferBytes();
  EXPECT_EQ(std::memcmp(p + 32 + desc.size() + histBytes, idx.data(), idx.size()), 0);
  EXPECT_EQ(std::memcmp(p + 32 + desc.size() + histBytes + idx.size(), a.data.data(), a.data.size()), 0);
  EXPECT_EQ(cs[2].size, 32 + desc.size() + histBytes + idx.size() + a.data.size());
  EXPECT_EQ(sectionId("dfs "), 0x20736664u);
  EXPECT_EQ(sectionIdName(sectionId("dfs ")), "dfs");
}

// ---- the writer refuses inconsistent input ----

TEST(SommFile, WriterValidatesItsInput) {
  auto expectRefused = [](const std::function<void(SommFile&)>& edit, const std::string& needle) {
    SommFile f = sampleFile(30, 5);
    edit(f);
    auto r = serializeSomm(f);
    ASSERT_FALSE(r.ok()) << needle;
    EXPECT_NE(r.error().message.find(needle), std::string::npos) << r.error().message;
  };
  expectRefused([](SommFile& f) { f.geometries[0].flat.descriptors[0].subdivisionLevel = 13; }, "level 13");
  expectRefused([](SommFile& f) { f.geometries[0].flat.descriptors[0].format = 3; }, "format 3");
  expectRefused([](SommFile& f) { f.geometries[0].flat.descriptors[0].dataOffset = 1u << 30; },
                "extends past");
  expectRefused([](SommFile& f) { f.geometries[0].flat.indices[0] = -5; }, "index of triangle 0 is -5");
  expectRefused([](SommFile& f) { f.geometries[0].flat.indices.push_back(0); }, "triangle count 30");
  expectRefused([](SommFile& f) { f.geometries[0].flat.histogram.clear(); }, "usage histogram");
  expectRefused([](SommFile& f) { f.geometries[0].info.maxLevel = 13; }, "max level 13");
  expectRefused([](SommFile& f) { f.geometries[0].info.format = Format(3); }, "format 3");
  expectRefused([](SommFile& f) { f.geometries[1].info.format = Format::FourState; }, "geometry is format 2");
  expectRefused([](SommFile& f) { f.geometries[1].info.minLevel = 4; }, "outside the level range");
  expectRefused([](SommFile& f) { f.geometries[0].extra.push_back(f.geometries[0].extra[0]); },
                "stored twice");
  expectRefused([](SommFile& f) { f.geometries[0].info.stats.unknownMicroTriangles = ~0ull; }, "exceeds");
}

// ---- corruption ----

TEST(SommFile, EveryTruncationIsRejected) {
  const auto bytes = serialize(sampleFile(12, 2));
  for (size_t n = 0; n < bytes.size(); ++n) {
    const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + ptrdiff_t(n));
    const std::string m = parseError(cut);
    ASSERT_FALSE(m.empty()) << "accepted a file truncated to " << n << " bytes";
    EXPECT_EQ(m.rfind("x.somm: ", 0), 0u) << m;
  }
  // Truncation at each chunk boundary, with the header's size field patched to match (so the chunk walk must
  // notice).
  for (const ChunkPos& c : chunks(bytes)) {
    std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + ptrdiff_t(c.offset));
    reseal(cut);
    const std::string m = parseError(cut);
    ASSERT_FALSE(m.empty()) << "accepted a file cut before chunk at " << c.offset;
    EXPECT_TRUE(m.find("truncated") != std::string::npos || m.find("cannot fit") != std::string::npos ||
                m.find("has no 'FLAT' chunk") != std::string::npos)
        << m;
  }
}

TEST(SommFile, EveryBitFlipIsRejected) {
  const auto bytes = serialize(sampleFile(6, 3));
  ASSERT_LT(bytes.size(), 4000u);
  for (size_t i = 0; i < bytes.size(); ++i)
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<uint8_t> f = bytes;
      f[i] ^= uint8_t(1u << bit);
      const std::string m = parseError(f);
      ASSERT_FALSE(m.empty()) << "accepted a flip of bit " << bit << " of byte " << i;
    }
}

TEST(SommFile, RandomByteDamageIsRejectedInLargeFiles) {
  const auto bytes = serialize(sampleFile(3000, 11));
  std::mt19937 rng(5);
  for (int k = 0; k < 300; ++k) {
    std::vector<uint8_t> f = bytes;
    const size_t at = rng() % f.size();
    f[at] = uint8_t(f[at] + 1 + rng() % 255);
    ASSERT_FALSE(parseError(f).empty()) << "accepted damage at byte " << at;
    const size_t len = rng() % bytes.size();
    ASSERT_FALSE(parseError(std::vector<uint8_t>(bytes.begin(), bytes.begin() + ptrdiff_t(len))).empty())
        << len;
  }
}

TEST(SommFile, ForeignFilesAndVersions) {
  const auto good = serialize(sampleFile(5, 1));
  expectRejected({}, "not a .somm file");
  const std::string png = "\x89PNG\r\n\x1a\n and more bytes here to be long enough..";
  expectRejected(std::vector<uint8_t>(png.begin(), png.end()), "not a .somm file (bad magic)");
  expectRejected(std::vector<uint8_t>(good.begin(), good.begin() + 5), "truncated");
  auto f = good;
  put32(&f[8], 2);
  reseal(f);
  expectRejected(f, ".somm version 2 is not supported");
  f = good;
  put32(&f[8], 0);
  expectRejected(f, "version 0");
  f = good;
  put32(&f[12], 1);
  reseal(f);
  expectRejected(f, "unknown header flags");
  f = good;
  f.push_back(0);
  expectRejected(f, "1 unexpected bytes after the declared end");  // size in the header no longer matches
  f = good;
  f.resize(f.size() - 8);
  expectRejected(f, "truncated: the header declares");
  f = good;
  for (int i = 0; i < 8; ++i) f.push_back(0);
  reseal(f);
  expectRejected(f, "unexpected bytes after the 'END' chunk");
}

// Changes one field, reseals all checksums and expects `needle` in the message.
void craft(const std::function<void(std::vector<uint8_t>&, const std::vector<ChunkPos>&)>& edit,
           const std::string& needle, uint32_t triangles = 30) {
  auto f = serialize(sampleFile(triangles, 4));
  const auto cs = chunks(f);
  edit(f, cs);
  reseal(f);
  expectRejected(f, needle);
}

constexpr size_t P = 24;  // payload offset within a chunk

TEST(SommFile, CraftedInconsistenciesAreRejected) {
  // FLAT header fields.
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "FLAT").offset + P], 0xffffffffu); }, "need");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "FLAT").offset + P + 4], 0x7fffffffu); }, "need");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "FLAT").offset + P + 8], 3); }, "index type 3");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "FLAT").offset + P + 12], 0xfffffff0u); }, "need");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "FLAT").offset + P + 20], 1); }, "reserved");
  craft([](auto& f, auto& cs) { put64(&f[find(cs, "FLAT").offset + P + 24], ~0ull); }, "data size");
  // Descriptors: level 13, format 3, offset out of the data, offset + size just past the end.
  craft([](auto& f, auto& cs) { f[find(cs, "FLAT").offset + P + 32 + 4] = 13; },
        "level 13 (must be at most 12)");
  craft([](auto& f, auto& cs) { f[find(cs, "FLAT").offset + P + 32 + 6] = 3; }, "format 3 (must be 1 or 2)");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "FLAT").offset + P + 32], 0xfffffff0u); }, "extends past");
  craft(
      [](auto& f, auto& cs) {
        const uint8_t* p = &f[find(cs, "FLAT").offset + P];
        const uint64_t data = le64(p + 24);
        const uint32_t level = p[32 + 4];
        const uint32_t need = micromapDataBytes(level, Format(p[32 + 6]));
        put32(&f[find(cs, "FLAT").offset + P + 32], uint32_t(data - need + 1));
      },
      "extends past");
  // Histogram entry changed.
  craft(
      [](auto& f, auto& cs) {
        const uint8_t* p = &f[find(cs, "FLAT").offset + P];
        const size_t at = 32 + 8 * size_t(le32(p + 4));
        put32(&f[find(cs, "FLAT").offset + P + at], le32(p + at) + 1);
      },
      "usage histogram does not match");
  // Index buffer: a descriptor index out of range (16-bit buffer).
  craft(
      [](auto& f, auto& cs) {
        uint8_t* p = &f[find(cs, "FLAT").offset + P];
        const size_t at = 32 + 8 * size_t(le32(p + 4)) + 12 * size_t(le32(p + 12) + le32(p + 16));
        p[at] = 0xf0;
        p[at + 1] = 0xff;
      },
      "index of triangle 0 is 65520");
  // GEOM fields: triangle count, format, levels, filter, wrap, stats.
  auto geomFixed = [](std::vector<uint8_t>& f, const std::vector<ChunkPos>& cs) -> uint8_t* {
    uint8_t* p = &f[find(cs, "GEOM").offset + P];
    const uint32_t nameLen = le32(p);
    const uint32_t matLen = le32(p + 4 + nameLen);
    return p + 8 + nameLen + matLen;  // triangle count
  };
  craft([&](auto& f, auto& cs) { put32(geomFixed(f, cs), 31); }, "triangle count 31");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[4] = 3; }, "format 3 is not 1 or 2");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[6] = 13; }, "max level 13");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[5] = 3, geomFixed(f, cs)[6] = 2; }, "is empty");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[7] = 2; }, "filter 2");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[8] = 3; }, "wrap mode");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[10] = 1; }, "reserved");
  craft([&](auto& f, auto& cs) { put64(geomFixed(f, cs) + 28, ~0ull); }, "exceeds the micro-triangle count");
  // Absurd string length.
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "GEOM").offset + P], 0xfffffff0u); }, "string length");
  // META: absurd geometry and option counts, wrong geometry count.
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "META").offset + P], 0xffffffffu); },
        "geometries cannot fit");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "META").offset + P], 2); },
        "more geometries than the 2 declared");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "META").offset + P], 4); }, "only 3 of 4");
  craft(
      [](auto& f, auto& cs) {
        uint8_t* p = &f[find(cs, "META").offset + P];
        const size_t at = 4 + 4 + le32(p + 4);
        const size_t at2 = at + 4 + le32(p + at);
        put32(p + at2, 0x40000000u);
      },
      "bake options cannot fit");
  // Chunk headers: unknown type, wrong geometry, ENCD before FLAT, duplicate ENCD id, reserved ENCD field.
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "ENCD").offset], sectionId("ZZZZ")); },
        "unknown chunk type");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "FLAT").offset + 4], 1); }, "does not follow");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "GEOM", 1).offset + 4], 2); }, "expected geometry 1");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "END ").offset], sectionId("META")); }, "a second 'META'");
  craft(
      [](auto& f, auto& cs) {
        const ChunkPos& a = cs[3];  // first ENCD of geometry 0 ("dfs ")
        const ChunkPos& b = cs[4];  // second ENCD of geometry 0 ("rank")
        ASSERT_EQ(a.type, sectionId("ENCD"));
        ASSERT_EQ(b.type, sectionId("ENCD"));
        put32(&f[b.offset + P], le32(&f[a.offset + P]));
      },
      "stored twice");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "ENCD").offset + P + 4], 9); }, "reserved field is not 0");
  // A 16-bit index buffer that could be 32-bit is fine; the reverse (a wider buffer than needed) is not
  // canonical.
  {
    SommFile s;
    s.geometries.push_back(randomGeometry("g", 4, Format::FourState, 1, 1, 2));
    auto f = serialize(s);
    const auto cs = chunks(f);
    const ChunkPos& fl = find(cs, "FLAT");
    uint8_t* p = &f[fl.offset + P];
    const size_t idxAt = 32 + 8 * size_t(le32(p + 4)) + 12 * size_t(le32(p + 12) + le32(p + 16));
    std::vector<uint8_t> payload(p, p + fl.size);
    std::vector<uint8_t> wide(payload.begin(), payload.begin() + ptrdiff_t(idxAt));
    put32(&wide[8], 4);
    for (uint32_t t = 0; t < 4; ++t) {
      const uint16_t v = uint16_t(payload[idxAt + 2 * t] | payload[idxAt + 2 * t + 1] << 8);
      const uint32_t w = v >= 0xfffc ? 0xffff0000u | v : v;
      for (int k = 0; k < 4; ++k) wide.push_back(uint8_t(w >> (8 * k)));
    }
    wide.insert(wide.end(), payload.begin() + ptrdiff_t(idxAt + 8), payload.end());
    std::vector<uint8_t> g(f.begin(), f.begin() + ptrdiff_t(fl.offset + P));
    put64(&g[fl.offset + 8], wide.size());
    g.insert(g.end(), wide.begin(), wide.end());
    while (g.size() % 8) g.push_back(0);
    g.insert(g.end(), f.end() - 24, f.end());  // END
    reseal(g);
    expectRejected(g, "not the narrowest");
  }
  // Non-zero padding after a payload.
  craft(
      [](auto& f, auto& cs) {
        const ChunkPos& e = find(cs, "ENCD");  // 8 + 5 bytes: three padding bytes
        ASSERT_NE(e.size % 8, 0u);
        f[e.offset + P + e.size] = 1;
      },
      "non-zero padding");
}

// ---- files on disk ----

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    path = std::filesystem::temp_directory_path() /
           ("somm_file_test_" + std::to_string(::getpid()) + "_" + std::to_string(std::random_device{}()));
    std::filesystem::create_directories(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  size_t entries() const {
    size_t n = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(path)) ++n;
    return n;
  }
};

TEST(SommFile, WriteAndReadFiles) {
  TempDir dir;
  const std::string p = (dir.path / "out.somm").string();
  const SommFile f = sampleFile(50, 9);
  ASSERT_TRUE(writeSommFile(p, f).ok());
  auto back = readSommFile(p);
  ASSERT_TRUE(back.ok()) << back.error().message;
  expectEqual(f, *back);
  EXPECT_EQ(dir.entries(), 1u);  // no temporary file left behind
  // Overwriting works and is atomic: replace with a different file.
  const SommFile g = sampleFile(10, 3);
  ASSERT_TRUE(writeSommFile(p, g).ok());
  expectEqual(g, *readSommFile(p));
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(SommFile, FailedWritesLeaveNothingBehind) {
  TempDir dir;
  const std::string p = (dir.path / "out.somm").string();
  const SommFile f = sampleFile(20, 1);
  ASSERT_TRUE(writeSommFile(p, f).ok());
  const auto before = readWholeFile(p);
  ASSERT_TRUE(before.ok());
  SommFile bad = f;
  bad.geometries[0].flat.descriptors[0].subdivisionLevel = 13;
  auto s = writeSommFile(p, bad);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message.rfind(p + ": not written: ", 0), 0u) << s.error().message;
  EXPECT_EQ(*readWholeFile(p), *before);  // untouched
  EXPECT_EQ(dir.entries(), 1u);
  // Unwritable destinations.
  const std::string missing = (dir.path / "no" / "such" / "dir.somm").string();
  s = writeSommFile(missing, f);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message.rfind(missing + ": ", 0), 0u) << s.error().message;
  s = writeSommFile(dir.path.string(), f);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("is a directory"), std::string::npos) << s.error().message;
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(SommFile, ReadErrorsNameTheFile) {
  TempDir dir;
  const std::string p = (dir.path / "missing.somm").string();
  auto r = readSommFile(p);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::IoError);
  EXPECT_EQ(r.error().message.rfind(p + ": cannot open", 0), 0u) << r.error().message;
  r = readSommFile(dir.path.string());
  ASSERT_FALSE(r.ok());
  const std::string q = (dir.path / "cut.somm").string();
  auto bytes = serialize(sampleFile(10, 1));
  bytes.resize(bytes.size() - 3);
  ASSERT_TRUE(writeFileAtomically(q, bytes).ok());
  r = readSommFile(q);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::CorruptFile);
  EXPECT_EQ(r.error().message.rfind(q + ": truncated", 0), 0u) << r.error().message;
}

}  // namespace
}  // namespace somm
