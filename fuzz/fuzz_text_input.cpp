// SPDX-License-Identifier: MIT
// Fuzz target: the text input of `somm index` / `somm microtri` (and of every command reading 'u v' lines):
// LineReader over a stream, nextToken, parseFloat, parseUInt. Checks: lines reassemble the input, tokens
// never contain whitespace, parseFloat equals strtof on the same text, parseUInt equals a reference decimal
// parser, and the index computed from the parsed floats is in range at every level.
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "somm/bird.h"
#include "text_input.h"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz_text_input: %s\n", what);
  std::abort();
}

bool isSpace(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

bool refParseUInt(std::string_view s, uint64_t& out) {
  if (s.empty()) return false;
  uint64_t v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    const uint64_t d = uint64_t(c - '0');
    if (v > (UINT64_MAX - d) / 10) return false;
    v = v * 10 + d;
  }
  out = v;
  return true;
}

void checkToken(std::string_view tok) {
  for (char c : tok)
    if (isSpace(c)) fail("token contains whitespace");
  float f = 0;
  const bool ok = somm::cli::parseFloat(tok, f);
  if (tok.size() <= 4096 && !tok.empty() && tok.find('\0') == std::string_view::npos) {
    const std::string s(tok);
    char* end = nullptr;
    const float r = std::strtof(s.c_str(), &end);
    const bool rok = end == s.c_str() + s.size();
    if (ok != rok) fail("parseFloat acceptance differs from strtof");
    if (ok && std::memcmp(&f, &r, 4) != 0 && !(f != f && r != r))
      fail("parseFloat value differs from strtof");
  }
  if (ok) {
    for (uint32_t level = 0; level <= somm::kMaxLevel; level += 4)
      if (somm::baryToIndex(f, f, level) >= somm::microTriangleCount(level)) fail("index out of range");
  }
  uint64_t a = 0, b = 0;
  const bool ua = somm::cli::parseUInt(tok, a), ub = refParseUInt(tok, b);
  if (ua != ub || (ua && a != b)) fail("parseUInt differs from the reference decimal parser");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::FILE* f = fmemopen(const_cast<uint8_t*>(data), size, "rb");
  if (size == 0) f = std::tmpfile();  // fmemopen rejects size 0 on some libcs
  if (!f) return 0;
  somm::cli::LineReader reader(f);
  std::string joined;
  std::string_view line;
  uint64_t lines = 0;
  while (reader.next(line)) {
    ++lines;
    if (reader.lineNumber() != lines) fail("line number mismatch");
    if (line.find('\n') != std::string_view::npos) fail("line contains a newline");
    joined.append(line);
    joined.push_back('\n');
    std::string_view rest = line;
    for (int k = 0; k < 64; ++k) {
      const std::string_view tok = somm::cli::nextToken(rest);
      if (tok.empty()) {
        for (char c : rest)
          if (!isSpace(c)) fail("nextToken stopped before the end of the line");
        break;
      }
      checkToken(tok);
    }
  }
  std::fclose(f);
  // Reassembly: input with every "\r\n" before a newline (and a final "\r") normalised must equal the joined
  // lines.
  std::string want;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  size_t pos = 0;
  while (pos < in.size()) {
    size_t nl = in.find('\n', pos);
    std::string_view l = in.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    want.append(l);
    want.push_back('\n');
    pos = nl == std::string_view::npos ? in.size() : nl + 1;
  }
  if (want != joined) fail("lines do not reassemble the input");
  return 0;
}
