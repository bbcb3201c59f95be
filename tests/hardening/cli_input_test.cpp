// SPDX-License-Identifier: MIT
// Bad-input suite, part 1: command-line options out of range and hostile text on stdin (index, microtri,
// query).
#include <gtest/gtest.h>

#include <string>

#include "hardening_util.h"

namespace somm {
namespace {

using testing::expectRejected;
using testing::runGuarded;

TEST(BadInputCli, OptionsOutOfRangeAreUsageErrors) {
  const struct {
    const char* args;
    const char* needle;
  } cases[] = {
      {"index --level 13", "--level"},
      {"index --level 4294967296", "--level"},
      {"index --level -1", "--level"},
      {"index --level 1e3", "--level"},
      {"index --level ''", "--level"},
      {"index", "--level"},
      {"index --level 3 --frobnicate", "frobnicate"},
      {"microtri --level 13", "--level"},
      {"microtri --level 99999999999999999999", "--level"},
      {"no-such-command", "no-such-command"},
  };
  for (const auto& c : cases) {
    const auto r = runGuarded(c.args, "0 0\n");
    // CLI11 adds a "Run with --help" hint on a second line; everything else is one line.
    SCOPED_TRACE(c.args);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_EQ(r.err.rfind("somm", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.needle), std::string::npos) << r.err;
    EXPECT_EQ(r.out, "");
  }
}

TEST(BadInputCli, HostileTextOnStdin) {
  const std::string longToken(5000, '1');  // longer than parseFloat accepts
  const struct {
    const char* cmd;
    std::string input;
    const char* needle;
  } cases[] = {
      {"index --level 4", std::string("0.5 0.5\n0.1\0 0.2\n", 18), "line 2"},
      {"index --level 4", "0.5 0.5\n" + longToken + " 0.5\n", "line 2"},
      {"index --level 4", "\xff\xfe\x00\x01 \x80\n", "line 1"},
      {"index --level 4", "0.5 0.5 0.5\n", "line 1"},
      {"index --level 4", "0,5 0,5\n", "line 1"},
      {"index --level 4", "0x 0.5\n", "line 1"},
      {"microtri --level 3", "64\n", "out of range"},
      {"microtri --level 3", "18446744073709551616\n", "line 1"},
      {"microtri --level 3", "-0\n", "line 1"},
      {"microtri --level 3", "+1\n", "line 1"},
  };
  for (const auto& c : cases) {
    const auto r = runGuarded(c.cmd, c.input);
    expectRejected(r, 2, {c.needle}, std::string(c.cmd) + " <<< " + c.input.substr(0, 20), true);
  }
}

// A single line of 16 MB without a newline: buffered once, never more than a small multiple of its size.
TEST(BadInputCli, HugeLineIsBoundedInMemory) {
  std::string line(16 << 20, '7');
  const auto r = runGuarded("index --level 4", line);
  expectRejected(r, 2, {"line 1"}, "16 MB line");
  const long limitKiB = (testing::kSanitized ? 8 : 4) * (16 << 10) + 64 * 1024;
  EXPECT_LT(r.maxRssKiB, limitKiB) << "peak RSS (KiB) for a 16 MB input";
}

}  // namespace
}  // namespace somm
