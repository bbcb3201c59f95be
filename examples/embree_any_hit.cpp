// SPDX-License-Identifier: MIT
// embree_any_hit: opacity micromaps as the any-hit stage of a renderer's own Embree 3 geometry (somm/embree.h).
//
// The scene of bake_from_memory.c (leaf cards over an RGBA8 leaf texture) is baked at level 6, 4-state, and traced
// twice with the same rays: once with the plain texture alpha test in an Embree filter on every candidate hit (what a
// renderer does without micromaps), once with the micromaps attached by somm::embree::attachMicromaps (fully
// transparent triangles leave the BVH, fully opaque ones lose the filter, known states decide without the texture,
// unknown states call the same alpha test). Then once more with the micromaps read in the compressed `sdag` encoding.
// Every ray must hit the same triangle at the same distance in all three; the program prints how many alpha tests
// each needed and exits 1 on any difference.
#include <embree3/rtcore.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include "example_scene.h"
#include "somm/bake.h"
#include "somm/embree.h"
#include "somm/encode.h"
#include "somm/omm_array.h"
#include "somm/texture.h"

namespace {

// The alpha test of the cards' material, exactly as the baker defines it (somm/texture.h): the UV of the hit
// interpolated from the triangle's corners, the material's sampler (linear, repeat), alpha >= cutoff.
struct LeafAlphaTest {
  const somm::AlphaTexture* texture = nullptr;
  const std::vector<float>* triangleUVs = nullptr;  // 6 floats per triangle
  somm::Sampler sampler;
  float cutoff = 0.5f;
  uint64_t* calls = nullptr;

  bool operator()(uint32_t triangle, float u, float v) const noexcept {
    ++*calls;
    const float* uv = triangleUVs->data() + 6 * size_t(triangle);
    const float w = 1.0f - u - v;
    const float s = w * uv[0] + u * uv[2] + v * uv[4], t = w * uv[1] + u * uv[3] + v * uv[5];
    return somm::alphaTestPasses(somm::sampleAlpha(*texture, sampler, s, t), cutoff);
  }
};

// Without micromaps: every candidate hit runs the alpha test.
void textureFilter(const RTCFilterFunctionNArguments* args) {
  const LeafAlphaTest& test = *static_cast<const LeafAlphaTest*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const uint32_t prim = RTCHitN_primID(args->hit, args->N, i);
    if (!test(prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i))) args->valid[i] = 0;
  }
}

struct Hit {
  uint32_t triangle = UINT32_MAX;  // UINT32_MAX: no hit
  float t = 0.0f;
  bool operator!=(const Hit& o) const {
    return triangle != o.triangle || std::memcmp(&t, &o.t, sizeof t) != 0;
  }
};

// One ray per pixel of an n × n grid over the cards, straight down the z axis.
template <class TriangleOf>
std::vector<Hit> traceGrid(RTCScene scene, uint32_t n, TriangleOf triangleOf) {
  std::vector<Hit> hits(size_t(n) * n);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      RTCRayHit rh{};
      rh.ray.org_x = -2.25f + 5.0f * (float(x) + 0.5f) / float(n);
      rh.ray.org_y = -2.25f + 5.0f * (float(y) + 0.5f) / float(n);
      rh.ray.org_z = 10.0f;
      rh.ray.dir_z = -1.0f;
      rh.ray.tfar = 1e30f;
      rh.ray.mask = 0xffffffffu;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene, &context, &rh);
      if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID)
        hits[size_t(y) * n + x] = Hit{triangleOf(rh.hit.geomID, rh.hit.primID), rh.ray.tfar};
    }
  return hits;
}

}  // namespace

