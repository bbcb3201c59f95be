// SPDX-License-Identifier: MIT
// Fuzz target: the C API (include/somm/somm.h) driven from fuzzer bytes, as a C caller would use it.
// Three modes (first byte % 3):
//   0: bake — textures (every texel format, strides, pitches, sizes), materials (alpha modes, cutoffs, samplers),
//      geometries (index types, UV strides, counts, material indices), options (levels, adaptive levels, format,
//      unknown_as, blend, layout, budget, a cancelling progress callback). Every caller buffer is a heap block of
//      exactly the bytes the contract says are read, so ASan reports any read outside it. An independent model of
//      the documented contract says whether the input is valid: invalid → SOMM_ERROR_INVALID_ARGUMENT, valid →
//      SOMM_OK (or SOMM_ERROR_CANCELLED when the callback asked). On success every size query, too-small buffer
//      (SOMM_ERROR_BUFFER_TOO_SMALL, nothing written), exact copy, histogram and special count is checked, and the
//      copied buffers are built into every encoding, which must answer like the flat data read by hand.
//   1: parse — the rest of the input as a serialized encoded array: an error, or an array whose every lookup stays
//      in bounds and whose serialization round-trips.
//   2: build — flat buffers (data, 8-byte triangle records, 16/32-bit indices) from the bytes: the same validity
//      model (levels, formats, offsets, indices, encodings); accepted arrays answer exactly like the flat bytes.
// Work per input is bounded: at most 4 geometries × 8 triangles, 16 × 16 texels, level ≤ 7 in bakes.
#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include "somm/bird.h"
#include "somm/somm.h"

namespace {

[[noreturn]] void fail(const char* what, const char* detail = "") {
  std::fprintf(stderr, "fuzz_capi: %s %s\n", what, detail);
  std::abort();
}
void check(bool ok, const char* what, const char* detail = "") {
  if (!ok) fail(what, detail);
}

// The error struct after a call: same code, a one-line NUL-terminated message (non-empty on failure).
void checkError(somm_result r, const somm_error& e) {
  check(e.code == r, "somm_error.code differs from the returned code");
  const void* nul = std::memchr(e.message, 0, sizeof e.message);
  check(nul != nullptr, "somm_error.message is not NUL-terminated");
  const size_t n = size_t(static_cast<const char*>(nul) - e.message);
  check(std::memchr(e.message, '\n', n) == nullptr, "somm_error.message is not one line", e.message);
  if (r == SOMM_OK)
    check(n == 0, "message on success", e.message);
  else
    check(n > 0, "empty message on failure");
}

// A heap block of exactly `n` bytes (ASan redzones right after it); data() is non-null even for n == 0.
struct Block {
  std::unique_ptr<uint8_t[]> p;
  size_t n = 0;
  explicit Block(size_t size = 0) : p(new uint8_t[size ? size : 1]), n(size) { std::memset(p.get(), 0, n); }
  uint8_t* data() const { return p.get(); }
};

void fill(FuzzedDataProvider& in, Block& b) {
  const std::vector<uint8_t> bytes = in.ConsumeBytes<uint8_t>(b.n);
  if (!bytes.empty()) std::memcpy(b.data(), bytes.data(), bytes.size());
}

// An enum value: mostly one of the valid ones, sometimes an invalid one (just past the range, far out, negative).
// Stored into the field as the int it is (a C caller may store any int; loading an out-of-range value through
// the C++ enum type would be undefined behaviour, so the fuzzer keeps the int and never loads the field).
template <class E>
int pickEnum(FuzzedDataProvider& in, std::initializer_list<int> valid, bool& ok, E& field) {
  static_assert(sizeof(E) == sizeof(int), "C API enums are int-sized");
  const uint8_t b = in.ConsumeIntegral<uint8_t>();
  int v;
  if (b < 240) {
    v = valid.begin()[b % valid.size()];
  } else {
    int maxValid = 0;
    for (int x : valid) maxValid = x > maxValid ? x : maxValid;
    const int invalid[] = {maxValid + 1, -1, 100, 0x7fffffff};
    v = invalid[b % 4];
  }
  ok = false;
  for (int x : valid) ok = ok || x == v;
  std::memcpy(&field, &v, sizeof v);
  return v;
}

// A float: common valid values, values just outside [0, 1], NaN, infinities or raw bits.
float pickFloat(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegral<uint8_t>() % 12) {
    case 0:
      return 0.0f;
    case 1:
      return 1.0f;
    case 2:
      return 0.5f;
    case 3:
      return -0.25f;
    case 4:
      return 1.25f;
    case 5:
      return std::numeric_limits<float>::quiet_NaN();
    case 6:
      return std::numeric_limits<float>::infinity();
    case 7: {
      float f;
      const uint32_t bits = in.ConsumeIntegral<uint32_t>();
      std::memcpy(&f, &bits, 4);
      return f;
    }
    default:
      return float(in.ConsumeIntegral<uint8_t>()) / 255.0f;
  }
}
bool inUnit(float f) {
  return f >= 0.0f && f <= 1.0f;
}

