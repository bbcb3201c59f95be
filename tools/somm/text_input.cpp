// SPDX-License-Identifier: MIT
#include "text_input.h"

#include <cerrno>
#include <charconv>
#include <cstdlib>
#include <cstring>

namespace somm::cli {

bool LineReader::next(std::string_view& line) {
  for (;;) {
    const size_t nl = buf_.find('\n', pos_);
    if (nl != std::string::npos) {
      line = std::string_view(buf_).substr(pos_, nl - pos_);
      pos_ = nl + 1;
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      ++lineNo_;
      return true;
    }
    if (eof_) {
      if (pos_ >= buf_.size()) return false;
      line = std::string_view(buf_).substr(pos_);
      pos_ = buf_.size();
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      ++lineNo_;
      return true;
    }
    buf_.erase(0, pos_);
    pos_ = 0;
    const size_t old = buf_.size();
    buf_.resize(old + (1 << 16));
    const size_t got = std::fread(buf_.data() + old, 1, 1 << 16, f_);
    buf_.resize(old + got);
    if (got == 0) eof_ = true;
  }
}

std::string_view nextToken(std::string_view& rest) {
  size_t i = 0;
  while (i < rest.size() &&
         (rest[i] == ' ' || rest[i] == '\t' || rest[i] == '\r' || rest[i] == '\v' || rest[i] == '\f'))
    ++i;
  size_t j = i;
  while (j < rest.size() &&
         !(rest[j] == ' ' || rest[j] == '\t' || rest[j] == '\r' || rest[j] == '\v' || rest[j] == '\f'))
    ++j;
  const std::string_view tok = rest.substr(i, j - i);
  rest.remove_prefix(j);
  return tok;
}

bool parseUVLine(std::string_view line, float& u, float& v, bool& blank) {
  std::string_view rest = line;
  const std::string_view a = nextToken(rest);
  blank = a.empty();
  if (blank) return true;
  const std::string_view b = nextToken(rest);
  return !b.empty() && nextToken(rest).empty() && parseFloat(a, u) && parseFloat(b, v);
}

bool parseFloat(std::string_view token, float& out) {
  if (token.empty() || token.size() > 4096) return false;
  char local[128];
  std::string heap;
  const char* s;
  if (token.size() < sizeof local) {
    std::memcpy(local, token.data(), token.size());
    local[token.size()] = '\0';
    s = local;
  } else {
    heap.assign(token);
    s = heap.c_str();
  }
  char* end = nullptr;
  errno = 0;
  out = std::strtof(
      s, &end);  // ERANGE (overflow to inf, underflow to 0/denormal) is accepted: that is strtof's value
  return end == s + token.size();
}

bool parseUInt(std::string_view token, uint64_t& out) {
  if (token.empty()) return false;
  const auto r = std::from_chars(token.data(), token.data() + token.size(), out);
  return r.ec == std::errc() && r.ptr == token.data() + token.size();
}

std::string excerpt(std::string_view line, size_t max) {
  std::string out;
  static const char* const kHex = "0123456789abcdef";
  for (size_t i = 0; i < line.size() && i < max; ++i) {
    const unsigned char c = static_cast<unsigned char>(line[i]);
    if (c >= 0x20 && c < 0x7f) {
      out.push_back(char(c));
    } else {
      out += "\\x";
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 15]);
    }
  }
  if (line.size() > max) out += "...";
  return out;
}

}  // namespace somm::cli
