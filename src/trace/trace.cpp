// SPDX-License-Identifier: MIT
// somm_trace: Embree scene, any-hit filter functions per method, the render workload.
#include "somm/trace.h"

#include <embree3/rtcore.h>
#include <stb_image_write.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>

#include "somm/bake.h"
#include "somm/embree.h"
#include "somm/encode.h"
#include "somm/io.h"
#include "somm/state_colours.h"
#include "trace_internal.h"

namespace somm {

// ---- small helpers ----

TraceCounters& TraceCounters::operator+=(const TraceCounters& o) noexcept {
  primaryRays += o.primaryRays;
  shadowRays += o.shadowRays;
  filterCalls += o.filterCalls;
  textureTests += o.textureTests;
  micromapLookups += o.micromapLookups;
  primaryHits += o.primaryHits;
  alphaTestedPixels += o.alphaTestedPixels;
  return *this;
}

std::string MethodSpec::name() const {
  switch (kind) {
    case MethodKind::Opaque:
      return "opaque";
    case MethodKind::Texture:
      return "texture";
    case MethodKind::Bitmask:
      return "bitmask";
    case MethodKind::StateOverlay:
      return "state-overlay";
    case MethodKind::Omm:
      return std::string(format == Format::TwoState ? "omm2-" : "omm4-") + encoding;
  }
  return "?";
}

std::vector<std::string> traceEncodings() {
  return detail::encodingNames();
}

Result<MethodSpec> parseMethod(std::string_view name) {
  MethodSpec m;
  if (name == "opaque")
    m.kind = MethodKind::Opaque;
  else if (name == "texture")
    m.kind = MethodKind::Texture;
  else if (name == "bitmask")
    m.kind = MethodKind::Bitmask;
  else if (name == "state-overlay")
    m.kind = MethodKind::StateOverlay;
  else if (name.starts_with("omm2-") || name.starts_with("omm4-")) {
    m.kind = MethodKind::Omm;
    m.format = name[3] == '2' ? Format::TwoState : Format::FourState;
    m.encoding = std::string(name.substr(5));
    const auto encs = traceEncodings();
    if (std::find(encs.begin(), encs.end(), m.encoding) == encs.end()) {
      std::string list;
      for (const auto& e : encs) list += (list.empty() ? "" : ", ") + e;
      return makeError(ErrorCode::InvalidArgument, "method '" + std::string(name) + "': unknown encoding '" +
                                                       m.encoding + "' (have " + list + ")");
    }
  } else {
    return makeError(
        ErrorCode::InvalidArgument,
        "unknown method '" + std::string(name) +
            "' (expected opaque, texture, bitmask, state-overlay, omm2-<encoding> or omm4-<encoding>)");
  }
  return m;
}

double percentPixelsDiffering(const Image& a, const Image& b) noexcept {
  if (a.width != b.width || a.height != b.height || a.rgba.size() != b.rgba.size()) return 100.0;
  const size_t n = size_t(a.width) * a.height;
  if (n == 0) return 0.0;
  size_t diff = 0;
  for (size_t i = 0; i < n; ++i)
    diff += (a.rgba[4 * i] != b.rgba[4 * i] || a.rgba[4 * i + 1] != b.rgba[4 * i + 1] ||
             a.rgba[4 * i + 2] != b.rgba[4 * i + 2] || a.rgba[4 * i + 3] != b.rgba[4 * i + 3]);
  return 100.0 * double(diff) / double(n);
}

Status writePng(const std::string& path, const Image& image) {
  if (image.width == 0 || image.height == 0 || image.rgba.size() != size_t(image.width) * image.height * 4)
    return makeError(ErrorCode::InvalidArgument, path + ": empty or malformed image");
  // Encoded in memory, then written atomically (a unique temporary file, never a fixed PATH.tmp).
  std::vector<uint8_t> png;
  auto sink = [](void* ctx, void* data, int size) {
    auto* out = static_cast<std::vector<uint8_t>*>(ctx);
    out->insert(out->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
  };
  if (!stbi_write_png_to_func(sink, &png, int(image.width), int(image.height), 4, image.rgba.data(),
                              int(image.width * 4)))
    return makeError(ErrorCode::IoError, path + ": cannot encode PNG");
  return writeFileAtomically(path, png.data(), png.size());
}

// ---- the world ----

namespace {

using V3 = std::array<float, 3>;
inline V3 sub(V3 a, V3 b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
inline V3 add(V3 a, V3 b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
inline V3 mul(V3 a, float s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
inline float dot(V3 a, V3 b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline V3 cross(V3 a, V3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline V3 normalize(V3 a) {
  const float l = std::sqrt(dot(a, a));
  return l > 0 ? mul(a, 1.0f / l) : V3{0, 0, 1};
}

}  // namespace

Result<std::vector<bool>> materialsThatCanFailAlphaTest(const Scene& scene, uint32_t threads) {
  std::vector<bool> canFail(scene.materials.size(), false);
  BakeOptions o;
  o.level = 0;
  o.threads = threads;
  for (const Geometry& g : scene.geometries) {
    if (g.material >= scene.materials.size()) continue;
    const Material& m = scene.materials[g.material];
    if (!m.alphaTested() || canFail[g.material] || g.triangleCount() == 0) continue;
    auto baked = bakeGeometry(g, m, o);
    if (!baked) return baked.error();
    if (baked->stats.specialCount[size_t(State::Opaque)] != g.triangleCount()) canFail[g.material] = true;
  }
  return canFail;
}

TraceWorld::~TraceWorld() {
  if (impl_ && impl_->device) rtcReleaseDevice(impl_->device);
}

Result<std::shared_ptr<const TraceWorld>> TraceWorld::create(const std::shared_ptr<const Scene>& scene) {
  const std::string where = scene->sourcePath.empty() ? std::string("scene") : scene->sourcePath;
  std::shared_ptr<TraceWorld> w(new TraceWorld());
  w->scene_ = scene;
  w->impl_ = std::make_unique<Impl>();
  Impl& im = *w->impl_;
  im.device = rtcNewDevice(nullptr);
  if (!im.device) return makeError(ErrorCode::UnsupportedFormat, "cannot create an Embree device");

  auto canFail = materialsThatCanFailAlphaTest(*scene);
  if (!canFail) return makeError(canFail.error().code, where + ": " + canFail.error().message);
  for (bool f : *canFail) w->alphaTestedMaterials_ += f;
  im.geometries.resize(scene->geometries.size());
  for (size_t g = 0; g < scene->geometries.size(); ++g) {
    const Geometry& geo = scene->geometries[g];
    if (geo.material >= scene->materials.size())
      return makeError(ErrorCode::CorruptFile,
                       where + ": geometry " + std::to_string(g) + " has no material");
    const Material& mat = scene->materials[geo.material];
    const size_t nv = geo.positions.size() / 3;
    if (geo.positions.size() % 3 != 0 || geo.indices.size() % 3 != 0)
      return makeError(ErrorCode::CorruptFile,
                       where + ": geometry " + std::to_string(g) + " has malformed arrays");
    for (uint32_t i : geo.indices)
      if (i >= nv)
        return makeError(ErrorCode::CorruptFile,
                         where + ": geometry " + std::to_string(g) + " has a vertex index out of range");
    if (!geo.uvs.empty() && geo.uvs.size() != 2 * nv)
      return makeError(ErrorCode::CorruptFile,
                       where + ": geometry " + std::to_string(g) + " has a UV count mismatch");
    detail::GeometryData& d = im.geometries[g];
    d.geometry = uint32_t(g);
    d.indices = geo.indices;
    d.indices.resize(geo.indices.size() + 4, 0);  // Embree reads buffers with 16-byte loads
    d.triUVs.resize(size_t(geo.triangleCount()) * 6, 0.0f);
    if (!geo.uvs.empty())
      for (size_t t = 0; t < geo.triangleCount(); ++t)
        for (int k = 0; k < 3; ++k) {
          d.triUVs[6 * t + 2 * k] = geo.uvs[2 * size_t(geo.indices[3 * t + k])];
          d.triUVs[6 * t + 2 * k + 1] = geo.uvs[2 * size_t(geo.indices[3 * t + k]) + 1];
        }
    d.alpha = mat.alpha && mat.alpha->width > 0 && mat.alpha->height > 0 ? mat.alpha.get() : nullptr;
    if (d.alpha && !d.alpha->consistent())
      return makeError(ErrorCode::CorruptFile,
                       where + ": material '" + mat.name + "' has a malformed alpha texture");
    d.sampler = mat.sampler;
    d.cutoff = mat.alphaCutoff;
    d.constantAlpha = mat.baseColorFactor[3];
    d.alphaTested = (*canFail)[geo.material];
    if (d.alphaTested) w->alphaTestedTriangles_ += geo.triangleCount();
    d.material = &mat;
  }

  Bounds b;
  b.lower = {std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
             std::numeric_limits<float>::infinity()};
  b.upper = mul(b.lower, -1.0f);
  for (size_t i = 0; i < scene->instances.size(); ++i) {
    const Instance& inst = scene->instances[i];
    if (inst.geometry >= scene->geometries.size())
      return makeError(ErrorCode::CorruptFile,
                       where + ": instance " + std::to_string(i) + " names no geometry");
    const Geometry& geo = scene->geometries[inst.geometry];
    if (!isUsableTransform(inst.transform))
      return makeError(ErrorCode::CorruptFile, where + ": instance " + std::to_string(i) + " (geometry " +
                                                   std::to_string(inst.geometry) +
                                                   (geo.name.empty() ? "" : " '" + geo.name + "'") +
                                                   ") has a singular or non-finite transform");
    if (geo.triangleCount() == 0) continue;
    detail::FlatGeometry f;
    f.geometry = inst.geometry;
    f.instance = uint32_t(i);
    const size_t nv = geo.positions.size() / 3;
    f.positions.resize(3 * nv + 4, 0.0f);
    const auto& m = inst.transform;  // column-major
    for (size_t v = 0; v < nv; ++v) {
      const float x = geo.positions[3 * v], y = geo.positions[3 * v + 1], z = geo.positions[3 * v + 2];
      for (int r = 0; r < 3; ++r) {
        const float p = m[r] * x + m[4 + r] * y + m[8 + r] * z + m[12 + r];
        f.positions[3 * v + r] = p;
        if (std::isfinite(p)) {
          b.lower[r] = std::min(b.lower[r], p);
          b.upper[r] = std::max(b.upper[r], p);
        }
      }
    }
    im.flat.push_back(std::move(f));
  }
  if (!(b.lower[0] <= b.upper[0])) b = Bounds{};
  w->bounds_ = b;
  return std::shared_ptr<const TraceWorld>(std::move(w));
}

Camera TraceWorld::camera(const RenderSettings& settings) const {
  if (settings.camera) return *settings.camera;
  if (scene_->camera) return *scene_->camera;
  // Frame the bounding box: the smallest distance along a fixed oblique direction at which all eight corners
  // project inside the image (a little margin).
  const V3 c = mul(add(bounds_.lower, bounds_.upper), 0.5f);
  Camera cam;
  cam.yfovRadians = 0.8f;
  const V3 toCam = normalize({0.45f, 0.2f, 1.0f});
  const V3 right = normalize(cross(mul(toCam, -1.0f), {0, 1, 0}));
  const V3 up = cross(right, mul(toCam, -1.0f));
  const float tanV = std::tan(0.5f * cam.yfovRadians);
  const float tanH = tanV * float(std::max(1u, settings.width)) / float(std::max(1u, settings.height));
  float dist = 1e-6f;
  for (int k = 0; k < 8; ++k) {
    const V3 corner{(k & 1) ? bounds_.upper[0] : bounds_.lower[0],
                    (k & 2) ? bounds_.upper[1] : bounds_.lower[1],
                    (k & 4) ? bounds_.upper[2] : bounds_.lower[2]};
    const V3 o = sub(corner, c);
    dist = std::max(dist,
                    dot(o, toCam) + std::max(std::fabs(dot(o, right)) / tanH, std::fabs(dot(o, up)) / tanV));
  }
  cam.eye = add(c, mul(toCam, dist));
  cam.target = c;
  cam.up = {0, 1, 0};
  return cam;
}

// ---- filter functions of the baselines (texture, bitmask); micromap filters are somm/embree.h's ----

namespace detail {

// The texture test as the alpha test of somm/embree.h's micromap filters.
struct TextureAlphaTest {
  const GeometryData* geometry = nullptr;
  bool operator()(uint32_t triangle, float u, float v) const noexcept {
    return textureTest(*geometry, triangle, u, v);
  }
};

// One filter function per policy: the same function for intersection and occlusion (idempotent, pure in the
// hit).
template <class Policy>
void filterFunction(const RTCFilterFunctionNArguments* args) noexcept {
  embree::FilterCounters& c = *reinterpret_cast<const embree::CountingContext*>(args->context)->counters;
  const auto& data = *static_cast<const typename Policy::Data*>(args->geometryUserPtr);
  const unsigned n = args->N;
  for (unsigned i = 0; i < n; ++i) {
    if (args->valid[i] == 0) continue;
    ++c.filterCalls;
    const uint32_t prim = RTCHitN_primID(args->hit, n, i);
    const float u = RTCHitN_u(args->hit, n, i), v = RTCHitN_v(args->hit, n, i);
    if (!Policy::accept(data, prim, u, v, c)) args->valid[i] = 0;
  }
}

struct TexturePolicy {
  using Data = GeometryData;
  static bool accept(const Data& d, uint32_t prim, float u, float v, embree::FilterCounters& c) noexcept {
    ++c.textureTests;
    return textureTest(d, prim, u, v);
  }
};

struct BitmaskPolicy {
  using Data = BitmaskData;
  static bool accept(const Data& d, uint32_t prim, float u, float v, embree::FilterCounters& c) noexcept {
    ++c.micromapLookups;
    const float n = float(d.n);
    const float fu = u > 0.0f ? u * n : 0.0f, fv = v > 0.0f ? v * n : 0.0f;  // NaN → 0
    const uint32_t iu = std::min(uint32_t(fu), d.n - 1), iv = std::min(uint32_t(fv), d.n - 1);
    const uint32_t cell = iv * d.n + iu;
    const uint32_t code = (d.masks[size_t(prim) * d.bytesPerTriangle + (cell >> 2)] >> (2 * (cell & 3))) & 3u;
    if (code == 1) return true;
    if (code == 0) return false;
    ++c.textureTests;
    return textureTest(*d.geometry, prim, u, v);
  }
};

}  // namespace detail

// ---- tracers ----

struct TracerFactory {
  struct Spec {
    std::string name;
    uint64_t bytes = 0;
    MethodKind kind = MethodKind::Texture;
    // Baselines: `filter` on alpha-tested geometries, userData[g] = its data for scene geometry g.
    RTCFilterFunctionN filter = nullptr;
    std::vector<void*> userData;
    // Micromap methods: alpha-tested geometries attached with somm/embree.h (encoded[a]: array a's encoding, or
    // null for flat).
    std::shared_ptr<const SceneMicromaps> micromaps;
    std::vector<const EncodedArray*> encoded;
    bool twoState = false, split = true;
    std::shared_ptr<const void> keepAlive;
  };

  static Result<std::unique_ptr<Tracer>> build(std::shared_ptr<const TraceWorld> world, Spec spec) {
    const TraceWorld::Impl& w = world->impl();
    RTCScene scene = rtcNewScene(w.device);
    if (!scene) return makeError(ErrorCode::UnsupportedFormat, "cannot create an Embree scene");
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    auto impl = std::make_unique<Tracer::Impl>();
    auto fail = [&](Error e) -> Result<std::unique_ptr<Tracer>> {
      rtcReleaseScene(scene);
      return e;
    };
    auto record = [&](unsigned id, uint32_t flat, const uint32_t* triangleOf) {
      if (id == RTC_INVALID_GEOMETRY_ID) return;
      if (impl->parts.size() <= id) impl->parts.resize(id + 1);
      impl->parts[id] = Tracer::Impl::Part{flat, triangleOf};
    };
    for (size_t fi = 0; fi < w.flat.size(); ++fi) {
      const detail::FlatGeometry& f = w.flat[fi];
      const detail::GeometryData& gd = w.geometries[f.geometry];
      const size_t tris = (gd.indices.size() - 4) / 3, verts = (f.positions.size() - 4) / 3;
      if (spec.micromaps && gd.alphaTested) {
        embree::TriangleMeshView mesh;
        mesh.vertices = f.positions.data();
        mesh.vertexCount = verts;
        mesh.indices = gd.indices.data();
        mesh.triangleCount = tris;
        embree::MicromapSource src;
        src.micromaps = spec.micromaps.get();
        src.geometry = f.geometry;
        src.encoded =
            spec.encoded.empty() ? nullptr : spec.encoded[spec.micromaps->geometries[f.geometry].array];
        src.twoState = spec.twoState;
        embree::AttachOptions ao;
        ao.splitSpecialIndices = spec.split;
        ao.countWork = true;
        auto attached =
            embree::attachMicromaps(w.device, scene, mesh, src, detail::TextureAlphaTest{&gd}, ao);
        if (!attached) return fail(attached.error());
        embree::AttachedGeometry& a = impl->attached.emplace_back(std::move(attached).value());
        record(a.opaqueId(), uint32_t(fi), a.triangleMap(a.opaqueId()));
        record(a.filteredId(), uint32_t(fi), a.triangleMap(a.filteredId()));
        continue;
      }
      RTCGeometry geom = rtcNewGeometry(w.device, RTC_GEOMETRY_TYPE_TRIANGLE);
      rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, f.positions.data(), 0,
                                 3 * sizeof(float), verts);
      rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, gd.indices.data(), 0,
                                 3 * sizeof(uint32_t), tris);
      if (spec.filter && gd.alphaTested) {
        rtcSetGeometryUserData(geom, spec.userData[f.geometry]);
        rtcSetGeometryIntersectFilterFunction(geom, spec.filter);
        rtcSetGeometryOccludedFilterFunction(geom, spec.filter);
      }
      rtcCommitGeometry(geom);
      record(rtcAttachGeometry(scene, geom), uint32_t(fi), nullptr);
      rtcReleaseGeometry(geom);
    }
    rtcCommitScene(scene);
    if (rtcGetDeviceError(w.device) != RTC_ERROR_NONE)
      return fail(makeError(ErrorCode::UnsupportedFormat,
                            "Embree failed to build the scene for method " + spec.name));
    std::unique_ptr<Tracer> t(new Tracer());
    t->name_ = std::move(spec.name);
    t->bytes_ = spec.bytes;
    impl->world = std::move(world);
    impl->scene = scene;
    impl->keepAlive = std::move(spec.keepAlive);
    impl->kind = spec.kind;
    if (spec.kind == MethodKind::StateOverlay) impl->overlay = spec.micromaps;
    impl->micromaps = std::move(spec.micromaps);
    t->impl_ = std::move(impl);
    return t;
  }
};

Tracer::~Tracer() {
  if (impl_ && impl_->scene) rtcReleaseScene(impl_->scene);
}

Result<std::unique_ptr<Tracer>> makeOpaqueTracer(std::shared_ptr<const TraceWorld> world) {
  TracerFactory::Spec spec;
  spec.name = "opaque";
  spec.kind = MethodKind::Opaque;
  return TracerFactory::build(std::move(world), std::move(spec));
}

Result<std::unique_ptr<Tracer>> makeTextureTracer(std::shared_ptr<const TraceWorld> world) {
  TracerFactory::Spec spec;
  spec.name = "texture";
  spec.kind = MethodKind::Texture;
  spec.filter = &detail::filterFunction<detail::TexturePolicy>;
  for (const auto& g : world->impl().geometries)
    spec.userData.push_back(const_cast<detail::GeometryData*>(&g));
  return TracerFactory::build(std::move(world), std::move(spec));
}

Result<std::unique_ptr<Tracer>> makeBitmaskTracer(std::shared_ptr<const TraceWorld> world, uint32_t level) {
  if (level > 10)
    return makeError(ErrorCode::InvalidArgument, "bitmask level " + std::to_string(level) + " > 10");
  const auto& geoms = world->impl().geometries;
  struct Store {
    std::vector<std::vector<uint8_t>> masks;
    std::vector<detail::BitmaskData> data;
  };
  auto store = std::make_shared<Store>();
  store->masks.resize(geoms.size());
  store->data.resize(geoms.size());
  const uint32_t n = 1u << level;
  const uint32_t bytesPerTriangle = std::max(1u, n * n / 4);
  uint64_t bytes = 0;
  for (size_t g = 0; g < geoms.size(); ++g) {
    const detail::GeometryData& gd = geoms[g];
    detail::BitmaskData& bd = store->data[g];
    bd.geometry = &gd;
    bd.n = n;
    bd.bytesPerTriangle = bytesPerTriangle;
    if (!gd.alphaTested) continue;
    const size_t tris = gd.triUVs.size() / 6;
    auto& mask = store->masks[g];
    mask.assign(tris * bytesPerTriangle, 0);
    // Triangles with identical UVs get identical masks: build each distinct UV triangle's mask once, then
    // copy.
    std::map<std::array<float, 6>, size_t> first;
    std::vector<size_t> source(tris), builds;
    for (size_t t = 0; t < tris; ++t) {
      std::array<float, 6> key;
      std::copy_n(gd.triUVs.data() + 6 * t, 6, key.begin());
      auto [it, fresh] = first.try_emplace(key, t);
      if (fresh) builds.push_back(t);
      source[t] = it->second;
    }
    // The baker's own classification (somm/bake.h): bake the triangle at the grid's level; square cell (iu, iv)
    // is the union of the closed upright micro-triangle (iu, iv) and the inverted one beside it, so it is known
    // only where both agree. Diagonal cells (iu + iv = n - 1) hold the upright micro-triangle only (hits beyond
    // the hypotenuse are rounding, within the bake margin); cells with iu + iv = n are reachable only by rounding at
    // the hypotenuse corner shared by the upright micro-triangles (iu - 1, iv) and (iu, iv - 1); cells further out
    // cannot be hit and stay unknown.
    std::optional<AlphaMask> alphaMask;
    if (gd.alpha) alphaMask.emplace(*gd.alpha, gd.sampler, gd.cutoff);
    const State constant = alphaTestPasses(gd.constantAlpha, gd.cutoff) ? State::Opaque : State::Transparent;
    tbb::parallel_for(size_t(0), builds.size(), [&](size_t b) {
      const size_t t = builds[b];
      const float* uv = gd.triUVs.data() + 6 * t;
      uint8_t* m = mask.data() + t * bytesPerTriangle;
      std::optional<TriangleBake> tb;
      if (alphaMask)
        tb.emplace(bakeTriangle(*alphaMask, {uv[0], uv[1]}, {uv[2], uv[3]}, {uv[4], uv[5]}, level,
                                Format::FourState));
      const float inv = 1.0f / float(n);
      auto micro = [&](int64_t iu, int64_t iv, bool inverted) -> State {
        if (!tb) return constant;
        const float off = inverted ? 2.0f / 3.0f : 1.0f / 3.0f;
        return tb->map.get(baryToIndex((float(iu) + off) * inv, (float(iv) + off) * inv, level));
      };
      auto combine = [](State a, State b) { return a == b && isKnown(a) ? a : State::UnknownOpaque; };
      for (uint32_t iv = 0; iv < n; ++iv)
        for (uint32_t iu = 0; iu < n; ++iu) {
          State st = State::UnknownOpaque;
          if (iu + iv + 2 <= n)
            st = combine(micro(iu, iv, false), micro(iu, iv, true));
          else if (iu + iv + 1 == n)
            st = micro(iu, iv, false);
          else if (iu + iv == n)
            st = combine(micro(int64_t(iu) - 1, iv, false), micro(iu, int64_t(iv) - 1, false));
          const uint32_t code = st == State::Transparent ? 0u : st == State::Opaque ? 1u : 2u;
          const uint32_t cell = iv * n + iu;
          m[cell >> 2] = uint8_t(m[cell >> 2] | (code << (2 * (cell & 3))));
        }
    });
    for (size_t t = 0; t < tris; ++t)
      if (source[t] != t)
        std::copy_n(mask.data() + source[t] * bytesPerTriangle, bytesPerTriangle,
                    mask.data() + t * bytesPerTriangle);
    bd.masks = mask.data();
    bytes += mask.size();
  }
  std::vector<void*> user;
  for (auto& d : store->data) user.push_back(&d);
  TracerFactory::Spec spec;
  spec.name = "bitmask";
  spec.bytes = bytes;
  spec.kind = MethodKind::Bitmask;
  spec.filter = &detail::filterFunction<detail::BitmaskPolicy>;
  spec.userData = std::move(user);
  spec.keepAlive = store;
  return TracerFactory::build(std::move(world), std::move(spec));
}

namespace {

uint64_t flatBytes(const OmmArray& a) {
  return a.data.size() + a.descriptors.size() * sizeof(TriangleDescriptor) +
         a.indices.size() * (a.indexType() == IndexType::UInt16 ? 2u : 4u);
}

// The scene-level checks (the per-geometry ones are attachMicromaps's).
Status checkMicromaps(const TraceWorld& world, const SceneMicromaps& m) {
  const auto& geoms = world.impl().geometries;
  if (m.geometries.size() != geoms.size())
    return makeError(ErrorCode::InvalidArgument, "micromaps for " + std::to_string(m.geometries.size()) +
                                                     " geometries, the scene has " +
                                                     std::to_string(geoms.size()));
  for (size_t g = 0; g < geoms.size(); ++g) {
    if (!geoms[g].alphaTested) continue;
    const GeometryMicromaps& r = m.geometries[g];
    const size_t tris = geoms[g].triUVs.size() / 6;
    if (r.triangleCount != tris)
      return makeError(ErrorCode::InvalidArgument,
                       "geometry " + std::to_string(g) + ": micromap index count " +
                           std::to_string(r.triangleCount) + " != triangle count " + std::to_string(tris));
    if (r.array >= m.arrays.size() ||
        uint64_t(r.firstTriangle) + r.triangleCount > m.arrays[r.array].indices.size())
      return makeError(ErrorCode::InvalidArgument,
                       "geometry " + std::to_string(g) + ": micromaps outside the arrays");
  }
  return Ok{};
}

Result<std::unique_ptr<Tracer>> makeFlat(std::shared_ptr<const TraceWorld> world,
                                         std::shared_ptr<const SceneMicromaps> micromaps, Format format,
                                         bool overlay, bool split) {
  if (Status s = checkMicromaps(*world, *micromaps); !s) return s.error();
  TracerFactory::Spec spec;
  spec.name = overlay ? "state-overlay" : (format == Format::TwoState ? "omm2-flat" : "omm4-flat");
  spec.kind = overlay ? MethodKind::StateOverlay : MethodKind::Omm;
  for (const OmmArray& a : micromaps->arrays) spec.bytes += flatBytes(a);
  spec.micromaps = std::move(micromaps);
  spec.twoState = format == Format::TwoState;
  spec.split = split;
  return TracerFactory::build(std::move(world), std::move(spec));
}

Result<std::unique_ptr<Tracer>> makeEncoded(std::shared_ptr<const TraceWorld> world,
                                            std::shared_ptr<const SceneMicromaps> micromaps, Format format,
                                            Encoding encoding, bool split) {
  if (Status s = checkMicromaps(*world, *micromaps); !s) return s.error();
  auto store = std::make_shared<std::vector<EncodedArray>>();
  TracerFactory::Spec spec;
  for (const OmmArray& a : micromaps->arrays) {
    auto built = EncodedArray::build(a, encoding);
    if (!built) return built.error();
    spec.bytes += built->byteSize();
    store->push_back(std::move(built).value());
  }
  for (const EncodedArray& e : *store) spec.encoded.push_back(&e);
  spec.name = std::string(format == Format::TwoState ? "omm2-" : "omm4-") + encodingName(encoding);
  spec.kind = MethodKind::Omm;
  spec.micromaps = std::move(micromaps);
  spec.twoState = format == Format::TwoState;
  spec.split = split;
  spec.keepAlive = store;
  return TracerFactory::build(std::move(world), std::move(spec));
}

}  // namespace

Result<std::unique_ptr<Tracer>> makeFlatOmmTracer(std::shared_ptr<const TraceWorld> world,
                                                  std::shared_ptr<const SceneMicromaps> micromaps,
                                                  Format format, bool splitSpecialIndices) {
  return makeFlat(std::move(world), std::move(micromaps), format, false, splitSpecialIndices);
}

Result<std::unique_ptr<Tracer>> makeStateOverlayTracer(std::shared_ptr<const TraceWorld> world,
                                                       std::shared_ptr<const SceneMicromaps> micromaps) {
  return makeFlat(std::move(world), std::move(micromaps), Format::FourState, true, true);
}

Result<std::unique_ptr<Tracer>> makeTracer(std::shared_ptr<const TraceWorld> world, const MethodSpec& method,
                                           const MicromapSet& micromaps) {
  auto need = [&](const std::shared_ptr<const SceneMicromaps>& a) -> Status {
    if (!a)
      return makeError(ErrorCode::InvalidArgument,
                       "method " + method.name() + ": no micromaps of that format");
    return Ok{};
  };
  switch (method.kind) {
    case MethodKind::Opaque:
      return makeOpaqueTracer(std::move(world));
    case MethodKind::Texture:
      return makeTextureTracer(std::move(world));
    case MethodKind::Bitmask:
      return makeBitmaskTracer(std::move(world), micromaps.bitmaskLevel);
    case MethodKind::StateOverlay:
      if (Status s = need(micromaps.flat4); !s) return s.error();
      return makeStateOverlayTracer(std::move(world), micromaps.flat4);
    case MethodKind::Omm: {
      const auto& m = method.format == Format::TwoState ? micromaps.flat2 : micromaps.flat4;
      if (Status s = need(m); !s) return s.error();
      if (method.encoding == "flat")
        return makeFlat(std::move(world), m, method.format, false, micromaps.splitSpecialIndices);
      if (auto e = parseEncodingName(method.encoding))
        return makeEncoded(std::move(world), m, method.format, *e, micromaps.splitSpecialIndices);
      return makeError(ErrorCode::InvalidArgument, "method " + method.name() + ": unknown encoding");
    }
  }
  return makeError(ErrorCode::InvalidArgument, "unknown method");
}

// ---- rendering ----

namespace {

// Base colour at a texture coordinate: nearest texel of the base colour image (sampler wrap) × factor.
V3 baseColor(const Material& m, float s, float t) {
  V3 c{m.baseColorFactor[0], m.baseColorFactor[1], m.baseColorFactor[2]};
  if (m.baseColor && m.baseColor->width > 0 && m.baseColor->height > 0 &&
      m.baseColor->rgba.size() == size_t(m.baseColor->width) * m.baseColor->height * 4) {
    const ColorImage& img = *m.baseColor;
    const uint32_t x = wrapTexel(texelFloor(double(s) * img.width), img.width, m.sampler.wrapS);
    const uint32_t y = wrapTexel(texelFloor(double(t) * img.height), img.height, m.sampler.wrapT);
    const uint8_t* p = img.rgba.data() + (size_t(y) * img.width + x) * 4;
    c = {c[0] * p[0] / 255.0f, c[1] * p[1] / 255.0f, c[2] * p[2] / 255.0f};
  }
  return c;
}

V3 rgb(const uint8_t* c) {
  return {c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f};
}

}  // namespace

RenderResult Tracer::render(const RenderSettings& settings) const {
  assert(settings.width > 0 && settings.height > 0 && settings.spp > 0);
  const TraceWorld& world = *impl_->world;
  const TraceWorld::Impl& w = world.impl();
  const Scene& scene = world.scene();
  const Camera cam = world.camera(settings);
  const V3 fwd = normalize(sub(cam.target, cam.eye));
  const V3 right = normalize(cross(fwd, cam.up));
  const V3 up = cross(right, fwd);
  const float tanHalf = std::tan(0.5f * cam.yfovRadians);
  const float aspect = float(settings.width) / float(settings.height);
  const V3 light = normalize(settings.lightDirection);
  const V3 ext = sub(world.bounds().upper, world.bounds().lower);
  const float sceneSize = std::max(1e-6f, std::sqrt(dot(ext, ext)));
  const float shadowEps = 1e-4f * sceneSize;
  const uint32_t W = settings.width, H = settings.height, spp = settings.spp;
  constexpr uint32_t kTile = 16;
  const uint32_t tilesX = (W + kTile - 1) / kTile, tilesY = (H + kTile - 1) / kTile;
  std::vector<TraceCounters> tileCounters(size_t(tilesX) * tilesY);
  RenderResult result;
  result.image.width = W;
  result.image.height = H;
  result.image.rgba.assign(size_t(W) * H * 4, 255);
  const RTCScene rtcScene = impl_->scene;
  const MethodKind kind = impl_->kind;
  const SceneMicromaps* overlay = impl_->overlay.get();
  const std::vector<Impl::Part>& parts = impl_->parts;

  auto traceTile = [&](uint32_t tile) {
    TraceCounters local;
    embree::FilterCounters work;
    embree::CountingContext ctx;
    embree::initCountingContext(ctx, &work);
    const uint32_t x0 = (tile % tilesX) * kTile, y0 = (tile / tilesX) * kTile;
    const uint32_t x1 = std::min(W, x0 + kTile), y1 = std::min(H, y0 + kTile);
    for (uint32_t y = y0; y < y1; ++y)
      for (uint32_t x = x0; x < x1; ++x) {
        V3 acc{0, 0, 0};
        const uint64_t filterCallsBefore = work.filterCalls;
        for (uint32_t s = 0; s < spp; ++s) {
          // Fixed sample pattern: pixel centre, then the R2 sequence around it.
          float ox = 0.5f + float(s) * 0.7548776662f, oy = 0.5f + float(s) * 0.5698402910f;
          ox -= std::floor(ox);
          oy -= std::floor(oy);
          const float px = (2.0f * (float(x) + ox) / float(W) - 1.0f) * tanHalf * aspect;
          const float py = (1.0f - 2.0f * (float(y) + oy) / float(H)) * tanHalf;
          const V3 dir = normalize(add(fwd, add(mul(right, px), mul(up, py))));
          RTCRayHit rh;
          rh.ray.org_x = cam.eye[0];
          rh.ray.org_y = cam.eye[1];
          rh.ray.org_z = cam.eye[2];
          rh.ray.dir_x = dir[0];
          rh.ray.dir_y = dir[1];
          rh.ray.dir_z = dir[2];
          rh.ray.tnear = 0.0f;
          rh.ray.tfar = std::numeric_limits<float>::infinity();
          rh.ray.time = 0.0f;
          rh.ray.mask = 0xffffffffu;
          rh.ray.id = 0;
          rh.ray.flags = 0;
          rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
          rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
          rtcIntersect1(rtcScene, &ctx.rtc, &rh);
          ++local.primaryRays;
          if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
            const float k = 0.5f + 0.5f * dir[1];
            acc = add(acc, add(mul(V3{0.9f, 0.93f, 0.97f}, 1.0f - k), mul(V3{0.45f, 0.62f, 0.88f}, k)));
            continue;
          }
          ++local.primaryHits;
          const Impl::Part& part = parts[rh.hit.geomID];
          const detail::FlatGeometry& f = w.flat[part.flat];
          const detail::GeometryData& gd = w.geometries[f.geometry];
          const uint32_t prim = part.triangleOf ? part.triangleOf[rh.hit.primID] : rh.hit.primID;
          const uint32_t* tri = gd.indices.data() + 3 * size_t(prim);
          const float* P = f.positions.data();
          const V3 a{P[3 * tri[0]], P[3 * tri[0] + 1], P[3 * tri[0] + 2]};
          const V3 b{P[3 * tri[1]], P[3 * tri[1] + 1], P[3 * tri[1] + 2]};
          const V3 c{P[3 * tri[2]], P[3 * tri[2] + 1], P[3 * tri[2] + 2]};
          V3 n = normalize(cross(sub(b, a), sub(c, a)));
          if (dot(n, dir) > 0) n = mul(n, -1.0f);
          float s0, t0;
          interpolateUV(gd.triUVs.data() + 6 * size_t(prim), rh.hit.u, rh.hit.v, s0, t0);
          V3 albedo = baseColor(*gd.material, s0, t0);
          if (kind == MethodKind::StateOverlay)
            albedo = gd.alphaTested ? rgb(stateColour(overlay->stateUV(f.geometry, prim, rh.hit.u, rh.hit.v)))
                                    : rgb(kNotAlphaTestedColour);
          const float ndl = dot(n, light);
          float direct = 0.0f;
          if (ndl > 0.0f) {
            direct = ndl;
            if (settings.shadows) {
              const V3 p = add(cam.eye, mul(dir, rh.ray.tfar));
              RTCRay sr;
              sr.org_x = p[0];
              sr.org_y = p[1];
              sr.org_z = p[2];
              sr.dir_x = light[0];
              sr.dir_y = light[1];
              sr.dir_z = light[2];
              sr.tnear = shadowEps;
              sr.tfar = std::numeric_limits<float>::infinity();
              sr.time = 0.0f;
              sr.mask = 0xffffffffu;
              sr.id = 0;
              sr.flags = 0;
              rtcOccluded1(rtcScene, &ctx.rtc, &sr);
              ++local.shadowRays;
              if (sr.tfar < 0.0f) direct = 0.0f;
            }
          }
          // The overlay is flat (no shading): lit and shadowed hits of one state have one colour.
          acc = add(acc, kind == MethodKind::StateOverlay ? albedo : mul(albedo, 0.3f + 0.7f * direct));
        }
        local.alphaTestedPixels += work.filterCalls != filterCallsBefore;
        uint8_t* px = result.image.rgba.data() + (size_t(y) * W + x) * 4;
        for (int k = 0; k < 3; ++k) {
          const float v = std::clamp(acc[k] / float(spp), 0.0f, 1.0f);
          // v >= 0, so truncating v·255 + ½ rounds; kept as is so that renders stay bit-identical.
          px[k] = uint8_t(v * 255.0f + 0.5f);  // NOLINT(bugprone-incorrect-roundings)
        }
        px[3] = 255;
      }
    local.filterCalls = work.filterCalls;
    local.textureTests = work.textureTests;
    local.micromapLookups = work.micromapLookups;
    tileCounters[tile] = local;
  };

  tbb::task_arena arena(settings.threads ? int(settings.threads) : tbb::task_arena::automatic);
  const auto start = std::chrono::steady_clock::now();
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, tilesX * tilesY, 1),
                      [&](const tbb::blocked_range<uint32_t>& r) {
                        for (uint32_t t = r.begin(); t < r.end(); ++t) traceTile(t);
                      });
  });
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const auto& c : tileCounters) result.counters += c;
  (void)scene;
  return result;
}

}  // namespace somm

namespace somm::detail {
std::vector<std::string> encodingNames() {
  std::vector<std::string> names;
  for (Encoding e : kAllEncodings) names.push_back(encodingName(e));
  return names;
}
}  // namespace somm::detail