uint32_t texelBytes(int f) {
  switch (f) {
    case SOMM_TEXEL_R8:
      return 1;
    case SOMM_TEXEL_RG8:
    case SOMM_TEXEL_R16:
      return 2;
    case SOMM_TEXEL_RGBA8:
    case SOMM_TEXEL_R32F:
      return 4;
    case SOMM_TEXEL_RGBA16:
      return 8;
    default:
      return 0;
  }
}
uint32_t channelCount(int f) {
  return f == SOMM_TEXEL_RG8 ? 2 : (f == SOMM_TEXEL_RGBA8 || f == SOMM_TEXEL_RGBA16) ? 4 : 1;
}

struct FuzzTexture {
  somm_texture t{};
  Block block;
  bool valid = true;
};

std::unique_ptr<FuzzTexture> makeTexture(FuzzedDataProvider& in) {
  auto ft = std::make_unique<FuzzTexture>();
  somm_texture& t = ft->t;
  t = somm_texture_default();
  bool ok = true;
  const int format = pickEnum(
      in,
      {SOMM_TEXEL_R8, SOMM_TEXEL_RG8, SOMM_TEXEL_RGBA8, SOMM_TEXEL_R16, SOMM_TEXEL_RGBA16, SOMM_TEXEL_R32F},
      ok, t.format);
  ft->valid &= ok;
  const uint32_t tb = texelBytes(format);
  const uint8_t dims = in.ConsumeIntegral<uint8_t>();
  t.width = dims & 15u;  // 0 is invalid
  t.height = dims >> 4;
  if (t.width == 0 || t.height == 0) ft->valid = false;
  const uint8_t ch = in.ConsumeIntegral<uint8_t>();
  t.alpha_channel = ch < 224 ? (channelCount(format) - 1) - (ch % channelCount(format)) : ch % 8;
  if (t.alpha_channel >= channelCount(format)) ft->valid = false;
  const uint64_t row = uint64_t(t.width) * (tb ? tb : 1);
  const uint8_t pitchSel = in.ConsumeIntegral<uint8_t>();
  uint64_t pitch = row;
  if (pitchSel < 128) {
    t.row_pitch = 0;
  } else if (pitchSel < 240) {
    pitch = row + (pitchSel & 7u);
    t.row_pitch = size_t(pitch);
  } else {
    pitch = row ? row - 1 : 0;  // less than a row: invalid (0 means tight)
    t.row_pitch = size_t(pitch);
    if (pitch == 0)
      pitch = row;
    else
      ft->valid = false;
  }
  const uint64_t need = t.height ? (uint64_t(t.height) - 1) * pitch + row : 0;
  const uint8_t sizeSel = in.ConsumeIntegral<uint8_t>();
  uint64_t size = need + (sizeSel & 3u);
  if (sizeSel >= 240 && need > 0) {
    size = need - 1;
    if (t.width && t.height && tb) ft->valid = false;
  }
  t.size = size_t(size);
  ft->block = Block(size_t(size));
  fill(in, ft->block);
  t.data = in.ConsumeIntegral<uint8_t>() >= 250 ? nullptr : ft->block.data();
  if (!t.data && t.width && t.height) ft->valid = false;
  // R32F: a NaN texel is invalid (only within the texels the texture covers).
  if (format == SOMM_TEXEL_R32F && ft->valid)
    for (uint32_t y = 0; y < t.height; ++y)
      for (uint32_t x = 0; x < t.width; ++x) {
        float a;
        std::memcpy(&a, ft->block.data() + size_t(y) * pitch + size_t(x) * 4, 4);
        if (std::isnan(a)) ft->valid = false;
      }
  return ft;
}

// The progress callback: returns non-zero (cancel) from call number cancelAfter on. Every call is recorded.
int progressCalls = 0;
int cancelAfter = -1;  // < 0: never
int firstCancel = -1;  // the call that first returned non-zero
double lastFraction = 0;
int progress(double f, void* user) {
  check(user == &progressCalls, "progress: wrong user pointer");
  check(f >= 0.0 && f <= 1.0, "progress fraction outside [0, 1]");
  check(f >= lastFraction, "progress fraction decreased");
  lastFraction = f;
  const int call = progressCalls++;
  if (cancelAfter >= 0 && call >= cancelAfter) {
    if (firstCancel < 0) firstCancel = call;
    return 1;
  }
  return 0;
}

int32_t decodeIndex(const uint8_t* p, uint32_t width) {
  if (width == 2) {
    const uint16_t v = uint16_t(p[0] | p[1] << 8);
    return v >= 0xFFFCu ? int32_t(v) - 65536 : int32_t(v);
  }
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(p[i]) << (8 * i);
  return int32_t(v);
}
uint32_t getU32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// The state of micro-triangle i of the flat map at `offset` (VK_EXT_opacity_micromap packing), read by hand.
int flatState(const uint8_t* data, uint32_t offset, uint32_t format, uint32_t i) {
  const uint8_t* m = data + offset;
  if (format == SOMM_FORMAT_2_STATE) return (m[i >> 3] >> (i & 7u)) & 1;
  return (m[i >> 2] >> (2u * (i & 3u))) & 3;
}
uint64_t mapBytes(uint32_t level, uint32_t format) {
  const uint64_t bits = (uint64_t(1) << (2 * level)) * (format == SOMM_FORMAT_2_STATE ? 1 : 2);
  return bits < 8 ? 1 : (bits + 7) / 8;
}

