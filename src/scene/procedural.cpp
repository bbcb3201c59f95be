// SPDX-License-Identifier: MIT
// somm — procedural alpha textures and scenes (deterministic, platform independent).
#include "somm/procedural.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

namespace somm {

namespace {

// SplitMix64: small, fast, identical everywhere.
struct Rng {
  uint64_t s;
  explicit Rng(uint64_t seed) : s(seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull) {}
  uint64_t next() {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1) with 24 bits (exact in float).
  float uniform() { return float(next() >> 40) * (1.0f / 16777216.0f); }
  float uniform(float a, float b) { return a + (b - a) * uniform(); }
  uint32_t below(uint32_t n) { return uint32_t((next() >> 32) % n); }
};

AlphaTexture blank(uint32_t size, float value = 0.0f) {
  AlphaTexture t;
  t.width = t.height = size;
  t.alpha.assign(size_t(size) * size, value);
  return t;
}

// Leaf silhouette test in normalised quadrant coordinates (x, y in [0, 1], y = 0 top): blade from tip (y =
// tipY) to base (y = baseY), stem below. `lobes` waves along the edge, `angle` rotates the leaf about the
// quadrant centre.
bool insideLeaf(double x, double y, double widthScale, double lobes, double angle) {
  const double cx = x - 0.5, cy = y - 0.5;
  const double c = std::cos(angle), s = std::sin(angle);
  x = 0.5 + c * cx - s * cy;
  y = 0.5 + s * cx + c * cy;
  const double tipY = 0.06, baseY = 0.82;
  if (y >= baseY && y <= 0.97) return std::abs(x - 0.5) <= 0.018;  // stem
  if (y < tipY || y > baseY) return false;
  const double t = (y - tipY) / (baseY - tipY);  // 0 at the tip, 1 at the base
  double w = 0.36 * widthScale * std::pow(std::sin(std::numbers::pi * std::pow(t, 0.8)), 0.9);
  w *= 1.0 + 0.12 * std::sin(t * lobes * 2.0 * std::numbers::pi);
  return std::abs(x - 0.5) <= w;
}

}  // namespace

AlphaTexture makeDiscTexture(uint32_t size) {
  AlphaTexture t = blank(size);
  const double c = size / 2.0, r = size * 0.375;
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) {
      const double d = std::hypot(x + 0.5 - c, y + 0.5 - c);
      t.alpha[size_t(y) * size + x] = float(std::clamp(r - d + 0.5, 0.0, 1.0));
    }
  return t;
}

AlphaTexture makeNoiseTexture(uint32_t size, uint32_t seed, uint32_t cell) {
  AlphaTexture t = blank(size);
  if (cell == 0) cell = 1;
  const uint32_t n = std::max<uint32_t>(1, (size + cell - 1) / cell);
  std::vector<float> lattice(size_t(n) * n);
  Rng rng(seed);
  for (float& v : lattice) v = rng.uniform();
  auto L = [&](uint32_t i, uint32_t j) { return lattice[size_t(j % n) * n + (i % n)]; };
  auto smooth = [](double f) { return f * f * (3.0 - 2.0 * f); };
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) {
      const double fx = (x + 0.5) / cell - 0.5, fy = (y + 0.5) / cell - 0.5;
      const double gx = std::floor(fx), gy = std::floor(fy);
      const double ax = smooth(fx - gx), ay = smooth(fy - gy);
      const uint32_t i = uint32_t(int64_t(gx) + n), j = uint32_t(int64_t(gy) + n);
      const double top = L(i, j) * (1 - ax) + L(i + 1, j) * ax;
      const double bot = L(i, j + 1) * (1 - ax) + L(i + 1, j + 1) * ax;
      t.alpha[size_t(y) * size + x] = float(std::clamp(top * (1 - ay) + bot * ay, 0.0, 1.0));
    }
  return t;
}

AlphaTexture makeCheckerTexture(uint32_t size, uint32_t cell) {
  AlphaTexture t = blank(size);
  if (cell == 0) cell = 1;
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x)
      t.alpha[size_t(y) * size + x] = ((x / cell + y / cell) % 2 == 0) ? 1.0f : 0.0f;
  return t;
}

AlphaTexture makeSpeckTexture(uint32_t size, uint32_t count, uint32_t seed) {
  AlphaTexture t = blank(size);
  const uint64_t total = uint64_t(size) * size;
  count = uint32_t(std::min<uint64_t>(count, total));
  Rng rng(seed);
  uint32_t placed = 0;
  while (placed < count) {
    const uint64_t i = rng.next() % total;
    if (t.alpha[i] == 0.0f) {
      t.alpha[i] = 1.0f;
      ++placed;
    }
  }
  return t;
}

AlphaTexture makeStripeTexture(uint32_t size, uint32_t period) {
  AlphaTexture t = blank(size);
  if (period < 2) period = 2;
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x)
      t.alpha[size_t(y) * size + x] = (x % period) < period / 2 ? 1.0f : 0.0f;
  return t;
}

AlphaTexture makeLeafTexture(uint32_t size) {
  AlphaTexture t = blank(size);
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x)
      t.alpha[size_t(y) * size + x] =
          insideLeaf((x + 0.5) / size, (y + 0.5) / size, 1.0, 3.0, 0.0) ? 1.0f : 0.0f;
  return t;
}

AlphaTexture makeLeafAtlasTexture(uint32_t size) {
  AlphaTexture t = blank(size);
  const uint32_t h = std::max<uint32_t>(1, size / 2);
  const double widths[4] = {1.0, 0.7, 1.2, 0.85}, lobes[4] = {3.0, 5.0, 2.0, 7.0},
               angles[4] = {0.0, 0.35, -0.3, 0.15};
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) {
      const uint32_t qx = std::min<uint32_t>(x / h, 1), qy = std::min<uint32_t>(y / h, 1), q = qy * 2 + qx;
      const double lx = (x - qx * h + 0.5) / h, ly = (y - qy * h + 0.5) / h;
      t.alpha[size_t(y) * size + x] = insideLeaf(lx, ly, widths[q], lobes[q], angles[q]) ? 1.0f : 0.0f;
    }
  return t;
}

