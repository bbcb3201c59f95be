// SPDX-License-Identifier: MIT
// somm — glTF 2.0 interchange of baked micromaps: the Khronos draft EXT_mesh_opacity_micromap (glTF pull request
// 2623). Writing a baked scene back as glTF with its micromaps, reading them from a glTF/GLB (every MUST of the draft
// checked), and one entry point that reads the micromaps of either a .somm file or such a glTF. See docs/gltf.md.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "somm/omm_array.h"
#include "somm/result.h"
#include "somm/scene.h"
#include "somm/somm_file.h"

namespace somm {

// The extension's name, as it appears in glTF files (and in the `micromaps` key of `--json` outputs).
inline constexpr const char* kGltfMicromapExtension = "EXT_mesh_opacity_micromap";

// True when `path` ends in .gltf or .glb (case-insensitive).
bool isGltfPath(const std::string& path);

struct GltfWriteOptions {
  std::string toolVersion;                                       // e.g. "somm 0.1.0" (stored in extras)
  std::string sourcePath;                                        // the scene the bake read (stored in extras)
  std::vector<std::pair<std::string, std::string>> bakeOptions;  // stored in the micromap's extras
};

// Writes the scene `scenePath` (already loaded as `scene`, same geometry numbering as loadScene) to `outPath`
// (.glb, or .gltf + a .bin next to it) with `micromaps` in EXT_mesh_opacity_micromap. `info[g]` says how geometry
// g was baked (cutoff and sampler filter, format; GeometryInfo from the .somm metadata).
//  * glTF input: the input JSON is kept as is (nodes, materials, textures, samplers, other extensions, extras);
//    its buffers are kept and the micromap data appended (.glb: to the binary chunk = buffer 0; .gltf: a new
//    buffer in the .bin, or buffer 0 when the input was a .glb); relative URIs are rewritten relative to the output.
//  * OBJ (or any other) input: the scene as writeGlb writes it (MASK materials with the cutoff used, textures
//    embedded), plus the extension.
// Every array of `micromaps` becomes one entry of the root `micromaps`; each triangle primitive points into its
// array with micromapBaseTriangle = its smallest micromap index and the smallest index component type that fits
// (micromapIndices omitted when the lookup is the identity). Written atomically (both files of a .gltf + .bin).
Status writeGltfMicromaps(const std::string& outPath, const std::string& scenePath, const Scene& scene,
                          const SceneMicromaps& micromaps, const std::vector<GeometryInfo>& info,
                          const GltfWriteOptions& options = {});

// What `somm bake -o OUT` writes: a glTF with the extension when OUT ends in .gltf/.glb (file.micromaps as they are —
// the bake's scene-wide array by default; tool version, source and bake options in the extras; further encodings are
// not stored), else the .somm file.
Status writeBakeOutput(const std::string& outPath, const std::string& scenePath, const Scene& scene,
                       const SommFile& file);

// The micromaps of a glTF, in the scene's geometry numbering (one geometry per mesh primitive, in order).
struct GltfMicromaps {
  SceneMicromaps micromaps;  // arrays = root micromaps[] (a primitive without the extension: all -4)
  std::vector<GeometryInfo> geometries;  // name/material as loadScene; format/levels from the records used;
                                         // cutoff/filter from the extension's extras, else from the material
  std::vector<uint8_t> hasMicromap;      // per geometry: 1 when its primitive carries the extension
  std::string toolVersion;               // from the extras, when somm wrote the file
  std::string sourcePath;                // likewise (the scene somm baked)
  std::vector<std::pair<std::string, std::string>> bakeOptions;
};

// Reads EXT_mesh_opacity_micromap from a .gltf/.glb. An error (one line: the path, the object and the broken rule of
// the draft) when the extension is present but invalid; `present == false` when the file does not use it.
struct GltfMicromapsRead {
  bool present = false;
  GltfMicromaps value;
};
Result<GltfMicromapsRead> readGltfMicromaps(const std::string& path);
// The same on a file's bytes (`binary`: GLB; external buffers resolved relative to `path`).
Result<GltfMicromapsRead> parseGltfMicromaps(const std::vector<uint8_t>& bytes, bool binary,
                                             const std::string& path);

// The micromaps of a .somm file or of a glTF with EXT_mesh_opacity_micromap (chosen by content: the GLB magic or JSON
// text starting with '{' → glTF, else .somm), for the commands that read micromaps (info, query, export, view, render,
// bench). For a glTF, `file` holds its SceneMicromaps as stored, the per-geometry GeometryInfo, no further encodings
// (one empty list per array) and sourcePath = the glTF itself (it is the scene, in the same geometry numbering).
struct MicromapSource {
  std::string container;     // "somm" or "EXT_mesh_opacity_micromap"
  uint32_t sommVersion = 0;  // the .somm container version as stored (0 for a glTF)
  SommFile file;
};
Result<MicromapSource> loadMicromapSource(const std::string& path);
Result<MicromapSource> parseMicromapSource(const std::vector<uint8_t>& bytes, const std::string& path);
// loadMicromapSource(path)->file: a drop-in for readSommFile that also reads glTF micromaps.
Result<SommFile> readMicromapFile(const std::string& path);

}  // namespace somm
