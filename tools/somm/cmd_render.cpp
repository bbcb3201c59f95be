// SPDX-License-Identifier: MIT
// somm render SCENE [--omm FILE.somm] --method M -o out.png [--json]: ray traces the scene on Embree with one
// any-hit method and writes the image.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

#include "command.h"
#include "file_summary.h"
#include "legend.h"
#include "somm/io.h"
#include "trace_cli.h"

namespace {

struct Options {
  somm::cli::TraceCliOptions trace;
  std::string method = "texture";
  std::string output;
};

int run(const Options& o) {
  using namespace somm::cli;
  auto spec = somm::parseMethod(o.method);
  if (!spec) {
    printError("render", spec.error().message);
    return kExitUsage;
  }
  const bool needMicromaps = spec->kind == somm::MethodKind::Omm ||
                             spec->kind == somm::MethodKind::StateOverlay ||
                             spec->kind == somm::MethodKind::Bitmask;
  if (somm::Status s = somm::checkOutputPath(o.output, {o.trace.scene, o.trace.omm}); !s) {
    printError("render", s.error().message);
    return kExitUsage;
  }
  int code = kExitOk;
  auto p = prepareTrace("render", o.trace, needMicromaps, code);
  if (!p) return code;
  // Nor any file the scene was read from (`render scene.gltf -o leaf.png` overwrote the scene's own texture).
  if (p->scene)
    if (somm::Status s = somm::checkOutputPath(o.output, p->scene->inputFiles); !s) {
      printError("render", s.error().message);
      return kExitUsage;
    }
  if (spec->kind == somm::MethodKind::Bitmask && o.trace.omm.empty() && o.trace.texelsPerMicroTri == 0)
    p->micromaps.bitmaskLevel = std::min(o.trace.level, 10u);
  auto tracer = somm::makeTracer(p->world, *spec, p->micromaps);
  if (!tracer) {
    printError("render", tracer.error().message);
    return kExitFailure;
  }
  somm::RenderResult r = (*tracer)->render(p->settings);
  if (spec->kind == somm::MethodKind::StateOverlay)
    drawStateLegend(r.image.rgba.data(), r.image.width, r.image.height, 4, true);
  if (somm::Status s = somm::writePng(o.output, r.image); !s) {
    printError("render", s.error().message);
    return kExitFailure;
  }
  const somm::TraceCounters& c = r.counters;
  const double rays = double(c.rays());
  if (c.primaryHits == 0)
    printError(
        "render",
        o.trace.scene + ": warning: no primary ray hit the scene (the image is empty sky); check --camera");
  Output out;
  if (o.trace.json) {
    nlohmann::json j;
    j["scene"] = o.trace.scene;
    j["method"] = (*tracer)->method();
    j["output"] = o.output;
    j["width"] = r.image.width;
    j["height"] = r.image.height;
    j["spp"] = p->settings.spp;
    j["micromaps"] = needMicromaps ? p->micromapSource : "";
    j["rays"] = c.rays();
    j["primary_rays"] = c.primaryRays;
    j["shadow_rays"] = c.shadowRays;
    j["filter_calls"] = c.filterCalls;
    j["texture_tests"] = c.textureTests;
    j["micromap_lookups"] = c.micromapLookups;
    j["primary_hits"] = c.primaryHits;
    j["alpha_tested_pixels"] = c.alphaTestedPixels;
    j["micromap_bytes"] = (*tracer)->micromapBytes();
    j["seconds"] = r.seconds;
    j["mrays_per_s"] = r.raysPerSecond() / 1e6;
    out.put(dumpJson(j) + "\n");
  } else {
    char buf[512];
    std::snprintf(
        buf, sizeof buf,
        "%s: %ux%u, %u spp, method %s -> %s\n"
        "rays %llu (primary %llu, shadow %llu), %.3f s, %.2f Mrays/s\n"
        "per ray: filter calls %.3f, texture tests %.3f, micromap lookups %.3f; micromap bytes %llu\n"
        "primary hits %llu; pixels with alpha-tested hits %llu\n",
        o.trace.scene.c_str(), r.image.width, r.image.height, p->settings.spp, (*tracer)->method().c_str(),
        o.output.c_str(), (unsigned long long)c.rays(), (unsigned long long)c.primaryRays,
        (unsigned long long)c.shadowRays, r.seconds, r.raysPerSecond() / 1e6,
        rays ? double(c.filterCalls) / rays : 0.0, rays ? double(c.textureTests) / rays : 0.0,
        rays ? double(c.micromapLookups) / rays : 0.0, (unsigned long long)(*tracer)->micromapBytes(),
        (unsigned long long)c.primaryHits, (unsigned long long)c.alphaTestedPixels);
    out.put(buf);
    if (needMicromaps) out.put("micromaps: " + p->micromapSource + "\n");
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand(
      "render",
      "Ray trace a scene on the CPU (Embree) with one any-hit method and write a PNG. "
      "Methods: opaque, texture, "
      "bitmask, omm2-<encoding>, omm4-<encoding>, state-overlay (hits coloured by "
      "micromap state, flat colours "
      "with a legend: green opaque, orange unknown-opaque, red unknown-transparent, grey not "
      "alpha-tested).");
  somm::cli::addTraceOptions(cmd, opts->trace);
  cmd->add_option("--method,-m", opts->method, "any-hit method (default texture)");
  cmd->add_option("--output,-o", opts->output, "output PNG")->required();
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("render", &setup);

}  // namespace
