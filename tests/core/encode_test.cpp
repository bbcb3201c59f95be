// SPDX-License-Identifier: MIT
// Every encoding against the flat micromap oracle (one typed suite), sizes against the documented formulas,
// round trips, and the validating parser against corrupt bytes.
#include "somm/encode.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <map>
#include <random>
#include <span>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "packed_index_oracle.h"
#include "somm/omm_array.h"
#include "somm_test_arrays.h"

namespace somm {
namespace {

enum class Pattern { Uniform, HalfHalf, Checker, Random, Disc, Leaf };
constexpr Pattern kPatterns[] = {Pattern::Uniform, Pattern::HalfHalf, Pattern::Checker,
                                 Pattern::Random,  Pattern::Disc,     Pattern::Leaf};

const char* patternName(Pattern p) {
  switch (p) {
    case Pattern::Uniform:
      return "uniform";
    case Pattern::HalfHalf:
      return "half";
    case Pattern::Checker:
      return "checker";
    case Pattern::Random:
      return "random";
    case Pattern::Disc:
      return "disc";
    case Pattern::Leaf:
      return "leaf";
  }
  return "?";
}

// Signed "inside" measure of a leaf silhouette in barycentric space: an ellipse along the diagonal, minus a
// notch, with thin transparent veins. > 0 inside, small |.| near the edge.
double leafField(double u, double v) {
  const double cx = 0.36, cy = 0.3, a = 0.3, b = 0.14, c = std::cos(0.7), s = std::sin(0.7);
  const double x = (u - cx) * c + (v - cy) * s, y = -(u - cx) * s + (v - cy) * c;
  double f = 1.0 - (x * x) / (a * a) - (y * y) / (b * b);
  if (std::abs(y) < 0.006 || std::abs(y - 0.5 * x) < 0.004) f = std::min(f, -0.01);  // veins
  if (x > 0.22 && std::abs(y) < 0.03) f = -1.0;                                      // notch at the tip
  return f;
}

Micromap makeMap(Pattern p, uint32_t level, Format f, uint32_t seed) {
  Micromap m(level, f);
  std::mt19937 rng(seed * 7919u + level * 31u + uint32_t(f));
  const bool four = f == Format::FourState;
  const double scale = 1.0 / double(1u << level);
  for (uint32_t i = 0; i < m.size(); ++i) {
    State s = State::Transparent;
    switch (p) {
      case Pattern::Uniform:
        s = four ? State::UnknownOpaque : State::Opaque;
        break;
      case Pattern::HalfHalf:
        s = i < m.size() / 2 ? State::Opaque : (four ? State::UnknownTransparent : State::Transparent);
        break;
      case Pattern::Checker:
        s = four ? State(i & 3u) : State(i & 1u);
        break;
      case Pattern::Random:
        s = State(rng() & (four ? 3u : 1u));
        break;
      case Pattern::Disc:
      case Pattern::Leaf: {
        const MicroTriangle t = indexToMicroTriangle(i, level);
        const double u = (t.v[0].u + t.v[1].u + t.v[2].u) * scale / 3.0;
        const double v = (t.v[0].v + t.v[1].v + t.v[2].v) * scale / 3.0;
        double field;
        if (p == Pattern::Disc) {
          const double du = u - 0.33, dv = v - 0.36;
          field = 0.28 * 0.28 - du * du - dv * dv;
        } else {
          field = leafField(u, v) * 0.05;
        }
        s = field > 0 ? State::Opaque : State::Transparent;
        if (four && std::abs(field) < 0.35 * scale)
          s = field > 0 ? State::UnknownOpaque : State::UnknownTransparent;
        break;
      }
    }
    m.set(i, s);
  }
  return m;
}

// Maps at levels 9..12 are costly to generate: shared by every encoding's tests.
const Micromap& cachedMap(Pattern p, uint32_t level, Format f, uint32_t seed) {
  static std::map<std::tuple<int, uint32_t, int, uint32_t>, Micromap> cache;
  const auto key = std::make_tuple(int(p), level, int(f), seed);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, makeMap(p, level, f, seed)).first;
  return it->second;
}

// An OmmArray holding `maps` verbatim (uniform maps too), contiguous, plus the four special indices.
OmmArray arrayOf(const std::vector<Micromap>& maps) {
  OmmArray a;
  for (size_t k = 0; k < maps.size(); ++k) {
    a.descriptors.push_back(
        TriangleDescriptor{uint32_t(a.data.size()), uint16_t(maps[k].level()), uint16_t(maps[k].format())});
    a.data.insert(a.data.end(), maps[k].bytes().begin(), maps[k].bytes().end());
    a.indices.push_back(int32_t(k));
  }
  for (int32_t s = -1; s >= -4; --s) a.indices.push_back(s);
  return a;
}

using somm::testing::packedIndexBufferBytes;

// Internal nodes of the collapsed tree, counted by brute force from the flat map (independent of the
// encoder).
encode::TreeShape bruteShape(const Micromap& m) {
  encode::TreeShape s;
  for (uint32_t d = 0; d < m.level(); ++d) {
    const uint32_t span = 1u << (2 * (m.level() - d));
    for (uint32_t start = 0; start < m.size(); start += span) {
      bool uniform = true;
      for (uint32_t i = start + 1; i < start + span && uniform; ++i) uniform = m.get(i) == m.get(start);
      if (!uniform) {
        ++s.internal;
        if (d + 1 == m.level()) ++s.internalAboveLast;
      }
    }
  }
  return s;
}

uint64_t formulaBytes(MapKind k, const Micromap& m) {
  const encode::TreeShape s = bruteShape(m);
  switch (k) {
    case MapKind::Flat:
      return encode::flatMapBytes(m.level(), m.format());
    case MapKind::Dfs:
      return encode::dfsMapBytes(m.level(), m.format(), s);
    case MapKind::Rank:
      return encode::rankMapBytes(m.level(), m.format(), s);
    case MapKind::Csm:
    case MapKind::Sdag:
      break;
  }
  return 0;
}

MapKind baseKind(Encoding e) {
  switch (e) {
    case Encoding::Dfs:
    case Encoding::DfsFast:
      return MapKind::Dfs;
    case Encoding::Rank:
      return MapKind::Rank;
    default:
      return MapKind::Flat;
  }
}

bool sameArray(const OmmArray& a, const OmmArray& b) {
  return a.data == b.data && a.descriptors == b.descriptors && a.indices == b.indices &&
         a.histogram == b.histogram && a.triangleHistogram == b.triangleHistogram;
}

template <Encoding E>
struct Enc {
  static constexpr Encoding value = E;
};

template <class T>
class EncodeTest : public ::testing::Test {
 protected:
  static constexpr Encoding kE = T::value;

  static EncodedArray build(const OmmArray& a) {
    auto r = EncodedArray::build(a, kE);
    EXPECT_TRUE(r.ok());
    return std::move(r).value();
  }

  // Number of (map, index) pairs whose state differs from the oracle, over every index of every map (every
  // `stride`-th index past the first 4096).
  static uint64_t mismatchesEveryIndex(const EncodedArray& e, const OmmArray& oracle, uint32_t stride = 1) {
    uint64_t bad = 0;
    for (uint32_t t = 0; t < oracle.indices.size(); ++t) {
      const int32_t i = oracle.indices[t];
      const uint32_t n = i < 0 ? 1 : microTriangleCount(oracle.descriptors[size_t(i)].subdivisionLevel);
      for (uint32_t k = 0; k < n; k += k < 4096 ? 1 : stride) {
        bad += e.template stateAs<kE>(t, k) != oracle.state(t, k);
        if (k % 64 == 0) bad += e.state(t, k) != oracle.state(t, k);  // the run-time dispatch, sampled
      }
    }
    return bad;
  }
};

struct EncName {
  template <class T>
  static std::string GetName(int) {
    std::string s = encodingName(T::value);
    for (char& c : s)
      if (c == '-') c = '_';
    return s;
  }
};

using AllEncodings =
    ::testing::Types<Enc<Encoding::Flat>, Enc<Encoding::Dfs>, Enc<Encoding::DfsFast>, Enc<Encoding::Rank>,
                     Enc<Encoding::Hybrid>, Enc<Encoding::Csm>, Enc<Encoding::Sdag>>;

bool isDag(Encoding e) {
  return e == Encoding::Csm || e == Encoding::Sdag;
}
TYPED_TEST_SUITE(EncodeTest, AllEncodings, EncName);

TYPED_TEST(EncodeTest, EveryIndexLevels0To8) {
  for (Format f : {Format::TwoState, Format::FourState})
    for (Pattern p : kPatterns)
      for (uint32_t level = 0; level <= 8; ++level) {
        const OmmArray oracle = arrayOf({makeMap(p, level, f, 1)});
        const EncodedArray e = this->build(oracle);
        // The paper's lookup walks ~4^level/2 bits per query on a full tree (checkerboard, random): at level
        // 8 those two maps are checked at every index below 4096 and every 7th above, to keep the suite fast
        // under ASan.
        const bool dfsOnFullTree =
            (TestFixture::kE == Encoding::Dfs || TestFixture::kE == Encoding::DfsFast) &&
            (p == Pattern::Checker || p == Pattern::Random);
        EXPECT_EQ(this->mismatchesEveryIndex(e, oracle, dfsOnFullTree ? 7 : 1), 0u)
            << patternName(p) << " level " << level << " format " << int(f);
      }
}

TYPED_TEST(EncodeTest, RandomIndicesAndUVLevels9To12) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  for (Format f : {Format::TwoState, Format::FourState})
    for (uint32_t level = 9; level <= 12; ++level) {
      // The paper's lookup walks ~4^level bits on a full tree: keep the degenerate maps to the lower levels.
      std::vector<Pattern> patterns{Pattern::Disc, Pattern::Leaf, Pattern::HalfHalf};
      if (level <= 10) patterns.insert(patterns.end(), {Pattern::Checker, Pattern::Random});
      for (Pattern p : patterns) {
        const OmmArray oracle = arrayOf({cachedMap(p, level, f, 2)});
        const EncodedArray e = this->build(oracle);
        const int n = level <= 10 && (p == Pattern::Checker || p == Pattern::Random) ? 100 : 2000;
        uint64_t bad = 0;
        for (int k = 0; k < n; ++k) {
          const uint32_t idx = rng() % microTriangleCount(level);
          bad += e.state(0, idx) != oracle.state(0, idx);
          float u = unit(rng), v = unit(rng);
          if (k % 3 == 0 && u + v > 1.f) {  // mostly inside, sometimes outside (clamped like the reference)
            u = 1.f - u;
            v = 1.f - v;
          }
          bad += e.stateUV(0, u, v) != oracle.stateUV(0, u, v);
          bad += e.template stateUVAs<TestFixture::kE>(0, u, v) != oracle.stateUV(0, u, v);
        }
        EXPECT_EQ(bad, 0u) << patternName(p) << " level " << level << " format " << int(f);
        // Special indices answer without data.
        for (uint32_t t = 1; t <= 4; ++t) EXPECT_EQ(e.stateUV(t, 0.2f, 0.3f), State(t - 1));
      }
    }
}

