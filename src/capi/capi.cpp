// SPDX-License-Identifier: MIT
// The C API (include/somm/somm.h). Every entry point catches everything: no exception crosses the API.
#include <cstdio>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "bake_views.h"
#include "somm/encode.h"
#include "somm/omm_array.h"
#include "somm/somm.h"

struct somm_bake_result {
  somm::capi::SceneBake bake;
  std::vector<std::vector<somm::UsageCount>> geometryUsage;
};

struct somm_encoded_array {
  somm::EncodedArray array;
};

namespace {

somm_result codeOf(somm::ErrorCode c) {
  switch (c) {
    case somm::ErrorCode::InvalidArgument:
      return SOMM_ERROR_INVALID_ARGUMENT;
    case somm::ErrorCode::ParseError:
      return SOMM_ERROR_PARSE;
    case somm::ErrorCode::IoError:
      return SOMM_ERROR_IO;
    case somm::ErrorCode::CorruptFile:
      return SOMM_ERROR_CORRUPT;
    case somm::ErrorCode::UnsupportedFormat:
      return SOMM_ERROR_UNSUPPORTED;
    case somm::ErrorCode::LimitExceeded:
      return SOMM_ERROR_LIMIT_EXCEEDED;
    case somm::ErrorCode::Cancelled:
      return SOMM_ERROR_CANCELLED;
  }
  return SOMM_ERROR_INTERNAL;
}

somm_result fail(somm_error* e, somm_result code, const char* message) noexcept {
  if (e) {
    e->code = code;
    std::snprintf(e->message, sizeof e->message, "%s", message);
  }
  return code;
}
somm_result fail(somm_error* e, somm_result code, const std::string& message) noexcept {
  return fail(e, code, message.c_str());
}
somm_result fail(somm_error* e, const somm::Error& err) noexcept {
  return fail(e, codeOf(err.code), err.message);
}
somm_result ok(somm_error* e) noexcept {
  if (e) {
    e->code = SOMM_OK;
    e->message[0] = '\0';
  }
  return SOMM_OK;
}

// Runs f() (returning somm_result) with every exception turned into an error code.
template <class F>
somm_result guarded(somm_error* e, F&& f) noexcept {
  try {
    return f();
  } catch (const somm::capi::Cancelled&) {
    return fail(e, SOMM_ERROR_CANCELLED, "cancelled by the progress callback");
  } catch (const std::bad_alloc&) {
    return fail(e, SOMM_ERROR_OUT_OF_MEMORY, "out of memory");
  } catch (const std::exception& x) {
    return fail(e, SOMM_ERROR_INTERNAL, std::string("internal error: ") + x.what());
  } catch (...) {
    return fail(e, SOMM_ERROR_INTERNAL, "internal error");
  }
}

void putU32(unsigned char* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = (unsigned char)(v >> (8 * i));
}
uint32_t getU32(const unsigned char* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
uint16_t getU16(const unsigned char* p) {
  return uint16_t(p[0] | p[1] << 8);
}

somm_result tooSmall(somm_error* e, const char* what, uint64_t need, uint64_t have) {
  return fail(e, SOMM_ERROR_BUFFER_TOO_SMALL,
              std::string(what) + " capacity " + std::to_string(have) + " is less than the " +
                  std::to_string(need) + " needed");
}

// A geometry's own index type: 16-bit when every non-special index fits below the special values (as `somm export`).
somm_index_type indexTypeOf(const somm::SceneMicromaps& m, uint32_t g) {
  const int32_t* idx = m.indices(g);
  for (uint32_t t = 0; t < m.geometries[g].triangleCount; ++t)
    if (!somm::isSpecialIndex(idx[t]) && uint32_t(idx[t]) > 0xfffbu) return SOMM_INDEX_UINT32;
  return SOMM_INDEX_UINT16;
}

void copyUsage(const std::vector<somm::UsageCount>& h, somm_usage_count* dst) {
  for (size_t i = 0; i < h.size(); ++i)
    dst[i] = somm_usage_count{h[i].count, h[i].subdivisionLevel, h[i].format};
}

}  // namespace

extern "C" {

const char* somm_version(void) {
  return SOMM_VERSION_STRING;
}

const char* somm_result_name(somm_result r) {
  switch (r) {
    case SOMM_OK:
      return "ok";
    case SOMM_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case SOMM_ERROR_PARSE:
      return "parse error";
    case SOMM_ERROR_IO:
      return "I/O error";
    case SOMM_ERROR_CORRUPT:
      return "corrupt data";
    case SOMM_ERROR_UNSUPPORTED:
      return "unsupported";
    case SOMM_ERROR_LIMIT_EXCEEDED:
      return "limit exceeded";
    case SOMM_ERROR_BUFFER_TOO_SMALL:
      return "buffer too small";
    case SOMM_ERROR_CANCELLED:
      return "cancelled";
    case SOMM_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case SOMM_ERROR_INTERNAL:
      return "internal error";
  }
  return "unknown result";
}

somm_texture somm_texture_default(void) {
  somm_texture t;
  std::memset(&t, 0, sizeof t);
  t.format = SOMM_TEXEL_RGBA8;
  t.alpha_channel = 3;
  return t;
}

somm_sampler somm_sampler_default(void) {
  somm_sampler s;
  s.filter = SOMM_FILTER_LINEAR;
  s.wrap_s = SOMM_WRAP_REPEAT;
  s.wrap_t = SOMM_WRAP_REPEAT;
  return s;
}

somm_material somm_material_default(void) {
  somm_material m;
  std::memset(&m, 0, sizeof m);
  m.alpha_mode = SOMM_ALPHA_MASK;
  m.cutoff = 0.5f;
  m.texture = nullptr;
  m.constant_alpha = 1.0f;
  m.sampler = somm_sampler_default();
  return m;
}

somm_geometry somm_geometry_default(void) {
  somm_geometry g;
  std::memset(&g, 0, sizeof g);
  g.uvs = nullptr;
  g.indices = nullptr;
  g.index_type = SOMM_INDEX_UINT32;
  return g;
}

somm_bake_options somm_bake_options_default(void) {
  somm_bake_options o;
  std::memset(&o, 0, sizeof o);
  o.level = 6;
  o.max_level = 0;
  o.texels_per_micro_triangle = 0.0f;
  o.format = SOMM_FORMAT_4_STATE;
  o.unknown_as = SOMM_UNKNOWN_AS_MAJORITY;
  o.max_bytes = 0;
  o.blend = SOMM_BLEND_UNKNOWN;
  o.layout = SOMM_ARRAY_PER_SCENE;
  o.threads = 0;
  o.progress = nullptr;
  o.progress_user = nullptr;
  return o;
}

somm_flat_array somm_flat_array_default(void) {
  somm_flat_array f;
  std::memset(&f, 0, sizeof f);
  f.data = f.triangles = f.indices = nullptr;
  f.index_type = SOMM_INDEX_UINT32;
  return f;
}

somm_result somm_bake(const somm_bake_input* input, const somm_bake_options* options,
                      somm_bake_result** result, somm_error* error) {
  return guarded(error, [&]() -> somm_result {
    if (!result) return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_bake: result is NULL");
    *result = nullptr;
    if (!input) return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_bake: input is NULL");
    const somm_bake_options o = options ? *options : somm_bake_options_default();
    auto baked = somm::capi::bakeFromViews(*input, o);
    if (!baked) return fail(error, baked.error());
    auto* r = new somm_bake_result{std::move(*baked), {}};
    const uint32_t n = uint32_t(r->bake.micromaps.geometries.size());
    r->geometryUsage.reserve(n);
    for (uint32_t g = 0; g < n; ++g) r->geometryUsage.push_back(r->bake.micromaps.triangleHistogram(g));
    *result = r;
    return ok(error);
  });
}

void somm_bake_result_destroy(somm_bake_result* result) {
  delete result;
}

uint32_t somm_bake_result_array_count(const somm_bake_result* r) {
  return r ? uint32_t(r->bake.micromaps.arrays.size()) : 0;
}
uint32_t somm_bake_result_geometry_count(const somm_bake_result* r) {
  return r ? uint32_t(r->bake.micromaps.geometries.size()) : 0;
}
somm_format somm_bake_result_format(const somm_bake_result* r) {
  return r && r->bake.format == somm::Format::TwoState ? SOMM_FORMAT_2_STATE : SOMM_FORMAT_4_STATE;
}
uint32_t somm_bake_result_level_cap(const somm_bake_result* r) {
  return r ? r->bake.levelCap : 12;
}

somm_result somm_bake_result_array_info(const somm_bake_result* r, uint32_t array, somm_array_info* info,
                                        somm_error* error) {
  return guarded(error, [&]() -> somm_result {
    if (!r || !info)
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_bake_result_array_info: NULL argument");
    if (array >= r->bake.micromaps.arrays.size())
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT,
                  "array " + std::to_string(array) + " is out of range (" +
                      std::to_string(r->bake.micromaps.arrays.size()) + " arrays)");
    const somm::OmmArray& a = r->bake.micromaps.arrays[array];
    info->data_size = a.data.size();
    info->triangle_count = uint32_t(a.descriptors.size());
    info->usage_count_count = uint32_t(a.histogram.size());
    info->geometry_count = 0;
    for (const somm::GeometryMicromaps& g : r->bake.micromaps.geometries)
      info->geometry_count += g.array == array;
    return ok(error);
  });
}

somm_result somm_bake_result_copy_array(const somm_bake_result* r, uint32_t array,
                                        const somm_array_buffers* b, somm_error* error) {
  return guarded(error, [&]() -> somm_result {
    somm_array_info info;
    if (somm_result s = somm_bake_result_array_info(r, array, &info, error); s != SOMM_OK) return s;
    if (!b) return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_bake_result_copy_array: buffers is NULL");
    const somm::OmmArray& a = r->bake.micromaps.arrays[array];
    const uint64_t trianglesBytes = uint64_t(info.triangle_count) * 8;
    if (b->data && b->data_capacity < info.data_size)
      return tooSmall(error, "data", info.data_size, b->data_capacity);
    if (b->triangles && b->triangles_capacity < trianglesBytes)
      return tooSmall(error, "triangles", trianglesBytes, b->triangles_capacity);
    if (b->usage_counts && b->usage_counts_capacity < info.usage_count_count)
      return tooSmall(error, "usage_counts", info.usage_count_count, b->usage_counts_capacity);
    if (b->data && !a.data.empty()) std::memcpy(b->data, a.data.data(), a.data.size());
    if (b->triangles) {
      auto* p = static_cast<unsigned char*>(b->triangles);
      for (const somm::TriangleDescriptor& d : a.descriptors) {
        putU32(p, d.dataOffset);
        putU32(p + 4, uint32_t(d.subdivisionLevel) | uint32_t(d.format) << 16);
        p += 8;
      }
    }
    if (b->usage_counts) copyUsage(a.histogram, b->usage_counts);
    return ok(error);
  });
}

somm_result somm_bake_result_geometry_info(const somm_bake_result* r, uint32_t geometry,
                                           somm_geometry_info* info, somm_error* error) {
  return guarded(error, [&]() -> somm_result {
    if (!r || !info)
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_bake_result_geometry_info: NULL argument");
    if (geometry >= r->bake.micromaps.geometries.size())
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT,
                  "geometry " + std::to_string(geometry) + " is out of range (" +
                      std::to_string(r->bake.micromaps.geometries.size()) + " geometries)");
    const somm::GeometryMicromaps& gm = r->bake.micromaps.geometries[geometry];
    const somm::capi::GeometryBakeInfo& gi = r->bake.geometries[geometry];
    std::memset(info, 0, sizeof *info);
    info->array = gm.array;
    info->triangle_count = gm.triangleCount;
    info->index_type = indexTypeOf(r->bake.micromaps, geometry);
    info->index_size = uint64_t(gm.triangleCount) * uint64_t(info->index_type);
    info->usage_count_count = uint32_t(r->geometryUsage[geometry].size());
    for (int s = 0; s < 4; ++s) info->special_count[s] = gi.specialCount[size_t(s)];
    info->micro_triangles = gi.microTriangles;
    info->unknown_micro_triangles = gi.unknownMicroTriangles;
    info->non_finite_uv_triangles = gi.nonFiniteUvTriangles;
    info->min_level = gi.minLevel;
    info->max_level = gi.maxLevel;
    return ok(error);
  });
}

