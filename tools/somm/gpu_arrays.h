// SPDX-License-Identifier: MIT
// somm CLI — the .somm file's encoded arrays as the GPU commands upload them (gpu-check, gpu-bench). The only
// place that knows how the file stores its arrays: adapt here when the file layout changes.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "somm/encode.h"
#include "somm/somm_file.h"

namespace somm::cli {

// One encoding of all OMM arrays of the file (SommFile::micromaps.arrays; the default bake stores one
// scene-wide array), packed into one GPU buffer.
struct GpuEncoding {
  Encoding encoding = Encoding::Flat;
  std::vector<EncodedArray> arrays;  // the CPU reference, one per stored array
  std::vector<uint32_t> bases;       // byte address of arrays[k]'s serialized bytes in `buffer` (16-aligned)
  std::vector<uint8_t> buffer;       // the serialized arrays, each padded to a multiple of 16 bytes
};

// The encodings to run: `encoding` = "all" (flat and every encoding stored for every array) or one name (an
// error if some array does not store it). Errors (one line) name the file.
Result<std::vector<GpuEncoding>> loadGpuEncodings(const SommFile& file, const std::string& path,
                                                  const std::string& encoding);

}  // namespace somm::cli