// A builder-made array (dedup, special indices, mixed levels and formats): encode → decode is the identity,
// and serialize → parse reproduces the encoded array.
TYPED_TEST(EncodeTest, DecodeAndSerializeRoundTrip) {
  OmmArrayBuilder b;
  uint32_t seed = 0;
  for (uint32_t level : {0u, 1u, 3u, 5u, 7u})
    for (Format f : {Format::TwoState, Format::FourState})
      for (Pattern p : kPatterns) {
        const Micromap m = makeMap(p, level, f, ++seed);
        b.add(m);
        b.add(makeMap(Pattern::Disc, level, f, 0));  // duplicates
        b.addSpecial(State(seed & 3u));
      }
  const OmmArray oracle = b.finish();
  ASSERT_GT(oracle.descriptors.size(), 20u);
  const EncodedArray e = this->build(oracle);
  EXPECT_EQ(e.encoding(), TestFixture::kE);
  EXPECT_TRUE(sameArray(e.decode(), oracle));
  EXPECT_EQ(this->mismatchesEveryIndex(e, oracle), 0u);
  const std::vector<uint8_t> bytes = e.serialize();
  EXPECT_EQ(bytes.size(), e.byteSize());
  auto parsed = EncodedArray::parse(bytes, "test");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_TRUE(*parsed == e);
  EXPECT_TRUE(sameArray(parsed->decode(), oracle));
  // A 32-bit index buffer (more than 0xfffb micromaps) round-trips too.
  std::vector<Micromap> many;
  for (uint32_t k = 0; k < 0x10003; ++k)
    many.push_back(makeMap(Pattern::Random, k % 3, Format::FourState, k));
  const OmmArray wide = arrayOf(many);
  ASSERT_EQ(wide.indexType(), IndexType::UInt32);
  const EncodedArray ew = this->build(wide);
  EXPECT_EQ(ew.indexType(), IndexType::UInt32);
  EXPECT_EQ(ew.state(0x10000, 0), wide.state(0x10000, 0));
  EXPECT_EQ(ew.state(0x10003 + 3, 0), State::UnknownOpaque);  // special index -4 in 32 bits
  auto pw = EncodedArray::parse(ew.serialize());
  ASSERT_TRUE(pw.ok()) << pw.error().message;
  EXPECT_TRUE(*pw == ew);
  EXPECT_EQ(ew.decode().data, wide.data);
}

TYPED_TEST(EncodeTest, SizesEqualTheFormulas) {
  std::vector<Micromap> maps;
  uint32_t seed = 10;
  for (Format f : {Format::TwoState, Format::FourState})
    for (Pattern p : kPatterns)
      for (uint32_t level : {0u, 1u, 2u, 4u, 6u, 8u, 9u}) maps.push_back(makeMap(p, level, f, ++seed));
  const OmmArray oracle = arrayOf(maps);
  const EncodedArray e = this->build(oracle);
  ASSERT_EQ(e.mapCount(), maps.size());
  if (isDag(TestFixture::kE)) {  // one shared DAG: only the framing has a closed form (see DagSizes tests)
    EXPECT_EQ(e.paddingBytes(), encode::kTailPadding);
    const uint64_t indexBytes =
        e.hasDirectory() ? packedIndexBufferBytes(oracle.indices, maps.size()) : 2u * oracle.indices.size();
    EXPECT_EQ(e.indexBufferBytes(), indexBytes);
    EXPECT_EQ(e.byteSize(), 20u + indexBytes + 8u * maps.size() + e.dataBytes() + 8u);
    EXPECT_EQ(e.serialize().size(), e.byteSize());
    return;
  }
  if (TestFixture::kE == Encoding::Hybrid && e.hasDirectory()) {
    // Hybrid took the DAG: smaller than the smallest per-map blobs (whose sizes the formulas give).
    uint64_t plain = 0;
    for (const Micromap& m : maps)
      plain += std::min(
          {formulaBytes(MapKind::Flat, m), formulaBytes(MapKind::Dfs, m), formulaBytes(MapKind::Rank, m)});
    // (with the directory the index buffer is packed: the data + index bytes are compared)
    EXPECT_LT(e.dataBytes() + e.indexBufferBytes(), plain + 2u * oracle.indices.size());
    EXPECT_EQ(e.indexBufferBytes(), packedIndexBufferBytes(oracle.indices, maps.size()));
    EXPECT_EQ(e.byteSize(), 20u + e.indexBufferBytes() + 8u * maps.size() + e.dataBytes() + 8u);
    return;
  }
  uint64_t total = 0;
  bool anyTree = false;
  for (size_t k = 0; k < maps.size(); ++k) {
    const EncodedMapDesc& d = e.maps()[k];
    const uint64_t end = k + 1 < maps.size() ? e.maps()[k + 1].offset : e.dataBytes();
    const uint64_t size = end - d.offset;
    if (TestFixture::kE == Encoding::Hybrid) {
      // The smallest of the three, ties to flat then rank.
      const uint64_t fb = formulaBytes(MapKind::Flat, maps[k]), db = formulaBytes(MapKind::Dfs, maps[k]),
                     rb = formulaBytes(MapKind::Rank, maps[k]);
      EXPECT_EQ(size, std::min({fb, db, rb}));
      EXPECT_EQ(size, formulaBytes(d.kind, maps[k]));
      EXPECT_LE(size, fb);
      anyTree |= d.kind != MapKind::Flat;
    } else {
      EXPECT_EQ(d.kind, baseKind(TestFixture::kE));
      EXPECT_EQ(size, formulaBytes(d.kind, maps[k])) << k;
      anyTree |= TestFixture::kE != Encoding::Flat;
    }
    total += size;
  }
  EXPECT_EQ(e.dataBytes(), total);
  EXPECT_EQ(e.paddingBytes(), anyTree ? encode::kTailPadding : 0u);
  EXPECT_EQ(e.byteSize(), 20u + 2u * oracle.indices.size() + 8u * maps.size() + total + e.paddingBytes());
  EXPECT_EQ(e.serialize().size(), e.byteSize());
}

// Hybrid never exceeds flat + the tail padding, on every map shape, level and format.
TYPED_TEST(EncodeTest, NeverLargerThanFlatWhenHybrid) {
  for (Format f : {Format::TwoState, Format::FourState})
    for (Pattern p : kPatterns)
      for (uint32_t level = 0; level <= 9; ++level) {
        const OmmArray oracle = arrayOf({makeMap(p, level, f, 3)});
        const EncodedArray e = this->build(oracle);
        const EncodedArray flat = EncodedArray::build(oracle, Encoding::Flat).value();
        if (TestFixture::kE == Encoding::Hybrid) {
          EXPECT_LE(e.dataBytes(), flat.dataBytes());
          EXPECT_LE(e.byteSize(), flat.byteSize() + encode::kTailPadding);
        }
        if (TestFixture::kE == Encoding::Sdag) {  // flat + the directory + the tail padding at worst
          EXPECT_LE(e.byteSize(), flat.byteSize() + encode::kSdagDirectoryBytes + encode::kTailPadding);
        }
        // Checkerboards are the degenerate case of a tree per map: no tree beats flat there. The DAG shares
        // their repeated leaves; its degenerate case is noise (every leaf distinct).
        if (p == (TestFixture::kE == Encoding::Csm ? Pattern::Random : Pattern::Checker) && level >= 3 &&
            TestFixture::kE != Encoding::Flat && TestFixture::kE != Encoding::Hybrid &&
            TestFixture::kE != Encoding::Sdag) {
          EXPECT_GT(e.dataBytes(), flat.dataBytes());
        }
      }
}

TYPED_TEST(EncodeTest, CorruptBytesRejected) {
  const OmmArray oracle = arrayOf({makeMap(Pattern::Leaf, 4, Format::TwoState, 1),
                                   makeMap(Pattern::Disc, 3, Format::FourState, 1),
                                   makeMap(Pattern::Checker, 2, Format::TwoState, 1)});
  const EncodedArray e = this->build(oracle);
  const std::vector<uint8_t> good = e.serialize();
  ASSERT_TRUE(EncodedArray::parse(good).ok());
  // Every truncation is rejected.
  for (size_t n = 0; n < good.size(); ++n) {
    auto r = EncodedArray::parse(std::span(good.data(), n), "cut.somm");
    ASSERT_FALSE(r.ok()) << n;
    EXPECT_EQ(r.error().message.rfind("cut.somm: ", 0), 0u);
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  }
  // Every single-bit flip either is rejected or yields an array whose lookups stay in bounds (ASan checks the
  // latter).
  uint64_t rejected = 0, accepted = 0;
  for (size_t byte = 0; byte < good.size(); ++byte)
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<uint8_t> bad = good;
      bad[byte] ^= uint8_t(1u << bit);
      auto r = EncodedArray::parse(bad);
      if (!r.ok()) {
        ++rejected;
        continue;
      }
      ++accepted;
      for (uint32_t t = 0; t < r->triangleCount(); ++t) {
        const int32_t i = r->indices()[t];
        const uint32_t n = i < 0 ? 1 : microTriangleCount(r->maps()[size_t(i)].level);
        for (uint32_t k = 0; k < n; ++k) (void)r->state(t, k);
      }
    }
  EXPECT_GT(rejected, 0u);
  EXPECT_GT(accepted, 0u);  // flipped state bits are valid data
  // Specific corruptions.
  auto expectReject = [&](std::vector<uint8_t> b, const char* what) {
    auto r = EncodedArray::parse(b);
    EXPECT_FALSE(r.ok()) << what;
  };
  std::vector<uint8_t> b = good;
  b[0] ^= 0xff;
  expectReject(b, "magic");
  b = good;
  b[5] = 9;
  expectReject(b, "encoding id");
  b = good;
  b[8] = 0xff, b[9] = 0xff, b[10] = 0xff, b[11] = 0x7f;  // triangle count far beyond the bytes
  expectReject(b, "triangle count");
  b = good;
  if (e.indexBits() != 0) {
    ASSERT_EQ(e.indexBits(), 3u);
    ASSERT_FALSE(e.indexRankPacked());    // 7 triangles: k bits each is smaller
    b[20] = uint8_t((b[20] & ~7u) | 3u);  // packed value 3 with 3 maps (4..7 are the specials)
  } else {
    b[20] = 7;  // index 7 with 3 maps
  }
  expectReject(b, "index");
  const size_t desc = 20 + e.indexBufferBytes();
  b = good;
  b[desc + 4] = 13;  // level 13
  expectReject(b, "level");
  b = good;
  b[desc + 5] = 3;  // format 3
  expectReject(b, "format");
  b = good;
  b[desc + 6] = 5;  // kind 5
  expectReject(b, "kind");
  b = good;
  b[desc + 0] = 0xf0;  // offset past the data
  expectReject(b, "offset");
  b = good;
  b.push_back(0);
  expectReject(b, "trailing byte");
}

