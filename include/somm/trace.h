// SPDX-License-Identifier: MIT
// somm — CPU ray tracing with opacity micromaps on Embree 3: every any-hit method of the paper side by side.
//
// A TraceWorld is a loaded Scene flattened into world space (every instance's vertices transformed once) and
// shared by all methods. A Tracer binds one any-hit method to the world: an Embree scene whose alpha-tested
// geometries carry intersection and occlusion filter functions instantiated for that method (opaque
// geometries carry none), so the hot path has no virtual call, no allocation and no method switch.
// Tracer::render traces the fixed workload: primary rays from a camera through a fixed sample pattern
// (identical rays for every method), one shadow ray per hit towards a directional light, diffuse shading with
// the base colour texture.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "somm/micromap.h"
#include "somm/omm_array.h"
#include "somm/result.h"
#include "somm/scene.h"

namespace somm {

// ---- methods ----

enum class MethodKind : uint8_t {
  Opaque,   // no alpha test: the lower bound, wrong pixels
  Texture,  // the alpha test itself (sampleAlpha + alphaTestPasses): the ground truth
  Bitmask,  // Gruen, Benthin & Woop 2020: 2 bits per cell of a row-major N×N grid in (u, v), else texture
  Omm,      // opacity micromap lookup: transparent reject, opaque accept, unknown → texture (4-state only)
  StateOverlay,  // traced like omm4-flat; visible hits coloured by their micromap state
};

struct MethodSpec {
  MethodKind kind = MethodKind::Texture;
  Format format = Format::FourState;  // Omm only
  std::string encoding = "flat";      // Omm only: flat, dfs, dfs-fast, rank, hybrid
  std::string name() const;           // "texture", "omm4-rank", ...
};

// Parses "opaque", "texture", "bitmask", "state-overlay", "omm2-<encoding>", "omm4-<encoding>".
Result<MethodSpec> parseMethod(std::string_view name);

// The encodings this build can trace (flat plus whatever compressed encodings are compiled in).
std::vector<std::string> traceEncodings();

// ---- workload ----

struct RenderSettings {
  uint32_t width = 640, height = 480;
  uint32_t spp = 1;      // samples per pixel, fixed pattern (pixel centre first)
  uint32_t threads = 0;  // 0: all hardware threads
  std::optional<Camera>
      camera;  // overrides the scene camera; without either the view is framed automatically
  std::array<float, 3> lightDirection{0.35f, 0.85f, 0.4f};  // towards the light (normalised internally)
  bool shadows = true;
};

struct TraceCounters {
  uint64_t primaryRays = 0, shadowRays = 0;
  uint64_t filterCalls = 0;      // filter function invocations (per ray and candidate hit)
  uint64_t textureTests = 0;     // alpha texture evaluations
  uint64_t micromapLookups = 0;  // micromap / bitmask state reads
  uint64_t primaryHits = 0;      // primary rays that hit geometry
  // Pixels at least one of whose rays ran a filter (a candidate hit on alpha-tested geometry). For `texture`
  // this is the number of pixels an exactness check actually tests; 0 means the comparison is vacuous.
  uint64_t alphaTestedPixels = 0;
  uint64_t rays() const noexcept { return primaryRays + shadowRays; }
  TraceCounters& operator+=(const TraceCounters& o) noexcept;
  friend bool operator==(const TraceCounters& a, const TraceCounters& b) noexcept {
    return a.primaryRays == b.primaryRays && a.shadowRays == b.shadowRays && a.filterCalls == b.filterCalls &&
           a.textureTests == b.textureTests && a.micromapLookups == b.micromapLookups &&
           a.primaryHits == b.primaryHits && a.alphaTestedPixels == b.alphaTestedPixels;
  }
  friend bool operator!=(const TraceCounters& a, const TraceCounters& b) noexcept { return !(a == b); }
};

// 8-bit RGBA, row 0 at the top.
struct Image {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;
};

struct RenderResult {
  Image image;
  TraceCounters counters;
  double seconds = 0;  // wall-clock time of the traced workload (rays + shading)
  double raysPerSecond() const noexcept { return seconds > 0 ? double(counters.rays()) / seconds : 0.0; }
};

// Percentage of pixels whose RGBA differs (100 when the sizes differ).
double percentPixelsDiffering(const Image& a, const Image& b) noexcept;

// Writes an 8-bit RGBA PNG atomically (temp file + rename).
Status writePng(const std::string& path, const Image& image);

// ---- the world and the tracers ----

struct Bounds {
  std::array<float, 3> lower{0, 0, 0}, upper{0, 0, 0};
};

// Per material: true when some triangle of it can fail the alpha test, decided by the library baker's own
// conservative classification (somm/bake.h: each geometry baked at level 0; a material all of whose triangles
// bake to the fully-opaque special index can never fail). False for materials that are not alpha-tested. The
// tracer gives only these materials a filter; the others are opaque geometry. Errors are the baker's.
Result<std::vector<bool>> materialsThatCanFailAlphaTest(const Scene& scene, uint32_t threads = 0);

class TraceWorld {
 public:
  // Flattens `scene` (which must outlive the world) into world space and opens an Embree device.
  static Result<std::shared_ptr<const TraceWorld>> create(const std::shared_ptr<const Scene>& scene);
  ~TraceWorld();
  TraceWorld(const TraceWorld&) = delete;
  TraceWorld& operator=(const TraceWorld&) = delete;

