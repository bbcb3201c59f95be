// SPDX-License-Identifier: MIT
// Fuzz target: the glTF 2.0 path of loadScene (tinygltf + our accessor, material, texture and node handling).
// The first input byte picks .gltf (even) or .glb (odd); the rest is the file. The scratch directory holds
// t.png and b.bin (64 bytes) for external URIs. Loaded scenes must satisfy the invariants in
// scene_fuzz_util.h; errors must be one line naming the file.
#include <cstddef>
#include <cstdint>

#include "scene_fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace somm;
  if (size < 1) return 0;
  const std::string& dir = fuzz::scratchDir();
  const std::string path = dir + ((data[0] & 1) ? "/f.glb" : "/f.gltf");
  fuzz::writeBytes(path, data + 1, size - 1);
  const Result<Scene> s = loadScene(path);
  if (s.ok())
    fuzz::checkScene("fuzz_gltf", *s);
  else
    fuzz::checkError("fuzz_gltf", s.error(), path);
  return 0;
}