somm_result somm_bake_result_copy_geometry(const somm_bake_result* r, uint32_t geometry,
                                           const somm_geometry_buffers* b, somm_error* error) {
  return guarded(error, [&]() -> somm_result {
    somm_geometry_info info;
    if (somm_result s = somm_bake_result_geometry_info(r, geometry, &info, error); s != SOMM_OK) return s;
    if (!b)
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_bake_result_copy_geometry: buffers is NULL");
    if (b->indices && b->indices_capacity < info.index_size)
      return tooSmall(error, "indices", info.index_size, b->indices_capacity);
    if (b->usage_counts && b->usage_counts_capacity < info.usage_count_count)
      return tooSmall(error, "usage_counts", info.usage_count_count, b->usage_counts_capacity);
    if (b->indices) {
      const int32_t* idx = r->bake.micromaps.indices(geometry);
      const size_t w = size_t(info.index_type);
      auto* p = static_cast<unsigned char*>(b->indices);
      for (uint32_t t = 0; t < info.triangle_count; ++t)
        for (size_t k = 0; k < w; ++k) p[t * w + k] = (unsigned char)(uint32_t(idx[t]) >> (8 * k));
    }
    if (b->usage_counts) copyUsage(r->geometryUsage[geometry], b->usage_counts);
    return ok(error);
  });
}

