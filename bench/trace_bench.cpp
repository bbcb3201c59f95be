// SPDX-License-Identifier: MIT
// Rays/s per any-hit method on a procedural layered leaf-card scene (many overlapping alpha-tested quads), as
// ratios to `texture` measured interleaved in the same run. Every method's image is checked against texture:
// 4-state methods and the bitmask must be pixel-identical (SkipWithError otherwise); 2-state and opaque
// report the % of pixels differing.
#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "somm/bake.h"
#include "somm/trace.h"
#include "trace/trace_scenes.h"

namespace {

constexpr uint32_t kCards = 6000, kTexture = 1024, kLevel = 8;

struct TraceBench {
  std::shared_ptr<const somm::TraceWorld> world;
  somm::MicromapSet micromaps;
  somm::RenderSettings settings;
  std::unique_ptr<somm::Tracer> texture;
  somm::RenderResult reference;
};

TraceBench& bench() {
  static TraceBench b = [] {
    TraceBench b;
    b.world = somm::TraceWorld::create(std::make_shared<const somm::Scene>(somm::testing::makeCardScene(
                                           kCards, 1, kTexture, /*specks=*/false)))
                  .value();
    // Micromaps from the baker (somm_bake), 4-state and 2-state.
    for (somm::Format f : {somm::Format::FourState, somm::Format::TwoState}) {
      somm::BakeOptions o;
      o.level = kLevel;
      o.format = f;
      auto arrays = std::make_shared<somm::OmmArrays>();
      for (const somm::Geometry& g : b.world->scene().geometries)
        arrays->push_back(somm::bakeGeometry(g, b.world->scene().materials[g.material], o).value().array);
      (f == somm::Format::FourState ? b.micromaps.flat4 : b.micromaps.flat2) = arrays;
    }
    b.micromaps.bitmaskLevel = kLevel;
    b.settings.width = 320;
    b.settings.height = 240;
    b.settings.threads = 1;  // stable timings; the ratios are what matter
    b.texture = somm::makeTextureTracer(b.world).value();
    b.reference = b.texture->render(b.settings);
    return b;
  }();
  return b;
}

void runMethod(benchmark::State& state, const std::string& name) {
  TraceBench& b = bench();
  auto spec = somm::parseMethod(name);
  if (!spec) return state.SkipWithError(spec.error().message.c_str());
  auto made = somm::makeTracer(b.world, *spec, b.micromaps);
  if (!made) return state.SkipWithError(made.error().message.c_str());
  std::unique_ptr<somm::Tracer> tracer = std::move(made).value();
  const bool exact = spec->kind == somm::MethodKind::Texture || spec->kind == somm::MethodKind::Bitmask ||
                     (spec->kind == somm::MethodKind::Omm && spec->format == somm::Format::FourState);
  double methodSeconds = 0, textureSeconds = 0, diff = 0;
  somm::TraceCounters counters;
  for (auto _ : state) {
    const somm::RenderResult r = tracer->render(b.settings);
    const somm::RenderResult t = b.texture->render(b.settings);  // interleaved baseline
    state.SetIterationTime(r.seconds);
    methodSeconds += r.seconds;
    textureSeconds += t.seconds;
    counters = r.counters;
    diff = somm::percentPixelsDiffering(r.image, b.reference.image);
    if (exact && diff != 0.0) return state.SkipWithError((name + ": image differs from texture").c_str());
    if (r.counters.primaryRays != b.reference.counters.primaryRays)
      return state.SkipWithError("different ray count");
  }
  const double rays = double(counters.rays());
  state.counters["Mrays_s"] = rays * double(state.iterations()) / methodSeconds / 1e6;
  state.counters["vs_texture"] = textureSeconds / methodSeconds;
  state.counters["filter_per_ray"] = double(counters.filterCalls) / rays;
  state.counters["tex_per_ray"] = double(counters.textureTests) / rays;
  state.counters["omm_bytes"] = double(tracer->micromapBytes());
  state.counters["pct_diff"] = diff;
}

const bool registered = [] {
  std::vector<std::string> methods = {"texture", "opaque", "bitmask"};
  for (const std::string& e : somm::traceEncodings()) {
    methods.push_back("omm4-" + e);
    methods.push_back("omm2-" + e);
  }
  for (const std::string& m : methods)
    benchmark::RegisterBenchmark(("Trace/cards/" + m).c_str(), [m](benchmark::State& s) { runMethod(s, m); })
        ->UseManualTime()
        ->Unit(benchmark::kMillisecond)
        ->MinTime(0.5);
  return true;
}();

}  // namespace
