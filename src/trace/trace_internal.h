// SPDX-License-Identifier: MIT
// somm_trace internals: per-geometry filter data and the hot-path alpha test.
#pragma once

#include <embree3/rtcore.h>

#include <memory>
#include <string>
#include <vector>

#include "somm/embree.h"
#include "somm/texture.h"
#include "somm/trace.h"

namespace somm {
namespace detail {

// Per scene geometry (shared by every instance of it): what the texture test needs.
struct GeometryData {
  uint32_t geometry = 0;
  std::vector<uint32_t> indices;        // padded by 4 for Embree
  std::vector<float> triUVs;            // 6 floats per triangle (s0 t0 s1 t1 s2 t2)
  const AlphaTexture* alpha = nullptr;  // null: constant alpha
  Sampler sampler;
  float cutoff = 0.5f;
  float constantAlpha = 1.0f;
  bool alphaTested = false;
  const Material* material = nullptr;
};

// One instance flattened into world space.
struct FlatGeometry {
  uint32_t geometry = 0, instance = 0;
  std::vector<float> positions;  // xyz per vertex, world space, padded by 4 floats
};

// The alpha test at hit (u, v) of triangle `prim`, exactly as the `texture` method evaluates it.
inline bool textureTest(const GeometryData& d, uint32_t prim, float u, float v) noexcept {
  if (!d.alpha) return alphaTestPasses(d.constantAlpha, d.cutoff);
  float s, t;
  interpolateUV(d.triUVs.data() + 6 * size_t(prim), u, v, s, t);
  return alphaTestPasses(sampleAlpha(*d.alpha, d.sampler, s, t), d.cutoff);
}

struct BitmaskData {
  const GeometryData* geometry = nullptr;
  const uint8_t* masks = nullptr;  // bytesPerTriangle per triangle, 2 bits per cell, cell = iv·n + iu
  uint32_t n = 1, bytesPerTriangle = 1;
};

std::vector<std::string> encodingNames();

}  // namespace detail

struct TraceWorld::Impl {
  RTCDevice device = nullptr;
  std::vector<detail::GeometryData> geometries;
  std::vector<detail::FlatGeometry> flat;  // Embree geometry id = index
};

struct Tracer::Impl {
  std::shared_ptr<const TraceWorld> world;
  RTCScene scene = nullptr;
  std::shared_ptr<const void> keepAlive;
  MethodKind kind = MethodKind::Texture;
  std::shared_ptr<const SceneMicromaps> micromaps, overlay;
  // By Embree geometry id: the flattened instance, and the part's primID → triangle map (null: identity).
  struct Part {
    uint32_t flat = 0;
    const uint32_t* triangleOf = nullptr;
  };
  std::vector<Part> parts;
  std::vector<embree::AttachedGeometry> attached;  // micromap methods: the parts somm/embree.h created
};

}  // namespace somm