TEST(EncodeMaps, DfsAndRankLayoutsByHand) {
  // Level 1, 2-state, states 1,0,0,0: root internal; dfs T = 1 0 0 0 0, values 1 0 0 0; header 1 bit = 1.
  Micromap m(1, Format::TwoState);
  m.set(0, State::Opaque);
  const std::vector<uint8_t> dfs = encode::encodeMap(m, MapKind::Dfs);
  ASSERT_EQ(dfs.size(), 3u);  // 1 header byte + ceil((5 + 4) / 8)
  EXPECT_EQ(dfs[0], 0x01);
  EXPECT_EQ(dfs[1], 0b00100001);  // T = 1,0,0,0,0 then value bits 1,0,0 at bits 5..7
  EXPECT_EQ(dfs[2], 0x00);        // last value bit 0
  // rank: header internal = 1, flags = 1 (1 bit each), flags "1", no directory, last-level states 1,0,0,0.
  const std::vector<uint8_t> rank = encode::encodeMap(m, MapKind::Rank);
  ASSERT_EQ(rank.size(), 2u);
  EXPECT_EQ(rank[0], 0b0111);   // internal 1, flags 1, K = 1 full level
  EXPECT_EQ(rank[1], 0b00011);  // flag 1, then values 1,0,0,0
  // A uniform level-3 map collapses to the root leaf.
  const Micromap u(3, Format::FourState, State::UnknownOpaque);
  EXPECT_EQ(encode::encodeMap(u, MapKind::Dfs),
            (std::vector<uint8_t>{0x00, 0b110}));  // 5-bit count 0; T 0; value 3
  EXPECT_EQ(encode::encodeMap(u, MapKind::Rank),
            (std::vector<uint8_t>{0x20, 0x00, 0b110}));  // nf=1; flag 0; value 3
}

TEST(EncodeMaps, RankDirectoryOnLargeMaps) {
  // Level-6 checkerboard: every node above the last level is internal, 1 + 4 + ... + 256 + 4·256 = 1365 flags
  // → 5 directory counters of 16 bits.
  const Micromap m = makeMap(Pattern::Checker, 6, Format::TwoState, 5);
  const encode::TreeShape s = bruteShape(m);
  EXPECT_EQ(s.internal, 1365u);
  EXPECT_EQ(encode::rankFlagBits(6, s), 1365u);
  EXPECT_EQ(encode::rankBlocks(1365), 6u);
  EXPECT_EQ(encode::rankFlagRegionBits(1365, 1365), 1365u + 6 * 40);
  EXPECT_EQ(encode::rankFlagPosition(0, 1365, 1365), 40u);
  EXPECT_EQ(encode::rankFlagPosition(257, 1365, 1365), 296u + 40 + 1);
  EXPECT_EQ(encode::encodeMap(m, MapKind::Rank).size(), encode::rankMapBytes(6, Format::TwoState, s));
  EXPECT_EQ(encode::rankMapBytes(6, Format::TwoState, s), 4 + (1365 + 6 * 40 + 4096 + 7) / 8);
  // The directory: block 1 starts at byte 4 + 37; its counter holds the 256 ones of block 0, its sub-counters
  // 64, 128, 192 (every flag is 1).
  const std::vector<uint8_t> blob = encode::encodeMap(m, MapKind::Rank);
  EXPECT_EQ(blob[4 + 37] | blob[4 + 38] << 8, 256);
  EXPECT_EQ(blob[4 + 39], 64);
  EXPECT_EQ(blob[4 + 40], 128);
  EXPECT_EQ(blob[4 + 41], 192);
  EXPECT_EQ((blob[2] >> 6) | (blob[3] & 3) << 2,
            6);  // K (bits 22..25): all six levels above the last are full
  EXPECT_EQ(encode::treeShape(m).internal, s.internal);
  EXPECT_EQ(encode::treeShape(m).internalAboveLast, s.internalAboveLast);
}

