// SPDX-License-Identifier: MIT
// somm CLI — shared setup of `somm render` and `somm bench`.
#include "trace_cli.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "command.h"
#include "limits_cli.h"
#include "somm/bake.h"
#include "somm/gltf.h"
#include "somm/somm_file.h"

namespace somm::cli {

void addTraceOptions(CLI::App* cmd, TraceCliOptions& o) {
  cmd->add_option("scene", o.scene, "scene file (.gltf, .glb or .obj)")->required();
  cmd->add_option("--omm", o.omm, ".somm file with the scene's micromaps (default: bake in memory)");
  cmd->add_option("--width", o.width, "image width in pixels")->check(CLI::Range(1u, 16384u));
  cmd->add_option("--height", o.height, "image height in pixels")->check(CLI::Range(1u, 16384u));
  cmd->add_option("--spp", o.spp, "samples per pixel (fixed pattern)")->check(CLI::Range(1u, 1024u));
  cmd->add_option("--threads", o.threads, "worker threads (0 = all)")->check(CLI::Range(0u, 1024u));
  cmd->add_option("--camera", o.camera,
                  "ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy: eye, target, up and vertical field of view in degrees "
                  "(default: the scene's camera, else a view framing the scene)");
  cmd->add_option("--level", o.level, "bake: fixed subdivision level")->check(CLI::Range(0u, 12u));
  cmd->add_option("--max-level", o.maxLevel, "bake: adaptive level cap (with --texels-per-microtri)")
      ->check(CLI::Range(0u, 12u));
  cmd->add_option("--texels-per-microtri", o.texelsPerMicroTri,
                  "bake: adaptive level target (texels per micro-triangle)")
      ->check(CLI::Range(0.0f, 1e9f) & somm::cli::NotNan);
  cmd->add_option("--filter", o.filter, "bake and trace: auto (each material's sampler), nearest or linear")
      ->check(CLI::IsMember({"auto", "nearest", "linear"}));
  cmd->add_option("--cutoff", o.cutoff, "bake and trace: alpha cutoff for every material")
      ->check(CLI::Range(0.0f, 1.0f) & somm::cli::NotNan);
  cmd->add_flag("--blend-as-mask", o.blendAsMask, "treat glTF BLEND materials as MASK");
  cmd->add_flag(
      "--no-split", o.noSplit,
      "micromap methods: keep triangles with a special index on the filter path (default: fully "
      "transparent ones leave the BVH, fully opaque ones lose their filter, as with hardware micromaps)");
  cmd->add_flag("--json", o.json, "print JSON instead of text");
  addLimitOption(cmd, o.limits);
}

Result<Camera> parseCamera(const std::string& text) {
  std::vector<float> v;
  std::string tok;
  std::stringstream ss(text);
  while (std::getline(ss, tok, ',')) {
    float f;
    if (!parseFloat(tok, f) || !std::isfinite(f))
      return makeError(ErrorCode::ParseError, "--camera: '" + tok + "' is not a finite number");
    v.push_back(f);
  }
  if (v.size() != 10)
    return makeError(ErrorCode::ParseError,
                     "--camera: expected 10 comma-separated numbers ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy, got " +
                         std::to_string(v.size()));
  Camera c;
  c.eye = {v[0], v[1], v[2]};
  c.target = {v[3], v[4], v[5]};
  c.up = {v[6], v[7], v[8]};
  if (!(v[9] > 0 && v[9] < 180))
    return makeError(ErrorCode::ParseError, "--camera: fovy must be in (0, 180) degrees");
  c.yfovRadians = v[9] * 3.14159265358979f / 180.0f;
  const float d[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]};
  const float cr[3] = {d[1] * v[8] - d[2] * v[7], d[2] * v[6] - d[0] * v[8], d[0] * v[7] - d[1] * v[6]};
  if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] == 0)
    return makeError(ErrorCode::ParseError, "--camera: eye and target coincide");
  if (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2] == 0)
    return makeError(ErrorCode::ParseError, "--camera: up is parallel to the view direction");
  return c;
}

