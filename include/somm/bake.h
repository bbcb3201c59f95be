// SPDX-License-Identifier: MIT
// somm — conservative opacity-micromap baking from alpha-tested textures (see docs/baking.md).
//
// For every triangle, each micro-triangle's UV triangle (in texel space, grown by a small safety margin) is
// classified against the material's alpha test (include/somm/texture.h): Opaque (Transparent) only when every
// point of it passes (fails) the test under the material's filter and wrap modes, otherwise unknown.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "somm/micromap.h"
#include "somm/omm_array.h"
#include "somm/result.h"
#include "somm/scene.h"
#include "somm/texture.h"

namespace somm {

// What an unknown micro-triangle becomes in a 2-state bake (4-state bakes keep it unknown and only pick
// unknown-opaque / unknown-transparent by majority).
enum class UnknownAs : uint8_t { Majority = 0, Opaque = 1, Transparent = 2 };

struct BakeOptions {
  uint32_t level = 6;           // fixed subdivision level 0..12 (used when texelsPerMicroTri == 0)
  uint32_t maxLevel = 0;        // adaptive: cap 0..12 (used when texelsPerMicroTri > 0)
  float texelsPerMicroTri = 0;  // adaptive: smallest level with UV area·W·H / 4^L <= S, capped at maxLevel
  Format format = Format::FourState;
  UnknownAs unknownAs = UnknownAs::Majority;  // 2-state only
  std::optional<Filter> filter;               // overrides the material's sampler filter
  std::optional<float> cutoff;                // overrides the material's alpha cutoff
  uint64_t maxBytes = 0;  // 0 = no limit; else lower the levels of the largest maps until the data fits
  uint32_t threads = 0;   // 0 = all hardware threads
  // Fraction done, 0..1, non-decreasing, ends at 1; called on the calling thread (the library never prints).
  std::function<void(double)> progress;
};

struct BakeStats {
  uint64_t triangles = 0;
  std::array<uint64_t, 4> specialCount{};  // triangles with a special index, by State (0..3)
  uint64_t uniqueMaps = 0;                 // descriptors in the array
  uint64_t dataBytes = 0;                  // size of the data buffer
  uint64_t microTriangles = 0;             // sum over triangles of 4^level (special-index triangles included)
  uint64_t unknownMicroTriangles = 0;      // micro-triangles the conservative test left unknown (before any
                                           // 2-state demotion)
  uint64_t nonFiniteUvTriangles = 0;       // triangles with NaN/inf UVs (or texel coordinates >= 1e14 in
                                           // magnitude): baked as whole-triangle unknown
  uint32_t minLevel = 0, maxLevel = 0;     // range of the levels chosen (over all triangles)
  uint32_t levelCap = kMaxLevel;           // the global cap --max-bytes applied (kMaxLevel = none)
  double seconds = 0;

  double unknownFraction() const noexcept {
    return microTriangles ? double(unknownMicroTriangles) / double(microTriangles) : 0.0;
  }
};

struct BakedGeometry {
  OmmArray array;
  BakeStats stats;
  std::vector<uint8_t> levels;  // chosen level per triangle (after the maxBytes cap)
};

// The alpha test of one material, prepared for fast conservative queries: per-texel pass bits in a
// summed-area table, the sampler (filter + wrap) and the cutoff. Building it is O(W·H); share it between
// geometries of one material.
class AlphaMask {
 public:
  AlphaMask() = default;
  // `texture` must be non-empty with alpha.size() == width·height (checked by bakeGeometry; asserted here).
  AlphaMask(const AlphaTexture& texture, const Sampler& sampler, float cutoff);

  uint32_t width() const noexcept { return w_; }
  uint32_t height() const noexcept { return h_; }
  const Sampler& sampler() const noexcept { return sampler_; }
  float cutoff() const noexcept { return cutoff_; }
  const AlphaTexture* texture() const noexcept { return tex_; }

