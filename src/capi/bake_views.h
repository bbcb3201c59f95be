// SPDX-License-Identifier: MIT
// The one place where the C API's memory views (somm.h: strided UVs, 16/32-bit or no indices, textures by pointer,
// pitch and texel format) meet the C++ baker: they are checked and handed to bakeScene as its views (no copies).
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
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

// The value a C caller stored in an enum field, read as the int it is. A C enum object may hold any int value, but
// loading one outside the enumerators' range through the C++ enum type is undefined behaviour (UBSan: "load of
// value 100, which is not a valid value for type 'somm_format'"), so every enum field or parameter from the caller is
// checked through this and loaded as its enum type only once it is known to be valid.
template <class E>
int32_t rawEnum(const E& field) noexcept {
  static_assert(sizeof(E) == sizeof(int32_t), "C API enums are int-sized");
  int32_t v;
  std::memcpy(&v, &field, sizeof v);
  return v;
}

// (Kept for capi.cpp's exception guard; bakeScene reports cancellation as ErrorCode::Cancelled.)
struct Cancelled {};

// Validates the views and options (messages in the C API's terms: "geometries[2].uv_stride ...") and bakes.
Result<SceneBake> bakeFromViews(const somm_bake_input& input, const somm_bake_options& options);

}  // namespace somm::capi
