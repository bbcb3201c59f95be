// SPDX-License-Identifier: MIT
// somm — alpha textures and the alpha test. This header is the single definition of "the alpha test" that the baker
// must be conservative against and that the ray tracer's `texture` method evaluates.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
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

// How an AlphaTexture holds its texels: as floats, or at an image's own precision (8 or 16 bits per texel) with a
// table from texel value to alpha.
enum class AlphaStorage : uint8_t { Float32 = 0, UInt8 = 1, UInt16 = 2 };

// The alpha of integer texel value v (0..255 for UInt8, 0..65535 for UInt16) times `scale`: the loaders'
// conversion, float(v / 255.0) resp. float(v / 65535.0) computed in double, then (scale ≠ 1) multiplied by scale in
// float and clamped to [0, 1]. An 8-bit v gives exactly the 16-bit alpha of v · 257.
inline float integerAlpha(uint32_t v, AlphaStorage storage, float scale) noexcept {
  float a = float(double(v) / (storage == AlphaStorage::UInt8 ? 255.0 : 65535.0));
  if (scale != 1.0f) a *= scale;
  return a < 0.0f ? 0.0f : (a > 1.0f ? 1.0f : a);  // NaN stays NaN
}

// Alpha values in [0, 1], row-major. Texel (x, y) covers texture coordinates [x/W, (x+1)/W] × [y/H, (y+1)/H] in the
// geometry's own UV convention: loaders flip image rows where needed (glTF: image row 0 is v = 0; OBJ: the bottom image
// row is v = 0), so no UV is ever rewritten. Alpha already includes any constant factor (glTF baseColorFactor alpha).
//
// Storage: Float32 (the default) keeps one float per texel in `alpha`. UInt8 / UInt16 keep the image's own texel
// values in `alpha8` / `alpha16` (an 8-bit image alpha stays 1 byte per texel) and `lut` maps a value to its alpha,
// lut[v] = integerAlpha(v, storage, scale); make one with fromUInt8 / fromUInt16. at() returns the same float for
// every storage that holds the same alphas.
struct AlphaTexture {
  uint32_t width = 0, height = 0;
  std::vector<float> alpha;  // Float32: width * height
  AlphaStorage storage = AlphaStorage::Float32;
  std::vector<uint8_t> alpha8;                    // UInt8: width * height texel values
  std::vector<uint16_t> alpha16;                  // UInt16: width * height texel values
  float scale = 1.0f;                             // UInt8 / UInt16: the factor the table includes
  std::shared_ptr<const std::vector<float>> lut;  // UInt8 / UInt16: 256 / 65536 alphas

  // The alpha of texel i = y · width + x.
  float texel(size_t i) const noexcept {
    if (storage == AlphaStorage::UInt8) return (*lut)[alpha8[i]];
    if (storage == AlphaStorage::UInt16) return (*lut)[alpha16[i]];
    return alpha[i];
  }
  float at(uint32_t x, uint32_t y) const noexcept { return texel(size_t(y) * width + x); }
  size_t texelCount() const noexcept { return size_t(width) * height; }
  // Every texel's alpha as a float (row-major), whatever the storage.
  std::vector<float> values() const {
    std::vector<float> v(texelCount());
    for (size_t i = 0; i < v.size(); ++i) v[i] = texel(i);
    return v;
  }
  // The storage holds width · height texels (and, for integer storage, a table of the right size).
  bool consistent() const noexcept {
    switch (storage) {
      case AlphaStorage::Float32:
        return alpha.size() == texelCount();
      case AlphaStorage::UInt8:
        return alpha8.size() == texelCount() && lut && lut->size() == 256;
      case AlphaStorage::UInt16:
        return alpha16.size() == texelCount() && lut && lut->size() == 65536;
    }
    return false;
  }
  // Bytes of texel storage (the table of the default scale 1 is shared by every texture and not counted).
  size_t memoryBytes() const noexcept {
    return alpha.size() * sizeof(float) + alpha8.size() + alpha16.size() * sizeof(uint16_t) +
           (lut && scale != 1.0f ? lut->size() * sizeof(float) : 0);
  }

  // The table for integer storage (UInt8 or UInt16) and a scale; the one of scale 1 is built once and shared.
  static std::shared_ptr<const std::vector<float>> table(AlphaStorage storage, float scale) {
    auto make = [](AlphaStorage st, float sc) {
      auto t = std::make_shared<std::vector<float>>(st == AlphaStorage::UInt8 ? 256 : 65536);
      for (size_t v = 0; v < t->size(); ++v) (*t)[v] = integerAlpha(uint32_t(v), st, sc);
      return std::shared_ptr<const std::vector<float>>(std::move(t));
    };
    if (scale != 1.0f) return make(storage, scale);
    static const std::shared_ptr<const std::vector<float>> t8 = make(AlphaStorage::UInt8, 1.0f);
    static const std::shared_ptr<const std::vector<float>> t16 = make(AlphaStorage::UInt16, 1.0f);
    return storage == AlphaStorage::UInt8 ? t8 : t16;
  }
  static AlphaTexture fromUInt8(uint32_t w, uint32_t h, std::vector<uint8_t> values, float scale = 1.0f) {
    AlphaTexture t = integer(w, h, AlphaStorage::UInt8, scale);
    t.alpha8 = std::move(values);
    return t;
  }
  static AlphaTexture fromUInt16(uint32_t w, uint32_t h, std::vector<uint16_t> values, float scale = 1.0f) {
    AlphaTexture t = integer(w, h, AlphaStorage::UInt16, scale);
    t.alpha16 = std::move(values);
    return t;
  }

 private:
  // A w × h texture of integer storage with its table, texels not yet set.
  static AlphaTexture integer(uint32_t w, uint32_t h, AlphaStorage storage, float scale) {
    AlphaTexture t;
    t.width = w;
    t.height = h;
    t.storage = storage;
    t.scale = scale;
    t.lut = table(storage, scale);
    return t;
  }
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
