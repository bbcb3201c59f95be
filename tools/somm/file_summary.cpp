// SPDX-License-Identifier: MIT
#include "file_summary.h"

#include <cstdio>

namespace somm::cli {

void ArraySummary::add(const ArraySummary& o) {
  triangles += o.triangles;
  for (size_t i = 0; i < 4; ++i) special[i] += o.special[i];
  micromapTriangles += o.micromapTriangles;
  uniqueMicromaps += o.uniqueMicromaps;
  for (size_t l = 0; l < 13; ++l) {
    levelMicromaps[l] += o.levelMicromaps[l];
    levelTriangles[l] += o.levelTriangles[l];
  }
  microTriangles += o.microTriangles;
  unknownMicroTriangles += o.unknownMicroTriangles;
  invalidUvTriangles += o.invalidUvTriangles;
  dataBytes += o.dataBytes;
  descriptorBytes += o.descriptorBytes;
  indexBytes += o.indexBytes;
}

ArraySummary summarize(const OmmArray& a, const GeometryBakeStats& stats) {
  ArraySummary s;
  s.triangles = a.indices.size();
  for (int32_t i : a.indices) {
    if (isSpecialIndex(i)) {
      ++s.special[size_t(stateOfSpecialIndex(i))];
    } else {
      ++s.micromapTriangles;
      ++s.levelTriangles[a.descriptors[size_t(i)].subdivisionLevel];
    }
  }
  s.uniqueMicromaps = a.descriptors.size();
  for (const TriangleDescriptor& d : a.descriptors) ++s.levelMicromaps[d.subdivisionLevel];
  s.microTriangles = stats.microTriangles;
  s.unknownMicroTriangles = stats.unknownMicroTriangles;
  s.invalidUvTriangles = stats.invalidUvTriangles;
  s.dataBytes = a.data.size();
  s.descriptorBytes = 8ull * a.descriptors.size();
  s.indexBytes = uint64_t(a.indexType()) * a.indices.size();
  return s;
}

nlohmann::json summaryJson(const ArraySummary& s) {
  nlohmann::json j;
  j["triangles"] = s.triangles;
  j["special"] = {{"transparent", s.special[0]},
                  {"opaque", s.special[1]},
                  {"unknown_transparent", s.special[2]},
                  {"unknown_opaque", s.special[3]}};
  j["micromap_triangles"] = s.micromapTriangles;
  j["unique_micromaps"] = s.uniqueMicromaps;
  nlohmann::json levels = nlohmann::json::array();
  for (uint32_t l = 0; l < 13; ++l)
    if (s.levelMicromaps[l] || s.levelTriangles[l])
      levels.push_back(
          {{"level", l}, {"micromaps", s.levelMicromaps[l]}, {"triangles", s.levelTriangles[l]}});
  j["level_histogram"] = levels;
  j["micro_triangles"] = s.microTriangles;
  j["unknown_micro_triangles"] = s.unknownMicroTriangles;
  j["unknown_fraction"] = s.unknownFraction();
  j["invalid_uv_triangles"] = s.invalidUvTriangles;
  j["bytes"] = {{"data", s.dataBytes},
                {"descriptors", s.descriptorBytes},
                {"index_buffer", s.indexBytes},
                {"total", s.dataBytes + s.descriptorBytes + s.indexBytes}};
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

std::string dumpJson(const nlohmann::json& j, int indent) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace somm::cli
