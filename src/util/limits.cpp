// SPDX-License-Identifier: MIT
// somm — limits against hostile input: names, parsing of --limit NAME=VALUE, messages (somm/limits.h).
#include "somm/limits.h"

#include <cstring>

namespace somm {

namespace {

struct Entry {
  const char* name;
  uint64_t Limits::*field;
};

const Entry kEntries[] = {
    {"file-bytes.scene", &Limits::sceneFileBytes},
    {"file-bytes.buffer", &Limits::bufferFileBytes},
    {"file-bytes.image", &Limits::imageFileBytes},
    {"file-bytes.mtl", &Limits::mtlFileBytes},
    {"file-bytes.somm", &Limits::sommFileBytes},
    {"image-pixels", &Limits::imagePixels},
    {"decoded-bytes", &Limits::decodedImageBytes},
    {"nodes", &Limits::nodes},
    {"instances", &Limits::instances},
    {"micro-triangles", &Limits::microTriangles},
};

}  // namespace

Status setLimit(Limits& limits, const std::string& a) {
  const size_t eq = a.find('=');
  if (eq == std::string::npos)
    return makeError(ErrorCode::InvalidArgument,
                     "--limit expects NAME=VALUE (names: " + std::string(limitNames()) + ")");
  const std::string name = a.substr(0, eq), value = a.substr(eq + 1);
  // Decimal digits, an optional K/M/G/T (powers of 1024) suffix, at most 2^63.
  uint64_t v = 0, mul = 1;
  size_t end = value.size();
  if (end > 0) {
    const char s = value[end - 1];
    const int shift = s == 'K' || s == 'k'   ? 10
                      : s == 'M' || s == 'm' ? 20
                      : s == 'G' || s == 'g' ? 30
                      : s == 'T' || s == 't' ? 40
                                             : 0;
    if (shift) mul = uint64_t(1) << shift, --end;
  }
  bool good = end > 0 && end <= 19;
  for (size_t i = 0; good && i < end; ++i) {
    if (value[i] < '0' || value[i] > '9')
      good = false;
    else
      v = v * 10 + uint64_t(value[i] - '0');
  }
  const uint64_t max = uint64_t(1) << 63;
  if (good && (v > max / mul || v * mul > max)) good = false;
  if (!good)
    return makeError(
        ErrorCode::InvalidArgument,
        "--limit " + name + ": '" + value + "' is not a count in 0..2^63 (K/M/G/T suffixes allowed)");
  v *= mul;
  if (name == "json-depth") {
    if (v > 100000) return makeError(ErrorCode::InvalidArgument, "--limit json-depth: at most 100000");
    limits.jsonDepth = uint32_t(v);
    return Ok{};
  }
  for (const Entry& e : kEntries)
    if (name == e.name) {
      limits.*e.field = v;
      return Ok{};
    }
  return makeError(ErrorCode::InvalidArgument,
                   "--limit: unknown limit '" + name + "' (names: " + std::string(limitNames()) + ")");
}

const char* limitNames() {
  return "file-bytes.scene, file-bytes.buffer, file-bytes.image, file-bytes.mtl, file-bytes.somm, "
         "image-pixels, "
         "decoded-bytes, nodes, instances, micro-triangles, json-depth";
}

std::string limitHint(const char* name, uint64_t value) {
  return std::string("the limit ") + name + " of " + std::to_string(value) + " (raise it with --limit " +
         name + "=N)";
}

}  // namespace somm
