// SPDX-License-Identifier: MIT
#include "somm/trace.h"

#include <gtest/gtest.h>
#include <stb_image.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "somm/bird.h"
#include "trace/trace_scenes.h"

namespace somm {
namespace {

std::shared_ptr<const TraceWorld> world(Scene s) {
  auto w = TraceWorld::create(std::make_shared<const Scene>(std::move(s)));
  EXPECT_TRUE(w.ok()) << (w.ok() ? "" : w.error().message);
  return *w;
}

std::shared_ptr<const SceneMicromaps> sceneMicromaps(OmmArrays perGeometry) {
  return std::make_shared<const SceneMicromaps>(perGeometryMicromaps(std::move(perGeometry)));
}

std::unique_ptr<Tracer> take(Result<std::unique_ptr<Tracer>> r) {
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(*r);
}

RenderSettings small(uint32_t w = 96, uint32_t h = 72, uint32_t spp = 1) {
  RenderSettings s;
  s.width = w;
  s.height = h;
  s.spp = spp;
  return s;
}

TEST(TraceMethod, ParsesNames) {
  for (const char* n : {"opaque", "texture", "bitmask", "state-overlay", "omm2-flat", "omm4-flat"}) {
    auto m = parseMethod(n);
    ASSERT_TRUE(m.ok()) << n;
    EXPECT_EQ(m->name(), n);
  }
  EXPECT_EQ(parseMethod("omm2-flat")->format, Format::TwoState);
  EXPECT_EQ(parseMethod("omm4-flat")->format, Format::FourState);
  EXPECT_FALSE(parseMethod("omm3-flat").ok());
  EXPECT_FALSE(parseMethod("omm4-zip").ok());
  EXPECT_FALSE(parseMethod("").ok());
  EXPECT_NE(parseMethod("omm4-zip").error().message.find("zip"), std::string::npos);
}

TEST(TraceWorldTest, RejectsBadScenes) {
  Scene s = testing::makeCardScene(2);
  s.geometries[0].indices.push_back(100000);
  s.geometries[0].indices.push_back(0);
  s.geometries[0].indices.push_back(0);
  EXPECT_FALSE(TraceWorld::create(std::make_shared<const Scene>(s)).ok());
  Scene t = testing::makeCardScene(2);
  t.instances.push_back(Instance{7, {}});
  auto r = TraceWorld::create(std::make_shared<const Scene>(t));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("procedural-cards"), std::string::npos);
}

TEST(TraceWorldTest, BoundsIncludeInstanceTransforms) {
  auto w = world(testing::makeCardScene(4));
  // Ground spans ±3.5 in x and z at y = -1.5.
  EXPECT_FLOAT_EQ(w->bounds().lower[0], -3.5f);
  EXPECT_FLOAT_EQ(w->bounds().upper[2], 3.5f);
  EXPECT_FLOAT_EQ(w->bounds().lower[1], -1.5f);
}

// The core exactness property: every 4-state method (and the conservative bitmask) renders pixel-identical to
// the texture method, with fewer texture tests; the same rays are traced by every method.
TEST(TraceExactness, FourStateMatchesTexturePixelForPixel) {
  auto w = world(testing::makeCardScene(60));
  const RenderSettings rs = small(128, 96, 2);
  auto texture = take(makeTextureTracer(w));
  const RenderResult ref = texture->render(rs);
  EXPECT_EQ(ref.counters.primaryRays, 128u * 96u * 2u);
  EXPECT_GT(ref.counters.filterCalls, ref.counters.primaryRays / 4);
  EXPECT_EQ(ref.counters.textureTests, ref.counters.filterCalls);
  EXPECT_EQ(ref.counters.micromapLookups, 0u);

  auto opaque = take(makeOpaqueTracer(w));
  const RenderResult op = opaque->render(rs);
  EXPECT_EQ(op.counters.filterCalls, 0u);
  EXPECT_GT(percentPixelsDiffering(op.image, ref.image), 5.0);

  for (uint32_t level : {0u, 3u, 6u}) {
    auto arrays = sceneMicromaps(bakeSimple(w->scene(), level, Format::FourState));
    auto omm = take(makeFlatOmmTracer(w, arrays, Format::FourState));
    EXPECT_EQ(omm->method(), "omm4-flat");
    EXPECT_GT(omm->micromapBytes(), 0u);
    const RenderResult r = omm->render(rs);
    EXPECT_EQ(percentPixelsDiffering(r.image, ref.image), 0.0) << "level " << level;
    EXPECT_EQ(r.image.rgba, ref.image.rgba) << "level " << level;
    EXPECT_EQ(r.counters.primaryRays, ref.counters.primaryRays);
    EXPECT_EQ(r.counters.shadowRays, ref.counters.shadowRays);
    EXPECT_EQ(r.counters.micromapLookups, r.counters.filterCalls);
    if (level == 6) {
      EXPECT_LT(r.counters.textureTests * 3, ref.counters.textureTests) << "micromaps must help";
    }

    auto bitmask = take(makeBitmaskTracer(w, level));
    const RenderResult b = bitmask->render(rs);
    EXPECT_EQ(b.image.rgba, ref.image.rgba) << "bitmask level " << level;
    EXPECT_EQ(b.counters.micromapLookups, b.counters.filterCalls);
    EXPECT_EQ(bitmask->micromapBytes(),
              w->scene().geometries[0].triangleCount() * std::max<uint64_t>(1, (1u << (2 * level)) / 4) +
                  w->scene().geometries[2].triangleCount() * std::max<uint64_t>(1, (1u << (2 * level)) / 4));
  }
}

TEST(TraceExactness, TwoStateNeverSamplesTheTexture) {
  auto w = world(testing::makeCardScene(60));
  const RenderSettings rs = small(96, 72, 1);
  auto arrays = sceneMicromaps(bakeSimple(w->scene(), 4, Format::TwoState));
  auto omm2 = take(makeFlatOmmTracer(w, arrays, Format::TwoState));
  EXPECT_EQ(omm2->method(), "omm2-flat");
  const RenderResult r = omm2->render(rs);
  EXPECT_EQ(r.counters.textureTests, 0u);
  EXPECT_EQ(r.counters.micromapLookups, r.counters.filterCalls);
  EXPECT_GT(r.counters.filterCalls, 0u);
  const RenderResult ref = take(makeTextureTracer(w))->render(rs);
  const double diff = percentPixelsDiffering(r.image, ref.image);
  EXPECT_GT(diff, 0.0);  // level 4 on a 64² leaf: the 2-state approximation is visible
  EXPECT_LT(diff, 50.0);
}

TEST(TraceExactness, GrazingAnglesAndCloseUps) {
  auto w = world(testing::makeCardScene(40, 7));
  auto arrays = sceneMicromaps(bakeSimple(w->scene(), 5, Format::FourState));
  auto texture = take(makeTextureTracer(w));
  auto omm = take(makeFlatOmmTracer(w, arrays, Format::FourState));
  auto bitmask = take(makeBitmaskTracer(w, 5));
  // Nearly in the plane of the instanced cards (z ≈ 1.5..1.8), very close to a card, and from below the
  // ground plane.
  const Camera cams[] = {
      Camera{{-1.2f + 3 * std::cos(0.6f), 0.3f, 1.5f - 3 * std::sin(0.6f) + 0.01f},
             {-1.2f, 0.3f, 1.5f},
             {0, 1, 0},
             0.5f},
      Camera{{1.4f, -0.2f, 1.83f}, {1.4f, -0.2f, 1.8f}, {0, 1, 0}, 1.2f},
      Camera{{0.0f, 6.0f, 0.0f}, {0.1f, -1.5f, 0.05f}, {0, 0, 1}, 1.0f},
      Camera{{5.0f, -1.49f, 0.0f}, {0.0f, -1.5f, 0.0f}, {0, 1, 0}, 0.9f},
  };
  for (const Camera& c : cams) {
    RenderSettings rs = small(80, 60, 2);
    rs.camera = c;
    const RenderResult ref = texture->render(rs);
    EXPECT_EQ(omm->render(rs).image.rgba, ref.image.rgba);
    EXPECT_EQ(bitmask->render(rs).image.rgba, ref.image.rgba);
  }
}

TEST(TraceRender, DeterministicAcrossThreadCounts) {
  auto w = world(testing::makeCardScene(30));
  auto texture = take(makeTextureTracer(w));
  RenderSettings a = small(64, 48, 2), b = a;
  a.threads = 1;
  b.threads = 2;
  const RenderResult ra = texture->render(a), rb = texture->render(b);
  EXPECT_EQ(ra.image.rgba, rb.image.rgba);
  EXPECT_EQ(ra.counters, rb.counters);
  EXPECT_GT(ra.seconds, 0.0);
  EXPECT_GT(ra.raysPerSecond(), 0.0);
}

TEST(TraceRender, InstancesEqualPreTransformedCopies) {
  Scene inst = testing::makeCardScene(10);
  Scene flat = inst;
  // Replace the two placements of geometry 2 by two geometries with the transform applied to the vertices.
  flat.instances.resize(2);
  for (int k = 2; k < 4; ++k) {
    Geometry g = inst.geometries[2];
    const auto& m = inst.instances[size_t(k)].transform;
    for (size_t v = 0; v < g.positions.size() / 3; ++v) {
      const float x = g.positions[3 * v], y = g.positions[3 * v + 1], z = g.positions[3 * v + 2];
      for (int r = 0; r < 3; ++r) g.positions[3 * v + r] = m[r] * x + m[4 + r] * y + m[8 + r] * z + m[12 + r];
    }
    flat.geometries.push_back(g);
    flat.instances.push_back(
        Instance{uint32_t(flat.geometries.size() - 1), {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}});
  }
  const RenderSettings rs = small(80, 60);
  const RenderResult a = take(makeTextureTracer(world(inst)))->render(rs);
  const RenderResult b = take(makeTextureTracer(world(flat)))->render(rs);
  EXPECT_EQ(a.image.rgba, b.image.rgba);
}

TEST(TraceRender, StateOverlayColoursByState) {
  auto w = world(testing::makeCardScene(30));
  auto arrays = sceneMicromaps(bakeSimple(w->scene(), 4, Format::FourState));
  auto overlay = take(makeStateOverlayTracer(w, arrays));
  EXPECT_EQ(overlay->method(), "state-overlay");
  const RenderResult r = overlay->render(small(96, 72));
  // Some hits are on opaque micro-triangles (green dominates) and some on unknown ones (red dominates).
  size_t green = 0, red = 0;
  for (size_t i = 0; i < r.image.rgba.size(); i += 4) {
    const int R = r.image.rgba[i], G = r.image.rgba[i + 1], B = r.image.rgba[i + 2];
    green += 10 * G > 14 * R && 10 * G > 14 * B;
    red += R > G && R > 2 * B && R > 60;
  }
  EXPECT_GT(green, 50u);
  EXPECT_GT(red, 0u);
}

TEST(TraceRender, RejectsMismatchedMicromaps) {
  auto w = world(testing::makeCardScene(10));
  const OmmArrays arrays = bakeSimple(w->scene(), 2, Format::FourState);
  EXPECT_TRUE(makeFlatOmmTracer(w, sceneMicromaps(arrays), Format::FourState).ok());
  OmmArrays tooFew = arrays;
  tooFew.pop_back();
  EXPECT_FALSE(makeFlatOmmTracer(w, sceneMicromaps(tooFew), Format::FourState).ok());
  OmmArrays badIndex = arrays;
  badIndex[0].indices[0] = 1 << 20;
  EXPECT_FALSE(makeFlatOmmTracer(w, sceneMicromaps(badIndex), Format::FourState).ok());
  OmmArrays shortList = arrays;
  shortList[0].indices.pop_back();
  EXPECT_FALSE(makeFlatOmmTracer(w, sceneMicromaps(shortList), Format::FourState).ok());
  EXPECT_FALSE(makeBitmaskTracer(w, 11).ok());
}

// Conservativeness of the classifier against the texture method's own evaluation at random points of each
// region.
TEST(TraceClassify, KnownStatesNeverContradictTheTexture) {
  const Scene s = testing::makeCardScene(1);
  testing::Rng rng{99};
  for (const Material& base : {s.materials[0], s.materials[2]}) {
    for (Filter filter : {Filter::Nearest, Filter::Linear}) {
      Material m = base;
      m.sampler.filter = filter;
      for (int trial = 0; trial < 40; ++trial) {
        float uv[6];
        for (float& x : uv) x = rng.next() * 3 - 1;
        const uint32_t level = 3;
        for (uint32_t k = 0; k < microTriangleCount(level); ++k) {
          const MicroTriangleF mt = indexToMicroTriangleF(k, level);
          const State st = classifyRegion(m, uv, mt.u, mt.v, 3);
          if (!isKnown(st)) continue;
          for (int p = 0; p < 30; ++p) {
            float a = rng.next(), b = rng.next();
            if (a + b > 1) a = 1 - a, b = 1 - b;
            const float u = mt.u[0] + a * (mt.u[1] - mt.u[0]) + b * (mt.u[2] - mt.u[0]);
            const float v = mt.v[0] + a * (mt.v[1] - mt.v[0]) + b * (mt.v[2] - mt.v[0]);
            float ss, tt;
            interpolateUV(uv, u, v, ss, tt);
            const bool pass = alphaTestPasses(sampleAlpha(*m.alpha, m.sampler, ss, tt), m.alphaCutoff);
            ASSERT_EQ(pass, st == State::Opaque) << "micro-triangle " << k << " trial " << trial;
          }
        }
      }
    }
  }
}

TEST(TraceImage, PngRoundTripAndDiff) {
  auto w = world(testing::makeCardScene(10));
  const RenderResult r = take(makeTextureTracer(w))->render(small(40, 30));
  const std::string path = (std::filesystem::temp_directory_path() / "somm_trace_test.png").string();
  ASSERT_TRUE(writePng(path, r.image).ok());
  int x = 0, y = 0, c = 0;
  unsigned char* px = stbi_load(path.c_str(), &x, &y, &c, 4);
  ASSERT_NE(px, nullptr);
  EXPECT_EQ(x, 40);
  EXPECT_EQ(y, 30);
  EXPECT_TRUE(std::equal(r.image.rgba.begin(), r.image.rgba.end(), px));
  stbi_image_free(px);
  std::remove(path.c_str());
  EXPECT_FALSE(writePng("/nonexistent-dir/x.png", r.image).ok());
  Image other = r.image;
  other.rgba[0] ^= 1;
  other.rgba[4 * 41 + 2] ^= 1;
  EXPECT_DOUBLE_EQ(percentPixelsDiffering(r.image, other), 100.0 * 2 / (40 * 30));
}

}  // namespace
}  // namespace somm