// Every lookup of `a` against the flat buffers (data / records / indices as the caller holds them).
// `work` bounds the micro-triangles compared over one input.
void compareWithFlat(const somm_encoded_array* a, const uint8_t* data, const uint8_t* records,
                     const std::vector<int32_t>& indices, uint64_t& work) {
  check(somm_encoded_array_triangle_count(a) == indices.size(), "encoded triangle count differs from flat");
  for (uint32_t t = 0; t < indices.size(); ++t) {
    const int32_t i = indices[t];
    const int level = somm_encoded_array_level(a, t);
    if (i < 0) {
      check(level == 0, "special index with a level");
      const int s = -i - 1;  // −1..−4 → states 0..3
      check(somm_encoded_array_state(a, t, 0) == s, "special index state");
      check(somm_encoded_array_state_uv(a, t, 0.25f, 0.25f) == s, "special index state_uv");
      continue;
    }
    const uint8_t* r = records + 8 * size_t(i);
    const uint32_t offset = getU32(r), lv = uint32_t(r[4] | r[5] << 8), format = uint32_t(r[6] | r[7] << 8);
    check(level == int(lv), "encoded level differs from the record");
    const uint32_t n = somm::microTriangleCount(lv);
    check(somm_encoded_array_state(a, t, n) == -1, "state past the map is not -1");
    const uint32_t step = work + n <= (uint64_t(1) << 18) ? 1 : n / 61 + 1;
    for (uint32_t m = 0; m < n; m += step) {
      if (somm_encoded_array_state(a, t, m) != flatState(data, offset, format, m))
        fail("state differs from flat");
    }
    work += n / step;
    const float uvs[][2] = {{0.1f, 0.2f}, {0.0f, 0.0f}, {1.0f, 0.0f}, {0.0f, 1.0f}, {0.3333f, 0.3333f}};
    for (const auto& uv : uvs)
      if (somm_encoded_array_state_uv(a, t, uv[0], uv[1]) !=
          flatState(data, offset, format, somm::baryToIndex(uv[0], uv[1], lv)))
        fail("state_uv differs from flat");
  }
  check(somm_encoded_array_state(a, uint32_t(indices.size()), 0) == -1, "state of a triangle past the end");
  check(somm_encoded_array_level(a, uint32_t(indices.size())) == -1, "level of a triangle past the end");
}

// Serialize with a too-small buffer, then exactly; parse back; the two must answer alike and re-serialize equal.
void roundTrip(const somm_encoded_array* a, FuzzedDataProvider* in) {
  const uint64_t size = somm_encoded_array_serialized_size(a);
  check(size >= 20, "serialized size below the header");
  somm_error e;
  Block small{size_t(size - 1)};
  std::memset(small.data(), 0xAB, small.n);
  somm_result r = somm_encoded_array_serialize(a, small.data(), size - 1, &e);
  checkError(r, e);
  check(r == SOMM_ERROR_BUFFER_TOO_SMALL, "serialize into a too-small buffer");
  for (size_t i = 0; i < small.n; ++i) check(small.data()[i] == 0xAB, "a too-small buffer was written");
  Block exact{size_t(size)};
  r = somm_encoded_array_serialize(a, exact.data(), size, in && in->ConsumeBool() ? nullptr : &e);
  check(r == SOMM_OK, "serialize into an exact buffer");
  somm_encoded_array* b = nullptr;
  r = somm_encoded_array_parse(exact.data(), exact.n, &b, &e);
  checkError(r, e);
  if (r != SOMM_OK) fail("a serialized array does not parse:", e.message);
  check(somm_encoded_array_encoding(b) == somm_encoded_array_encoding(a), "encoding changed in a round trip");
  check(somm_encoded_array_serialized_size(b) == size, "size changed in a round trip");
  Block again{size_t(size)};
  check(somm_encoded_array_serialize(b, again.data(), size, &e) == SOMM_OK, "re-serialize");
  check(std::memcmp(again.data(), exact.data(), exact.n) == 0, "serialize(parse(serialize(a))) differs");
  const uint32_t n = somm_encoded_array_triangle_count(a);
  for (uint32_t t = 0; t < n && t < 64; ++t) {
    check(somm_encoded_array_level(a, t) == somm_encoded_array_level(b, t), "level changed in a round trip");
    const int level = somm_encoded_array_level(a, t);
    check(level >= 0 && level <= 12, "level out of range");
    const uint32_t last = somm::microTriangleCount(uint32_t(level)) - 1;
    for (uint32_t m : {0u, last / 2, last}) {
      const int s = somm_encoded_array_state(a, t, m);
      check(s >= 0 && s <= 3, "state out of range");
      check(somm_encoded_array_state(b, t, m) == s, "state changed in a round trip");
    }
    for (float u : {0.0f, 0.3f, 1.0f, -1.0f, std::numeric_limits<float>::quiet_NaN()}) {
      const int s = somm_encoded_array_state_uv(a, t, u, 0.25f);
      check(s >= 0 && s <= 3, "state_uv out of range");
      check(somm_encoded_array_state_uv(b, t, u, 0.25f) == s, "state_uv changed in a round trip");
    }
  }
  somm_encoded_array_destroy(b);
}

