// SPDX-License-Identifier: MIT
#include "somm/omm_array.h"

#include <algorithm>
#include <cstring>

namespace somm {

namespace {

uint64_t mix(uint64_t h, uint64_t x) {
  h ^= x + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
  h *= 0xff51afd7ed558ccdull;
  return h ^ (h >> 33);
}

uint64_t hashMap(const Micromap& m) {
  uint64_t h = mix(uint64_t(m.level()) << 8 | uint64_t(m.format()), 0x51u);
  const auto bytes = m.bytes();
  size_t i = 0;
  for (; i + 8 <= bytes.size(); i += 8) {
    uint64_t w;
    std::memcpy(&w, bytes.data() + i, 8);
    h = mix(h, w);
  }
  uint64_t tail = 0;
  for (size_t k = 0; i < bytes.size(); ++i, ++k) tail |= uint64_t(bytes[i]) << (8 * k);
  return mix(h, tail);
}

void putU32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
}
void putU16(std::vector<uint8_t>& out, uint16_t v) {
  out.push_back(uint8_t(v));
  out.push_back(uint8_t(v >> 8));
}

}  // namespace

IndexType OmmArray::indexType() const noexcept {
  for (int32_t i : indices)
    if (i >= 0 && i > 0xfffb) return IndexType::UInt32;  // 0xfffc..0xffff are the 16-bit special values
  return IndexType::UInt16;
}

std::vector<uint8_t> OmmArray::indexBufferBytes() const {
  std::vector<uint8_t> out;
  const bool wide = indexType() == IndexType::UInt32;
  out.reserve(indices.size() * (wide ? 4 : 2));
  for (int32_t i : indices) {
    if (wide)
      putU32(out, uint32_t(i));
    else
      putU16(out, uint16_t(uint32_t(i)));  // -1 → 0xffff ... -4 → 0xfffc
  }
  return out;
}

std::vector<uint8_t> OmmArray::descriptorBytes() const {
  std::vector<uint8_t> out;
  out.reserve(descriptors.size() * 8);
  for (const TriangleDescriptor& d : descriptors) {
    putU32(out, d.dataOffset);
    putU16(out, d.subdivisionLevel);
    putU16(out, d.format);
  }
  return out;
}

State OmmArray::state(uint32_t triangle, uint32_t index) const noexcept {
  const int32_t i = indices[triangle];
  if (i < 0) return stateOfSpecialIndex(i);
  const TriangleDescriptor& d = descriptors[size_t(i)];
  return readPackedState(data.data() + d.dataOffset, Format(d.format), index);
}

State OmmArray::stateUV(uint32_t triangle, float u, float v) const noexcept {
  const int32_t i = indices[triangle];
  if (i < 0) return stateOfSpecialIndex(i);
  const TriangleDescriptor& d = descriptors[size_t(i)];
  return readPackedState(data.data() + d.dataOffset, Format(d.format), baryToIndex(u, v, d.subdivisionLevel));
}

void OmmArrayBuilder::addSpecial(State s) {
  array_.indices.push_back(specialIndexFor(s));
}

void OmmArrayBuilder::grow() {
  std::vector<std::vector<Slot>> next(buckets_.size() * 4);
  for (auto& b : buckets_)
    for (const Slot& s : b) next[s.hash & (next.size() - 1)].push_back(s);
  buckets_.swap(next);
}

int32_t OmmArrayBuilder::add(const Micromap& map) {
  const int32_t id = intern(map);
  array_.indices.push_back(id);
  return id;
}

int32_t OmmArrayBuilder::intern(const Micromap& map) {
  if (auto u = map.uniformState()) return specialIndexFor(*u);
  const uint64_t h = hashMap(map);
  auto& bucket = buckets_[h & (buckets_.size() - 1)];
  const auto bytes = map.bytes();
  for (const Slot& s : bucket) {
    if (s.hash != h) continue;
    const TriangleDescriptor& d = array_.descriptors[size_t(s.descriptor)];
    if (d.subdivisionLevel == map.level() && d.format == uint16_t(map.format()) &&
        storedEquals(d.dataOffset, bytes.data(), bytes.size()))
      return s.descriptor;
  }
  const int32_t id = int32_t(array_.descriptors.size());
  array_.descriptors.push_back(
      TriangleDescriptor{uint32_t(dataSize_), uint16_t(map.level()), uint16_t(map.format())});
  store(bytes.data(), bytes.size());
  bucket.push_back(Slot{h, id});
  if (++uniqueCount_ > buckets_.size() * 2) grow();
  return id;
}

