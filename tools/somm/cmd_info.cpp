// somm info FILE.somm [--json]: what a .somm file holds, per geometry and in total.
#include <algorithm>
#include <cstdio>
#include <string>

#include "command.h"
#include "encodings.h"
#include "file_summary.h"
#include "somm/gltf.h"
#include "somm/somm_file.h"

namespace {

struct Options {
  std::string path;
  bool json = false;
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

void printSummary(somm::cli::Output& out, const somm::cli::ArraySummary& s, const std::string& indent) {
  using std::to_string;
  out.put(indent + "special indices: transparent " + to_string(s.special[0]) + ", opaque " +
          to_string(s.special[1]) + ", unknown-transparent " + to_string(s.special[2]) + ", unknown-opaque " +
          to_string(s.special[3]) + "\n");
  out.put(indent + "micromaps: " + to_string(s.micromapTriangles) + " triangles use " +
          to_string(s.uniqueMicromaps) + " unique micromaps\n");
  out.put(indent + "level histogram (level:micromaps): " + somm::cli::levelList(s.levelMicromaps) + "\n");
  out.put(indent + "level histogram (level:triangles): " + somm::cli::levelList(s.levelTriangles) + "\n");
  out.put(indent + "unknown: " + to_string(s.unknownMicroTriangles) + " of " + to_string(s.microTriangles) +
          " micro-triangles (" + percent(s.unknownFraction()) + ")");
  if (s.invalidUvTriangles) out.put(", " + to_string(s.invalidUvTriangles) + " triangles with NaN/inf UVs");
  out.put("\n");
  out.put(indent + "bytes: data " + to_string(s.dataBytes) + ", descriptors " + to_string(s.descriptorBytes) +
          ", index buffer " + to_string(s.indexBytes) + ", total " +
          somm::cli::humanBytes(s.dataBytes + s.descriptorBytes + s.indexBytes) + "\n");
}

// "encoded sizes: flat 1234 B, rank 120 B (0.0972×), ..."
std::string ratioLine(const somm::cli::EncodingSizes& s) {
  std::string line = "encoded sizes: flat " + std::to_string(s.flat) + " B";
  for (const auto& [e, b] : s.stored) {
    char buf[64];
    std::snprintf(buf, sizeof buf, " (%.4fx)", s.flat ? double(b) / double(s.flat) : 0.0);
    line += std::string(", ") + somm::encodingName(e) + " " + std::to_string(b) + " B" + buf;
  }
  for (const auto& [e, msg] : s.invalid) line += std::string(", ") + somm::encodingName(e) + " unreadable";
  return line;
}

int run(const Options& o) {
  using namespace somm::cli;
  auto file = somm::readMicromapFile(o.path);  // .somm or glTF (EXT_mesh_opacity_micromap)
  if (!file) {
    printError("info", file.error().message);
    return kExitFailure;
  }
  const somm::SommFile& f = *file;
  ArraySummary total;
  std::vector<ArraySummary> per;
  for (const somm::SommGeometry& g : f.geometries) {
    per.push_back(summarize(g.flat, g.info.stats));
    total.add(per.back());
  }
  // Bytes per extra encoding, summed over the geometries that store it (in order of first appearance).
  std::vector<std::pair<uint32_t, uint64_t>> encTotals;
  for (const somm::SommGeometry& g : f.geometries)
    for (const somm::EncodedSection& e : g.extra) {
      auto it =
          std::find_if(encTotals.begin(), encTotals.end(), [&](const auto& p) { return p.first == e.id; });
      if (it == encTotals.end())
        encTotals.emplace_back(e.id, e.bytes.size());
      else
        it->second += e.bytes.size();
    }

  // Exact bytes of every stored encoding and their ratio to flat (docs/encodings.md); JSON adds zstd/xz references.
  somm::cli::EncodingSizes sizeTotal;
  std::vector<somm::cli::EncodingSizes> sizes;
  for (size_t i = 0; i < f.geometries.size(); ++i) {
    auto s = somm::cli::encodingSizes(f.geometries[i], uint32_t(i), o.path, o.json);
    if (!s) {
      printError("info", s.error().message);
      return kExitFailure;
    }
    sizes.push_back(*s);
    sizeTotal.add(*s);
  }

  Output out;
  if (o.json) {
    nlohmann::json j;
    j["file"] = o.path;
    j["version"] = somm::kSommFileVersion;
    j["source"] = f.sourcePath;
    j["tool_version"] = f.toolVersion;
    nlohmann::json opts = nlohmann::json::object();
    for (const auto& [k, v] : f.bakeOptions) opts[k] = v;
    j["bake_options"] = opts;
    nlohmann::json geos = nlohmann::json::array();
    for (size_t i = 0; i < f.geometries.size(); ++i) {
      const somm::SommGeometry& g = f.geometries[i];
      nlohmann::json x = summaryJson(per[i]);
      x["index"] = i;
      x["name"] = g.info.name;
      x["material"] = g.info.material;
      x["format"] = statesOf(g.info.format);
      x["min_level"] = g.info.minLevel;
      x["max_level"] = g.info.maxLevel;
      x["cutoff"] = g.info.cutoff;
      x["filter"] = filterName(g.info.sampler.filter);
      x["wrap"] = {wrapName(g.info.sampler.wrapS), wrapName(g.info.sampler.wrapT)};
      x["index_type"] = g.flat.indexType() == somm::IndexType::UInt16 ? 16 : 32;
      nlohmann::json enc = nlohmann::json::array();
      for (const somm::EncodedSection& e : g.extra)
        enc.push_back({{"id", somm::sectionIdName(e.id)}, {"bytes", e.bytes.size()}});
      x["encodings"] = enc;
      x["encoding_sizes"] = somm::cli::encodingSizesJson(sizes[i]);
      geos.push_back(std::move(x));
    }
    j["geometries"] = geos;
    nlohmann::json t = summaryJson(total);
    t["geometries"] = f.geometries.size();
    nlohmann::json enc = nlohmann::json::array();
    for (const auto& [id, bytes] : encTotals)
      enc.push_back({{"id", somm::sectionIdName(id)}, {"bytes", bytes}});
    t["encodings"] = enc;
    t["encoding_sizes"] = somm::cli::encodingSizesJson(sizeTotal);
    j["total"] = t;
    out.put(dumpJson(j));
    out.put("\n");
    return kExitOk;
  }

  out.put(o.path + ": .somm version " + std::to_string(somm::kSommFileVersion) + ", written by '" +
          f.toolVersion + "' from '" + f.sourcePath + "'\n");
  if (!f.bakeOptions.empty()) {
    out.put("bake options:");
    for (const auto& [k, v] : f.bakeOptions) out.put(" " + k + "=" + v);
    out.put("\n");
  }
  for (size_t i = 0; i < f.geometries.size(); ++i) {
    const somm::SommGeometry& g = f.geometries[i];
    out.put("geometry " + std::to_string(i) + " '" + g.info.name + "' (material '" + g.info.material +
            "'): " + std::to_string(g.info.triangleCount) + " triangles, " +
            std::to_string(statesOf(g.info.format)) + "-state, levels " + std::to_string(g.info.minLevel) +
            ".." + std::to_string(g.info.maxLevel) + ", cutoff " + floatText(g.info.cutoff) + ", " +
            filterName(g.info.sampler.filter) + ", wrap " + wrapName(g.info.sampler.wrapS) + "/" +
            wrapName(g.info.sampler.wrapT) + ", " +
            (g.flat.indexType() == somm::IndexType::UInt16 ? "16" : "32") + "-bit indices\n");
    printSummary(out, per[i], "  ");
    if (!g.extra.empty()) {
      out.put("  encodings:");
      for (const somm::EncodedSection& e : g.extra)
        out.put(" " + somm::sectionIdName(e.id) + " " + std::to_string(e.bytes.size()) + " B");
      out.put("\n");
      out.put("  " + ratioLine(sizes[i]) + "\n");
    }
  }
  out.put("total: " + std::to_string(f.geometries.size()) + " geometries, " +
          std::to_string(total.triangles) + " triangles\n");
  printSummary(out, total, "  ");
  if (!encTotals.empty()) {
    out.put("  encodings:");
    for (const auto& [id, bytes] : encTotals)
      out.put(" " + somm::sectionIdName(id) + " " + std::to_string(bytes) + " B");
    out.put("\n");
    out.put("  " + ratioLine(sizeTotal) + "\n");
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand(
      "info",
      "Describe a .somm file: per geometry and in total, triangles, special indices per state, unique "
      "micromaps, level histograms, unknown fraction and buffer sizes.");
  cmd->add_option("file", opts->path, ".somm file")->required();
  cmd->add_flag("--json", opts->json, "print JSON (keys documented in docs/cli.md)");
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("info", &setup);

}  // namespace