namespace {

std::shared_ptr<const SceneMicromaps> demote(const SceneMicromaps& four) {
  auto out = std::make_shared<SceneMicromaps>();
  out->geometries = four.geometries;
  for (const OmmArray& a : four.arrays) {
    OmmArray b = a;
    for (TriangleDescriptor& d : b.descriptors) d.format = uint16_t(Format::TwoState);
    // Re-pack each micromap as 2-state bits in place of the 4-state bytes (the spec's force-2-state).
    std::vector<uint8_t> data;
    for (size_t i = 0; i < a.descriptors.size(); ++i) {
      const TriangleDescriptor& d = a.descriptors[i];
      if (Format(d.format) == Format::TwoState) {
        b.descriptors[i].dataOffset = uint32_t(data.size());
        data.insert(data.end(), a.data.begin() + d.dataOffset,
                    a.data.begin() + d.dataOffset + micromapDataBytes(d.subdivisionLevel, Format::TwoState));
        continue;
      }
      std::vector<uint8_t> m(micromapDataBytes(d.subdivisionLevel, Format::TwoState), 0);
      for (uint32_t k = 0; k < microTriangleCount(d.subdivisionLevel); ++k)
        writePackedState(m.data(), Format::TwoState, k,
                         toTwoState(readPackedState(a.data.data() + d.dataOffset, Format::FourState, k)));
      b.descriptors[i].dataOffset = uint32_t(data.size());
      data.insert(data.end(), m.begin(), m.end());
    }
    b.data = std::move(data);
    for (int32_t& idx : b.indices)
      if (isSpecialIndex(idx)) idx = specialIndexFor(toTwoState(stateOfSpecialIndex(idx)));
    out->arrays.push_back(std::move(b));
  }
  return out;
}

}  // namespace

// --omm, or the scene itself when it is a glTF using EXT_mesh_opacity_micromap, or "" (bake in memory).
static std::string embeddedMicromapPath(const char* command, const TraceCliOptions& o, bool needMicromaps,
                                        int& exitCode) {
  exitCode = kExitOk;
  if (!o.omm.empty() || !needMicromaps || !isGltfPath(o.scene)) return o.omm;
  auto read = readGltfMicromaps(o.scene);
  if (!read) {
    printError(command, read.error().message);
    exitCode = kExitFailure;
    return "";
  }
  return read->present ? o.scene : "";
}

