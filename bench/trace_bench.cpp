// SPDX-License-Identifier: MIT
// Rays/s per any-hit method on a procedural layered leaf-card scene (many overlapping alpha-tested quads) and, when
// ../shared/assets/foliage is present (or $SOMM_FOLIAGE_DIR), on real foliage scenes with cameras into the foliage,
// as the median of per-run ratios to `texture` measured interleaved in the same run. filter_per_ray shows the
// special-index split of somm/embree.h (fully opaque / transparent triangles run no filter). Every method's
// image is checked against texture:
// 4-state methods and the bitmask must be pixel-identical (SkipWithError otherwise); 2-state and opaque
// report the % of pixels differing.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "somm/bake.h"
#include "somm/scene.h"
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
  std::string error;  // non-empty: the scene could not be prepared
};

// A scene of the benchmark: the procedural cards, or a real foliage scene (../shared/assets/foliage) with a camera
// that looks into the foliage.
struct BenchScene {
  std::string name, path;  // empty path: the procedural cards; a directory: its .obj files as one scene
  float cutoff = -1;       // < 0: the materials' own
  std::optional<somm::Camera> camera;
};

// The .obj files of a directory as one scene, side by side: each file's materials, geometries and instances
// appended (indices renumbered), its instances moved along x and y so that the models stand on a grid (cells of the
// largest model's extent in x and y, plus a quarter).
somm::Result<somm::Scene> loadDirectory(const std::string& dir) {
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (e.path().extension() == ".obj") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  std::vector<somm::Scene> parts;
  float cell = 0;
  for (const std::string& f : files) {
    auto loaded = somm::loadScene(f);
    if (!loaded) return loaded.error();
    float lo[2] = {1e30f, 1e30f}, hi[2] = {-1e30f, -1e30f};
    for (const somm::Geometry& g : loaded->geometries)
      for (size_t v = 0; v + 2 < g.positions.size(); v += 3)
        for (int a = 0; a < 2; ++a) {
          lo[a] = std::min(lo[a], g.positions[v + size_t(a)]);
          hi[a] = std::max(hi[a], g.positions[v + size_t(a)]);
        }
    cell = std::max({cell, hi[0] - lo[0], hi[1] - lo[1]});
    parts.push_back(std::move(loaded).value());
  }
  somm::Scene all;
  all.sourcePath = dir;
  const uint32_t columns = uint32_t(std::ceil(std::sqrt(double(parts.size()))));
  for (size_t k = 0; k < parts.size(); ++k) {
    somm::Scene& p = parts[k];
    const uint32_t materials = uint32_t(all.materials.size()), geometries = uint32_t(all.geometries.size());
    for (somm::Material& m : p.materials) all.materials.push_back(std::move(m));
    for (somm::Geometry& g : p.geometries) {
      g.material += materials;
      all.geometries.push_back(std::move(g));
    }
    for (somm::Instance inst : p.instances) {
      inst.geometry += geometries;
      inst.transform[12] += 1.25f * cell * float(k % columns);
      inst.transform[13] += 1.25f * cell * float(k / columns);
      all.instances.push_back(inst);
    }
  }
  return all;
}

std::string foliageDir() {
  const char* env = std::getenv("SOMM_FOLIAGE_DIR");
  const std::string dir = env && *env ? env : SOMM_FOLIAGE_DIR;
  return std::filesystem::is_directory(dir) ? dir : std::string();
}

std::vector<BenchScene> benchScenes() {
  std::vector<BenchScene> v = {{"cards", "", -1, std::nullopt}};
  const std::string dir = foliageDir();
  if (dir.empty()) return v;
  v.push_back({"torcs-forza", dir + "/torcs-forza/forza.obj", -1,
               somm::Camera{{450, 12, -860}, {348, 7, -868}, {0, 1, 0}, 1.05f}});
  v.push_back({"redeclipse-tree01", dir + "/redeclipse/obj/tree01.obj", 0.7f, std::nullopt});
  v.push_back({"flora-quarter", dir + "/zeroad/flora-quarter.obj", -1, std::nullopt});
  // The Red Eclipse models as one scene (a collection: 7,404 triangles, 182 maps at level 8); cutoff 0.7, the
  // manifest's for all but bush01 (0.6).
  v.push_back({"redeclipse", dir + "/redeclipse/obj", 0.7f, std::nullopt});
  return v;
}

