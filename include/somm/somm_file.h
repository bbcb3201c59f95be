// SPDX-License-Identifier: MIT
// somm — the .somm container: the baked OMM arrays of a scene, their metadata and further encodings, every
// section checksummed (XXH3-64), written atomically. Byte layout: docs/somm-format.md.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "somm/micromap.h"
#include "somm/omm_array.h"
#include "somm/result.h"
#include "somm/span.h"
#include "somm/texture.h"

namespace somm {

// The version serializeSomm writes. parseSomm also reads version 1 (one array per geometry, encodings per geometry),
// converting it with perGeometryMicromaps.
inline constexpr uint32_t kSommFileVersion = 2;

// Four ASCII characters packed little-endian: sectionId("dfs ") == 'd' | 'f' << 8 | 's' << 16 | ' ' << 24.
constexpr uint32_t sectionId(const char (&s)[5]) noexcept {
  return uint32_t(uint8_t(s[0])) | uint32_t(uint8_t(s[1])) << 8 | uint32_t(uint8_t(s[2])) << 16 |
         uint32_t(uint8_t(s[3])) << 24;
}
// The id as text with trailing spaces trimmed ("dfs "), non-printable bytes as \xNN.
std::string sectionIdName(uint32_t id);

// An encoding of one OMM array's micromaps besides the flat spec buffers (dfs, rank, ...): it encodes the whole
// array (all triangles of all geometries that share it). Stored and checksummed opaquely; ids must be unique
// within an array.
struct EncodedSection {
  uint32_t id = 0;
  std::vector<uint8_t> bytes;
  friend bool operator==(const EncodedSection& a, const EncodedSection& b) {
    return a.id == b.id && a.bytes == b.bytes;
  }
  friend bool operator!=(const EncodedSection& a, const EncodedSection& b) noexcept { return !(a == b); }
};

// What the baker measured. Stored as is (never timings: a file is identical for any thread count).
struct GeometryBakeStats {
  uint64_t microTriangles = 0;  // micro-triangles classified (Σ 4^level over the geometry's triangles)
  uint64_t unknownMicroTriangles =
      0;                            // of which the classification left unknown (before any 2-state demotion)
  uint64_t invalidUvTriangles = 0;  // triangles with NaN/inf UVs (classified unknown)
  friend bool operator==(const GeometryBakeStats& a, const GeometryBakeStats& b) noexcept {
    return a.microTriangles == b.microTriangles && a.unknownMicroTriangles == b.unknownMicroTriangles &&
           a.invalidUvTriangles == b.invalidUvTriangles;
  }
  friend bool operator!=(const GeometryBakeStats& a, const GeometryBakeStats& b) noexcept {
    return !(a == b);
  }
};

// Per-geometry metadata.
struct GeometryInfo {
  std::string name;
  std::string material;
  uint32_t triangleCount = 0;  // must equal SommFile::micromaps.geometries[g].triangleCount
  Format format = Format::FourState;
  uint32_t minLevel = 0, maxLevel = 0;  // every descriptor the geometry uses has this format and a level in
                                        // [minLevel, maxLevel] ⊆ [0, 12]
  float cutoff = 0.5f;
  Sampler sampler;  // filter and wrap modes used by the bake
  GeometryBakeStats stats;
  friend bool operator==(const GeometryInfo& a, const GeometryInfo& b) {
    return a.name == b.name && a.material == b.material && a.triangleCount == b.triangleCount &&
           a.format == b.format && a.minLevel == b.minLevel && a.maxLevel == b.maxLevel &&
           a.cutoff == b.cutoff && a.sampler == b.sampler && a.stats == b.stats;
  }
  friend bool operator!=(const GeometryInfo& a, const GeometryInfo& b) noexcept { return !(a == b); }
};

struct SommFile {
  std::string sourcePath;   // the scene the bake read
  std::string toolVersion;  // e.g. "somm 0.1.0"
  std::vector<std::pair<std::string, std::string>>
      bakeOptions;                       // the options used, in order ("level" → "8", ...)
  std::vector<GeometryInfo> geometries;  // per scene geometry, in scene order
  // The micromaps: OMM arrays shared by geometries (micromaps.geometries[g] places geometry g in its array; one
  // entry per geometries[g]). The default bake stores one scene-wide array, `--arrays geometry` one per geometry.
  SceneMicromaps micromaps;
  // encodings[a]: further encodings of micromaps.arrays[a], in file order (one entry per array, possibly empty).
  std::vector<std::vector<EncodedSection>> encodings;
};

// Checks an OmmArray's internal consistency: descriptor levels ≤ 12 and formats 1/2, every micromap inside
// the data, indices < descriptor count or special, histograms equal to the ones recomputed from descriptors
// and indices. `what` prefixes messages.
Status validateOmmArray(const OmmArray& a, std::string_view what);

// Serialises after validating (a written file always reads back). Deterministic: equal inputs give equal
// bytes.
Result<std::vector<uint8_t>> serializeSomm(const SommFile& file);
// Parses and validates everything before allocating more than a small multiple of bytes.size(). `name` (the
// path) starts every error message.
Result<SommFile> parseSomm(Span<const uint8_t> bytes, std::string_view name);

Status writeSommFile(const std::string& path, const SommFile& file);
Result<SommFile> readSommFile(const std::string& path);
// The scene's micromaps stored in a .somm file (readSommFile(path)->micromaps): what a ray tracer needs, with
// SommFile::geometries[g] giving geometry g's format, cutoff and sampler when those matter.
Result<SceneMicromaps> readSceneMicromaps(const std::string& path);

// Writes `bytes` to `path` atomically: a temporary file in the same directory, fsync, rename, fsync of the
// directory. On failure the temporary file is removed and an existing `path` is left untouched.
Status writeFileAtomically(const std::string& path, Span<const uint8_t> bytes);
// Reads a whole file (errors name the path).
Result<std::vector<uint8_t>> readWholeFile(const std::string& path);

}  // namespace somm
