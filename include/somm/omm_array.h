// SPDX-License-Identifier: MIT
// somm — OMM arrays: byte-exact VkMicromapEXT / DXR OMM array build inputs.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "somm/micromap.h"
#include "somm/span.h"

namespace somm {

// VkMicromapTriangleEXT: 8 bytes, little endian.
struct TriangleDescriptor {
  uint32_t dataOffset = 0;  // byte offset of the micromap in the data buffer
  uint16_t subdivisionLevel = 0;
  uint16_t format = 0;  // 1 = 2-state, 2 = 4-state
  friend bool operator==(const TriangleDescriptor& a, const TriangleDescriptor& b) noexcept {
    return a.dataOffset == b.dataOffset && a.subdivisionLevel == b.subdivisionLevel && a.format == b.format;
  }
  friend bool operator!=(const TriangleDescriptor& a, const TriangleDescriptor& b) noexcept {
    return !(a == b);
  }
};
static_assert(sizeof(TriangleDescriptor) == 8);

// VkMicromapUsageEXT.
struct UsageCount {
  uint32_t count = 0;
  uint32_t subdivisionLevel = 0;
  uint32_t format = 0;
  friend bool operator==(const UsageCount& a, const UsageCount& b) noexcept {
    return a.count == b.count && a.subdivisionLevel == b.subdivisionLevel && a.format == b.format;
  }
  friend bool operator!=(const UsageCount& a, const UsageCount& b) noexcept { return !(a == b); }
};

enum class IndexType : uint8_t { UInt16 = 2, UInt32 = 4 };

// The spec buffers of one geometry.
struct OmmArray {
  std::vector<uint8_t> data;                    // micromaps at their byte offsets
  std::vector<TriangleDescriptor> descriptors;  // one per unique micromap
  std::vector<int32_t> indices;                 // per triangle: descriptor index or special index (-1..-4)
  // Usage counts per (level, format) with count > 0, sorted by format then level:
  std::vector<UsageCount> histogram;  // micromaps in the array (for vkCmdBuildMicromapsEXT)
  std::vector<UsageCount>
      triangleHistogram;  // triangles referencing them (for the acceleration structure build)

  IndexType indexType() const noexcept;  // 16-bit when every value fits (as its unsigned cast), else 32-bit
  std::vector<uint8_t> indexBufferBytes() const;  // little-endian index buffer in indexType()
  std::vector<uint8_t> descriptorBytes() const;   // little-endian descriptors, 8 bytes each

  // State of micro-triangle `index` of `triangle`, exactly as a ray tracer reads it (special indices resolved).
  State state(uint32_t triangle, uint32_t index) const noexcept;
  State stateUV(uint32_t triangle, float u, float v) const noexcept;
};

// Usage counts per (level, format), sorted by format then level: micromaps among `descriptors`, and triangles whose
// index refers to one of them.
struct UsageHistograms {
  std::vector<UsageCount> micromaps, triangles;
};
UsageHistograms countUsage(Span<const TriangleDescriptor> descriptors, Span<const int32_t> indices);

// Recomputes a.histogram and a.triangleHistogram from its descriptors and indices.
void computeUsageHistograms(OmmArray& a);

// Builds an OmmArray one triangle at a time. Uniform micromaps become special indices; identical micromaps are stored
// once (hash + exact compare), in order of first appearance.
class OmmArrayBuilder {
 public:
  // Appends the next triangle's micromap; returns the index value stored for it.
  int32_t add(const Micromap& map);
  // Appends a triangle with a special index directly.
  void addSpecial(State s);
  // Stores a map (deduplicated; uniform maps are not stored) without appending a triangle; returns the index value
  // add() would have stored for it.
  int32_t intern(const Micromap& map);
  // What intern() computes from a map before it looks at the array: its uniform state (if any) and its hash. A pure
  // function of the map, so a caller may compute it on another thread and pass it to intern(map, key).
  struct MapKey {
    std::optional<State> uniform;
    uint64_t hash = 0;
  };
  static MapKey keyOf(const Micromap& map);
  // intern(map) with key == keyOf(map) (checked in debug builds).
  int32_t intern(const Micromap& map, const MapKey& key);
  // A hint: the data will probably hold at most `bytes`. Up to that size the maps go to one buffer reserved now
  // (address space: pages are touched only as maps are stored), which finish() hands over without a copy; beyond
  // it they go to chunks as without the hint. Only before the first map is stored.
  void reserveData(size_t bytes);
  // Appends a triangle with an index value an earlier add() / intern() returned (a descriptor of this array or a special
  // index).
  void addIndex(int32_t index) { array_.indices.push_back(index); }

