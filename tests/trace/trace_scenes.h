// SPDX-License-Identifier: MIT
// Procedural scenes for the trace tests and benchmarks: layered alpha-tested leaf cards.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>

#include "somm/scene.h"

namespace somm::testing {

// A leaf-shaped alpha: 1 inside a lobed ellipse, 0 outside, a soft rim of intermediate values; `size`²
// texels.
inline std::shared_ptr<AlphaTexture> leafAlpha(uint32_t size, bool specks = true) {
  auto t = std::make_shared<AlphaTexture>();
  t->width = t->height = size;
  t->alpha.resize(size_t(size) * size);
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) {
      const float u = (x + 0.5f) / size * 2 - 1, v = (y + 0.5f) / size * 2 - 1;
      const float ang = std::atan2(v, u);
      const float r = std::sqrt(u * u / 0.45f + v * v) / (0.85f + 0.12f * std::sin(7 * ang));
      float a = std::clamp((1.0f - r) * 12.0f + 0.5f, 0.0f, 1.0f);
      if (specks && (x * 7 + y * 13) % 211 == 0) a = 1.0f - a;  // specks: single texels of the other class
      t->alpha[size_t(y) * size + x] = a;
    }
  return t;
}

inline std::shared_ptr<ColorImage> leafColor(uint32_t size) {
  auto c = std::make_shared<ColorImage>();
  c->width = c->height = size;
  c->rgba.resize(size_t(size) * size * 4);
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) {
      uint8_t* p = c->rgba.data() + (size_t(y) * size + x) * 4;
      p[0] = uint8_t(40 + (x * 3) % 60);
      p[1] = uint8_t(120 + (y * 5) % 100);
      p[2] = uint8_t(30 + ((x ^ y) & 31));
      p[3] = 255;
    }
  return c;
}

struct Rng {
  uint64_t s;
  float next() {  // [0, 1)
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return float((s >> 40) & 0xffffff) / float(1 << 24);
  }
};

// `cards` alpha-tested quads (linear filter, repeat; some with UVs tiled ×2) scattered in a box in front of
// the camera, an opaque ground, and one nearest/clamp-sampled card geometry instanced twice. Geometries: 0
// cards, 1 ground, 2 instanced card.
inline Scene makeCardScene(uint32_t cards, uint64_t seed = 1, uint32_t texSize = 64, bool specks = true) {
  Scene s;
  s.sourcePath = "procedural-cards";
  Material leaf;
  leaf.name = "leaf";
  leaf.alphaMode = AlphaMode::Mask;
  leaf.alphaCutoff = 0.5f;
  leaf.doubleSided = true;
  leaf.alpha = leafAlpha(texSize, specks);
  leaf.baseColor = leafColor(texSize);
  leaf.sampler = Sampler{Wrap::Repeat, Wrap::Repeat, Filter::Linear};
  Material ground;
  ground.name = "ground";
  ground.baseColorFactor = {0.6f, 0.5f, 0.4f, 1.0f};
  Material leafNearest = leaf;
  leafNearest.name = "leaf-nearest";
  leafNearest.sampler = Sampler{Wrap::ClampToEdge, Wrap::MirroredRepeat, Filter::Nearest};
  s.materials = {leaf, ground, leafNearest};

  Rng rng{seed};
  Geometry g;
  g.name = "cards";
  g.material = 0;
  for (uint32_t i = 0; i < cards; ++i) {
    const float cx = rng.next() * 4 - 2, cy = rng.next() * 3 - 1.0f, cz = rng.next() * 4 - 2;
    const float a = rng.next() * 6.2831853f, b = (rng.next() - 0.5f) * 1.2f;
    const float size = 0.4f + 0.6f * rng.next();
    // Card axes: e1 horizontal-ish, e2 tilted.
    const float e1[3] = {std::cos(a) * size, 0, std::sin(a) * size};
    const float e2[3] = {-std::sin(a) * std::sin(b) * size, std::cos(b) * size,
                         std::cos(a) * std::sin(b) * size};
    const uint32_t base = uint32_t(g.positions.size() / 3);
    for (int k = 0; k < 4; ++k) {
      const float su = (k & 1) ? 1.0f : -1.0f, sv = (k & 2) ? 1.0f : -1.0f;
      g.positions.insert(g.positions.end(), {cx + su * e1[0] + sv * e2[0], cy + su * e1[1] + sv * e2[1],
                                             cz + su * e1[2] + sv * e2[2]});
      const float tile = (i % 5 == 0) ? 2.0f : 1.0f;
      g.uvs.insert(g.uvs.end(), {(k & 1) ? tile : 0.0f, (k & 2) ? tile : 0.0f});
    }
    g.indices.insert(g.indices.end(), {base, base + 1, base + 2, base + 2, base + 1, base + 3});
  }
  Geometry gr;
  gr.name = "ground";
  gr.material = 1;
  gr.positions = {-3.5f, -1.5f, -3.5f, 3.5f, -1.5f, -3.5f, -3.5f, -1.5f, 3.5f, 3.5f, -1.5f, 3.5f};
  gr.uvs = {0, 0, 1, 0, 0, 1, 1, 1};
  gr.indices = {0, 2, 1, 1, 2, 3};
  Geometry one;
  one.name = "instanced-card";
  one.material = 2;
  one.positions = {-1, -1, 0, 1, -1, 0, -1, 1, 0, 1, 1, 0};
  one.uvs = {-0.1f, -0.2f, 1.1f, -0.2f, -0.1f, 1.3f, 1.1f, 1.3f};
  one.indices = {0, 1, 2, 2, 1, 3};
  s.geometries = {g, gr, one};
  s.instances.push_back(Instance{0, {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}});
  s.instances.push_back(Instance{1, {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}});
  // Two placements of geometry 2: rotated about y and translated.
  const float c = std::cos(0.6f), sn = std::sin(0.6f);
  s.instances.push_back(Instance{2, {c, 0, -sn, 0, 0, 1, 0, 0, sn, 0, c, 0, -1.2f, 0.3f, 1.5f, 1}});
  s.instances.push_back(Instance{2, {0.7f, 0, 0, 0, 0, 0.7f, 0, 0, 0, 0, 0.7f, 0, 1.4f, -0.2f, 1.8f, 1}});
  return s;
}

}  // namespace somm::testing
