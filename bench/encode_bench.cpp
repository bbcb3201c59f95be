// SPDX-License-Identifier: MIT
// ns per micromap lookup from random (u, v) hits over every micromap of a procedural leaf-card set, for every
// encoding at levels 4, 8 and 12 in both formats. Each benchmark checks all its answers against the flat OMM
// array first and reports its time and size as ratios to flat measured in the same run (counters x_flat and
// bytes_x_flat).
#include <benchmark/benchmark.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "reference_compressors.h"
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
  s.flatNs =
      nsPerLookup(s, [&](uint32_t t, float u, float v) { return flat.stateUVAs<Encoding::Flat>(t, u, v); });
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
      if (auto baked = bakeGeometry(*best, scene->materials[best->material], o))
        s.flat = std::move(baked->array);
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
  const size_t nq = (E == Encoding::Dfs || E == Encoding::DfsFast) && level >= 10 ? 4096 : s.tri.size();
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

// ---- real foliage (../shared/assets/foliage, or $SOMM_FOLIAGE_DIR): one scene-wide array per scene ----
//
// Every geometry baked with the library baker at the level (4-state), merged into one scene-wide array
// (mergeToSceneArray, as the default bake stores it), then every encoding of that array: bytes and their ratios
// to flat, dfs, csm and xz -9 of the flat array, and ns per random lookup against flat in the same run.
// Skipped when the assets are absent.

std::string foliageDir() {
  const char* env = std::getenv("SOMM_FOLIAGE_DIR");
  return env ? env : SOMM_FOLIAGE_DIR;
}

// 0: torcs-forza/forza.obj, 1: zeroad/flora-quarter.obj, 2: every redeclipse/obj/*.obj as one scene.
std::vector<std::string> realSceneFiles(int which) {
  const std::string d = foliageDir();
  if (which == 0) return {d + "/torcs-forza/forza.obj"};
  if (which == 1) return {d + "/zeroad/flora-quarter.obj"};
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(d + "/redeclipse/obj", ec))
    if (e.path().extension() == ".obj") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

struct RealScene : Scene {
  uint64_t dfsBytes = 0, csmBytes = 0, xzBytes = 0;
};

const RealScene& realScene(int which, uint32_t level) {
  static std::map<std::pair<int, uint32_t>, RealScene> cache;
  auto it = cache.find({which, level});
  if (it != cache.end()) return it->second;
  RealScene s;
  std::vector<OmmArray> perGeometry;
  bool ok = true;
  for (const std::string& file : realSceneFiles(which)) {
    if (!std::filesystem::exists(file)) {
      ok = false;
      break;
    }
    auto scene = loadScene(file);
    if (!scene) {
      ok = false;
      break;
    }
    BakeOptions o;
    o.level = level;
    o.format = Format::FourState;
    for (const Geometry& g : scene->geometries) {
      if (g.material >= scene->materials.size()) continue;
      auto baked = bakeGeometry(g, scene->materials[g.material], o);
      if (!baked) {
        ok = false;
        break;
      }
      perGeometry.push_back(std::move(baked->array));
    }
  }
  if (ok && !perGeometry.empty()) {
    SceneMicromaps sm = mergeToSceneArray(perGeometryMicromaps(std::move(perGeometry)));
    s.flat = std::move(sm.arrays[0]);
    s.dfsBytes = EncodedArray::build(s.flat, Encoding::Dfs).value().byteSize();
    s.csmBytes = EncodedArray::build(s.flat, Encoding::Csm).value().byteSize();
    s.xzBytes = somm::cli::xzBytes(EncodedArray::build(s.flat, Encoding::Flat).value().serialize());
    // Queries on triangles that have a micromap.
    std::vector<uint32_t> withMap;
    for (uint32_t t = 0; t < s.flat.indices.size(); ++t)
      if (s.flat.indices[t] >= 0) withMap.push_back(t);
    if (!withMap.empty()) {
      std::mt19937 rng(level * 11 + uint32_t(which));
      std::uniform_real_distribution<float> uf(0.f, 1.f);
      for (size_t q = 0; q < (1u << 16); ++q) {
        float u = uf(rng), v = uf(rng);
        if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
        s.tri.push_back(withMap[rng() % withMap.size()]);
        s.u.push_back(u);
        s.v.push_back(v);
        s.want.push_back(s.flat.stateUV(s.tri.back(), u, v));
      }
      const EncodedArray flat = EncodedArray::build(s.flat, Encoding::Flat).value();
      s.flatBytes = flat.byteSize();
      s.flatNs = nsPerLookup(
          s, [&](uint32_t t, float u, float v) { return flat.stateUVAs<Encoding::Flat>(t, u, v); });
    }
  }
  if (s.tri.empty()) s.flat = OmmArray{};
  return cache.emplace(std::make_pair(which, level), std::move(s)).first->second;
}

template <Encoding E>
void BM_LookupFoliage(benchmark::State& state) {
  const uint32_t level = uint32_t(state.range(1));
  const RealScene& s = realScene(int(state.range(0)), level);
  if (s.flat.indices.empty()) {
    state.SkipWithError("foliage scene unavailable (set SOMM_FOLIAGE_DIR)");
    return;
  }
  runLookups<E>(state, s, level);
  const double bytes = state.counters["bytes"];
  state.counters["bytes_x_dfs"] = bytes / double(s.dfsBytes);
  state.counters["bytes_x_csm"] = bytes / double(s.csmBytes);
  state.counters["bytes_x_xz"] = bytes / double(s.xzBytes);
  state.counters["maps"] = double(s.flat.descriptors.size());
}

// Scenes 0 (TORCS forza), 1 (0 A.D. flora), 2 (Red Eclipse, 18 models) at levels 8, 10, 12 (4-state). Levels
// above 8 bake every map at that level: the 0 A.D. and TORCS scenes (thousands of maps) only at 8.
void foliageArgs(benchmark::internal::Benchmark* b) {
  for (int scene : {0, 1, 2})
    for (int level : {8, 10, 12})
      if (level == 8 || scene == 2) b->Args({scene, level});
  b->ArgNames({"scene", "level"});
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
BENCHMARK(BM_Lookup<Encoding::Csm>)->Apply(levelsAndFormats);
BENCHMARK(BM_Lookup<Encoding::Sdag>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Flat>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Dfs>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::DfsFast>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Rank>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Hybrid>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Csm>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupOak<Encoding::Sdag>)->Apply(levelsAndFormats);
BENCHMARK(BM_LookupFoliage<Encoding::Flat>)->Apply(foliageArgs)->Iterations(3);
BENCHMARK(BM_LookupFoliage<Encoding::Dfs>)->Apply(foliageArgs)->Iterations(1);
BENCHMARK(BM_LookupFoliage<Encoding::DfsFast>)->Apply(foliageArgs)->Iterations(1);
BENCHMARK(BM_LookupFoliage<Encoding::Rank>)->Apply(foliageArgs)->Iterations(3);
BENCHMARK(BM_LookupFoliage<Encoding::Hybrid>)->Apply(foliageArgs)->Iterations(3);
BENCHMARK(BM_LookupFoliage<Encoding::Csm>)->Apply(foliageArgs)->Iterations(3);
BENCHMARK(BM_LookupFoliage<Encoding::Sdag>)->Apply(foliageArgs)->Iterations(3);

}  // namespace
