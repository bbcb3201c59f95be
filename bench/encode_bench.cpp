// SPDX-License-Identifier: MIT
// ns per micromap lookup from random (u, v) hits over every micromap of a procedural leaf-card set, for every
// encoding at levels 4, 8 and 12 in both formats. Each benchmark checks all its answers against the flat OMM
// array first and reports its time and size as ratios to flat measured in the same run (counters x_flat and
// bytes_x_flat).
#include <benchmark/benchmark.h>
#include <time.h>

#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "somm/bake.h"
#include "somm/encode.h"
#include "somm/omm_array.h"
#include "somm/scene.h"

namespace {

using namespace somm;

// A leaf card: an elliptical leaf with a notch and veins, randomly placed, rotated and scaled in the
// triangle; 4-state maps mark micro-triangles within half a micro-triangle of the silhouette as unknown.
struct LeafShape {
  double cx, cy, a, b, angle;
  double field(double u, double v) const {
    const double c = std::cos(angle), s = std::sin(angle);
    const double x = (u - cx) * c + (v - cy) * s, y = -(u - cx) * s + (v - cy) * c;
    double f = 1.0 - (x * x) / (a * a) - (y * y) / (b * b);
    if (std::abs(y) < 0.004 * (1 + x / a)) f = std::min(f, -0.01);  // midrib
    if (x > 0.75 * a && std::abs(y) < 0.1 * b) f = -1.0;            // notch at the tip
    return f * a * b;
  }
};

Micromap leafMap(const LeafShape& shape, uint32_t level, Format format) {
  Micromap m(level, format);
  const uint32_t n = 1u << level;
  const double h = 1.0 / n;
  for (uint32_t iv = 0; iv < n; ++iv)
    for (uint32_t iu = 0; iu + iv < n; ++iu)
      for (uint32_t upper = 0; upper < 2 && iu + iv + upper < n; ++upper) {
        const double u = (iu + (upper ? 2.0 : 1.0) / 3.0) * h, v = (iv + (upper ? 2.0 : 1.0) / 3.0) * h;
        const double f = shape.field(u, v);
        State s = f > 0 ? State::Opaque : State::Transparent;
        if (format == Format::FourState && std::abs(f) < 0.02 * h)
          s = f > 0 ? State::UnknownOpaque : State::UnknownTransparent;
        m.set(detail::cellToIndex(iu, iv, upper, level), s);
      }
  return m;
}

struct Scene {
  OmmArray flat;
  std::vector<uint32_t> tri;
  std::vector<float> u, v;
  std::vector<State> want;
  double flatNs = 0;
  uint64_t flatBytes = 0;
};

// Thread CPU time in ns: the machine is shared, wall time would measure the neighbours.
double cpuNs() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e9 + double(t.tv_nsec);
}

template <class F>
double nsPerLookup(const Scene& s, F&& lookup) {
  double best = 1e30;
  for (int rep = 0; rep < 5; ++rep) {
    const double t0 = cpuNs();
    uint32_t sum = 0;
    for (size_t i = 0; i < s.tri.size(); ++i) sum += uint32_t(lookup(s.tri[i], s.u[i], s.v[i]));
    benchmark::DoNotOptimize(sum);
    best = std::min(best, (cpuNs() - t0) / double(s.tri.size()));
  }
  return best;
}

void addQueries(Scene& s, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> uf(0.f, 1.f);
  const size_t queries = 1 << 16;
  for (size_t q = 0; q < queries; ++q) {
    float u = uf(rng), v = uf(rng);
    if (u + v > 1.f) {
      u = 1.f - u;
      v = 1.f - v;
    }
    s.tri.push_back(uint32_t(rng() % s.flat.indices.size()));
    s.u.push_back(u);
    s.v.push_back(v);
    s.want.push_back(s.flat.stateUV(s.tri.back(), u, v));
  }
  const EncodedArray flat = EncodedArray::build(s.flat, Encoding::Flat).value();
  s.flatBytes = flat.byteSize();
  s.flatNs = nsPerLookup(s, [&](uint32_t t, float u, float v) { return flat.stateUVAs<Encoding::Flat>(t, u, v); });
}

