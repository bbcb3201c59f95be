// SPDX-License-Identifier: MIT
// The C API (somm/somm.h): views of caller memory give the same buffers as the C++ baker and as `somm bake` +
// `somm export`; every texel format / index type / UV stride; errors, cancellation, buffer size checks; encoded
// arrays built from the copied buffers answer every lookup like the flat array.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "cli_util.h"
#include "somm/bake.h"
#include "somm/encode.h"
#include "somm/procedural.h"
#include "somm/scene.h"
#include "somm/somm.h"

namespace {

using somm::testing::readFile;
using somm::testing::runSomm;
using somm::testing::TempDir;

// The buffers of one array and of the geometries in it, as the C API hands them out.
struct Buffers {
  somm_array_info info{};
  std::vector<uint8_t> data, triangles, indices;  // indices: of the first geometry in the array
  std::vector<somm_usage_count> usage, triangleUsage;
  somm_index_type indexType = SOMM_INDEX_NONE;
};

void copyGeometry(const somm_bake_result* r, uint32_t g, Buffers& b) {
  somm_error e;
  somm_geometry_info gi;
  EXPECT_EQ(somm_bake_result_geometry_info(r, g, &gi, &e), SOMM_OK) << e.message;
  b.indexType = gi.index_type;
  b.indices.resize(size_t(gi.index_size));
  b.triangleUsage.resize(gi.usage_count_count);
  somm_geometry_buffers dst;
  std::memset(&dst, 0, sizeof dst);
  dst.indices = b.indices.data();
  dst.indices_capacity = b.indices.size();
  dst.usage_counts = b.triangleUsage.data();
  dst.usage_counts_capacity = uint32_t(b.triangleUsage.size());
  EXPECT_EQ(somm_bake_result_copy_geometry(r, g, &dst, &e), SOMM_OK) << e.message;
}

// Array a, with the index buffer of geometry `g` (default: a, for per-geometry arrays).
Buffers copyArray(const somm_bake_result* r, uint32_t a, int g = -1) {
  Buffers b;
  somm_error e;
  EXPECT_EQ(somm_bake_result_array_info(r, a, &b.info, &e), SOMM_OK) << e.message;
  b.data.resize(size_t(b.info.data_size));
  b.triangles.resize(size_t(b.info.triangle_count) * 8);
  b.usage.resize(b.info.usage_count_count);
  somm_array_buffers dst;
  std::memset(&dst, 0, sizeof dst);
  dst.data = b.data.data();
  dst.data_capacity = b.data.size();
  dst.triangles = b.triangles.data();
  dst.triangles_capacity = b.triangles.size();
  dst.usage_counts = b.usage.data();
  dst.usage_counts_capacity = uint32_t(b.usage.size());
  EXPECT_EQ(somm_bake_result_copy_array(r, a, &dst, &e), SOMM_OK) << e.message;
  copyGeometry(r, g < 0 ? a : uint32_t(g), b);
  return b;
}

void expectEqual(const Buffers& b, const somm::OmmArray& a) {
  EXPECT_EQ(b.data, a.data);
  EXPECT_EQ(b.triangles, a.descriptorBytes());
  EXPECT_EQ(b.indices, a.indexBufferBytes());
  ASSERT_EQ(b.usage.size(), a.histogram.size());
  for (size_t i = 0; i < a.histogram.size(); ++i) {
    EXPECT_EQ(b.usage[i].count, a.histogram[i].count);
    EXPECT_EQ(b.usage[i].subdivision_level, a.histogram[i].subdivisionLevel);
    EXPECT_EQ(b.usage[i].format, a.histogram[i].format);
  }
  ASSERT_EQ(b.triangleUsage.size(), a.triangleHistogram.size());
  for (size_t i = 0; i < a.triangleHistogram.size(); ++i)
    EXPECT_EQ(b.triangleUsage[i].count, a.triangleHistogram[i].count);
}

// A leaf-card scene (binary-alpha atlas): its alpha as 8-bit texels, and the same scene with the alpha that an
// 8-bit image decodes to, for the C++ baker.
struct Input {
  somm::Scene scene;
  std::vector<uint8_t> rgba;  // width·height·4, alpha in channel 3
};

Input leafCards(uint32_t cards) {
  Input in;
  in.scene = somm::makeLeafCardScene(cards, 7);
  const somm::AlphaTexture& t = *in.scene.materials[0].alpha;
  auto q = std::make_shared<somm::AlphaTexture>(t);
  in.rgba.assign(size_t(t.width) * t.height * 4, 0);
  for (size_t i = 0; i < t.alpha.size(); ++i) {
    const uint8_t b = uint8_t(std::lround(double(t.alpha[i]) * 255.0));
    in.rgba[4 * i + 0] = uint8_t(i);
    in.rgba[4 * i + 1] = 200;
    in.rgba[4 * i + 3] = b;
    q->alpha[i] = float(double(b) / 255.0);
  }
  in.scene.materials[0].alpha = q;
  return in;
}

somm_texture rgba8(const Input& in) {
  const somm::AlphaTexture& t = *in.scene.materials[0].alpha;
  somm_texture tex = somm_texture_default();
  tex.data = in.rgba.data();
  tex.size = in.rgba.size();
  tex.width = t.width;
  tex.height = t.height;
  return tex;
}

somm_material material(const somm::Material& m, const somm_texture* tex) {
  somm_material cm = somm_material_default();
  cm.cutoff = m.alphaCutoff;
  cm.texture = tex;
  cm.sampler.filter = somm_filter(m.sampler.filter);
  cm.sampler.wrap_s = somm_wrap(m.sampler.wrapS);
  cm.sampler.wrap_t = somm_wrap(m.sampler.wrapT);
  return cm;
}

somm_geometry geometry(const somm::Geometry& g) {
  somm_geometry cg = somm_geometry_default();
  cg.uvs = g.uvs.data();
  cg.vertex_count = uint32_t(g.uvs.size() / 2);
  cg.indices = g.indices.data();
  cg.triangle_count = g.triangleCount();
  cg.material = g.material;
  return cg;
}

struct Baked {
  somm_bake_result* r = nullptr;
  somm_result code = SOMM_OK;
  somm_error error{};
  ~Baked() { somm_bake_result_destroy(r); }
};

void bake(Baked& b, const std::vector<somm_geometry>& gs, const std::vector<somm_material>& ms,
          const somm_bake_options& o) {
  somm_bake_input in;
  in.geometries = gs.data();
  in.geometry_count = uint32_t(gs.size());
  in.materials = ms.data();
  in.material_count = uint32_t(ms.size());
  b.code = somm_bake(&in, &o, &b.r, &b.error);
}

TEST(CApi, VersionAndDefaults) {
  EXPECT_STREQ(somm_version(), "0.1.0");
  EXPECT_EQ(std::to_string(SOMM_VERSION_MAJOR) + "." + std::to_string(SOMM_VERSION_MINOR) + "." +
                std::to_string(SOMM_VERSION_PATCH),
            somm_version());
  const somm_bake_options o = somm_bake_options_default();
  EXPECT_EQ(o.level, 6u);
  EXPECT_EQ(o.format, SOMM_FORMAT_4_STATE);
  EXPECT_EQ(o.max_bytes, 0u);
  EXPECT_EQ(o.progress, nullptr);
  EXPECT_EQ(o.layout, SOMM_ARRAY_PER_SCENE);  // as `somm bake`
  const somm_material m = somm_material_default();
  EXPECT_EQ(m.alpha_mode, SOMM_ALPHA_MASK);  // never a silent "opaque, nothing baked"
  EXPECT_EQ(m.cutoff, 0.5f);
  EXPECT_EQ(m.sampler.filter, SOMM_FILTER_LINEAR);
  EXPECT_STREQ(somm_result_name(SOMM_ERROR_CANCELLED), "cancelled");
  static_assert(sizeof(somm_usage_count) == 12, "VkMicromapUsageEXT layout");
}

// The C API on an RGBA8 image equals bakeGeometry on the alpha that image decodes to, byte for byte.
TEST(CApi, EqualsTheCxxBaker) {
  const Input in = leafCards(60);
  const somm_texture tex = rgba8(in);
  const std::vector<somm_material> ms = {material(in.scene.materials[0], &tex)};
  const std::vector<somm_geometry> gs = {geometry(in.scene.geometries[0])};
  for (uint32_t format : {2u, 4u}) {
    somm_bake_options o = somm_bake_options_default();
    o.level = 5;
    o.format = format == 2 ? SOMM_FORMAT_2_STATE : SOMM_FORMAT_4_STATE;
    Baked b;
    bake(b, gs, ms, o);
    ASSERT_EQ(b.code, SOMM_OK) << b.error.message;
    ASSERT_EQ(somm_bake_result_array_count(b.r), 1u);
    somm::BakeOptions bo;
    bo.level = 5;
    bo.format = format == 2 ? somm::Format::TwoState : somm::Format::FourState;
    auto ref = somm::bakeGeometry(in.scene.geometries[0], in.scene.materials[0], bo);
    ASSERT_TRUE(ref) << ref.error().message;
    ASSERT_GT(ref->array.descriptors.size(), 10u);
    expectEqual(copyArray(b.r, 0), ref->array);
    somm_geometry_info gi;
    ASSERT_EQ(somm_bake_result_geometry_info(b.r, 0, &gi, nullptr), SOMM_OK);
    EXPECT_EQ(gi.micro_triangles, ref->stats.microTriangles);
    EXPECT_EQ(gi.unknown_micro_triangles, ref->stats.unknownMicroTriangles);
    for (int s = 0; s < 4; ++s) EXPECT_EQ(gi.special_count[s], ref->stats.specialCount[size_t(s)]);
    EXPECT_EQ(gi.array, 0u);
    EXPECT_EQ(gi.index_type, SOMM_INDEX_UINT16);
  }
}

// Every view of the same data gives the same bytes: texel formats (alpha in any channel, row padding), strided UVs,
// 16-bit / 32-bit / no indices.
TEST(CApi, EveryViewGivesTheSameBytes) {
  const Input in = leafCards(40);
  const somm::Geometry& g = in.scene.geometries[0];
  const uint32_t w = in.scene.materials[0].alpha->width, h = in.scene.materials[0].alpha->height;
  const somm_texture base = rgba8(in);
  somm_bake_options o = somm_bake_options_default();
  o.level = 4;
  auto bytesOf = [&](const somm_texture& tex, const somm_geometry& cg) {
    const std::vector<somm_material> ms = {material(in.scene.materials[0], &tex)};
    Baked b;
    bake(b, {cg}, ms, o);
    EXPECT_EQ(b.code, SOMM_OK) << b.error.message;
    if (b.code != SOMM_OK) return Buffers{};
    return copyArray(b.r, 0);
  };
  const Buffers ref = bytesOf(base, geometry(g));
  ASSERT_GT(ref.info.triangle_count, 5u);

  // Binary alpha: 0 or full scale in every format. Each with 3 bytes of row padding and alpha in channel c.
  std::vector<std::vector<uint8_t>> store;
  for (somm_texel_format f : {SOMM_TEXEL_R8, SOMM_TEXEL_RG8, SOMM_TEXEL_RGBA8, SOMM_TEXEL_R16,
                              SOMM_TEXEL_RGBA16, SOMM_TEXEL_R32F}) {
    const uint32_t tb = f == SOMM_TEXEL_R8                           ? 1
                        : f == SOMM_TEXEL_RG8 || f == SOMM_TEXEL_R16 ? 2
                        : f == SOMM_TEXEL_RGBA16                     ? 8
                                                                     : 4;
    const uint32_t ch = f == SOMM_TEXEL_RG8 ? 1 : f == SOMM_TEXEL_RGBA8 ? 2 : f == SOMM_TEXEL_RGBA16 ? 3 : 0;
    const size_t pitch = size_t(w) * tb + 3;
    std::vector<uint8_t> px(pitch * h, 0x5a);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        const bool on = in.rgba[(size_t(y) * w + x) * 4 + 3] >= 128;
        uint8_t* p = &px[y * pitch + size_t(x) * tb];
        std::memset(p, 0x11, tb);  // other channels: noise
        if (f == SOMM_TEXEL_R8 || f == SOMM_TEXEL_RG8 || f == SOMM_TEXEL_RGBA8) p[ch] = on ? 255 : 0;
        if (f == SOMM_TEXEL_R16 || f == SOMM_TEXEL_RGBA16) {
          const uint16_t v = on ? 65535 : 0;
          std::memcpy(p + 2 * ch, &v, 2);
        }
        if (f == SOMM_TEXEL_R32F) {
          const float v = on ? 1.0f : 0.0f;
          std::memcpy(p, &v, 4);
        }
      }
    store.push_back(std::move(px));
    somm_texture t = base;
    t.data = store.back().data();
    t.size = store.back().size();
    t.row_pitch = pitch;
    t.format = f;
    t.alpha_channel = ch;
    const Buffers b = bytesOf(t, geometry(g));
    EXPECT_EQ(b.data, ref.data) << "format " << int(f);
    EXPECT_EQ(b.triangles, ref.triangles) << "format " << int(f);
    EXPECT_EQ(b.indices, ref.indices) << "format " << int(f);
  }

