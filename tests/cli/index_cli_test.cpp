// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "bird_reference.h"
#include "cli_util.h"
#include "somm/bird.h"

namespace somm {
namespace {

using testing::runSomm;

int countLines(const std::string& s) {
  return int(std::count(s.begin(), s.end(), '\n'));
}

TEST(CliIndex, HandComputedAndHexFloats) {
  const auto r = runSomm("index --level 2", "0.5 0.25\n0.25 0.5\n\n0.7   0.7\r\n0x1p-1 0x1p-2\ninf nan\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.out, "11\n12\n12\n11\n" + std::to_string(baryToIndex(INFINITY, NAN, 2)) + "\n");
  EXPECT_EQ(r.err, "");
}

TEST(CliIndex, MatchesReferenceOnManyRandomLines) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> d(-0.2f, 1.2f);
  std::ostringstream in, want;
  in.precision(9);
  for (int i = 0; i < 200000; ++i) in << d(rng) << ' ' << d(rng) << '\n';
  // The CLI must parse the text exactly like strtof: build the expected output the same way.
  std::istringstream lines(in.str());
  std::string a, b;
  while (lines >> a >> b)
    want << reference::BarycentricsToSpaceFillingCurveIndex(std::strtof(a.c_str(), nullptr),
                                                            std::strtof(b.c_str(), nullptr), 9)
         << '\n';
  const auto r = runSomm("index --level 9", in.str());
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.out, want.str());
}

TEST(CliIndex, MalformedLineIsReportedWithItsNumber) {
  const auto r = runSomm("index --level 3", "0.1 0.2\n0.3 zebra\n0.5 0.5\n");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("line 2"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("zebra"), std::string::npos) << r.err;
  EXPECT_EQ(countLines(r.err), 1);
  EXPECT_EQ(r.out, std::to_string(baryToIndex(0.1f, 0.2f, 3)) + "\n");  // output up to the bad line
  EXPECT_EQ(runSomm("index --level 3", "0.1\n").exitCode, 2);
  EXPECT_EQ(runSomm("index --level 3", "0.1 0.2 0.3\n").exitCode, 2);
  EXPECT_EQ(runSomm("index --level 3", "0.1f 0.2\n").exitCode, 2);
}

TEST(CliIndex, BadLevelIsAUsageError) {
  for (const char* args : {"index --level 13", "index --level -1", "index --level x", "index"}) {
    const auto r = runSomm(args, "0 0\n");
    EXPECT_EQ(r.exitCode, 2) << args;
    EXPECT_FALSE(r.err.empty()) << args;
    EXPECT_EQ(r.out, "") << args;
  }
}

TEST(CliMicrotri, PrintsGridVertices) {
  const auto r = runSomm("microtri --level 2", "0\n11\n15\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.out, "0 0 1 0 0 1\n3 1 2 1 2 2\n0 3 1 3 0 4\n");
}

TEST(CliMicrotri, OutOfRangeAndMalformed) {
  auto r = runSomm("microtri --level 2", "3\n16\n");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("line 2"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("out of range"), std::string::npos) << r.err;
  EXPECT_EQ(runSomm("microtri --level 2", "-1\n").exitCode, 2);
  EXPECT_EQ(runSomm("microtri --level 2", "1.5\n").exitCode, 2);
  EXPECT_EQ(runSomm("microtri --level 20", "1\n").exitCode, 2);
}

TEST(Cli, VersionAndHelp) {
  auto r = runSomm("--version");
  EXPECT_EQ(r.exitCode, 0);
  EXPECT_NE(r.out.find("somm "), std::string::npos);
  for (const char* sub : {"index", "microtri"}) {
    r = runSomm(std::string(sub) + " --help");
    EXPECT_EQ(r.exitCode, 0) << sub;
    EXPECT_NE(r.out.find("--level"), std::string::npos) << sub;
  }
  EXPECT_EQ(runSomm("no-such-command").exitCode, 2);
}

}  // namespace
}  // namespace somm

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace somm {
namespace {

// Millions of lines stream through in constant memory: 5M lines (40 MB of text) with a small resident set.
TEST(CliIndex, StreamsMillionsOfLines) {
  testing::TempDir dir;
  const std::string out = dir.file("out");
  const std::string cmd = "yes '0.3 0.3' | head -n 5000000 | '" + std::string(SOMM_CLI_PATH) +
                          "' index --level 5 > '" + out + "'";
  // Run the pipeline from a fresh child process so that RUSAGE_CHILDREN covers only this pipeline, not the children
  // of earlier tests in the same test process.
  const std::string rssFile = dir.file("rss");
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int rc = std::system(cmd.c_str());
    struct rusage ru {};
    getrusage(RUSAGE_CHILDREN, &ru);
    testing::writeFile(rssFile, std::to_string(ru.ru_maxrss));
    _exit(rc == 0 ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  const std::string text = testing::readFile(out);
  ASSERT_EQ(text.size(), 5000000u * (std::to_string(baryToIndex(0.3f, 0.3f, 5)).size() + 1));
  const long maxRssKiB = std::stol(testing::readFile(rssFile));
#if !defined(__SANITIZE_ADDRESS__)
  EXPECT_LT(maxRssKiB, 20 * 1024) << "max RSS in KiB";  // far below the 40 MB of input
#else
  EXPECT_GT(maxRssKiB, 0);
#endif
}

}  // namespace
}  // namespace somm
