// SPDX-License-Identifier: MIT
// bakeScene: views of the caller's memory (texel formats, strides, index widths), one pool over all geometries with
// identical work done once, scene-level policy (BLEND, maxBytes, layouts), cancellation — each checked against the
// per-geometry bake of the same data.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <set>
#include <string>
#include <thread>

#include "bake/bake_test_util.h"
#include "somm/bake.h"
#include "somm/scene.h"

namespace somm {
namespace {

// 8-bit alpha values (so every texel format can hold them exactly) with a soft disc and noise.
std::vector<uint8_t> alpha8(uint32_t w, uint32_t h) {
  std::vector<uint8_t> a(size_t(w) * h);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const double dx = (x + 0.5) / w - 0.5, dy = (y + 0.5) / h - 0.5;
      const double r = std::sqrt(dx * dx + dy * dy) + 0.03 * std::sin(x * 0.7) * std::cos(y * 1.3);
      a[size_t(y) * w + x] = uint8_t(std::lround(std::clamp(1.0 - (r - 0.3) * 10, 0.0, 1.0) * 255));
    }
  return a;
}

AlphaTexture floatTexture(const std::vector<uint8_t>& a, uint32_t w, uint32_t h) {
  AlphaTexture t;
  t.width = w;
  t.height = h;
  for (uint8_t v : a) t.alpha.push_back(float(double(v) / 255.0));
  return t;
}

// alpha8 thresholded at 128 to 0 / 255: a binary mask (under the linear filter the unknown band's majorities often
// tie).
std::vector<uint8_t> binaryAlpha8(uint32_t w, uint32_t h) {
  std::vector<uint8_t> a = alpha8(w, h);
  for (uint8_t& v : a) v = v >= 128 ? 255 : 0;
  return a;
}

// An alpha-tested (MASK) material reading the w × h alphas `a`.
Material maskMaterial(const std::string& name, const Sampler& sampler, const std::vector<uint8_t>& a,
                      uint32_t w, uint32_t h) {
  Material m;
  m.name = name;
  m.alphaMode = AlphaMode::Mask;
  m.sampler = sampler;
  m.alpha = std::make_shared<AlphaTexture>(floatTexture(a, w, h));
  return m;
}

std::vector<float> randomUvs(uint32_t triangles, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> c(-0.2f, 1.2f), d(-0.15f, 0.15f);
  std::vector<float> uv;
  for (uint32_t t = 0; t < triangles; ++t) {
    const float x = c(rng), y = c(rng);
    for (int k = 0; k < 6; ++k) uv.push_back((k % 2 ? y : x) + d(rng));
  }
  return uv;
}

Geometry geometryOf(const std::vector<float>& uv, const char* name) {
  Geometry g;
  g.name = name;
  g.uvs = uv;
  for (uint32_t i = 0; i < uv.size() / 2; ++i) g.indices.push_back(i);
  return g;
}

void expectSameArray(const OmmArray& a, const OmmArray& b) {
  EXPECT_EQ(a.data, b.data);
  EXPECT_EQ(a.descriptors, b.descriptors);
  EXPECT_EQ(a.indices, b.indices);
  EXPECT_EQ(a.histogram, b.histogram);
  EXPECT_EQ(a.triangleHistogram, b.triangleHistogram);
}

const Sampler kSampler{Wrap::Repeat, Wrap::MirroredRepeat, Filter::Linear};

// Every texel format (8/16-bit through their pass tables and 8-bit texel reads, float directly) gives the bake of the
// float texture with the same values.
void expectEveryFormatGivesTheFloatBake(uint32_t W, uint32_t H, uint32_t level, uint32_t triangles) {
  const std::vector<uint8_t> a = alpha8(W, H);
  const AlphaTexture ft = floatTexture(a, W, H);
  const std::vector<float> uv = randomUvs(triangles, 3);
  // Reference: the per-geometry bake of the float texture.
  Material m;
  m.name = "m";
  m.alphaMode = AlphaMode::Mask;
  m.sampler = kSampler;
  m.alpha = std::make_shared<AlphaTexture>(ft);
  BakeOptions o;
  o.level = level;
  auto ref = bakeGeometry(geometryOf(uv, "g"), m, o);
  ASSERT_TRUE(ref.ok());

  // Every format, alpha in a non-zero channel where there is one, rows padded.
  for (TexelFormat f : {TexelFormat::R8, TexelFormat::RG8, TexelFormat::RGBA8, TexelFormat::R16,
                        TexelFormat::RGBA16, TexelFormat::R32F}) {
    const uint32_t channels = texelChannels(f), bytes = texelBytes(f), ch = channels - 1;
    const size_t pitch = size_t(W) * bytes + 12;
    std::vector<uint8_t> img(pitch * H, 0x5a);
    for (uint32_t y = 0; y < H; ++y)
      for (uint32_t x = 0; x < W; ++x) {
        uint8_t* p = img.data() + y * pitch + x * bytes;
        const uint8_t v = a[size_t(y) * W + x];
        if (f == TexelFormat::R32F) {
          const float fv = float(double(v) / 255.0);
          std::memcpy(p, &fv, 4);
        } else if (bytes / channels == 2) {
          const uint16_t v16 = uint16_t(v * 257);
          std::memcpy(p + 2 * ch, &v16, 2);
        } else {
          p[ch] = v;
        }
      }
    // UVs with a stride of 5 floats, 16-bit indices.
    std::vector<float> strided;
    for (size_t i = 0; i < uv.size() / 2; ++i)
      strided.insert(strided.end(), {uv[2 * i], uv[2 * i + 1], 7, 7, 7});
    std::vector<uint16_t> idx;
    for (uint16_t i = 0; i < uv.size() / 2; ++i) idx.push_back(i);
    TextureView tv;
    tv.data = img.data();
    tv.width = W;
    tv.height = H;
    tv.rowPitch = pitch;
    tv.format = f;
    tv.alphaChannel = ch;
    MaterialInput mi;
    mi.texture = 0;
    mi.sampler = kSampler;
    GeometryInput gi;
    gi.uvs = strided.data();
    gi.uvStride = 5 * sizeof(float);
    gi.vertexCount = uint32_t(uv.size() / 2);
    gi.indices = idx.data();
    gi.indexFormat = IndexFormat::UInt16;
    gi.triangleCount = uint32_t(uv.size() / 6);
    BakeInputs in{&tv, 1, &mi, 1, &gi, 1};
    for (ArrayLayout layout : {ArrayLayout::SceneWide, ArrayLayout::PerGeometry}) {
      BakeOptions so = o;
      so.layout = layout;
      auto r = bakeScene(in, so);
      ASSERT_TRUE(r.ok()) << r.error().message;
      ASSERT_EQ(r->micromaps.arrays.size(), 1u);
      expectSameArray(r->micromaps.arrays[0], ref->array);
      EXPECT_EQ(r->geometries[0].levels, ref->levels);
      EXPECT_EQ(r->geometries[0].stats.unknownMicroTriangles, ref->stats.unknownMicroTriangles)
          << texelFormatName(f);
      EXPECT_EQ(r->total.uniqueMaps, ref->stats.uniqueMaps);
    }
    // No index buffer: triangle t = vertices 3t..3t+2.
    gi.indices = nullptr;
    gi.indexFormat = IndexFormat::None;
    auto r = bakeScene(in, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    expectSameArray(r->micromaps.arrays[0], ref->array);
  }
}

TEST(BakeScene, EveryTexelFormatAndLayoutGivesTheFloatBake) {
  expectEveryFormatGivesTheFloatBake(48, 40, 4, 200);
}

// Above 65,536 texels a 16-bit mask is built through its pass table; micro-triangles a few texels wide take the
// leaves' 8-bit texel reads and the bitwise row runs.
TEST(BakeScene, LargeTexturesInEveryTexelFormatGiveTheFloatBake) {
  expectEveryFormatGivesTheFloatBake(300, 260, 6, 40);
}

// A scene of several geometries sharing textures, with repeated and period-shifted triangles.
Scene sharedScene() {
  Scene s;
  const uint32_t W = 32, H = 32;
  auto tex = std::make_shared<AlphaTexture>(floatTexture(alpha8(W, H), W, H));
  for (int k = 0; k < 3; ++k) {
    Material m;
    m.name = "m" + std::to_string(k);
    m.alphaMode = AlphaMode::Mask;
    m.sampler = Sampler{Wrap::Repeat, k == 2 ? Wrap::ClampToEdge : Wrap::Repeat, Filter::Linear};
    m.alpha = tex;  // shared
    s.materials.push_back(m);
  }
  Material opaque;
  opaque.name = "opaque";
  s.materials.push_back(opaque);
  std::vector<float> base = randomUvs(60, 9);
  for (uint32_t g = 0; g < 6; ++g) {
    std::vector<float> uv = base;
    // Geometries 1 and 5: shifted by whole periods, (5, 5) and (6, 6) (the same binade: the same float rounding and
    // margin); geometry 3: each triangle of geometry 0 twice.
    if (g == 1 || g == 5)
      for (float& c : uv) c += g == 1 ? 5.0f : 6.0f;
    if (g == 3) uv.insert(uv.end(), base.begin(), base.end());
    Geometry geo = geometryOf(uv, ("g" + std::to_string(g)).c_str());
    geo.material = g == 4 ? 3u : g == 5 ? 0u : g % 3;
    s.geometries.push_back(geo);
  }
  return s;
}

TEST(BakeScene, SceneArrayEqualsMergedPerGeometryBakes) {
  const Scene s = sharedScene();
  BakeOptions o;
  o.level = 3;
  std::vector<OmmArray> per;
  uint64_t unknown = 0;
  for (const Geometry& g : s.geometries) {
    auto r = bakeGeometry(g, s.materials[g.material], o);
    ASSERT_TRUE(r.ok());
    unknown += r->stats.unknownMicroTriangles;
    per.push_back(r->array);
  }
  const SceneMicromaps merged = mergeToSceneArray(perGeometryMicromaps(per));
  for (uint32_t threads : {1u, 2u, 4u, 0u}) {
    o.threads = threads;
    auto r = bakeScene(s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->micromaps.arrays.size(), 1u);
    expectSameArray(r->micromaps.arrays[0], merged.arrays[0]);
    EXPECT_EQ(r->micromaps.geometries, merged.geometries);
    EXPECT_EQ(r->total.unknownMicroTriangles, unknown);
    EXPECT_EQ(r->masks, 2u);  // (texture, sampler): materials 0 and 1 share one
    // Geometry 3 repeats geometry 0's inputs, geometry 5 geometry 1's after removing whole periods: only
    // geometries 0, 1 and 2 are classified.
    EXPECT_EQ(r->classifiedTriangles, 180u);
    for (uint32_t g = 0; g < s.geometries.size(); ++g) {
      const OmmArray own = r->micromaps.standalone(g);
      expectSameArray(own, per[g]);
      EXPECT_EQ(r->geometries[g].stats.uniqueMaps, per[g].descriptors.size());
      EXPECT_EQ(r->geometries[g].stats.dataBytes, per[g].data.size());
    }
  }
  o.layout = ArrayLayout::PerGeometry;
  auto r = bakeScene(s, o);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->micromaps.arrays.size(), s.geometries.size());
  for (uint32_t g = 0; g < s.geometries.size(); ++g) expectSameArray(r->micromaps.arrays[g], per[g]);
}

// A triangle listing another triangle's corners in another order (a double-sided leaf card's back face) shares its
// classification: its map is the first one's with the vertices reordered, where the majority rule tied the tie point
// sampled again in its own order, and with the work bound reached it is classified on its own — the same states as
// baking every triangle by itself (bakeTriangle).
TEST(BakeScene, VertexOrdersShareOneClassification) {
  const uint32_t W = 32, H = 32;
  // A binary mask (alpha 0 or 1: under the linear filter the unknown band's majorities often tie) and a soft one.
  Scene s;
  s.materials.push_back(maskMaterial("binary", kSampler, binaryAlpha8(W, H), W, H));
  s.materials.push_back(maskMaterial("soft", kSampler, alpha8(W, H), W, H));
  // UVs on a 2^-12 grid: every midpoint of the subdivision is exact, in any vertex order.
  std::vector<float> base = randomUvs(40, 21);
  for (float& c : base) c = std::round(c * 4096.0f) / 4096.0f;
  const VertexOrder orders[6] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (uint32_t m = 0; m < 2; ++m) {
    std::vector<float> reordered;  // every triangle in the 5 other orders
    for (size_t t = 0; t < base.size() / 6; ++t)
      for (int o = 1; o < 6; ++o)
        for (int k = 0; k < 3; ++k) {
          reordered.push_back(base[6 * t + 2 * orders[o][k]]);
          reordered.push_back(base[6 * t + 2 * orders[o][k] + 1]);
        }
    Geometry a = geometryOf(base, "base"), b = geometryOf(reordered, "reordered");
    a.material = b.material = m;
    s.geometries.push_back(a);
    s.geometries.push_back(b);
  }
  // A triangle that reaches the work bound (docs/hardening.md: clamping wraps, UVs spanning thousands of texels) in
  // two orders: where the bound cuts the classification short depends on the order.
  Material clamped = s.materials[1];
  clamped.name = "clamped";
  clamped.sampler = Sampler{Wrap::ClampToEdge, Wrap::ClampToEdge, Filter::Linear};
  s.materials.push_back(clamped);
  const std::vector<float> huge = {-1000.f, -800.f, 1000.f, -790.f, 3.f,     1000.f,
                                   1000.f,  -790.f, 3.f,    1000.f, -1000.f, -800.f};
  Geometry h = geometryOf(huge, "huge");
  h.material = 2;
  s.geometries.push_back(h);

  for (Format f : {Format::FourState, Format::TwoState})
    for (uint32_t level : {3u, 7u}) {
      BakeOptions o;
      o.level = level;
      o.format = f;
      uint64_t unknown = 0, tieDifferences = 0;
      std::vector<std::vector<Micromap>> own(s.geometries.size());
      for (uint32_t g = 0; g < s.geometries.size(); ++g) {
        const Geometry& geo = s.geometries[g];
        const Material& mat = s.materials[geo.material];
        const AlphaMask mask(*mat.alpha, mat.sampler, mat.alphaCutoff);
        for (uint32_t t = 0; t < geo.triangleCount(); ++t) {
          const float* uv = geo.uvs.data() + 6 * t;
          const TriangleBake tb =
              bakeTriangle(mask, {uv[0], uv[1]}, {uv[2], uv[3]}, {uv[4], uv[5]}, level, f);
          unknown += tb.unknownCount;
          own[g].push_back(tb.map);
          if (geo.name == "reordered") {
            // What reordering the first triangle's map alone would give: it differs where a majority tied.
            Micromap r;
            reorderVertices(own[g - 1][t / 5], orders[t % 5 + 1], r);
            for (uint32_t i = 0; i < r.size(); ++i) tieDifferences += r.get(i) != tb.map.get(i);
          }
        }
      }
      EXPECT_GT(tieDifferences, 0u) << "the test needs ties";
      if (level == 7 && f == Format::FourState) {
        Micromap r;
        reorderVertices(own.back()[0], {1, 2, 0}, r);
        EXPECT_NE(r, own.back()[1]) << "the test needs the work bound to depend on the order";
      }
      for (uint32_t threads : {1u, 2u}) {
        o.threads = threads;
        auto r = bakeScene(s, o);
        ASSERT_TRUE(r.ok()) << r.error().message;
        // The 80 distinct corner sets once each, and the huge triangle in its two orders.
        EXPECT_EQ(r->classifiedTriangles, 81u);
        EXPECT_EQ(r->total.unknownMicroTriangles, unknown);
        for (uint32_t g = 0; g < s.geometries.size(); ++g)
          for (uint32_t t = 0; t < s.geometries[g].triangleCount(); ++t)
            for (uint32_t i = 0; i < own[g][t].size(); ++i)
              ASSERT_EQ(r->micromaps.state(g, t, i), own[g][t].get(i))
                  << "format " << int(f) << " level " << level << " geometry " << g << " triangle " << t
                  << " micro " << i;
      }
    }
}

// Many batches (the pipeline's ring slots are reused): every triangle followed by its back face (two vertices
// swapped), the maps of the back faces made from the front faces' — the same states and the same array as baking each
// triangle on its own and adding the maps in triangle order.
TEST(BakeScene, VertexOrdersAcrossManyBatches) {
  const uint32_t W = 32, H = 32;
  Scene s;
  Material m;
  m.name = "soft";
  m.alphaMode = AlphaMode::Mask;
  m.sampler = kSampler;
  m.alpha = std::make_shared<AlphaTexture>(floatTexture(alpha8(W, H), W, H));
  s.materials.push_back(m);
  std::vector<float> uv;
  const std::vector<float> base = randomUvs(3000, 5);
  for (size_t t = 0; t < base.size() / 6; ++t) {
    const float* p = base.data() + 6 * t;
    uv.insert(uv.end(), p, p + 6);
    for (int k : {0, 2, 1}) uv.insert(uv.end(), {p[2 * k], p[2 * k + 1]});
  }
  s.geometries.push_back(geometryOf(uv, "cards"));
  const AlphaMask mask(*m.alpha, m.sampler, m.alphaCutoff);
  for (uint32_t level : {2u, 4u}) {
    OmmArrayBuilder own;
    for (uint32_t t = 0; t < uv.size() / 6; ++t) {
      const float* p = uv.data() + 6 * t;
      own.add(bakeTriangle(mask, {p[0], p[1]}, {p[2], p[3]}, {p[4], p[5]}, level, Format::FourState).map);
    }
    const OmmArray expected = own.finish();
    BakeOptions o;
    o.level = level;
    for (uint32_t threads : {1u, 2u}) {
      o.threads = threads;
      auto r = bakeScene(s, o);
      ASSERT_TRUE(r.ok()) << r.error().message;
      EXPECT_EQ(r->classifiedTriangles, 3000u);
      expectSameArray(r->micromaps.arrays[0], expected);
    }
  }
}

// The triangles' jobs are prepared in parallel blocks of scene order and enter the job table block by block: blocks
// that end inside a geometry, geometries without triangles or without a texture between them, the same corners (in
// any order) in far-apart geometries and blocks — the same array as baking each triangle on its own and adding the
// maps in scene order, at every thread count.
TEST(BakeScene, JobsPreparedInBlocksAcrossGeometries) {
  const uint32_t W = 32, H = 32;
  Scene s;
  s.materials.push_back(maskMaterial("m0", kSampler, alpha8(W, H), W, H));
  s.materials.push_back(maskMaterial("m1", kSampler, binaryAlpha8(W, H), W, H));
  s.materials.push_back(
      maskMaterial("m2", Sampler{Wrap::ClampToEdge, Wrap::Repeat, Filter::Linear}, alpha8(W, H), W, H));
  Material opaque;
  opaque.name = "opaque";
  s.materials.push_back(opaque);
  // 300 distinct UV triangles on a 2^-12 grid (midpoints exact in any vertex order), drawn at random in random vertex
  // orders into geometries of 0 to 2,500 triangles.
  std::vector<float> pool = randomUvs(300, 17);
  for (float& c : pool) c = std::round(c * 4096.0f) / 4096.0f;
  const VertexOrder orders[6] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  std::mt19937 rng(99);
  const uint32_t sizes[] = {0, 1, 1023, 1025, 7, 0, 2500, 513, 64, 3},
                 materials[] = {0, 3, 0, 1, 3, 2, 1, 3, 0, 2};
  std::set<std::pair<uint32_t, uint32_t>> jobs;  // (material, pool triangle): one classification each
  for (uint32_t g = 0; g < std::size(sizes); ++g) {
    std::vector<float> uv;
    for (uint32_t t = 0; t < sizes[g]; ++t) {
      const uint32_t p = uint32_t(rng() % 300), o = uint32_t(rng() % 6);
      if (materials[g] != 3) jobs.insert({materials[g], p});
      for (int k = 0; k < 3; ++k) {
        uv.push_back(pool[6 * p + 2 * orders[o][k]]);
        uv.push_back(pool[6 * p + 2 * orders[o][k] + 1]);
      }
    }
    Geometry geo = geometryOf(uv, ("g" + std::to_string(g)).c_str());
    geo.material = materials[g];
    s.geometries.push_back(geo);
  }
  BakeOptions o;
  o.level = 3;
  OmmArrayBuilder own;
  uint64_t unknown = 0;
  for (const Geometry& geo : s.geometries) {
    const Material& mat = s.materials[geo.material];
    if (!mat.alpha) {
      for (uint32_t t = 0; t < geo.triangleCount(); ++t) own.addSpecial(State::Opaque);
      continue;
    }
    const AlphaMask mask(*mat.alpha, mat.sampler, mat.alphaCutoff);
    for (uint32_t t = 0; t < geo.triangleCount(); ++t) {
      const float* p = geo.uvs.data() + 6 * t;
      const TriangleBake tb = bakeTriangle(mask, {p[0], p[1]}, {p[2], p[3]}, {p[4], p[5]}, o.level, o.format);
      unknown += tb.unknownCount;
      own.add(tb.map);
    }
  }
  const OmmArray expected = own.finish();
  for (uint32_t threads : {1u, 2u, 4u}) {
    o.threads = threads;
    auto r = bakeScene(s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    // Each (mask, corner set) once, however often and in whichever vertex order it repeats.
    EXPECT_EQ(r->classifiedTriangles, jobs.size());
    EXPECT_EQ(r->total.unknownMicroTriangles, unknown);
    expectSameArray(r->micromaps.arrays[0], expected);
  }
}

TEST(BakeScene, MaxBytesIsSceneWide) {
  const Scene s = sharedScene();
  BakeOptions o;
  o.level = 5;
  auto full = bakeScene(s, o);
  ASSERT_TRUE(full.ok());
  o.maxBytes = full->total.dataBytes / 3;
  auto r = bakeScene(s, o);
  ASSERT_TRUE(r.ok());
  EXPECT_LE(r->total.dataBytes, o.maxBytes);
  EXPECT_LT(r->total.levelCap, 5u);
  // The cap is the highest that fits: one more level does not.
  BakeOptions above = o;
  above.maxBytes = 0;
  above.level = r->total.levelCap + 1;
  auto a = bakeScene(s, above);
  ASSERT_TRUE(a.ok());
  EXPECT_GT(a->total.dataBytes, o.maxBytes);
}

TEST(BakeScene, BlendNeedsAPolicy) {
  Scene s = sharedScene();
  s.materials[1].alphaMode = AlphaMode::Blend;
  BakeOptions o;
  o.level = 2;
  auto r = bakeScene(s, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("material 'm1' has alpha mode BLEND"), std::string::npos)
      << r.error().message;
  o.blend = BlendAs::Unknown;
  r = bakeScene(s, o);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->geometries[1].stats.specialCount[size_t(State::UnknownOpaque)],
            s.geometries[1].triangleCount());
  EXPECT_EQ(r->geometries[1].stats.unknownMicroTriangles, s.geometries[1].triangleCount());
  o.blend = BlendAs::Opaque;
  r = bakeScene(s, o);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->geometries[1].stats.specialCount[size_t(State::Opaque)], s.geometries[1].triangleCount());
  o.blend = BlendAs::Mask;
  r = bakeScene(s, o);
  ASSERT_TRUE(r.ok());
  auto own = bakeGeometry(s.geometries[1], s.materials[1], o);
  expectSameArray(r->micromaps.standalone(1), own->array);
  // Opaque is opaque only when stated; the zero-initialised material input is baked.
  EXPECT_EQ(r->geometries[4].stats.specialCount[size_t(State::Opaque)], s.geometries[4].triangleCount());
  EXPECT_EQ(MaterialInput{}.alpha, MaterialAlpha::Tested);
}

