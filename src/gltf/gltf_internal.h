// SPDX-License-Identifier: MIT
// somm — helpers shared by the EXT_mesh_opacity_micromap reader and writer. Internal to somm_gltf.
#pragma once

#include <string>
#include <vector>

#include "document.h"
#include "somm/gltf.h"

namespace somm {

// Reads the extension from a parsed document (present == false when it is not used).
Result<GltfMicromapsRead> readDocumentMicromaps(gltfdoc::Document& d);

namespace gltfint {

using gltfdoc::json;

const json* member(const json& o, const char* key);
const json* array(const json& root, const char* key);  // root[key] when it is an array

struct ViewBytes {
  const uint8_t* data = nullptr;
  size_t size = 0;
  bool hasStride = false;
  uint64_t byteOffset = 0;  // in its buffer
};
// A validated bufferView (inside its buffer). `what` names the referrer in messages.
Result<ViewBytes> bufferView(gltfdoc::Document& d, int64_t index, const std::string& what);

// One mesh primitive = one scene geometry (loadScene's numbering).
struct PrimitiveRef {
  size_t mesh = 0, primitive = 0;
  std::string name;   // "<mesh name>/<primitive>"
  std::string where;  // "meshes[i].primitives[j]"
  int64_t mode = 4;
  int64_t material = -1;
  uint32_t triangles = 0;  // indices count / 3 (POSITION count / 3 without indices); 0 unless mode 4
};
Result<std::vector<PrimitiveRef>> primitives(gltfdoc::Document& d);

struct MaterialRef {
  std::string name = "default";
  std::string alphaMode = "OPAQUE";
  double cutoff = 0.5;
  Sampler sampler;
};
MaterialRef materialRef(const gltfdoc::Document& d, int64_t material);

}  // namespace gltfint
}  // namespace somm
