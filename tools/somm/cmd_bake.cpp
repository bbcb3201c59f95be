// SPDX-License-Identifier: MIT
// somm bake SCENE -o OUT.somm [...]: conservative OMM baking of every geometry of a glTF / OBJ scene into a
// .somm file.
#include <tbb/global_control.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <new>
#include <optional>
#include <string>

#include "command.h"
#include "encodings.h"
#include "file_summary.h"
#include "limits_cli.h"
#include "somm/bake.h"
#include "somm/gltf.h"
#include "somm/io.h"
#include "somm/scene.h"
#include "somm/somm_file.h"

namespace {

// -j's cap on TBB's threads (0: none). It lives to the process's exit, not to the end of the command: destroying a
// global_control lifts the limit and TBB starts a thread to resize its pool, one thread created for nothing at the
// end of every `somm bake -j N`. A later call with another value replaces it.
void capThreads(size_t threads) {
  alignas(tbb::global_control) static unsigned char storage[sizeof(tbb::global_control)];
  static tbb::global_control* cap = nullptr;
  static size_t capped = 0;
  if (cap && capped == threads) return;
  if (cap) {
    cap->~global_control();
    cap = nullptr;
  }
  if (threads) cap = new (storage) tbb::global_control(tbb::global_control::max_allowed_parallelism, threads);
  capped = threads;
}

struct Options {
  std::string scene, output;
  std::optional<uint32_t> level, maxLevel;
  std::optional<float> texelsPerMicroTri;
  uint32_t format = 4;
  somm::cli::MaterialOverrides material;  // --filter, --cutoff, --blend-as-mask
  std::string unknownAs = "majority";
  uint64_t maxBytes = 0;
  bool estimate = false;
  uint32_t threads = 0;
  bool json = false;
  std::string encodings;            // --encoding: comma list or "all" (flat is always stored)
  std::vector<std::string> limits;  // --limit NAME=VALUE
  std::string arrays = "scene";     // --arrays: one scene-wide OMM array, or one per geometry
};

std::string floatText(double f) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", f);
  return buf;
}

// A progress bar on stderr: only on a terminal, and only once the bake has run for a second.
class Progress {
 public:
  Progress() : tty_(::isatty(STDERR_FILENO) == 1), t0_(std::chrono::steady_clock::now()) {}
  ~Progress() { finish(); }
  void update(double fraction) {
    if (!tty_) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - t0_ < std::chrono::seconds(1)) return;
    if (drawn_ && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    drawn_ = true;
    fraction = std::clamp(fraction, 0.0, 1.0);
    const int width = 40, filled = int(fraction * width);
    std::string bar(size_t(filled), '#');
    bar.append(size_t(width - filled), '.');
    std::fprintf(stderr, "\rsomm bake: [%s] %3d%%", bar.c_str(), int(fraction * 100.0));
    std::fflush(stderr);
  }
  void finish() {
    if (drawn_) std::fprintf(stderr, "\r%60s\r", "");
    drawn_ = false;
  }

 private:
  bool tty_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point t0_, last_;
};

// A library message names BakeOptions fields ("level 13 is out of range (0..12)"); the CLI names its flags.
std::string flagNames(const std::string& message) {
  static const std::pair<const char*, const char*> kFlags[] = {
      {"level ", "--level "},
      {"maxLevel ", "--max-level "},
      {"texelsPerMicroTri ", "--texels-per-microtri "},
      {"format ", "--format "},
      {"cutoff ", "--cutoff "},
      {"unknownAs ", "--unknown-as "}};
  for (const auto& [field, flag] : kFlags)
    if (message.rfind(field, 0) == 0) return flag + message.substr(std::string(field).size());
  return message;
}

