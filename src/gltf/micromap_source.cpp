// SPDX-License-Identifier: MIT
// somm — the micromaps of a .somm file or of a glTF with EXT_mesh_opacity_micromap, for the commands.
#include <cstring>

#include "document.h"
#include "gltf_internal.h"
#include "somm/gltf.h"

namespace somm {

Result<MicromapSource> loadMicromapSource(const std::string& path) {
  auto bytes = readWholeFile(path);
  if (!bytes) return bytes.error();
  MicromapSource src;
  const bool glb = bytes->size() >= 4 && std::memcmp(bytes->data(), "glTF", 4) == 0;
  size_t first = 0;
  while (first < bytes->size() && std::strchr(" \t\r\n", char((*bytes)[first])) && (*bytes)[first] != 0) ++first;
  const bool json = !glb && first < bytes->size() && (*bytes)[first] == '{';
  if (!glb && !json) {
    auto file = parseSomm(*bytes, path);
    if (!file) return file.error();
    src.container = "somm";
    std::vector<OmmArray> flats;
    for (const SommGeometry& g : file->geometries) flats.push_back(g.flat);
    src.micromaps = perGeometryMicromaps(std::move(flats));
    src.file = std::move(*file);
    return src;
  }
  auto read = parseGltfMicromaps(*bytes, glb, path);
  if (!read) return read.error();
  if (!read->present)
    return makeError(ErrorCode::UnsupportedFormat,
                     path + ": a glTF without " + std::string(kGltfMicromapExtension) + " holds no micromaps");
  GltfMicromaps& m = read->value;
  src.container = kGltfMicromapExtension;
  src.file.sourcePath = path;  // the glTF holds the scene itself, in the same geometry numbering
  src.file.toolVersion = m.toolVersion;
  src.file.bakeOptions = m.bakeOptions;
  for (size_t g = 0; g < m.geometries.size(); ++g) {
    SommGeometry sg;
    sg.info = m.geometries[g];
    sg.flat = m.micromaps.standalone(uint32_t(g));
    src.file.geometries.push_back(std::move(sg));
  }
  src.micromaps = std::move(m.micromaps);
  return src;
}

Status writeBakeOutput(const std::string& outPath, const std::string& scenePath, const Scene& scene,
                       const SommFile& file) {
  if (!isGltfPath(outPath)) return writeSommFile(outPath, file);
  std::vector<OmmArray> flats;
  std::vector<GeometryInfo> info;
  for (const SommGeometry& g : file.geometries) {
    flats.push_back(g.flat);
    info.push_back(g.info);
  }
  GltfWriteOptions o;
  o.toolVersion = file.toolVersion;
  o.sourcePath = file.sourcePath;
  o.bakeOptions = file.bakeOptions;
  return writeGltfMicromaps(outPath, scenePath, scene, mergeToSceneArray(perGeometryMicromaps(std::move(flats))), info,
                            o);
}

Result<SommFile> readMicromapFile(const std::string& path) {
  auto s = loadMicromapSource(path);
  if (!s) return s.error();
  return std::move(s->file);
}

}  // namespace somm
