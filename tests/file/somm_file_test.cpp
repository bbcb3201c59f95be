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

using testing::Layout;
using testing::randomGeometry;
using testing::sampleFile;
using testing::singleGeometryFile;

std::vector<uint8_t> serialize(const SommFile& f) {
  auto r = serializeSomm(f);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? *r : std::vector<uint8_t>{};
}

void expectEqual(const SommFile& a, const SommFile& b) {
  EXPECT_EQ(a.sourcePath, b.sourcePath);
  EXPECT_EQ(a.toolVersion, b.toolVersion);
  EXPECT_EQ(a.bakeOptions, b.bakeOptions);
  EXPECT_EQ(a.geometries, b.geometries);
  EXPECT_EQ(a.micromaps.geometries, b.micromaps.geometries);
  ASSERT_EQ(a.micromaps.arrays.size(), b.micromaps.arrays.size());
  for (size_t i = 0; i < a.micromaps.arrays.size(); ++i) {
    const OmmArray &x = a.micromaps.arrays[i], &y = b.micromaps.arrays[i];
    EXPECT_EQ(x.data, y.data);
    EXPECT_EQ(x.descriptors, y.descriptors);
    EXPECT_EQ(x.indices, y.indices);
    EXPECT_EQ(x.histogram, y.histogram);
    EXPECT_EQ(x.triangleHistogram, y.triangleHistogram);
  }
  EXPECT_EQ(a.encodings, b.encodings);
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
  for (Layout layout : {Layout::Scene, Layout::PerGeometry}) {
    const SommFile f = sampleFile(300, 7, layout);
    ASSERT_EQ(f.micromaps.arrays.size(), layout == Layout::Scene ? 1u : 3u);
    const std::vector<uint8_t> bytes = serialize(f);
    ASSERT_EQ(bytes.size() % 8, 0u);
    EXPECT_EQ(le32(&bytes[8]), 2u);
    auto back = parseSomm(bytes, "mem");
    ASSERT_TRUE(back.ok()) << back.error().message;
    expectEqual(f, *back);
    EXPECT_EQ(serialize(*back), bytes);
    // Deterministic: a second serialisation of the same input is identical.
    EXPECT_EQ(serialize(f), bytes);
  }
}

TEST(SommFile, RoundTripEmptyFileAndLargeArrays) {
  SommFile empty;
  const auto eb = serialize(empty);
  auto e = parseSomm(eb, "mem");
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_TRUE(e->geometries.empty());
  EXPECT_EQ(serialize(*e), eb);

  // More than 0xfffb unique micromaps: a 32-bit index buffer.
  SommFile big = singleGeometryFile(randomGeometry("big", 150000, Format::FourState, 3, 4, 99));
  ASSERT_GT(big.micromaps.arrays[0].descriptors.size(), 0xfffcu);
  ASSERT_EQ(big.micromaps.arrays[0].indexType(), IndexType::UInt32);
  const auto bytes = serialize(big);
  auto back = parseSomm(bytes, "mem");
  ASSERT_TRUE(back.ok()) << back.error().message;
  expectEqual(big, *back);
  EXPECT_EQ(serialize(*back), bytes);
}

TEST(SommFile, StatesSurviveTheRoundTrip) {
  std::vector<Micromap> maps;
  const SommFile f = singleGeometryFile(randomGeometry("g", 200, Format::FourState, 0, 5, 3, &maps));
  auto back = parseSomm(serialize(f), "mem");
  ASSERT_TRUE(back.ok());
  const OmmArray& a = back->micromaps.arrays[0];
  for (uint32_t t = 0; t < maps.size(); ++t)
    for (uint32_t i = 0; i < maps[t].size(); ++i) ASSERT_EQ(a.state(t, i), maps[t].get(i)) << t << " " << i;
}