TEST(BakeScene, ErrorsInLibraryTerms) {
  Scene s = sharedScene();
  BakeOptions o;
  o.level = 13;
  auto r = bakeScene(s, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "level 13 is out of range (0..12)");
  o.level = 2;
  s.geometries[2].indices[4] = 999;
  r = bakeScene(s, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "geometry 2 'g2': index 999 out of range (180 vertices with UVs)");
  TextureView tv;
  uint8_t px[4] = {};
  tv.data = px;
  tv.width = 2;
  tv.height = 1;
  tv.format = TexelFormat::RG8;
  tv.alphaChannel = 2;
  tv.name = "t.png";
  EXPECT_EQ(validateTexture(tv).error().message, "texture 't.png': alpha channel 2 is out of range for RG8");
  tv.alphaChannel = 1;
  tv.rowPitch = 3;
  EXPECT_EQ(validateTexture(tv).error().message, "texture 't.png': row pitch 3 is less than width * 2 = 4");
}

TEST(BakeScene, ProgressCanCancel) {
  const Scene s = sharedScene();
  BakeOptions o;
  o.level = 3;
  std::vector<double> seen;
  o.progress = [&](double f) { seen.push_back(f); };
  ASSERT_TRUE(bakeScene(s, o).ok());
  ASSERT_FALSE(seen.empty());
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(seen.back(), 1.0);
  o.progress = [](double) { return false; };
  auto r = bakeScene(s, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::Cancelled);
}

