// SPDX-License-Identifier: MIT
// somm — scenes loaded from glTF 2.0 (.gltf/.glb) and OBJ/MTL: what the baker and the ray tracer consume.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "somm/limits.h"
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

// True when every entry of the column-major transform is finite and its linear (upper-left 3×3) part is
// invertible: |det| > 1e-12 × the product of its column lengths (a rank-deficient matrix computed in float
// leaves a tiny non-zero determinant). Loaders and the tracer reject other instance transforms: a singular
// one collapses the geometry onto a plane, a line or a point.
inline bool isUsableTransform(const std::array<float, 16>& m) noexcept {
  for (float x : m)
    if (!(x - x == 0.0f)) return false;  // NaN or ±inf
  const double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6], i = m[10];
  const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
  double norms = 1.0;
  for (int col = 0; col < 3; ++col) {
    const double x = m[4 * col], y = m[4 * col + 1], z = m[4 * col + 2];
    norms *= x * x + y * y + z * z;
  }
  return norms > 0 && det * det > 1e-24 * norms;
}

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
  // Every file the loader read: the scene file, external glTF buffers and images, OBJ material libraries and
  // textures. A command's output must not replace any of them (`render scene.gltf -o leaf.png` overwrote the
  // scene's own texture).
  std::vector<std::string> inputFiles;
};

struct LoadOptions {
  bool blendAsMask = false;  // treat glTF BLEND materials as MASK with their cutoff
  // Keep the base colour images (Material::baseColor) for shading. False: baseColor stays null and only what the
  // alpha test needs is kept (`somm bake`: the images are still decoded, for their alpha, then dropped).
  bool loadColor = true;
  // Keep the vertex positions (Geometry::positions). False: positions stay empty and everything else is what a
  // full load gives (the same geometries, vertex numbering, UVs, triangles, materials, textures and warnings):
  // what baking reads (`somm bake`). An OBJ is then parsed without tinyobjloader's whole-file arrays (less memory
  // and time; docs/scene.md "UV-only loading").
  bool loadPositions = true;
  Limits limits;  // file sizes, image pixels, nodes, instances (docs/hardening.md)
};

// Loads .gltf, .glb or .obj (by extension). Errors name the file and the problem. See docs/scene.md.
Result<Scene> loadScene(const std::string& path, const LoadOptions& options = {});

// Writes a scene as one self-contained .glb that loadScene reads back with the same numbering: geometry i →
// mesh i (one primitive), instance → node, camera → camera node. A material's alpha texture is stored as the alpha
// of its base colour PNG (RGB from baseColor, resampled to the alpha's size, else white) with baseColorFactor alpha 1:
// an 8-bit PNG when the alpha is an 8-bit image's without a factor (exact), else a 16-bit one (alpha rounded to
// multiples of 1/65535); materials with the same textures share one image (docs/gltf.md). Written atomically
// (temporary file + rename).
Status writeGlb(const Scene& scene, const std::string& path);
// The bytes writeGlb writes (`path` only names the file in messages).
Result<std::vector<uint8_t>> encodeGlb(const Scene& scene, const std::string& path);

}  // namespace somm