  // Number of passing texels in the (unwrapped, inclusive) texel rectangle [x0, x1] × [y0, y1] after
  // wrapping, and the number of texels it covers (counted with multiplicity per wrapped interval). Used to
  // decide uniformity.
  struct Count {
    uint64_t pass = 0, total = 0;
  };
  Count count(int64_t x0, int64_t x1, int64_t y0, int64_t y1) const noexcept;

 private:
  const AlphaTexture* tex_ = nullptr;  // not owned; for majority sampling
  uint32_t w_ = 0, h_ = 0;
  Sampler sampler_;
  float cutoff_ = 0.5f;
  std::vector<uint32_t> sat_;  // (w+1)·(h+1) summed-area table of pass bits
  uint64_t rect(uint32_t x0, uint32_t x1, uint32_t y0,
                uint32_t y1) const noexcept;  // inclusive, wrapped coords
};

// Per-triangle result of the classifier.
struct TriangleBake {
  Micromap map;  // level/format as requested; uniform maps are left to OmmArrayBuilder to specialise
  uint64_t unknownCount = 0;  // micro-triangles left unknown by the conservative test
  bool nonFiniteUv = false;
};

// Bakes one triangle with UVs uv0..uv2 at `level` (0..12). The building block of bakeGeometry, exposed for
// tests.
TriangleBake bakeTriangle(const AlphaMask& mask, std::array<float, 2> uv0, std::array<float, 2> uv1,
                          std::array<float, 2> uv2, uint32_t level, Format format,
                          UnknownAs unknownAs = UnknownAs::Majority);

// The safety margin (in texels) used for a triangle whose texel-space vertices are given: 1e-3 texel plus
// 1e-5 of the largest vertex coordinate magnitude or extent (float interpolation error of a ray tracer, see
// docs/baking.md).
double bakeMarginTexels(const double x[3], const double y[3]) noexcept;

// Adaptive level of a triangle: the smallest L in [0, maxLevel] with uvArea·W·H / 4^L <= texelsPerMicroTri
// (maxLevel when none). Zero-area and non-finite triangles get level 0.
uint32_t adaptiveLevel(std::array<float, 2> uv0, std::array<float, 2> uv1, std::array<float, 2> uv2,
                       uint32_t width, uint32_t height, float texelsPerMicroTri, uint32_t maxLevel) noexcept;

// Bakes one geometry. Materials that are not alpha-tested (OPAQUE) get FullyOpaque for every triangle; MASK
// and BLEND (a caller that bakes BLEND treats it as a mask) are baked; a material without an alpha texture
// has the constant alpha baseColorFactor[3] everywhere. Output bytes are identical for every thread count.
Result<BakedGeometry> bakeGeometry(const Geometry& geometry, const Material& material,
                                   const BakeOptions& options);

// Same, with a prepared mask for the material (nullptr when the material has no alpha texture). The mask's
// sampler and cutoff are used as they are: build it with the effective filter / cutoff (options.filter /
// cutoff are not applied).
Result<BakedGeometry> bakeGeometry(const Geometry& geometry, const Material& material, const AlphaMask* mask,
                                   const BakeOptions& options);

// What `somm bake --estimate` reports, computed from the levels alone (no classification): the data size if
// every alpha-tested triangle with finite UVs and a texture stored its own micromap (no special indices, no
// deduplication). This is an exact upper bound of the baked data size (without maxBytes).
struct BakeEstimate {
  uint64_t triangles = 0;
  uint64_t mapTriangles = 0;  // triangles that would need a micromap if not uniform
  uint64_t dataBytes = 0;     // sum of micromapDataBytes(level) over mapTriangles
  uint64_t microTriangles = 0;
  std::array<uint64_t, kMaxLevel + 1> levelHistogram{};  // over mapTriangles
};
Result<BakeEstimate> estimateBake(const Geometry& geometry, const Material& material,
                                  const BakeOptions& options);

// Checks BakeOptions ranges; the message names the option.
Status validateBakeOptions(const BakeOptions& options);

}  // namespace somm