int main() {
  static ex_scene scene;
  ex_make_scene(&scene);

  // The material, the mesh and the triangles' UVs from the engine's own arrays.
  auto texture = std::make_shared<somm::AlphaTexture>();
  texture->width = texture->height = EX_TEX;
  texture->alpha.resize(EX_TEX * EX_TEX);
  for (size_t i = 0; i < texture->alpha.size(); ++i)
    texture->alpha[i] = float(double(scene.rgba[4 * i + 3]) / 255.0);
  somm::Material material;
  material.alphaMode = somm::AlphaMode::Mask;
  material.alphaCutoff = 0.5f;
  material.alpha = texture;
  somm::Geometry geometry;
  for (const ex_vertex& v : scene.vertices) geometry.uvs.insert(geometry.uvs.end(), {v.u, v.v});
  geometry.indices.assign(scene.indices, scene.indices + 3 * EX_TRIANGLES);
  std::vector<float> triangleUVs;
  for (uint32_t i : geometry.indices)
    triangleUVs.insert(triangleUVs.end(), {scene.vertices[i].u, scene.vertices[i].v});

  somm::BakeOptions options;  // level 6, 4-state
  auto baked = somm::bakeGeometry(geometry, material, options);
  if (!baked) {
    std::fprintf(stderr, "embree_any_hit: %s\n", baked.error().message.c_str());
    return 1;
  }
  std::vector<somm::OmmArray> arrays;
  arrays.push_back(std::move(baked->array));
  const somm::SceneMicromaps micromaps = somm::perGeometryMicromaps(std::move(arrays));
  auto sdag = somm::EncodedArray::build(micromaps.arrays[0], somm::Encoding::Sdag);
  if (!sdag) {
    std::fprintf(stderr, "embree_any_hit: %s\n", sdag.error().message.c_str());
    return 1;
  }

  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) {
    std::fprintf(stderr, "embree_any_hit: cannot create an Embree device\n");
    return 1;
  }
  somm::embree::TriangleMeshView mesh;
  mesh.vertices = &scene.vertices[0].x;  // x y z u v: the u v of the last vertex pad Embree's 16-byte loads
  mesh.vertexStride = sizeof(ex_vertex);
  mesh.vertexCount = EX_VERTICES;
  mesh.indices = geometry.indices.data();
  mesh.triangleCount = EX_TRIANGLES;

  uint64_t textureCalls = 0, micromapCalls = 0, sdagCalls = 0;
  const LeafAlphaTest textureTest{texture.get(), &triangleUVs, material.sampler, 0.5f, &textureCalls};

  // 1. The texture test on every candidate hit.
  RTCScene plain = rtcNewScene(device);
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, mesh.vertices, 0,
                             mesh.vertexStride, mesh.vertexCount);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, mesh.indices, 0,
                             3 * sizeof(uint32_t), mesh.triangleCount);
  rtcSetGeometryUserData(g, const_cast<LeafAlphaTest*>(&textureTest));
  rtcSetGeometryIntersectFilterFunction(g, textureFilter);
  rtcSetGeometryOccludedFilterFunction(g, textureFilter);
  rtcCommitGeometry(g);
  rtcAttachGeometry(plain, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(plain);

  // 2. Flat micromaps, 3. the same micromaps read in the sdag encoding; unknown states run the same alpha test.
  somm::embree::MicromapSource flatSource;
  flatSource.micromaps = &micromaps;
  somm::embree::MicromapSource sdagSource = flatSource;
  sdagSource.encoded = &*sdag;
  LeafAlphaTest micromapTest = textureTest, sdagTest = textureTest;
  micromapTest.calls = &micromapCalls;
  sdagTest.calls = &sdagCalls;
  RTCScene withMaps = rtcNewScene(device), withSdag = rtcNewScene(device);
  auto attached = somm::embree::attachMicromaps(device, withMaps, mesh, flatSource, micromapTest);
  auto attachedSdag = somm::embree::attachMicromaps(device, withSdag, mesh, sdagSource, sdagTest);
  if (!attached || !attachedSdag) {
    std::fprintf(stderr, "embree_any_hit: %s\n",
                 (!attached ? attached.error() : attachedSdag.error()).message.c_str());
    return 1;
  }
  rtcCommitScene(withMaps);
  rtcCommitScene(withSdag);

  const uint32_t n = 512;
  const std::vector<Hit> reference =
      traceGrid(plain, n, [](unsigned, unsigned prim) { return uint32_t(prim); });
  const std::vector<Hit> flat =
      traceGrid(withMaps, n, [&](unsigned geom, unsigned prim) { return attached->triangle(geom, prim); });
  const std::vector<Hit> compressed = traceGrid(
      withSdag, n, [&](unsigned geom, unsigned prim) { return attachedSdag->triangle(geom, prim); });
  size_t hits = 0, flatDiffer = 0, sdagDiffer = 0;
  for (size_t i = 0; i < reference.size(); ++i) {
    hits += reference[i].triangle != UINT32_MAX;
    flatDiffer += flat[i] != reference[i];
    sdagDiffer += compressed[i] != reference[i];
  }
  std::printf("%u rays, %zu hits; triangles: %zu dropped (transparent), %zu opaque, %zu filtered\n", n * n,
              hits, attached->droppedTriangles(), attached->opaqueTriangles(), attached->filteredTriangles());
  std::printf(
      "alpha tests: texture only %llu, flat micromaps %llu (%.1f%%), sdag micromaps %llu (%zu bytes)\n",
      (unsigned long long)textureCalls, (unsigned long long)micromapCalls,
      textureCalls ? 100.0 * double(micromapCalls) / double(textureCalls) : 0.0,
      (unsigned long long)sdagCalls, size_t(sdag->byteSize()));
  std::printf("hits that differ from the texture test: flat %zu, sdag %zu\n", flatDiffer, sdagDiffer);

  rtcReleaseScene(plain);
  rtcReleaseScene(withMaps);
  rtcReleaseScene(withSdag);
  rtcReleaseDevice(device);
  return flatDiffer == 0 && sdagDiffer == 0 && hits > 0 && micromapCalls < textureCalls ? 0 : 1;
}