  const Scene& scene() const noexcept { return *scene_; }
  const Bounds& bounds() const noexcept { return bounds_; }
  // Materials traced as alpha-tested (materialsThatCanFailAlphaTest), and their geometries' triangles.
  uint32_t alphaTestedMaterials() const noexcept { return alphaTestedMaterials_; }
  uint64_t alphaTestedTriangles() const noexcept { return alphaTestedTriangles_; }
  // The camera used by render: settings override, else the scene's, else framed on the bounds.
  Camera camera(const RenderSettings& settings) const;

  struct Impl;
  const Impl& impl() const noexcept { return *impl_; }

 private:
  TraceWorld() = default;
  std::shared_ptr<const Scene> scene_;
  Bounds bounds_;
  uint32_t alphaTestedMaterials_ = 0;
  uint64_t alphaTestedTriangles_ = 0;
  std::unique_ptr<Impl> impl_;
};

class Tracer {
 public:
  ~Tracer();
  Tracer(const Tracer&) = delete;
  Tracer& operator=(const Tracer&) = delete;

  const std::string& method() const noexcept { return name_; }
  // Bytes of micromap / bitmask data the filters read (data + descriptors + index buffer / masks), 0 for
  // opaque/texture.
  uint64_t micromapBytes() const noexcept { return bytes_; }
  RenderResult render(const RenderSettings& settings) const;

  struct Impl;

 private:
  friend struct TracerFactory;
  Tracer() = default;
  std::string name_;
  uint64_t bytes_ = 0;
  std::unique_ptr<Impl> impl_;
};

Result<std::unique_ptr<Tracer>> makeOpaqueTracer(std::shared_ptr<const TraceWorld> world);
Result<std::unique_ptr<Tracer>> makeTextureTracer(std::shared_ptr<const TraceWorld> world);
// Bitmask at grid resolution 2^level × 2^level (2 bits per cell), classified by the library baker (bakeTriangle at
// that level; a square cell is known where both its micro-triangles agree).
Result<std::unique_ptr<Tracer>> makeBitmaskTracer(std::shared_ptr<const TraceWorld> world, uint32_t level);
// Flat micromaps (the spec layout), attached with somm/embree.h: special-index triangles leave the filter path
// (fully transparent: not in the BVH; fully opaque: no filter) unless splitSpecialIndices is false. `format`
// selects the method: TwoState never samples the texture (bit 0 of the state decides), FourState tests the
// texture on unknown states. Micromaps of geometries that are not alpha-tested are ignored.
Result<std::unique_ptr<Tracer>> makeFlatOmmTracer(std::shared_ptr<const TraceWorld> world,
                                                  std::shared_ptr<const SceneMicromaps> micromaps,
                                                  Format format, bool splitSpecialIndices = true);
// Traced like omm4-flat; visible hits are coloured by the state their micromap gives them.
Result<std::unique_ptr<Tracer>> makeStateOverlayTracer(std::shared_ptr<const TraceWorld> world,
                                                       std::shared_ptr<const SceneMicromaps> micromaps);

// Everything a method may need, by format. Methods whose inputs are missing fail with a message.
struct MicromapSet {
  std::shared_ptr<const SceneMicromaps> flat2, flat4;  // 2-state and 4-state
  uint32_t bitmaskLevel = 6;                           // grid 2^level × 2^level (use the micromaps' level)
  bool splitSpecialIndices = true;                     // omm methods: see makeFlatOmmTracer
};

// Any method by spec (state-overlay uses flat4; compressed encodings are built per array of the micromaps).
Result<std::unique_ptr<Tracer>> makeTracer(std::shared_ptr<const TraceWorld> world, const MethodSpec& method,
                                           const MicromapSet& micromaps);

// UV of the hit (u, v) on triangle (s0 t0 s1 t1 s2 t2), exactly as the texture method computes it.
inline void interpolateUV(const float* uv, float u, float v, float& s, float& t) noexcept {
  const float w = 1.0f - u - v;
  s = w * uv[0] + u * uv[2] + v * uv[4];
  t = w * uv[1] + u * uv[3] + v * uv[5];
}

}  // namespace somm
