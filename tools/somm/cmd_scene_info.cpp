// SPDX-License-Identifier: MIT
// somm scene-info SCENE [--blend-as-mask] [--json]: the geometries of a glTF/OBJ scene as every command
// numbers them, with their materials, alpha textures and samplers — what to look at before baking.
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "command.h"
#include "limits_cli.h"
#include "somm/io.h"
#include "somm/scene.h"
#include "somm/trace.h"

namespace {

struct Options {
  std::string path;
  bool blendAsMask = false;
  bool json = false;
  std::vector<std::string> limits;
};

const char* modeName(somm::AlphaMode m) {
  switch (m) {
    case somm::AlphaMode::Opaque:
      return "opaque";
    case somm::AlphaMode::Mask:
      return "mask";
    case somm::AlphaMode::Blend:
      return "blend";
  }
  return "?";
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

int run(const Options& o) {
  using namespace somm::cli;
  somm::LoadOptions lo;
  lo.blendAsMask = o.blendAsMask;
  if (!applyLimits("scene-info", o.limits, lo.limits)) return kExitUsage;
  auto scene = somm::loadScene(o.path, lo);
  if (!scene) {
    printError("scene-info", scene.error().message);
    return kExitFailure;  // a bad scene file is a failed operation (exit 1), never a usage error
  }
  const somm::Scene& s = *scene;
  // Alpha-tested materials, and those of them that can fail the alpha test (the baker's conservative
  // classification): only those are traced with a filter.
  auto canFailResult = somm::materialsThatCanFailAlphaTest(s);
  if (!canFailResult) {
    printError("scene-info", canFailResult.error().message);
    return kExitFailure;
  }
  const std::vector<bool>& canFail = *canFailResult;
  uint64_t triangles = 0, tested = 0, failing = 0, testedMaterials = 0, failingMaterials = 0;
  for (size_t m = 0; m < s.materials.size(); ++m) {
    testedMaterials += s.materials[m].alphaTested();
    failingMaterials += canFail[m];
  }
  for (const auto& g : s.geometries) {
    triangles += g.triangleCount();
    if (s.materials[g.material].alphaTested()) tested += g.triangleCount();
    if (g.material < canFail.size() && canFail[g.material]) failing += g.triangleCount();
  }
  Output out;
  if (o.json) {
    nlohmann::json j;
    j["scene"] = o.path;
    j["triangles"] = triangles;
    j["alpha_tested_triangles"] = tested;
    j["can_fail_triangles"] = failing;
    j["alpha_tested_materials"] = testedMaterials;
    j["can_fail_materials"] = failingMaterials;
    j["instances"] = s.instances.size();
    nlohmann::json mats = nlohmann::json::array();
    for (size_t i = 0; i < s.materials.size(); ++i) {
      const somm::Material& m = s.materials[i];
      nlohmann::json x = {{"index", i},
                          {"name", m.name},
                          {"alpha_mode", modeName(m.alphaMode)},
                          {"alpha_tested", m.alphaTested()},
                          {"can_fail_alpha_test", bool(canFail[i])},
                          {"cutoff", m.alphaCutoff},
                          {"double_sided", m.doubleSided},
                          {"alpha_factor", m.baseColorFactor[3]},
                          {"filter", filterName(m.sampler.filter)},
                          {"wrap", {wrapName(m.sampler.wrapS), wrapName(m.sampler.wrapT)}}};
      if (m.alpha) {
        x["alpha_texture"] = {
            {"width", m.alpha->width}, {"height", m.alpha->height}, {"source", m.alphaSource}};
      } else {
        x["alpha_texture"] = nullptr;
      }
      mats.push_back(std::move(x));
    }
    j["materials"] = mats;
    nlohmann::json geos = nlohmann::json::array();
    for (size_t i = 0; i < s.geometries.size(); ++i) {
      const somm::Geometry& g = s.geometries[i];
      geos.push_back({{"index", i},
                      {"name", g.name},
                      {"triangles", g.triangleCount()},
                      {"vertices", g.positions.size() / 3},
                      {"material", g.material}});
    }
    j["geometries"] = geos;
    if (s.camera) {
      j["camera"] = {{"eye", s.camera->eye},
                     {"target", s.camera->target},
                     {"up", s.camera->up},
                     {"yfov", s.camera->yfovRadians}};
    } else {
      j["camera"] = nullptr;
    }
    j["warnings"] = s.warnings;
    out.put(j.dump(2));
    out.put("\n");
    return kExitOk;
  }
  using std::to_string;
  out.put("scene: " + o.path + "\n");
  out.put(to_string(s.geometries.size()) + " geometries, " + to_string(triangles) + " triangles (" +
          to_string(tested) + " alpha-tested, " + to_string(failing) + " of them can fail the alpha test), " +
          to_string(s.materials.size()) + " materials (" + to_string(testedMaterials) + " alpha-tested, " +
          to_string(failingMaterials) + " can fail; the others are traced opaque), " +
          to_string(s.instances.size()) + " instances\n");
  out.put("geometries:\n");
  for (size_t i = 0; i < s.geometries.size(); ++i) {
    const somm::Geometry& g = s.geometries[i];
    const somm::Material& m = s.materials[g.material];
    out.put("  " + to_string(i) + "  " + somm::escapeName(g.name) + ": " + to_string(g.triangleCount()) +
            " triangles, " + to_string(g.positions.size() / 3) + " vertices, material " +
            to_string(g.material) + " '" + somm::escapeName(m.name) + "' (" + modeName(m.alphaMode) + ")\n");
  }
  out.put("materials:\n");
  for (size_t i = 0; i < s.materials.size(); ++i) {
    const somm::Material& m = s.materials[i];
    std::string line = "  " + to_string(i) + "  '" + somm::escapeName(m.name) + "': " + modeName(m.alphaMode);
    if (m.alphaTested()) {
      line += ", cutoff " + fmt("%g", m.alphaCutoff);
      if (m.alpha)
        line += ", alpha " + to_string(m.alpha->width) + "x" + to_string(m.alpha->height) + " from " +
                somm::escapeName(m.alphaSource) + ", " + filterName(m.sampler.filter) + ", wrap " +
                wrapName(m.sampler.wrapS) + "/" + wrapName(m.sampler.wrapT);
      else
        line += ", constant alpha " + fmt("%g", m.baseColorFactor[3]);
      line += canFail[i] ? "; can fail the alpha test" : "; never fails the alpha test (traced opaque)";
    }
    out.put(line + "\n");
  }
  if (s.camera) {
    const auto& c = *s.camera;
    out.put("camera: eye (" + fmt("%g", c.eye[0]) + ", " + fmt("%g", c.eye[1]) + ", " + fmt("%g", c.eye[2]) +
            "), target (" + fmt("%g", c.target[0]) + ", " + fmt("%g", c.target[1]) + ", " +
            fmt("%g", c.target[2]) + "), yfov " + fmt("%g", c.yfovRadians) + "\n");
  }
  for (const auto& w : s.warnings) out.put("warning: " + w + "\n");
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand("scene-info",
                                      "List the geometries of a glTF (.gltf/.glb) or OBJ scene as every "
                                      "command numbers them, with materials, alpha "
                                      "modes, cutoffs, alpha textures and samplers.");
  cmd->add_option("scene", opts->path, "scene file (.gltf, .glb or .obj)")->required();
  somm::cli::addLimitOption(cmd, opts->limits);
  cmd->add_flag("--blend-as-mask", opts->blendAsMask, "treat glTF BLEND materials as MASK with their cutoff");
  cmd->add_flag("--json", opts->json, "machine-readable output");
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("scene-info", &setup);

}  // namespace