  // Strided UVs (interleaved with positions) and 16-bit indices.
  const uint32_t nv = uint32_t(g.uvs.size() / 2);
  std::vector<float> interleaved(size_t(nv) * 5, -7.0f);
  for (uint32_t v = 0; v < nv; ++v) {
    interleaved[5 * v + 3] = g.uvs[2 * v];
    interleaved[5 * v + 4] = g.uvs[2 * v + 1];
  }
  std::vector<uint16_t> idx16(g.indices.begin(), g.indices.end());
  somm_geometry cg = geometry(g);
  cg.uvs = interleaved.data() + 3;
  cg.uv_stride = 5 * sizeof(float);
  cg.indices = idx16.data();
  cg.index_type = SOMM_INDEX_UINT16;
  Buffers b = bytesOf(base, cg);
  EXPECT_EQ(b.data, ref.data);
  EXPECT_EQ(b.indices, ref.indices);
  // Non-indexed: vertices 3t..3t+2.
  std::vector<float> flat;
  for (uint32_t i : g.indices) flat.insert(flat.end(), {g.uvs[2 * i], g.uvs[2 * i + 1]});
  cg = geometry(g);
  cg.uvs = flat.data();
  cg.vertex_count = uint32_t(flat.size() / 2);
  cg.indices = nullptr;
  cg.index_type = SOMM_INDEX_NONE;
  b = bytesOf(base, cg);
  EXPECT_EQ(b.data, ref.data);
  EXPECT_EQ(b.triangles, ref.triangles);
  EXPECT_EQ(b.indices, ref.indices);
}

