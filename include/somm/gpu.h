// SPDX-License-Identifier: MIT
// somm — the Vulkan compute harness for the shader lookups of shaders/somm.glsl and shaders/somm.hlsl
// (library target somm_gpu, optional: configure with -DSOMM_BUILD_GPU=OFF to leave it out). The kernels are
// compiled to SPIR-V at build time and embedded; the Vulkan loader (libvulkan.so.1) is opened at run time, so
// a machine without Vulkan gets an error from Device::open, not a missing-library failure. docs/shaders.md.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "somm/result.h"

namespace somm {
namespace gpu {

// Which front end the kernel was written for (both run on Vulkan as SPIR-V).
enum class ShaderLanguage : uint8_t { Glsl = 0, Hlsl = 1 };
const char* shaderLanguageName(ShaderLanguage l) noexcept;  // "glsl", "hlsl"

// What each invocation computes for its query.
enum class LookupMode : uint32_t {
  StateUV = 0,     // sommStateUV(array at base + w, triangle, u, v): EncodedArray::stateUV
  BirdIndex = 1,   // sommBaryToIndex(u, v, w = level): baryToIndex
  StateIndex = 2,  // sommState(array at base, triangle, w = index): EncodedArray::state
};

// One query, 16 bytes as the kernel reads it (uvec4): u and v are passed as their exact bit patterns.
struct Query {
  uint32_t triangle = 0;
  float u = 0.0f, v = 0.0f;
  uint32_t w =
      0;  // StateUV: byte offset of the array from `base`; BirdIndex: the level; StateIndex: the index
};
static_assert(sizeof(Query) == 16, "Query must match the kernel's uvec4");

// A Vulkan device with the lookup kernels loaded.
class Device {
 public:
  // Loads the Vulkan loader, creates an instance and a device on the first physical device with a compute
  // queue (a GPU before a CPU implementation such as lavapipe). Error (one line) when there is none.
  static Result<Device> open();

  Device(Device&&) noexcept;
  Device& operator=(Device&&) noexcept;
  ~Device();

  const std::string& name() const noexcept;  // e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  const char* typeName() const noexcept;     // "discrete GPU", "integrated GPU", "CPU", ...

  // Runs one invocation per query and returns the results. `buffer` holds one or more serialized
  // EncodedArrays; `base` is the byte address of the one to query (StateUV: plus the query's w; ignored by
  // BirdIndex). The buffer is
  // uploaded with 16 zero bytes appended (the shaders' 8-byte read-ahead). With repeats > 1 the dispatch
  // runs that many times and *seconds (if given) is the fastest dispatch's wall time (upload excluded).
  Result<std::vector<uint32_t>> run(ShaderLanguage language, LookupMode mode,
                                    const std::vector<uint8_t>& buffer, uint32_t base,
                                    const std::vector<Query>& queries, uint32_t repeats = 1,
                                    double* seconds = nullptr);

 private:
  struct Impl;
  explicit Device(std::unique_ptr<Impl> impl) noexcept;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gpu
}  // namespace somm