// Several geometries in one scene-wide array: each geometry's states are its own maps', at its own triangle numbers.
TEST(SommFile, SceneArrayStatesPerGeometry) {
  std::vector<std::vector<Micromap>> maps(4);
  std::vector<testing::TestGeometry> geos;
  for (uint32_t g = 0; g < 4; ++g)
    geos.push_back(
        randomGeometry("g" + std::to_string(g), 60 + 10 * g, Format::FourState, 0, 4, 20 + g % 2, &maps[g]));
  const SommFile f = testing::makeFile(geos, Layout::Scene);
  auto back = parseSomm(serialize(f), "mem");
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->micromaps.arrays.size(), 1u);
  // Geometries 0/2 and 1/3 were made from the same seeds: their maps are stored once.
  uint64_t perGeometryMaps = 0;
  for (const auto& g : geos) perGeometryMaps += g.flat.descriptors.size();
  EXPECT_LT(back->micromaps.arrays[0].descriptors.size(), perGeometryMaps);
  for (uint32_t g = 0; g < 4; ++g) {
    EXPECT_EQ(back->micromaps.geometries[g].triangleCount, maps[g].size());
    for (uint32_t t = 0; t < maps[g].size(); ++t)
      for (uint32_t i = 0; i < maps[g][t].size(); ++i)
        ASSERT_EQ(back->micromaps.state(g, t, i), maps[g][t].get(i)) << g << " " << t << " " << i;
  }
}

TEST(SommFile, LayoutMatchesTheDocumentation) {
  SommFile f = singleGeometryFile(randomGeometry("g", 5, Format::TwoState, 1, 1, 4));
  f.sourcePath = "s";
  const auto b = serialize(f);
  EXPECT_EQ(std::memcmp(b.data(), "SOMM\r\n\x1a\n", 8), 0);
  EXPECT_EQ(le32(&b[8]), 2u);
  EXPECT_EQ(le32(&b[12]), 0u);
  EXPECT_EQ(le64(&b[16]), b.size());
  EXPECT_EQ(le64(&b[24]), XXH3_64bits(b.data(), 24));
  const auto cs = chunks(b);
  ASSERT_EQ(cs.size(), 4u);
  EXPECT_EQ(cs[0].type, sectionId("META"));
  EXPECT_EQ(cs[0].geometry, 0xffffffffu);
  EXPECT_EQ(le32(&b[cs[0].offset + 24]), 1u);      // geometries
  EXPECT_EQ(le32(&b[cs[0].offset + 24 + 4]), 1u);  // arrays
  EXPECT_EQ(cs[1].type, sectionId("GEOM"));
  EXPECT_EQ(cs[2].type, sectionId("FLAT"));
  EXPECT_EQ(cs[2].geometry, 0u);  // the array index
  EXPECT_EQ(cs[3].type, sectionId("END "));
  EXPECT_EQ(cs[3].offset + 24, b.size());
  // GEOM: name, material, triangle count, array, first triangle, format.
  const uint8_t* g = &b[cs[1].offset + 24];
  const uint32_t nameLen = le32(g), matLen = le32(g + 4 + nameLen);
  const uint8_t* fixed = g + 8 + nameLen + matLen;
  EXPECT_EQ(le32(fixed), 5u);
  EXPECT_EQ(le32(fixed + 4), 0u);
  EXPECT_EQ(le32(fixed + 8), 0u);
  EXPECT_EQ(fixed[12], 1u);
  EXPECT_EQ(cs[1].size, 8 + nameLen + matLen + 52);
  // FLAT: header, then descriptors, histograms, index buffer and data exactly as the OmmArray's spec buffers.
  const OmmArray& a = f.micromaps.arrays[0];
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

  // The scene-wide sample: META, GEOM × 3, FLAT of array 0 with its three ENCD chunks, END.
  const auto s = serialize(sampleFile(8, 2));
  std::vector<uint32_t> types;
  for (const ChunkPos& c : chunks(s)) types.push_back(c.type);
  EXPECT_EQ(types, (std::vector<uint32_t>{sectionId("META"), sectionId("GEOM"), sectionId("GEOM"),
                                          sectionId("GEOM"), sectionId("FLAT"), sectionId("ENCD"),
                                          sectionId("ENCD"), sectionId("ENCD"), sectionId("END ")}));
}

// ---- version 1 (one array per geometry, chunks META (GEOM FLAT ENCD*)* END) is still read ----