Scene makeQuadScene(std::shared_ptr<const AlphaTexture> texture, Sampler sampler, float cutoff,
                    std::array<float, 4> uvRect) {
  Scene s;
  s.sourcePath = "procedural:quad";
  Material m;
  m.name = "quad";
  m.alphaMode = AlphaMode::Mask;
  m.alphaCutoff = cutoff;
  m.doubleSided = true;
  m.alpha = std::move(texture);
  m.sampler = sampler;
  m.alphaSource = "procedural";
  s.materials.push_back(std::move(m));
  Geometry g;
  g.name = "quad";
  const float u0 = uvRect[0], v0 = uvRect[1], u1 = uvRect[2], v1 = uvRect[3];
  // 0 top-left, 1 bottom-left, 2 bottom-right, 3 top-right.
  g.positions = {-1, 1, 0, -1, -1, 0, 1, -1, 0, 1, 1, 0};
  g.uvs = {u0, v0, u0, v1, u1, v1, u1, v0};
  g.indices = {0, 1, 2, 0, 2, 3};
  s.geometries.push_back(std::move(g));
  s.instances.push_back(Instance{});  // geometry 0, identity transform
  Camera cam;
  cam.eye = {0, 0, 2.5f};
  cam.target = {0, 0, 0};
  s.camera = cam;
  return s;
}

Scene makeLeafCardScene(uint32_t cards, uint32_t seed, uint32_t atlasSize) {
  Scene s;
  s.sourcePath = "procedural:leaf-cards";
  Material m;
  m.name = "leaf";
  m.alphaMode = AlphaMode::Mask;
  m.alphaCutoff = 0.5f;
  m.doubleSided = true;
  m.alpha = std::make_shared<const AlphaTexture>(makeLeafAtlasTexture(atlasSize));
  m.sampler = Sampler{Wrap::Repeat, Wrap::Repeat, Filter::Linear};
  m.alphaSource = "procedural leaf atlas";
  s.materials.push_back(std::move(m));
  Geometry g;
  g.name = "cards";
  g.positions.reserve(size_t(cards) * 12);
  g.uvs.reserve(size_t(cards) * 8);
  g.indices.reserve(size_t(cards) * 6);
  Rng rng(seed);
  for (uint32_t c = 0; c < cards; ++c) {
    const float cx = rng.uniform(-1, 1), cy = rng.uniform(-1, 1), cz = rng.uniform(-1, 1);
    // Random unit normal (rejection-free: uniform z and angle), then an orthonormal tangent frame rotated
    // randomly.
    const float nz = rng.uniform(-1, 1), phi = rng.uniform(0, 2 * std::numbers::pi_v<float>);
    const float r = std::sqrt(std::max(0.0f, 1 - nz * nz));
    const float n[3] = {r * std::cos(phi), r * std::sin(phi), nz};
    float a[3] = {0, 0, 0};
    if (std::abs(n[0]) < 0.9f)
      a[0] = 1;
    else
      a[1] = 1;
    // t = normalize(a - n (a·n)), b = n × t
    const float d = a[0] * n[0] + a[1] * n[1] + a[2] * n[2];
    float t[3] = {a[0] - n[0] * d, a[1] - n[1] * d, a[2] - n[2] * d};
    const float tl = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    for (float& v : t) v /= tl;
    const float b[3] = {n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]};
    const float psi = rng.uniform(0, 2 * std::numbers::pi_v<float>);
    const float cp = std::cos(psi), sp = std::sin(psi);
    float ex[3], ey[3];
    for (int k = 0; k < 3; ++k) {
      ex[k] = cp * t[k] + sp * b[k];
      ey[k] = -sp * t[k] + cp * b[k];
    }
    const float half = 0.5f * rng.uniform(0.25f, 0.6f);
    const uint32_t q = rng.below(4);
    const float qu = 0.5f * float(q % 2), qv = q >= 2 ? 0.5f : 0.0f;
    float uv[4];
    uv[0] = qu + rng.uniform(-0.025f, 0.025f);
    uv[1] = qv + rng.uniform(-0.025f, 0.025f);
    uv[2] = qu + 0.5f + rng.uniform(-0.025f, 0.025f);
    uv[3] = qv + 0.5f + rng.uniform(-0.025f, 0.025f);
    const uint32_t base = uint32_t(g.positions.size() / 3);
    const float corner[4][2] = {
        {-1, 1}, {-1, -1}, {1, -1}, {1, 1}};  // top-left, bottom-left, bottom-right, top-right
    for (int k = 0; k < 4; ++k) {
      const float sx = corner[k][0] * half, sy = corner[k][1] * half;
      g.positions.insert(g.positions.end(), {cx + sx * ex[0] + sy * ey[0], cy + sx * ex[1] + sy * ey[1],
                                             cz + sx * ex[2] + sy * ey[2]});
      g.uvs.insert(g.uvs.end(), {corner[k][0] < 0 ? uv[0] : uv[2], corner[k][1] > 0 ? uv[1] : uv[3]});
    }
    g.indices.insert(g.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
  s.geometries.push_back(std::move(g));
  s.instances.push_back(Instance{});  // geometry 0, identity transform
  Camera cam;
  cam.eye = {0, 0, 3.5f};
  cam.target = {0, 0, 0};
  s.camera = cam;
  return s;
}

}  // namespace somm
