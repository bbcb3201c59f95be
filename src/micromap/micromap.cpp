// SPDX-License-Identifier: MIT
#include "somm/micromap.h"

#include <algorithm>

#include "somm/result.h"

namespace somm {

const char* errorCodeName(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::InvalidArgument:
      return "invalid argument";
    case ErrorCode::ParseError:
      return "parse error";
    case ErrorCode::IoError:
      return "I/O error";
    case ErrorCode::CorruptFile:
      return "corrupt file";
    case ErrorCode::UnsupportedFormat:
      return "unsupported format";
    case ErrorCode::LimitExceeded:
      return "limit exceeded";
    case ErrorCode::Cancelled:
      return "cancelled";
  }
  return "error";
}

namespace {
uint8_t fillByte(Format f, State s) {
  if (f == Format::TwoState) return (uint8_t(s) & 1u) ? 0xffu : 0x00u;
  const uint8_t v = uint8_t(s) & 3u;
  return uint8_t(v | (v << 2) | (v << 4) | (v << 6));
}
}  // namespace

Micromap::Micromap(uint32_t level, Format format, State fill)
    : level_(level), format_(format), bytes_(micromapDataBytes(level, format), 0) {
  std::fill(bytes_.begin(), bytes_.end(), fillByte(format, fill));
  // Keep unused bits of a partial byte zero, so that equal maps have equal bytes.
  const uint64_t bits = uint64_t(size()) * bitsPerState(format);
  if (bits % 8 != 0) bytes_.back() &= uint8_t((1u << (bits % 8)) - 1u);
}

std::optional<State> Micromap::uniformState() const noexcept {
  const State first = get(0);
  const uint64_t bits = uint64_t(size()) * bitsPerState(format_);
  if (bits < 8) {
    for (uint32_t i = 1; i < size(); ++i)
      if (get(i) != first) return std::nullopt;
    return first;
  }
  const uint8_t want = fillByte(format_, first);
  for (uint8_t b : bytes_)
    if (b != want) return std::nullopt;
  return first;
}

Micromap Micromap::toTwoStateMap() const {
  if (format_ == Format::TwoState) return *this;
  Micromap r(level_, Format::TwoState);
  for (uint32_t i = 0; i < size(); ++i) r.set(i, toTwoState(get(i)));
  return r;
}

}  // namespace somm