TraceBench prepare(const BenchScene& sc) {
  TraceBench b;
  std::shared_ptr<const somm::Scene> scene;
  if (sc.path.empty()) {
    scene = std::make_shared<const somm::Scene>(
        somm::testing::makeCardScene(kCards, 1, kTexture, /*specks=*/false));
  } else {
    auto loaded = std::filesystem::is_directory(sc.path) ? loadDirectory(sc.path) : somm::loadScene(sc.path);
    if (!loaded) {
      b.error = loaded.error().message;
      return b;
    }
    if (sc.cutoff >= 0)
      for (somm::Material& m : loaded->materials) m.alphaCutoff = sc.cutoff;
    scene = std::make_shared<const somm::Scene>(std::move(loaded).value());
  }
  auto world = somm::TraceWorld::create(scene);
  if (!world) {
    b.error = world.error().message;
    return b;
  }
  b.world = *world;
  // Micromaps from the baker (somm_bake), 4-state and 2-state, in one scene-wide array.
  for (somm::Format f : {somm::Format::FourState, somm::Format::TwoState}) {
    somm::BakeOptions o;
    o.level = kLevel;
    o.format = f;
    std::vector<somm::OmmArray> arrays;
    for (const somm::Geometry& g : scene->geometries) {
      auto baked = somm::bakeGeometry(g, scene->materials[g.material], o);
      if (!baked) {
        b.error = baked.error().message;
        return b;
      }
      arrays.push_back(std::move(baked->array));
    }
    (f == somm::Format::FourState ? b.micromaps.flat4 : b.micromaps.flat2) =
        std::make_shared<const somm::SceneMicromaps>(
            somm::mergeToSceneArray(somm::perGeometryMicromaps(std::move(arrays))));
  }
  b.micromaps.bitmaskLevel = kLevel;
  b.settings.width = 320;
  b.settings.height = 240;
  b.settings.threads = 1;  // stable timings; the ratios are what matter
  b.settings.camera = sc.camera;
  b.texture = somm::makeTextureTracer(b.world).value();
  b.reference = b.texture->render(b.settings);
  if (b.reference.counters.alphaTestedPixels == 0)
    b.error = sc.name + ": the view hits no alpha-tested geometry";
  return b;
}

TraceBench& bench(const BenchScene& sc) {
  static std::map<std::string, TraceBench> cache;
  auto it = cache.find(sc.name);
  if (it == cache.end()) it = cache.emplace(sc.name, prepare(sc)).first;
  return it->second;
}

void runMethod(benchmark::State& state, const BenchScene& sc, const std::string& name) {
  TraceBench& b = bench(sc);
  if (!b.error.empty()) return state.SkipWithError(b.error.c_str());
  auto spec = somm::parseMethod(name);
  if (!spec) return state.SkipWithError(spec.error().message.c_str());
  // The bitmask needs N²/4 bytes per triangle: skip it where that exceeds 1 GB.
  if (spec->kind == somm::MethodKind::Bitmask &&
      b.world->alphaTestedTriangles() * (1ull << (2 * kLevel)) / 4 > (1ull << 30))
    return state.SkipWithError("bitmask: more than 1 GB of masks");
  auto made = somm::makeTracer(b.world, *spec, b.micromaps);
  if (!made) return state.SkipWithError(made.error().message.c_str());
  std::unique_ptr<somm::Tracer> tracer = std::move(made).value();
  const bool exact = spec->kind == somm::MethodKind::Texture || spec->kind == somm::MethodKind::Bitmask ||
                     (spec->kind == somm::MethodKind::Omm && spec->format == somm::Format::FourState);
  std::vector<double> ratios;
  double methodSeconds = 0, diff = 0;
  somm::TraceCounters counters;
  for (auto _ : state) {
    const somm::RenderResult r = tracer->render(b.settings);
    const somm::RenderResult t = b.texture->render(b.settings);  // interleaved baseline
    state.SetIterationTime(r.seconds);
    methodSeconds += r.seconds;
    ratios.push_back(r.seconds > 0 ? t.seconds / r.seconds : 0.0);
    counters = r.counters;
    diff = somm::percentPixelsDiffering(r.image, b.reference.image);
    if (exact && diff != 0.0) return state.SkipWithError((name + ": image differs from texture").c_str());
    if (r.counters.primaryRays != b.reference.counters.primaryRays)
      return state.SkipWithError("different ray count");
  }
  std::sort(ratios.begin(), ratios.end());
  const double rays = double(counters.rays());
  state.counters["Mrays_s"] = rays * double(state.iterations()) / methodSeconds / 1e6;
  state.counters["vs_texture"] =
      ratios.empty() ? 0.0 : ratios[ratios.size() / 2];  // median of per-run ratios
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
  for (const BenchScene& sc : benchScenes())
    for (const std::string& m : methods)
      benchmark::RegisterBenchmark(("Trace/" + sc.name + "/" + m).c_str(),
                                   [sc, m](benchmark::State& s) { runMethod(s, sc, m); })
          ->UseManualTime()
          ->Unit(benchmark::kMillisecond)
          ->MinTime(0.5);
  return true;
}();

}  // namespace
