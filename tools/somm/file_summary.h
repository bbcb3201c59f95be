// SPDX-License-Identifier: MIT
// somm CLI — per-geometry counters of an OMM array (shared by `somm info` and `somm bake`).
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "somm/omm_array.h"
#include "somm/somm_file.h"

namespace somm::cli {

struct ArraySummary {
  uint64_t triangles = 0;
  std::array<uint64_t, 4>
      special{};  // triangles per special index, by State (transparent, opaque, unknown-t, unknown-o)
  uint64_t micromapTriangles = 0;  // triangles referencing a micromap
  uint64_t uniqueMicromaps = 0;    // descriptors
  std::array<uint64_t, 13> levelMicromaps{}, levelTriangles{};
  uint64_t microTriangles = 0, unknownMicroTriangles = 0, invalidUvTriangles = 0;
  uint64_t dataBytes = 0, descriptorBytes = 0, indexBytes = 0;

  double unknownFraction() const {
    return microTriangles ? double(unknownMicroTriangles) / double(microTriangles) : 0.0;
  }
  void add(const ArraySummary& o);
};

ArraySummary summarize(const OmmArray& a, const GeometryBakeStats& stats);

// The counters as JSON (keys documented in docs/cli.md).
nlohmann::json summaryJson(const ArraySummary& s);

// "0:12 3:40" — level:count pairs with non-zero counts.
std::string levelList(const std::array<uint64_t, 13>& perLevel);

// Human-readable byte count ("1.5 MiB").
std::string humanBytes(uint64_t bytes);

// Dumps JSON with invalid UTF-8 replaced (names come from files).
std::string dumpJson(const nlohmann::json& j, int indent = 2);

}  // namespace somm::cli
