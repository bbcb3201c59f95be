// SPDX-License-Identifier: MIT
// ns per index: ours scalar, ours batch, the paper's descent and the Vulkan reference, at levels 4, 8, 12.
// Each benchmark checks its results against the reference before timing.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <random>
#include <vector>

#include "bird_reference.h"
#include "somm/bird.h"

namespace {

struct Points {
  std::vector<float> u, v;
  std::vector<uint32_t> want[13];
};

const Points& points() {
  static const Points p = [] {
    Points p;
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> d(0.f, 1.f);
    const size_t n = 1 << 16;
    for (size_t i = 0; i < n; ++i) {
      float a = d(rng), b = d(rng);
      if (a + b > 1.f) {
        a = 1.f - a;
        b = 1.f - b;
      }
      p.u.push_back(a);
      p.v.push_back(b);
    }
    for (uint32_t l = 0; l <= 12; ++l)
      for (size_t i = 0; i < n; ++i)
        p.want[l].push_back(somm::reference::BarycentricsToSpaceFillingCurveIndex(p.u[i], p.v[i], l));
    return p;
  }();
  return p;
}

template <uint32_t (*F)(float, float, uint32_t)>
void runScalar(benchmark::State& state) {
  const Points& p = points();
  const uint32_t level = uint32_t(state.range(0));
  for (size_t i = 0; i < p.u.size(); ++i)
    if (F(p.u[i], p.v[i], level) != p.want[level][i]) {
      state.SkipWithError("result differs from the Vulkan reference");
      return;
    }
  std::vector<uint32_t> out(p.u.size());
  for (auto _ : state) {
    for (size_t i = 0; i < p.u.size(); ++i) out[i] = F(p.u[i], p.v[i], level);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(p.u.size()));
  state.counters["ns_per_index"] = benchmark::Counter(
      double(p.u.size()), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

uint32_t reference(float u, float v, uint32_t l) {
  return somm::reference::BarycentricsToSpaceFillingCurveIndex(u, v, l);
}
uint32_t ours(float u, float v, uint32_t l) {
  return somm::baryToIndex(u, v, l);
}
uint32_t descent(float u, float v, uint32_t l) {
  return somm::baryToIndexDescent(u, v, l);
}

void BM_Index_Reference(benchmark::State& s) {
  runScalar<reference>(s);
}
void BM_Index_Ours(benchmark::State& s) {
  runScalar<ours>(s);
}
void BM_Index_PaperDescent(benchmark::State& s) {
  runScalar<descent>(s);
}

void BM_Index_OursBatch(benchmark::State& state) {
  const Points& p = points();
  const uint32_t level = uint32_t(state.range(0));
  const auto isa = somm::BatchIsa(state.range(1));
  if (!somm::batchIsaSupported(isa)) {
    state.SkipWithError("instruction set not supported on this CPU");
    return;
  }
  std::vector<uint32_t> out(p.u.size());
  somm::baryToIndexBatch(isa, p.u.data(), p.v.data(), p.u.size(), level, out.data());
  if (out != p.want[level]) {
    state.SkipWithError("batch result differs from the Vulkan reference");
    return;
  }
  for (auto _ : state) {
    somm::baryToIndexBatch(isa, p.u.data(), p.v.data(), p.u.size(), level, out.data());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(p.u.size()));
  state.counters["ns_per_index"] = benchmark::Counter(
      double(p.u.size()), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.SetLabel(somm::batchIsaName(isa));
}

BENCHMARK(BM_Index_Reference)->Arg(4)->Arg(8)->Arg(12);
BENCHMARK(BM_Index_Ours)->Arg(4)->Arg(8)->Arg(12);
BENCHMARK(BM_Index_OursBatch)->ArgsProduct({{4, 8, 12}, {1, 2, 3}});
BENCHMARK(BM_Index_PaperDescent)->Arg(4)->Arg(8)->Arg(12);

}  // namespace
