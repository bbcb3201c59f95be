// somm — OMM arrays: byte-exact VkMicromapEXT / DXR OMM array build inputs.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "somm/micromap.h"

namespace somm {

// VkMicromapTriangleEXT: 8 bytes, little endian.
struct TriangleDescriptor {
  uint32_t dataOffset = 0;  // byte offset of the micromap in the data buffer
  uint16_t subdivisionLevel = 0;
  uint16_t format = 0;  // 1 = 2-state, 2 = 4-state
  friend bool operator==(const TriangleDescriptor&, const TriangleDescriptor&) = default;
};
static_assert(sizeof(TriangleDescriptor) == 8);

// VkMicromapUsageEXT.
struct UsageCount {
  uint32_t count = 0;
  uint32_t subdivisionLevel = 0;
  uint32_t format = 0;
  friend bool operator==(const UsageCount&, const UsageCount&) = default;
};

enum class IndexType : uint8_t { UInt16 = 2, UInt32 = 4 };

// The spec buffers of one geometry.
struct OmmArray {
  std::vector<uint8_t> data;                     // micromaps at their byte offsets
  std::vector<TriangleDescriptor> descriptors;   // one per unique micromap
  std::vector<int32_t> indices;                  // per triangle: descriptor index or special index (-1..-4)
  // Usage counts per (level, format) with count > 0, sorted by format then level:
  std::vector<UsageCount> histogram;          // micromaps in the array (for vkCmdBuildMicromapsEXT)
  std::vector<UsageCount> triangleHistogram;  // triangles referencing them (for the acceleration structure build)

  IndexType indexType() const noexcept;          // 16-bit when every value fits (as its unsigned cast), else 32-bit
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
UsageHistograms countUsage(std::span<const TriangleDescriptor> descriptors, std::span<const int32_t> indices);

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

  uint32_t triangleCount() const noexcept { return uint32_t(array_.indices.size()); }
  const OmmArray& array() const noexcept { return array_; }
  OmmArray finish();

 private:
  struct Slot {
    uint64_t hash;
    int32_t descriptor;
  };
  OmmArray array_;
  std::vector<std::vector<Slot>> buckets_ = std::vector<std::vector<Slot>>(1024);
  size_t uniqueCount_ = 0;
  void grow();
};

}  // namespace somm
