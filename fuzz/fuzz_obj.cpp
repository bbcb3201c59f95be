// SPDX-License-Identifier: MIT
// Fuzz target: the OBJ/MTL path of loadScene (tinyobjloader + our material/texture handling). The input is
// the OBJ text, optionally followed by a NUL byte and the text of m.mtl; the scratch directory also holds
// t.png, so `mtllib m.mtl` and `map_d t.png` resolve. Loaded scenes must satisfy the invariants in
// scene_fuzz_util.h; errors must be one line naming the file.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "scene_fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace somm;
  const std::string& dir = fuzz::scratchDir();
  const uint8_t* nul = static_cast<const uint8_t*>(std::memchr(data, 0, size));
  const size_t objSize = nul ? size_t(nul - data) : size;
  const std::string obj = dir + "/f.obj";
  fuzz::writeBytes(obj, data, objSize);
  if (nul)
    fuzz::writeBytes(dir + "/m.mtl", nul + 1, size - objSize - 1);
  else
    std::remove((dir + "/m.mtl").c_str());
  const Result<Scene> s = loadScene(obj);
  if (s.ok())
    fuzz::checkScene("fuzz_obj", *s);
  else
    fuzz::checkError("fuzz_obj", s.error(), obj);
  return 0;
}
