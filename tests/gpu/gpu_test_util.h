// SPDX-License-Identifier: MIT
// Opening the Vulkan device in tests: a missing device fails the test (make test installs lavapipe), except in
// the sanitizer build, where lavapipe may be unusable; there the test is skipped with the reason.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <optional>

#include "somm/gpu.h"

namespace somm::testing {

inline bool sanitizerBuild() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return true;
#else
  return false;
#endif
#else
  return false;
#endif
}

// Opens the device into `var` (a std::optional<Device>), or skips (sanitizer build) / fails the test.
#define SOMM_OPEN_DEVICE_OR_SKIP(var)                                                                     \
  std::optional<somm::gpu::Device> var;                                                                   \
  {                                                                                                       \
    auto opened = somm::gpu::Device::open();                                                              \
    if (!opened) {                                                                                        \
      if (somm::testing::sanitizerBuild()) GTEST_SKIP() << "sanitizer build: " << opened.error().message; \
      FAIL() << opened.error().message;                                                                   \
    }                                                                                                     \
    var.emplace(std::move(*opened));                                                                      \
  }

}  // namespace somm::testing
