// SPDX-License-Identifier: MIT
// somm — scene loading entry point: dispatch by extension, common checks.
#include "somm/scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <new>
#include <stdexcept>
#include <system_error>

#include "loaders.h"

namespace somm {

Result<Scene> loadScene(const std::string& path, const LoadOptions& options) {
  std::error_code ec;
  const std::filesystem::path p(path);
  if (!std::filesystem::exists(p, ec))
    return makeError(ErrorCode::IoError, path + ": cannot open file (no such file)");
  if (!std::filesystem::is_regular_file(p, ec))
    return makeError(ErrorCode::IoError, path + ": not a regular file");
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext != ".gltf" && ext != ".glb" && ext != ".obj")
    return makeError(ErrorCode::UnsupportedFormat,
                     path + ": unknown scene format '" + ext + "' (expected .gltf, .glb or .obj)");
  Result<Scene> r = makeError(ErrorCode::UnsupportedFormat, "");
  uint64_t droppedBadPos = 0;  // non-finite components of positions not kept (LoadOptions::loadPositions)
  try {
    if (ext == ".obj")
      r = detail::loadObj(path, options, droppedBadPos);
    else
      r = detail::loadGltf(path, ext == ".glb", options, droppedBadPos);
  } catch (const std::bad_alloc&) {
    return makeError(ErrorCode::LimitExceeded, path + ": out of memory while loading the scene");
  } catch (const std::length_error&) {
    return makeError(ErrorCode::LimitExceeded, path + ": scene too large");
  }
  if (!r.ok()) return r;
  Scene& s = r.value();
  uint64_t badPos = droppedBadPos, badUv = 0;
  for (Geometry& g : s.geometries) {
    for (float v : g.positions) badPos += !std::isfinite(v);
    for (float v : g.uvs) badUv += !std::isfinite(v);
    // A loader that had to read them anyway (an irregular OBJ, docs/scene.md "UV-only loading"): counted, dropped.
    if (!options.loadPositions) std::vector<float>().swap(g.positions);
  }
  if (badPos || badUv)
    s.warnings.push_back(std::to_string(badPos) + " non-finite position and " + std::to_string(badUv) +
                         " non-finite texture coordinate components (NaN/inf)");
  if (s.geometries.empty()) s.warnings.push_back("the scene has no geometry");
  return r;
}

namespace detail {

void splitLines(const std::string& text, std::vector<std::string>& out) {
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (!line.empty()) out.push_back(std::move(line));
    start = end + 1;
  }
}

}  // namespace detail

}  // namespace somm