// The bundled oak tree (data/oak-tree), baked at the level: its alpha-tested geometry with the most triangles.
// Empty when the scene cannot be loaded or baked.
const Scene& oakScene(uint32_t level, Format format) {
  static std::map<std::pair<uint32_t, Format>, Scene> cache;
  auto it = cache.find({level, format});
  if (it != cache.end()) return it->second;
  Scene s;
  auto scene = loadScene(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf");
  if (scene) {
    const Geometry* best = nullptr;
    for (const Geometry& g : scene->geometries)
      if (g.material < scene->materials.size() && scene->materials[g.material].alphaTested() &&
          (!best || g.triangleCount() > best->triangleCount()))
        best = &g;
    BakeOptions o;
    o.level = level;
    o.format = format;
    if (best)
      if (auto baked = bakeGeometry(*best, scene->materials[best->material], o)) s.flat = std::move(baked->array);
  }
  if (!s.flat.indices.empty()) addQueries(s, level * 5 + uint32_t(format));
  return cache.emplace(std::make_pair(level, format), std::move(s)).first->second;
}

// Leaf-card micromaps: 2048 at level 4, 256 at level 8, 12 at level 12 (flat: 64 KiB, 4 MiB and 24/48 MiB),
// each triangle with its own leaf; 1/8 of the triangles fully transparent or opaque (special indices).
const Scene& scene(uint32_t level, Format format) {
  static std::map<std::pair<uint32_t, Format>, Scene> cache;
  auto it = cache.find({level, format});
  if (it != cache.end()) return it->second;
  Scene s;
  std::mt19937 rng(level * 17 + uint32_t(format));
  std::uniform_real_distribution<double> d(0, 1);
  const uint32_t maps = level <= 4 ? 2048 : level <= 8 ? 256 : 12;
  OmmArrayBuilder b;
  for (uint32_t k = 0; k < maps; ++k) {
    if (k % 8 == 7) {
      b.addSpecial(k % 16 == 7 ? State::Transparent : State::Opaque);
      continue;
    }
    const LeafShape shape{0.25 + 0.15 * d(rng), 0.25 + 0.15 * d(rng), 0.18 + 0.12 * d(rng),
                          0.07 + 0.08 * d(rng), 6.283 * d(rng)};
    b.add(leafMap(shape, level, format));
  }
  s.flat = b.finish();
  addQueries(s, level * 3 + uint32_t(format));
  return cache.emplace(std::make_pair(level, format), std::move(s)).first->second;
}

template <Encoding E>
void runLookups(benchmark::State& state, const Scene& s, uint32_t level) {
  if (s.flat.indices.empty()) {
    state.SkipWithError("scene unavailable");
    return;
  }
  const EncodedArray e = EncodedArray::build(s.flat, E).value();
  // The paper's lookups cost ~4^level at level 12: time them on the first 4096 queries only.
  const size_t nq = (E == Encoding::Dfs || E == Encoding::DfsFast) && level == 12 ? 4096 : s.tri.size();
  for (size_t i = 0; i < nq; ++i)
    if (e.stateUVAs<E>(s.tri[i], s.u[i], s.v[i]) != s.want[i]) {
      state.SkipWithError("lookup differs from the flat OMM array");
      return;
    }
  const double t0 = cpuNs();
  uint64_t lookups = 0;
  for (auto _ : state) {
    uint32_t sum = 0;
    for (size_t i = 0; i < nq; ++i) sum += uint32_t(e.stateUVAs<E>(s.tri[i], s.u[i], s.v[i]));
    benchmark::DoNotOptimize(sum);
    lookups += nq;
  }
  const double ns = (cpuNs() - t0) / double(lookups ? lookups : 1);
  state.counters["ns_per_lookup"] = ns;
  state.counters["x_flat"] = ns / s.flatNs;
  state.counters["bytes"] = double(e.byteSize());
  state.counters["bytes_x_flat"] = double(e.byteSize()) / double(s.flatBytes);
}

template <Encoding E>
void BM_Lookup(benchmark::State& state) {
  const uint32_t level = uint32_t(state.range(0));
  runLookups<E>(state, scene(level, Format(state.range(1))), level);
}

template <Encoding E>
void BM_LookupOak(benchmark::State& state) {
  const uint32_t level = uint32_t(state.range(0));
  runLookups<E>(state, oakScene(level, Format(state.range(1))), level);
}

void levelsAndFormats(benchmark::internal::Benchmark* b) {
  for (int level : {4, 8, 12})
    for (int f : {1, 2}) b->Args({level, f});
  b->ArgNames({"level", "format"});
}

BENCHMARK(BM_Lookup<Encoding::Flat>)->Apply(levelsAndFormats);
BENCHMARK(BM_Lookup<Encoding::Dfs>)->Apply(levelsAndFormats);
BENCHMARK(BM_Lookup<Encoding::DfsFast>)->Apply(levelsAndFormats);
BENCHMARK(BM_Lookup<Encoding::Rank>)->Apply(levelsAndFormats);
BENCHMARK(BM_Lookup<Encoding::Hybrid>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Flat>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Dfs>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::DfsFast>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Rank>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Hybrid>)->Apply(levelsAndFormats);

}  // namespace