// ---- encoded arrays ----

somm_result somm_encoded_array_build(const somm_flat_array* f, somm_encoding encoding,
                                     somm_encoded_array** out, somm_error* error) {
  return guarded(error, [&]() -> somm_result {
    if (!out) return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_encoded_array_build: array is NULL");
    *out = nullptr;
    if (!f) return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_encoded_array_build: flat is NULL");
    const int32_t enc = somm::capi::rawEnum(encoding), indexType = somm::capi::rawEnum(f->index_type);
    if (enc < 0 || enc > int32_t(SOMM_ENCODING_SDAG))
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT,
                  "encoding " + std::to_string(enc) + " is not a somm_encoding");
    if (indexType != SOMM_INDEX_UINT16 && indexType != SOMM_INDEX_UINT32)
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "flat.index_type must be SOMM_INDEX_UINT16 or _UINT32");
    if ((f->data_size && !f->data) || (f->triangle_count && !f->triangles) || (f->index_count && !f->indices))
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_encoded_array_build: a buffer pointer is NULL");
    somm::OmmArray a;
    const auto* d = static_cast<const unsigned char*>(f->data);
    a.data.assign(d, d + f->data_size);
    const auto* t = static_cast<const unsigned char*>(f->triangles);
    a.descriptors.resize(f->triangle_count);
    for (uint32_t i = 0; i < f->triangle_count; ++i) {
      a.descriptors[i].dataOffset = getU32(t + 8 * size_t(i));
      a.descriptors[i].subdivisionLevel = getU16(t + 8 * size_t(i) + 4);
      a.descriptors[i].format = getU16(t + 8 * size_t(i) + 6);
    }
    const auto* x = static_cast<const unsigned char*>(f->indices);
    a.indices.resize(f->index_count);
    for (uint32_t i = 0; i < f->index_count; ++i) {
      if (f->index_type == SOMM_INDEX_UINT16) {
        const uint16_t v = getU16(x + 2 * size_t(i));
        a.indices[i] = v >= 0xFFFCu ? int32_t(v) - 65536 : int32_t(v);  // special indices −1..−4 as 16 bits
      } else {
        a.indices[i] = int32_t(getU32(x + 4 * size_t(i)));
      }
    }
    somm::computeUsageHistograms(a);
    auto e = somm::EncodedArray::build(a, somm::Encoding(encoding));
    if (!e) return fail(error, e.error());
    *out = new somm_encoded_array{std::move(*e)};
    return ok(error);
  });
}

