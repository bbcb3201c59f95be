// SPDX-License-Identifier: MIT
#include "file_summary.h"

#include <cstdio>

#include "somm/micromap.h"

namespace somm::cli {

void ArraySummary::add(const ArraySummary& o) {
  geometries += o.geometries;
  triangles += o.triangles;
  uniqueMicromaps += o.uniqueMicromaps;
  for (size_t l = 0; l < 13; ++l) {
    levelMicromaps[l] += o.levelMicromaps[l];
    levelTriangles[l] += o.levelTriangles[l];
  }
  dataBytes += o.dataBytes;
  descriptorBytes += o.descriptorBytes;
}

void GeometrySummary::add(const GeometrySummary& o) {
  triangles += o.triangles;
  for (size_t i = 0; i < 4; ++i) special[i] += o.special[i];
  micromapTriangles += o.micromapTriangles;
  distinctMicromaps += o.distinctMicromaps;
  for (size_t l = 0; l < 13; ++l) levelTriangles[l] += o.levelTriangles[l];
  microTriangles += o.microTriangles;
  unknownMicroTriangles += o.unknownMicroTriangles;
  indexBytes += o.indexBytes;
  bake.microTriangles += o.bake.microTriangles;
  bake.unknownMicroTriangles += o.bake.unknownMicroTriangles;
  bake.invalidUvTriangles += o.bake.invalidUvTriangles;
}

std::vector<uint32_t> unknownStatesPerMicromap(const OmmArray& a) {
  std::vector<uint32_t> out(a.descriptors.size(), 0);
  for (size_t i = 0; i < a.descriptors.size(); ++i) {
    const TriangleDescriptor& d = a.descriptors[i];
    if (Format(d.format) != Format::FourState) continue;  // 2-state maps hold no unknown states
    const uint8_t* p = a.data.data() + d.dataOffset;
    const uint32_t n = microTriangleCount(d.subdivisionLevel);
    uint32_t count = 0;
    if (n < 4) {
      for (uint32_t k = 0; k < n; ++k) count += isKnown(readPackedState(p, Format::FourState, k)) ? 0 : 1;
    } else {
      // Two bits per state, LSB first: a state is unknown when its high bit (odd bit positions) is set.
      for (uint32_t b = 0; b < n / 4; ++b) count += uint32_t(__builtin_popcount(p[b] & 0xaau));
    }
    out[i] = count;
  }
  return out;
}

ArraySummary summarizeArray(const SceneMicromaps& m, uint32_t array) {
  const OmmArray& a = m.arrays[array];
  ArraySummary s;
  for (const GeometryMicromaps& g : m.geometries) s.geometries += g.array == array ? 1 : 0;
  s.triangles = a.indices.size();
  s.uniqueMicromaps = a.descriptors.size();
  for (const TriangleDescriptor& d : a.descriptors) ++s.levelMicromaps[d.subdivisionLevel];
  for (int32_t i : a.indices)
    if (!isSpecialIndex(i)) ++s.levelTriangles[a.descriptors[size_t(i)].subdivisionLevel];
  s.dataBytes = a.data.size();
  s.descriptorBytes = 8ull * a.descriptors.size();
  return s;
}

IndexType geometryIndexType(const SceneMicromaps& m, uint32_t g) {
  const int32_t* idx = m.indices(g);
  for (uint32_t t = 0; t < m.geometries[g].triangleCount; ++t)
    if (!isSpecialIndex(idx[t]) && uint32_t(idx[t]) > 0xfffbu) return IndexType::UInt32;
  return IndexType::UInt16;
}

GeometrySummary summarizeGeometry(const SceneMicromaps& m, uint32_t g, const GeometryBakeStats& bake,
                                  const std::vector<uint32_t>& unknownPerMicromap) {
  const OmmArray& a = m.arrayOf(g);
  const int32_t* idx = m.indices(g);
  GeometrySummary s;
  s.triangles = m.geometries[g].triangleCount;
  std::vector<bool> used(a.descriptors.size(), false);
  for (uint64_t t = 0; t < s.triangles; ++t) {
    const int32_t i = idx[t];
    if (isSpecialIndex(i)) {
      ++s.special[size_t(stateOfSpecialIndex(i))];
      continue;
    }
    const TriangleDescriptor& d = a.descriptors[size_t(i)];
    ++s.micromapTriangles;
    ++s.levelTriangles[d.subdivisionLevel];
    s.microTriangles += microTriangleCount(d.subdivisionLevel);
    s.unknownMicroTriangles += unknownPerMicromap[size_t(i)];
    if (!used[size_t(i)]) {
      used[size_t(i)] = true;
      ++s.distinctMicromaps;
    }
  }
  s.indexBytes = uint64_t(geometryIndexType(m, g)) * s.triangles;
  s.bake = bake;
  return s;
}

FileSummary summarizeFile(const SommFile& f) {
  FileSummary s;
  std::vector<std::vector<uint32_t>> unknown;
  for (uint32_t a = 0; a < f.micromaps.arrays.size(); ++a) {
    s.arrays.push_back(summarizeArray(f.micromaps, a));
    s.arrayTotal.add(s.arrays.back());
    unknown.push_back(unknownStatesPerMicromap(f.micromaps.arrays[a]));
  }
  for (uint32_t g = 0; g < f.geometries.size(); ++g) {
    s.geometries.push_back(
        summarizeGeometry(f.micromaps, g, f.geometries[g].stats, unknown[f.micromaps.geometries[g].array]));
    s.geometryTotal.add(s.geometries.back());
  }
  return s;
}

namespace {
nlohmann::json levelsJson(const std::array<uint64_t, 13>* micromaps,
                          const std::array<uint64_t, 13>& triangles) {
  nlohmann::json levels = nlohmann::json::array();
  for (uint32_t l = 0; l < 13; ++l)
    if ((micromaps && (*micromaps)[l]) || triangles[l]) {
      nlohmann::json e = {{"level", l}};
      if (micromaps) e["micromaps"] = (*micromaps)[l];
      e["triangles"] = triangles[l];
      levels.push_back(std::move(e));
    }
  return levels;
}
}  // namespace

nlohmann::json arraySummaryJson(const ArraySummary& s) {
  nlohmann::json j;
  j["geometries"] = s.geometries;
  j["triangles"] = s.triangles;
  j["unique_micromaps"] = s.uniqueMicromaps;
  j["level_histogram"] = levelsJson(&s.levelMicromaps, s.levelTriangles);
  j["bytes"] = {
      {"data", s.dataBytes}, {"descriptors", s.descriptorBytes}, {"total", s.dataBytes + s.descriptorBytes}};
  return j;
}

nlohmann::json geometrySummaryJson(const GeometrySummary& s) {
  nlohmann::json j;
  j["triangles"] = s.triangles;
  j["special"] = {{"transparent", s.special[0]},
                  {"opaque", s.special[1]},
                  {"unknown_transparent", s.special[2]},
                  {"unknown_opaque", s.special[3]}};
  j["micromap_triangles"] = s.micromapTriangles;
  j["level_histogram"] = levelsJson(nullptr, s.levelTriangles);
  j["micro_triangles"] = s.microTriangles;
  j["unknown_micro_triangles"] = s.unknownMicroTriangles;
  j["unknown_fraction"] = s.unknownFraction();
  j["index_buffer_bytes"] = s.indexBytes;
  j["bake_stats"] = {{"classified_micro_triangles", s.bake.microTriangles},
                     {"classified_unknown_micro_triangles", s.bake.unknownMicroTriangles},
                     {"invalid_uv_triangles", s.bake.invalidUvTriangles}};
  return j;
}

std::string levelList(const std::array<uint64_t, 13>& perLevel) {
  std::string out;
  for (uint32_t l = 0; l < 13; ++l)
    if (perLevel[l]) {
      if (!out.empty()) out += ' ';
      out += std::to_string(l) + ":" + std::to_string(perLevel[l]);
    }
  return out.empty() ? "-" : out;
}

std::string counted(uint64_t n, const char* singular, const char* plural) {
  return std::to_string(n) + " " + (n == 1 ? singular : plural);
}

std::string humanBytes(uint64_t bytes) {
  char buf[32];
  if (bytes < 1024) return std::to_string(bytes) + " B";
  const char* units[] = {"KiB", "MiB", "GiB", "TiB"};
  double v = double(bytes);
  int u = -1;
  while (v >= 1024 && u < 3) {
    v /= 1024;
    ++u;
  }
  std::snprintf(buf, sizeof buf, "%.1f %s", v, units[u]);
  return buf;
}

std::string bytesText(uint64_t bytes) {
  if (bytes < 1024) return std::to_string(bytes) + " B";
  return std::to_string(bytes) + " B (" + humanBytes(bytes) + ")";
}

std::string dumpJson(const nlohmann::json& j, int indent) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace somm::cli