UsageHistograms countUsage(Span<const TriangleDescriptor> descriptors, Span<const int32_t> indices) {
  auto bump = [](std::vector<UsageCount>& hist, const TriangleDescriptor& d) {
    auto it = std::find_if(hist.begin(), hist.end(), [&](const UsageCount& c) {
      return c.subdivisionLevel == d.subdivisionLevel && c.format == d.format;
    });
    if (it == hist.end())
      hist.push_back(UsageCount{1, d.subdivisionLevel, d.format});
    else
      ++it->count;
  };
  auto order = [](const UsageCount& x, const UsageCount& y) {
    return x.format != y.format ? x.format < y.format : x.subdivisionLevel < y.subdivisionLevel;
  };
  UsageHistograms h;
  for (const TriangleDescriptor& d : descriptors) bump(h.micromaps, d);
  for (int32_t i : indices)
    if (i >= 0 && size_t(i) < descriptors.size()) bump(h.triangles, descriptors[size_t(i)]);
  std::sort(h.micromaps.begin(), h.micromaps.end(), order);
  std::sort(h.triangles.begin(), h.triangles.end(), order);
  return h;
}

void computeUsageHistograms(OmmArray& a) {
  UsageHistograms h = countUsage(a.descriptors, a.indices);
  a.histogram = std::move(h.micromaps);
  a.triangleHistogram = std::move(h.triangles);
}

void OmmArrayBuilder::store(const uint8_t* p, size_t n) {
  dataSize_ += n;
  while (n) {
    if (chunks_.empty() || chunks_.back().size() == kChunkBytes) {
      chunks_.emplace_back();
      // Later chunks are reserved whole; the first grows with the data (small bakes allocate little).
      if (chunks_.size() > 1) chunks_.back().reserve(kChunkBytes);
    }
    std::vector<uint8_t>& c = chunks_.back();
    const size_t k = std::min(n, kChunkBytes - c.size());
    c.insert(c.end(), p, p + k);
    p += k;
    n -= k;
  }
}

bool OmmArrayBuilder::storedEquals(size_t offset, const uint8_t* p, size_t n) const {
  while (n) {
    const std::vector<uint8_t>& c = chunks_[offset / kChunkBytes];
    const size_t at = offset % kChunkBytes, k = std::min(n, c.size() - at);
    if (std::memcmp(c.data() + at, p, k) != 0) return false;
    offset += k;
    p += k;
    n -= k;
  }
  return true;
}

OmmArray OmmArrayBuilder::finish() {
  // One contiguous copy of the chunks, each freed once copied: the data is held about once (+ one chunk), never
  // twice as a growing vector's reallocation would.
  array_.data.reserve(dataSize_);
  for (std::vector<uint8_t>& c : chunks_) {
    array_.data.insert(array_.data.end(), c.begin(), c.end());
    std::vector<uint8_t>().swap(c);
  }
  chunks_.clear();
  dataSize_ = 0;
  computeUsageHistograms(array_);
  OmmArray out = std::move(array_);
  array_ = OmmArray{};
  buckets_.assign(1024, {});
  uniqueCount_ = 0;
  return out;
}

// ---- SceneMicromaps ----

namespace {
Micromap mapOf(const OmmArray& a, int32_t descriptor) {
  const TriangleDescriptor& d = a.descriptors[size_t(descriptor)];
  Micromap m(d.subdivisionLevel, Format(d.format));
  auto bytes = m.bytes();
  std::memcpy(bytes.data(), a.data.data() + d.dataOffset, bytes.size());
  return m;
}
}  // namespace

std::vector<UsageCount> SceneMicromaps::triangleHistogram(uint32_t g) const {
  const OmmArray& a = arrayOf(g);
  return countUsage(a.descriptors, Span<const int32_t>(indices(g), geometries[g].triangleCount)).triangles;
}

OmmArray SceneMicromaps::standalone(uint32_t g) const {
  const OmmArray& a = arrayOf(g);
  const int32_t* idx = indices(g);
  OmmArrayBuilder b;
  for (uint32_t t = 0; t < geometries[g].triangleCount; ++t) {
    if (idx[t] < 0)
      b.addSpecial(stateOfSpecialIndex(idx[t]));
    else
      b.add(mapOf(a, idx[t]));
  }
  return b.finish();
}

SceneMicromaps perGeometryMicromaps(std::vector<OmmArray> perGeometry) {
  SceneMicromaps s;
  s.geometries.resize(perGeometry.size());
  for (size_t g = 0; g < perGeometry.size(); ++g)
    s.geometries[g] = GeometryMicromaps{uint32_t(g), 0, uint32_t(perGeometry[g].indices.size())};
  s.arrays = std::move(perGeometry);
  return s;
}

SceneMicromaps mergeToSceneArray(const SceneMicromaps& in) {
  SceneMicromaps out;
  OmmArrayBuilder b;
  out.geometries.resize(in.geometries.size());
  for (uint32_t g = 0; g < in.geometries.size(); ++g) {
    const OmmArray& a = in.arrayOf(g);
    const int32_t* idx = in.indices(g);
    out.geometries[g] = GeometryMicromaps{0, b.triangleCount(), in.geometries[g].triangleCount};
    for (uint32_t t = 0; t < in.geometries[g].triangleCount; ++t) {
      if (idx[t] < 0)
        b.addSpecial(stateOfSpecialIndex(idx[t]));
      else
        b.add(mapOf(a, idx[t]));
    }
  }
  out.arrays.push_back(b.finish());
  return out;
}

}  // namespace somm