somm_result somm_encoded_array_parse(const void* bytes, size_t size, somm_encoded_array** out,
                                     somm_error* error) {
  return guarded(error, [&]() -> somm_result {
    if (!out) return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_encoded_array_parse: array is NULL");
    *out = nullptr;
    if (!bytes && size)
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_encoded_array_parse: bytes is NULL");
    static const uint8_t kEmpty = 0;
    const uint8_t* p = size ? static_cast<const uint8_t*>(bytes) : &kEmpty;
    auto e = somm::EncodedArray::parse(somm::Span<const uint8_t>(p, size), "encoded array");
    if (!e) return fail(error, e.error());
    *out = new somm_encoded_array{std::move(*e)};
    return ok(error);
  });
}

void somm_encoded_array_destroy(somm_encoded_array* a) {
  delete a;
}

somm_encoding somm_encoded_array_encoding(const somm_encoded_array* a) {
  return a ? somm_encoding(a->array.encoding()) : SOMM_ENCODING_FLAT;
}
uint32_t somm_encoded_array_triangle_count(const somm_encoded_array* a) {
  return a ? a->array.triangleCount() : 0;
}
uint32_t somm_encoded_array_map_count(const somm_encoded_array* a) {
  return a ? a->array.mapCount() : 0;
}
uint64_t somm_encoded_array_serialized_size(const somm_encoded_array* a) {
  return a ? a->array.byteSize() : 0;
}