// The pool hands the progress callback to the calling thread only, with any thread count.
TEST(BakeScene, ProgressRunsOnTheCallingThread) {
  const Scene s = sharedScene();
  BakeOptions o;
  o.level = 5;
  o.threads = 2;
  const std::thread::id caller = std::this_thread::get_id();
  int calls = 0, elsewhere = 0;
  o.progress = [&](double) {
    ++calls;
    if (std::this_thread::get_id() != caller) ++elsewhere;
  };
  ASSERT_TRUE(bakeScene(s, o).ok());
  EXPECT_GE(calls, 1);
  EXPECT_EQ(elsewhere, 0);
  // Cancelled with two threads too.
  o.progress = [](double) { return false; };
  auto r = bakeScene(s, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::Cancelled);
}

}  // namespace
}  // namespace somm

namespace somm {
namespace {

// classifyRegion (the baker's test for one barycentric sub-triangle, for the tracer's bitmask) agrees with the bake:
// a micro-triangle's region is Opaque / Transparent exactly when the bake made it known with that state. This is
// also the check that deciding an inner node by its exact bilinear bound (nodes up to kNodeCells = 64 cells, linear)
// decides exactly what testing each micro-triangle would: on the 256² texture at level 5 the triangles' nodes at
// depths 0–4 cover from about 1,500 down to a few cells.
TEST(ClassifyRegion, AgreesWithTheBakedMicroTriangles) {
  struct Case {
    uint32_t w, h, level;
  };
  for (const Case& cs : {Case{48, 40, 3}, Case{256, 256, 5}}) {
    const uint32_t W = cs.w, H = cs.h;
    const AlphaTexture tex = floatTexture(alpha8(W, H), W, H);
    for (Filter f : {Filter::Nearest, Filter::Linear}) {
      const AlphaMask mask(tex, Sampler{Wrap::Repeat, Wrap::ClampToEdge, f}, 0.5f);
      const std::vector<float> uv = randomUvs(40, 11);
      uint64_t known = 0;
      for (size_t t = 0; t < uv.size() / 6; ++t) {
        const std::array<float, 2> a{uv[6 * t], uv[6 * t + 1]}, b{uv[6 * t + 2], uv[6 * t + 3]},
            c{uv[6 * t + 4], uv[6 * t + 5]};
        const uint32_t level = cs.level;
        const double side = double(1u << level);
        const Micromap map = bakeTriangle(mask, a, b, c, level, Format::FourState).map;
        for (uint32_t i = 0; i < map.size(); ++i) {
          const MicroTriangle m = indexToMicroTriangle(i, level);
          std::array<double, 2> corners[3];
          for (int k = 0; k < 3; ++k) corners[k] = {m.v[k].u / side, m.v[k].v / side};
          const State s = classifyRegion(mask, a, b, c, corners);
          const State baked = map.get(i);
          EXPECT_EQ(isKnown(s) ? s : State::UnknownOpaque, isKnown(baked) ? baked : State::UnknownOpaque)
              << "level " << level << " filter " << int(f) << " triangle " << t << " micro " << i;
          known += isKnown(baked);
        }
        const std::array<double, 2> whole[3] = {{0, 0}, {1, 0}, {0, 1}};
        const auto u = bakeTriangle(mask, a, b, c, 0, Format::FourState).map.get(0);
        EXPECT_EQ(classifyRegion(mask, a, b, c, whole), isKnown(u) ? u : State::UnknownOpaque);
      }
      EXPECT_GT(known, 100u);
    }
  }
}

// AlphaTexture at source precision: at() gives the loaders' float conversion (v / 65535 in double, 8-bit values
// widened as v · 257, then × factor in float and clamped) for every 8-bit value and sampled 16-bit values, with
// and without a factor; the float storage of the same alphas is the same.
TEST(AlphaTextureStorage, IntegerTexelsGiveTheLoaderFloats) {
  auto loader = [](uint32_t v16, float factor) {
    float a = float(v16 / 65535.0);
    if (factor != 1.0f) a *= factor;
    return std::clamp(a, 0.0f, 1.0f);
  };
  for (float factor : {1.0f, 0.7f, 1.9f}) {
    std::vector<uint8_t> v8(256);
    for (uint32_t v = 0; v < 256; ++v) v8[v] = uint8_t(v);
    const AlphaTexture t8 = AlphaTexture::fromUInt8(16, 16, v8, factor);
    ASSERT_TRUE(t8.consistent());
    for (uint32_t v = 0; v < 256; ++v) EXPECT_EQ(t8.at(v % 16, v / 16), loader(v * 257, factor)) << v;
    std::vector<uint16_t> v16;
    for (uint32_t v = 0; v < 65536; v += 97) v16.push_back(uint16_t(v));
    v16.push_back(65535);
    const AlphaTexture t16 = AlphaTexture::fromUInt16(uint32_t(v16.size()), 1, v16, factor);
    ASSERT_TRUE(t16.consistent());
    for (size_t i = 0; i < v16.size(); ++i) EXPECT_EQ(t16.texel(i), loader(v16[i], factor)) << v16[i];
  }
  AlphaTexture f;
  f.width = 2;
  f.height = 1;
  f.alpha = {0.25f, 1.0f};
  EXPECT_TRUE(f.consistent());
  EXPECT_EQ(f.at(0, 0), 0.25f);
  AlphaTexture bad = AlphaTexture::fromUInt8(2, 2, {1, 2, 3});
  EXPECT_FALSE(bad.consistent());
}

// The same alphas as 8 bits, 16 bits (v · 257) and floats, with a factor, bake to the same bytes through
// bakeScene(Scene) (masks over the 8/16-bit texels, no float copy) and through the AlphaMask of the texture.
TEST(AlphaTextureStorage, EveryStorageBakesTheSame) {
  const uint32_t w = 61, h = 47;
  const std::vector<uint8_t> a = alpha8(w, h);
  std::vector<uint16_t> a16(a.size());
  for (size_t i = 0; i < a.size(); ++i) a16[i] = uint16_t(a[i] * 257);
  const float factor = 0.9f;
  AlphaTexture flt = floatTexture(a, w, h);
  for (float& v : flt.alpha) v = std::clamp(v * factor, 0.0f, 1.0f);
  const std::vector<float> uv = randomUvs(300, 5);
  std::vector<std::vector<uint8_t>> outs;
  for (const AlphaTexture& t :
       {AlphaTexture::fromUInt8(w, h, a, factor), AlphaTexture::fromUInt16(w, h, a16, factor), flt}) {
    EXPECT_EQ(t.values(), flt.values());
    Scene s;
    Material m;
    m.alphaMode = AlphaMode::Mask;
    m.alphaCutoff = 0.4f;
    m.sampler = kSampler;
    m.alpha = std::make_shared<const AlphaTexture>(t);
    s.materials.push_back(m);
    s.geometries.push_back(geometryOf(uv, "g"));
    BakeOptions o;
    o.level = 5;
    auto r = bakeScene(s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    outs.push_back(r->micromaps.arrays[0].data);
    const AlphaMask mask(t, kSampler, 0.4f);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) ASSERT_EQ(mask.texel(x, y), flt.at(x, y));
    // The mask holds its word table and pass bits only: an 8/16-bit texture's value table is shared, not
    // copied (it was 256 KB per mask of a 16-bit texture).
    EXPECT_EQ(mask.memoryBytes(), (size_t(w / 64 + 2) * (h + 1)) * 4 + (size_t(w / 64 + 1) * h + 1) * 8);
  }
  EXPECT_EQ(outs[0], outs[2]);
  EXPECT_EQ(outs[1], outs[2]);
}

// A scene loaded without its colour images (LoadOptions::loadColor = false, as `somm bake` loads) has no baseColor
// and bakes to the same bytes as the full load.
TEST(AlphaTextureStorage, SceneWithoutColourBakesTheSame) {
  for (const char* rel : {"/oak-tree/oaktree.gltf", "/redeclipse-tree01/tree01.obj"}) {
    const std::string path = std::string(SOMM_DATA_DIR) + rel;
    if (!std::filesystem::exists(path)) continue;
    SCOPED_TRACE(path);
    auto full = loadScene(path);
    LoadOptions lo;
    lo.loadColor = false;
    auto lean = loadScene(path, lo);
    ASSERT_TRUE(full.ok() && lean.ok());
    bool anyColour = false;
    for (const Material& m : full->materials) anyColour |= bool(m.baseColor);
    EXPECT_TRUE(anyColour);
    for (const Material& m : lean->materials) EXPECT_FALSE(m.baseColor);
    for (uint32_t level : {3u, 7u}) {
      BakeOptions o;
      o.level = level;
      o.blend = BlendAs::Unknown;
      auto a = bakeScene(*full, o), b = bakeScene(*lean, o);
      ASSERT_TRUE(a.ok() && b.ok());
      expectSameArray(a->micromaps.arrays[0], b->micromaps.arrays[0]);
    }
  }
}

}  // namespace
}  // namespace somm
