// SPDX-License-Identifier: MIT
// somm — error handling. The library never prints and never exits: it returns Result<T>.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace somm {

enum class ErrorCode {
  InvalidArgument = 1,  // an option or parameter out of range
  ParseError,           // malformed text input
  IoError,              // a file could not be opened, read or written
  CorruptFile,          // a file is truncated, has a bad checksum or inconsistent contents
  UnsupportedFormat,    // a foreign file, unknown version or a feature we do not handle
  LimitExceeded,        // declared sizes beyond what we are willing to allocate
  Cancelled,            // the caller's progress callback asked to stop
};

const char* errorCodeName(ErrorCode code) noexcept;

struct Error {
  ErrorCode code = ErrorCode::InvalidArgument;
  std::string message;  // one line, names the file/argument and the problem
};

// A value or an Error (a small std::expected for C++20).
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Result(Error error) : v_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  bool ok() const noexcept { return v_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }

  T& value() & {
    assert(ok());
    return std::get<0>(v_);
  }
  const T& value() const& {
    assert(ok());
    return std::get<0>(v_);
  }
  T&& value() && {
    assert(ok());
    return std::get<0>(std::move(v_));
  }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  const Error& error() const {
    assert(!ok());
    return std::get<1>(v_);
  }

 private:
  std::variant<T, Error> v_;
};

// Result for operations that produce nothing.
struct Ok {};
using Status = Result<Ok>;

inline Error makeError(ErrorCode code, std::string message) {
  return Error{code, std::move(message)};
}

}  // namespace somm
