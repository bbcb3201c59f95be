// SPDX-License-Identifier: MIT
// somm — internal entry points of the scene loaders.
#pragma once

#include <string>
#include <vector>

#include "somm/result.h"
#include "somm/scene.h"

namespace somm::detail {

Result<Scene> loadGltf(const std::string& path, bool binary, const LoadOptions& options,
                       uint64_t& nonFinitePositions);
// `nonFinitePositions`: with options.loadPositions false, the non-finite components of the positions that were
// not kept (0 otherwise). Without positions a loader may still return them (loadScene drops them).
Result<Scene> loadObj(const std::string& path, const LoadOptions& options, uint64_t& nonFinitePositions);
// The UV-only parse alone (what loadObj tries first without positions): `irregular` set when the file needs the
// full load instead (the result is then an error to ignore).
Result<Scene> loadObjUvOnly(const std::string& path, const LoadOptions& options, bool& irregular,
                            uint64_t& nonFinitePositions);

// A parser's warning text, one entry per non-empty line (trailing CR and spaces removed), appended to `out`.
void splitLines(const std::string& text, std::vector<std::string>& out);

}  // namespace somm::detail
