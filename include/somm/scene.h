// somm — scenes loaded from glTF 2.0 (.gltf/.glb) and OBJ/MTL: what the baker and the ray tracer consume.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "somm/result.h"
#include "somm/texture.h"

namespace somm {

enum class AlphaMode : uint8_t { Opaque = 0, Mask = 1, Blend = 2 };

// An 8-bit RGBA image for shading (base colour), row order as AlphaTexture (row y covers v in [y/H,
// (y+1)/H]).
struct ColorImage {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;  // width * height * 4
};

struct Material {
  std::string name;
  AlphaMode alphaMode = AlphaMode::Opaque;
  float alphaCutoff = 0.5f;
  bool doubleSided = false;
  std::array<float, 4> baseColorFactor{1, 1, 1, 1};
  // Alpha used by the alpha test: alpha texture × constant factor already multiplied in. Null when the alpha
  // is the constant baseColorFactor[3] alone. Loaders set it for alpha-tested materials only.
  std::shared_ptr<const AlphaTexture> alpha;
  std::shared_ptr<const ColorImage> baseColor;  // may be null; as stored (baseColorFactor not applied)
  Sampler sampler;                              // of the alpha (base colour) texture
  std::string alphaSource;                      // path of the image the alpha comes from, for messages

  // True when triangles of this material need an alpha test (MASK, or BLEND treated as mask).
  bool alphaTested() const noexcept { return alphaMode == AlphaMode::Mask; }
};

// One geometry: a glTF mesh primitive, or an OBJ (shape, material) group. Micromaps belong to geometries.
struct Geometry {
  std::string name;
  uint32_t material = 0;          // index into Scene::materials
  std::vector<float> positions;   // xyz per vertex (object space)
  std::vector<float> uvs;         // st per vertex, in the material's texture convention (see AlphaTexture)
  std::vector<uint32_t> indices;  // 3 per triangle
  uint32_t triangleCount() const noexcept { return uint32_t(indices.size() / 3); }
};

// A placement of a geometry in the world. glTF instances share one geometry.
struct Instance {
  uint32_t geometry = 0;
  std::array<float, 16> transform{1, 0, 0, 0, 0, 1, 0, 0,
                                  0, 0, 1, 0, 0, 0, 0, 1};  // column-major object→world
};

struct Camera {
  std::array<float, 3> eye{0, 0, 0}, target{0, 0, -1}, up{0, 1, 0};
  float yfovRadians = 0.8f;
};

struct Scene {
  std::string sourcePath;
  std::vector<Material> materials;
  std::vector<Geometry> geometries;
  std::vector<Instance> instances;
  std::optional<Camera> camera;       // the first glTF camera, if any
  std::vector<std::string> warnings;  // non-fatal notes (skipped primitives, BLEND materials, ...)
};

struct LoadOptions {
  bool blendAsMask = false;  // treat glTF BLEND materials as MASK with their cutoff
};

// Loads .gltf, .glb or .obj (by extension). Errors name the file and the problem. See docs/scene.md.
Result<Scene> loadScene(const std::string& path, const LoadOptions& options = {});

// Writes a scene as one self-contained .glb that loadScene reads back with the same numbering: geometry i →
// mesh i (one primitive), instance → node, camera → camera node. Alpha textures are stored as the alpha of a
// 16-bit PNG (RGB from baseColor when it has the same size, else white) with baseColorFactor alpha 1, so
// alpha values are rounded to multiples of 1/65535 (exact for 8-bit and binary alphas). Written atomically
// (temporary file + rename).
Status writeGlb(const Scene& scene, const std::string& path);
// The bytes writeGlb writes (`path` only names the file in messages).
Result<std::vector<uint8_t>> encodeGlb(const Scene& scene, const std::string& path);

}  // namespace somm
