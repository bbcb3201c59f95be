// SPDX-License-Identifier: MIT
// somm — a glTF 2.0 document as JSON (nlohmann) plus its buffers, loaded lazily. Internal to somm_gltf.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "somm/result.h"

namespace somm::gltfdoc {

using nlohmann::json;

struct Document {    // NOLINT(bugprone-exception-escape): nlohmann::json's defaulted members
  std::string path;  // for messages and relative URIs
  bool binary = false;
  json root;
  std::vector<uint8_t> bin;  // the GLB binary chunk (empty for .gltf)
  bool hasBin = false;
  uint64_t fileBytes = 0;  // size of the parsed file

  // An upper bound of buffer i's real size without loading it: ≤ the file for embedded buffers, ≤ the referenced
  // file for external ones (0 when that does not exist), never more than its byteLength.
  uint64_t bufferBound(size_t i) const;

  // Buffer i's bytes (exactly byteLength of them). Loaded on first use: the GLB chunk, a data URI or a file relative
  // to `path`. Errors name the buffer.
  Result<const std::vector<uint8_t>*> buffer(size_t i);

  Error fail(ErrorCode c, const std::string& what) const { return makeError(c, path + ": " + what); }

 private:
  std::map<size_t, std::vector<uint8_t>> cache_;
};

// Parses a .gltf (JSON text) or .glb (binary) file's bytes. The JSON must be an object.
Result<Document> parseDocument(const std::vector<uint8_t>& bytes, bool binary, const std::string& path);
Result<Document> readDocument(const std::string& path);  // binary iff the GLB magic

// URI helpers (RFC 3986 percent-encoding).
bool isDataUri(const std::string& uri);
bool isRelativeUri(const std::string& uri);  // no scheme, not absolute
std::string percentDecode(const std::string& s);
std::string percentEncodePath(const std::string& s);

// Integer member access: true and `out` set when `o[key]` is an integer (negative allowed).
bool getInt(const json& o, const char* key, int64_t& out);

}  // namespace somm::gltfdoc