// An independent version-1 writer following docs/somm-format.md ("Version 1").
std::vector<uint8_t> writeV1(const SommFile& f) {
  std::vector<uint8_t> out;
  auto u8 = [](std::vector<uint8_t>& o, uint8_t v) { o.push_back(v); };
  auto u32 = [](std::vector<uint8_t>& o, uint32_t v) {
    for (int i = 0; i < 4; ++i) o.push_back(uint8_t(v >> (8 * i)));
  };
  auto u64 = [](std::vector<uint8_t>& o, uint64_t v) {
    for (int i = 0; i < 8; ++i) o.push_back(uint8_t(v >> (8 * i)));
  };
  auto str = [&](std::vector<uint8_t>& o, const std::string& s) {
    u32(o, uint32_t(s.size()));
    o.insert(o.end(), s.begin(), s.end());
  };
  auto chunk = [&](uint32_t type, uint32_t index, const std::vector<uint8_t>& payload) {
    const size_t at = out.size();
    u32(out, type);
    u32(out, index);
    u64(out, payload.size());
    u64(out, 0);
    out.insert(out.end(), payload.begin(), payload.end());
    put64(&out[at + 16], XXH3_64bits_withSeed(payload.data(), payload.size(), XXH3_64bits(&out[at], 16)));
    while (out.size() % 8) out.push_back(0);
  };
  for (uint8_t c : {'S', 'O', 'M', 'M', '\r', '\n', '\x1a', '\n'}) out.push_back(c);
  u32(out, 1);
  u32(out, 0);
  u64(out, 0);
  u64(out, 0);
  std::vector<uint8_t> meta;
  u32(meta, uint32_t(f.geometries.size()));
  str(meta, f.sourcePath);
  str(meta, f.toolVersion);
  u32(meta, uint32_t(f.bakeOptions.size()));
  for (const auto& [k, v] : f.bakeOptions) str(meta, k), str(meta, v);
  chunk(sectionId("META"), 0xffffffffu, meta);
  for (uint32_t g = 0; g < f.geometries.size(); ++g) {
    const GeometryInfo& in = f.geometries[g];
    std::vector<uint8_t> p;
    str(p, in.name);
    str(p, in.material);
    u32(p, in.triangleCount);
    for (uint32_t v : {uint32_t(in.format), in.minLevel, in.maxLevel, uint32_t(in.sampler.filter),
                       uint32_t(in.sampler.wrapS), uint32_t(in.sampler.wrapT), 0u, 0u})
      u8(p, uint8_t(v));
    uint32_t cutoff;
    std::memcpy(&cutoff, &in.cutoff, 4);
    u32(p, cutoff);
    u32(p, 0);
    u64(p, in.stats.microTriangles);
    u64(p, in.stats.unknownMicroTriangles);
    u64(p, in.stats.invalidUvTriangles);
    chunk(sectionId("GEOM"), g, p);
    const OmmArray& a = f.micromaps.arrays[f.micromaps.geometries[g].array];
    std::vector<uint8_t> fl;
    for (uint32_t v : {uint32_t(a.indices.size()), uint32_t(a.descriptors.size()), uint32_t(a.indexType()),
                       uint32_t(a.histogram.size()), uint32_t(a.triangleHistogram.size()), 0u})
      u32(fl, v);
    u64(fl, a.data.size());
    const auto d = a.descriptorBytes(), i = a.indexBufferBytes();
    fl.insert(fl.end(), d.begin(), d.end());
    for (const auto* h : {&a.histogram, &a.triangleHistogram})
      for (const UsageCount& c : *h) u32(fl, c.count), u32(fl, c.subdivisionLevel), u32(fl, c.format);
    fl.insert(fl.end(), i.begin(), i.end());
    fl.insert(fl.end(), a.data.begin(), a.data.end());
    chunk(sectionId("FLAT"), g, fl);
    for (const EncodedSection& e : f.encodings[f.micromaps.geometries[g].array]) {
      std::vector<uint8_t> p2;
      u32(p2, e.id);
      u32(p2, 0);
      p2.insert(p2.end(), e.bytes.begin(), e.bytes.end());
      chunk(sectionId("ENCD"), g, p2);
    }
  }
  chunk(sectionId("END "), 0xffffffffu, {});
  put64(&out[16], out.size());
  put64(&out[24], XXH3_64bits(out.data(), 24));
  return out;
}