// ---- mode 0: bake ----

void bakeCase(FuzzedDataProvider& in) {
  bool valid = true, ok = true;
  somm_bake_options o = somm_bake_options_default();
  o.threads = 1;
  {
    // Levels: 0..7 valid (work bounded), 13..15 invalid.
    const uint8_t l = in.ConsumeIntegral<uint8_t>() & 15u;
    o.level = l <= 7 ? l : l <= 12 ? l - 8 : l;
    const uint8_t ml = in.ConsumeIntegral<uint8_t>() & 15u;
    o.max_level = ml <= 7 ? ml : ml <= 12 ? ml - 8 : ml;
    const uint8_t adaptive = in.ConsumeIntegral<uint8_t>();
    if (adaptive < 128)
      o.texels_per_micro_triangle = 0;
    else if (adaptive < 240)
      o.texels_per_micro_triangle = float(adaptive & 15u) / 4.0f + 0.25f;
    else
      o.texels_per_micro_triangle = pickFloat(in);
    if (!(o.texels_per_micro_triangle >= 0.0f) || !std::isfinite(o.texels_per_micro_triangle)) valid = false;
    if (o.level > 12 || o.max_level > 12) valid = false;
  }
  pickEnum(in, {SOMM_FORMAT_2_STATE, SOMM_FORMAT_4_STATE}, ok, o.format);
  valid &= ok;
  pickEnum(in, {SOMM_UNKNOWN_AS_MAJORITY, SOMM_UNKNOWN_AS_OPAQUE, SOMM_UNKNOWN_AS_TRANSPARENT}, ok,
           o.unknown_as);
  valid &= ok;
  const int blend = pickEnum(in, {SOMM_BLEND_UNKNOWN, SOMM_BLEND_AS_MASK}, ok, o.blend);
  valid &= ok;
  pickEnum(in, {SOMM_ARRAY_PER_SCENE, SOMM_ARRAY_PER_GEOMETRY}, ok, o.layout);
  valid &= ok;
  const uint8_t budget = in.ConsumeIntegral<uint8_t>();
  o.max_bytes =
      budget < 160 ? 0 : uint64_t(budget - 159) * uint64_t(in.ConsumeIntegralInRange<uint8_t>(1, 8));
  const uint8_t prog = in.ConsumeIntegral<uint8_t>();
  progressCalls = 0;
  lastFraction = 0;
  firstCancel = -1;
  cancelAfter = -1;
  if (prog >= 128) {
    o.progress = progress;
    o.progress_user = &progressCalls;
    if (prog >= 200) cancelAfter = prog & 3;
  }

  // Textures, materials, geometries.
  std::vector<std::unique_ptr<FuzzTexture>> textures(in.ConsumeIntegralInRange<size_t>(0, 2));
  for (auto& t : textures) t = makeTexture(in);
  const uint32_t materialCount = in.ConsumeIntegralInRange<uint32_t>(0, 3);
  std::vector<somm_material> materials(materialCount);
  std::vector<bool> materialNeedsUvs(materialCount);
  for (uint32_t m = 0; m < materialCount; ++m) {
    somm_material& mat = materials[m];
    mat = somm_material_default();
    const int mode = pickEnum(in, {SOMM_ALPHA_MASK, SOMM_ALPHA_OPAQUE, SOMM_ALPHA_BLEND}, ok, mat.alpha_mode);
    const bool modeOk = ok;
    valid &= ok;
    const uint8_t c = in.ConsumeIntegral<uint8_t>();
    mat.cutoff = c < 200 ? float(c) / 199.0f : pickFloat(in);
    if (!inUnit(mat.cutoff)) valid = false;
    pickEnum(in, {SOMM_FILTER_LINEAR, SOMM_FILTER_NEAREST}, ok, mat.sampler.filter);
    valid &= ok;
    pickEnum(in, {SOMM_WRAP_REPEAT, SOMM_WRAP_CLAMP_TO_EDGE, SOMM_WRAP_MIRRORED_REPEAT}, ok,
             mat.sampler.wrap_s);
    valid &= ok;
    pickEnum(in, {SOMM_WRAP_REPEAT, SOMM_WRAP_CLAMP_TO_EDGE, SOMM_WRAP_MIRRORED_REPEAT}, ok,
             mat.sampler.wrap_t);
    valid &= ok;
    const uint8_t tsel = in.ConsumeIntegral<uint8_t>();
    mat.texture = textures.empty() || tsel < 64 ? nullptr : &textures[tsel % textures.size()]->t;
    const uint8_t ca = in.ConsumeIntegral<uint8_t>();
    mat.constant_alpha = ca < 230 ? float(ca) / 229.0f : pickFloat(in);
    const bool opaque = mode == SOMM_ALPHA_OPAQUE;
    if (modeOk && !opaque) {
      if (mat.texture) {
        for (const auto& t : textures)
          if (&t->t == mat.texture && !t->valid) valid = false;
      } else if (!inUnit(mat.constant_alpha)) {
        valid = false;
      }
    }
    materialNeedsUvs[m] =
        mat.texture && modeOk && !opaque && (mode != SOMM_ALPHA_BLEND || blend == SOMM_BLEND_AS_MASK);
  }

  struct FuzzGeometry {
    Block uvs, indices;
  };
  const uint32_t geometryCount = in.ConsumeIntegralInRange<uint32_t>(0, 4);
  std::vector<somm_geometry> geometries(geometryCount);
  std::vector<FuzzGeometry> blocks(geometryCount);
  for (uint32_t g = 0; g < geometryCount; ++g) {
    somm_geometry& geo = geometries[g];
    geo = somm_geometry_default();
    geo.material = in.ConsumeIntegralInRange<uint32_t>(0, materialCount);  // == count: invalid
    if (in.ConsumeIntegral<uint8_t>() >= 250) geo.material = 0x7fffffffu;
    const bool materialOk = geo.material < materialCount;
    if (!materialOk) valid = false;
    geo.vertex_count = in.ConsumeIntegralInRange<uint32_t>(0, 12);
    geo.triangle_count = in.ConsumeIntegralInRange<uint32_t>(0, 8);
    const int indexType =
        pickEnum(in, {SOMM_INDEX_UINT16, SOMM_INDEX_UINT32, SOMM_INDEX_NONE}, ok, geo.index_type);
    const bool typeOk = ok;
    valid &= ok;
    const uint32_t n = geo.triangle_count, v = geo.vertex_count;
    if (indexType == SOMM_INDEX_NONE) {
      if (uint64_t(v) < 3ull * n) valid = false;
      geo.indices = nullptr;
    } else if (typeOk) {
      const uint32_t w = uint32_t(indexType);
      blocks[g].indices = Block(size_t(3) * n * w);
      for (uint32_t i = 0; i < 3 * n; ++i) {
        // Mostly in range, sometimes == vertex_count or far out.
        const uint8_t b = in.ConsumeIntegral<uint8_t>();
        uint32_t x = b < 250 ? b % (v + 1) : (w == 2 ? 0xFFFFu : 0x80000000u);
        if (b < 250 && x == v && (b & 1u)) x = v ? v - 1 : 0;
        if (x >= v) valid = false;
        for (uint32_t k = 0; k < w; ++k) blocks[g].indices.data()[i * w + k] = uint8_t(x >> (8 * k));
      }
      geo.indices = in.ConsumeIntegral<uint8_t>() >= 250 ? nullptr : blocks[g].indices.data();
      if (!geo.indices && n) valid = false;
    }
    const uint8_t strideSel = in.ConsumeIntegral<uint8_t>();
    geo.uv_stride = strideSel < 100   ? 0
                    : strideSel < 150 ? 8
                    : strideSel < 200 ? 12
                    : strideSel < 245 ? 20
                                      : 4;
    const size_t stride = geo.uv_stride ? geo.uv_stride : 8;
    const bool needUvs = materialOk && materialNeedsUvs[geo.material];
    if (needUvs && stride < 8) valid = false;
    if (stride >= 8 && v) {
      blocks[g].uvs = Block((v - 1) * stride + 8);
      for (uint32_t i = 0; i < v; ++i) {
        float uv[2];
        for (float& c : uv) {
          const uint8_t b = in.ConsumeIntegral<uint8_t>();
          c = b < 240 ? float(int(b) - 40) / 100.0f : pickFloat(in);
        }
        std::memcpy(blocks[g].uvs.data() + i * stride, uv, 8);
      }
      geo.uvs = reinterpret_cast<const float*>(blocks[g].uvs.data());
    }
    if (in.ConsumeIntegral<uint8_t>() >= 250) geo.uvs = nullptr;
    if (needUvs && v && !geo.uvs) valid = false;
  }

  somm_bake_input input;
  input.geometries = geometries.data();
  input.geometry_count = geometryCount;
  input.materials = materials.data();
  input.material_count = materialCount;
  if (in.ConsumeIntegral<uint8_t>() >= 252) {
    input.geometries = nullptr;
    if (geometryCount) valid = false;
  }

  somm_error e;
  somm_bake_result* result = reinterpret_cast<somm_bake_result*>(&e);  // must be overwritten
  const somm_result r = somm_bake(&input, &o, &result, &e);
  checkError(r, e);
  if (r != SOMM_OK) check(result == nullptr, "failed bake left a result");
  if (!valid) {
    if (r != SOMM_ERROR_INVALID_ARGUMENT)
      fail("invalid input not refused with SOMM_ERROR_INVALID_ARGUMENT:", r == SOMM_OK ? "(ok)" : e.message);
    return;
  }
  // Cancellation: the bake stops at the first non-zero return (no call after it), except that the last call (1,
  // once the work is done) cannot cancel any more.
  if (r == SOMM_ERROR_CANCELLED) {
    check(firstCancel >= 0, "cancelled without the callback asking");
    check(firstCancel == progressCalls - 1, "progress called again after cancelling");
    return;
  }
  if (r != SOMM_OK) fail("a valid bake failed:", e.message);
  check(firstCancel < 0 || firstCancel == progressCalls - 1, "the callback cancelled but the bake went on");
  if (o.progress) check(lastFraction == 1.0, "progress did not end at 1");

  // Queries on the result.
  check(somm_bake_result_geometry_count(result) == geometryCount, "geometry count");
  check(somm_bake_result_format(result) == o.format, "format");
  const uint32_t cap = somm_bake_result_level_cap(result);
  check(cap <= 12, "level cap");
  if (o.max_bytes == 0) check(cap == 12, "a level cap without a budget");
  const uint32_t arrays = somm_bake_result_array_count(result);
  if (o.layout == SOMM_ARRAY_PER_GEOMETRY) check(arrays == geometryCount, "per-geometry layout: array count");
  somm_array_info ai;
  check(somm_bake_result_array_info(result, arrays, &ai, &e) == SOMM_ERROR_INVALID_ARGUMENT,
        "array past end");
  checkError(SOMM_ERROR_INVALID_ARGUMENT, e);
  check(somm_bake_result_array_info(result, 0, nullptr, nullptr) == SOMM_ERROR_INVALID_ARGUMENT, "NULL info");
  somm_geometry_info gi;
  check(somm_bake_result_geometry_info(result, geometryCount, &gi, &e) == SOMM_ERROR_INVALID_ARGUMENT,
        "geometry past end");
  check(somm_bake_result_copy_array(result, 0, nullptr, &e) != SOMM_OK, "NULL array buffers");
  check(somm_bake_result_copy_geometry(result, 0, nullptr, &e) != SOMM_OK, "NULL geometry buffers");

  struct ArrayCopy {
    somm_array_info info;
    Block data, records;
    std::vector<somm_usage_count> usage;
  };
  std::vector<ArrayCopy> copies(arrays);
  uint64_t totalData = 0, geometriesInArrays = 0;
  for (uint32_t a = 0; a < arrays; ++a) {
    ArrayCopy& c = copies[a];
    check(somm_bake_result_array_info(result, a, &c.info, &e) == SOMM_OK, "array_info");
    checkError(SOMM_OK, e);
    totalData += c.info.data_size;
    geometriesInArrays += c.info.geometry_count;
    c.data = Block(size_t(c.info.data_size));
    c.records = Block(size_t(c.info.triangle_count) * 8);
    c.usage.assign(c.info.usage_count_count + 1, somm_usage_count{0xAB, 0xAB, 0xAB});
    // Each buffer too small by one (the others exact): refused, nothing written.
    for (int which = 0; which < 3; ++which) {
      somm_array_buffers b;
      std::memset(&b, 0, sizeof b);
      b.data = c.data.data();
      b.data_capacity = c.info.data_size;
      b.triangles = c.records.data();
      b.triangles_capacity = c.records.n;
      b.usage_counts = c.usage.data();
      b.usage_counts_capacity = c.info.usage_count_count;
      if (which == 0) {
        if (c.info.data_size == 0) continue;
        b.data_capacity -= 1;
      } else if (which == 1) {
        if (c.records.n == 0) continue;
        b.triangles_capacity -= 1;
      } else {
        if (c.info.usage_count_count == 0) continue;
        b.usage_counts_capacity -= 1;
      }
      std::memset(c.data.data(), 0xAB, c.data.n);
      std::memset(c.records.data(), 0xAB, c.records.n);
      const somm_result rr = somm_bake_result_copy_array(result, a, &b, &e);
      checkError(rr, e);
      check(rr == SOMM_ERROR_BUFFER_TOO_SMALL, "copy_array into a too-small buffer");
      for (size_t i = 0; i < c.data.n; ++i) check(c.data.data()[i] == 0xAB, "too-small copy wrote data");
      for (size_t i = 0; i < c.records.n; ++i)
        check(c.records.data()[i] == 0xAB, "too-small copy wrote records");
      for (const somm_usage_count& u : c.usage) check(u.count == 0xAB, "too-small copy wrote usage counts");
    }
    somm_array_buffers b;
    b.data = c.data.n ? c.data.data() : nullptr;
    b.data_capacity = c.info.data_size;
    b.triangles = c.records.n ? c.records.data() : nullptr;
    b.triangles_capacity = c.records.n;
    b.usage_counts = c.usage.data();
    b.usage_counts_capacity = c.info.usage_count_count;
    check(somm_bake_result_copy_array(result, a, &b, &e) == SOMM_OK, "copy_array into exact buffers",
          e.message);
    check(c.usage.back().count == 0xAB, "copy_array wrote past usage_count_count");
    c.usage.pop_back();
    uint64_t maps = 0;
    for (const somm_usage_count& u : c.usage) {
      check(u.format == uint32_t(o.format), "usage count format");
      check(u.subdivision_level <= 12, "usage count level");
      maps += u.count;
    }
    check(maps == c.info.triangle_count, "array usage counts do not add up to its records");
    for (uint32_t d = 0; d < c.info.triangle_count; ++d) {
      const uint8_t* rec = c.records.data() + 8 * size_t(d);
      const uint32_t level = uint32_t(rec[4] | rec[5] << 8), format = uint32_t(rec[6] | rec[7] << 8);
      check(format == uint32_t(o.format), "record format");
      check(level <= cap, "record level above the cap");
      check(level <= (o.texels_per_micro_triangle > 0 ? o.max_level : o.level),
            "record level above the option");
      check(getU32(rec) + mapBytes(level, format) <= c.info.data_size, "record points past the data");
    }
  }
  check(geometriesInArrays == geometryCount, "arrays' geometry counts do not add up");
  if (o.max_bytes) check(totalData <= o.max_bytes, "data above max_bytes");

  uint64_t work = 0;
  for (uint32_t g = 0; g < geometryCount; ++g) {
    check(somm_bake_result_geometry_info(result, g, &gi, &e) == SOMM_OK, "geometry_info");
    check(gi.array < arrays, "geometry's array out of range");
    check(gi.triangle_count == geometries[g].triangle_count, "geometry triangle count");
    check(gi.index_type == SOMM_INDEX_UINT16 || gi.index_type == SOMM_INDEX_UINT32, "geometry index type");
    check(gi.index_size == uint64_t(gi.triangle_count) * uint32_t(gi.index_type), "geometry index size");
    Block idx{size_t(gi.index_size)};
    std::vector<somm_usage_count> usage(gi.usage_count_count + 1, somm_usage_count{0xAB, 0xAB, 0xAB});
    somm_geometry_buffers b;
    b.indices = idx.data();
    b.indices_capacity = gi.index_size;
    b.usage_counts = usage.data();
    b.usage_counts_capacity = gi.usage_count_count;
    if (gi.index_size) {
      b.indices_capacity = gi.index_size - 1;
      std::memset(idx.data(), 0xAB, idx.n);
      check(somm_bake_result_copy_geometry(result, g, &b, &e) == SOMM_ERROR_BUFFER_TOO_SMALL,
            "copy_geometry into a too-small index buffer");
      for (size_t i = 0; i < idx.n; ++i) check(idx.data()[i] == 0xAB, "too-small copy wrote indices");
      b.indices_capacity = gi.index_size;
    }
    if (gi.usage_count_count) {
      b.usage_counts_capacity = gi.usage_count_count - 1;
      check(somm_bake_result_copy_geometry(result, g, &b, &e) == SOMM_ERROR_BUFFER_TOO_SMALL,
            "copy_geometry into a too-small usage buffer");
      b.usage_counts_capacity = gi.usage_count_count;
    }
    check(somm_bake_result_copy_geometry(result, g, &b, nullptr) == SOMM_OK,
          "copy_geometry into exact buffers");
    check(usage.back().count == 0xAB, "copy_geometry wrote past usage_count_count");
    usage.pop_back();
    const ArrayCopy& c = copies[gi.array];
    std::vector<int32_t> indices(gi.triangle_count);
    uint64_t special[4] = {0, 0, 0, 0}, mapped = 0, usageTotal = 0;
    for (uint32_t t = 0; t < gi.triangle_count; ++t) {
      const int32_t i =
          decodeIndex(idx.data() + size_t(t) * uint32_t(gi.index_type), uint32_t(gi.index_type));
      indices[t] = i;
      if (i < 0) {
        check(i >= -4, "index below the special indices");
        ++special[-i - 1];
      } else {
        check(uint32_t(i) < c.info.triangle_count, "index past the array's records");
        ++mapped;
      }
    }
    for (int s = 0; s < 4; ++s)
      check(special[s] == gi.special_count[s], "special counts differ from the indices");
    for (const somm_usage_count& u : usage) usageTotal += u.count;
    check(usageTotal == mapped, "geometry usage counts do not add up to its mapped triangles");

    // The copied buffers through every C API encoding: each must answer like the flat data.
    somm_flat_array f = somm_flat_array_default();
    f.data = c.data.n ? c.data.data() : nullptr;
    f.data_size = c.info.data_size;
    f.triangles = c.records.n ? c.records.data() : nullptr;
    f.triangle_count = c.info.triangle_count;
    f.indices = idx.n ? idx.data() : nullptr;
    f.index_type = gi.index_type;
    f.index_count = gi.triangle_count;
    for (int enc = SOMM_ENCODING_FLAT; enc <= SOMM_ENCODING_SDAG; ++enc) {
      somm_encoded_array* a = nullptr;
      const somm_result br = somm_encoded_array_build(&f, somm_encoding(enc), &a, &e);
      checkError(br, e);
      if (br != SOMM_OK) fail("baked buffers do not build:", e.message);
      check(somm_encoded_array_encoding(a) == enc, "built encoding");
      compareWithFlat(a, c.data.data(), c.records.data(), indices, work);
      if (enc == SOMM_ENCODING_FLAT || in.ConsumeBool()) roundTrip(a, &in);
      somm_encoded_array_destroy(a);
    }
  }
  somm_bake_result_destroy(result);
}

