// SPDX-License-Identifier: MIT
// Helpers for the bad-input suite: run the built CLI under `timeout`, measure its peak RSS, and check that a
// failure is clean (documented exit code, one-line message naming the file and the problem, no sanitizer
// report, no output left behind).
#pragma once

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <initializer_list>
#include <set>
#include <string>

#include "cli_util.h"

namespace somm::testing {

struct GuardedResult {
  int exitCode = -1;  // 124: timed out (a hang); >= 128: killed by a signal (a crash)
  long maxRssKiB = 0;
  std::string out, err;
};

inline std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs `somm <args>` (args already shell-quoted where needed) with stdin from `stdinData`, a wall-clock limit
// of `seconds`, and reports the peak RSS of the somm process (getrusage of the waited child tree).
inline GuardedResult runGuarded(const std::string& args, const std::string& stdinData = "",
                                int seconds = 60) {
  TempDir dir;
  const std::string in = dir.file("stdin"), out = dir.file("stdout"), err = dir.file("stderr");
  writeFile(in, stdinData);
  const std::string cmd = "exec timeout -k 5 " + std::to_string(seconds) + " " + quote(SOMM_CLI_PATH) + " " +
                          args + " < " + quote(in) + " > " + quote(out) + " 2> " + quote(err);
  GuardedResult r;
  const pid_t pid = fork();
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  struct rusage ru {};
  if (pid > 0 && wait4(pid, &status, 0, &ru) == pid) {
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    r.maxRssKiB = ru.ru_maxrss;
  }
  r.out = readFile(out);
  r.err = readFile(err);
  return r;
}

// Directory listing (names only), to check that a failed command leaves nothing behind.
inline std::set<std::string> listDir(const std::string& dir) {
  std::set<std::string> names;
  std::error_code ec;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir, ec))
    names.insert(std::filesystem::relative(e.path(), dir).string());
  return names;
}

// A clean rejection: the expected exit code, exactly one line on stderr starting with "somm", containing
// every needle, no sanitizer report, and nothing on stdout unless allowed.
inline void expectRejected(const GuardedResult& r, int exitCode, std::initializer_list<std::string> needles,
                           const std::string& what, bool stdoutMayHaveOutput = false) {
  SCOPED_TRACE(what);
  EXPECT_NE(r.exitCode, 124) << "timed out (hang)";
  EXPECT_LT(r.exitCode, 128) << "killed by a signal (crash)\n" << r.err;
  EXPECT_EQ(r.exitCode, exitCode) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(r.err.rfind("somm", 0), 0u) << r.err;
  for (const std::string& n : needles)
    EXPECT_NE(r.err.find(n), std::string::npos) << "missing '" << n << "' in: " << r.err;
  for (size_t i = 0; i + 1 < r.err.size(); ++i)
    if (static_cast<unsigned char>(r.err[i]) < 0x20) {
      ADD_FAILURE() << "control character in the message: " << r.err;
      break;
    }
  EXPECT_EQ(r.err.find("Sanitizer"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("runtime error"), std::string::npos) << r.err;
  if (!stdoutMayHaveOutput) {
    EXPECT_EQ(r.out, "");
  }
}

// Whether this build's CLI has a subcommand (the suite grows as the stages land).
inline bool hasCommand(const std::string& name) {
  const std::string help = runSomm("--help").out;  // the subcommand list: "  name   description"
  return help.find("\n  " + name + " ") != std::string::npos;
}

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

}  // namespace somm::testing