int run(const Options& o) {
  using namespace somm::cli;
  std::vector<somm::Encoding> encodings;
  if (!o.encodings.empty()) {
    auto list = somm::parseEncodingList(o.encodings);
    if (!list) {
      printError("bake", "--encoding: " + list.error().message);
      return kExitUsage;
    }
    encodings = *list;
  }
  const auto t0 = std::chrono::steady_clock::now();
  // ---- options ----
  auto usage = [](const std::string& m) {
    printError("bake", m);
    return kExitUsage;
  };
  somm::BakeOptions bo;
  if (o.level && (o.maxLevel || o.texelsPerMicroTri))
    return usage("--level cannot be combined with --max-level / --texels-per-microtri");
  if (o.maxLevel.has_value() != o.texelsPerMicroTri.has_value())
    return usage("--max-level and --texels-per-microtri go together (adaptive levels)");
  if (o.texelsPerMicroTri && !(*o.texelsPerMicroTri > 0 && std::isfinite(*o.texelsPerMicroTri)))
    return usage("--texels-per-microtri must be a finite number > 0");
  if (!applyMaterialOverrides("bake", o.material, bo)) return kExitUsage;
  if (!o.estimate && o.output.empty()) return usage("-o OUT.somm is required (or --estimate)");
  bo.level = o.level.value_or(6);
  if (o.maxLevel) {
    bo.maxLevel = *o.maxLevel;
    bo.texelsPerMicroTri = *o.texelsPerMicroTri;
  }
  bo.format = o.format == 2 ? somm::Format::TwoState : somm::Format::FourState;
  bo.unknownAs = o.unknownAs == "opaque"        ? somm::UnknownAs::Opaque
                 : o.unknownAs == "transparent" ? somm::UnknownAs::Transparent
                                                : somm::UnknownAs::Majority;
  bo.maxBytes = o.maxBytes;
  bo.threads = o.threads;
  if (somm::Status s = somm::validateBakeOptions(bo); !s) return usage(flagNames(s.error().message));

  // -j bounds every stage (the loader decodes images in parallel, the bake runs its pool).
  capThreads(o.threads);

#ifdef __GLIBC__
  // Blocks of 4 MiB and more (decoded images, large masks, map chunks) are mapped on their own and returned to the
  // system when freed. glibc's default raises this threshold to the largest block freed so far, after which such
  // blocks come from the heap and their pages stay resident once freed: forza.obj at level 6 peaked 10 MB higher
  // (47.6 → 37 MB). A lower threshold (256 KiB) saves no more and costs CPU: the bake's smaller scratch blocks would
  // be mapped and faulted in afresh each time.
  mallopt(M_MMAP_THRESHOLD, 4 << 20);
  // Freed memory at the top of the heap is kept for the next allocation instead of being handed back (glibc's
  // default trims above 128 KiB): the loader's image buffers, freed one after the other, were otherwise faulted in
  // afresh each time, and a page's first touch costs 5-10 µs on the VMs this was measured on. 0 A.D. flora-quarter
  // level 6, one thread: 19.3k -> 6.1k page faults, 0.71 -> 0.58 s wall; same peak (29.6 MB).
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  // One heap for all threads: a worker thread's own heap keeps the pages of what it freed (the decoder's buffers, the
  // bake's batches) resident beside the main heap's. forza.obj at level 6, two threads: 28.4 → 25.6 MB peak, no
  // slower (the bake allocates little while it classifies).
  mallopt(M_ARENA_MAX, 1);
#endif

  // ---- scene ----
  somm::LoadOptions lo;
  lo.blendAsMask = o.material.blendAsMask;
  // The bake needs only the alpha and the UVs. A glTF output holds the geometry too, and for a scene that is not glTF
  // already (an OBJ) its materials' base colours, written into the output's textures.
  lo.loadPositions = !o.output.empty() && somm::isGltfPath(o.output);
  lo.loadColor = lo.loadPositions && !somm::isGltfPath(o.scene);
  if (!applyLimits("bake", o.limits, lo.limits)) return kExitUsage;
  if (!o.output.empty())
    if (somm::Status s = somm::checkOutputPath(o.output, {o.scene}); !s) return usage(s.error().message);
  auto scene = somm::loadScene(o.scene, lo);
  if (!scene) {
    printError("bake", scene.error().message);
    return kExitFailure;
  }
  // Nor any file the scene was read from (its buffers, textures, material libraries), before the bake.
  if (!o.output.empty())
    if (somm::Status s = somm::checkOutputPath(o.output, scene->inputFiles); !s)
      return usage(s.error().message);
  if (somm::Status s = checkBakeWork(*scene, bo, lo.limits); !s) {
    printError("bake", s.error().message);
    return kExitFailure;
  }
  for (const std::string& w : scene->warnings) printError("bake", o.scene + ": note: " + w);

  uint64_t totalTriangles = 0;
  for (const somm::Geometry& g : scene->geometries) totalTriangles += g.triangleCount();

  Output out;
  if (o.estimate) {
    uint64_t data = 0, mapTriangles = 0, micro = 0;
    std::array<uint64_t, 13> levels{};
    nlohmann::json geos = nlohmann::json::array();
    for (size_t gi = 0; gi < scene->geometries.size(); ++gi) {
      const somm::Geometry& g = scene->geometries[gi];
      const somm::Material& m = scene->materials[g.material];
      somm::Result<somm::BakeEstimate> e = somm::BakeEstimate{};
      if (m.alphaMode == somm::AlphaMode::Blend)
        e->triangles = g.triangleCount();  // not baked: no micromaps
      else
        e = somm::estimateBake(g, m, bo);
      if (!e) {
        printError("bake",
                   o.scene + ": geometry " + std::to_string(gi) + " '" + g.name + "': " + e.error().message);
        return kExitFailure;
      }
      data += e->dataBytes;
      mapTriangles += e->mapTriangles;
      micro += e->microTriangles;
      for (size_t l = 0; l < 13; ++l) levels[l] += e->levelHistogram[l];
      geos.push_back({{"index", gi},
                      {"name", g.name},
                      {"triangles", e->triangles},
                      {"map_triangles", e->mapTriangles},
                      {"data_bytes", e->dataBytes},
                      {"micro_triangles", e->microTriangles}});
    }
    if (o.json) {
      nlohmann::json j = {{"scene", o.scene},
                          {"estimate", true},
                          {"geometries", geos},
                          {"triangles", totalTriangles},
                          {"map_triangles", mapTriangles},
                          {"data_bytes", data},
                          {"micro_triangles", micro}};
      nlohmann::json lh = nlohmann::json::array();
      for (uint32_t l = 0; l < 13; ++l)
        if (levels[l]) lh.push_back({{"level", l}, {"triangles", levels[l]}});
      j["level_histogram"] = lh;
      out.put(dumpJson(j) + "\n");
    } else {
      out.put(o.scene +
              ": estimate (every alpha-tested triangle with its own micromap, before special indices and "
              "deduplication):\n");
      out.put("  triangles " + std::to_string(totalTriangles) + ", with micromaps " +
              std::to_string(mapTriangles) + ", micro-triangles " + std::to_string(micro) + "\n");
      out.put("  level histogram (level:triangles): " + levelList(levels) + "\n");
      out.put("  data bytes " + std::to_string(data) + " (" + humanBytes(data) + ")\n");
    }
    return kExitOk;
  }

  // ---- bake ----
  somm::SommFile file;
  file.sourcePath = o.scene;
  file.toolVersion = std::string("somm ") + SOMM_VERSION;
  if (o.maxLevel) {
    file.bakeOptions.emplace_back("max_level", std::to_string(bo.maxLevel));
    file.bakeOptions.emplace_back("texels_per_microtri", floatText(bo.texelsPerMicroTri));
  } else {
    file.bakeOptions.emplace_back("level", std::to_string(bo.level));
  }
  file.bakeOptions.emplace_back("format", std::to_string(o.format));
  file.bakeOptions.emplace_back("filter", o.material.filter);
  file.bakeOptions.emplace_back("cutoff",
                                o.material.cutoff ? floatText(*o.material.cutoff) : std::string("material"));
  if (o.format == 2) file.bakeOptions.emplace_back("unknown_as", o.unknownAs);
  if (o.maxBytes) file.bakeOptions.emplace_back("max_bytes", std::to_string(o.maxBytes));
  file.bakeOptions.emplace_back("blend_as_mask", o.material.blendAsMask ? "true" : "false");

  file.bakeOptions.emplace_back("arrays", o.arrays);
  const bool sceneArray = o.arrays == "scene";

  Progress progress;
  // One bake of the whole scene in the library (masks shared, identical triangles classified once, --max-bytes over
  // all arrays). BLEND materials (without --blend-as-mask, which the loader applied) are not alpha-tested: no
  // micromaps, every triangle unknown (the renderer's any-hit shader decides, as without OMMs).
  somm::BakeOptions sbo = bo;
  sbo.layout = sceneArray ? somm::ArrayLayout::SceneWide : somm::ArrayLayout::PerGeometry;
  sbo.blend = somm::BlendAs::Unknown;
  sbo.progress = [&](double f) { progress.update(f); };
  auto baked = somm::bakeScene(*scene, sbo);
  if (!baked) {
    progress.finish();
    printError("bake", o.scene + ": " + baked.error().message);
    return kExitFailure;
  }
  for (size_t gi = 0; gi < scene->geometries.size(); ++gi) {
    const somm::Geometry& g = scene->geometries[gi];
    const somm::Material& m = scene->materials[g.material];
    const somm::GeometryBake& gb = baked->geometries[gi];
    somm::GeometryInfo info;
    info.name = g.name;
    info.material = m.name;
    info.triangleCount = g.triangleCount();
    info.format = bo.format;
    info.cutoff = bo.cutoff.value_or(m.alphaCutoff);
    info.sampler = m.sampler;
    if (bo.filter) info.sampler.filter = *bo.filter;
    info.stats.microTriangles = gb.stats.microTriangles;
    info.stats.unknownMicroTriangles = gb.stats.unknownMicroTriangles;
    info.stats.invalidUvTriangles = gb.stats.nonFiniteUvTriangles;
    info.minLevel = gb.stats.minLevel;
    info.maxLevel = gb.stats.maxLevel;
    file.geometries.push_back(std::move(info));
  }
  file.micromaps = std::move(baked->micromaps);
  file.encodings.assign(file.micromaps.arrays.size(), {});
  if (baked->total.levelCap < somm::kMaxLevel)
    file.bakeOptions.emplace_back("level_cap", std::to_string(baked->total.levelCap));
  progress.finish();
  if (!encodings.empty()) {
    std::string names;
    for (somm::Encoding e : encodings)
      names += (names.empty() ? "" : ",") + std::string(somm::encodingName(e));
    file.bakeOptions.emplace_back("encoding", names);
    if (somm::Status s = addEncodingSections(file, encodings); !s) {
      printError("bake", o.scene + ": " + s.error().message);
      return kExitFailure;
    }
  }
  if (somm::Status s = somm::writeBakeOutput(o.output, o.scene, *scene, file); !s) {
    printError("bake", s.error().message);
    return kExitFailure;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const FileSummary sum = summarizeFile(file);
  const GeometrySummary& s = sum.geometryTotal;

  if (o.json) {
    nlohmann::json j;
    j["scene"] = o.scene;
    j["output"] = o.output;
    j["seconds"] = seconds;
    nlohmann::json arrays = nlohmann::json::array();
    for (size_t a = 0; a < sum.arrays.size(); ++a) {
      nlohmann::json x = arraySummaryJson(sum.arrays[a]);
      x["index"] = a;
      arrays.push_back(std::move(x));
    }
    j["arrays"] = arrays;
    nlohmann::json geos = nlohmann::json::array();
    for (size_t i = 0; i < sum.geometries.size(); ++i) {
      nlohmann::json x = geometrySummaryJson(sum.geometries[i]);
      x["index"] = i;
      x["name"] = file.geometries[i].name;
      x["material"] = file.geometries[i].material;
      x["array"] = file.micromaps.geometries[i].array;
      x["first_triangle"] = file.micromaps.geometries[i].firstTriangle;
      x["distinct_micromaps"] = sum.geometries[i].distinctMicromaps;
      geos.push_back(std::move(x));
    }
    j["geometries"] = geos;
    nlohmann::json t = geometrySummaryJson(s);
    t["geometries"] = sum.geometries.size();
    t["arrays"] = sum.arrays.size();
    t["unique_micromaps"] = sum.arrayTotal.uniqueMicromaps;
    t["bytes"] = {{"data", sum.arrayTotal.dataBytes},
                  {"descriptors", sum.arrayTotal.descriptorBytes},
                  {"index_buffers", s.indexBytes},
                  {"total", sum.arrayTotal.dataBytes + sum.arrayTotal.descriptorBytes + s.indexBytes}};
    j["total"] = t;
    out.put(dumpJson(j) + "\n");
    return kExitOk;
  }
  char frac[32], secs[32];
  std::snprintf(frac, sizeof frac, "%.3f%%", 100.0 * s.unknownFraction());
  std::snprintf(secs, sizeof secs, "%.2f", seconds);
  out.put(o.output + ": " + counted(sum.geometries.size(), "geometry", "geometries") + ", " +
          std::to_string(s.triangles) + " triangles baked in " + secs + " s into " +
          (sceneArray ? std::string("one scene-wide OMM array")
                      : std::to_string(sum.arrays.size()) + " OMM arrays (one per geometry)") +
          "\n");
  out.put("  special indices (triangles): transparent " + std::to_string(s.special[0]) + ", opaque " +
          std::to_string(s.special[1]) + ", unknown-transparent " + std::to_string(s.special[2]) +
          ", unknown-opaque " + std::to_string(s.special[3]) + "\n");
  out.put("  micromaps: " + std::to_string(s.micromapTriangles) + " triangles reference " +
          std::to_string(sum.arrayTotal.uniqueMicromaps) + " unique micromaps, levels (level:micromaps) " +
          levelList(sum.arrayTotal.levelMicromaps) + "\n");
  out.put("  build buffers: data " + bytesText(sum.arrayTotal.dataBytes) + ", descriptors " +
          bytesText(sum.arrayTotal.descriptorBytes) + ", index buffers " + bytesText(s.indexBytes) + "\n");
  out.put("  unknown: " + std::to_string(s.unknownMicroTriangles) + " of the " +
          std::to_string(s.microTriangles) + " micro-triangles of the triangles with micromaps (" + frac +
          ")\n");
  return kExitOk;
}

void setup(CLI::App& root) {
  auto o = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand(
      "bake",
      "Bake conservative opacity micromaps for every geometry of a glTF (.gltf/.glb) or OBJ scene into a "
      ".somm file, and print a summary.");
  cmd->add_option("scene", o->scene, "scene file (.gltf, .glb, .obj)")->required();
  cmd->add_option("-o,--output", o->output,
                  "output .somm file, or .glb / .gltf (+ .bin): the scene with its micromaps in "
                  "EXT_mesh_opacity_micromap (written atomically)");
  cmd->add_option("--level,-l", o->level, "fixed subdivision level 0..12 (default 6)")
      ->check(CLI::Range(0u, 12u));
  cmd->add_option("--max-level", o->maxLevel, "adaptive levels: the cap 0..12")->check(CLI::Range(0u, 12u));
  cmd->add_option(
      "--texels-per-microtri", o->texelsPerMicroTri,
      "adaptive levels: per triangle the smallest level whose micro-triangles cover at most S texels");
  cmd->add_option("--format", o->format, "2 or 4 states (default 4)")->check(CLI::IsMember({2u, 4u}));
  somm::cli::addMaterialOverrideOptions(cmd, o->material);
  cmd->add_option("--unknown-as", o->unknownAs,
                  "2-state: what unknown micro-triangles become (default majority)")
      ->check(CLI::IsMember({"opaque", "transparent", "majority"}));
  cmd->add_option("--max-bytes", o->maxBytes,
                  "lower a scene-wide level cap until the data of all arrays fits in B bytes")
      ->check(CLI::NonNegativeNumber &
              CLI::Range(uint64_t(0), uint64_t(1) << 63));  // CLI11 would wrap "-5" into 2^64 - 5
  cmd->add_flag("--estimate", o->estimate,
                "print the data size from the levels alone, bake nothing, write nothing");
  cmd->add_option("--threads,-j", o->threads, "worker threads (default: all)")->check(CLI::Range(0u, 1024u));
  somm::cli::addLimitOption(cmd, o->limits);
  cmd->add_option("--encoding,-e", o->encodings,
                  "also store these encodings of each array (docs/encodings.md): comma list of " +
                      somm::cli::encodingNameList() + ", or all");
  cmd->add_option("--arrays", o->arrays,
                  "scene (default): one OMM array shared by all geometries, identical maps stored once; "
                  "geometry: one array per geometry")
      ->check(CLI::IsMember({"scene", "geometry"}));
  cmd->add_flag("--json", o->json, "print the summary as JSON (keys in docs/cli.md)");
  cmd->callback([o] { somm::cli::setExitCode(run(*o)); });
}

const somm::cli::Registration reg("bake", &setup);

}  // namespace
