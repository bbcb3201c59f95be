// SPDX-License-Identifier: MIT
// somm — limits against hostile input (docs/hardening.md): one struct with documented defaults, raised from the
// command line with `--limit NAME=VALUE`. Every check that refuses an input names the limit and that option.
// C++17.
#pragma once

#include <cstdint>
#include <string>

#include "somm/result.h"

namespace somm {

struct Limits {
  // Bytes of one file read, per kind. Only regular files are read (FIFOs, devices, directories refused).
  uint64_t sceneFileBytes = uint64_t(1) << 30;    // file-bytes.scene: a .gltf / .glb / .obj
  uint64_t bufferFileBytes = uint64_t(2) << 30;   // file-bytes.buffer: an external glTF buffer
  uint64_t imageFileBytes = uint64_t(256) << 20;  // file-bytes.image: a texture file
  uint64_t mtlFileBytes = uint64_t(64) << 20;     // file-bytes.mtl: an OBJ material library
  uint64_t sommFileBytes = uint64_t(16) << 30;    // file-bytes.somm: a .somm file
  // Scene size, checked before the work starts.
  uint64_t imagePixels = uint64_t(1) << 25;  // image-pixels: texels of one image (32 Mi, e.g. 8192 x 4096)
  uint64_t decodedImageBytes = uint64_t(2)
                               << 30;      // decoded-bytes: decoded texels over a scene (8 bytes/texel/ch.)
  uint64_t nodes = uint64_t(1) << 20;      // nodes: glTF node visits (a DAG is expanded to a tree)
  uint64_t instances = uint64_t(1) << 18;  // instances: instances of a scene (262,144)
  uint64_t microTriangles = uint64_t(1) << 36;  // micro-triangles: Σ 4^level over the triangles of a bake
  uint32_t jsonDepth = 256;                     // json-depth: nesting of glTF JSON arrays and objects
};

// The limits every loader uses unless told otherwise.
inline Limits defaultLimits() {
  return Limits{};
}

// Sets one limit from "name=value" (value: a decimal integer ≤ 2^63, optionally with a K/M/G/T suffix of
// powers of 1024). InvalidArgument for an unknown name or a bad value.
Status setLimit(Limits& limits, const std::string& assignment);
// The names accepted by setLimit, comma-separated (for --help).
const char* limitNames();
// "the limit NAME of VALUE (raise it with --limit NAME=N)", for error messages.
std::string limitHint(const char* name, uint64_t value);

}  // namespace somm
