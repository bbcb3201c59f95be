// SPDX-License-Identifier: MIT
// somm/embree.h on a caller's own mesh: the special-index split (transparent triangles left out, opaque ones
// without a filter), hits mapped back to the caller's triangles, the caller's alpha test called only on unknown
// states, 2-state reading, and errors for mismatched micromaps.
#include "somm/embree.h"

#include <gtest/gtest.h>

#include <limits>
#include <vector>

namespace somm {
namespace {

// Triangle t covers x in [3t, 3t + 2], y in [0, 2] at z = 0.
struct Mesh {
  std::vector<float> vertices;
  std::vector<uint32_t> indices;
  explicit Mesh(uint32_t triangles) {
    for (uint32_t t = 0; t < triangles; ++t) {
      const float x = 3.0f * float(t);
      const uint32_t b = uint32_t(vertices.size() / 3);
      vertices.insert(vertices.end(), {x, 0, 0, x + 2, 0, 0, x, 2, 0});
      indices.insert(indices.end(), {b, b + 1, b + 2});
    }
    vertices.resize(vertices.size() + 4, 0.0f);
  }
  embree::TriangleMeshView view() const {
    embree::TriangleMeshView v;
    v.vertices = vertices.data();
    v.vertexCount = (vertices.size() - 4) / 3;
    v.indices = indices.data();
    v.triangleCount = indices.size() / 3;
    return v;
  }
};

// Triangle 0 transparent, 1 opaque, 2 a level-1 map (opaque, transparent, unknown-opaque, unknown-transparent at
// micro-triangles 0..3), 3 unknown-opaque everywhere (a special index).
SceneMicromaps micromaps() {
  OmmArrayBuilder b;
  b.add(Micromap(1, Format::FourState, State::Transparent));
  b.add(Micromap(1, Format::FourState, State::Opaque));
  Micromap m(1, Format::FourState);
  m.set(0, State::Opaque);
  m.set(1, State::Transparent);
  m.set(2, State::UnknownOpaque);
  m.set(3, State::UnknownTransparent);
  b.add(m);
  b.add(Micromap(1, Format::FourState, State::UnknownOpaque));
  std::vector<OmmArray> arrays;
  arrays.push_back(b.finish());
  return perGeometryMicromaps(std::move(arrays));
}

struct Calls {
  std::vector<uint32_t> triangles;
};
bool alphaTest(void* user, uint32_t triangle, float, float) {
  static_cast<Calls*>(user)->triangles.push_back(triangle);
  return false;  // everything the micromap leaves unknown is transparent in this test
}

// A ray along -z through barycentric (u, v) of triangle t.
RTCRayHit rayAt(uint32_t t, float u, float v) {
  RTCRayHit rh{};
  rh.ray.org_x = 3.0f * float(t) + 2.0f * u;
  rh.ray.org_y = 2.0f * v;
  rh.ray.org_z = 5.0f;
  rh.ray.dir_z = -1.0f;
  rh.ray.tfar = std::numeric_limits<float>::infinity();
  rh.ray.mask = 0xffffffffu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

TEST(EmbreeIntegration, SpecialIndicesLeaveTheFilterPath) {
  const SceneMicromaps sm = micromaps();
  ASSERT_EQ(sm.arrays[0].indices[0], specialIndexFor(State::Transparent));
  ASSERT_EQ(sm.arrays[0].indices[1], specialIndexFor(State::Opaque));
  ASSERT_GE(sm.arrays[0].indices[2], 0);
  ASSERT_EQ(sm.arrays[0].indices[3], specialIndexFor(State::UnknownOpaque));
  const Mesh mesh(4);
  RTCDevice device = rtcNewDevice(nullptr);
  ASSERT_NE(device, nullptr);
  for (bool twoState : {false, true}) {
    RTCScene scene = rtcNewScene(device);
    Calls calls;
    embree::MicromapSource src;
    src.micromaps = &sm;
    src.twoState = twoState;
    embree::AttachOptions ao;
    ao.countWork = true;
    auto a = embree::attachMicromaps(device, scene, mesh.view(), src,
                                     embree::AlphaTestFunction{&alphaTest, &calls}, ao);
    ASSERT_TRUE(a.ok()) << a.error().message;
    rtcCommitScene(scene);
    EXPECT_EQ(a->droppedTriangles(), 1u);
    EXPECT_EQ(a->opaqueTriangles(),
              twoState ? 2u : 1u);  // 2-state: the unknown-opaque special index is opaque
    EXPECT_EQ(a->filteredTriangles(), twoState ? 1u : 2u);
    embree::FilterCounters work;
    embree::CountingContext ctx;
    embree::initCountingContext(ctx, &work);
    auto trace = [&](uint32_t t, float u, float v) {
      RTCRayHit rh = rayAt(t, u, v);
      rtcIntersect1(scene, &ctx.rtc, &rh);
      return rh;
    };
    // Transparent triangle: not in the BVH, no filter call.
    EXPECT_EQ(trace(0, 0.3f, 0.3f).hit.geomID, RTC_INVALID_GEOMETRY_ID);
    EXPECT_EQ(work.filterCalls, 0u);
    // Opaque triangle: a hit without a filter call, mapped back to triangle 1.
    RTCRayHit h = trace(1, 0.3f, 0.3f);
    ASSERT_EQ(h.hit.geomID, a->opaqueId());
    EXPECT_EQ(a->triangle(h.hit.geomID, h.hit.primID), 1u);
    EXPECT_EQ(work.filterCalls, 0u);
    // The level-1 map: micro-triangle 0 (near vertex 0) opaque, 1 (the middle one) transparent.
    h = trace(2, 0.1f, 0.1f);
    ASSERT_EQ(h.hit.geomID, a->filteredId());
    EXPECT_EQ(a->triangle(h.hit.geomID, h.hit.primID), 2u);
    EXPECT_EQ(trace(2, 0.3f, 0.3f).hit.geomID, RTC_INVALID_GEOMETRY_ID);
    EXPECT_TRUE(calls.triangles.empty());
    EXPECT_EQ(work.filterCalls, 2u);
    EXPECT_EQ(work.micromapLookups, 2u);
    // Unknown states: 4-state asks the caller's alpha test (which says transparent), 2-state reads bit 0.
    const RTCRayHit unknownOpaque = trace(2, 0.8f, 0.1f);
    const uint32_t uo = baryToIndex(0.8f, 0.1f, 1);
    ASSERT_TRUE(uo == 2 || uo == 3);
    const RTCRayHit special = trace(3, 0.3f, 0.3f);
    if (twoState) {
      EXPECT_TRUE(calls.triangles.empty());
      EXPECT_EQ(special.hit.geomID, a->opaqueId());
      EXPECT_EQ(a->triangle(special.hit.geomID, special.hit.primID), 3u);
      EXPECT_EQ(unknownOpaque.hit.geomID == RTC_INVALID_GEOMETRY_ID, uo == 3);
    } else {
      EXPECT_EQ(unknownOpaque.hit.geomID, RTC_INVALID_GEOMETRY_ID);
      EXPECT_EQ(special.hit.geomID, RTC_INVALID_GEOMETRY_ID);
      EXPECT_EQ(calls.triangles, (std::vector<uint32_t>{2, 3}));
      EXPECT_EQ(work.textureTests, 2u);
    }
    rtcReleaseScene(scene);
  }

  // Without the split every triangle is filtered, also the fully transparent and opaque ones.
  RTCScene scene = rtcNewScene(device);
  Calls calls;
  embree::MicromapSource src;
  src.micromaps = &sm;
  embree::AttachOptions ao;
  ao.splitSpecialIndices = false;
  auto a = embree::attachMicromaps(device, scene, mesh.view(), src,
                                   embree::AlphaTestFunction{&alphaTest, &calls}, ao);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->filteredTriangles(), 4u);
  EXPECT_EQ(a->opaqueId(), RTC_INVALID_GEOMETRY_ID);
  rtcReleaseScene(scene);

  // Mismatches are errors.
  scene = rtcNewScene(device);
  const Mesh three(3);
  EXPECT_FALSE(
      embree::attachMicromaps(device, scene, three.view(), src, embree::AlphaTestFunction{&alphaTest, &calls})
          .ok());
  src.geometry = 1;
  EXPECT_FALSE(
      embree::attachMicromaps(device, scene, mesh.view(), src, embree::AlphaTestFunction{&alphaTest, &calls})
          .ok());
  SceneMicromaps bad = sm;
  bad.arrays[0].indices[2] = 99;
  src.geometry = 0;
  src.micromaps = &bad;
  auto e =
      embree::attachMicromaps(device, scene, mesh.view(), src, embree::AlphaTestFunction{&alphaTest, &calls});
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().message.find("triangle 2"), std::string::npos) << e.error().message;
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
}

}  // namespace
}  // namespace somm
