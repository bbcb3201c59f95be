// SPDX-License-Identifier: MIT
// somm — internal entry points of the scene loaders.
#pragma once

#include <string>

#include "somm/result.h"
#include "somm/scene.h"

namespace somm::detail {

Result<Scene> loadGltf(const std::string& path, bool binary, const LoadOptions& options);
Result<Scene> loadObj(const std::string& path, const LoadOptions& options);

}  // namespace somm::detail
