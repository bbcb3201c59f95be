// SPDX-License-Identifier: MIT
// The one place where the C API's memory views (somm.h: strided UVs, 16/32-bit or no indices, textures by pointer,
// pitch and texel format) meet the C++ baker. Today it converts the views into Geometry / Material and runs the
// scene-level policy (BLEND, the scene-wide byte budget) over bakeGeometry exactly as `somm bake` does; when the
// library's scene-level bake over views lands, only bake_views.cpp changes.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "somm/omm_array.h"
#include "somm/result.h"
#include "somm/somm.h"

namespace somm::capi {

struct GeometryBakeInfo {
  std::array<uint64_t, 4> specialCount{};
  uint64_t microTriangles = 0, unknownMicroTriangles = 0, nonFiniteUvTriangles = 0;
  uint32_t minLevel = 0, maxLevel = 0;
};

struct SceneBake {
  SceneMicromaps micromaps;
  std::vector<GeometryBakeInfo> geometries;
  Format format = Format::FourState;
  uint32_t levelCap = 12;
};

// Thrown by the progress adapter when the caller's callback returns non-zero; caught in capi.cpp.
struct Cancelled {};

// Validates the views and options (messages in the C API's terms: "geometries[2].uv_stride ...") and bakes.
Result<SceneBake> bakeFromViews(const somm_bake_input& input, const somm_bake_options& options);

}  // namespace somm::capi
