// SPDX-License-Identifier: MIT
// Baker throughput: micro-triangles per second, single-threaded and with all threads, on a procedural foliage
// scene (random UV triangles over a leaf-atlas texture). Every run is checked byte-for-byte against a
// single-threaded bake; the multi-threaded benchmark reports its speed-up over the single-threaded reference
// bake of the same run.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <thread>

#include "somm/bake.h"

namespace {

struct BenchScene {
  somm::Geometry geometry;
  somm::Material material;
  somm::BakedGeometry reference;  // single-threaded bake
  double referenceSeconds = 0;
};

// A 1024×1024 atlas of 4×4 leaves: ellipses with a serrated rim and a soft 2-texel alpha ramp.
std::shared_ptr<somm::AlphaTexture> leafAtlas() {
  auto t = std::make_shared<somm::AlphaTexture>();
  t->width = t->height = 1024;
  t->alpha.resize(size_t(1024) * 1024);
  for (uint32_t y = 0; y < 1024; ++y)
    for (uint32_t x = 0; x < 1024; ++x) {
      const double cx = (x % 256) + 0.5 - 128, cy = (y % 256) + 0.5 - 128;
      const double a = std::atan2(cy, cx), r = std::sqrt(cx * cx / (100.0 * 100.0) + cy * cy / (60.0 * 60.0));
      const double rim = 1.0 + 0.08 * std::sin(a * 14 + (x / 256) * 1.7 + (y / 256));
      t->alpha[size_t(y) * 1024 + x] = float(std::clamp((rim - r) * 50.0 + 0.5, 0.0, 1.0));
    }
  return t;
}

const BenchScene& scene() {
  static const BenchScene s = [] {
    BenchScene s;
    s.material.name = "leaves";
    s.material.alphaMode = somm::AlphaMode::Mask;
    s.material.sampler = somm::Sampler{somm::Wrap::Repeat, somm::Wrap::Repeat, somm::Filter::Linear};
    s.material.alpha = leafAtlas();
    std::mt19937 rng(2024);
    std::uniform_real_distribution<float> pos(0.f, 1.f), size(0.005f, 0.06f), ang(0.f, 6.2831853f);
    const uint32_t n = 100000;
    for (uint32_t t = 0; t < n; ++t) {
      const float cx = pos(rng), cy = pos(rng), r = size(rng), a = ang(rng);
      for (int k = 0; k < 3; ++k) {
        const float b = a + 2.0943951f * float(k) + 0.3f * pos(rng);
        s.geometry.uvs.push_back(cx + r * std::cos(b));
        s.geometry.uvs.push_back(cy + r * std::sin(b));
        s.geometry.positions.insert(s.geometry.positions.end(), {0, 0, 0});
        s.geometry.indices.push_back(3 * t + uint32_t(k));
      }
    }
    somm::BakeOptions o;
    o.level = 8;
    o.threads = 1;
    const auto t0 = std::chrono::steady_clock::now();
    auto r = somm::bakeGeometry(s.geometry, s.material, o);
    s.referenceSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (r.ok()) s.reference = std::move(r.value());
    return s;
  }();
  return s;
}

void BM_Bake_Level8(benchmark::State& state) {
  const BenchScene& s = scene();
  if (s.reference.array.indices.empty()) {
    state.SkipWithError("reference bake failed");
    return;
  }
  somm::BakeOptions o;
  o.level = 8;
  o.threads = uint32_t(state.range(0));
  double seconds = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    auto r = somm::bakeGeometry(s.geometry, s.material, o);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!r.ok() || r->array.data != s.reference.array.data || r->array.indices != s.reference.array.indices ||
        r->array.descriptors != s.reference.array.descriptors) {
      state.SkipWithError("bake differs from the single-threaded reference bake");
      return;
    }
  }
  const double micro = double(s.reference.stats.microTriangles);
  state.counters["Mmicrotri_per_s"] =
      benchmark::Counter(micro * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["speedup_vs_1thread"] = s.referenceSeconds / (seconds / double(state.iterations()));
  state.counters["unknown_pct"] = 100.0 * s.reference.stats.unknownFraction();
  state.counters["unique_maps"] = double(s.reference.stats.uniqueMaps);
  state.SetLabel("100k tris, level 8, threads " +
                 std::to_string(o.threads ? o.threads : std::thread::hardware_concurrency()));
}

BENCHMARK(BM_Bake_Level8)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

}  // namespace