// docs/encodings.md's worked example, byte for byte.
TEST(EncodeDag, WorkedExampleLayouts) {
  Micromap m(3, Format::TwoState);
  for (uint32_t i = 0; i < 64; ++i)
    m.set(i, (i >= 16 && i < 32) || (i >= 32 && (i & 15) < 8) ? State::Opaque : State::Transparent);
  const OmmArray a = arrayOf({m});
  const EncodedArray csm = EncodedArray::build(a, Encoding::Csm).value();
  const std::vector<uint8_t> csmData{0xff, 0x00, 0xff, 0xff, 0x0e, 0x00, 0x02, 0x00, 0x00,
                                     0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
  EXPECT_EQ(std::vector<uint8_t>(csm.data().begin(), csm.data().end()), csmData);
  EXPECT_EQ(csm.maps()[0].offset, 4u);
  EXPECT_EQ(csm.maps()[0].kind, MapKind::Csm);
  const EncodedArray sdag = EncodedArray::build(a, Encoding::Sdag).value();
  ASSERT_EQ(sdag.dataBytes(), 107u);
  EXPECT_TRUE(sdag.hasDirectory());
  EXPECT_EQ(sdag.directory().base[0], 104u);
  for (uint32_t k = 1; k <= encode::kSdagRegions; ++k) EXPECT_EQ(sdag.directory().base[k], 106u);
  for (uint32_t k = 0; k < encode::kSdagRegions; ++k) EXPECT_EQ(sdag.directory().width[k], 0u);
  for (uint32_t k = 0; k < encode::kSdagRegions; ++k) EXPECT_EQ(sdag.directory().tier[k], 0u);
  for (uint32_t k = 0; k < encode::kSdagRegions; ++k) EXPECT_EQ(sdag.directory().local[k], 0u);
  EXPECT_EQ(sdag.data()[0], 104u);
  EXPECT_EQ(sdag.data()[4], 106u);
  EXPECT_EQ(sdag.data()[104], 0xff);
  EXPECT_EQ(sdag.data()[105], 0x00);
  EXPECT_EQ(sdag.data()[106], 0x2c);
  EXPECT_EQ(sdag.serialize()[4],
            7u);  // arrays with the directory (and the packed index buffer) are version 7
  EXPECT_EQ(sdag.serialize()[7], 1u);  // the directory; the index buffer is not rank-packed (5 triangles)
  EXPECT_EQ(sdag.serialize()[6], 3u);  // one map: k = bits for 0 .. 1 + 3
  // triangles 0..4 → map 0, then -1..-4 as 7, 6, 5, 4 (3 bits each): 0x4bb8
  EXPECT_EQ(sdag.serialize()[20], 0xb8);
  EXPECT_EQ(sdag.serialize()[21], 0x4b);
  EXPECT_EQ(sdag.byteSize(), 20u + 2u + 8u + 107u + 8u);
  EXPECT_EQ(sdag.maps()[0].offset, 106u);
  EXPECT_EQ(sdag.maps()[0].kind, MapKind::Sdag);
  for (uint32_t i = 0; i < 64; ++i) {
    EXPECT_EQ(csm.state(0, i), m.get(i)) << i;
    EXPECT_EQ(sdag.state(0, i), m.get(i)) << i;
  }
}

// A level-4 2-state map whose slot s (micro-triangles 16s .. 16s + 15) holds the 16-bit leaf leafOf(s): the
// worked examples of docs/encodings.md.
template <class LeafOf>
Micromap levelFourMap(LeafOf leafOf) {
  Micromap m(4, Format::TwoState);
  for (uint32_t i = 0; i < 256; ++i)
    m.set(i, (leafOf(i >> 4) >> (i & 15)) & 1u ? State::Opaque : State::Transparent);
  return m;
}
// The sdag array of one map, whose data after the directory must be `regions`.
EncodedArray sdagWithRegions(const Micromap& m, const std::vector<uint8_t>& regions) {
  EncodedArray e = EncodedArray::build(arrayOf({m}), Encoding::Sdag).value();
  EXPECT_EQ(e.dataBytes(), encode::kSdagDirectoryBytes + regions.size());
  if (e.dataBytes() >= encode::kSdagDirectoryBytes) {
    EXPECT_EQ(std::vector<uint8_t>(e.data().begin() + encode::kSdagDirectoryBytes, e.data().end()), regions);
  }
  return e;
}

// docs/encodings.md's second worked example: a tiered reference region (short references of 0 bits).
TEST(EncodeDag, WorkedExampleTieredReferences) {
  const uint32_t leaf[4] = {0x00ff, 0x0f0f, 0x3333, 0x5555};
  const Micromap m = levelFourMap([&](uint32_t slot) { return leaf[slot < 10 ? 0 : (slot - 8) / 2]; });
  const EncodedArray sdag = sdagWithRegions(
      m, {0xff, 0x00, 0x0f, 0x0f, 0x33, 0x33, 0x55, 0x55, 0xff, 0xff, 0xff, 0x03, 0xa5, 0x0f});
  const encode::SdagDirectory& dir = sdag.directory();
  EXPECT_EQ(dir.base[0], 104u);
  EXPECT_EQ(dir.base[1], 112u);
  for (uint32_t k = 2; k <= encode::kSdagRegions; ++k) EXPECT_EQ(dir.base[k], 118u);
  EXPECT_EQ(dir.width[0], 2u);
  EXPECT_EQ(dir.tier[0], 1u);  // short references: 0 bits (the leaf used 10 times)
  EXPECT_EQ(dir.mid[0], 0u);
  for (uint32_t k = 1; k < encode::kSdagRegions; ++k) EXPECT_EQ(dir.width[k] + dir.tier[k], 0u);
  for (uint32_t k = 0; k < encode::kSdagRegions; ++k) EXPECT_EQ(dir.local[k], 0u);  // no leaf is used once
  EXPECT_EQ(sdag.maps()[0].offset, 112u);
  EXPECT_EQ(sdag.state(0, 213), State::Opaque);
  EXPECT_EQ(sdag.state(0, 100), State::Opaque);
  EXPECT_EQ(sdag.state(0, 172), State::Transparent);
  for (uint32_t i = 0; i < 256; ++i) EXPECT_EQ(sdag.state(0, i), m.get(i)) << i;
  // A version-1 array with the directory (the old 64-byte layout) is refused clearly.
  std::vector<uint8_t> bytes = sdag.serialize();
  bytes[4] = 1;
  const auto old = EncodedArray::parse(bytes, "old.somm");
  ASSERT_FALSE(old);
  EXPECT_EQ(old.error().code, ErrorCode::UnsupportedFormat);
  EXPECT_NE(old.error().message.find("old sdag layout"), std::string::npos) << old.error().message;
  // Versions 2..6 (the retired sdag layouts) are refused clearly too, naming the version and what to do.
  for (uint8_t v : {2, 3, 4, 5, 6}) {
    bytes[4] = v;
    const auto r = EncodedArray::parse(bytes, "old.somm");
    ASSERT_FALSE(r) << int(v);
    EXPECT_EQ(r.error().code, ErrorCode::UnsupportedFormat);
    EXPECT_NE(r.error().message.find("version " + std::to_string(v) + " ("), std::string::npos)
        << r.error().message;
    EXPECT_NE(r.error().message.find("encode the micromaps again"), std::string::npos) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  }
  bytes[4] = 5;
  EXPECT_NE(EncodedArray::parse(bytes).error().message.find("96-byte directory, without local references"),
            std::string::npos);
  bytes[4] = 6;
  EXPECT_NE(EncodedArray::parse(bytes).error().message.find("one bit per uniform child"), std::string::npos);
}

// docs/encodings.md's worked example with local leaves: slots 0..12 hold the leaf 0x00ff, slots 13, 14, 15 the
// leaves 0x0f00, 0x3333, 0x5555, each used once: they are stored right before the root and take no reference bits.
// (No two of them are one leaf transform apart.)
TEST(EncodeDag, WorkedExampleLocalLeaves) {
  const uint32_t leaf[4] = {0x00ff, 0x0f00, 0x3333, 0x5555};
  const Micromap m = levelFourMap([&](uint32_t slot) { return leaf[slot < 13 ? 0 : slot - 12]; });
  const EncodedArray sdag =
      sdagWithRegions(m, {0xff, 0x00, 0x00, 0x0f, 0x33, 0x33, 0x55, 0x55, 0xff, 0xff, 0x00, 0xe0});
  const encode::SdagDirectory& dir = sdag.directory();
  EXPECT_EQ(dir.base[0], 104u);
  EXPECT_EQ(dir.base[1], 106u);
  for (uint32_t k = 2; k <= encode::kSdagRegions; ++k) EXPECT_EQ(dir.base[k], 116u);
  EXPECT_EQ(dir.local[0], 1u);
  EXPECT_EQ(dir.width[1], 3u);  // the root's reference in its region is 6 (after its local leaves); unused
  for (uint32_t k = 0; k < encode::kSdagRegions; ++k)
    EXPECT_EQ(dir.width[k] + dir.tier[k] + dir.mid[k], k == 1 ? 3u : 0u) << k;
  for (uint32_t k = 1; k < encode::kSdagRegions; ++k) EXPECT_EQ(dir.local[k], 0u);
  EXPECT_EQ(sdag.data()[88], 1u);
  EXPECT_EQ(sdag.maps()[0].offset, 112u);
  EXPECT_EQ(sdag.state(0, 213), State::Transparent);  // local leaf 0 of 3: 3·2 bytes before the root, 0x0f00
  EXPECT_EQ(sdag.state(0, 100), State::Opaque);       // leaf 0 (0 bits) of region (1, 1)
  EXPECT_EQ(sdag.state(0, 250), State::Opaque);       // local leaf 2: 2 bytes before the root, 0x5555
  for (uint32_t i = 0; i < 256; ++i) EXPECT_EQ(sdag.state(0, i), m.get(i)) << i;
  const std::vector<uint8_t> bytes = sdag.serialize();
  EXPECT_EQ(EncodedArray::parse(bytes).value(), sdag);
  // A local leaf before the first region: H of slots 0..3 set (7 local leaves, the first 14 bytes before the
  // root, inside the directory) is refused.
  std::vector<uint8_t> bad = bytes;
  const size_t data = 20 + sdag.indexBufferBytes() + 8 * sdag.mapCount();
  bad[data + 112 + 2] = 0x0f;
  const auto r = EncodedArray::parse(bad);
  EXPECT_FALSE(r);
}

// docs/encodings.md's worked example with leaf transforms: one level-4 2-state map whose 16 slots hold, in turn,
// the six leaves one transform apart from 0x00ff (0x00ff, 0xff00, 0x0f0f, 0xf0f0, 0x0ff0, 0xf00f, then again):
// one stored leaf, and each reference carries its transform in its low 4 bits.
TEST(EncodeDag, WorkedExampleLeafTransforms) {
  const uint32_t leaf[6] = {0x00ff, 0xff00, 0x0f0f, 0xf0f0, 0x0ff0, 0xf00f};
  const Micromap m = levelFourMap([&](uint32_t slot) { return leaf[slot % 6]; });
  // Region (1, 1): the leaf 0x00ff; the root at 106: M = 0xffff, then 16 references of 4 bits (leaf 0, T):
  // 0x00ff T 0, 0xff00 T 8 (the complement), 0x0f0f T 12 (p 4, complemented), 0xf0f0 T 4, 0x0ff0 T 2, 0xf00f T 10.
  const EncodedArray sdag =
      sdagWithRegions(m, {0xff, 0x00, 0xff, 0xff, 0x80, 0x4c, 0xa2, 0x80, 0x4c, 0xa2, 0x80, 0x4c});
  const encode::SdagDirectory& dir = sdag.directory();
  EXPECT_EQ(dir.base[1], 106u);
  EXPECT_EQ(dir.width[0], 4u);
  EXPECT_EQ(dir.tier[0] + dir.mid[0] + dir.local[0], 0u);
  EXPECT_EQ(dir.xform[0], 1u);
  EXPECT_EQ(dir.xform[1], 0u);
  EXPECT_EQ(sdag.data()[100], 1u);
  EXPECT_EQ(sdag.maps()[0].offset, 106u);
  EXPECT_EQ(sdag.state(0, 37), State::Transparent);  // slot 2, T 12: state P4[5] = 5 of 0x00ff (1), xor 1
  EXPECT_EQ(sdag.state(0, 40), State::Opaque);       // slot 2, state 8: P4[8] = 12 of 0x00ff (0), xor 1
  EXPECT_EQ(sdag.state(0, 17), State::Transparent);  // slot 1, T 8: state 1 of 0x00ff, xor 1
  // Without transforms: six leaves of 2 bytes and 3-bit references (the root 8 bytes): 124 data bytes.
  for (uint32_t i = 0; i < 256; ++i) EXPECT_EQ(sdag.state(0, i), m.get(i)) << i;
  const std::vector<uint8_t> bytes = sdag.serialize();
  EXPECT_EQ(bytes[4], 8u);  // version 8: a leaf region with transforms
  EXPECT_EQ(EncodedArray::parse(bytes).value(), sdag);
  // A transform with p = 6 or 7 is refused; so is a transform flag above 1, or version 8 without one.
  const size_t data = 20 + sdag.indexBufferBytes() + 8 * sdag.mapCount();
  std::vector<uint8_t> bad = bytes;
  bad[data + 108] = 0x86;  // slot 0: T 6
  EXPECT_FALSE(EncodedArray::parse(bad));
  bad = bytes;
  bad[data + 100] = 2;
  EXPECT_FALSE(EncodedArray::parse(bad));
  bad[data + 100] = 0;
  EXPECT_FALSE(EncodedArray::parse(bad));
}

// Arrays whose leaves are a few leaves under random transforms (so that the builder takes transforms), with local
// leaves, 4-way roots of leaves (level 3) and level-2 maps whose root leaf is another map's leaf transformed (their
// own classes): every state equals flat through the memo walk and the plain walk, decode and parse round trip.
TEST(EncodeDag, LeafTransformsAnswerAsFlat) {
  std::mt19937 rng(2026);
  for (Format f : {Format::TwoState, Format::FourState}) {
    const uint32_t states = f == Format::TwoState ? 2u : 4u;
    std::vector<uint32_t> base(24);
    for (uint32_t& b : base) {
      b = 0;
      for (uint32_t i = 0; i < 16; ++i) b |= (rng() % states) << (2 * i);
    }
    // The leaf (2-bit states) reached from leaf v with transform t (p = t & 7 < 6, complement t >> 3).
    auto transformed = [](uint32_t v, uint32_t t) {
      uint32_t o = 0;
      for (uint32_t i = 0; i < 16; ++i)
        o |= ((v >> (2 * (uint32_t(encode::kSdagLeafPerm[t & 7u] >> (4 * i)) & 15u))) & 3u) << (2 * i);
      return o ^ ((t >> 3) * 0x55555555u);
    };
    std::vector<Micromap> maps;
    for (uint32_t level : {2u, 3u, 4u, 5u, 6u, 8u, 2u, 3u}) {
      Micromap m(level, f);
      for (uint32_t g = 0; g < m.size() / 16; ++g) {
        const uint32_t t = rng() % 12, leaf = transformed(base[rng() % base.size()], t < 6 ? t : t + 2);
        const bool uniform = level > 3 && rng() % 3 == 0, unique = rng() % 17 == 0;
        for (uint32_t i = 0; i < 16; ++i) {
          const uint32_t v = uniform ? 0u : unique ? uint32_t(rng() % states) : (leaf >> (2 * i)) & 3u;
          m.set(g * 16 + i, State(v));
        }
      }
      maps.push_back(m);
    }
    const OmmArray a = arrayOf(maps);
    const EncodedArray e = EncodedArray::build(a, Encoding::Sdag).value();
    EXPECT_EQ(e.directory().xform[uint32_t(f) - 1], 1u) << int(f);
    const EncodedArray flat = EncodedArray::build(a, Encoding::Flat).value();
    EXPECT_LT(e.dataBytes(), flat.dataBytes());
    for (uint32_t m = 0; m < maps.size(); ++m) {
      const auto& d = e.maps()[m];
      for (uint32_t i = 0; i < maps[m].size(); ++i) {
        ASSERT_EQ(e.state(m, i), maps[m].get(i)) << int(f) << " map " << m << " index " << i;
        if (d.kind != MapKind::Sdag) continue;  // a map the builder kept flat
        ASSERT_EQ(encode::sdagState(e.data().data(), e.directory(), d.offset, d.level, f, i), maps[m].get(i))
            << int(f) << " map " << m << " level " << int(d.level) << " kind " << int(d.kind) << " index "
            << i;
      }
    }
    for (uint32_t m = 0; m < maps.size(); ++m) EXPECT_TRUE(e.decodeMap(m) == maps[m]) << m;
    EXPECT_TRUE(sameArray(e.decode(), flat.decode()));
    const EncodedArray parsed = EncodedArray::parse(e.serialize()).value();
    EXPECT_EQ(parsed, e);
    EXPECT_EQ(e.serialize()[4], 8u);
  }
}

// The leaf transforms' permutations are the bird curve's: micro-triangle i of a level-2 triangle goes to the one
// holding its centroid with the barycentric weights permuted, and the six form a group.
TEST(EncodeDag, LeafSymmetriesFollowTheBirdCurve) {
  const int order[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  uint32_t perm[6][16];
  for (uint32_t p = 0; p < 6; ++p)
    for (uint32_t i = 0; i < 16; ++i) {
      const MicroTriangle t = indexToMicroTriangle(i, 2);
      const float cu = float(t.v[0].u + t.v[1].u + t.v[2].u) / 12.0f;
      const float cv = float(t.v[0].v + t.v[1].v + t.v[2].v) / 12.0f;
      const float w[3] = {1.0f - cu - cv, cu, cv};
      perm[p][i] = baryToIndex(w[order[p][1]], w[order[p][2]], 2);
      EXPECT_EQ(uint32_t(encode::kSdagLeafPerm[p] >> (4 * i)) & 15u, perm[p][i]) << p << " " << i;
    }
  EXPECT_EQ(encode::kSdagLeafPerm[6], encode::kSdagLeafPerm[0]);
  EXPECT_EQ(encode::kSdagLeafPerm[7], encode::kSdagLeafPerm[0]);
  for (uint32_t a = 0; a < 6; ++a)
    for (uint32_t b = 0; b < 6; ++b) {
      bool found = false;
      for (uint32_t c = 0; c < 6 && !found; ++c) {
        bool same = true;
        for (uint32_t i = 0; i < 16; ++i) same = same && perm[a][perm[b][i]] == perm[c][i];
        found = same;
      }
      EXPECT_TRUE(found) << a << " " << b;
    }
}

// docs/encodings.md's third worked example: 4-state uniform children take 1 bit; a uniformly unknown child is a
// node child referring to the uniform leaf. The uniform children disagree (slot 1 opaque, slots 3..15 transparent):
// E = 1 and one bit each.
TEST(EncodeDag, WorkedExampleUnknownUniformChild) {
  Micromap m(4, Format::FourState);
  for (uint32_t i = 0; i < 16; ++i) m.set(i, State::UnknownOpaque);
  for (uint32_t i = 16; i < 32; ++i) m.set(i, State::Opaque);
  for (uint32_t i = 32; i < 48; ++i) m.set(i, State(i % 4));
  const EncodedArray sdag = EncodedArray::build(arrayOf({m}), Encoding::Sdag).value();
  const std::vector<uint8_t> regions{0xff, 0xff, 0xff, 0xff, 0xe4, 0xe4, 0xe4,
                                     0xe4, 0x05, 0x00, 0x03, 0x00, 0x01};
  ASSERT_EQ(sdag.dataBytes(), 117u);
  EXPECT_EQ(std::vector<uint8_t>(sdag.data().begin() + 104, sdag.data().begin() + 117), regions);
  const encode::SdagDirectory& dir = sdag.directory();
  for (uint32_t k = 0; k <= 6; ++k) EXPECT_EQ(dir.base[k], 104u);
  EXPECT_EQ(dir.base[7], 112u);
  for (uint32_t k = 8; k <= encode::kSdagRegions; ++k) EXPECT_EQ(dir.base[k], 117u);
  EXPECT_EQ(dir.width[6], 1u);
  EXPECT_EQ(dir.tier[6], 0u);
  EXPECT_EQ(dir.local[6], 0u);
  EXPECT_EQ(sdag.maps()[0].offset, 112u);
  EXPECT_EQ(sdag.state(0, 5), State::UnknownOpaque);
  EXPECT_EQ(sdag.state(0, 20), State::Opaque);
  EXPECT_EQ(sdag.state(0, 39), State::UnknownOpaque);
  EXPECT_EQ(sdag.state(0, 200), State::Transparent);
  for (uint32_t i = 0; i < 256; ++i) EXPECT_EQ(sdag.state(0, i), m.get(i)) << i;
  EXPECT_EQ(EncodedArray::parse(sdag.serialize()).value(), sdag);
}

// The same map with slot 1 transparent too: the uniform children agree, so the root holds E = 0 and one state bit
// for all of them (2 bits instead of 14), and its references follow at bit 18.
TEST(EncodeDag, WorkedExampleAgreeingUniformChildren) {
  Micromap m(4, Format::FourState);
  for (uint32_t i = 0; i < 16; ++i) m.set(i, State::UnknownOpaque);
  for (uint32_t i = 32; i < 48; ++i) m.set(i, State(i % 4));
  const EncodedArray sdag = EncodedArray::build(arrayOf({m}), Encoding::Sdag).value();
  const std::vector<uint8_t> regions{0xff, 0xff, 0xff, 0xff, 0xe4, 0xe4, 0xe4, 0xe4, 0x05, 0x00, 0x08};
  ASSERT_EQ(sdag.dataBytes(), 115u);
  EXPECT_EQ(std::vector<uint8_t>(sdag.data().begin() + 104, sdag.data().begin() + 115), regions);
  EXPECT_EQ(sdag.maps()[0].offset, 112u);
  EXPECT_EQ(sdag.state(0, 5), State::UnknownOpaque);   // slot 0: reference 0 at bit 18
  EXPECT_EQ(sdag.state(0, 20), State::Transparent);    // slot 1: the one state, bit 17
  EXPECT_EQ(sdag.state(0, 39), State::UnknownOpaque);  // slot 2: reference 1 at bit 19
  for (uint32_t i = 0; i < 256; ++i) EXPECT_EQ(sdag.state(0, i), m.get(i)) << i;
  // Every opaque instead: the one state bit is 1.
  Micromap o = m;
  for (uint32_t i = 16; i < 32; ++i) o.set(i, State::Opaque);
  for (uint32_t i = 48; i < 256; ++i) o.set(i, State::Opaque);
  const EncodedArray so = EncodedArray::build(arrayOf({o}), Encoding::Sdag).value();
  ASSERT_EQ(so.dataBytes(), 115u);
  EXPECT_EQ(so.data()[114], 0x0a);
  for (uint32_t i = 0; i < 256; ++i) EXPECT_EQ(so.state(0, i), o.get(i)) << i;
  EXPECT_EQ(EncodedArray::parse(so.serialize()).value(), so);
}

// The packed index buffer of sdag arrays: k = sdagIndexBits(M) bits per triangle, specials as the k-bit two's
// complement; exact bits, round trip through serialize / parse, and every special value.
TEST(EncodeDag, PackedIndexBuffer) {
  EXPECT_EQ(encode::sdagIndexBits(0), 2u);
  EXPECT_EQ(encode::sdagIndexBits(1), 3u);
  EXPECT_EQ(encode::sdagIndexBits(4), 3u);
  EXPECT_EQ(encode::sdagIndexBits(5), 4u);
  EXPECT_EQ(encode::sdagIndexBits(852), 10u);
  EXPECT_EQ(encode::sdagIndexBits(1020), 10u);
  EXPECT_EQ(encode::sdagIndexBits(1021), 11u);
  EXPECT_EQ(encode::sdagIndexBits(uint64_t(INT32_MAX)), 32u);
  Micromap a(2, Format::FourState), b(3, Format::FourState);
  for (uint32_t i = 0; i < 16; ++i) a.set(i, State(i & 3));
  for (uint32_t i = 0; i < 64; ++i) b.set(i, State((i >> 2) & 3));
  OmmArray arr = arrayOf({a, b});
  arr.indices = {1, -1, 0, -2, -3, -4, 1, 0, 1};
  const EncodedArray e = EncodedArray::build(arr, Encoding::Sdag).value();
  ASSERT_EQ(e.indexBits(), 3u);  // M = 2: values 0, 1 and 4..7 for -4..-1
  const std::vector<uint8_t> bytes = e.serialize();
  // values 1 7 0 6 5 4 1 0 1, 3 bits each from bit 0
  uint64_t want = 0;
  const uint32_t vals[9] = {1, 7, 0, 6, 5, 4, 1, 0, 1};
  for (uint32_t t = 0; t < 9; ++t) want |= uint64_t(vals[t]) << (3 * t);
  ASSERT_EQ(e.indexBufferBytes(), 4u);
  uint64_t got = 0;
  for (uint32_t i = 0; i < 4; ++i) got |= uint64_t(bytes[20 + i]) << (8 * i);
  EXPECT_EQ(got, want);
  for (uint32_t t = 0; t < 9; ++t) EXPECT_EQ(e.stateAs<Encoding::Sdag>(t, 5), arr.state(t, 5)) << t;
  const EncodedArray back = EncodedArray::parse(bytes).value();
  EXPECT_EQ(back, e);
  EXPECT_EQ(std::vector<int32_t>(back.indices().begin(), back.indices().end()), arr.indices);
  // A value between M and 2^k - 4 is out of range; stray bits after the last triangle are refused.
  std::vector<uint8_t> badValue = bytes;
  badValue[20] = uint8_t((badValue[20] & ~7u) | 3u);
  EXPECT_FALSE(EncodedArray::parse(badValue));
  std::vector<uint8_t> stray = bytes;
  stray[23] |= 0x80;
  EXPECT_FALSE(EncodedArray::parse(stray));
  std::vector<uint8_t> width = bytes;
  width[6] = 4;
  EXPECT_FALSE(EncodedArray::parse(width));
}

// docs/encodings.md's rank-packed index buffer example: 100 triangles, all opaque (-2) but four; M = 2, k = 3.
// Exact bytes, every lookup, round trip, and the corruptions the parser refuses.
TEST(EncodeDag, RankPackedIndexBuffer) {
  Micromap a(2, Format::FourState), b(3, Format::FourState);
  for (uint32_t i = 0; i < 16; ++i) a.set(i, State(i & 3));
  for (uint32_t i = 0; i < 64; ++i) b.set(i, State((i >> 2) & 3));
  OmmArray arr = arrayOf({a, b});
  arr.indices.assign(100, -2);
  arr.indices[1] = 0;
  arr.indices[33] = 1;
  arr.indices[35] = -1;
  arr.indices[99] = 0;
  const EncodedArray e = EncodedArray::build(arr, Encoding::Sdag).value();
  ASSERT_EQ(e.indexBits(), 3u);
  ASSERT_TRUE(e.indexRankPacked());
  ASSERT_EQ(e.indexBufferBytes(), 34u);  // 4 group words + 5 entries of 3 bits (plain: 300 bits = 38 bytes)
  EXPECT_EQ(packedIndexBufferBytes(arr.indices, 2), 34u);
  const std::vector<uint8_t> bytes = e.serialize();
  EXPECT_EQ(bytes[4], 7u);
  EXPECT_EQ(bytes[7], 3u);  // the directory + the rank-packed index buffer
  const std::vector<uint8_t> index{
      0x00, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00,  // group 0: 0 listed before, triangle 1
      0x01, 0x00, 0x00, 0x00, 0x0a, 0x00, 0x00, 0x00,  // group 1: 1 before, triangles 33, 35
      0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,  // group 2: 3 before, none
      0x03, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00,  // group 3 (triangles 96..99): 3 before, triangle 99
      0x46, 0x0e};  // entries 6 (the default, -2), 0, 1, 7 (-1), 0: 3 bits each
  EXPECT_EQ(std::vector<uint8_t>(bytes.begin() + 20, bytes.begin() + 54), index);
  for (uint32_t t = 0; t < 100; ++t) {
    EXPECT_EQ(e.indexAs<Encoding::Sdag>(t), arr.indices[t]) << t;
    EXPECT_EQ(e.stateAs<Encoding::Sdag>(t, 5), arr.state(t, 5)) << t;
  }
  const EncodedArray back = EncodedArray::parse(bytes).value();
  EXPECT_EQ(back, e);
  EXPECT_TRUE(back.indexRankPacked());
  EXPECT_EQ(std::vector<int32_t>(back.indices().begin(), back.indices().end()), arr.indices);
  auto refused = [&](std::vector<uint8_t> bad, const char* what) {
    EXPECT_FALSE(EncodedArray::parse(bad)) << what;
  };
  std::vector<uint8_t> bad = bytes;
  bad[28] = 2;  // group 1 claims 2 listed triangles before it
  refused(bad, "count");
  bad = bytes;
  bad[44 + 4] |= 0x10;  // group 3 lists triangle 100 (past the last)
  refused(bad, "mask past the end");
  bad = bytes;
  bad[53] |= 0x80;  // a bit after the last entry
  refused(bad, "stray bits");
  bad = bytes;
  bad[52] = uint8_t((bad[52] & ~0x38u) | (6u << 3));  // entry 1 = the default value
  refused(bad, "listed default");
  bad = bytes;
  bad[52] = uint8_t((bad[52] & ~7u) | 2u);  // default value 2: between M and 2^k - 4
  refused(bad, "default out of range");
  bad = bytes;
  bad[7] = 2;  // rank-packed without the directory
  refused(bad, "flags");
  // The same values with an extra listed triangle stay consistent: moving triangle 99 to group 2 is refused
  // (group 3's count no longer matches), the count fixed accepts it.
  bad = bytes;
  bad[44 + 4] = 0;
  bad[36 + 4] = 0x01;  // triangle 64 listed instead of 99
  EXPECT_FALSE(EncodedArray::parse(bad));
  bad[44] = 4;
  const auto moved = EncodedArray::parse(bad);
  ASSERT_TRUE(moved) << moved.error().message;
  EXPECT_EQ(moved->indices()[64], 0);
  EXPECT_EQ(moved->indices()[99], -2);
  EXPECT_EQ(moved->indexAs<Encoding::Sdag>(64), 0);
  EXPECT_EQ(moved->indexAs<Encoding::Sdag>(99), -2);
}

// The three-class reference code (docs/encodings.md, sdag: tier and mid): random level-6..8 maps give a leaf region
// whose references are short, mid or long. Lookups equal flat, decode is bit-exact, parse round-trips, and a
// directory whose mid is not between the tier and the width is refused.
TEST(EncodeDag, MidReferenceClass) {
  const OmmArray flat = somm::testing::randomOmmArray(200, Format::FourState, 6, 8, 1);
  const EncodedArray e = EncodedArray::build(flat, Encoding::Sdag).value();
  const uint32_t k = encode::sdagRegion(Format::FourState, 1);
  const encode::SdagDirectory& dir = e.directory();
  ASSERT_NE(dir.mid[k], 0u);
  EXPECT_GT(dir.mid[k], dir.tier[k]);
  EXPECT_GT(dir.tier[k], 0u);
  EXPECT_LE(dir.mid[k], dir.local[k] != 0 ? 33u : dir.width[k]);  // with local references: up to 32 bits
  for (uint32_t t = 0; t < flat.indices.size(); ++t) {
    const int32_t i = flat.indices[t];
    const uint32_t n = i < 0 ? 1 : microTriangleCount(flat.descriptors[size_t(i)].subdivisionLevel);
    for (uint32_t x = 0; x < n; x += 7) ASSERT_EQ(e.state(t, x), flat.state(t, x)) << t << " " << x;
  }
  EXPECT_TRUE(sameArray(e.decode(), flat));
  const std::vector<uint8_t> bytes = e.serialize();
  EXPECT_EQ(EncodedArray::parse(bytes).value(), e);
  const size_t data = 20 + e.indexBufferBytes() + 8 * e.mapCount();
  std::vector<uint8_t> bad = bytes;
  bad[data + 76 + k] = dir.tier[k];  // mid = tier
  EXPECT_FALSE(EncodedArray::parse(bad));
  bad[data + 76 + k] =
      uint8_t(dir.local[k] != 0 ? 34 : dir.width[k] + 1);  // mid above the width (or 32 bits)
  EXPECT_FALSE(EncodedArray::parse(bad));
  bad = bytes;
  bad[data + 100] = 1;  // reserved
  EXPECT_FALSE(EncodedArray::parse(bad));
  bad = bytes;
  bad[data + 88 + k] = 2;  // local flag above 1
  EXPECT_FALSE(EncodedArray::parse(bad));
}

// Level-6 2-state maps whose roots each have 16 height-2 children of their own (one leaf 0x00ff at slot j of child
// j, the other 15 children uniform, from a hash of (map, j)): every height-2 record is referenced once, so with
// enough maps local references (a few bits from the root) beat region references (many records).
Micromap localMap(uint32_t m) {
  Micromap out(6, Format::TwoState);
  for (uint32_t i = 0; i < 4096; ++i) {
    const uint32_t j = i >> 8, s = (i >> 4) & 15u, v = ((m * 16 + j + 1) * 2654435761u) >> 9;
    const bool opaque = s == j ? (i & 15u) < 8 : ((v >> s) & 1u) != 0;
    out.set(i, opaque ? State::Opaque : State::Transparent);
  }
  return out;
}

// Local references (docs/encodings.md, sdag: the local class): records referenced once are stored after their
// parent and reached by a byte offset from it. Lookups equal flat, decode is bit-exact, parse round-trips; a record
// referenced once from two different maps' parents (twice in all) stays in its region; corrupted local references
// are refused (or still stay in bounds: every lookup of whatever parses runs under the sanitizers).
TEST(EncodeDag, LocalReferences) {
  std::vector<Micromap> maps;
  for (uint32_t m = 0; m < 8; ++m) maps.push_back(localMap(m));
  const uint32_t k2 = encode::sdagRegion(Format::TwoState, 2), k3 = k2 + 1;
  auto check = [](const OmmArray& flat, const EncodedArray& e) {
    for (uint32_t t = 0; t < flat.indices.size(); ++t)
      for (uint32_t x = 0; x < 4096; ++x) ASSERT_EQ(e.state(t, x), flat.state(t, x)) << t << " " << x;
    const OmmArray back = e.decode();
    EXPECT_TRUE(back.data == flat.data && back.descriptors == flat.descriptors &&
                back.indices == flat.indices);
    EXPECT_EQ(EncodedArray::parse(e.serialize()).value(), e);
  };
  const OmmArray flat = arrayOf(maps);
  const EncodedArray e = EncodedArray::build(flat, Encoding::Sdag).value();
  const encode::SdagDirectory& dir = e.directory();
  ASSERT_EQ(dir.local[k2], 1u);
  EXPECT_EQ(dir.tier[k2], 0u);                // every reference into height 2 is local
  EXPECT_EQ(dir.base[k2 + 1], dir.base[k2]);  // so region (1, 2) is empty: the records follow their roots
  EXPECT_EQ(dir.local[encode::sdagRegion(Format::TwoState, 1)], 0u);
  check(flat, e);
  // The roots are stored in region (1, 3), each followed by its 16 children: the first root's first local
  // reference is its own size.
  const uint8_t* root = e.data().data() + e.maps()[0].offset;
  EXPECT_EQ(e.maps()[0].offset, dir.base[k3]);
  EXPECT_EQ(encode::sdagRefClass(root, 16, 16, 0, dir.width[k2], 0, 0).ref,
            (16 + 16 * dir.width[k2] + 7) / 8);
  const uint64_t plainSize = [&] {
    std::vector<Micromap> one{maps[0]};
    return EncodedArray::build(arrayOf(one), Encoding::Sdag).value().directory().local[k2];
  }();
  EXPECT_EQ(plainSize, 0u);  // one map alone: local references would not be shorter
  // Map 8 repeats map 0's child 3 under its own root: that record is referenced twice (once from each of two
  // maps' parents) and stays in region (1, 2); the others stay local.
  Micromap shared = localMap(8);
  for (uint32_t i = 0; i < 4096; ++i)
    if ((i >> 8) == 5) shared.set(i, maps[0].get(3 * 256 + (i & 255)));
  std::vector<Micromap> more = maps;
  more.push_back(shared);
  const OmmArray flat2 = arrayOf(more);
  const EncodedArray e2 = EncodedArray::build(flat2, Encoding::Sdag).value();
  ASSERT_EQ(e2.directory().local[k2], 1u);
  EXPECT_GT(e2.directory().base[k2 + 1], e2.directory().base[k2]);  // the shared record
  EXPECT_NE(e2.directory().tier[k2], 0u);
  check(flat2, e2);
  // Corruptions: every byte of the first root and its first local child, each bit flipped; and a local
  // reference pointing before the end of its record, or past the regions.
  const std::vector<uint8_t> bytes = e.serialize();
  const size_t data = 20 + e.indexBufferBytes() + 8 * e.mapCount();
  for (size_t at = data + e.maps()[0].offset; at < data + e.maps()[0].offset + 40; ++at)
    for (uint32_t bit = 0; bit < 8; ++bit) {
      std::vector<uint8_t> bad = bytes;
      bad[at] ^= uint8_t(1u << bit);
      const auto r = EncodedArray::parse(bad);
      if (!r) continue;
      for (uint32_t t = 0; t < r->triangleCount(); ++t)
        for (uint32_t x = 0; x < 4096; x += 5) (void)r->state(t, x);
    }
  std::vector<uint8_t> bad = bytes;
  const size_t rootAt = data + e.maps()[0].offset;
  for (uint32_t b = 16; b < 16u + dir.width[k2];
       ++b)  // the first local reference = 0: inside the root itself
    bad[rootAt + b / 8] &= uint8_t(~(1u << (b % 8)));
  EXPECT_FALSE(EncodedArray::parse(bad));
  bad = bytes;
  bad[data + 88 + k2] = 0;  // the local class read as region references
  EXPECT_FALSE(EncodedArray::parse(bad));
  bad = bytes;
  bad.resize(bad.size() - 9);  // truncated
  EXPECT_FALSE(EncodedArray::parse(bad));
}

// Identical subtrees of different maps are stored once: a second map that differs from the first in one
// leaf adds about a root-to-leaf path, not a second tree.
TEST(EncodeDag, SubtreesSharedAcrossMaps) {
  for (Format f : {Format::TwoState, Format::FourState}) {
    const Micromap m1 = makeMap(Pattern::Leaf, 8, f, 1);
    Micromap m2 = m1;
    for (uint32_t i = 30000; i < 30016; ++i)
      m2.set(i, m2.get(i) == State::Opaque ? State::Transparent : State::Opaque);
    Micromap m3(9, f);  // a level-9 map whose four quarters are m1: shares every subtree below its root
    for (uint32_t q = 0; q < 4; ++q)
      for (uint32_t i = 0; i < m1.size(); ++i) m3.set(q * m1.size() + i, m1.get(i));
    for (Encoding e : {Encoding::Csm, Encoding::Sdag}) {
      const uint64_t one = EncodedArray::build(arrayOf({m1}), e).value().dataBytes();
      const EncodedArray all = EncodedArray::build(arrayOf({m1, m2, m3}), e).value();
      EXPECT_LT(all.dataBytes(), one + one / 4) << encodingName(e) << " format " << int(f);
      const OmmArray oracle = arrayOf({m1, m2, m3});
      for (uint32_t t = 0; t < 3; ++t)
        for (uint32_t i = 0; i < oracle.descriptors.size() * 0 + microTriangleCount(t == 2 ? 9 : 8); i += 7)
          ASSERT_EQ(all.state(t, i), oracle.state(t, i)) << encodingName(e) << " " << t << " " << i;
    }
  }
}

// sdag beats csm and dfs on trees with structure (procedural leaves, levels 6..10), and csm's 32-bit
// pointers cost more than sdag's bit-packed references.
TEST(EncodeDag, SdagSmallerThanCsmAndDfs) {
  for (uint32_t level : {6u, 8u, 10u}) {
    std::vector<Micromap> maps;
    for (uint32_t s = 0; s < 4; ++s)
      maps.push_back(cachedMap(s % 2 ? Pattern::Leaf : Pattern::Disc, level, Format::FourState, s));
    const OmmArray a = arrayOf(maps);
    const uint64_t sdag = EncodedArray::build(a, Encoding::Sdag).value().byteSize();
    const uint64_t csm = EncodedArray::build(a, Encoding::Csm).value().byteSize();
    const uint64_t dfs = EncodedArray::build(a, Encoding::Dfs).value().byteSize();
    EXPECT_LT(sdag, csm) << level;
    EXPECT_LT(sdag, dfs) << level;
    EXPECT_LE(EncodedArray::build(a, Encoding::Hybrid).value().byteSize(), sdag) << level;
  }
}

TEST(EncodeDag, DfsFastIsTheDfsBytes) {
  const OmmArray a = arrayOf({makeMap(Pattern::Leaf, 6, Format::FourState, 1)});
  EncodedArray dfs = EncodedArray::build(a, Encoding::Dfs).value();
  const EncodedArray fast = EncodedArray::build(a, Encoding::DfsFast).value();
  EXPECT_EQ(EncodedArray::storedEncoding(Encoding::DfsFast), Encoding::Dfs);
  EXPECT_EQ(std::vector<uint8_t>(dfs.data().begin(), dfs.data().end()),
            std::vector<uint8_t>(fast.data().begin(), fast.data().end()));
  EXPECT_TRUE(dfs.setLookup(Encoding::DfsFast));
  EXPECT_EQ(dfs.encoding(), Encoding::DfsFast);
  EXPECT_TRUE(dfs == fast);
  EXPECT_FALSE(dfs.setLookup(Encoding::Rank));
  EXPECT_EQ(dfs.encoding(), Encoding::DfsFast);
}

TEST(EncodeNames, ParseLists) {
  EXPECT_EQ(parseEncodingList("rank").value(), std::vector<Encoding>{Encoding::Rank});
  EXPECT_EQ(parseEncodingList("dfs,dfs-fast,dfs").value(),
            (std::vector<Encoding>{Encoding::Dfs, Encoding::DfsFast}));
  EXPECT_EQ(parseEncodingList("all").value().size(), 7u);
  EXPECT_FALSE(parseEncodingList("rank,,flat").ok());
  EXPECT_FALSE(parseEncodingList("zip").ok());
  for (Encoding e : kAllEncodings) EXPECT_EQ(parseEncodingName(encodingName(e)), e);
}

}  // namespace
}  // namespace somm

