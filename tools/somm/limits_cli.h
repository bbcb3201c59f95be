// SPDX-License-Identifier: MIT
// somm CLI — `--limit NAME=VALUE` (somm/limits.h) and the checks made before a bake starts.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "somm/bake.h"
#include "somm/limits.h"
#include "somm/scene.h"

namespace somm::cli {

// Adds the repeatable option --limit NAME=VALUE to cmd.
void addLimitOption(CLI::App* cmd, std::vector<std::string>& assignments);
// Applies the assignments to `limits`; on a bad one prints the error (one line) and returns false (exit 2).
bool applyLimits(const char* command, const std::vector<std::string>& assignments, Limits& limits);
// The material overrides of a bake (somm bake, somm compare): --filter, --cutoff, --blend-as-mask.
struct MaterialOverrides {
  std::string filter = "auto";  // auto (each material's sampler), nearest or linear
  std::optional<float> cutoff;  // every material's alpha cutoff, in [0, 1]
  bool blendAsMask = false;     // glTF BLEND materials loaded as MASK (LoadOptions::blendAsMask)
};
void addMaterialOverrideOptions(CLI::App* cmd, MaterialOverrides& m);
// Sets bo.filter and bo.cutoff; a cutoff that is not a number in [0, 1] prints the one-line error and returns
// false (exit 2).
bool applyMaterialOverrides(const char* command, const MaterialOverrides& m, BakeOptions& bo);
// Σ 4^level over the triangles `bo` would bake (alpha-tested geometries) against limits.microTriangles, before
// the work starts. LimitExceeded names the limit and the option that raises it.
Status checkBakeWork(const Scene& scene, const BakeOptions& bo, const Limits& limits);

}  // namespace somm::cli
