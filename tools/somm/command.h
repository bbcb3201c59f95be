// SPDX-License-Identifier: MIT
// somm CLI — subcommand registry and shared helpers. Each cmd_*.cpp registers one subcommand:
//   static const somm::cli::Registration reg("name", &setupFunction);
// setupFunction adds a CLI11 subcommand to the root app and sets its callback, which returns the exit code via
// somm::cli::setExitCode().
#pragma once

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "text_input.h"

namespace somm::cli {

// Documented exit codes.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  // the operation failed (I/O, corrupt or unsupported input file)
inline constexpr int kExitUsage = 2;    // bad command line or malformed text input

// CLI::Range lets NaN through (every comparison with NaN is false): add `& NotNan` to float range checks.
inline const CLI::Validator NotNan(
    [](std::string& s) {
      const char* b = s.c_str();
      char* e = nullptr;
      const double v = std::strtod(b, &e);
      return v != v ? std::string("Value " + s + " is not a number") : std::string();
    },
    "", "NotNan");

using SetupFn = void (*)(CLI::App& root);

// The required `--level,-l` option of the bird-curve commands (index, microtri): 0..12.
inline void addRequiredLevel(CLI::App* cmd, uint32_t& level) {
  cmd->add_option("--level,-l", level, "subdivision level 0..12")->required()->check(CLI::Range(0u, 12u));
}

struct Registration {
  Registration(const char* name, SetupFn setup);
};

void setExitCode(int code);

// Prints "somm <command>: <message>" on stderr, one line.
void printError(std::string_view command, std::string_view message);

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
  void putChar(char c) {
    buf_.push_back(c);
    if (buf_.size() >= (1 << 16)) flush();
  }
  void flush();

 private:
  std::string buf_;
};

}  // namespace somm::cli
