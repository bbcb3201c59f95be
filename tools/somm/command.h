// somm CLI — subcommand registry and shared helpers. Each cmd_*.cpp registers one subcommand:
//   static const somm::cli::Registration reg("name", &setupFunction);
// setupFunction adds a CLI11 subcommand to the root app and sets its callback, which returns the exit code via
// somm::cli::setExitCode().
#pragma once

#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>
#include <string_view>

namespace somm::cli {

// Documented exit codes.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;   // the operation failed (I/O, corrupt or unsupported input file)
inline constexpr int kExitUsage = 2;     // bad command line or malformed text input

using SetupFn = void (*)(CLI::App& root);

struct Registration {
  Registration(const char* name, SetupFn setup);
};

void setExitCode(int code);

// Prints "somm <command>: <message>" on stderr, one line.
void printError(std::string_view command, std::string_view message);

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

// Parses a whole token as a float exactly as strtof does (decimal, hex floats, inf, nan). False if malformed or if
// anything is left over.
bool parseFloat(std::string_view token, float& out);
// Parses a whole token as an unsigned decimal integer that fits in uint64.
bool parseUInt(std::string_view token, uint64_t& out);

// Buffered stdout writer.
class Output {
 public:
  Output() { buf_.reserve(1 << 16); }
  ~Output() { flush(); }
  void put(std::string_view s) {
    buf_.append(s);
    if (buf_.size() >= (1 << 16)) flush();
  }
  void putUInt(uint64_t v);
  void putChar(char c) { buf_.push_back(c); if (buf_.size() >= (1 << 16)) flush(); }
  void flush();

 private:
  std::string buf_;
};

}  // namespace somm::cli
