// SPDX-License-Identifier: MIT
// Fuzz target: the glTF 2.0 path of loadScene (tinygltf + our accessor, material, texture and node handling), and
// the EXT_mesh_opacity_micromap reader (readGltfMicromaps: every MUST of the draft; docs/gltf.md) on the same file,
// and readMicromapFile (what `somm info` / `query` open a glTF with): it must agree with the reader.
// The first input byte picks .gltf (even) or .glb (odd); the rest is the file. The scratch directory holds
// t.png and b.bin (64 bytes) for external URIs. Loaded scenes must satisfy the invariants in
// scene_fuzz_util.h; errors must be one line naming the file.
#include <cstddef>
#include <cstdint>

#include "scene_fuzz_util.h"
#include "somm/gltf.h"
#include "somm/somm_file.h"

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
  // The micromaps: accepted ones must be internally consistent (every lookup resolvable, every region readable).
  const Result<GltfMicromapsRead> m = readGltfMicromaps(path);
  const Result<SommFile> file = readMicromapFile(path);
  if (file.ok() != (m.ok() && m->present))
    fuzz::fail("fuzz_gltf", "readMicromapFile disagrees with readGltfMicromaps");
  if (file.ok()) {
    if (file->micromaps.arrays.size() != m->value.micromaps.arrays.size() ||
        file->geometries.size() != m->value.geometries.size())
      fuzz::fail("fuzz_gltf", "readMicromapFile: other arrays or geometries than readGltfMicromaps");
    for (const OmmArray& a : file->micromaps.arrays)
      if (!validateOmmArray(a, "fuzz").ok())
        fuzz::fail("fuzz_gltf", "readMicromapFile: an array does not validate");
  } else {
    fuzz::checkError("fuzz_gltf", file.error(), path);
  }
  if (!m.ok()) {
    fuzz::checkError("fuzz_gltf", m.error(), path);
    return 0;
  }
  if (!m->present) return 0;
  const SceneMicromaps& mm = m->value.micromaps;
  if (mm.geometries.size() != m->value.geometries.size()) fuzz::fail("fuzz_gltf", "geometry count mismatch");
  for (uint32_t g = 0; g < mm.geometries.size(); ++g) {
    const GeometryMicromaps& r = mm.geometries[g];
    if (r.array >= mm.arrays.size() ||
        uint64_t(r.firstTriangle) + r.triangleCount > mm.arrays[r.array].indices.size())
      fuzz::fail("fuzz_gltf", "geometry outside its array");
    const OmmArray& a = mm.arrays[r.array];
    for (uint32_t t = 0; t < r.triangleCount; ++t) {
      const int32_t i = mm.indices(g)[t];
      if (i < -4 || (i >= 0 && size_t(i) >= a.descriptors.size()))
        fuzz::fail("fuzz_gltf", "unresolvable lookup");
      const uint32_t level = i >= 0 ? a.descriptors[size_t(i)].subdivisionLevel : 0;
      (void)mm.state(g, t, (1u << (2 * level)) - 1);  // the last micro-triangle's bits are inside the data
    }
  }
  return 0;
}