// ---- mode 1: parse arbitrary bytes ----

void parseCase(FuzzedDataProvider& in) {
  const std::vector<uint8_t> rest = in.ConsumeRemainingBytes<uint8_t>();
  Block bytes{rest.size()};
  if (!rest.empty()) std::memcpy(bytes.data(), rest.data(), rest.size());
  somm_encoded_array* a = reinterpret_cast<somm_encoded_array*>(bytes.data());
  somm_error e;
  const somm_result r = somm_encoded_array_parse(bytes.data(), bytes.n, &a, &e);
  checkError(r, e);
  if (r != SOMM_OK) {
    check(a == nullptr, "failed parse left an array");
    check(r == SOMM_ERROR_CORRUPT || r == SOMM_ERROR_UNSUPPORTED || r == SOMM_ERROR_LIMIT_EXCEEDED,
          "parse error code", e.message);
    return;
  }
  check(uint32_t(somm_encoded_array_encoding(a)) <= 6, "parsed encoding out of range");
  roundTrip(a, nullptr);
  somm_encoded_array_destroy(a);
}

// ---- mode 2: build from arbitrary flat buffers ----

void buildCase(FuzzedDataProvider& in) {
  bool valid = true, ok = true;
  somm_encoding enc;  // written by pickEnum, never read
  const int encoding =
      pickEnum(in,
               {SOMM_ENCODING_FLAT, SOMM_ENCODING_DFS, SOMM_ENCODING_DFS_FAST, SOMM_ENCODING_RANK,
                SOMM_ENCODING_HYBRID, SOMM_ENCODING_CSM, SOMM_ENCODING_SDAG},
               ok, enc);
  valid &= ok;
  somm_flat_array f = somm_flat_array_default();
  const int indexType = pickEnum(in, {SOMM_INDEX_UINT32, SOMM_INDEX_UINT16}, ok, f.index_type);
  valid &= ok;
  Block data{in.ConsumeIntegralInRange<size_t>(0, 1100)};
  fill(in, data);
  const uint32_t records = in.ConsumeIntegralInRange<uint32_t>(0, 6);
  Block rec{size_t(records) * 8};
  for (uint32_t d = 0; d < records; ++d) {
    uint8_t* r = rec.data() + 8 * size_t(d);
    const uint8_t lb = in.ConsumeIntegral<uint8_t>();
    const uint32_t level = lb < 240 ? lb % 6 : lb % 16;  // 13..15: invalid
    const uint8_t fb = in.ConsumeIntegral<uint8_t>();
    const uint32_t format = fb < 240 ? 1 + fb % 2 : fb % 4;
    const uint32_t offset = in.ConsumeIntegral<uint8_t>() < 240
                                ? in.ConsumeIntegralInRange<uint32_t>(0, uint32_t(data.n))
                                : in.ConsumeIntegral<uint32_t>();
    for (int k = 0; k < 4; ++k) r[k] = uint8_t(offset >> (8 * k));
    r[4] = uint8_t(level), r[5] = 0, r[6] = uint8_t(format), r[7] = 0;
    if (level > 12 || (format != 1 && format != 2) || uint64_t(offset) + mapBytes(level, format) > data.n)
      valid = false;
  }
  const uint32_t count = in.ConsumeIntegralInRange<uint32_t>(0, 10);
  const uint32_t w = indexType == SOMM_INDEX_UINT16 ? 2 : 4;
  Block idx{size_t(count) * w};
  std::vector<int32_t> indices(count);
  for (uint32_t t = 0; t < count; ++t) {
    const uint8_t b = in.ConsumeIntegral<uint8_t>();
    int32_t i = b < 200   ? int32_t(b % (records + 1))
                : b < 250 ? -1 - int32_t(b % 4)
                : b < 253 ? -5
                          : 0x7fffffff;
    if (w == 2 && (i < -4 || i > 0xFFFB)) i = 0xFFF0;  // a 16-bit value neither special nor (here) a record
    if (i >= int32_t(records) || i < -4) valid = false;
    indices[t] = i;
    for (uint32_t k = 0; k < w; ++k) idx.data()[t * w + k] = uint8_t(uint32_t(i) >> (8 * k));
  }
  f.data = data.data();
  f.data_size = data.n;
  f.triangles = rec.data();
  f.triangle_count = records;
  f.indices = idx.data();
  f.index_count = count;
  const uint8_t nulls = in.ConsumeIntegral<uint8_t>();
  if (nulls >= 250) {
    if (nulls & 1u) {
      f.data = nullptr;
      if (data.n) valid = false;
    } else {
      f.indices = nullptr;
      if (count) valid = false;
    }
  }
  somm_encoded_array* a = reinterpret_cast<somm_encoded_array*>(&f);
  somm_error e;
  const somm_result r = somm_encoded_array_build(&f, somm_encoding(encoding), &a, &e);
  checkError(r, e);
  if (!valid) {
    check(r != SOMM_OK, "invalid flat buffers were accepted");
    check(r == SOMM_ERROR_INVALID_ARGUMENT, "invalid flat buffers: not SOMM_ERROR_INVALID_ARGUMENT",
          e.message);
    check(a == nullptr, "failed build left an array");
    return;
  }
  if (r != SOMM_OK) fail("valid flat buffers were refused:", e.message);
  check(int(somm_encoded_array_encoding(a)) == encoding, "built encoding");
  uint64_t work = 0;
  compareWithFlat(a, data.data(), rec.data(), indices, work);
  roundTrip(a, &in);
  somm_encoded_array_destroy(a);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  switch (in.ConsumeIntegral<uint8_t>() % 3) {
    case 0:
      bakeCase(in);
      break;
    case 1:
      parseCase(in);
      break;
    default:
      buildCase(in);
      break;
  }
  return 0;
}
