// SPDX-License-Identifier: MIT
// somm CLI — counters of a scene's micromaps per OMM array and per geometry (shared by `somm info` and
// `somm bake`).
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "somm/omm_array.h"
#include "somm/somm_file.h"

namespace somm::cli {

// One OMM array: what the micromap build (vkCmdBuildMicromapsEXT) consumes.
struct ArraySummary {
  uint64_t geometries = 0;       // geometries whose index buffers point into it
  uint64_t triangles = 0;        // entries of its index buffer (all its geometries)
  uint64_t uniqueMicromaps = 0;  // descriptors: identical maps are stored once
  std::array<uint64_t, 13> levelMicromaps{}, levelTriangles{};
  uint64_t dataBytes = 0, descriptorBytes = 0;
  void add(const ArraySummary& o);
};

// One geometry's triangles (its range of its array's index buffer): what its acceleration structure build reads.
struct GeometrySummary {
  uint64_t triangles = 0;
  std::array<uint64_t, 4>
      special{};  // triangles per special index, by State (transparent, opaque, unknown-t, unknown-o)
  uint64_t micromapTriangles = 0;  // triangles referencing a micromap
  uint64_t distinctMicromaps = 0;  // distinct micromaps they reference (not additive over geometries)
  std::array<uint64_t, 13> levelTriangles{};
  // Over the micro-triangles of the triangles that reference a micromap (special-index triangles are counted in
  // `special` only): Σ 4^level, and those whose stored state is unknown.
  uint64_t microTriangles = 0, unknownMicroTriangles = 0;
  uint64_t indexBytes = 0;  // its own index buffer: 2 or 4 bytes per triangle
  GeometryBakeStats bake;   // what the baker measured (before special indices and 2-state demotion)

  double unknownFraction() const {
    return microTriangles ? double(unknownMicroTriangles) / double(microTriangles) : 0.0;
  }
  void add(const GeometrySummary& o);
};

// Per descriptor of `a`: its micro-triangles whose state is unknown (2 or 3).
std::vector<uint32_t> unknownStatesPerMicromap(const OmmArray& a);

ArraySummary summarizeArray(const SceneMicromaps& m, uint32_t array);
// `unknownPerMicromap` = unknownStatesPerMicromap(m.arrayOf(g)).
GeometrySummary summarizeGeometry(const SceneMicromaps& m, uint32_t g, const GeometryBakeStats& bake,
                                  const std::vector<uint32_t>& unknownPerMicromap);

// Index type of one geometry's own index buffer (16-bit when every entry fits).
IndexType geometryIndexType(const SceneMicromaps& m, uint32_t g);

// Every array and geometry of a file, plus totals.
struct FileSummary {
  std::vector<ArraySummary> arrays;
  std::vector<GeometrySummary> geometries;
  ArraySummary arrayTotal;        // summed over arrays: unique micromaps and data of the whole scene
  GeometrySummary geometryTotal;  // summed over geometries
};
FileSummary summarizeFile(const SommFile& f);

// The counters as JSON (keys documented in docs/cli.md).
nlohmann::json arraySummaryJson(const ArraySummary& s);
nlohmann::json geometrySummaryJson(const GeometrySummary& s);

// "0:12 3:40" — level:count pairs with non-zero counts.
std::string levelList(const std::array<uint64_t, 13>& perLevel);

// "1 array", "3 arrays": a count with its noun.
std::string counted(uint64_t n, const char* singular, const char* plural);

// Human-readable byte count ("1.5 MiB").
std::string humanBytes(uint64_t bytes);
// "98626 B (96.3 KiB)": exact bytes, and the human-readable size when it differs.
std::string bytesText(uint64_t bytes);

// Dumps JSON with invalid UTF-8 replaced (names come from files).
std::string dumpJson(const nlohmann::json& j, int indent = 2);

}  // namespace somm::cli
