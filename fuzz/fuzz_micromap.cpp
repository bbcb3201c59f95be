// SPDX-License-Identifier: MIT
// Fuzz target: Micromap and OmmArray invariants. The input describes a sequence of micromaps (level, format,
// fill and a list of set() operations); they are added to an OmmArrayBuilder and the finished array must
// answer every lookup exactly as the maps do, dedupe identical maps, turn uniform maps into special indices,
// and serialise its index and descriptor buffers consistently.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "somm/micromap.h"
#include "somm/omm_array.h"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz_micromap: %s\n", what);
  std::abort();
}

struct Reader {
  const uint8_t* p;
  size_t n;
  uint8_t u8() {
    if (n == 0) return 0;
    --n;
    return *p++;
  }
  uint32_t u32() {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(u8()) << (8 * i);
    return v;
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Reader r{data, size};
  somm::OmmArrayBuilder builder;
  std::vector<somm::Micromap> maps;
  while (r.n > 0 && maps.size() < 64) {
    const uint8_t head = r.u8();
    const uint32_t level = head % 7;  // up to 4096 micro-triangles per map keeps each run fast
    const somm::Format format = (head & 0x80) ? somm::Format::FourState : somm::Format::TwoState;
    const somm::State fill = somm::State((head >> 3) & 3);
    somm::Micromap m(level, format, fill);
    const uint32_t ops = r.u8() % 32;
    for (uint32_t k = 0; k < ops; ++k) {
      const uint32_t index = r.u32() % m.size();
      const somm::State s = somm::State(r.u8() & 3);
      m.set(index, s);
      const somm::State want = format == somm::Format::TwoState ? somm::toTwoState(s) : s;
      if (m.get(index) != want) fail("set/get mismatch");
    }
    // Padding bits beyond the last state stay zero.
    const uint64_t bits = uint64_t(m.size()) * somm::bitsPerState(format);
    if (m.bytes().size() != somm::micromapDataBytes(level, format))
      fail("byte size differs from the formula");
    if (bits % 8 != 0 && (m.bytes().back() >> (bits % 8)) != 0) fail("padding bits not zero");
    // uniformState agrees with a scan.
    bool uniform = true;
    for (uint32_t i = 1; i < m.size(); ++i) uniform = uniform && m.get(i) == m.get(0);
    const auto us = m.uniformState();
    if (uniform != us.has_value() || (us && *us != m.get(0))) fail("uniformState disagrees with a scan");
    // 2-state demotion.
    const somm::Micromap two = m.toTwoStateMap();
    if (two.format() != somm::Format::TwoState || two.level() != level) fail("toTwoStateMap header");
    for (uint32_t i = 0; i < m.size(); ++i)
      if (two.get(i) != somm::toTwoState(m.get(i))) fail("toTwoStateMap state");
    const int32_t id = builder.add(m);
    if (us) {
      if (id != somm::specialIndexFor(*us)) fail("uniform map did not become its special index");
    } else if (id < 0) {
      fail("non-uniform map got a special index");
    }
    maps.push_back(std::move(m));
  }
  const somm::OmmArray a = builder.finish();
  if (a.indices.size() != maps.size()) fail("triangle count");
  size_t dataEnd = 0;
  for (size_t d = 0; d < a.descriptors.size(); ++d) {
    const somm::TriangleDescriptor& desc = a.descriptors[d];
    if (desc.subdivisionLevel > somm::kMaxLevel || !somm::isValidFormat(desc.format)) fail("bad descriptor");
    if (desc.dataOffset != dataEnd) fail("descriptors not packed in order");
    dataEnd += somm::micromapDataBytes(desc.subdivisionLevel, somm::Format(desc.format));
    for (size_t e = 0; e < d; ++e) {  // identical maps are stored once
      const somm::TriangleDescriptor& o = a.descriptors[e];
      if (o.subdivisionLevel == desc.subdivisionLevel && o.format == desc.format &&
          std::memcmp(a.data.data() + o.dataOffset, a.data.data() + desc.dataOffset,
                      somm::micromapDataBytes(desc.subdivisionLevel, somm::Format(desc.format))) == 0)
        fail("duplicate micromap stored twice");
    }
  }
  if (dataEnd != a.data.size()) fail("data size");
  for (size_t t = 0; t < maps.size(); ++t) {
    const somm::Micromap& m = maps[t];
    for (uint32_t i = 0; i < m.size(); ++i)
      if (a.state(uint32_t(t), i) != m.get(i)) fail("OmmArray::state differs from the micromap");
    const float u = float(t % 7) / 7.0f, v = float(t % 5) / 11.0f;
    if (a.stateUV(uint32_t(t), u, v) != m.getUV(u, v)) fail("OmmArray::stateUV differs from the micromap");
  }
  // Buffers: descriptors 8 bytes each; the index buffer decodes back to the indices.
  const std::vector<uint8_t> db = a.descriptorBytes();
  if (db.size() != 8 * a.descriptors.size()) fail("descriptor bytes size");
  const std::vector<uint8_t> ib = a.indexBufferBytes();
  const size_t w = a.indexType() == somm::IndexType::UInt32 ? 4 : 2;
  if (ib.size() != w * a.indices.size()) fail("index buffer size");
  for (size_t t = 0; t < a.indices.size(); ++t) {
    uint32_t raw = 0;
    for (size_t k = 0; k < w; ++k) raw |= uint32_t(ib[w * t + k]) << (8 * k);
    const int32_t back = w == 2 && raw >= 0xfffcu ? int32_t(raw) - 0x10000 : int32_t(raw);
    if (back != a.indices[t]) fail("index buffer does not decode to the indices");
  }
  // Usage histograms count every descriptor / referencing triangle once.
  uint64_t hs = 0, ts = 0, refs = 0;
  for (const auto& h : a.histogram) hs += h.count;
  for (const auto& h : a.triangleHistogram) ts += h.count;
  for (int32_t i : a.indices) refs += i >= 0;
  if (hs != a.descriptors.size() || ts != refs) fail("usage histogram totals");
  return 0;
}