// Scene-level policy: BLEND (unknown, or as mask), OPAQUE, constant alpha, the scene-wide byte budget, one shared
// array.
TEST(CApi, ScenePolicyAndLayout) {
  const Input in = leafCards(50);
  const somm_texture tex = rgba8(in);
  std::vector<somm_material> ms(4, material(in.scene.materials[0], &tex));
  ms[1].alpha_mode = SOMM_ALPHA_BLEND;
  ms[2].alpha_mode = SOMM_ALPHA_OPAQUE;
  ms[3].texture = nullptr;
  ms[3].constant_alpha = 0.25f;  // below the cutoff: fully transparent
  std::vector<somm_geometry> gs(4, geometry(in.scene.geometries[0]));
  for (uint32_t i = 0; i < 4; ++i) gs[i].material = i;
  const uint32_t n = in.scene.geometries[0].triangleCount();

  somm_bake_options o = somm_bake_options_default();
  o.layout = SOMM_ARRAY_PER_GEOMETRY;
  Baked b;
  bake(b, gs, ms, o);
  ASSERT_EQ(b.code, SOMM_OK) << b.error.message;
  ASSERT_EQ(somm_bake_result_array_count(b.r), 4u);
  somm_geometry_info gi[4];
  for (uint32_t g = 0; g < 4; ++g)
    ASSERT_EQ(somm_bake_result_geometry_info(b.r, g, &gi[g], nullptr), SOMM_OK);
  EXPECT_EQ(gi[1].special_count[SOMM_STATE_UNKNOWN_OPAQUE], n);
  EXPECT_EQ(gi[2].special_count[SOMM_STATE_OPAQUE], n);
  EXPECT_EQ(gi[3].special_count[SOMM_STATE_TRANSPARENT], n);
  const Buffers mask = copyArray(b.r, 0);

  o.blend = SOMM_BLEND_AS_MASK;
  Baked asMask;
  bake(asMask, gs, ms, o);
  ASSERT_EQ(asMask.code, SOMM_OK);
  EXPECT_EQ(copyArray(asMask.r, 1).data, mask.data);
  EXPECT_EQ(copyArray(asMask.r, 1).indices, mask.indices);

  // One scene-wide array: identical maps stored once; geometry 1 (as mask) shares all of geometry 0's maps.
  o.layout = SOMM_ARRAY_PER_SCENE;
  Baked scene;
  bake(scene, gs, ms, o);
  ASSERT_EQ(scene.code, SOMM_OK);
  ASSERT_EQ(somm_bake_result_array_count(scene.r), 1u);
  const Buffers s = copyArray(scene.r, 0, 1);
  EXPECT_EQ(s.data, mask.data);
  EXPECT_EQ(s.info.geometry_count, 4u);
  EXPECT_EQ(s.indices,
            mask.indices);  // geometry 1 (BLEND as mask) uses the same maps as geometry 0 did alone
  ASSERT_EQ(somm_bake_result_geometry_info(scene.r, 2, &gi[2], nullptr), SOMM_OK);
  EXPECT_EQ(gi[2].array, 0u);
  EXPECT_EQ(gi[2].triangle_count, n);
  EXPECT_EQ(gi[2].usage_count_count, 0u);  // all special

  // Budget: the data of all geometries together fits, with a scene-wide cap below 12.
  o = somm_bake_options_default();
  o.layout = SOMM_ARRAY_PER_GEOMETRY;
  o.level = 7;
  o.max_bytes = mask.data.size() / 3;
  Baked capped;
  bake(capped, gs, ms, o);
  ASSERT_EQ(capped.code, SOMM_OK);
  uint64_t total = 0;
  for (uint32_t a = 0; a < somm_bake_result_array_count(capped.r); ++a)
    total += copyArray(capped.r, a).data.size();
  EXPECT_LE(total, o.max_bytes);
  EXPECT_LT(somm_bake_result_level_cap(capped.r), 7u);
}

