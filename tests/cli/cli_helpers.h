// Helpers for tests that run the built `somm` binary (SOMM_CLI_PATH).
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

namespace somm::testing {

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    path = std::filesystem::temp_directory_path() /
           ("somm_cli_test_" + std::to_string(::getpid()) + "_" + std::to_string(std::random_device{}()));
    std::filesystem::create_directories(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
  size_t entries() const {
    size_t n = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(path)) ++n;
    return n;
  }
};

inline std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

inline std::string shellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

struct RunResult {
  int exitCode = -1;
  std::string out, err;
};

// Runs `somm ARGS` (ARGS already shell-quoted as needed) with stdin from `stdinPath` (or /dev/null).
inline RunResult runSomm(const TempDir& dir, const std::string& args, const std::string& stdinPath = "") {
  const std::string outPath = dir / "stdout.txt", errPath = dir / "stderr.txt";
  const std::string cmd = shellQuote(SOMM_CLI_PATH) + " " + args + " < " +
                          shellQuote(stdinPath.empty() ? "/dev/null" : stdinPath) + " > " +
                          shellQuote(outPath) + " 2> " + shellQuote(errPath);
  const int status = std::system(cmd.c_str());
  RunResult r;
  r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = readText(outPath);
  r.err = readText(errPath);
  std::filesystem::remove(outPath);
  std::filesystem::remove(errPath);
  return r;
}

}  // namespace somm::testing
