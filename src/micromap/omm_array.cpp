// SPDX-License-Identifier: MIT
#include "somm/omm_array.h"

#include <algorithm>
#include <cassert>
#include <cstring>
#include <exception>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace somm {

namespace {

uint64_t mix(uint64_t h, uint64_t x) {
  h ^= x + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
  h *= 0xff51afd7ed558ccdull;
  return h ^ (h >> 33);
}

// Four independent lanes over 32-byte blocks (a level-9 map is 64 KiB: one chain of multiplies would be the
// builder's main cost), then the rest word by word into the first lane, then the lanes and the tail combined.
uint64_t hashMap(const Micromap& m) {
  const uint64_t seed = mix(uint64_t(m.level()) << 8 | uint64_t(m.format()), 0x51u);
  uint64_t lane[4] = {seed, seed ^ 1u, seed ^ 2u, seed ^ 3u};
  const auto bytes = m.bytes();
  const uint8_t* p = bytes.data();
  const size_t n = bytes.size();
  size_t i = 0;
  for (; i + 32 <= n; i += 32)
    for (int k = 0; k < 4; ++k) {
      uint64_t w;
      std::memcpy(&w, p + i + 8 * k, 8);
      lane[k] = mix(lane[k], w);
    }
  for (; i + 8 <= n; i += 8) {
    uint64_t w;
    std::memcpy(&w, p + i, 8);
    lane[0] = mix(lane[0], w);
  }
  uint64_t tail = 0;
  for (size_t k = 0; i < n; ++i, ++k) tail |= uint64_t(p[i]) << (8 * k);
  return mix(mix(mix(mix(lane[0], lane[1]), lane[2]), lane[3]), tail);
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

OmmArrayBuilder::MapKey OmmArrayBuilder::keyOf(const Micromap& map) {
  MapKey k;
  k.uniform = map.uniformState();
  if (!k.uniform) k.hash = hashMap(map);
  return k;
}

int32_t OmmArrayBuilder::intern(const Micromap& map) {
  return intern(map, keyOf(map));
}

int32_t OmmArrayBuilder::intern(const Micromap& map, const MapKey& key) {
  assert(key.uniform == map.uniformState() && (key.uniform || key.hash == hashMap(map)));
  if (key.uniform) return specialIndexFor(*key.uniform);
  const uint64_t h = key.hash;
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

void OmmArrayBuilder::reserveData(size_t bytes) {
  if (dataSize_ != 0 || !chunks_.empty() || bytes <= head_.capacity()) return;
  try {
    head_.reserve(bytes);
  } catch (const std::exception&) {  // too large to reserve: the chunks take the maps, as without the hint
    return;
  }
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  // Large heads fault in 2 MiB pages where the kernel allows it (transparent huge pages in "madvise" mode): storing
  // a level-9 scene's maps otherwise spends most of its time in 4 KiB page faults.
  constexpr size_t kPage = size_t(2) << 20;
  const size_t lead = (kPage - (reinterpret_cast<uintptr_t>(head_.data()) & (kPage - 1))) & (kPage - 1);
  if (head_.capacity() > lead + kPage)
    madvise(head_.data() + lead, (head_.capacity() - lead) & ~(kPage - 1), MADV_HUGEPAGE);
#endif
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
  if (chunks_.empty() && n <= head_.capacity() - head_.size()) {
    head_.insert(head_.end(), p, p + n);
    return;
  }
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
  if (offset < head_.size()) {
    const size_t k = std::min(n, head_.size() - offset);
    if (std::memcmp(head_.data() + offset, p, k) != 0) return false;
    offset += k;
    p += k;
    n -= k;
  }
  offset -= head_.size();
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
  if (chunks_.empty()) {
    // Everything fitted the reserved head (or there is no data): handed over as it is.
    array_.data = std::move(head_);
  } else {
    // One contiguous copy of the head and the chunks, each chunk freed once copied: the data is held about once (+
    // one chunk), never twice as a growing vector's reallocation would.
    array_.data.reserve(dataSize_);
    array_.data.insert(array_.data.end(), head_.begin(), head_.end());
    std::vector<uint8_t>().swap(head_);
    for (std::vector<uint8_t>& c : chunks_) {
      array_.data.insert(array_.data.end(), c.begin(), c.end());
      std::vector<uint8_t>().swap(c);
    }
  }
  head_ = {};
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