TEST(SommFile, Version1IsReadAsOneArrayPerGeometry) {
  const SommFile f = sampleFile(100, 12, Layout::PerGeometry);
  const auto v1 = writeV1(f);
  auto back = parseSomm(v1, "old.somm");
  ASSERT_TRUE(back.ok()) << back.error().message;
  expectEqual(f, *back);  // same arrays, placements GeometryMicromaps{g, 0, triangles}, encodings per array
  for (uint32_t g = 0; g < 3; ++g)
    EXPECT_EQ(back->micromaps.geometries[g], (GeometryMicromaps{g, 0, f.geometries[g].triangleCount}));
  // Rewritten as version 2, then read back the same.
  auto again = parseSomm(serialize(*back), "new.somm");
  ASSERT_TRUE(again.ok());
  expectEqual(f, *again);
  // Version-1 damage is still found: every truncation, and a wrong triangle count.
  for (size_t n = 0; n < v1.size(); n += 7)
    EXPECT_FALSE(parseError(std::vector<uint8_t>(v1.begin(), v1.begin() + ptrdiff_t(n))).empty()) << n;
  auto bad = v1;
  const auto cs = chunks(bad);
  uint8_t* g = &bad[find(cs, "GEOM").offset + 24];
  put32(g + 8 + le32(g) + le32(g + 4 + le32(g)), 101);
  reseal(bad);
  expectRejected(bad, "triangle count 101 but the index buffer has 100 entries");
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
  auto arr = [](SommFile& f) -> OmmArray& { return f.micromaps.arrays[0]; };
  expectRefused([&](SommFile& f) { arr(f).descriptors[0].subdivisionLevel = 13; }, "level 13");
  expectRefused([&](SommFile& f) { arr(f).descriptors[0].format = 3; }, "format 3");
  expectRefused([&](SommFile& f) { arr(f).descriptors[0].dataOffset = 1u << 30; }, "extends past");
  expectRefused([&](SommFile& f) { arr(f).indices[0] = -5; }, "index of triangle 0 is -5");
  expectRefused([&](SommFile& f) { arr(f).indices.push_back(-1); },
                "its geometries cover 60 triangles but its index buffer has 61");
  expectRefused([&](SommFile& f) { arr(f).histogram.clear(); }, "usage histogram");
  expectRefused([](SommFile& f) { f.geometries[0].maxLevel = 13; }, "max level 13");
  expectRefused([](SommFile& f) { f.geometries[0].format = Format(3); }, "format 3");
  expectRefused([](SommFile& f) { f.geometries[1].format = Format::FourState; }, "geometry is format 2");
  expectRefused([](SommFile& f) { f.geometries[1].minLevel = 4; }, "outside the level range");
  expectRefused([](SommFile& f) { f.encodings[0].push_back(f.encodings[0][0]); }, "stored twice");
  expectRefused([](SommFile& f) { f.geometries[0].stats.unknownMicroTriangles = ~0ull; }, "exceeds");
  expectRefused([](SommFile& f) { f.geometries[0].triangleCount = 31; }, "but its micromaps cover 30");
  expectRefused([](SommFile& f) { f.micromaps.geometries[1].array = 1; }, "array 1 does not exist");
  expectRefused([](SommFile& f) { f.micromaps.geometries[1].firstTriangle = 29; }, "expected 30");
  expectRefused([](SommFile& f) { std::swap(f.micromaps.geometries[0], f.micromaps.geometries[1]); },
                "tile its index buffer in geometry order");
  expectRefused([](SommFile& f) { f.encodings.clear(); }, "1 arrays but encodings for 0");
  expectRefused([](SommFile& f) { f.micromaps.geometries.pop_back(); }, "3 geometries but micromaps for 2");
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
  put32(&f[8], 3);
  reseal(f);
  expectRejected(f, ".somm version 3 is not supported (this build reads versions 1 and 2)");
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
  // Geometry 1 then starts at triangle 30 of the array where 31 are taken.
  craft([&](auto& f, auto& cs) { put32(geomFixed(f, cs), 31); },
        "starts at triangle 30 of array 0, expected 31");
  craft([&](auto& f, auto& cs) { put32(geomFixed(f, cs) + 4, 5); }, "array 5 does not exist (1 arrays)");
  craft([&](auto& f, auto& cs) { put32(geomFixed(f, cs) + 8, 2); },
        "starts at triangle 2 of array 0, expected 0");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[12] = 3; }, "format 3 is not 1 or 2");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[14] = 13; }, "max level 13");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[13] = 3, geomFixed(f, cs)[14] = 2; }, "is empty");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[15] = 2; }, "filter 2");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[16] = 3; }, "wrap mode");
  craft([&](auto& f, auto& cs) { geomFixed(f, cs)[18] = 1; }, "reserved");
  craft([&](auto& f, auto& cs) { put64(geomFixed(f, cs) + 36, ~0ull); }, "exceeds the micro-triangle count");
  // The last geometry of the array claims more triangles than the array holds.
  craft(
      [](auto& f, auto& cs) {
        uint8_t* p = &f[find(cs, "GEOM", 2).offset + P];
        put32(p + 8 + le32(p) + le32(p + 4 + le32(p)), 1);
      },
      "its geometries cover 61 triangles but its index buffer has 60");
  // A geometry whose level range excludes a map it uses (the array itself is valid).
  craft(
      [](auto& f, auto& cs) {
        uint8_t* p = &f[find(cs, "GEOM", 1).offset + P];
        p[8 + le32(p) + le32(p + 4 + le32(p)) + 14] = 1;  // bark: levels 1..1, its maps are 1..4
      },
      "outside the level range 1..1");
  // Absurd string length.
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "GEOM").offset + P], 0xfffffff0u); }, "string length");
  // META: absurd geometry and option counts, wrong geometry count.
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "META").offset + P], 0xffffffffu); },
        "geometries cannot fit");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "META").offset + P], 2); },
        "more geometries than the 2 declared");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "META").offset + P], 4); },
        "only 3 of 4 declared geometries precede the arrays");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "META").offset + P + 4], 0xffffffffu); },
        "arrays cannot fit");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "META").offset + P + 4], 2); },
        "only 1 of 2 declared arrays");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "META").offset + P + 4], 0); }, "array 0 does not exist");
  craft(
      [](auto& f, auto& cs) {
        uint8_t* p = &f[find(cs, "META").offset + P];
        const size_t at = 8 + 4 + le32(p + 8);
        const size_t at2 = at + 4 + le32(p + at);
        put32(p + at2, 0x40000000u);
      },
      "bake options cannot fit");
  // Chunk headers: unknown type, wrong geometry, ENCD before FLAT, duplicate ENCD id, reserved ENCD field.
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "ENCD").offset], sectionId("ZZZZ")); },
        "unknown chunk type");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "FLAT").offset + 4], 1); }, "expected array 0");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "ENCD").offset + 4], 1); },
        "does not follow the 'FLAT' chunk of its array");
  // A GEOM chunk after the arrays: the last ENCD renamed.
  craft([](auto& f, auto& cs) { put32(&f[cs[cs.size() - 2].offset], sectionId("GEOM")); },
        "more geometries than the 3 declared");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "GEOM", 1).offset + 4], 2); }, "expected geometry 1");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "END ").offset], sectionId("META")); }, "a second 'META'");
  craft(
      [](auto& f, auto& cs) {
        const ChunkPos& a = cs[5];  // first ENCD of array 0 ("dfs ")
        const ChunkPos& b = cs[6];  // second ENCD of array 0 ("rank")
        ASSERT_EQ(a.type, sectionId("ENCD"));
        ASSERT_EQ(b.type, sectionId("ENCD"));
        put32(&f[b.offset + P], le32(&f[a.offset + P]));
      },
      "stored twice");
  craft([](auto& f, auto& cs) { put32(&f[find(cs, "ENCD").offset + P + 4], 9); }, "reserved field is not 0");
  // A 16-bit index buffer that could be 32-bit is fine; the reverse (a wider buffer than needed) is not
  // canonical.
  {
    auto f = serialize(singleGeometryFile(randomGeometry("g", 4, Format::FourState, 1, 1, 2)));
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
  bad.micromaps.arrays[0].descriptors[0].subdivisionLevel = 13;
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
