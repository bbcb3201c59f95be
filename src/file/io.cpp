// SPDX-License-Identifier: MIT
// Whole-file reading and atomic writing of .somm files; the mechanisms live in somm/io.h (src/util/io.cpp).
#include "somm/io.h"

#include <string>

#include "somm/limits.h"
#include "somm/somm_file.h"

namespace somm {

Status writeFileAtomically(const std::string& path, Span<const uint8_t> bytes) {
  return writeFileAtomically(path, bytes.data(), bytes.size());
}

Result<std::vector<uint8_t>> readWholeFile(const std::string& path) {
  return readRegularFile(path, defaultLimits().sommFileBytes, "file", "file-bytes.somm");
}

// writeSommFile is in somm_file.cpp: it writes the arrays' bytes from the SommFile itself, without a copy.

Result<SommFile> readSommFile(const std::string& path) {
  auto bytes = readWholeFile(path);
  if (!bytes) return bytes.error();
  return parseSomm(*bytes, path);
}

Result<SceneMicromaps> readSceneMicromaps(const std::string& path) {
  auto file = readSommFile(path);
  if (!file) return file.error();
  return std::move(file->micromaps);
}

}  // namespace somm
