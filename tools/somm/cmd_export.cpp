// SPDX-License-Identifier: MIT
// somm export FILE.somm --dir D: per OMM array the raw buffers of vkCmdBuildMicromapsEXT / a DXR OMM array
// build, per geometry its OMM index buffer into its array (docs/cli.md).
#include <sys/stat.h>

#include <filesystem>
#include <string>
#include <system_error>

#include "command.h"
#include "file_summary.h"
#include "somm/gltf.h"
#include "somm/io.h"
#include "somm/somm_file.h"

namespace {

struct Options {
  std::string path;
  std::string dir;
};

// VkMicromapUsageEXT entries, with the Vulkan format value (1 = 2-state, 2 = 4-state) and the number of states.
nlohmann::json usageJson(const std::vector<somm::UsageCount>& h) {
  nlohmann::json a = nlohmann::json::array();
  for (const somm::UsageCount& c : h)
    a.push_back({{"count", c.count},
                 {"subdivisionLevel", c.subdivisionLevel},
                 {"format", c.format},
                 {"states", c.format == uint32_t(somm::Format::TwoState) ? 2 : 4}});
  return a;
}

// One geometry's index buffer: little-endian, 2 or 4 bytes per triangle, special indices −1..−4 as 0xFFFF..0xFFFC
// (32-bit: 0xFFFFFFFF..0xFFFFFFFC).
std::vector<uint8_t> indexBytes(const int32_t* idx, uint32_t n, somm::IndexType type) {
  const size_t w = size_t(type);
  std::vector<uint8_t> out(size_t(n) * w);
  for (size_t t = 0; t < n; ++t) {
    const uint32_t v = uint32_t(idx[t]);
    for (size_t k = 0; k < w; ++k) out[t * w + k] = uint8_t(v >> (8 * k));
  }
  return out;
}

struct OutFile {
  std::string name;
  std::vector<uint8_t> bytes;
};

bool writeDir(const std::filesystem::path& sub, const std::vector<OutFile>& files) {
  std::error_code ec;
  std::filesystem::create_directories(sub, ec);
  if (ec) {
    somm::cli::printError("export", sub.string() + ": cannot create directory: " + ec.message());
    return false;
  }
  for (const OutFile& out : files) {
    const somm::Status s = somm::writeFileAtomically((sub / out.name).string(), out.bytes);
    if (!s) {
      somm::cli::printError("export", s.error().message);
      return false;
    }
  }
  return true;
}

std::vector<uint8_t> textBytes(const nlohmann::json& j) {
  const std::string text = somm::cli::dumpJson(j) + "\n";
  return std::vector<uint8_t>(text.begin(), text.end());
}

int run(const Options& o) {
  using namespace somm::cli;
  // --dir naming something that is not a directory (/dev/null, a file, a FIFO) is a usage error, found before the
  // input is read.
  {
    struct stat st;
    if (::stat(o.dir.c_str(), &st) == 0 && !S_ISDIR(st.st_mode)) {
      printError("export", somm::escapeName(o.dir) + ": exists and is not a directory");
      return kExitUsage;
    }
  }
  auto file = somm::readMicromapFile(o.path);  // .somm or glTF (EXT_mesh_opacity_micromap)
  if (!file) {
    printError("export", file.error().message);
    return kExitFailure;
  }
  const somm::SommFile& f = *file;
  const somm::SceneMicromaps& m = f.micromaps;
  // Whole or not at all: everything is written into a temporary directory next to --dir and renamed into place
  // at the end (a failure leaves nothing; an existing non-empty directory is refused and kept as it is).
  somm::StagedDirectory staged;
  if (somm::Status s = staged.begin(o.dir); !s) {
    printError("export", s.error().message);
    return kExitFailure;
  }
  const std::filesystem::path root(staged.staging());
  // Per array: the micromap build inputs (one VkMicromapEXT / DXR OMM array).
  for (uint32_t ai = 0; ai < m.arrays.size(); ++ai) {
    const somm::OmmArray& a = m.arrays[ai];
    nlohmann::json u;
    u["array"] = ai;
    nlohmann::json geos = nlohmann::json::array();
    for (uint32_t g = 0; g < m.geometries.size(); ++g)
      if (m.geometries[g].array == ai) geos.push_back(g);
    u["geometries"] = geos;
    u["micromaps"] = a.descriptors.size();
    u["data_bytes"] = a.data.size();
    u["triangle_array_stride"] = 8;
    u["usage_counts"] = usageJson(a.histogram);  // VkMicromapBuildInfoEXT::pUsageCounts
    if (!writeDir(
            root / ("array-" + std::to_string(ai)),
            {{"data.bin", a.data}, {"triangles.bin", a.descriptorBytes()}, {"usage.json", textBytes(u)}}))
      return kExitFailure;
  }
  // Per geometry: its OMM index buffer into its array (VkAccelerationStructureTrianglesOpacityMicromapEXT).
  for (uint32_t gi = 0; gi < f.geometries.size(); ++gi) {
    const somm::GeometryInfo& g = f.geometries[gi];
    const somm::IndexType type = geometryIndexType(m, gi);
    const bool wide = type == somm::IndexType::UInt32;
    const bool two = g.format == somm::Format::TwoState;
    nlohmann::json u;
    u["geometry"] = gi;
    u["name"] = g.name;
    u["array"] = m.geometries[gi].array;
    u["format"] = uint32_t(g.format);
    u["states"] = two ? 2 : 4;
    u["vk_format"] =
        two ? "VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT" : "VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT";
    u["triangles"] = m.geometries[gi].triangleCount;
    u["index_type"] = wide ? "uint32" : "uint16";
    u["vk_index_type"] = wide ? "VK_INDEX_TYPE_UINT32" : "VK_INDEX_TYPE_UINT16";
    u["dxgi_index_format"] = wide ? "DXGI_FORMAT_R32_UINT" : "DXGI_FORMAT_R16_UINT";
    u["index_stride"] = wide ? 4 : 2;
    u["base_triangle"] = 0;
    u["triangle_usage_counts"] = usageJson(m.triangleHistogram(gi));
    if (!writeDir(root / ("geometry-" + std::to_string(gi)),
                  {{"index.bin", indexBytes(m.indices(gi), m.geometries[gi].triangleCount, type)},
                   {"usage.json", textBytes(u)}}))
      return kExitFailure;
  }
  if (somm::Status s = staged.commit(); !s) {
    printError("export", s.error().message);
    return kExitFailure;
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd =
      root.add_subcommand("export",
                          "Write the Vulkan / DXR build inputs as raw files: per OMM array "
                          "D/array-<a>/data.bin (micromap data), triangles.bin (8-byte "
                          "VkMicromapTriangleEXT descriptors) and usage.json (its geometries, "
                          "usage histogram); per geometry D/geometry-<g>/index.bin (its 16- or "
                          "32-bit OMM index buffer into its array, special indices -1..-4) and "
                          "usage.json (array, format, index type, its triangle usage histogram).");
  cmd->add_option("file", opts->path, ".somm file")->required();
  cmd->add_option("--dir,-d", opts->dir, "output directory: new or empty (written whole or not at all)")
      ->required();
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("export", &setup);

}  // namespace
