// SPDX-License-Identifier: MIT
// bake_from_memory_cpp17 [DIR]: the input of bake_from_memory.c through the C++ API (C++17): somm::bakeGeometry,
// the spec buffers, and a compressed (rank) array with random access. With DIR it writes the buffers as
// DIR/array-0/{data,triangles}.bin and DIR/geometry-0/index.bin, byte-identical to the C API's and to `somm bake` + `somm export`.
#include <sys/stat.h>

#include <cstdio>
#include <memory>
#include <string>

#include "example_scene.h"
#include "somm/bake.h"
#include "somm/encode.h"

int main(int argc, char** argv) {
  static ex_scene scene;
  ex_make_scene(&scene);

  auto alpha = std::make_shared<somm::AlphaTexture>();
  alpha->width = alpha->height = EX_TEX;
  alpha->alpha.resize(EX_TEX * EX_TEX);
  for (size_t i = 0; i < alpha->alpha.size(); ++i)
    alpha->alpha[i] = float(double(scene.rgba[4 * i + 3]) / 255.0);
  somm::Material material;
  material.alphaMode = somm::AlphaMode::Mask;  // the default is Opaque: nothing would be baked
  material.alphaCutoff = 0.5f;
  material.alpha = alpha;
  somm::Geometry geometry;
  for (const ex_vertex& v : scene.vertices) geometry.uvs.insert(geometry.uvs.end(), {v.u, v.v});
  geometry.indices.assign(scene.indices, scene.indices + 3 * EX_TRIANGLES);

  somm::BakeOptions options;  // level 6, 4-state
  auto baked = somm::bakeGeometry(geometry, material, options);
  if (!baked) {
    std::fprintf(stderr, "bake_from_memory_cpp17: %s\n", baked.error().message.c_str());
    return 1;
  }
  const somm::OmmArray& a = baked->array;
  const std::vector<uint8_t> triangles = a.descriptorBytes(), indices = a.indexBufferBytes();
  std::printf(
      "%zu triangles: %zu micromaps; data %zu bytes, triangle array %zu bytes, index buffer %zu bytes\n",
      a.indices.size(), a.descriptors.size(), a.data.size(), triangles.size(), indices.size());
  auto rank = somm::EncodedArray::build(a, somm::Encoding::Rank);
  if (!rank) {
    std::fprintf(stderr, "bake_from_memory_cpp17: %s\n", rank.error().message.c_str());
    return 1;
  }
  uint32_t mismatches = 0;
  for (uint32_t t = 0; t < a.indices.size(); ++t)
    mismatches += rank->stateUV(t, 0.25f, 0.25f) != a.stateUV(t, 0.25f, 0.25f);
  std::printf("rank encoding %llu bytes (flat %zu), lookups equal: %s\n",
              (unsigned long long)rank->byteSize(), a.data.size() + triangles.size() + indices.size(),
              mismatches == 0 ? "yes" : "NO");
  if (mismatches) return 1;
  if (argc > 1) {
    const std::string dir = argv[1], arr = dir + "/array-0", geo = dir + "/geometry-0";
    mkdir(dir.c_str(), 0777);
    mkdir(arr.c_str(), 0777);
    mkdir(geo.c_str(), 0777);
    if (ex_write_file(arr.c_str(), "data.bin", a.data.data(), a.data.size()) ||
        ex_write_file(arr.c_str(), "triangles.bin", triangles.data(), triangles.size()) ||
        ex_write_file(geo.c_str(), "index.bin", indices.data(), indices.size())) {
      std::fprintf(stderr, "bake_from_memory_cpp17: %s: cannot write the output files\n", dir.c_str());
      return 1;
    }
  }
  return 0;
}