TEST(CApi, ErrorsCancellationAndBufferSizes) {
  const Input in = leafCards(8);
  somm_texture tex = rgba8(in);
  std::vector<somm_material> ms = {material(in.scene.materials[0], &tex)};
  std::vector<somm_geometry> gs = {geometry(in.scene.geometries[0])};
  somm_bake_options o = somm_bake_options_default();
  auto expectError = [&](somm_result code, const char* text) {
    Baked b;
    bake(b, gs, ms, o);
    EXPECT_EQ(b.code, code) << b.error.message;
    EXPECT_EQ(b.error.code, code);
    EXPECT_NE(std::string(b.error.message).find(text), std::string::npos) << b.error.message;
    EXPECT_EQ(b.r, nullptr);
  };
  o.level = 13;
  expectError(SOMM_ERROR_INVALID_ARGUMENT, "options.level 13 is out of range 0..12");
  o = somm_bake_options_default();
  tex.alpha_channel = 4;
  expectError(SOMM_ERROR_INVALID_ARGUMENT, "materials[0].texture.alpha_channel 4");
  tex = rgba8(in);
  tex.size -= 1;
  expectError(SOMM_ERROR_INVALID_ARGUMENT, "materials[0].texture.size");
  tex = rgba8(in);
  gs[0].vertex_count = 3;
  expectError(SOMM_ERROR_INVALID_ARGUMENT, "geometries[0]: index");
  gs = {geometry(in.scene.geometries[0])};
  gs[0].material = 1;
  expectError(SOMM_ERROR_INVALID_ARGUMENT, "geometries[0].material 1 is out of range");
  gs = {geometry(in.scene.geometries[0])};
  ms[0].cutoff = 2.0f;
  expectError(SOMM_ERROR_INVALID_ARGUMENT, "materials[0].cutoff");
  ms = {material(in.scene.materials[0], &tex)};

  // Cancellation from the progress callback.
  o.progress = [](double, void* user) -> int { return ++*static_cast<int*>(user) >= 1; };
  int calls = 0;
  o.progress_user = &calls;
  expectError(SOMM_ERROR_CANCELLED, "cancelled");
  EXPECT_EQ(calls, 1);
  // Progress without cancelling: non-decreasing, ends at 1.
  std::vector<double> seen;
  o.progress = [](double f, void* user) -> int {
    static_cast<std::vector<double>*>(user)->push_back(f);
    return 0;
  };
  o.progress_user = &seen;
  Baked ok;
  bake(ok, gs, ms, o);
  ASSERT_EQ(ok.code, SOMM_OK);
  ASSERT_FALSE(seen.empty());
  for (size_t i = 1; i < seen.size(); ++i) EXPECT_LE(seen[i - 1], seen[i]);
  EXPECT_EQ(seen.back(), 1.0);

  // Caller buffers smaller than the size query: nothing written, BUFFER_TOO_SMALL.
  somm_array_info info;
  ASSERT_EQ(somm_bake_result_array_info(ok.r, 0, &info, nullptr), SOMM_OK);
  ASSERT_GT(info.data_size, 0u);
  std::vector<uint8_t> small(size_t(info.data_size) - 1, 0xcc);
  somm_array_buffers dst;
  std::memset(&dst, 0, sizeof dst);
  dst.data = small.data();
  dst.data_capacity = small.size();
  somm_error e;
  EXPECT_EQ(somm_bake_result_copy_array(ok.r, 0, &dst, &e), SOMM_ERROR_BUFFER_TOO_SMALL);
  EXPECT_NE(std::string(e.message).find("data capacity"), std::string::npos) << e.message;
  EXPECT_EQ(small, std::vector<uint8_t>(small.size(), 0xcc));
  EXPECT_EQ(somm_bake_result_array_info(ok.r, 1, &info, &e), SOMM_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(somm_bake(nullptr, nullptr, nullptr, nullptr),
            SOMM_ERROR_INVALID_ARGUMENT);  // NULL error is fine
}

// Encoded arrays built from the copied spec buffers: every state equals the flat array's, serialize/parse round
// trip, the same bytes as EncodedArray::build, and hostile bytes are rejected.
TEST(CApi, EncodedArrays) {
  const Input in = leafCards(30);
  const somm_texture tex = rgba8(in);
  const std::vector<somm_material> ms = {material(in.scene.materials[0], &tex)};
  const std::vector<somm_geometry> gs = {geometry(in.scene.geometries[0])};
  somm_bake_options o = somm_bake_options_default();
  o.level = 5;
  Baked b;
  bake(b, gs, ms, o);
  ASSERT_EQ(b.code, SOMM_OK);
  const Buffers buf = copyArray(b.r, 0);
  somm::BakeOptions bo;
  bo.level = 5;
  const somm::OmmArray ref = somm::bakeGeometry(in.scene.geometries[0], in.scene.materials[0], bo)->array;
  somm_flat_array flat = somm_flat_array_default();
  flat.data = buf.data.data();
  flat.data_size = buf.data.size();
  flat.triangles = buf.triangles.data();
  flat.triangle_count = buf.info.triangle_count;
  flat.indices = buf.indices.data();
  flat.index_type = buf.indexType;
  flat.index_count = uint32_t(buf.indices.size() / size_t(buf.indexType));
  for (somm_encoding enc : {SOMM_ENCODING_FLAT, SOMM_ENCODING_DFS, SOMM_ENCODING_DFS_FAST, SOMM_ENCODING_RANK,
                            SOMM_ENCODING_HYBRID, SOMM_ENCODING_CSM, SOMM_ENCODING_SDAG}) {
    somm_encoded_array* a = nullptr;
    somm_error e;
    ASSERT_EQ(somm_encoded_array_build(&flat, enc, &a, &e), SOMM_OK) << e.message;
    EXPECT_EQ(somm_encoded_array_encoding(a), enc);
    ASSERT_EQ(somm_encoded_array_triangle_count(a), ref.indices.size());
    for (uint32_t t = 0; t < ref.indices.size(); ++t) {
      const int level = somm_encoded_array_level(a, t);
      ASSERT_EQ(level,
                ref.indices[t] < 0 ? 0 : int(ref.descriptors[size_t(ref.indices[t])].subdivisionLevel));
      const uint32_t count = ref.indices[t] < 0 ? 1 : somm::microTriangleCount(uint32_t(level));
      for (uint32_t i = 0; i < count; ++i) ASSERT_EQ(somm_encoded_array_state(a, t, i), int(ref.state(t, i)));
      EXPECT_EQ(somm_encoded_array_state_uv(a, t, 0.2f, 0.3f), int(ref.stateUV(t, 0.2f, 0.3f)));
    }
    EXPECT_EQ(somm_encoded_array_state(a, uint32_t(ref.indices.size()), 0), -1);
    std::vector<uint8_t> bytes(size_t(somm_encoded_array_serialized_size(a)));
    ASSERT_EQ(somm_encoded_array_serialize(a, bytes.data(), bytes.size(), &e), SOMM_OK) << e.message;
    EXPECT_EQ(bytes, somm::EncodedArray::build(ref, somm::Encoding(enc))->serialize());
    EXPECT_EQ(somm_encoded_array_serialize(a, bytes.data(), bytes.size() - 1, &e),
              SOMM_ERROR_BUFFER_TOO_SMALL);
    somm_encoded_array* p = nullptr;
    ASSERT_EQ(somm_encoded_array_parse(bytes.data(), bytes.size(), &p, &e), SOMM_OK) << e.message;
    for (uint32_t t = 0; t < ref.indices.size(); ++t)
      ASSERT_EQ(somm_encoded_array_state(p, t, 0), int(ref.state(t, 0)));
    somm_encoded_array_destroy(p);
    p = nullptr;
    EXPECT_EQ(somm_encoded_array_parse(bytes.data(), bytes.size() / 2, &p, &e), SOMM_ERROR_CORRUPT);
    EXPECT_EQ(p, nullptr);
    somm_encoded_array_destroy(a);
  }
  // Inconsistent flat buffers are rejected with a message.
  std::vector<uint8_t> badTriangles = buf.triangles;
  badTriangles[0] = 0xff, badTriangles[3] = 0x7f;  // offset far outside the data
  flat.triangles = badTriangles.data();
  somm_encoded_array* a = nullptr;
  somm_error e;
  EXPECT_EQ(somm_encoded_array_build(&flat, SOMM_ENCODING_RANK, &a, &e), SOMM_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(a, nullptr);
  EXPECT_GT(std::strlen(e.message), 0u);
}

// Real data through the C API (alpha as R32F: the loader's floats exactly) and through `somm bake` + `somm export`:
// the same bytes for every geometry.
TEST(CApi, OakTreeEqualsSommBakeAndExport) {
  const std::string path = std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf";
  auto scene = somm::loadScene(path);
  ASSERT_TRUE(scene) << scene.error().message;
  std::vector<somm_texture> texs(scene->materials.size());
  std::vector<std::vector<float>> floats(scene->materials.size());
  std::vector<somm_material> ms;
  for (size_t m = 0; m < scene->materials.size(); ++m) {
    const somm::Material& sm = scene->materials[m];
    somm_material cm = material(sm, nullptr);
    cm.alpha_mode = somm_alpha_mode(sm.alphaMode);
    if (sm.alpha) {
      texs[m] = somm_texture_default();
      floats[m] = sm.alpha->values();
      texs[m].data = floats[m].data();
      texs[m].size = floats[m].size() * sizeof(float);
      texs[m].width = sm.alpha->width;
      texs[m].height = sm.alpha->height;
      texs[m].format = SOMM_TEXEL_R32F;
      texs[m].alpha_channel = 0;
      cm.texture = &texs[m];
    } else {
      cm.constant_alpha = sm.baseColorFactor[3];
    }
    ms.push_back(cm);
  }
  std::vector<somm_geometry> gs;
  for (const somm::Geometry& g : scene->geometries) gs.push_back(geometry(g));
  somm_bake_options o = somm_bake_options_default();
  o.level = 7;
  Baked b;
  bake(b, gs, ms, o);
  ASSERT_EQ(b.code, SOMM_OK) << b.error.message;

  TempDir dir;
  const auto baked = runSomm("bake '" + path + "' --level 7 -o '" + dir.file("oak.somm") + "'");
  ASSERT_EQ(baked.exitCode, 0) << baked.err;
  const auto exported = runSomm("export '" + dir.file("oak.somm") + "' --dir '" + dir.file("out") + "'");
  ASSERT_EQ(exported.exitCode, 0) << exported.err;
  ASSERT_EQ(somm_bake_result_geometry_count(b.r), scene->geometries.size());
  ASSERT_EQ(somm_bake_result_array_count(b.r), 1u);  // one scene-wide array, as `somm bake`
  const Buffers buf = copyArray(b.r, 0);
  EXPECT_EQ(std::string(buf.data.begin(), buf.data.end()), readFile(dir.file("out/array-0/data.bin")));
  EXPECT_EQ(std::string(buf.triangles.begin(), buf.triangles.end()),
            readFile(dir.file("out/array-0/triangles.bin")));
  size_t withMaps = buf.info.triangle_count;
  for (uint32_t g = 0; g < somm_bake_result_geometry_count(b.r); ++g) {
    Buffers gb;
    copyGeometry(b.r, g, gb);
    EXPECT_EQ(std::string(gb.indices.begin(), gb.indices.end()),
              readFile(dir.file("out/geometry-" + std::to_string(g) + "/index.bin")))
        << g;
  }
  EXPECT_GT(withMaps, 0u);
}

}  // namespace
