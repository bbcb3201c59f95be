// SPDX-License-Identifier: MIT
// somm — opacity micromaps as the any-hit stage of a renderer's own Embree 3 triangle geometry (target
// somm_trace). C++17.
//
// attachMicromaps() takes one triangle mesh of the caller (its vertex and index buffers, shared, not copied)
// and the micromaps of that geometry (flat SceneMicromaps, optionally one of its arrays in a compressed
// encoding), and attaches it to the caller's RTCScene the way hardware micromaps behave:
//   * triangles whose micromap index is the special index "fully transparent" are left out of the BVH;
//   * triangles with the special index "fully opaque" go into an opaque part without a filter function;
//   * every other triangle goes into a filtered part whose intersection and occlusion filters look the hit's
//     micromap state up: opaque → accept, transparent → reject, unknown → the caller's alpha test.
// With a 2-state reading (MicromapSource::twoState) unknown states never reach the alpha test (bit 0 decides) and
// the special indices "unknown opaque/transparent" are split like opaque/transparent.
//
// The filter is one function template instantiated per (lookup encoding, 2/4-state, counting, AlphaTest type),
// handed to Embree as a plain function pointer: no virtual call, no allocation, no switch on the hot path. The
// alpha test is the caller's callable, inlined: `bool operator()(uint32_t triangle, float u, float v) const`
// (triangle = the caller's triangle number in the mesh; (u, v) = Embree's hit barycentrics). It must be pure in
// its arguments (Embree may call a filter more than once per hit). AlphaTestFunction wraps a C function
// pointer + user pointer.
//
// A hit on a part reports the part's geometry id and primitive id; AttachedGeometry::triangle(geomID, primID)
// maps it back to the caller's triangle.
#pragma once

#include <embree3/rtcore.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "somm/bird.h"
#include "somm/encode.h"
#include "somm/micromap.h"
#include "somm/omm_array.h"
#include "somm/result.h"

namespace somm {
namespace embree {

// Work counters a filter updates when the geometry was attached with AttachOptions::countWork: every
// rtcIntersect / rtcOccluded call on the scene must then pass a CountingContext (its `rtc` member).
struct FilterCounters {
  uint64_t filterCalls = 0;      // filter invocations (per ray and candidate hit)
  uint64_t textureTests = 0;     // calls of the alpha test
  uint64_t micromapLookups = 0;  // micromap state reads
};
struct CountingContext {
  RTCIntersectContext rtc;  // first member: Embree hands this pointer back to the filters
  FilterCounters* counters = nullptr;
};
inline void initCountingContext(CountingContext& c, FilterCounters* counters) noexcept {
  rtcInitIntersectContext(&c.rtc);
  c.counters = counters;
}

// The caller's triangle mesh. Embree reads vertex buffers with 16-byte loads: the vertex memory must stay readable
// for 4 bytes past the last vertex (as for rtcSetSharedGeometryBuffer). Both buffers must outlive the scene.
struct TriangleMeshView {
  const float* vertices = nullptr;  // x y z at every vertexStride bytes
  size_t vertexStride = 3 * sizeof(float);
  size_t vertexCount = 0;
  const uint32_t* indices = nullptr;  // 3 per triangle
  size_t triangleCount = 0;
};

// The micromaps of one geometry: geometry `geometry` of `micromaps` (its triangles are global triangles
// firstTriangle + t of its array). `encoded`, when set, is that array in a compressed encoding (built from it) and
// is what the filter reads; the special-index split always reads the flat index buffer.
struct MicromapSource {
  const SceneMicromaps* micromaps = nullptr;
  uint32_t geometry = 0;
  const EncodedArray* encoded = nullptr;
  bool twoState = false;  // the 2-state reading: bit 0 of the state decides, the alpha test is never called
};

struct AttachOptions {
  bool splitSpecialIndices = true;  // false: every triangle in one filtered geometry (for comparisons)
  bool countWork = false;           // update FilterCounters through a CountingContext
  RTCBuildQuality quality = RTC_BUILD_QUALITY_HIGH;
};

// A C-style alpha test: fn(user, triangle, u, v) → passes.
struct AlphaTestFunction {
  bool (*fn)(void* user, uint32_t triangle, float u, float v) = nullptr;
  void* user = nullptr;
  bool operator()(uint32_t triangle, float u, float v) const noexcept { return fn(user, triangle, u, v); }
};

class AttachedGeometry;
// Defined below.
template <class AlphaTest>
Result<AttachedGeometry> attachMicromaps(RTCDevice device, RTCScene scene, const TriangleMeshView& mesh,
                                         const MicromapSource& source, AlphaTest test,
                                         const AttachOptions& options = AttachOptions());

// The geometries attachMicromaps created and the data their filters read: keep it alive (and the micromaps, the
// encoded array and the mesh buffers) while the scene is used. Movable, not copyable.
class AttachedGeometry {
 public:
  AttachedGeometry() = default;
  AttachedGeometry(AttachedGeometry&&) noexcept = default;
  AttachedGeometry& operator=(AttachedGeometry&&) noexcept = default;
  AttachedGeometry(const AttachedGeometry&) = delete;
  AttachedGeometry& operator=(const AttachedGeometry&) = delete;

