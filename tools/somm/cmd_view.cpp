// SPDX-License-Identifier: MIT
// somm view FILE.somm --geometry G [--triangles A-B] -o img.png: the alpha texture with the micro-triangles
// of the selected triangles drawn over it, coloured by the state a ray tracer reads.
#include <stb/stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "command.h"
#include "legend.h"
#include "limits_cli.h"
#include "somm/bird.h"
#include "somm/gltf.h"
#include "somm/io.h"
#include "somm/scene.h"
#include "somm/somm_file.h"
#include "somm/state_colours.h"

namespace {

struct Options {
  std::string path, output, scene, triangles;
  uint64_t geometry = 0;
  uint32_t size = 1024;
  std::vector<std::string> limits;
};

// Overlay colours: somm/state_colours.h (the one table of every picture).
constexpr float kOverlay = 0.55f;

bool parseRange(const std::string& s, uint64_t& a, uint64_t& b) {
  const size_t dash = s.find('-');
  if (dash == std::string::npos) return somm::cli::parseUInt(s, a) && (b = a, true);
  return somm::cli::parseUInt(std::string_view(s).substr(0, dash), a) &&
         somm::cli::parseUInt(std::string_view(s).substr(dash + 1), b) && a <= b;
}

bool endsWithObj(const std::string& p) {
  if (p.size() < 4) return false;
  std::string ext = p.substr(p.size() - 4);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".obj";
}

int run(const Options& o) {
  using namespace somm::cli;
  somm::LoadOptions lo;
  if (!applyLimits("view", o.limits, lo.limits)) return kExitUsage;
  if (somm::Status s = somm::checkOutputPath(o.output, {o.path, o.scene}); !s) {
    printError("view", s.error().message);
    return kExitUsage;
  }
  auto file = somm::readMicromapFile(o.path);  // .somm or glTF (EXT_mesh_opacity_micromap)
  if (!file) {
    printError("view", file.error().message);
    return kExitFailure;
  }
  const somm::SommFile& f = *file;
  if (o.geometry >= f.geometries.size()) {
    printError("view", "--geometry " + std::to_string(o.geometry) + " is out of range: " + o.path + " has " +
                           std::to_string(f.geometries.size()) + " geometries");
    return kExitUsage;
  }
  const somm::GeometryInfo& sg = f.geometries[o.geometry];
  const somm::SceneMicromaps& maps = f.micromaps;
  const uint32_t geometry = uint32_t(o.geometry);
  const uint64_t triangleCount = sg.triangleCount;
  uint64_t first = 0, last = triangleCount ? triangleCount - 1 : 0;
  if (!o.triangles.empty()) {
    if (!parseRange(o.triangles, first, last)) {
      printError("view",
                 "--triangles '" + excerpt(o.triangles) + "': expected A-B (A <= B) or a single index");
      return kExitUsage;
    }
    if (last >= triangleCount) {
      printError("view", "--triangles " + o.triangles + " is out of range: geometry " +
                             std::to_string(o.geometry) + " has " + std::to_string(triangleCount) +
                             " triangles");
      return kExitUsage;
    }
  }

  // The scene: --scene, else the source path stored in the file (as given to bake, else relative to the
  // file).
  std::string scenePath = o.scene.empty() ? f.sourcePath : o.scene;
  if (o.scene.empty() && !std::filesystem::exists(scenePath) &&
      std::filesystem::path(scenePath).is_relative()) {
    const auto alt = std::filesystem::path(o.path).parent_path() / scenePath;
    if (std::filesystem::exists(alt)) scenePath = alt.string();
  }
  if (somm::Status s = somm::checkOutputPath(o.output, {scenePath}); !s) {
    printError("view", s.error().message);
    return kExitUsage;
  }
  for (const auto& [k, v] : f.bakeOptions)
    if (k == "blend_as_mask") lo.blendAsMask = v == "true";
  auto scene = somm::loadScene(scenePath, lo);
  if (!scene) {
    printError("view", scene.error().message +
                           (o.scene.empty() ? " (the scene named in " + o.path + "; use --scene)" : ""));
    return kExitFailure;
  }
  // Nor any file the scene was read from (`view F.somm -o leaf.png` over the scene's own texture).
  if (somm::Status s = somm::checkOutputPath(o.output, scene->inputFiles); !s) {
    printError("view", s.error().message);
    return kExitUsage;
  }
  if (scene->geometries.size() != f.geometries.size() ||
      scene->geometries[o.geometry].triangleCount() != triangleCount) {
    printError("view", scenePath + " does not match " + o.path + ": geometry " + std::to_string(o.geometry) +
                           " has " +
                           std::to_string(o.geometry < scene->geometries.size()
                                              ? scene->geometries[o.geometry].triangleCount()
                                              : 0) +
                           " triangles in the scene and " + std::to_string(triangleCount) + " in the file");
    return kExitFailure;
  }
  const somm::Geometry& geo = scene->geometries[o.geometry];
  const somm::Material& mat = scene->materials[geo.material];

  // Background: the alpha as grey (a constant alpha fills a 256×256 square).
  const uint32_t tw = mat.alpha ? mat.alpha->width : 256, th = mat.alpha ? mat.alpha->height : 256;
  const double scale = double(o.size) / double(std::max(tw, th));
  const uint32_t w = std::max(1u, uint32_t(std::lround(tw * scale))),
                 h = std::max(1u, uint32_t(std::lround(th * scale)));
  const bool flip =
      endsWithObj(scenePath);  // OBJ: v = 0 is the bottom row of the image; show it as the file looks
  std::vector<float> rgb(size_t(w) * h * 3);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const uint32_t ty = std::min(th - 1, uint32_t(double(flip ? h - 1 - y : y) / scale));
      const uint32_t tx = std::min(tw - 1, uint32_t(double(x) / scale));
      float a = mat.alpha ? mat.alpha->at(tx, ty)
                          : (mat.alphaMode == somm::AlphaMode::Opaque ? 1.0f : mat.baseColorFactor[3]);
      if (!(a >= 0.0f)) a = 0.0f;
      a = std::min(a, 1.0f);
      for (int c = 0; c < 3; ++c) rgb[(size_t(y) * w + x) * 3 + size_t(c)] = 40.0f + 180.0f * a;
    }

