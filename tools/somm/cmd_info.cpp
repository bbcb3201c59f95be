// SPDX-License-Identifier: MIT
// somm info FILE.somm [--json] [--reference-compressors]: what a .somm file holds, per array, per geometry and in
// total.
#include <algorithm>
#include <cstdio>
#include <string>

#include "command.h"
#include "encodings.h"
#include "file_summary.h"
#include "somm/gltf.h"
#include "somm/io.h"
#include "somm/somm_file.h"

namespace {

struct Options {
  std::string path;
  bool json = false;
  bool referenceCompressors = false;
};

int statesOf(somm::Format f) {
  return f == somm::Format::TwoState ? 2 : 4;
}

std::string percent(double f) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f%%", 100.0 * f);
  return buf;
}

std::string floatText(float f) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", double(f));
  return buf;
}

void printGeometry(somm::cli::Output& out, const somm::cli::GeometrySummary& s, const std::string& indent) {
  using std::to_string;
  out.put(indent + "special indices (triangles): transparent " + to_string(s.special[0]) + ", opaque " +
          to_string(s.special[1]) + ", unknown-transparent " + to_string(s.special[2]) + ", unknown-opaque " +
          to_string(s.special[3]) + "\n");
  out.put(indent + "micromaps: " + to_string(s.micromapTriangles) + " triangles reference " +
          to_string(s.distinctMicromaps) + " distinct micromaps; level histogram (level:triangles): " +
          somm::cli::levelList(s.levelTriangles) + "\n");
  out.put(indent + "unknown: " + to_string(s.unknownMicroTriangles) + " of the " +
          to_string(s.microTriangles) + " micro-triangles of the triangles with micromaps (" +
          percent(s.unknownFraction()) + ")");
  if (s.bake.invalidUvTriangles)
    out.put(", " + to_string(s.bake.invalidUvTriangles) + " triangles with NaN/inf UVs");
  out.put("\n");
}

void printArray(somm::cli::Output& out, const somm::cli::ArraySummary& s, const std::string& indent) {
  using std::to_string;
  out.put(indent + "level histogram (level:micromaps): " + somm::cli::levelList(s.levelMicromaps) + "\n");
  out.put(indent + "level histogram (level:triangles): " + somm::cli::levelList(s.levelTriangles) + "\n");
  out.put(indent + "micromap build buffers: data " + somm::cli::bytesText(s.dataBytes) + ", descriptors " +
          somm::cli::bytesText(s.descriptorBytes) + "\n");
}

// "encodings (whole array: index buffer, descriptors, data, header): flat 1234 B, rank 120 B (0.0972x flat)"
std::string encodingsLine(const somm::cli::EncodingSizes& s) {
  std::string line = "encodings (whole array serialized: header, index buffer, descriptors, data): flat " +
                     std::to_string(s.flat) + " B";
  for (const auto& [e, b] : s.stored) {
    char buf[64];
    std::snprintf(buf, sizeof buf, " (%.4fx flat)", s.flat ? double(b) / double(s.flat) : 0.0);
    line += std::string(", ") + somm::encodingName(e) + " " + std::to_string(b) + " B" + buf;
  }
  for (const auto& [e, msg] : s.invalid) line += std::string(", ") + somm::encodingName(e) + " unreadable";
  return line;
}

std::string referenceLine(const somm::cli::EncodingSizes& s) {
  return "reference compressors of the flat encoding (not random access): zstd -19 " +
         std::to_string(s.zstd) + " B, xz -9 " + std::to_string(s.xz) + " B";
}

std::string indexBits(somm::IndexType t) {
  return t == somm::IndexType::UInt16 ? "16" : "32";
}

