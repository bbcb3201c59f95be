// SPDX-License-Identifier: MIT
// Fuzz target: the OBJ/MTL path of loadScene (tinyobjloader + our material/texture handling). The input is
// the OBJ text, optionally followed by a NUL byte and the text of m.mtl; the scratch directory also holds
// t.png, so `mtllib m.mtl` and `map_d t.png` resolve. Loaded scenes must satisfy the invariants in
// scene_fuzz_util.h; errors must be one line naming the file. The UV-only load (tinyobjloader's callback parser,
// LoadOptions::loadPositions = false) is checked against the full load: the same scene without positions, or the
// same error.
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
  // The UV-only load (LoadOptions::loadPositions = false, what `somm bake` uses) must give the same scene without
  // positions, or the same error.
  LoadOptions uvOnly;
  uvOnly.loadPositions = false;
  const Result<Scene> u = loadScene(obj, uvOnly);
  if (s.ok() != u.ok()) fuzz::fail("fuzz_obj", "the UV-only load and the full load disagree on success");
  if (!s.ok()) {
    if (s.error().message != u.error().message) fuzz::fail("fuzz_obj", "the UV-only load's error differs");
    return 0;
  }
  if (s->warnings != u->warnings || s->inputFiles != u->inputFiles ||
      s->materials.size() != u->materials.size() || s->geometries.size() != u->geometries.size() ||
      s->instances.size() != u->instances.size())
    fuzz::fail("fuzz_obj", "the UV-only load's scene differs");
  for (size_t g = 0; g < s->geometries.size(); ++g) {
    const Geometry &a = s->geometries[g], &b = u->geometries[g];
    if (a.name != b.name || a.material != b.material || a.indices != b.indices || !b.positions.empty() ||
        a.uvs.size() != b.uvs.size() ||
        (!a.uvs.empty() && std::memcmp(a.uvs.data(), b.uvs.data(), a.uvs.size() * sizeof(float)) != 0))
      fuzz::fail("fuzz_obj", "the UV-only load's geometry differs");
  }
  for (size_t m = 0; m < s->materials.size(); ++m)
    if (s->materials[m].name != u->materials[m].name ||
        s->materials[m].alphaMode != u->materials[m].alphaMode ||
        bool(s->materials[m].alpha) != bool(u->materials[m].alpha))
      fuzz::fail("fuzz_obj", "the UV-only load's material differs");
  return 0;
}