namespace somm {
namespace {

// The per-thread memo of the sdag walk is keyed by the array's identity: two arrays with the same layout (same
// root offsets, levels and index prefixes) but different states, looked up alternately, each answer as flat;
// a copy answers as its original, and a parsed array gets its own identity.
TEST(EncodeDag, WalkMemoNeverAnswersForOtherBytes) {
  for (Format f : {Format::TwoState, Format::FourState})
    for (uint32_t level : {6u, 7u, 8u}) {
      const OmmArray a = arrayOf({makeMap(Pattern::Leaf, level, f, 1)});
      OmmArray b = a;
      for (uint8_t& byte : b.data) byte = uint8_t(~byte);  // every state changes (4-state: 0<->3, 1<->2)
      const EncodedArray ea = EncodedArray::build(a, Encoding::Sdag).value();
      const EncodedArray eb = EncodedArray::build(b, Encoding::Sdag).value();
      ASSERT_NE(ea.identity(), eb.identity());
      const EncodedArray copy = ea;
      const EncodedArray parsed = EncodedArray::parse(eb.serialize()).value();
      EXPECT_EQ(copy.identity(), ea.identity());
      EXPECT_NE(parsed.identity(), eb.identity());
      for (uint32_t i = 0; i < microTriangleCount(level); i += 3) {
        ASSERT_EQ(ea.state(0, i), a.state(0, i)) << level << " " << i;
        ASSERT_EQ(eb.state(0, i), b.state(0, i)) << level << " " << i;
        ASSERT_EQ(copy.state(0, i), a.state(0, i)) << level << " " << i;
        ASSERT_EQ(parsed.state(0, i), b.state(0, i)) << level << " " << i;
      }
    }
}

// The next index a test looks up in triangle t of `a` (its level from a's index buffer; 0 for a special index):
// random, 1 + [0, maxStep) past `last`, or `last` with one bit flipped (a walk restarting at any height); kept in
// `last`.
uint32_t nextLookupIndex(std::mt19937& rng, const OmmArray& a, uint32_t t, uint32_t& last, uint32_t maxStep) {
  const uint32_t level = a.indices[t] >= 0 ? a.descriptors[size_t(a.indices[t])].subdivisionLevel : 0;
  const uint32_t n = microTriangleCount(level);
  switch (rng() % 3) {
    case 0:
      last = rng() % n;
      break;
    case 1:
      last = (last + 1 + (maxStep > 1 ? rng() % maxStep : 0)) % n;
      break;
    default:
      last = level ? last ^ (1u << (rng() % (2 * level))) : 0;
  }
  return last;
}

// The per-thread memo of sdag lookups (one entry per triangle hash: the index-buffer value resolved and the
// root's children): any order of lookups answers as flat. 600 triangles (more than the memo's 256 entries, so
// entries are evicted and refilled), maps of every level 0..10 and pattern (uniform maps become special indices,
// noise maps are stored flat inside the sdag array), repeated maps; lookups in random order, stepping to the next
// index, flipping one index bit (every height of the walk), by index and by (u, v), with a second array
// interleaved.
TEST(EncodeDag, WalkMemoAnswersAsFlatInAnyOrder) {
  for (Format f : {Format::TwoState, Format::FourState}) {
    std::mt19937 rng(f == Format::TwoState ? 11u : 12u);
    std::vector<Micromap> maps;
    for (uint32_t t = 0; t < 600; ++t) {
      if (t > 20 && rng() % 4 == 0) {
        maps.push_back(maps[rng() % maps.size()]);
        continue;
      }
      const uint32_t level = rng() % 11;
      maps.push_back(cachedMap(kPatterns[rng() % 6], level, f, 1 + rng() % 3));
    }
    const OmmArray oracle = arrayOf(maps);
    const EncodedArray e = EncodedArray::build(oracle, Encoding::Sdag).value();
    const OmmArray other = arrayOf({cachedMap(Pattern::Leaf, 8, f, 7), cachedMap(Pattern::Disc, 9, f, 7)});
    const EncodedArray o = EncodedArray::build(other, Encoding::Sdag).value();
    bool flatKind = false;
    for (const EncodedMapDesc& d : e.maps()) flatKind |= d.kind == MapKind::Flat;
    EXPECT_TRUE(flatKind);  // the noise maps
    const uint32_t triangles = e.triangleCount();
    std::vector<uint32_t> last(triangles, 0);
    for (uint32_t q = 0; q < 200000; ++q) {
      const uint32_t t = rng() % triangles, i = nextLookupIndex(rng, oracle, t, last[t], 1);
      ASSERT_EQ(e.state(t, i), oracle.state(t, i)) << int(f) << " triangle " << t << " index " << i;
      const float u = float(rng() % 4097) / 4096.0f, v = float(rng() % 4097) / 4096.0f;
      ASSERT_EQ(e.stateUV(t, u, v), oracle.stateUV(t, u, v))
          << int(f) << " triangle " << t << " " << u << " " << v;
      const uint32_t ot = rng() % 2, oi = rng() % microTriangleCount(ot == 1 ? 9 : 8);
      ASSERT_EQ(o.state(ot, oi), other.state(ot, oi)) << int(f) << " other " << ot << " " << oi;
    }
  }
}
// The memo is per thread and on the heap: a thread has none until its first sdag lookup, which allocates it; a
// thread that cannot have one (its allocation failed, or the thread is ending: sdagMemoEnded) walks from the root and
// answers the same. Each case runs on a thread of its own.
TEST(EncodeDag, WalkMemoIsAllocatedPerThreadAndOptional) {
  std::mt19937 rng(21u);
  std::vector<Micromap> maps;
  for (uint32_t t = 0; t < 300; ++t) {
    const uint32_t level = rng() % 11;
    maps.push_back(cachedMap(kPatterns[rng() % 6], level, Format::FourState, 1 + rng() % 3));
  }
  const OmmArray oracle = arrayOf(maps);
  const EncodedArray e = EncodedArray::build(oracle, Encoding::Sdag).value();
  auto lookups = [&](uint32_t seed, bool& sawMemo, bool& haveMemo) {
    std::mt19937 r(seed);
    sawMemo = encode::sdagMemoSlot() != nullptr;
    std::vector<uint32_t> last(e.triangleCount(), 0);
    for (uint32_t q = 0; q < 20000; ++q) {
      const uint32_t t = r() % e.triangleCount(), i = nextLookupIndex(r, oracle, t, last[t], 1);
      ASSERT_EQ(e.state(t, i), oracle.state(t, i)) << "triangle " << t << " index " << i;
      const float u = float(r() % 4097) / 4096.0f, v = float(r() % 4097) / 4096.0f;
      ASSERT_EQ(e.stateUV(t, u, v), oracle.stateUV(t, u, v)) << "triangle " << t << " " << u << " " << v;
    }
    haveMemo = encode::sdagMemoSlot() != nullptr;
  };
  bool saw = true, have = false;
  std::thread([&] { lookups(1, saw, have); }).join();
  EXPECT_FALSE(saw);  // a new thread starts without one
  EXPECT_TRUE(have);  // its first lookup allocated it
  std::thread([&] {
    encode::sdagMemoEnded() = true;  // as if its allocation had failed
    lookups(2, saw, have);
  }).join();
  EXPECT_FALSE(saw);
  EXPECT_FALSE(have);  // every lookup went without it
}

// `base` with a run of micro-triangles (where depends on k) made opaque: distinct maps of one shape for distinct k.
Micromap withOpaqueRun(const Micromap& base, uint32_t k) {
  Micromap m = base;
  const uint32_t n = m.size(), first = uint32_t((uint64_t(k) * 2654435761u) % n);
  for (uint32_t i = first; i < std::min(n, first + 1 + n / 64); ++i) m.set(i, State::Opaque);
  return m;
}
// Lookups in `runs` runs of `perRun` over up to `maxWidth` neighbouring triangles of array e (flat: oracle), a quarter
// of the runs on a second array o (flat: other) instead, each of those lookups followed by onOther(triangle, run);
// afterRun() after every run. Every answer as flat; stops at the first fatal failure.
template <class OnOther, class AfterRun>
void lookupRuns(std::mt19937& rng, Format f, const EncodedArray& e, const OmmArray& oracle,
                const EncodedArray& o, const OmmArray& other, uint32_t runs, uint32_t perRun,
                uint32_t maxWidth, OnOther onOther, AfterRun afterRun) {
  const uint32_t n = e.triangleCount();
  std::vector<uint32_t> last(n, 0);
  for (uint32_t run = 0; run < runs; ++run) {
    const uint32_t first = rng() % n, width = 1 + rng() % maxWidth;
    const bool otherArray = rng() % 4 == 0;
    for (uint32_t q = 0; q < perRun; ++q) {
      const uint32_t t = (first + rng() % width) % n, i = nextLookupIndex(rng, oracle, t, last[t], 16);
      if (otherArray) {
        ASSERT_EQ(o.state(t, i), other.state(t, i)) << int(f) << " other " << t << " " << i;
        onOther(t, run);
        if (::testing::Test::HasFatalFailure()) return;
      } else {
        ASSERT_EQ(e.state(t, i), oracle.state(t, i)) << int(f) << " triangle " << t << " index " << i;
      }
    }
    afterRun();
  }
}
// The per-map grandchild tables of the sdag memo (arrays of at most 256 maps; 64 tables per thread): 180 distinct
// maps of levels 5..10 (every height of the root's children), 400 triangles sharing them, lookups in runs over a few
// triangles at a time (tables filled, kept, taken over by other maps after their owners idle, so that entries
// still holding a table's old owner must stop reading it), interleaved with a second array of the same shapes but
// other states (its maps' roots land in the same tables) and with an array of 300 maps (no tables). Every answer
// as flat.
TEST(EncodeDag, WalkMemoGrandTablesAnswerAsFlat) {
  for (Format f : {Format::TwoState, Format::FourState}) {
    std::mt19937 rng(f == Format::TwoState ? 31u : 32u);
    std::vector<Micromap> maps;
    for (uint32_t k = 0; k < 180; ++k)
      maps.push_back(withOpaqueRun(cachedMap(k % 3 ? Pattern::Leaf : Pattern::Disc, 5 + k % 6, f, 1), k));
    OmmArray oracle = arrayOf(maps);  // 180 descriptors; 400 triangles share them, then the 4 special indices
    oracle.indices.clear();
    for (uint32_t t = 0; t < 400; ++t) oracle.indices.push_back(int32_t(t < 180 ? t : rng() % 180));
    for (int32_t s = -1; s >= -4; --s) oracle.indices.push_back(s);
    OmmArray other = oracle;
    for (uint8_t& byte : other.data) byte = uint8_t(~byte);  // every state changes (4-state: 0<->3, 1<->2)
    const EncodedArray e = EncodedArray::build(oracle, Encoding::Sdag).value();
    const EncodedArray o = EncodedArray::build(other, Encoding::Sdag).value();
    // 300 distinct maps: more than 256, no tables
    std::vector<Micromap> many;
    for (uint32_t k = 0; k < 300; ++k)
      many.push_back(withOpaqueRun(cachedMap(Pattern::Leaf, 5 + k % 3, f, 1), k));
    const OmmArray manyOracle = arrayOf(many);
    const EncodedArray m = EncodedArray::build(manyOracle, Encoding::Sdag).value();
    ASSERT_TRUE(e.keepsGrandTables());
    ASSERT_TRUE(o.keepsGrandTables());
    ASSERT_FALSE(m.keepsGrandTables());
    lookupRuns(
        rng, f, e, oracle, o, other, 3000, 60, 6,
        [&](uint32_t t, uint32_t run) {
          const uint32_t mt = (t + run) % 300, mi = rng() % microTriangleCount(5 + mt % 3);
          ASSERT_EQ(m.state(mt, mi), manyOracle.state(mt, mi)) << int(f) << " many " << mt << " " << mi;
        },
        [] {});
  }
}
// The per-map deep tables of the sdag memo (maps of level >= 8 in arrays of at most 256 maps; 4 tables per thread,
// at[g] = a record below the root's grandchildren: a leaf at levels 8 and 9): 12 distinct maps of levels 8..12
// over 40 triangles, so that maps compete for the 4 tables (taken, kept while their entries are refilled, taken
// over after their owners idle; a map left without one walks from its grandchild table or its root's child),
// lookups in runs over a few triangles, interleaved with a second array of the same shapes but other states (its
// roots land in the same tables). Every answer as flat, and the tables are used.
TEST(EncodeDag, WalkMemoDeepTablesAnswerAsFlat) {
  for (Format f : {Format::TwoState, Format::FourState}) {
    std::mt19937 rng(f == Format::TwoState ? 41u : 42u);
    std::vector<Micromap> maps;
    for (uint32_t k = 0; k < 12; ++k) {
      const uint32_t level = k < 10 ? 8 + k % 3 : 11 + k % 2;
      maps.push_back(withOpaqueRun(cachedMap(k % 2 ? Pattern::Leaf : Pattern::Disc, level, f, 2), k));
    }
    OmmArray oracle = arrayOf(maps);
    oracle.indices.clear();
    for (uint32_t t = 0; t < 40; ++t) oracle.indices.push_back(int32_t(t < 12 ? t : rng() % 12));
    OmmArray other = oracle;
    for (uint8_t& byte : other.data) byte = uint8_t(~byte);  // every state changes (4-state: 0<->3, 1<->2)
    const EncodedArray e = EncodedArray::build(oracle, Encoding::Sdag).value();
    const EncodedArray o = EncodedArray::build(other, Encoding::Sdag).value();
    ASSERT_TRUE(e.keepsGrandTables());
    uint32_t held = 0;  // runs ended while a deep table was e's (counted per table)
    lookupRuns(
        rng, f, e, oracle, o, other, 2000, 80, 4, [](uint32_t, uint32_t) {},
        [&] {
          for (const encode::SdagMemo::Deep& d : encode::sdagMemo().deep) held += d.array == e.identity();
        });
    EXPECT_GT(held, 1000u);
  }
}
// The deepest maps (levels 11 and 12: a 4-way root over height-5 records, a height-6 root) through the memo:
// neighbouring, bit-flipped and random indices (successive lookups differing at every height 2..6), against flat.
TEST(EncodeDag, WalkMemoRestartsAtEveryHeightOfLevels11And12) {
  for (Format f : {Format::TwoState, Format::FourState}) {
    std::mt19937 rng(f == Format::TwoState ? 21u : 22u);
    const OmmArray oracle = arrayOf({cachedMap(Pattern::Leaf, 11, f, 2), cachedMap(Pattern::Disc, 12, f, 2),
                                     cachedMap(Pattern::Leaf, 12, f, 2)});
    const EncodedArray e = EncodedArray::build(oracle, Encoding::Sdag).value();
    std::vector<uint32_t> last(3, 0);
    uint32_t restarts[8] = {};
    for (uint32_t q = 0; q < 300000; ++q) {
      const uint32_t t = rng() % 3, level = t == 0 ? 11u : 12u, n = microTriangleCount(level);
      uint32_t i;
      switch (rng() % 4) {
        case 0:
          i = rng() % n;
          break;
        case 1:
          i = (last[t] + 1 + rng() % 64) % n;
          break;
        default:
          i = last[t] ^ (1u << (rng() % (2 * level)));
      }
      if (i != last[t]) ++restarts[std::min(7u, (uint32_t(std::bit_width(i ^ last[t])) + 3u) >> 2)];
      last[t] = i;
      ASSERT_EQ(e.state(t, i), oracle.state(t, i)) << int(f) << " triangle " << t << " index " << i;
    }
    for (uint32_t h = 2; h <= 6; ++h) EXPECT_GT(restarts[h], 1000u) << "restarts at height " << h;
  }
}
}  // namespace
}  // namespace somm