  uint32_t triangleCount() const noexcept { return uint32_t(array_.indices.size()); }
  // The descriptors and indices so far; its `data` is filled by finish() (the maps are kept elsewhere until then).
  const OmmArray& array() const noexcept { return array_; }
  // Bytes of micromap data stored so far.
  size_t dataBytes() const noexcept { return dataSize_; }
  OmmArray finish();

 private:
  struct Slot {
    uint64_t hash;
    int32_t descriptor;
  };
  static constexpr size_t kChunkBytes = size_t(16) << 20;
  OmmArray array_;
  std::vector<uint8_t> head_;  // the data's first head_.size() bytes (up to the reserveData() hint) ...
  std::vector<std::vector<uint8_t>> chunks_;  // ... then fixed-size chunks, concatenated by finish()
  size_t dataSize_ = 0;
  void store(const uint8_t* p, size_t n);
  bool storedEquals(size_t offset, const uint8_t* p, size_t n) const;
  std::vector<std::vector<Slot>> buckets_ = std::vector<std::vector<Slot>>(1024);
  size_t uniqueCount_ = 0;
  void grow();
};

// ---- a scene's micromaps: OMM arrays shared by geometries ----
//
// Vulkan (VkAccelerationStructureTrianglesOpacityMicromapEXT::micromap) and DXR let many geometries point into one
// OMM array, each with its own index buffer. The default bake stores ONE scene-wide array: identical maps of all
// geometries are stored once. Per-geometry arrays (one OmmArray per geometry) remain an option.
//
// Representation: the index buffers of the geometries that share an array are concatenated, in geometry order, in
// that array's `indices` (so an OmmArray/EncodedArray built from it answers for "global" triangle numbers
// firstTriangle + t); its `histogram` counts the array's micromaps and its `triangleHistogram` all triangles of all
// its geometries. A geometry's own triangle usage histogram (for its BLAS build) is triangleHistogram(g).
struct GeometryMicromaps {
  uint32_t array = 0;          // index into SceneMicromaps::arrays
  uint32_t firstTriangle = 0;  // offset of this geometry's index buffer in arrays[array].indices
  uint32_t triangleCount = 0;  // = the geometry's triangle count
  friend bool operator==(const GeometryMicromaps& a, const GeometryMicromaps& b) noexcept {
    return a.array == b.array && a.firstTriangle == b.firstTriangle && a.triangleCount == b.triangleCount;
  }
  friend bool operator!=(const GeometryMicromaps& a, const GeometryMicromaps& b) noexcept {
    return !(a == b);
  }
};

struct SceneMicromaps {
  std::vector<OmmArray> arrays;
  std::vector<GeometryMicromaps> geometries;  // one per scene geometry, in scene order

  // Geometry g's index buffer (triangleCount entries) and its global triangle number in its array.
  const int32_t* indices(uint32_t g) const noexcept {
    const GeometryMicromaps& r = geometries[g];
    return arrays[r.array].indices.data() + r.firstTriangle;
  }
  uint32_t globalTriangle(uint32_t g, uint32_t triangle) const noexcept {
    return geometries[g].firstTriangle + triangle;
  }
  const OmmArray& arrayOf(uint32_t g) const noexcept { return arrays[geometries[g].array]; }
  // State of micro-triangle `index` of triangle `triangle` of geometry g (special indices resolved).
  State state(uint32_t g, uint32_t triangle, uint32_t index) const noexcept {
    return arrayOf(g).state(globalTriangle(g, triangle), index);
  }
  State stateUV(uint32_t g, uint32_t triangle, float u, float v) const noexcept {
    return arrayOf(g).stateUV(globalTriangle(g, triangle), u, v);
  }
  // Triangle usage counts of geometry g alone (VkAccelerationStructureTrianglesOpacityMicromapEXT::pUsageCounts).
  std::vector<UsageCount> triangleHistogram(uint32_t g) const;
  // Geometry g as a stand-alone array holding only the maps it uses (in order of first use), e.g. for a per-geometry
  // export. States are identical: standalone(g).state(t, i) == state(g, t, i).
  OmmArray standalone(uint32_t g) const;
};

// One array per geometry (each `perGeometry[g]` holds geometry g's triangles) → SceneMicromaps with per-geometry arrays.
SceneMicromaps perGeometryMicromaps(std::vector<OmmArray> perGeometry);
// Merge into one scene-wide array: identical maps across geometries stored once (order of first appearance over the
// geometries in order), index buffers concatenated. States unchanged for every (g, triangle, index).
SceneMicromaps mergeToSceneArray(const SceneMicromaps& in);

}  // namespace somm
