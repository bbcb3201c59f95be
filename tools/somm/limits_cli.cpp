// SPDX-License-Identifier: MIT
#include "limits_cli.h"

#include <cmath>

#include "command.h"

namespace somm::cli {

void addLimitOption(CLI::App* cmd, std::vector<std::string>& assignments) {
  cmd->add_option(
         "--limit", assignments,
         std::string("raise a limit against hostile input, NAME=VALUE (repeatable; docs/hardening.md): ") +
             limitNames())
      ->take_all()
      ->expected(1)
      ->allow_extra_args(false);
}

void addMaterialOverrideOptions(CLI::App* cmd, MaterialOverrides& m) {
  cmd->add_option("--filter", m.filter, "auto (each material's sampler; OBJ: linear), nearest or linear")
      ->check(CLI::IsMember({"auto", "nearest", "linear"}));
  cmd->add_option("--cutoff", m.cutoff,
                  "alpha cutoff in [0, 1] for every material (default: the material's)");
  cmd->add_flag("--blend-as-mask", m.blendAsMask, "bake glTF BLEND materials as MASK with their cutoff");
}

bool applyMaterialOverrides(const char* command, const MaterialOverrides& m, BakeOptions& bo) {
  if (m.cutoff && !(std::isfinite(*m.cutoff) && *m.cutoff >= 0.0f && *m.cutoff <= 1.0f)) {
    printError(command, "--cutoff must be a number in [0, 1]");
    return false;
  }
  bo.cutoff = m.cutoff;
  if (m.filter == "nearest") bo.filter = Filter::Nearest;
  if (m.filter == "linear") bo.filter = Filter::Linear;
  return true;
}

bool applyLimits(const char* command, const std::vector<std::string>& assignments, Limits& limits) {
  for (const std::string& a : assignments)
    if (Status s = setLimit(limits, a); !s) {
      printError(command, s.error().message);
      return false;
    }
  return true;
}

Status checkBakeWork(const Scene& scene, const BakeOptions& bo, const Limits& limits) {
  uint64_t total = 0;
  for (const Geometry& g : scene.geometries) {
    if (g.material >= scene.materials.size()) continue;
    const Material& m = scene.materials[g.material];
    if (m.alphaMode == AlphaMode::Opaque || !m.alpha) continue;
    const uint32_t n = g.triangleCount();
    if (bo.texelsPerMicroTri > 0 && g.uvs.size() / 2 >= g.positions.size() / 3) {
      for (uint32_t t = 0; t < n; ++t) {
        auto uv = [&](uint32_t k) {
          const size_t v = g.indices[3 * size_t(t) + k];
          return std::array<float, 2>{g.uvs[2 * v], g.uvs[2 * v + 1]};
        };
        if (size_t(3) * t + 2 >= g.indices.size() || g.indices[3 * size_t(t) + 2] >= g.uvs.size() / 2) break;
        total += uint64_t(1) << (2 * adaptiveLevel(uv(0), uv(1), uv(2), m.alpha->width, m.alpha->height,
                                                   bo.texelsPerMicroTri, bo.maxLevel));
      }
    } else {
      total += uint64_t(n) << (2 * std::min<uint32_t>(bo.level, 12));
    }
    if (total > limits.microTriangles) break;
  }
  if (total > limits.microTriangles)
    return makeError(ErrorCode::LimitExceeded, scene.sourcePath + ": baking would classify " +
                                                   (total > limits.microTriangles ? "more than " : "") +
                                                   std::to_string(limits.microTriangles) +
                                                   " micro-triangles, " +
                                                   limitHint("micro-triangles", limits.microTriangles));
  return Ok{};
}

}  // namespace somm::cli
