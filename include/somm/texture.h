// SPDX-License-Identifier: MIT
// somm — alpha textures and the alpha test. This header is the single definition of "the alpha test" that the baker
// must be conservative against and that the ray tracer's `texture` method evaluates.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

namespace somm {

enum class Wrap : uint8_t { Repeat = 0, ClampToEdge = 1, MirroredRepeat = 2 };
enum class Filter : uint8_t { Nearest = 0, Linear = 1 };

struct Sampler {
  Wrap wrapS = Wrap::Repeat;  // along u (texel x)
  Wrap wrapT = Wrap::Repeat;  // along v (texel y)
  Filter filter = Filter::Linear;
  friend bool operator==(const Sampler& a, const Sampler& b) noexcept {
    return a.wrapS == b.wrapS && a.wrapT == b.wrapT && a.filter == b.filter;
  }
  friend bool operator!=(const Sampler& a, const Sampler& b) noexcept { return !(a == b); }
};

// Alpha values in [0, 1], row-major. Texel (x, y) covers texture coordinates [x/W, (x+1)/W] × [y/H, (y+1)/H] in the
// geometry's own UV convention: loaders flip image rows where needed (glTF: image row 0 is v = 0; OBJ: the bottom image
// row is v = 0), so no UV is ever rewritten. Alpha already includes any constant factor (glTF baseColorFactor alpha).
struct AlphaTexture {
  uint32_t width = 0, height = 0;
  std::vector<float> alpha;  // width * height
  float at(uint32_t x, uint32_t y) const noexcept { return alpha[size_t(y) * width + x]; }
};

// Names used in CLI output and JSON.
constexpr const char* filterName(Filter f) noexcept {
  return f == Filter::Nearest ? "nearest" : "linear";
}
constexpr const char* wrapName(Wrap w) noexcept {
  return w == Wrap::Repeat ? "repeat" : w == Wrap::ClampToEdge ? "clamp" : "mirror";
}

// Texel index i (any integer) → [0, size) under a wrap mode (OpenGL / glTF semantics).
inline uint32_t wrapTexel(int64_t i, uint32_t size, Wrap w) noexcept {
  const int64_t n = int64_t(size);
  switch (w) {
    case Wrap::Repeat: {
      int64_t r = i % n;
      return uint32_t(r < 0 ? r + n : r);
    }
    case Wrap::ClampToEdge:
      return uint32_t(i < 0 ? 0 : (i >= n ? n - 1 : i));
    case Wrap::MirroredRepeat: {
      int64_t r = i % (2 * n);
      if (r < 0) r += 2 * n;
      return uint32_t(r < n ? r : 2 * n - 1 - r);
    }
  }
  return 0;
}

// Texel coordinate of a texture coordinate, clamped to a range where int64 arithmetic is exact and safe.
inline int64_t texelFloor(double x) noexcept {
  if (!(x > -1e15)) return -1000000000000000LL;  // also catches NaN
  if (x > 1e15) return 1000000000000000LL;
  return int64_t(std::floor(x));
}

// The alpha the material's sampler returns at (s, t). Nearest: the texel containing (s·W, t·H). Linear: the bilinear
// blend of the four texels around (s·W − ½, t·H − ½). Computed in double for stability; NaN/inf coordinates sample
// texel 0 after wrapping of the clamped coordinate (the baker never classifies such triangles as known).
inline float sampleAlpha(const AlphaTexture& tex, const Sampler& smp, float s, float t) noexcept {
  const double x = double(s) * tex.width, y = double(t) * tex.height;
  if (smp.filter == Filter::Nearest) {
    const uint32_t tx = wrapTexel(texelFloor(x), tex.width, smp.wrapS);
    const uint32_t ty = wrapTexel(texelFloor(y), tex.height, smp.wrapT);
    return tex.at(tx, ty);
  }
  const double xs = x - 0.5, ys = y - 0.5;
  const int64_t x0 = texelFloor(xs), y0 = texelFloor(ys);
  const double fx = std::isfinite(xs) ? xs - double(x0) : 0.0, fy = std::isfinite(ys) ? ys - double(y0) : 0.0;
  const uint32_t ax = wrapTexel(x0, tex.width, smp.wrapS), bx = wrapTexel(x0 + 1, tex.width, smp.wrapS);
  const uint32_t ay = wrapTexel(y0, tex.height, smp.wrapT), by = wrapTexel(y0 + 1, tex.height, smp.wrapT);
  const double top = double(tex.at(ax, ay)) * (1.0 - fx) + double(tex.at(bx, ay)) * fx;
  const double bot = double(tex.at(ax, by)) * (1.0 - fx) + double(tex.at(bx, by)) * fx;
  return float(top * (1.0 - fy) + bot * fy);
}

// The alpha test (glTF MASK): opaque when alpha >= cutoff.
inline bool alphaTestPasses(float alpha, float cutoff) noexcept {
  return alpha >= cutoff;
}

}  // namespace somm