std::unique_ptr<PreparedTrace> prepareTrace(const char* command, const TraceCliOptions& o, bool needMicromaps,
                                            int& exitCode) {
  auto p = std::make_unique<PreparedTrace>();
  LoadOptions lo;
  lo.blendAsMask = o.blendAsMask;
  if (!applyLimits(command, o.limits, lo.limits)) {
    exitCode = kExitUsage;
    return nullptr;
  }
  auto loaded = loadScene(o.scene, lo);
  if (!loaded) {
    printError(command, loaded.error().message);
    exitCode = kExitFailure;  // a bad scene file is a failed operation, never a usage error
    return nullptr;
  }
  Scene scene = std::move(loaded).value();
  if (o.blendAsMask)
    for (Material& m : scene.materials)
      if (m.alphaMode == AlphaMode::Blend) m.alphaMode = AlphaMode::Mask;
  // Overrides apply to the ground truth too, so that `texture` and the micromaps test the same thing.
  for (Material& m : scene.materials) {
    if (o.cutoff >= 0) m.alphaCutoff = o.cutoff;
    if (o.filter == "nearest") m.sampler.filter = Filter::Nearest;
    if (o.filter == "linear") m.sampler.filter = Filter::Linear;
  }
  if (!o.camera.empty()) {
    auto cam = parseCamera(o.camera);
    if (!cam) {
      printError(command, cam.error().message);
      exitCode = kExitUsage;
      return nullptr;
    }
    p->settings.camera = *cam;
  }
  p->settings.width = o.width;
  p->settings.height = o.height;
  p->settings.spp = o.spp;
  p->settings.threads = o.threads;

  std::shared_ptr<const SceneMicromaps> flat4, flat2;
  // Without --omm, a glTF scene's own EXT_mesh_opacity_micromap micromaps are used (else they are baked in memory).
  const std::string ommPath = embeddedMicromapPath(command, o, needMicromaps, exitCode);
  if (exitCode != kExitOk) return nullptr;
  if (needMicromaps && !ommPath.empty()) {
    auto file = readMicromapFile(ommPath);
    if (!file) {
      printError(command, file.error().message);
      exitCode = kExitFailure;
      return nullptr;
    }
    if (file->geometries.size() != scene.geometries.size()) {
      printError(command, ommPath + ": holds " + std::to_string(file->geometries.size()) + " geometries, " +
                              o.scene + " has " + std::to_string(scene.geometries.size()));
      exitCode = kExitFailure;
      return nullptr;
    }
    bool four = true;
    for (size_t g = 0; g < file->geometries.size(); ++g) {
      const GeometryInfo& sg = file->geometries[g];
      if (sg.triangleCount != scene.geometries[g].triangleCount()) {
        printError(command, ommPath + ": geometry " + std::to_string(g) + " has " +
                                std::to_string(sg.triangleCount) + " triangles, the scene's has " +
                                std::to_string(scene.geometries[g].triangleCount()));
        exitCode = kExitFailure;
        return nullptr;
      }
      Material& m = scene.materials[scene.geometries[g].material];
      if (m.alphaTested()) {
        if (sg.format == Format::TwoState) four = false;
        // Trace against the alpha test the file was baked for.
        m.alphaCutoff = sg.cutoff;
        m.sampler = sg.sampler;
      }
    }
    // The file's scene micromaps as they are (version 2: arrays shared by geometries; version 1 is read as
    // per-geometry arrays).
    auto arrays = std::make_shared<const SceneMicromaps>(std::move(file->micromaps));
    if (four) {
      flat4 = arrays;
      flat2 = demote(*arrays);
    } else {
      flat2 = arrays;
    }
    p->micromapSource = !isGltfPath(ommPath) ? ommPath
                                             : std::string(kGltfMicromapExtension) +
                                                   (o.omm.empty() ? " (embedded in " : " (") + ommPath + ")";
  }
  p->scene = std::make_shared<const Scene>(std::move(scene));
  auto world = TraceWorld::create(p->scene);
  if (!world) {
    printError(command, world.error().message);
    exitCode = kExitFailure;
    return nullptr;
  }
  p->world = *world;

  if (needMicromaps && ommPath.empty()) {
    BakeOptions bo;
    bo.level = o.level;
    bo.maxLevel = o.maxLevel;
    bo.texelsPerMicroTri = o.texelsPerMicroTri;
    bo.threads = o.threads;
    if (Status s = validateBakeOptions(bo); !s) {
      printError(command, s.error().message);
      exitCode = kExitUsage;
      return nullptr;
    }
    if (Status s = checkBakeWork(*p->scene, bo, lo.limits); !s) {
      printError(command, s.error().message);
      exitCode = kExitFailure;
      return nullptr;
    }
    const auto start = std::chrono::steady_clock::now();
    bo.blend = BlendAs::Unknown;  // as somm bake: BLEND (without --blend-as-mask) is not alpha-tested
    for (Format f : {Format::FourState, Format::TwoState}) {
      bo.format = f;
      // One scene-wide array, as `somm bake` stores it: identical maps of all geometries stored once.
      auto baked = bakeScene(*p->scene, bo);
      if (!baked) {
        printError(command, baked.error().message);
        exitCode = kExitFailure;
        return nullptr;
      }
      (f == Format::FourState ? flat4 : flat2) =
          std::make_shared<const SceneMicromaps>(std::move(baked->micromaps));
    }
    p->bakeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    p->micromapSource = o.texelsPerMicroTri > 0
                            ? "baked in memory (adaptive, max level " + std::to_string(o.maxLevel) + ")"
                            : "baked in memory (level " + std::to_string(o.level) + ")";
  }
  p->micromaps.splitSpecialIndices = !o.noSplit;
  p->micromaps.flat4 = flat4;
  p->micromaps.flat2 = flat2;
  uint32_t maxLevel = 0;
  if (flat4 || flat2)
    for (const OmmArray& a : (flat4 ? *flat4 : *flat2).arrays)
      for (const TriangleDescriptor& d : a.descriptors)
        maxLevel = std::max<uint32_t>(maxLevel, d.subdivisionLevel);
  p->micromaps.bitmaskLevel = std::min<uint32_t>(maxLevel, 10);
  return p;
}

}  // namespace somm::cli
