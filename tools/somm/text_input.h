// SPDX-License-Identifier: MIT
// somm CLI — text-input parsing shared by the CLI and the fuzz targets (fuzz/). No CLI11, no stdout: pure
// parsing.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace somm::cli {

// Reads a text stream line by line in large chunks (streams arbitrarily long inputs in constant memory).
class LineReader {
 public:
  explicit LineReader(std::FILE* f) : f_(f) {}
  // Next line without its terminator ("\n" or "\r\n"); false at end of input.
  bool next(std::string_view& line);
  uint64_t lineNumber() const { return lineNo_; }

 private:
  std::FILE* f_;
  std::string buf_;
  size_t pos_ = 0;
  bool eof_ = false;
  uint64_t lineNo_ = 0;
};

// Splits off the next whitespace-separated token; empty when none is left.
std::string_view nextToken(std::string_view& rest);

// Parses a whole token as a float exactly as strtof does (decimal, hex floats, inf, nan). False if malformed
// or if anything is left over.
bool parseFloat(std::string_view token, float& out);
// A stdin line of the form "u v" (two floats, nothing else; see parseFloat). Blank: true for an empty or
// whitespace-only line (u, v untouched; the caller skips it). Returns false for a malformed line.
bool parseUVLine(std::string_view line, float& u, float& v, bool& blank);
// The start of an input line for an error message: at most `max` bytes, non-printable bytes as \xNN (so a
// message stays one printable line whatever the input holds), "..." when cut.
std::string excerpt(std::string_view line, size_t max = 80);

// Parses a whole token as an unsigned decimal integer that fits in uint64.
bool parseUInt(std::string_view token, uint64_t& out);

}  // namespace somm::cli
