// SPDX-License-Identifier: MIT
// Bad-input suite, the C API: enum fields holding values no enumerator has. A C caller may store any int in an
// enum object (a stale struct, a value from a newer header, -1 as "unset"); the library loaded such fields through
// the C++ enum type before checking them, which is undefined behaviour (UBSan in the sanitizer build: "load of value
// 100, which is not a valid value for type 'somm_texel_format'"). Every one must give SOMM_ERROR_INVALID_ARGUMENT
// with a message naming the field, in every build.
#if __has_include("somm/somm.h")
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "somm/somm.h"

namespace {

template <class E>
void store(E& field, int value) {
  static_assert(sizeof(E) == sizeof(int), "C API enums are int-sized");
  std::memcpy(&field, &value, sizeof value);
}

struct Quad {
  std::vector<uint8_t> texels = std::vector<uint8_t>(4 * 4 * 4, 255);
  float uvs[8] = {0, 0, 1, 0, 1, 1, 0, 1};
  uint32_t indices[6] = {0, 1, 2, 0, 2, 3};
  somm_texture texture = somm_texture_default();
  somm_material material = somm_material_default();
  somm_geometry geometry = somm_geometry_default();
  somm_bake_input input{};
  somm_bake_options options = somm_bake_options_default();
  Quad() {
    texture.data = texels.data();
    texture.size = texels.size();
    texture.width = texture.height = 4;
    material.texture = &texture;
    geometry.uvs = uvs;
    geometry.vertex_count = 4;
    geometry.indices = indices;
    geometry.triangle_count = 2;
    input.geometries = &geometry;
    input.geometry_count = 1;
    input.materials = &material;
    input.material_count = 1;
    options.level = 2;
    options.threads = 1;
  }
  somm_result bake(std::string& message) {
    somm_bake_result* r = nullptr;
    somm_error e;
    const somm_result code = somm_bake(&input, &options, &r, &e);
    message = e.message;
    somm_bake_result_destroy(r);
    return code;
  }
};

TEST(BadCapi, OutOfRangeEnumValuesAreInvalidArguments) {
  {
    Quad q;
    std::string m;
    ASSERT_EQ(q.bake(m), SOMM_OK) << m;
  }
  struct Case {
    const char* field;
    void (*set)(Quad&, int);
  };
  const Case cases[] = {
      {"texture.format", [](Quad& q, int v) { store(q.texture.format, v); }},
      {"alpha_mode", [](Quad& q, int v) { store(q.material.alpha_mode, v); }},
      {"sampler.filter", [](Quad& q, int v) { store(q.material.sampler.filter, v); }},
      {"wrap mode", [](Quad& q, int v) { store(q.material.sampler.wrap_s, v); }},
      {"wrap mode", [](Quad& q, int v) { store(q.material.sampler.wrap_t, v); }},
      {"index_type", [](Quad& q, int v) { store(q.geometry.index_type, v); }},
      {"options.format", [](Quad& q, int v) { store(q.options.format, v); }},
      {"options.unknown_as", [](Quad& q, int v) { store(q.options.unknown_as, v); }},
      {"options.blend", [](Quad& q, int v) { store(q.options.blend, v); }},
      {"options.layout", [](Quad& q, int v) { store(q.options.layout, v); }},
  };
  for (const Case& c : cases)
    for (int v : {100, -1, 0x7fffffff, int(0x80000000u)}) {
      SCOPED_TRACE(std::string(c.field) + " = " + std::to_string(v));
      Quad q;
      c.set(q, v);
      std::string m;
      EXPECT_EQ(q.bake(m), SOMM_ERROR_INVALID_ARGUMENT) << m;
      EXPECT_NE(m.find(c.field), std::string::npos) << m;
      EXPECT_NE(m.find(std::to_string(v)), std::string::npos) << m;
    }
  // somm_encoded_array_build: the encoding and the flat array's index type.
  const uint8_t data[1] = {0};
  const uint8_t record[8] = {0, 0, 0, 0, 0, 0, 2, 0};  // offset 0, level 0, 4-state
  const uint32_t index = 0;
  // (The encoding is passed by value: C++ can only pass values within the enumerators' range 0..7; a C caller
  // can pass any int, which the library reads as an int.)
  for (int v : {7}) {  // 5 and 6 are csm and sdag
    SCOPED_TRACE(v);
    somm_flat_array f = somm_flat_array_default();
    f.data = data;
    f.data_size = 1;
    f.triangles = record;
    f.triangle_count = 1;
    f.indices = &index;
    f.index_count = 1;
    somm_encoded_array* a = nullptr;
    somm_error e;
    EXPECT_EQ(somm_encoded_array_build(&f, somm_encoding(v), &a, &e), SOMM_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(a, nullptr);
    EXPECT_NE(std::string(e.message).find("encoding " + std::to_string(v)), std::string::npos) << e.message;
    for (int t : {3, 100, -1, 0x7fffffff}) {
      store(f.index_type, t);
      EXPECT_EQ(somm_encoded_array_build(&f, SOMM_ENCODING_FLAT, &a, &e), SOMM_ERROR_INVALID_ARGUMENT);
      EXPECT_NE(std::string(e.message).find("index_type"), std::string::npos) << e.message;
    }
    store(f.index_type, int(SOMM_INDEX_UINT32));
    ASSERT_EQ(somm_encoded_array_build(&f, SOMM_ENCODING_FLAT, &a, &e), SOMM_OK) << e.message;
    somm_encoded_array_destroy(a);
  }
}

// A huge triangle_count without indices and with few vertices is refused before anything is allocated (it
// allocated 3 · 2^32 indices first: SOMM_ERROR_OUT_OF_MEMORY, or tens of GB).
TEST(BadCapi, NonIndexedTriangleCountCheckedFirst) {
  Quad q;
  q.geometry.index_type = SOMM_INDEX_NONE;
  q.geometry.indices = nullptr;
  q.geometry.triangle_count = 0xFFFFFFFFu;
  std::string m;
  EXPECT_EQ(q.bake(m), SOMM_ERROR_INVALID_ARGUMENT) << m;
  EXPECT_NE(m.find("non-indexed triangles need"), std::string::npos) << m;
}

}  // namespace
#endif
