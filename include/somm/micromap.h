// SPDX-License-Identifier: MIT
// somm — opacity micromaps in the Vulkan / DXR spec layout.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "somm/bird.h"
#include "somm/span.h"

namespace somm {

enum class Format : uint16_t { TwoState = 1, FourState = 2 };

enum class State : uint8_t { Transparent = 0, Opaque = 1, UnknownTransparent = 2, UnknownOpaque = 3 };

// Per-triangle special indices: the whole triangle has one state and no micromap data.
enum class SpecialIndex : int32_t {
  FullyTransparent = -1,
  FullyOpaque = -2,
  FullyUnknownTransparent = -3,
  FullyUnknownOpaque = -4,
};

constexpr int32_t specialIndexFor(State s) noexcept {
  return -1 - int32_t(s);
}
constexpr bool isSpecialIndex(int32_t index) noexcept {
  return index >= -4 && index <= -1;
}
constexpr State stateOfSpecialIndex(int32_t index) noexcept {
  return State(-1 - index);
}

constexpr uint32_t bitsPerState(Format f) noexcept {
  return f == Format::TwoState ? 1u : 2u;
}
constexpr bool isKnown(State s) noexcept {
  return s == State::Transparent || s == State::Opaque;
}
constexpr bool isValidFormat(uint32_t f) noexcept {
  return f == 1 || f == 2;
}

// Bytes of one micromap in the spec layout: max(1, ceil(4^L · bits / 8)).
constexpr uint32_t micromapDataBytes(uint32_t level, Format f) noexcept {
  const uint64_t bits = uint64_t(microTriangleCount(level)) * bitsPerState(f);
  const uint64_t bytes = (bits + 7) / 8;
  return bytes < 1 ? 1u : uint32_t(bytes);
}

// The spec's force-2-state demotion: unknown-transparent → transparent, unknown-opaque → opaque.
constexpr State toTwoState(State s) noexcept {
  return State(uint8_t(s) & 1u);
}

// Read state `index` from spec-layout bytes (LSB-first within each byte).
inline State readPackedState(const uint8_t* data, Format f, uint32_t index) noexcept {
  if (f == Format::TwoState) return State((data[index >> 3] >> (index & 7u)) & 1u);
  return State((data[index >> 2] >> (2u * (index & 3u))) & 3u);
}

inline void writePackedState(uint8_t* data, Format f, uint32_t index, State s) noexcept {
  if (f == Format::TwoState) {
    const uint8_t bit = uint8_t(1u << (index & 7u));
    data[index >> 3] = uint8_t((data[index >> 3] & ~bit) | ((uint8_t(s) & 1u) ? bit : 0u));
  } else {
    const uint32_t shift = 2u * (index & 3u);
    data[index >> 2] = uint8_t((data[index >> 2] & ~(3u << shift)) | ((uint32_t(s) & 3u) << shift));
  }
}

// One micromap: a level, a format and 4^level states packed in the spec layout.
class Micromap {
 public:
  Micromap() = default;
  // All micro-triangles start in `fill`. A 2-state map stores only bit 0 of each state (see toTwoState).
  Micromap(uint32_t level, Format format, State fill = State::Transparent);

  uint32_t level() const noexcept { return level_; }
  Format format() const noexcept { return format_; }
  uint32_t size() const noexcept { return microTriangleCount(level_); }

  State get(uint32_t index) const noexcept { return readPackedState(bytes_.data(), format_, index); }
  void set(uint32_t index, State s) noexcept { writePackedState(bytes_.data(), format_, index, s); }
  State getUV(float u, float v) const noexcept { return get(baryToIndex(u, v, level_)); }
  void setUV(float u, float v, State s) noexcept { set(baryToIndex(u, v, level_), s); }

  // The state shared by every micro-triangle, if they all agree.
  std::optional<State> uniformState() const noexcept;

  // This map in 2-state format (the spec's demotion of unknown states).
  Micromap toTwoStateMap() const;

  Span<const uint8_t> bytes() const noexcept { return bytes_; }
  Span<uint8_t> bytes() noexcept { return bytes_; }

  friend bool operator==(const Micromap& a, const Micromap& b) {
    return a.level_ == b.level_ && a.format_ == b.format_ && a.bytes_ == b.bytes_;
  }
  friend bool operator!=(const Micromap& a, const Micromap& b) noexcept { return !(a == b); }

 private:
  uint32_t level_ = 0;
  Format format_ = Format::TwoState;
  std::vector<uint8_t> bytes_ = std::vector<uint8_t>(1, 0);
};

// ---- one triangle, its vertices listed in another order ----
// A triangle T' with the points of a triangle T listed in another order: order[k] is the vertex of T that is vertex k
// of T' (a permutation of 0, 1, 2). T' is subdivided into the same micro-triangles as T (midpoints are midpoints in
// any order), listed at other bird-curve indices. docs/baking.md "Vertex orders".
using VertexOrder = std::array<uint8_t, 3>;

// True when `order` is a permutation of (0, 1, 2).
bool isVertexOrder(const VertexOrder& order) noexcept;

// T''s micromap from T's (`map`, any level and format): state i of `out` is the state of the micro-triangle of `map`
// covering the same region as micro-triangle i of T'. `out` takes `map`'s level and format (its storage is reused).
void reorderVertices(const Micromap& map, const VertexOrder& order, Micromap& out);

// Node `prefix` at `depth` (0..level) of T — the aligned block of micro-triangles [prefix · 4^(L - depth),
// (prefix + 1) · 4^(L - depth)) at any level L ≥ depth — is node reorderedNode(...) at the same depth of T', where its
// vertex k is its vertex nodeOrder[k] in T (the order reorderVertices applies inside it). nodeOrder may be null.
uint32_t reorderedNode(uint32_t prefix, uint32_t depth, const VertexOrder& order,
                       VertexOrder* nodeOrder = nullptr) noexcept;

}  // namespace somm
