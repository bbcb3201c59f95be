// SPDX-License-Identifier: MIT
// somm — the micromaps of a .somm file or of a glTF with EXT_mesh_opacity_micromap, for the commands.
#include <cstring>

#include "document.h"
#include "gltf_internal.h"
#include "somm/gltf.h"

namespace somm {

Result<MicromapSource> parseMicromapSource(const std::vector<uint8_t>& bytes, const std::string& path) {
  MicromapSource src;
  // GLB: the magic, version 2 and a length equal to the file's (or a .glb name); anything else is left to the .somm
  // parser, which names foreign files.
  const auto le32 = [&](size_t at) {
    return uint32_t(bytes[at]) | uint32_t(bytes[at + 1]) << 8 | uint32_t(bytes[at + 2]) << 16 |
           uint32_t(bytes[at + 3]) << 24;
  };
  const bool glb = bytes.size() >= 12 && std::memcmp(bytes.data(), "glTF", 4) == 0 && le32(4) == 2 &&
                   (le32(8) == bytes.size() || isGltfPath(path));
  size_t first = 0;
  while (first < bytes.size() &&
         (bytes[first] == ' ' || bytes[first] == '\t' || bytes[first] == '\r' || bytes[first] == '\n'))
    ++first;
  const bool json = !glb && first < bytes.size() && bytes[first] == '{';
  if (!glb && !json) {
    auto file = parseSomm(bytes, path);
    if (!file) return file.error();
    src.container = "somm";
    if (bytes.size() >= 12)
      src.sommVersion = uint32_t(bytes[8]) | uint32_t(bytes[9]) << 8 | uint32_t(bytes[10]) << 16 |
                        uint32_t(bytes[11]) << 24;
    src.file = std::move(*file);
    return src;
  }
  auto read = parseGltfMicromaps(bytes, glb, path);
  if (!read) return read.error();
  if (!read->present)
    return makeError(
        ErrorCode::UnsupportedFormat,
        path + ": a glTF without " + std::string(kGltfMicromapExtension) + " holds no micromaps");
  GltfMicromaps& m = read->value;
  src.container = kGltfMicromapExtension;
  src.file.sourcePath = path;  // the glTF holds the scene itself, in the same geometry numbering
  src.file.toolVersion = m.toolVersion;
  src.file.bakeOptions = m.bakeOptions;
  src.file.geometries = std::move(m.geometries);
  src.file.micromaps = std::move(m.micromaps);
  src.file.encodings.resize(src.file.micromaps.arrays.size());
  return src;
}

Result<MicromapSource> loadMicromapSource(const std::string& path) {
  auto bytes = readWholeFile(path);
  if (!bytes) return bytes.error();
  return parseMicromapSource(*bytes, path);
}

Status writeBakeOutput(const std::string& outPath, const std::string& scenePath, const Scene& scene,
                       const SommFile& file) {
  if (!isGltfPath(outPath)) return writeSommFile(outPath, file);
  GltfWriteOptions o;
  o.toolVersion = file.toolVersion;
  o.sourcePath = file.sourcePath;
  o.bakeOptions = file.bakeOptions;
  return writeGltfMicromaps(outPath, scenePath, scene, file.micromaps, file.geometries, o);
}

Result<SommFile> readMicromapFile(const std::string& path) {
  auto s = loadMicromapSource(path);
  if (!s) return s.error();
  return std::move(s->file);
}

}  // namespace somm
