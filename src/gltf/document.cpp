// SPDX-License-Identifier: MIT
// somm — glTF document parsing: GLB container, JSON, buffers (GLB chunk, base64 data URIs, external files).
#include "document.h"

#include <algorithm>
#include <cstring>
#include <filesystem>

#include "somm/somm_file.h"

namespace somm::gltfdoc {

namespace {

uint32_t le32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

int base64Value(unsigned char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+' || c == '-') return 62;
  if (c == '/' || c == '_') return 63;
  return -1;
}

bool base64Decode(const std::string& s, size_t from, std::vector<uint8_t>& out) {
  out.clear();
  out.reserve((s.size() - from) / 4 * 3 + 3);
  uint32_t acc = 0;
  int bits = 0;
  for (size_t i = from; i < s.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c == '=') break;
    const int v = base64Value(c);
    if (v < 0) return false;
    acc = (acc << 6) | uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(uint8_t(acc >> bits));
    }
  }
  return true;
}

}  // namespace

bool getInt(const json& o, const char* key, int64_t& out) {
  if (!o.is_object()) return false;
  auto it = o.find(key);
  if (it == o.end()) return false;
  if (it->is_number_unsigned()) {
    const uint64_t u = it->get<uint64_t>();
    if (u > uint64_t(INT64_MAX)) return false;
    out = int64_t(u);
    return true;
  }
  if (it->is_number_integer()) {
    out = it->get<int64_t>();
    return true;
  }
  if (it->is_number_float()) {  // 3.0 is an integer in JSON Schema terms
    const double d = it->get<double>();
    // The range first: converting a double outside int64_t's range (or NaN) is undefined (found by fuzz_gltf:
    // 8.9e25).
    if (d > -9.0e18 && d < 9.0e18 && d == double(int64_t(d))) {
      out = int64_t(d);
      return true;
    }
  }
  return false;
}

bool isDataUri(const std::string& uri) {
  return uri.rfind("data:", 0) == 0;
}

bool isRelativeUri(const std::string& uri) {
  if (uri.empty() || uri[0] == '/' || uri[0] == '\\') return false;
  // A scheme: ALPHA *( ALPHA / DIGIT / "+" / "-" / "." ) ":" before any '/'.
  const size_t colon = uri.find(':'), slash = uri.find('/');
  if (colon != std::string::npos && (slash == std::string::npos || colon < slash)) return false;
  return true;
}

std::string percentDecode(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  auto hex = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && hex(s[i + 1]) >= 0 && hex(s[i + 2]) >= 0) {
      out.push_back(char(hex(s[i + 1]) * 16 + hex(s[i + 2])));
      i += 2;
    } else {
      out.push_back(s[i]);
    }
  }
  return out;
}

std::string percentEncodePath(const std::string& s) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  for (char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c <= 0x20 || c == 0x7F || c == '%' || c == '#' || c == '?' || c == '\\') {
      out.push_back('%');
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 15]);
    } else {
      out.push_back(ch);
    }
  }
  return out;
}

Result<Document> parseDocument(const std::vector<uint8_t>& bytes, bool binary, const std::string& path) {
  Document d;
  d.path = path;
  d.binary = binary;
  d.fileBytes = bytes.size();
  const char* text = reinterpret_cast<const char*>(bytes.data());
  size_t textSize = bytes.size();
  if (binary) {
    if (bytes.size() < 20 || le32(bytes.data()) != 0x46546C67u)
      return d.fail(ErrorCode::CorruptFile, "not a GLB file (bad magic)");
    if (le32(bytes.data() + 4) != 2)
      return d.fail(ErrorCode::UnsupportedFormat,
                    "GLB version " + std::to_string(le32(bytes.data() + 4)) + " (only 2 is supported)");
    const uint64_t total = le32(bytes.data() + 8);
    if (total > bytes.size()) return d.fail(ErrorCode::CorruptFile, "GLB length exceeds the file size");
    // (A declared length below the 20-byte header made `total - 20` wrap: the JSON chunk length was then never
    // checked and the parser read past the file.)
    if (total < 20)
      return d.fail(ErrorCode::CorruptFile,
                    "GLB length " + std::to_string(total) + " is less than its headers (20 bytes)");
    const uint64_t jsonLen = le32(bytes.data() + 12);
    if (le32(bytes.data() + 16) != 0x4E4F534Au)
      return d.fail(ErrorCode::CorruptFile, "GLB: the first chunk is not JSON");
    if (jsonLen > total - 20)
      return d.fail(ErrorCode::CorruptFile, "GLB: the JSON chunk extends past the end");
    text = reinterpret_cast<const char*>(bytes.data() + 20);
    textSize = size_t(jsonLen);
    uint64_t at = 20 + ((jsonLen + 3) & ~uint64_t(3));
    if (at + 8 <= total) {
      const uint64_t binLen = le32(bytes.data() + at);
      if (le32(bytes.data() + at + 4) == 0x004E4942u) {
        if (binLen > total - at - 8)
          return d.fail(ErrorCode::CorruptFile, "GLB: the BIN chunk extends past the end");
        d.bin.assign(bytes.begin() + ptrdiff_t(at + 8), bytes.begin() + ptrdiff_t(at + 8 + binLen));
        d.hasBin = true;
      }
    }
  }
  d.root = json::parse(text, text + textSize, nullptr, false);
  if (d.root.is_discarded()) return d.fail(ErrorCode::CorruptFile, "invalid JSON");
  if (!d.root.is_object()) return d.fail(ErrorCode::CorruptFile, "the glTF JSON is not an object");
  return d;
}