somm_result somm_encoded_array_serialize(const somm_encoded_array* a, void* bytes, uint64_t capacity,
                                         somm_error* error) {
  return guarded(error, [&]() -> somm_result {
    if (!a || !bytes)
      return fail(error, SOMM_ERROR_INVALID_ARGUMENT, "somm_encoded_array_serialize: NULL argument");
    if (capacity < a->array.byteSize())
      return fail(error, SOMM_ERROR_BUFFER_TOO_SMALL,
                  "capacity " + std::to_string(capacity) + " is less than the " +
                      std::to_string(a->array.byteSize()) + " bytes needed");
    const std::vector<uint8_t> s = a->array.serialize();
    std::memcpy(bytes, s.data(), s.size());
    return ok(error);
  });
}

int somm_encoded_array_level(const somm_encoded_array* a, uint32_t triangle) {
  if (!a || triangle >= a->array.triangleCount()) return -1;
  const int32_t i = a->array.indices()[triangle];
  return i < 0 ? 0 : int(a->array.maps()[size_t(i)].level);
}

int somm_encoded_array_state(const somm_encoded_array* a, uint32_t triangle, uint32_t index) {
  const int level = somm_encoded_array_level(a, triangle);
  if (level < 0) return -1;
  const int32_t i = a->array.indices()[triangle];
  if (i >= 0 && index >= somm::microTriangleCount(uint32_t(level))) return -1;
  if (i < 0 && index != 0 && index >= somm::microTriangleCount(somm::kMaxLevel)) return -1;
  return int(a->array.state(triangle, index));
}

int somm_encoded_array_state_uv(const somm_encoded_array* a, uint32_t triangle, float u, float v) {
  if (!a || triangle >= a->array.triangleCount()) return -1;
  return int(a->array.stateUV(triangle, u, v));
}

}  // extern "C"