  // Geometry ids in the scene (RTC_INVALID_GEOMETRY_ID when the part is empty).
  unsigned opaqueId() const noexcept { return opaqueId_; }
  unsigned filteredId() const noexcept { return filteredId_; }
  size_t opaqueTriangles() const noexcept { return opaque_.size(); }
  size_t filteredTriangles() const noexcept { return filtered_.size(); }
  size_t droppedTriangles() const noexcept { return dropped_; }
  // The caller's triangle of primitive primID of part geomID (opaqueId() or filteredId()).
  uint32_t triangle(unsigned geomID, unsigned primID) const noexcept {
    return geomID == opaqueId_ ? opaque_[primID] : filtered_[primID];
  }
  // The triangle map of a part (primID → the caller's triangle), null for other ids.
  const uint32_t* triangleMap(unsigned geomID) const noexcept {
    return geomID == opaqueId_ ? opaque_.data() : geomID == filteredId_ ? filtered_.data() : nullptr;
  }

 private:
  template <class AlphaTest>
  friend Result<AttachedGeometry> attachMicromaps(RTCDevice, RTCScene, const TriangleMeshView&,
                                                  const MicromapSource&, AlphaTest, const AttachOptions&);
  unsigned opaqueId_ = RTC_INVALID_GEOMETRY_ID, filteredId_ = RTC_INVALID_GEOMETRY_ID;
  std::vector<uint32_t> opaque_, filtered_;                // part primID → caller's triangle
  std::vector<uint32_t> opaqueIndices_, filteredIndices_;  // the parts' index buffers (+ padding)
  size_t dropped_ = 0;
  std::shared_ptr<void> filterData_;
};

namespace detail {

template <class AlphaTest>
struct FilterData {
  const uint32_t* triangleOf = nullptr;  // filtered primID → caller's triangle
  uint32_t firstTriangle = 0;            // of the geometry in its array
  const int32_t* indices = nullptr;      // flat array: index buffer (global triangles), descriptors, data
  const TriangleDescriptor* descriptors = nullptr;
  const uint8_t* data = nullptr;
  const EncodedArray* encoded = nullptr;
  AlphaTest test;
};

struct FlatLookup {
  template <class D>
  static State state(const D& d, uint32_t global, float u, float v) noexcept {
    const int32_t i = d.indices[global];
    if (i < 0) return stateOfSpecialIndex(i);
    const TriangleDescriptor& desc = d.descriptors[i];
    return readPackedState(d.data + desc.dataOffset, Format(desc.format),
                           baryToIndex(u, v, desc.subdivisionLevel));
  }
};

template <Encoding E>
struct EncodedLookup {
  template <class D>
  static State state(const D& d, uint32_t global, float u, float v) noexcept {
    return d.encoded->template stateUVAs<E>(global, u, v);
  }
};

// The filter: the same function for intersection and occlusion.
template <class Data, class Lookup, bool FourState, bool Count>
void microFilter(const RTCFilterFunctionNArguments* args) noexcept {
  const Data& d = *static_cast<const Data*>(args->geometryUserPtr);
  FilterCounters* c = nullptr;
  if (Count) c = reinterpret_cast<const CountingContext*>(args->context)->counters;
  const unsigned n = args->N;
  for (unsigned i = 0; i < n; ++i) {
    if (args->valid[i] == 0) continue;
    const uint32_t prim = RTCHitN_primID(args->hit, n, i);
    const uint32_t tri = d.triangleOf ? d.triangleOf[prim] : prim;
    const float u = RTCHitN_u(args->hit, n, i), v = RTCHitN_v(args->hit, n, i);
    if (Count) {
      ++c->filterCalls;
      ++c->micromapLookups;
    }
    const State s = Lookup::state(d, d.firstTriangle + tri, u, v);
    bool accept;
    if (!FourState) {
      accept = (uint8_t(s) & 1u) != 0;
    } else if (s == State::Opaque) {
      accept = true;
    } else if (s == State::Transparent) {
      accept = false;
    } else {
      if (Count) ++c->textureTests;
      accept = d.test(tri, u, v);
    }
    if (!accept) args->valid[i] = 0;
  }
}

template <class Data, class Lookup>
RTCFilterFunctionN pickFilter(bool fourState, bool count) noexcept {
  if (fourState)
    return count ? &microFilter<Data, Lookup, true, true> : &microFilter<Data, Lookup, true, false>;
  return count ? &microFilter<Data, Lookup, false, true> : &microFilter<Data, Lookup, false, false>;
}

template <class Data>
RTCFilterFunctionN selectFilter(const EncodedArray* encoded, bool fourState, bool count) noexcept {
  if (!encoded) return pickFilter<Data, FlatLookup>(fourState, count);
  switch (encoded->encoding()) {
    case Encoding::Flat:
      return pickFilter<Data, EncodedLookup<Encoding::Flat>>(fourState, count);
    case Encoding::Dfs:
      return pickFilter<Data, EncodedLookup<Encoding::Dfs>>(fourState, count);
    case Encoding::DfsFast:
      return pickFilter<Data, EncodedLookup<Encoding::DfsFast>>(fourState, count);
    case Encoding::Rank:
      return pickFilter<Data, EncodedLookup<Encoding::Rank>>(fourState, count);
    case Encoding::Hybrid:
      return pickFilter<Data, EncodedLookup<Encoding::Hybrid>>(fourState, count);
    case Encoding::Csm:
      return pickFilter<Data, EncodedLookup<Encoding::Csm>>(fourState, count);
    case Encoding::Sdag:
      return pickFilter<Data, EncodedLookup<Encoding::Sdag>>(fourState, count);
  }
  return nullptr;
}

// Where a triangle goes: 0 dropped (transparent), 1 opaque part, 2 filtered part.
inline int partOf(int32_t index, bool twoState, bool split) noexcept {
  if (!split || !isSpecialIndex(index)) return 2;
  const State s = stateOfSpecialIndex(index);
  if (s == State::Transparent || (twoState && s == State::UnknownTransparent)) return 0;
  if (s == State::Opaque || (twoState && s == State::UnknownOpaque)) return 1;
  return 2;  // 4-state unknown special index: every hit runs the alpha test
}

inline unsigned attachPart(RTCDevice device, RTCScene scene, const TriangleMeshView& mesh,
                           const std::vector<uint32_t>& indices, size_t triangles, RTCBuildQuality quality,
                           RTCFilterFunctionN filter, void* user) {
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (!g) return RTC_INVALID_GEOMETRY_ID;
  rtcSetGeometryBuildQuality(g, quality);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, mesh.vertices, 0,
                             mesh.vertexStride, mesh.vertexCount);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, indices.data(), 0,
                             3 * sizeof(uint32_t), triangles);
  if (filter) {
    rtcSetGeometryUserData(g, user);
    rtcSetGeometryIntersectFilterFunction(g, filter);
    rtcSetGeometryOccludedFilterFunction(g, filter);
  }
  rtcCommitGeometry(g);
  const unsigned id = rtcAttachGeometry(scene, g);
  rtcReleaseGeometry(g);
  return id;
}

}  // namespace detail

