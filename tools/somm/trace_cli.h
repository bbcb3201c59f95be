// SPDX-License-Identifier: MIT
// somm CLI — shared by `somm render` and `somm bench`: scene loading, micromaps (from a .somm file or baked
// in memory), camera and image options.
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "somm/result.h"
#include "somm/scene.h"
#include "somm/trace.h"

namespace somm::cli {

struct TraceCliOptions {
  std::string scene;
  std::string omm;  // .somm file; empty: bake in memory
  uint32_t width = 640, height = 480, spp = 1, threads = 0;
  std::string camera;  // ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy (degrees)
  // Bake options (as for `somm bake`) when micromaps are baked in memory.
  uint32_t level = 6, maxLevel = 0;
  float texelsPerMicroTri = 0;
  std::string filter = "auto";
  float cutoff = -1;  // < 0: each material's own
  bool blendAsMask = false;
  bool noSplit = false;  // omm methods: keep special-index triangles on the filter path (for comparisons)
  bool json = false;
};

void addTraceOptions(CLI::App* cmd, TraceCliOptions& o);

struct PreparedTrace {
  std::shared_ptr<const Scene> scene;
  std::shared_ptr<const TraceWorld> world;
  MicromapSet micromaps;
  RenderSettings settings;
  std::string micromapSource;  // "baked in memory (level 6)" or the .somm path
  double bakeSeconds = 0;
};

// Loads the scene, reads or bakes the micromaps (when `needMicromaps`), parses the camera. On failure prints
// the error (prefixed with `command`) and sets `exitCode`.
std::unique_ptr<PreparedTrace> prepareTrace(const char* command, const TraceCliOptions& o, bool needMicromaps,
                                            int& exitCode);

// Parses "ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy" (fovy in degrees, 0 < fovy < 180).
Result<Camera> parseCamera(const std::string& text);

}  // namespace somm::cli
