// SPDX-License-Identifier: MIT
// somm CLI — `--limit NAME=VALUE` (somm/limits.h) and the checks made before a bake starts.
#pragma once

#include <CLI/CLI.hpp>
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
// Σ 4^level over the triangles `bo` would bake (alpha-tested geometries) against limits.microTriangles, before
// the work starts. LimitExceeded names the limit and the option that raises it.
Status checkBakeWork(const Scene& scene, const BakeOptions& bo, const Limits& limits);

}  // namespace somm::cli
