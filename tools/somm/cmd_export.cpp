// somm export FILE.somm --dir D: per geometry the raw spec buffers for vkCmdBuildMicromapsEXT / a DXR OMM
// array build.
#include <filesystem>
#include <string>
#include <system_error>

#include "command.h"
#include "file_summary.h"
#include "somm/gltf.h"
#include "somm/somm_file.h"

namespace {

struct Options {
  std::string path;
  std::string dir;
};

nlohmann::json usageJson(const std::vector<somm::UsageCount>& h) {
  nlohmann::json a = nlohmann::json::array();
  for (const somm::UsageCount& c : h)
    a.push_back({{"count", c.count}, {"subdivisionLevel", c.subdivisionLevel}, {"format", c.format}});
  return a;
}

int run(const Options& o) {
  using namespace somm::cli;
  auto file = somm::readMicromapFile(o.path);  // .somm or glTF (EXT_mesh_opacity_micromap)
  if (!file) {
    printError("export", file.error().message);
    return kExitFailure;
  }
  const somm::SommFile& f = *file;
  std::error_code ec;
  std::filesystem::create_directories(o.dir, ec);
  if (ec || !std::filesystem::is_directory(o.dir)) {
    printError("export",
               o.dir + ": cannot create the output directory" + (ec ? ": " + ec.message() : std::string()));
    return kExitFailure;
  }
  for (size_t gi = 0; gi < f.geometries.size(); ++gi) {
    const somm::SommGeometry& g = f.geometries[gi];
    const std::filesystem::path sub = std::filesystem::path(o.dir) / ("geometry-" + std::to_string(gi));
    std::filesystem::create_directories(sub, ec);
    if (ec) {
      printError("export", sub.string() + ": cannot create directory: " + ec.message());
      return kExitFailure;
    }
    const somm::OmmArray& a = g.flat;
    const bool wide = a.indexType() == somm::IndexType::UInt32;
    nlohmann::json u;
    u["geometry"] = gi;
    u["name"] = g.info.name;
    u["format"] = g.info.format == somm::Format::TwoState ? 2 : 4;
    u["vk_format"] = g.info.format == somm::Format::TwoState ? "VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT"
                                                             : "VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT";
    u["triangles"] = a.indices.size();
    u["micromaps"] = a.descriptors.size();
    u["data_bytes"] = a.data.size();
    u["index_type"] = wide ? "uint32" : "uint16";
    u["vk_index_type"] = wide ? "VK_INDEX_TYPE_UINT32" : "VK_INDEX_TYPE_UINT16";
    u["dxgi_index_format"] = wide ? "DXGI_FORMAT_R32_UINT" : "DXGI_FORMAT_R16_UINT";
    u["index_stride"] = wide ? 4 : 2;
    u["triangle_array_stride"] = 8;
    u["usage_counts"] = usageJson(a.histogram);  // VkMicromapBuildInfoEXT::pUsageCounts
    u["triangle_usage_counts"] =
        usageJson(a.triangleHistogram);  // VkAccelerationStructureTrianglesOpacityMicromapEXT
    const std::string usage = dumpJson(u) + "\n";
    const struct {
      const char* name;
      std::vector<uint8_t> bytes;
    } outputs[] = {{"data.bin", a.data},
                   {"triangles.bin", a.descriptorBytes()},
                   {"index.bin", a.indexBufferBytes()},
                   {"usage.json", std::vector<uint8_t>(usage.begin(), usage.end())}};
    for (const auto& out : outputs) {
      const somm::Status s = somm::writeFileAtomically((sub / out.name).string(), out.bytes);
      if (!s) {
        printError("export", s.error().message);
        return kExitFailure;
      }
    }
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand("export",
                                      "Write each geometry's spec buffers as raw files: "
                                      "D/geometry-<g>/data.bin (micromap data), triangles.bin "
                                      "(8-byte VkMicromapTriangleEXT descriptors), index.bin (16- or 32-bit "
                                      "OMM index buffer, special indices "
                                      "-1..-4) and usage.json (format, index type, usage histograms).");
  cmd->add_option("file", opts->path, ".somm file")->required();
  cmd->add_option("--dir,-d", opts->dir, "output directory (created if missing)")->required();
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("export", &setup);

}  // namespace
