// SPDX-License-Identifier: MIT
// somm — internal entry points of the scene loaders.
#pragma once

#include <string>
#include <vector>

#include "somm/result.h"
#include "somm/scene.h"

namespace somm::detail {

Result<Scene> loadGltf(const std::string& path, bool binary, const LoadOptions& options);
Result<Scene> loadObj(const std::string& path, const LoadOptions& options);

// A parser's warning text, one entry per non-empty line (trailing CR and spaces removed), appended to `out`.
void splitLines(const std::string& text, std::vector<std::string>& out);

}  // namespace somm::detail
