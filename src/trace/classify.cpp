// SPDX-License-Identifier: MIT
// Conservative classification of barycentric regions against a material's alpha test (bitmask build,
// bakeSimple).
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "somm/bird.h"
#include "somm/trace.h"

namespace somm {

namespace {

// Inclusive texel index range [a, b] on one axis after wrapping semantics are taken into account: a range
// covering a whole period is shortened to one period (2·size for mirrored repeat), a clamped range is clamped
// to the texture.
void normaliseRange(int64_t& a, int64_t& b, uint32_t size, Wrap wrap) noexcept {
  const int64_t n = int64_t(size);
  if (wrap == Wrap::ClampToEdge) {
    a = std::clamp<int64_t>(a, 0, n - 1);
    b = std::clamp<int64_t>(b, 0, n - 1);
    return;
  }
  if (b - a + 1 > 2 * n) b = a + 2 * n - 1;
}

}  // namespace

State classifyRegion(const Material& material, const float* uv, const float* u, const float* v,
                     uint32_t count) noexcept {
  const float cutoff = material.alphaCutoff;
  if (!material.alpha || material.alpha->width == 0 || material.alpha->height == 0)
    return alphaTestPasses(material.baseColorFactor[3], cutoff) ? State::Opaque : State::Transparent;
  const AlphaTexture& tex = *material.alpha;
  const double W = tex.width, H = tex.height;
  // Texel-space triangle vertices (for the margin), then the region's points.
  double tx[3], ty[3];
  for (int i = 0; i < 3; ++i) {
    tx[i] = double(uv[2 * i]) * W;
    ty[i] = double(uv[2 * i + 1]) * H;
    if (!std::isfinite(tx[i]) || !std::isfinite(ty[i])) return State::UnknownOpaque;
  }
  double minx = std::numeric_limits<double>::infinity(), maxx = -minx, miny = minx, maxy = -minx;
  for (uint32_t k = 0; k < count; ++k) {
    const double bu = u[k], bv = v[k], bw = 1.0 - bu - bv;
    const double x = bw * tx[0] + bu * tx[1] + bv * tx[2];
    const double y = bw * ty[0] + bu * ty[1] + bv * ty[2];
    minx = std::min(minx, x);
    maxx = std::max(maxx, x);
    miny = std::min(miny, y);
    maxy = std::max(maxy, y);
  }
  // Safety margin: float interpolation of the hit UV and hit barycentrics a hair outside the region
  // (docs/trace.md).
  auto margin = [](const double c[3]) {
    const double mag = std::max({std::fabs(c[0]), std::fabs(c[1]), std::fabs(c[2])});
    const double ext = std::max({c[0], c[1], c[2]}) - std::min({c[0], c[1], c[2]});
    return 1e-3 + 1e-5 * std::max(mag, ext);
  };
  const double mx = margin(tx), my = margin(ty);
  minx -= mx;
  maxx += mx;
  miny -= my;
  maxy += my;
  int64_t x0, x1, y0, y1;
  if (material.sampler.filter == Filter::Nearest) {
    x0 = texelFloor(minx);
    x1 = texelFloor(maxx);
    y0 = texelFloor(miny);
    y1 = texelFloor(maxy);
  } else {
    x0 = texelFloor(minx - 0.5);
    x1 = texelFloor(maxx - 0.5) + 1;
    y0 = texelFloor(miny - 0.5);
    y1 = texelFloor(maxy - 0.5) + 1;
  }
  normaliseRange(x0, x1, tex.width, material.sampler.wrapS);
  normaliseRange(y0, y1, tex.height, material.sampler.wrapT);
  bool anyPass = false, anyFail = false;
  for (int64_t y = y0; y <= y1 && !(anyPass && anyFail); ++y) {
    const uint32_t wy = wrapTexel(y, tex.height, material.sampler.wrapT);
    for (int64_t x = x0; x <= x1; ++x) {
      const bool pass = alphaTestPasses(tex.at(wrapTexel(x, tex.width, material.sampler.wrapS), wy), cutoff);
      anyPass |= pass;
      anyFail |= !pass;
      if (anyPass && anyFail) break;
    }
  }
  if (!anyFail) return State::Opaque;
  if (!anyPass) return State::Transparent;
  // Unknown: opaque or transparent by the alpha test at the region's centroid.
  float cu = 0, cv = 0;
  for (uint32_t k = 0; k < count; ++k) {
    cu += u[k];
    cv += v[k];
  }
  float s, t;
  interpolateUV(uv, cu / float(count), cv / float(count), s, t);
  return alphaTestPasses(sampleAlpha(tex, material.sampler, s, t), cutoff) ? State::UnknownOpaque
                                                                           : State::UnknownTransparent;
}

OmmArrays bakeSimple(const Scene& scene, uint32_t level, Format format) {
  OmmArrays out(scene.geometries.size());
  for (size_t g = 0; g < scene.geometries.size(); ++g) {
    const Geometry& geo = scene.geometries[g];
    const Material& mat = scene.materials[geo.material];
    if (!mat.alphaTested()) continue;
    const uint32_t tris = geo.triangleCount();
    // Triangles with identical UVs get identical micromaps: classify each distinct UV triangle once.
    std::map<std::array<float, 6>, uint32_t> distinct;
    std::vector<std::array<float, 6>> keys;
    std::vector<uint32_t> which(tris);
    for (uint32_t tri = 0; tri < tris; ++tri) {
      std::array<float, 6> uv{};
      if (!geo.uvs.empty())
        for (int i = 0; i < 3; ++i) {
          uv[2 * i] = geo.uvs[2 * size_t(geo.indices[3 * size_t(tri) + i])];
          uv[2 * i + 1] = geo.uvs[2 * size_t(geo.indices[3 * size_t(tri) + i]) + 1];
        }
      auto [it, fresh] = distinct.try_emplace(uv, uint32_t(keys.size()));
      if (fresh) keys.push_back(uv);
      which[tri] = it->second;
    }
    std::vector<Micromap> maps(keys.size());
    tbb::parallel_for(size_t(0), keys.size(), [&](size_t k) {
      Micromap map(level, format);
      for (uint32_t m = 0; m < microTriangleCount(level); ++m) {
        const MicroTriangleF mt = indexToMicroTriangleF(m, level);
        State s = classifyRegion(mat, keys[k].data(), mt.u, mt.v, 3);
        if (format == Format::TwoState) s = toTwoState(s);
        map.set(m, s);
      }
      maps[k] = std::move(map);
    });
    OmmArrayBuilder builder;
    for (uint32_t tri = 0; tri < tris; ++tri) builder.add(maps[which[tri]]);
    out[g] = builder.finish();
  }
  return out;
}

}  // namespace somm