// Attaches `mesh` with its micromaps to `scene` (not committed: call rtcCommitScene after attaching everything).
// Errors (InvalidArgument) for a mesh / micromaps mismatch: triangle counts, an index outside the array, a bad
// descriptor, an encoded array of another triangle count; the scene is left unchanged then.
template <class AlphaTest>
Result<AttachedGeometry> attachMicromaps(RTCDevice device, RTCScene scene, const TriangleMeshView& mesh,
                                         const MicromapSource& source, AlphaTest test,
                                         const AttachOptions& options) {
  const SceneMicromaps* sm = source.micromaps;
  if (!sm || source.geometry >= sm->geometries.size())
    return makeError(ErrorCode::InvalidArgument, "micromaps: no geometry " + std::to_string(source.geometry));
  const GeometryMicromaps& gm = sm->geometries[source.geometry];
  const std::string where = "micromaps of geometry " + std::to_string(source.geometry);
  if (gm.array >= sm->arrays.size()) return makeError(ErrorCode::InvalidArgument, where + ": no array");
  const OmmArray& a = sm->arrays[gm.array];
  if (gm.triangleCount != mesh.triangleCount)
    return makeError(ErrorCode::InvalidArgument, where + ": " + std::to_string(gm.triangleCount) +
                                                     " triangles, the mesh has " +
                                                     std::to_string(mesh.triangleCount));
  if (uint64_t(gm.firstTriangle) + gm.triangleCount > a.indices.size())
    return makeError(ErrorCode::InvalidArgument, where + ": triangles beyond the array's index buffer");
  if (source.encoded && source.encoded->triangleCount() != a.indices.size())
    return makeError(ErrorCode::InvalidArgument, where + ": the encoded array has another triangle count");
  if (!mesh.vertices || !mesh.indices || mesh.vertexStride < 3 * sizeof(float))
    return makeError(ErrorCode::InvalidArgument, where + ": empty mesh buffers");
  for (size_t t = 0; t < mesh.triangleCount; ++t) {
    const int32_t i = a.indices[gm.firstTriangle + t];
    if (i < -4 || (i >= 0 && size_t(i) >= a.descriptors.size()))
      return makeError(ErrorCode::InvalidArgument,
                       where + ": triangle " + std::to_string(t) + " has a bad index");
  }
  for (const TriangleDescriptor& d : a.descriptors)
    if (d.subdivisionLevel > kMaxLevel || !isValidFormat(d.format) ||
        uint64_t(d.dataOffset) + micromapDataBytes(d.subdivisionLevel, Format(d.format)) > a.data.size())
      return makeError(ErrorCode::InvalidArgument, where + ": bad micromap descriptor");

  AttachedGeometry out;
  for (size_t t = 0; t < mesh.triangleCount; ++t) {
    const int part =
        detail::partOf(a.indices[gm.firstTriangle + t], source.twoState, options.splitSpecialIndices);
    if (part == 0) {
      ++out.dropped_;
      continue;
    }
    std::vector<uint32_t>& map = part == 1 ? out.opaque_ : out.filtered_;
    std::vector<uint32_t>& idx = part == 1 ? out.opaqueIndices_ : out.filteredIndices_;
    map.push_back(uint32_t(t));
    idx.insert(idx.end(), mesh.indices + 3 * t, mesh.indices + 3 * t + 3);
  }
  out.opaqueIndices_.resize(out.opaqueIndices_.size() + 4,
                            0);  // Embree reads index buffers with 16-byte loads
  out.filteredIndices_.resize(out.filteredIndices_.size() + 4, 0);

  using Data = detail::FilterData<AlphaTest>;
  auto data = std::make_shared<Data>(Data{nullptr, gm.firstTriangle, a.indices.data(), a.descriptors.data(),
                                          a.data.data(), source.encoded, test});
  data->triangleOf = out.filtered_.data();  // stable: the vector's buffer moves with `out`
  const RTCFilterFunctionN filter =
      detail::selectFilter<Data>(source.encoded, !source.twoState, options.countWork);
  if (!out.opaque_.empty())
    out.opaqueId_ = detail::attachPart(device, scene, mesh, out.opaqueIndices_, out.opaque_.size(),
                                       options.quality, nullptr, nullptr);
  if (!out.filtered_.empty())
    out.filteredId_ = detail::attachPart(device, scene, mesh, out.filteredIndices_, out.filtered_.size(),
                                         options.quality, filter, data.get());
  if (rtcGetDeviceError(device) != RTC_ERROR_NONE)
    return makeError(ErrorCode::InvalidArgument, where + ": Embree rejected the geometry");
  out.filterData_ = std::move(data);
  return out;
}

}  // namespace embree
}  // namespace somm