Result<Document> readDocument(const std::string& path) {
  auto bytes = readWholeFile(path);
  if (!bytes) return bytes.error();
  const bool binary = bytes->size() >= 4 && le32(bytes->data()) == 0x46546C67u;
  return parseDocument(*bytes, binary, path);
}

uint64_t Document::bufferBound(size_t i) const {
  const json* buffers = root.contains("buffers") ? &root["buffers"] : nullptr;
  if (!buffers || !buffers->is_array() || i >= buffers->size()) return 0;
  const json& b = (*buffers)[i];
  int64_t len = 0;
  if (!getInt(b, "byteLength", len) || len < 1) return 0;
  uint64_t bound = fileBytes;
  if (b.contains("uri") && b["uri"].is_string()) {
    const std::string uri = b["uri"].get<std::string>();
    if (!isDataUri(uri)) {
      std::error_code ec;
      const auto n = std::filesystem::file_size(
          std::filesystem::path(path).parent_path() / std::filesystem::path(percentDecode(uri)), ec);
      bound = ec ? 0 : uint64_t(n);
    }
  }
  return std::min<uint64_t>(bound, uint64_t(len));
}

Result<const std::vector<uint8_t>*> Document::buffer(size_t i) {
  auto it = cache_.find(i);
  if (it != cache_.end()) return &it->second;
  const std::string what = "buffers[" + std::to_string(i) + "]";
  const json* buffers = root.contains("buffers") ? &root["buffers"] : nullptr;
  if (!buffers || !buffers->is_array() || i >= buffers->size())
    return fail(ErrorCode::CorruptFile, what + " does not exist");
  const json& b = (*buffers)[i];
  int64_t len = 0;
  if (!b.is_object() || !getInt(b, "byteLength", len) || len < 1)
    return fail(ErrorCode::CorruptFile, what + ": byteLength MUST be an integer >= 1 (glTF 2.0)");
  std::vector<uint8_t> data;
  if (!b.contains("uri")) {
    if (!binary || i != 0 || !hasBin)
      return fail(ErrorCode::CorruptFile, what + " has no uri and is not the GLB binary chunk");
    data = bin;
  } else {
    if (!b["uri"].is_string()) return fail(ErrorCode::CorruptFile, what + ": uri is not a string");
    const std::string uri = b["uri"].get<std::string>();
    if (isDataUri(uri)) {
      const size_t comma = uri.find(',');
      if (comma == std::string::npos || uri.rfind(";base64", comma) == std::string::npos)
        return fail(ErrorCode::UnsupportedFormat, what + ": only base64 data URIs are supported");
      if (!base64Decode(uri, comma + 1, data))
        return fail(ErrorCode::CorruptFile, what + ": invalid base64 in its data URI");
    } else if (isRelativeUri(uri)) {
      const std::filesystem::path file =
          std::filesystem::path(path).parent_path() / std::filesystem::path(percentDecode(uri));
      auto bytes = readWholeFile(file.string());
      if (!bytes) return fail(bytes.error().code, what + ": " + bytes.error().message);
      data = std::move(*bytes);
    } else {
      return fail(ErrorCode::UnsupportedFormat, what + ": only relative and data URIs are supported");
    }
  }
  if (data.size() < uint64_t(len))
    return fail(ErrorCode::CorruptFile, what + ": holds " + std::to_string(data.size()) +
                                            " bytes, fewer than its byteLength " + std::to_string(len));
  data.resize(size_t(len));
  return &(cache_[i] = std::move(data));
}

}  // namespace somm::gltfdoc