  // Each pixel centre inside a selected triangle's UV triangle gets the state at its barycentrics; ids mark
  // the micro-triangle so that borders can be outlined afterwards.
  std::vector<uint64_t> id(size_t(w) * h, 0);
  const bool twoState = sg.format == somm::Format::TwoState;
  // Work bound: pixels visited over all triangles ≤ 16 × the image (huge UV triangles cover it whole; a
  // thousand of them must not cost a minute).
  const uint64_t budget = uint64_t(16) * w * h + (uint64_t(1) << 20);
  uint64_t visited = 0;
  for (uint64_t t = first; t <= last && triangleCount > 0; ++t) {
    double px[3], py[3];
    bool finite = true;
    for (int k = 0; k < 3; ++k) {
      const uint32_t vi = geo.indices[size_t(t) * 3 + size_t(k)];
      px[k] = geo.uvs[size_t(vi) * 2];
      py[k] = geo.uvs[size_t(vi) * 2 + 1];
      finite = finite && std::isfinite(px[k]) && std::isfinite(py[k]);
    }
    if (!finite) continue;
    // Shift into the [0, 1) tile by the centroid (repeating textures).
    const double sx = std::floor((px[0] + px[1] + px[2]) / 3.0),
                 sy = std::floor((py[0] + py[1] + py[2]) / 3.0);
    for (int k = 0; k < 3; ++k) {
      px[k] = (px[k] - sx) * w;
      py[k] = flip ? (1.0 - (py[k] - sy)) * h : (py[k] - sy) * h;
    }
    const double area = (px[1] - px[0]) * (py[2] - py[0]) - (px[2] - px[0]) * (py[1] - py[0]);
    if (std::abs(area) < 1e-12) continue;
    const int32_t index = maps.indices(geometry)[size_t(t)];
    const uint32_t level =
        index >= 0 ? maps.arrayOf(geometry).descriptors[size_t(index)].subdivisionLevel : 0;
    const bool outlineMicro = std::abs(area) / 2.0 / double(somm::microTriangleCount(level)) >= 24.0;
    const int64_t x0 = std::max<int64_t>(0, int64_t(std::floor(std::min({px[0], px[1], px[2]}))));
    const int64_t x1 = std::min<int64_t>(int64_t(w) - 1, int64_t(std::ceil(std::max({px[0], px[1], px[2]}))));
    const int64_t y0 = std::max<int64_t>(0, int64_t(std::floor(std::min({py[0], py[1], py[2]}))));
    const int64_t y1 = std::min<int64_t>(int64_t(h) - 1, int64_t(std::ceil(std::max({py[0], py[1], py[2]}))));
    if (x1 >= x0 && y1 >= y0) visited += uint64_t(x1 - x0 + 1) * uint64_t(y1 - y0 + 1);
    if (visited > budget) {
      printError("view", "note: drew triangles " + std::to_string(first) + "-" + std::to_string(t - 1) +
                             " only: the rest cover more than 16 times the image (huge UV triangles)");
      break;
    }
    for (int64_t y = y0; y <= y1; ++y)
      for (int64_t x = x0; x <= x1; ++x) {
        const double cx = double(x) + 0.5, cy = double(y) + 0.5;
        // Barycentric weights of vertices 1 and 2.
        const double u = ((cx - px[0]) * (py[2] - py[0]) - (px[2] - px[0]) * (cy - py[0])) / area;
        const double v = ((px[1] - px[0]) * (cy - py[0]) - (cx - px[0]) * (py[1] - py[0])) / area;
        if (u < 0.0 || v < 0.0 || u + v > 1.0) continue;
        somm::State s = maps.stateUV(geometry, uint32_t(t), float(u), float(v));
        if (twoState) s = somm::toTwoState(s);
        const size_t p = size_t(y) * w + size_t(x);
        for (int c = 0; c < 3; ++c)
          rgb[p * 3 + size_t(c)] =
              rgb[p * 3 + size_t(c)] * (1.0f - kOverlay) + somm::stateColour(s)[c] * kOverlay;
        id[p] = (t + 1) << 24 | (outlineMicro ? somm::baryToIndex(float(u), float(v), level) : 0u);
      }
  }
  std::vector<uint8_t> img(size_t(w) * h * 3);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const size_t p = size_t(y) * w + x;
      const bool edge =
          id[p] != 0 && ((x + 1 < w && id[p + 1] != id[p]) || (y + 1 < h && id[p + w] != id[p]) ||
                         (x > 0 && id[p - 1] == 0) || (y > 0 && id[p - w] == 0));
      for (int c = 0; c < 3; ++c)
        img[p * 3 + size_t(c)] =
            uint8_t(std::clamp(rgb[p * 3 + size_t(c)] * (edge ? 0.35f : 1.0f), 0.0f, 255.0f));
    }
  drawStateLegend(img.data(), w, h, 3, false);
  std::vector<uint8_t> png;
  auto sink = [](void* ctx, void* data, int size) {
    auto* out = static_cast<std::vector<uint8_t>*>(ctx);
    out->insert(out->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
  };
  if (!stbi_write_png_to_func(sink, &png, int(w), int(h), 3, img.data(), int(w * 3))) {
    printError("view", o.output + ": PNG encoding failed");
    return kExitFailure;
  }
  if (somm::Status s = somm::writeFileAtomically(o.output, png); !s) {
    printError("view", s.error().message);
    return kExitFailure;
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto o = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand(
      "view",
      "Draw a geometry's micromaps over its alpha texture (grey = alpha) as a PNG: each selected triangle's "
      "UV "
      "triangle, every pixel coloured by the state a ray tracer reads there (blue transparent, green opaque, "
      "orange "
      "unknown-transparent, red unknown-opaque), micro-triangles outlined when large enough.");
  cmd->add_option("file", o->path, ".somm file")->required();
  somm::cli::addLimitOption(cmd, o->limits);
  cmd->add_option("--geometry,-g", o->geometry, "geometry index (see somm info)")->required();
  cmd->add_option("--triangles,-t", o->triangles,
                  "triangle range A-B (inclusive) or a single index; default all");
  cmd->add_option("-o,--output", o->output, "output PNG (written atomically)")->required();
  cmd->add_option("--scene", o->scene, "scene file to use instead of the one named in the .somm file");
  cmd->add_option("--size", o->size, "longest side of the image in pixels (default 1024)")
      ->check(CLI::Range(16u, 8192u));
  cmd->callback([o] { somm::cli::setExitCode(run(*o)); });
}

const somm::cli::Registration reg("view", &setup);

}  // namespace
