// SPDX-License-Identifier: MIT
// somm bench SCENE [--omm FILE.somm] [--methods ...] [--repeat K] [--json]: traces the same rays with every
// any-hit method, interleaved over K repeats, and compares speed, work and images against `texture`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "command.h"
#include "file_summary.h"
#include "trace_cli.h"

namespace {

struct Options {
  somm::cli::TraceCliOptions trace;
  std::string methods;  // comma list; empty = all
  uint32_t repeat = 3;
  bool allowEmpty = false;
};

struct Row {
  std::string name;
  somm::MethodSpec spec;
  std::unique_ptr<somm::Tracer> tracer;
  std::vector<double> mrays;   // per repeat
  std::vector<double> ratios;  // per repeat: mrays / texture's mrays of the same repeat
  std::vector<double> toFlat;  // per repeat: mrays / the same format's omm<f>-flat mrays (empty: no such row)
  somm::TraceCounters counters;
  double diff = 0;
  bool exact = false;  // must match texture pixel for pixel
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

int run(const Options& o) {
  using namespace somm::cli;
  std::vector<std::string> names;
  if (o.methods.empty()) {
    names = {"texture", "opaque", "bitmask"};
    for (const std::string& e : somm::traceEncodings()) names.push_back("omm2-" + e);
    for (const std::string& e : somm::traceEncodings()) names.push_back("omm4-" + e);
  } else {
    std::stringstream ss(o.methods);
    std::string t;
    while (std::getline(ss, t, ','))
      if (!t.empty()) names.push_back(t);
    for (size_t i = 0; i < names.size(); ++i)
      if (std::find(names.begin(), names.begin() + std::ptrdiff_t(i), names[i]) !=
          names.begin() + std::ptrdiff_t(i)) {
        printError("bench", "--methods lists '" + names[i] + "' twice");
        return kExitUsage;
      }
    // The texture test runs first in every repeat, wherever it was listed: it is the reference image every row is
    // compared with and the run every ratio divides by.
    names.erase(std::remove(names.begin(), names.end(), "texture"), names.end());
    names.insert(names.begin(), "texture");
  }
  std::vector<Row> rows;
  bool needMicromaps = false;
  for (const std::string& n : names) {
    auto spec = somm::parseMethod(n);
    if (!spec) {
      printError("bench", spec.error().message);
      return kExitUsage;
    }
    if (spec->kind == somm::MethodKind::StateOverlay) {
      printError("bench", "state-overlay is a picture, not a method to benchmark (use somm render)");
      return kExitUsage;
    }
    needMicromaps |= spec->kind != somm::MethodKind::Opaque && spec->kind != somm::MethodKind::Texture;
    Row r;
    r.name = n;
    r.spec = *spec;
    r.exact = spec->kind == somm::MethodKind::Texture || spec->kind == somm::MethodKind::Bitmask ||
              (spec->kind == somm::MethodKind::Omm && spec->format == somm::Format::FourState);
    rows.push_back(std::move(r));
  }
  int code = kExitOk;
  auto p = prepareTrace("bench", o.trace, needMicromaps, code);
  if (!p) return code;
  for (Row& r : rows) {
    auto t = somm::makeTracer(p->world, r.spec, p->micromaps);
    if (!t) {
      printError("bench", t.error().message);
      return kExitFailure;
    }
    r.tracer = std::move(t).value();
  }
  somm::Image reference;
  for (uint32_t k = 0; k < o.repeat; ++k)
    for (Row& r : rows) {
      const somm::RenderResult res = r.tracer->render(p->settings);
      r.mrays.push_back(res.raysPerSecond() / 1e6);
      if (k == 0) {
        r.counters = res.counters;
        if (r.spec.kind == somm::MethodKind::Texture) reference = res.image;
        r.diff = somm::percentPixelsDiffering(res.image, reference);
      }
    }
  // Ratios per repeat (texture ran in the same repeat, interleaved), then their median: robust against the
  // machine's speed changing between repeats.
  const std::vector<double>& textureRuns = rows.front().mrays;
  for (Row& r : rows)
    for (size_t k = 0; k < r.mrays.size(); ++k)
      r.ratios.push_back(textureRuns[k] > 0 ? r.mrays[k] / textureRuns[k] : 0.0);
  // The same against flat micromaps of the same format (omm2-flat / omm4-flat), when that row was run: what a
  // compressed encoding costs in tracing.
  for (Row& r : rows) {
    if (r.spec.kind != somm::MethodKind::Omm) continue;
    for (const Row& f : rows)
      if (f.spec.kind == somm::MethodKind::Omm && f.spec.format == r.spec.format &&
          f.name == (r.spec.format == somm::Format::FourState ? "omm4-flat" : "omm2-flat"))
        for (size_t k = 0; k < r.mrays.size(); ++k)
          r.toFlat.push_back(f.mrays[k] > 0 ? r.mrays[k] / f.mrays[k] : 0.0);
  }
  const double textureMedian = median(textureRuns);
  const double textureSpread = textureMedian > 0
                                   ? (*std::max_element(textureRuns.begin(), textureRuns.end()) -
                                      *std::min_element(textureRuns.begin(), textureRuns.end())) /
                                         textureMedian
                                   : 0.0;
  bool inexact = false;
  for (const Row& r : rows) inexact |= r.exact && r.diff != 0.0;
  const uint64_t alphaPixels = rows.front().counters.alphaTestedPixels;

  Output out;
  if (o.trace.json) {
    nlohmann::json j;
    j["scene"] = o.trace.scene;
    j["micromaps"] = needMicromaps ? p->micromapSource : "";
    j["width"] = p->settings.width;
    j["height"] = p->settings.height;
    j["spp"] = p->settings.spp;
    j["threads"] = p->settings.threads;
    j["repeat"] = o.repeat;
    j["bitmask_level"] = p->micromaps.bitmaskLevel;
    j["alpha_tested_pixels"] = alphaPixels;
    j["texture_spread"] = textureSpread;
    nlohmann::json ms = nlohmann::json::array();
    for (const Row& r : rows) {
      const double rays = double(r.counters.rays());
      ms.push_back({{"method", r.name},
                    {"mrays_per_s", median(r.mrays)},
                    {"mrays_per_s_runs", r.mrays},
                    {"ratio_to_texture", median(r.ratios)},
                    {"ratio_to_texture_runs", r.ratios},
                    {"ratio_min", *std::min_element(r.ratios.begin(), r.ratios.end())},
                    {"ratio_max", *std::max_element(r.ratios.begin(), r.ratios.end())},
                    {"ratio_to_flat", r.toFlat.empty() ? nlohmann::json() : nlohmann::json(median(r.toFlat))},
                    {"ratio_to_flat_runs", r.toFlat},
                    {"rays", r.counters.rays()},
                    {"filter_calls_per_ray", rays ? double(r.counters.filterCalls) / rays : 0.0},
                    {"texture_tests_per_ray", rays ? double(r.counters.textureTests) / rays : 0.0},
                    {"micromap_lookups_per_ray", rays ? double(r.counters.micromapLookups) / rays : 0.0},
                    {"micromap_bytes", r.tracer->micromapBytes()},
                    {"pct_pixels_differing", r.diff},
                    {"exact_required", r.exact}});
    }
    j["methods"] = ms;
    out.put(dumpJson(j) + "\n");
  } else {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%s: %ux%u, %u spp, %u repeats (medians; ratios per repeat), micromaps %s\n"
                  "pixels with alpha-tested hits (texture): %llu of %llu\n",
                  o.trace.scene.c_str(), p->settings.width, p->settings.height, p->settings.spp, o.repeat,
                  needMicromaps ? p->micromapSource.c_str() : "-", (unsigned long long)alphaPixels,
                  (unsigned long long)p->settings.width * p->settings.height);
    out.put(buf);
    std::snprintf(buf, sizeof buf, "%-14s %9s %10s %13s %8s %13s %12s %13s %14s %9s\n", "method", "Mrays/s",
                  "vs texture", "ratio range", "vs flat", "flat range", "filter/ray", "texture/ray",
                  "micromap bytes", "% pixels");
    out.put(buf);
    for (const Row& r : rows) {
      const double rays = double(r.counters.rays());
      char range[64], flat[32] = "-", flatRange[64] = "-";
      std::snprintf(range, sizeof range, "%.2f-%.2f", *std::min_element(r.ratios.begin(), r.ratios.end()),
                    *std::max_element(r.ratios.begin(), r.ratios.end()));
      if (!r.toFlat.empty()) {
        std::snprintf(flat, sizeof flat, "%.3fx", median(r.toFlat));
        std::snprintf(flatRange, sizeof flatRange, "%.2f-%.2f",
                      *std::min_element(r.toFlat.begin(), r.toFlat.end()),
                      *std::max_element(r.toFlat.begin(), r.toFlat.end()));
      }
      std::snprintf(buf, sizeof buf, "%-14s %9.2f %9.2fx %13s %8s %13s %12.3f %13.3f %14llu %8.3f%s\n",
                    r.name.c_str(), median(r.mrays), median(r.ratios), range, flat, flatRange,
                    rays ? double(r.counters.filterCalls) / rays : 0.0,
                    rays ? double(r.counters.textureTests) / rays : 0.0,
                    (unsigned long long)r.tracer->micromapBytes(), r.diff,
                    r.exact && r.diff != 0.0 ? "  NOT EXACT" : "");
      out.put(buf);
    }
  }
  out.flush();
  if (textureSpread > 0.10)
    printError("bench", "warning: the texture runs spread by " +
                            std::to_string(std::lround(textureSpread * 100)) +
                            " % (the machine's speed changed; use more --repeat)");
  if (alphaPixels == 0 && !o.allowEmpty) {
    printError("bench", o.trace.scene +
                            ": no pixel saw a hit on alpha-tested geometry, so the comparison tests nothing "
                            "(aim --camera into the foliage, or pass --allow-empty)");
    return kExitFailure;
  }
  if (inexact) {
    printError("bench", "a method that must be exact rendered pixels different from texture");
    return kExitFailure;
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand(
      "bench",
      "Trace the same rays with every any-hit method (interleaved over --repeat runs) and print Mrays/s "
      "(median), the "
      "median of the per-repeat ratios to texture, filter calls and texture tests per ray, micromap bytes "
      "and the % of pixels "
      "differing from "
      "texture. Exit code 1 if a 4-state method or the bitmask is not pixel-identical to texture, or if no "
      "pixel "
      "saw an alpha-tested hit (unless --allow-empty).");
  somm::cli::addTraceOptions(cmd, opts->trace);
  cmd->add_option("--methods", opts->methods,
                  "comma-separated methods (default: all; texture is always included)");
  cmd->add_option("--repeat", opts->repeat, "interleaved repeats")->check(CLI::Range(1u, 1000u));
  cmd->add_flag("--allow-empty", opts->allowEmpty,
                "do not fail when the texture method hit no alpha-tested geometry (an empty comparison)");
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("bench", &setup);

}  // namespace
