// SPDX-License-Identifier: MIT
// Shared by the scene fuzz targets: a private scratch directory holding the fuzzed file next to a small valid
// texture and buffer (so that references resolve), and the invariants every loaded Scene must satisfy.
#pragma once

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>

#include "somm/scene.h"

namespace somm::fuzz {

// A 4x4 RGBA PNG with a checkerboard alpha.
inline constexpr unsigned char kTinyPng[] = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44,
    0x52, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x04, 0x08, 0x06, 0x00, 0x00, 0x00, 0xa9,
    0xf1, 0x9e, 0x7e, 0x00, 0x00, 0x00, 0x2f, 0x49, 0x44, 0x41, 0x54, 0x78, 0xda, 0x15, 0xca,
    0x31, 0x01, 0x00, 0x30, 0x0c, 0xc3, 0x30, 0x03, 0x2b, 0xb0, 0x9c, 0x05, 0x15, 0x7e, 0x9d,
    0x77, 0xe9, 0x11, 0xb0, 0x0c, 0x7b, 0xd1, 0x2a, 0xcc, 0xde, 0xcc, 0x12, 0xad, 0x42, 0x1c,
    0x71, 0x68, 0xf3, 0x47, 0x1d, 0x75, 0x68, 0xf5, 0x01, 0x36, 0xbd, 0x1b, 0x39, 0xee, 0x9e,
    0x78, 0xdb, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

[[noreturn]] inline void fail(const char* target, const std::string& what) {
  std::fprintf(stderr, "%s: %s\n", target, what.c_str());
  std::abort();
}

inline void writeBytes(const std::string& path, const void* data, size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) fail("fuzz", "cannot write " + path);
  if (size) std::fwrite(data, 1, size, f);
  std::fclose(f);
}

// Per process: /dev/shm (or /tmp)/somm-fuzz-<pid>/ with t.png and b.bin (64 bytes: floats 0, 0.25, 0.5, ...).
inline const std::string& scratchDir() {
  static const std::string dir = [] {
    const std::filesystem::path base = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    const std::filesystem::path d = base / ("somm-fuzz-" + std::to_string(getpid()));
    std::error_code ec;
    std::filesystem::create_directories(d, ec);
    if (ec) fail("fuzz", "cannot create " + d.string());
    writeBytes((d / "t.png").string(), kTinyPng, sizeof kTinyPng);
    float buf[16];
    for (int i = 0; i < 16; ++i) buf[i] = float(i % 5) * 0.25f;
    writeBytes((d / "b.bin").string(), buf, sizeof buf);
    return d.string();
  }();
  static const struct Cleanup {
    ~Cleanup() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  } cleanup;
  return dir;
}

// Error messages: one line starting with the path.
inline void checkError(const char* target, const Error& e, const std::string& path) {
  if (e.message.rfind(path, 0) != 0) fail(target, "error does not start with the file name: " + e.message);
  if (e.message.find('\n') != std::string::npos) fail(target, "error is not one line: " + e.message);
}

// What the baker and the tracer rely on.
inline void checkScene(const char* target, const Scene& s) {
  for (const Material& m : s.materials) {
    if (m.alpha && (m.alpha->width == 0 || m.alpha->height == 0 || !m.alpha->consistent()))
      fail(target, "alpha texture size");
    if (m.alpha)
      for (size_t i = 0; i < m.alpha->texelCount(); ++i) {
        const float a = m.alpha->texel(i);
        if (!(a >= 0.0f && a <= 1.0f)) fail(target, "alpha outside [0, 1]");
      }
    if (m.baseColor && m.baseColor->rgba.size() != size_t(m.baseColor->width) * m.baseColor->height * 4)
      fail(target, "colour image size");
  }
  for (const Geometry& g : s.geometries) {
    if (g.material >= s.materials.size()) fail(target, "geometry material out of range");
    if (g.positions.size() % 3 != 0) fail(target, "positions not xyz");
    const size_t verts = g.positions.size() / 3;
    if (g.uvs.size() != 2 * verts && !(g.uvs.empty() && !s.materials[g.material].alpha))
      fail(target, "uv count differs from the vertex count");
    if (g.indices.size() % 3 != 0) fail(target, "indices not triangles");
    for (uint32_t i : g.indices)
      if (i >= verts) fail(target, "index out of range");
  }
  for (const Instance& in : s.instances)
    if (in.geometry >= s.geometries.size()) fail(target, "instance geometry out of range");
}

}  // namespace somm::fuzz
