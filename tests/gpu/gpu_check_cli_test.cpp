// SPDX-License-Identifier: MIT
// `somm gpu-check` on the bundled scenes at levels 4, 8 and 12 with every encoding: 0 mismatches required, on
// both the GLSL and the HLSL kernel. Plus its errors: no Vulkan device, a missing encoding, a bad file.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "cli_util.h"
#include "gpu_test_util.h"
#include "somm/encode.h"

namespace {

using somm::testing::runSomm;
using somm::testing::shellQuote;
using somm::testing::TempDir;

// Is there a Vulkan device for the CLI? (The sanitizer build may have none: then the tests skip.)
bool cliDeviceOrSkipReason(std::string& reason) {
  auto d = somm::gpu::Device::open();
  if (d) return true;
  reason = d.error().message;
  return false;
}

#define SOMM_REQUIRE_DEVICE()                                                             \
  do {                                                                                    \
    std::string reason;                                                                   \
    if (!cliDeviceOrSkipReason(reason)) {                                                 \
      if (somm::testing::sanitizerBuild()) GTEST_SKIP() << "sanitizer build: " << reason; \
      FAIL() << reason;                                                                   \
    }                                                                                     \
  } while (0)

std::vector<std::string> lines(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

struct Case {
  const char* scene;  // under data/
  uint32_t level;
  uint32_t format;
  uint32_t samples;
};

class GpuCheckScene : public ::testing::TestWithParam<Case> {};

TEST_P(GpuCheckScene, ZeroMismatchesForEveryEncoding) {
  SOMM_REQUIRE_DEVICE();
  const Case& c = GetParam();
  TempDir dir;
  const std::string somm = dir / "scene.somm";
  const auto bake = runSomm("bake " + shellQuote(std::string(SOMM_DATA_DIR) + "/" + c.scene) + " -l " +
                            std::to_string(c.level) + " --format " + std::to_string(c.format) +
                            " --encoding all -o " + shellQuote(somm));
  ASSERT_EQ(bake.exitCode, 0) << bake.err;
  const auto r = runSomm("gpu-check " + shellQuote(somm) + " --samples " + std::to_string(c.samples));
  EXPECT_EQ(r.exitCode, 0) << r.out << r.err;
  const std::vector<std::string> out = lines(r.out);
  ASSERT_FALSE(out.empty());
  EXPECT_EQ(out[0].rfind("device: ", 0), 0u) << out[0];
  // bird + every encoding (bake --encoding all stores them all), each on the GLSL and the HLSL kernel.
  std::vector<std::string> what = {"bird"};
  for (somm::Encoding e : somm::kAllEncodings) what.push_back(somm::encodingName(e));
  ASSERT_EQ(out.size(), 1 + 2 * what.size()) << r.out;
  for (size_t i = 0; i < what.size(); ++i)
    for (size_t l = 0; l < 2; ++l) {
      const std::string expect =
          what[i] + (l ? " hlsl" : " glsl") + ": 0 mismatches in " + std::to_string(c.samples) + " lookups";
      EXPECT_EQ(out[1 + 2 * i + l], expect);
    }
}

INSTANTIATE_TEST_SUITE_P(
    BundledScenes, GpuCheckScene,
    ::testing::Values(Case{"oak-tree/oaktree.gltf", 4, 4, 100000}, Case{"oak-tree/oaktree.gltf", 8, 4, 50000},
                      Case{"oak-tree/oaktree.gltf", 12, 4, 10000}, Case{"oak-tree/oaktree.gltf", 8, 2, 50000},
                      Case{"alpha-blend-mode-test/AlphaBlendModeTest.gltf", 4, 4, 100000},
                      Case{"alpha-blend-mode-test/AlphaBlendModeTest.gltf", 8, 4, 50000},
                      Case{"alpha-blend-mode-test/AlphaBlendModeTest.gltf", 12, 4, 10000},
                      Case{"alpha-blend-mode-test/AlphaBlendModeTest.gltf", 12, 2, 10000}),
    [](const ::testing::TestParamInfo<Case>& i) {
      std::string s = std::string(i.param.scene).substr(0, 3) + "_L" + std::to_string(i.param.level) + "_F" +
                      std::to_string(i.param.format);
      return s;
    });

TEST(GpuCheckCli, NoVulkanDeviceIsAOneLineError) {
  TempDir dir;
  const std::string somm = dir / "scene.somm";
  ASSERT_EQ(runSomm("bake " + shellQuote(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf") +
                    " -l 2 -o " + shellQuote(somm))
                .exitCode,
            0);
  // The loader finds no driver through a manifest list that names none.
  const std::string cmd = "VK_ICD_FILENAMES=" + shellQuote(dir / "none.json") +
                          " VK_DRIVER_FILES=" + shellQuote(dir / "none.json") + " '" + SOMM_CLI_PATH +
                          "' gpu-check " + shellQuote(somm) + " > " + shellQuote(dir / "out") + " 2> " +
                          shellQuote(dir / "err");
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string err = somm::testing::readFile(dir / "err");
  EXPECT_EQ(lines(err).size(), 1u) << err;
  EXPECT_NE(err.find("somm gpu-check: no Vulkan device"), std::string::npos) << err;
  EXPECT_EQ(somm::testing::readFile(dir / "out"), "");
}

TEST(GpuCheckCli, MissingEncodingAndBadFile) {
  TempDir dir;
  const std::string somm = dir / "scene.somm";
  ASSERT_EQ(runSomm("bake " + shellQuote(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf") +
                    " -l 3 -o " + shellQuote(somm))
                .exitCode,
            0);
  auto r = runSomm("gpu-check " + shellQuote(somm) + " --encoding rank");
  EXPECT_EQ(r.exitCode, 1) << r.err;  // the file stores no rank encoding (as somm query)
  EXPECT_NE(r.err.find("stores no 'rank' encoding"), std::string::npos) << r.err;
  EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
  r = runSomm("gpu-check " + shellQuote(somm) + " --encoding nope");
  EXPECT_EQ(r.exitCode, 2) << r.err;
  somm::testing::writeFile(dir / "bad.somm", "not a somm file");
  r = runSomm("gpu-check " + shellQuote(dir / "bad.somm"));
  EXPECT_EQ(r.exitCode, 1) << r.err;
  EXPECT_NE(r.err.find("bad.somm"), std::string::npos) << r.err;
  EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
}

TEST(GpuCheckCli, FlatOnlyFileChecksFlat) {
  SOMM_REQUIRE_DEVICE();
  TempDir dir;
  const std::string somm = dir / "scene.somm";
  ASSERT_EQ(runSomm("bake " + shellQuote(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf") +
                    " -l 5 -o " + shellQuote(somm))
                .exitCode,
            0);
  const auto r = runSomm("gpu-check " + shellQuote(somm) + " --samples 1000 --shader hlsl");
  EXPECT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(lines(r.out).size(), 3u) << r.out;  // device, bird hlsl, flat hlsl
  EXPECT_NE(r.out.find("flat hlsl: 0 mismatches in 1000 lookups"), std::string::npos) << r.out;
}

TEST(GpuBenchCli, RatiosToFlat) {
  SOMM_REQUIRE_DEVICE();
  TempDir dir;
  const std::string somm = dir / "scene.somm";
  ASSERT_EQ(runSomm("bake " + shellQuote(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf") +
                    " -l 4 --encoding rank -o " + shellQuote(somm))
                .exitCode,
            0);
  const auto r = runSomm("gpu-bench " + shellQuote(somm) + " --samples 4096 --repeat 1");
  EXPECT_EQ(r.exitCode, 0) << r.err;
  const std::vector<std::string> out = lines(r.out);
  ASSERT_EQ(out.size(), 4u) << r.out;  // device, description, flat, rank
  EXPECT_NE(out[2].find("1.000 x flat"), std::string::npos) << out[2];
  EXPECT_EQ(out[3].rfind("rank ", 0), 0u) << out[3];
  EXPECT_NE(out[3].find(" x flat"), std::string::npos) << out[3];
}

}  // namespace