int run(const Options& o) {
  using namespace somm::cli;
  auto bytes = somm::readWholeFile(o.path);
  if (!bytes) {
    printError("info", bytes.error().message);
    return kExitFailure;
  }
  auto src = somm::parseMicromapSource(*bytes, o.path);  // .somm or glTF (EXT_mesh_opacity_micromap)
  if (!src) {
    printError("info", src.error().message);
    return kExitFailure;
  }
  auto file = &src->file;
  // The container version as stored (version 1 files are read as one array per geometry; 0: a glTF).
  const uint32_t version = src->sommVersion;
  bytes->clear();
  bytes->shrink_to_fit();
  const somm::SommFile& f = *file;
  const somm::SceneMicromaps& m = f.micromaps;
  const FileSummary sum = summarizeFile(f);

  // Exact bytes of every stored encoding of each array and their ratio to flat (docs/encodings.md); the zstd/xz
  // references only with --reference-compressors (slow on large files).
  EncodingSizes sizeTotal;
  std::vector<EncodingSizes> sizes;
  for (uint32_t a = 0; a < m.arrays.size(); ++a) {
    auto s = encodingSizes(f, a, o.path, o.referenceCompressors);
    if (!s) {
      printError("info", s.error().message);
      return kExitFailure;
    }
    sizes.push_back(*s);
    sizeTotal.add(*s);
  }
  auto storedSections = [&](uint32_t a) {
    nlohmann::json enc = nlohmann::json::array();
    for (const somm::EncodedSection& e : f.encodings[a])
      enc.push_back({{"name", sectionName(e.id)}, {"section_bytes", e.bytes.size()}});
    return enc;
  };
  auto arrayGeometries = [&](uint32_t a) {
    nlohmann::json g = nlohmann::json::array();
    for (uint32_t i = 0; i < m.geometries.size(); ++i)
      if (m.geometries[i].array == a) g.push_back(i);
    return g;
  };

  Output out;
  if (o.json) {
    nlohmann::json j;
    j["file"] = o.path;
    j["version"] = version;
    j["container"] = src->container;
    j["source"] = f.sourcePath;
    j["tool_version"] = f.toolVersion;
    nlohmann::json opts = nlohmann::json::object();
    for (const auto& [k, v] : f.bakeOptions) opts[k] = v;
    j["bake_options"] = opts;
    nlohmann::json arrays = nlohmann::json::array();
    for (uint32_t a = 0; a < m.arrays.size(); ++a) {
      nlohmann::json x = arraySummaryJson(sum.arrays[a]);
      x["index"] = a;
      x["geometry_indices"] = arrayGeometries(a);
      x["index_type"] = m.arrays[a].indexType() == somm::IndexType::UInt16 ? 16 : 32;
      x["encodings"] = storedSections(a);
      x["encoding_sizes"] = encodingSizesJson(sizes[a]);
      arrays.push_back(std::move(x));
    }
    j["arrays"] = arrays;
    nlohmann::json geos = nlohmann::json::array();
    for (uint32_t i = 0; i < f.geometries.size(); ++i) {
      const somm::GeometryInfo& g = f.geometries[i];
      nlohmann::json x = geometrySummaryJson(sum.geometries[i]);
      x["index"] = i;
      x["name"] = g.name;
      x["material"] = g.material;
      x["array"] = m.geometries[i].array;
      x["first_triangle"] = m.geometries[i].firstTriangle;
      x["distinct_micromaps"] = sum.geometries[i].distinctMicromaps;
      x["states"] = statesOf(g.format);
      x["min_level"] = g.minLevel;
      x["max_level"] = g.maxLevel;
      x["cutoff"] = g.cutoff;
      x["filter"] = filterName(g.sampler.filter);
      x["wrap"] = {wrapName(g.sampler.wrapS), wrapName(g.sampler.wrapT)};
      x["index_type"] = geometryIndexType(m, i) == somm::IndexType::UInt16 ? 16 : 32;
      geos.push_back(std::move(x));
    }
    j["geometries"] = geos;
    nlohmann::json t = geometrySummaryJson(sum.geometryTotal);
    t["geometries"] = f.geometries.size();
    t["arrays"] = m.arrays.size();
    t["unique_micromaps"] = sum.arrayTotal.uniqueMicromaps;
    t["bytes"] = {
        {"data", sum.arrayTotal.dataBytes},
        {"descriptors", sum.arrayTotal.descriptorBytes},
        {"index_buffers", sum.geometryTotal.indexBytes},
        {"total", sum.arrayTotal.dataBytes + sum.arrayTotal.descriptorBytes + sum.geometryTotal.indexBytes}};
    t["encoding_sizes"] = encodingSizesJson(sizeTotal);
    j["total"] = t;
    out.put(dumpJson(j));
    out.put("\n");
    return kExitOk;
  }

  out.put(o.path + ": " + (version ? ".somm version " + std::to_string(version) : src->container) +
          ", written by '" + somm::escapeName(f.toolVersion) + "' from '" + somm::escapeName(f.sourcePath) +
          "'\n");
  if (!f.bakeOptions.empty()) {
    out.put("bake options:");
    for (const auto& [k, v] : f.bakeOptions) out.put(" " + k + "=" + v);
    out.put("\n");
  }
  for (uint32_t a = 0; a < m.arrays.size(); ++a) {
    const ArraySummary& s = sum.arrays[a];
    out.put("array " + std::to_string(a) + ": " + counted(s.geometries, "geometry", "geometries") + ", " +
            std::to_string(s.triangles) + " triangles, " + std::to_string(s.uniqueMicromaps) +
            " unique micromaps\n");
    printArray(out, s, "  ");
    out.put("  " + encodingsLine(sizes[a]) + "\n");
    if (o.referenceCompressors) out.put("  " + referenceLine(sizes[a]) + "\n");
  }
  for (uint32_t i = 0; i < f.geometries.size(); ++i) {
    const somm::GeometryInfo& g = f.geometries[i];
    out.put("geometry " + std::to_string(i) + " '" + somm::escapeName(g.name) + "' (material '" +
            somm::escapeName(g.material) + "'): " + std::to_string(g.triangleCount) + " triangles at " +
            std::to_string(m.geometries[i].firstTriangle) + " in array " +
            std::to_string(m.geometries[i].array) + ", " + std::to_string(statesOf(g.format)) +
            "-state, levels " + std::to_string(g.minLevel) + ".." + std::to_string(g.maxLevel) + ", cutoff " +
            floatText(g.cutoff) + ", " + filterName(g.sampler.filter) + ", wrap " +
            wrapName(g.sampler.wrapS) + "/" + wrapName(g.sampler.wrapT) + ", " +
            indexBits(geometryIndexType(m, i)) + "-bit indices (" + bytesText(sum.geometries[i].indexBytes) +
            ")\n");
    printGeometry(out, sum.geometries[i], "  ");
  }
  const GeometrySummary& t = sum.geometryTotal;
  out.put("total: " + counted(f.geometries.size(), "geometry", "geometries") + ", " +
          counted(m.arrays.size(), "array", "arrays") + ", " + std::to_string(t.triangles) + " triangles, " +
          std::to_string(sum.arrayTotal.uniqueMicromaps) + " unique micromaps\n");
  out.put("  special indices (triangles): transparent " + std::to_string(t.special[0]) + ", opaque " +
          std::to_string(t.special[1]) + ", unknown-transparent " + std::to_string(t.special[2]) +
          ", unknown-opaque " + std::to_string(t.special[3]) + "\n");
  out.put("  unknown: " + std::to_string(t.unknownMicroTriangles) + " of the " +
          std::to_string(t.microTriangles) + " micro-triangles of the " +
          std::to_string(t.micromapTriangles) + " triangles with micromaps (" + percent(t.unknownFraction()) +
          ")\n");
  out.put("  build buffers: data " + bytesText(sum.arrayTotal.dataBytes) + ", descriptors " +
          bytesText(sum.arrayTotal.descriptorBytes) + ", index buffers " + bytesText(t.indexBytes) +
          "; sum " + bytesText(sum.arrayTotal.dataBytes + sum.arrayTotal.descriptorBytes + t.indexBytes) +
          "\n");
  if (m.arrays.size() > 1) {
    out.put("  " + encodingsLine(sizeTotal) + "\n");
    if (o.referenceCompressors) out.put("  " + referenceLine(sizeTotal) + "\n");
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand(
      "info",
      "Describe a .somm file: per OMM array its micromaps, level histograms, buffer and encoding sizes; per "
      "geometry its triangles, special indices per state and unknown fraction; and the totals.");
  cmd->add_option("file", opts->path, ".somm file")->required();
  cmd->add_flag("--json", opts->json, "print JSON (keys documented in docs/cli.md)");
  cmd->add_flag("--reference-compressors", opts->referenceCompressors,
                "also compress each array's flat encoding with zstd -19 and xz -9 (slow on large files)");
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("info", &setup);

}  // namespace
