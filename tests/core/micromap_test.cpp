// SPDX-License-Identifier: MIT
#include "somm/micromap.h"

#include <gtest/gtest.h>

#include <random>

#include "somm/omm_array.h"

namespace somm {
namespace {

TEST(Micromap, SpecLayoutTwoState) {
  Micromap m(2, Format::TwoState);  // 16 states, 2 bytes
  ASSERT_EQ(m.bytes().size(), 2u);
  m.set(0, State::Opaque);
  m.set(3, State::Opaque);
  m.set(9, State::Opaque);
  m.set(15, State::Opaque);
  EXPECT_EQ(m.bytes()[0], 0x09);  // bits 0 and 3
  EXPECT_EQ(m.bytes()[1], 0x82);  // bits 1 and 7 of byte 1
  EXPECT_EQ(m.get(9), State::Opaque);
  EXPECT_EQ(m.get(10), State::Transparent);
  m.set(3, State::UnknownTransparent);  // stored as its low bit: transparent
  EXPECT_EQ(m.get(3), State::Transparent);
}

TEST(Micromap, SpecLayoutFourState) {
  Micromap m(1, Format::FourState);  // 4 states, 1 byte
  m.set(0, State::Opaque);
  m.set(1, State::UnknownTransparent);
  m.set(2, State::UnknownOpaque);
  m.set(3, State::Transparent);
  EXPECT_EQ(m.bytes()[0], 0b00'11'10'01);
  EXPECT_EQ(m.get(2), State::UnknownOpaque);
  Micromap big(3, Format::FourState);
  ASSERT_EQ(big.bytes().size(), 16u);
  big.set(13, State::UnknownOpaque);  // byte 3, bits 2..3
  EXPECT_EQ(big.bytes()[3], 0x0c);
}

TEST(Micromap, DataBytesFormula) {
  EXPECT_EQ(micromapDataBytes(0, Format::TwoState), 1u);
  EXPECT_EQ(micromapDataBytes(1, Format::TwoState), 1u);
  EXPECT_EQ(micromapDataBytes(2, Format::TwoState), 2u);
  EXPECT_EQ(micromapDataBytes(0, Format::FourState), 1u);
  EXPECT_EQ(micromapDataBytes(1, Format::FourState), 1u);
  EXPECT_EQ(micromapDataBytes(2, Format::FourState), 4u);
  EXPECT_EQ(micromapDataBytes(12, Format::TwoState), 2097152u);
  EXPECT_EQ(micromapDataBytes(12, Format::FourState), 4194304u);
}

TEST(Micromap, UniformStateAndDemotion) {
  for (Format f : {Format::TwoState, Format::FourState})
    for (uint32_t level : {0u, 1u, 2u, 5u}) {
      Micromap m(level, f, State::Opaque);
      ASSERT_EQ(m.uniformState(), State::Opaque);
      m.set(m.size() - 1, State::Transparent);
      if (m.size() > 1) {
        EXPECT_FALSE(m.uniformState().has_value());
      } else {
        EXPECT_EQ(m.uniformState(), State::Transparent);
      }
    }
  Micromap m(2, Format::FourState, State::UnknownOpaque);
  m.set(4, State::UnknownTransparent);
  m.set(5, State::Opaque);
  const Micromap two = m.toTwoStateMap();
  EXPECT_EQ(two.format(), Format::TwoState);
  EXPECT_EQ(two.get(0), State::Opaque);
  EXPECT_EQ(two.get(4), State::Transparent);
  EXPECT_EQ(two.get(5), State::Opaque);
  EXPECT_EQ(toTwoState(State::UnknownTransparent), State::Transparent);
  EXPECT_EQ(toTwoState(State::UnknownOpaque), State::Opaque);
}

TEST(Micromap, GetSetByBarycentrics) {
  Micromap m(2, Format::FourState);
  m.setUV(0.5f, 0.25f, State::UnknownOpaque);
  EXPECT_EQ(m.get(11), State::UnknownOpaque);
  EXPECT_EQ(m.getUV(0.55f, 0.27f), State::UnknownOpaque);
}

// Maps are stored in fixed-size chunks until finish(): a map that straddles a chunk boundary (16 MiB) is found
// again by its exact bytes, one that differs only in its last byte is not, and finish() gives the plain
// concatenation in order of first appearance.
TEST(OmmArray, BuilderDedupAcrossDataChunks) {
  OmmArrayBuilder b;
  Micromap tiny(1, Format::FourState);
  tiny.set(0, State::Opaque);  // 1 byte: every later 1 MiB map is offset by one byte from the chunk grid
  std::vector<Micromap> maps;
  for (uint32_t k = 0; k < 17; ++k) {
    Micromap m(11, Format::FourState);  // 2^22 micro-triangles × 2 bits = 1 MiB
    m.set(k, State::Opaque);
    m.set(m.size() - 1 - k, State::UnknownOpaque);
    maps.push_back(std::move(m));
  }
  ASSERT_EQ(maps[0].bytes().size(), size_t(1) << 20);
  EXPECT_EQ(b.add(tiny), 0);
  for (uint32_t k = 0; k < 17; ++k) EXPECT_EQ(b.add(maps[k]), int32_t(k + 1));
  EXPECT_EQ(b.dataBytes(), 1 + (size_t(17) << 20));
  // maps[15] occupies [1 + 15 MiB, 1 + 16 MiB): its last byte is in the second chunk.
  EXPECT_EQ(b.add(maps[15]), 16);
  Micromap last = maps[15];
  last.set(last.size() - 1, State::Opaque);  // differs in the straddling map's last byte only
  EXPECT_EQ(b.add(last), 18);
  EXPECT_EQ(b.add(tiny), 0);
  const OmmArray arr = b.finish();
  std::vector<uint8_t> expect(tiny.bytes().begin(), tiny.bytes().end());
  for (const Micromap& m : maps) expect.insert(expect.end(), m.bytes().begin(), m.bytes().end());
  expect.insert(expect.end(), last.bytes().begin(), last.bytes().end());
  EXPECT_TRUE(arr.data == expect);
  ASSERT_EQ(arr.descriptors.size(), 19u);
  EXPECT_EQ(arr.descriptors[16].dataOffset, 1 + (uint32_t(15) << 20));
  EXPECT_EQ(arr.descriptors[18].dataOffset, 1 + (uint32_t(17) << 20));
  EXPECT_EQ(arr.indices.size(), 21u);
}

// reserveData() puts the maps into one reserved buffer that finish() hands over (no copy), and maps past the hint
// into chunks; intern(map, keyOf(map)) is intern(map). Whatever the hint, the array is the same: the same indices,
// descriptors and bytes as a builder without one, and equal maps are found in the head, in the chunks and across.
TEST(OmmArray, BuilderReservedHeadEqualsChunks) {
  std::vector<Micromap> maps;
  uint64_t seed = 12345;
  auto next = [&seed] {
    seed = seed * 6364136223846793005ull + 1442695040888963407ull;
    return uint32_t(seed >> 33);
  };
  for (uint32_t k = 0; k < 60; ++k) {
    Micromap m(3 + k % 4, k % 3 ? Format::FourState : Format::TwoState);
    if (k % 7 == 3) {
      maps.push_back(Micromap(m.level(), m.format(), State::Opaque));  // uniform: a special index
      continue;
    }
    for (uint32_t i = 0; i < m.size(); ++i)
      m.set(i, State(next() % (m.format() == Format::FourState ? 4 : 2)));
    maps.push_back(std::move(m));
  }
  for (uint32_t k = 0; k < 40; ++k) maps.push_back(maps[next() % 60]);  // repeats, stored once
  OmmArrayBuilder plain;
  for (const Micromap& m : maps) plain.add(m);
  const size_t total = plain.dataBytes();
  const OmmArray expect = plain.finish();
  ASSERT_GT(total, 0u);
  for (const size_t hint : {size_t(0), size_t(1), total / 2, total, 4 * total}) {
    OmmArrayBuilder b;
    b.reserveData(hint);
    for (const Micromap& m : maps) {
      const OmmArrayBuilder::MapKey key = OmmArrayBuilder::keyOf(m);
      EXPECT_EQ(key.uniform, m.uniformState());
      const int32_t id = b.intern(m, key);
      EXPECT_EQ(b.intern(m), id);  // unkeyed: the same index, nothing stored twice
      b.addIndex(id);
    }
    EXPECT_EQ(b.dataBytes(), total) << "hint " << hint;
    const OmmArray arr = b.finish();
    EXPECT_EQ(arr.indices, expect.indices) << "hint " << hint;
    EXPECT_EQ(arr.descriptors, expect.descriptors) << "hint " << hint;
    EXPECT_TRUE(arr.data == expect.data) << "hint " << hint;
    EXPECT_EQ(arr.histogram, expect.histogram);
    // The builder is empty again: a second array starts from offset 0.
    EXPECT_EQ(b.add(maps[0]), 0);
    EXPECT_TRUE(b.finish().data == std::vector<uint8_t>(maps[0].bytes().begin(), maps[0].bytes().end()));
  }
}

TEST(OmmArray, DedupSpecialIndicesAndBytes) {
  OmmArrayBuilder b;
  Micromap a(1, Format::FourState);
  a.set(0, State::Opaque);  // states 1,0,0,0 → byte 0x01
  Micromap c(1, Format::TwoState);
  c.set(2, State::Opaque);  // byte 0x04
  EXPECT_EQ(b.add(Micromap(3, Format::FourState, State::Opaque)), -2);
  EXPECT_EQ(b.add(a), 0);
  EXPECT_EQ(b.add(Micromap(0, Format::TwoState, State::Transparent)), -1);
  EXPECT_EQ(b.add(c), 1);
  EXPECT_EQ(b.add(a), 0);  // identical → stored once
  EXPECT_EQ(b.add(Micromap(2, Format::FourState, State::UnknownTransparent)), -3);
  EXPECT_EQ(b.add(Micromap(2, Format::FourState, State::UnknownOpaque)), -4);
  const OmmArray arr = b.finish();
  EXPECT_EQ(arr.data, (std::vector<uint8_t>{0x01, 0x04}));
  ASSERT_EQ(arr.descriptors.size(), 2u);
  EXPECT_EQ(arr.descriptors[0], (TriangleDescriptor{0, 1, 2}));
  EXPECT_EQ(arr.descriptors[1], (TriangleDescriptor{1, 1, 1}));
  EXPECT_EQ(arr.indices, (std::vector<int32_t>{-2, 0, -1, 1, 0, -3, -4}));
  EXPECT_EQ(arr.indexType(), IndexType::UInt16);
  EXPECT_EQ(arr.indexBufferBytes(), (std::vector<uint8_t>{0xfe, 0xff, 0x00, 0x00, 0xff, 0xff, 0x01, 0x00,
                                                          0x00, 0x00, 0xfd, 0xff, 0xfc, 0xff}));
  EXPECT_EQ(arr.descriptorBytes(), (std::vector<uint8_t>{0, 0, 0, 0, 1, 0, 2, 0, 1, 0, 0, 0, 1, 0, 1, 0}));
  ASSERT_EQ(arr.histogram.size(), 2u);
  EXPECT_EQ(arr.histogram[0], (UsageCount{1, 1, 1}));
  EXPECT_EQ(arr.histogram[1], (UsageCount{1, 1, 2}));
  EXPECT_EQ(arr.triangleHistogram[1], (UsageCount{2, 1, 2}));
  EXPECT_EQ(arr.state(0, 3), State::Opaque);
  EXPECT_EQ(arr.state(1, 0), State::Opaque);
  EXPECT_EQ(arr.state(1, 1), State::Transparent);
  EXPECT_EQ(arr.state(3, 2), State::Opaque);
  EXPECT_EQ(arr.state(5, 0), State::UnknownTransparent);
  EXPECT_EQ(arr.stateUV(1, 0.1f, 0.1f), State::Opaque);
}

TEST(OmmArray, WideIndicesWhenDescriptorsExceed16Bits) {
  OmmArrayBuilder b;
  for (uint32_t i = 0; i < 70000; ++i) {
    Micromap m(4, Format::TwoState);
    for (uint32_t bit = 0; bit < 17; ++bit)
      if ((i >> bit) & 1u) m.set(bit, State::Opaque);
    m.set(200, State::Opaque);  // never uniform
    ASSERT_EQ(b.add(m), int32_t(i));
  }
  b.addSpecial(State::Opaque);
  const OmmArray arr = b.finish();
  EXPECT_EQ(arr.indexType(), IndexType::UInt32);
  const auto bytes = arr.indexBufferBytes();
  ASSERT_EQ(bytes.size(), 70001u * 4);
  EXPECT_EQ(bytes[4 * 69999 + 0], uint8_t(69999 & 0xff));
  EXPECT_EQ(bytes[4 * 70000 + 3], 0xff);  // -2 as uint32 = 0xfffffffe
  EXPECT_EQ(bytes[4 * 70000 + 0], 0xfe);
  EXPECT_EQ(arr.data.size(), 70000u * 32);
}

// ---- vertex orders: checked against the geometry of indexToMicroTriangle ----

// The 6 vertex orders (order[k] = the vertex of T that is vertex k of T').
const VertexOrder kAllOrders[6] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

// A grid point of T' (units of 2^-level, weights of T''s vertices 1 and 2) as weights (w0, w1, w2) of T's vertices.
std::array<uint32_t, 3> inT(GridPoint p, uint32_t n, const VertexOrder& order) {
  const uint32_t w[3] = {n - p.u - p.v, p.u, p.v};
  std::array<uint32_t, 3> r{};
  for (int k = 0; k < 3; ++k) r[order[k]] = w[k];
  return r;
}

TEST(VertexOrder, ReorderedMapReadsTheSameRegions) {
  std::mt19937 rng(7);
  for (Format f : {Format::TwoState, Format::FourState})
    for (uint32_t level = 0; level <= 6; ++level) {
      Micromap map(level, f);
      for (uint32_t i = 0; i < map.size(); ++i) map.set(i, State(rng() & 3u));
      const uint32_t n = 1u << level;
      for (const VertexOrder& order : kAllOrders) {
        ASSERT_TRUE(isVertexOrder(order));
        Micromap out;
        reorderVertices(map, order, out);
        ASSERT_EQ(out.level(), level);
        ASSERT_EQ(out.format(), f);
        for (uint32_t i = 0; i < map.size(); ++i) {
          // Micro-triangle i of T' as a region of T: its centroid picks T's micro-triangle.
          const MicroTriangle m = indexToMicroTriangle(i, level);
          uint32_t s1 = 0, s2 = 0;
          for (const GridPoint& p : m.v) {
            const auto w = inT(p, n, order);
            s1 += w[1];
            s2 += w[2];
          }
          const uint32_t j = baryToIndex(float(s1) / float(3 * n), float(s2) / float(3 * n), level);
          ASSERT_EQ(out.get(i), map.get(j)) << "level " << level << " order " << int(order[0])
                                            << int(order[1]) << int(order[2]) << " index " << i;
        }
        // Back with the inverse order gives the map again; unused bits of a partial byte stay zero.
        VertexOrder inverse{};
        for (uint8_t k = 0; k < 3; ++k) inverse[order[k]] = k;
        Micromap back;
        reorderVertices(out, inverse, back);
        EXPECT_EQ(back, map);
      }
    }
  EXPECT_FALSE(isVertexOrder({0, 0, 1}));
  EXPECT_FALSE(isVertexOrder({0, 1, 3}));
}

TEST(VertexOrder, ReorderedNodeIsTheSameTriangleInItsOwnOrder) {
  for (uint32_t depth = 0; depth <= 5; ++depth) {
    const uint32_t n = 1u << depth;
    for (const VertexOrder& order : kAllOrders)
      for (uint32_t q = 0; q < (1u << (2 * depth)); ++q) {
        VertexOrder nodeOrder{};
        const uint32_t q2 = reorderedNode(q, depth, order, &nodeOrder);
        ASSERT_LT(q2, 1u << (2 * depth));
        // Node q of T and node q2 of T' in their own windings, both as weights of T's vertices.
        const MicroTriangle a = indexToMicroTriangle(q, depth), b = indexToMicroTriangle(q2, depth);
        for (int k = 0; k < 3; ++k) {
          const auto wb = inT(b.v[k], n, order);
          const GridPoint pa = a.v[nodeOrder[k]];
          EXPECT_EQ(wb[1], pa.u) << depth << " " << q << " " << k;
          EXPECT_EQ(wb[2], pa.v) << depth << " " << q << " " << k;
        }
        // The node's micro-triangles at a deeper level are the block of node q2.
        if (depth <= 3) {
          Micromap map(depth + 2, Format::FourState, State::Transparent);
          for (uint32_t i = q * 16; i < q * 16 + 16; ++i) map.set(i, State::Opaque);
          Micromap out;
          reorderVertices(map, order, out);
          for (uint32_t i = 0; i < out.size(); ++i)
            EXPECT_EQ(out.get(i), (i >> 4) == q2 ? State::Opaque : State::Transparent);
        }
      }
  }
}

}  // namespace
}  // namespace somm

// ---- SceneMicromaps ----

namespace {
somm::OmmArray arrayOfMaps(const std::vector<somm::Micromap>& maps) {
  somm::OmmArrayBuilder b;
  for (const auto& m : maps) b.add(m);
  return b.finish();
}
somm::Micromap checker(uint32_t level, uint32_t phase) {
  somm::Micromap m(level, somm::Format::FourState);
  for (uint32_t i = 0; i < m.size(); ++i) m.set(i, somm::State((i + phase) % 4));
  return m;
}
}  // namespace

TEST(SceneMicromaps, MergeSharesIdenticalMapsAcrossGeometriesAndKeepsStates) {
  using namespace somm;
  const Micromap a = checker(2, 0), b = checker(2, 1), c = checker(3, 2);
  const Micromap opaque(1, Format::FourState, State::Opaque);
  std::vector<OmmArray> per{arrayOfMaps({a, b, opaque}), arrayOfMaps({b, c, a, a})};
  const SceneMicromaps split = perGeometryMicromaps(per);
  ASSERT_EQ(split.arrays.size(), 2u);
  const SceneMicromaps merged = mergeToSceneArray(split);
  ASSERT_EQ(merged.arrays.size(), 1u);
  EXPECT_EQ(merged.arrays[0].descriptors.size(), 3u);  // a, b, c once each
  EXPECT_EQ(merged.arrays[0].indices, (std::vector<int32_t>{0, 1, -2, 1, 2, 0, 0}));
  EXPECT_EQ(merged.geometries[1].firstTriangle, 3u);
  EXPECT_EQ(merged.geometries[1].triangleCount, 4u);
  EXPECT_EQ(merged.indices(1)[1], 2);
  for (uint32_t g = 0; g < 2; ++g)
    for (uint32_t t = 0; t < split.geometries[g].triangleCount; ++t)
      for (uint32_t i = 0; i < 64; ++i) {
        const uint32_t lv =
            split.arrayOf(g).indices[t] < 0
                ? 0
                : split.arrayOf(g).descriptors[size_t(split.arrayOf(g).indices[t])].subdivisionLevel;
        if (i >= microTriangleCount(lv)) break;
        EXPECT_EQ(merged.state(g, t, i), split.state(g, t, i));
      }
  // Geometry 1's own triangle usage: b, c, a, a → level 2 ×3, level 3 ×1.
  const auto h = merged.triangleHistogram(1);
  ASSERT_EQ(h.size(), 2u);
  EXPECT_EQ(h[0], (UsageCount{3, 2, 2}));
  EXPECT_EQ(h[1], (UsageCount{1, 3, 2}));
  // standalone(g) gives back a per-geometry array equal to the original.
  EXPECT_EQ(merged.standalone(1).descriptors.size(), 3u);
  EXPECT_EQ(merged.standalone(0).data, per[0].data);
  EXPECT_EQ(merged.standalone(0).indices, per[0].indices);
}
