// SPDX-License-Identifier: MIT
/* somm — the C API (C99 / C11 / C++17). Bake opacity micromaps from the caller's own memory and get the
 * VK_EXT_opacity_micromap / DXR 1.2 build inputs, build and read compressed (succinct) micromap arrays.
 *
 * Conventions (docs/c-api.md has the details):
 *  - Every function that can fail returns a somm_result and fills the optional somm_error (NULL = not wanted)
 *    with the code and a one-line message. No C++ exception crosses this API; the library never prints or exits.
 *  - Structs are initialised with their somm_*_default() function, then the fields of interest are set.
 *  - Inputs are views of the caller's memory, read during the call only (never retained).
 *  - Results live in an opaque object until the caller copies them into memory it owns: query the sizes
 *    (somm_bake_result_array_info / _geometry_info), allocate (or map a staging buffer), copy
 *    (somm_bake_result_copy_array / _copy_geometry), destroy.
 *  - Output buffers are little endian and byte-identical to the somm CLI's (`somm bake` + `somm export`).
 */
#ifndef SOMM_SOMM_H
#define SOMM_SOMM_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32) && defined(SOMM_SHARED_BUILD)
#define SOMM_API __declspec(dllexport)
#elif defined(__GNUC__)
#define SOMM_API __attribute__((visibility("default")))
#else
#define SOMM_API
#endif

/* ---- version and errors ---- */

#define SOMM_VERSION_MAJOR 0
#define SOMM_VERSION_MINOR 1
#define SOMM_VERSION_PATCH 0

/* The library's version, "MAJOR.MINOR.PATCH" (static storage). */
SOMM_API const char* somm_version(void);

typedef enum somm_result {
  SOMM_OK = 0,
  SOMM_ERROR_INVALID_ARGUMENT = 1, /* a parameter or option out of range, inconsistent input */
  SOMM_ERROR_PARSE = 2,            /* malformed text */
  SOMM_ERROR_IO = 3,               /* (not used by the C API: it does no I/O) */
  SOMM_ERROR_CORRUPT = 4,          /* serialized bytes truncated or inconsistent */
  SOMM_ERROR_UNSUPPORTED = 5,      /* unknown version or feature */
  SOMM_ERROR_LIMIT_EXCEEDED = 6,   /* sizes beyond what the library is willing to allocate */
  SOMM_ERROR_BUFFER_TOO_SMALL = 7, /* a caller buffer is smaller than the size query said */
  SOMM_ERROR_CANCELLED = 8,        /* the progress callback asked to stop */
  SOMM_ERROR_OUT_OF_MEMORY = 9,
  SOMM_ERROR_INTERNAL = 10
} somm_result;

#define SOMM_ERROR_MESSAGE_SIZE 256
typedef struct somm_error {
  somm_result code;
  char message[SOMM_ERROR_MESSAGE_SIZE]; /* one line, NUL-terminated, truncated if longer */
} somm_error;

/* "ok", "invalid argument", ... (static storage). */
SOMM_API const char* somm_result_name(somm_result result);

/* ---- states and formats (values as in VK_EXT_opacity_micromap) ---- */

typedef enum somm_state {
  SOMM_STATE_TRANSPARENT = 0,
  SOMM_STATE_OPAQUE = 1,
  SOMM_STATE_UNKNOWN_TRANSPARENT = 2,
  SOMM_STATE_UNKNOWN_OPAQUE = 3
} somm_state;

typedef enum somm_format { SOMM_FORMAT_2_STATE = 1, SOMM_FORMAT_4_STATE = 2 } somm_format;

/* Index values of the OMM index buffer other than a triangle record index. */
#define SOMM_SPECIAL_INDEX_FULLY_TRANSPARENT (-1)
#define SOMM_SPECIAL_INDEX_FULLY_OPAQUE (-2)
#define SOMM_SPECIAL_INDEX_FULLY_UNKNOWN_TRANSPARENT (-3)
#define SOMM_SPECIAL_INDEX_FULLY_UNKNOWN_OPAQUE (-4)

/* Index buffer element types (values = bytes per index). NONE: non-indexed, triangle t uses vertices 3t..3t+2. */
typedef enum somm_index_type {
  SOMM_INDEX_NONE = 0,
  SOMM_INDEX_UINT16 = 2,
  SOMM_INDEX_UINT32 = 4
} somm_index_type;

/* VkMicromapUsageEXT / D3D12_RAYTRACING_OPACITY_MICROMAP_HISTOGRAM_ENTRY-compatible (12 bytes). */
typedef struct somm_usage_count {
  uint32_t count;
  uint32_t subdivision_level;
  uint32_t format; /* somm_format */
} somm_usage_count;

/* ---- bake input: views of the caller's memory ---- */

typedef enum somm_texel_format {
  SOMM_TEXEL_R8 = 1,     /* 1 byte per texel, unorm */
  SOMM_TEXEL_RG8 = 2,    /* 2 bytes */
  SOMM_TEXEL_RGBA8 = 3,  /* 4 bytes */
  SOMM_TEXEL_R16 = 4,    /* 2 bytes, unorm, native-endian uint16 */
  SOMM_TEXEL_RGBA16 = 5, /* 8 bytes */
  SOMM_TEXEL_R32F = 6    /* 4 bytes, float (NaN is invalid input; values are clamped to [0, 1]) */
} somm_texel_format;

/* An alpha texture. Texel (x, y) is at (const char*)data + y·row_pitch + x·texel_size and covers texture
 * coordinates [x/W, (x+1)/W] × [y/H, (y+1)/H]: row 0 is v = 0 (the Vulkan / D3D / glTF convention). Unorm values v
 * become alpha v / (2^bits − 1). */
typedef struct somm_texture {
  const void* data;
  size_t size; /* bytes readable at data: at least (height − 1)·row_pitch + width·texel_size */
  uint32_t width, height;
  size_t row_pitch; /* bytes from one row to the next; 0 = width·texel_size */
  somm_texel_format format;
  uint32_t alpha_channel; /* which channel holds alpha: 0..channels−1 (default: the last one) */
} somm_texture;

typedef enum somm_filter { SOMM_FILTER_NEAREST = 0, SOMM_FILTER_LINEAR = 1 } somm_filter;
typedef enum somm_wrap {
  SOMM_WRAP_REPEAT = 0,
  SOMM_WRAP_CLAMP_TO_EDGE = 1,
  SOMM_WRAP_MIRRORED_REPEAT = 2
} somm_wrap;

/* The sampler the renderer's alpha test uses (the bake is conservative against exactly this). */
typedef struct somm_sampler {
  somm_filter filter;
  somm_wrap wrap_s; /* along u (texel x) */
  somm_wrap wrap_t; /* along v (texel y) */
} somm_sampler;

typedef enum somm_alpha_mode {
  SOMM_ALPHA_OPAQUE = 0, /* no alpha test: every triangle fully opaque, no micromaps */
  SOMM_ALPHA_MASK = 1,   /* alpha test: opaque where alpha >= cutoff (the default of somm_material_default) */
  SOMM_ALPHA_BLEND = 2   /* blended: see somm_bake_options.blend */
} somm_alpha_mode;

typedef struct somm_material {
  somm_alpha_mode alpha_mode;
  float cutoff;                /* MASK: opaque where alpha >= cutoff, in [0, 1] */
  const somm_texture* texture; /* NULL: the constant alpha below everywhere */
  float constant_alpha;        /* with texture == NULL */
  somm_sampler sampler;
} somm_material;

/* One geometry: UVs as strided float pairs, an optional 16/32-bit index buffer, a material. */
typedef struct somm_geometry {
  const float* uvs; /* (u, v) of vertex i at (const char*)uvs + i·uv_stride */
  size_t uv_stride; /* bytes; 0 = 2·sizeof(float) */
  uint32_t vertex_count;
  const void* indices; /* 3 per triangle, of index_type; NULL with SOMM_INDEX_NONE */
  somm_index_type index_type;
  uint32_t triangle_count;
  uint32_t material; /* index into somm_bake_input.materials */
} somm_geometry;

typedef struct somm_bake_input {
  const somm_geometry* geometries;
  uint32_t geometry_count;
  const somm_material* materials;
  uint32_t material_count;
} somm_bake_input;

typedef enum somm_unknown_as {
  SOMM_UNKNOWN_AS_MAJORITY = 0, /* 2-state: an unknown micro-triangle becomes the state of most of its area */
  SOMM_UNKNOWN_AS_OPAQUE = 1,
  SOMM_UNKNOWN_AS_TRANSPARENT = 2
} somm_unknown_as;

typedef enum somm_blend_policy {
  SOMM_BLEND_UNKNOWN =
      0, /* BLEND triangles get the special index fully-unknown-opaque: the any-hit shader decides */
  SOMM_BLEND_AS_MASK = 1 /* bake BLEND materials as MASK with their cutoff */
} somm_blend_policy;

typedef enum somm_array_layout {
  SOMM_ARRAY_PER_SCENE =
      0, /* one array shared by all geometries, identical micromaps stored once (the default,
                                 as `somm bake`) */
  SOMM_ARRAY_PER_GEOMETRY = 1 /* one OMM array per geometry (`somm bake --arrays geometry`) */
} somm_array_layout;

/* Progress: fraction done in [0, 1], non-decreasing, called on the calling thread. Return non-zero to cancel
 * (somm_bake then returns SOMM_ERROR_CANCELLED and no result). The last call, with 1, comes once the work is done:
 * its return value is ignored. */
typedef int (*somm_progress_fn)(double fraction, void* user);

typedef struct somm_bake_options {
  uint32_t level;     /* fixed subdivision level 0..12 (default 6), when texels_per_micro_triangle == 0 */
  uint32_t max_level; /* adaptive: the cap 0..12 */
  float
      texels_per_micro_triangle; /* adaptive (> 0): per triangle the smallest level whose micro-triangles cover
                                       at most this many texels, capped at max_level */
  somm_format format;            /* default 4-state */
  somm_unknown_as unknown_as;    /* 2-state only */
  uint64_t max_bytes; /* scene-wide budget of micromap data bytes (0 = none): the highest levels are
                                       lowered, scene-wide, until the data of all geometries fits */
  somm_blend_policy blend;
  somm_array_layout layout;
  uint32_t threads;          /* 0 = all hardware threads; results are identical for every count */
  somm_progress_fn progress; /* may be NULL */
  void* progress_user;
} somm_bake_options;

SOMM_API somm_texture somm_texture_default(void);   /* RGBA8, alpha channel 3, everything else 0 */
SOMM_API somm_sampler somm_sampler_default(void);   /* linear, repeat, repeat */
SOMM_API somm_material somm_material_default(void); /* MASK, cutoff 0.5, no texture, constant alpha 1 */
SOMM_API somm_geometry somm_geometry_default(void); /* no data, 32-bit indices, tight UVs, material 0 */
SOMM_API somm_bake_options somm_bake_options_default(void); /* level 6, 4-state, majority, no budget, BLEND
                                                               unknown, one scene-wide array, all threads */

/* ---- bake ---- */

typedef struct somm_bake_result somm_bake_result;

/* Bakes every geometry. On success *result owns the buffers until somm_bake_result_destroy. */
SOMM_API somm_result somm_bake(const somm_bake_input* input, const somm_bake_options* options,
                               somm_bake_result** result, somm_error* error);
SOMM_API void somm_bake_result_destroy(somm_bake_result* result); /* NULL is ignored */

/* The sizes of one OMM array's buffers (one VkMicromapEXT / DXR OMM array): allocate these, then
 * somm_bake_result_copy_array. */
typedef struct somm_array_info {
  uint64_t data_size;      /* bytes: micromap data (VkMicromapBuildInfoEXT::data) */
  uint32_t triangle_count; /* records of 8 bytes (VkMicromapTriangleEXT): triangleArray, stride 8 */
  uint32_t
      usage_count_count; /* entries of the micromap usage histogram (VkMicromapBuildInfoEXT::pUsageCounts) */
  uint32_t geometry_count; /* geometries whose index buffers point into this array */
} somm_array_info;

/* Caller-owned destinations; a NULL pointer skips that buffer. Capacities in bytes (usage counts: entries). */
typedef struct somm_array_buffers {
  void* data;
  uint64_t data_capacity;
  void* triangles;
  uint64_t triangles_capacity;
  somm_usage_count* usage_counts;
  uint32_t usage_counts_capacity;
} somm_array_buffers;

/* One geometry's OMM index buffer into its array (VkAccelerationStructureTrianglesOpacityMicromapEXT: micromap =
 * array, indexType, indexBuffer, indexStride = index_type bytes, baseTriangle 0, pUsageCounts) and what the bake
 * found. */
typedef struct somm_geometry_info {
  uint32_t array;
  uint32_t triangle_count;    /* = index count */
  somm_index_type index_type; /* UINT16 when every non-special index fits (<= 0xFFFB), else UINT32 */
  uint64_t index_size;        /* bytes: triangle_count · index_type */
  uint32_t usage_count_count; /* entries of this geometry's triangle usage histogram (for its BLAS build) */
  uint64_t special_count[4];  /* triangles with a special index, by somm_state */
  uint64_t micro_triangles;   /* Σ 4^level */
  uint64_t unknown_micro_triangles;
  uint64_t non_finite_uv_triangles;
  uint32_t min_level, max_level;
} somm_geometry_info;

typedef struct somm_geometry_buffers {
  void* indices; /* special indices −1..−4 as 0xFFFF..0xFFFC in 16 bits */
  uint64_t indices_capacity;
  somm_usage_count* usage_counts;
  uint32_t usage_counts_capacity;
} somm_geometry_buffers;

SOMM_API uint32_t somm_bake_result_array_count(const somm_bake_result* result);
SOMM_API uint32_t somm_bake_result_geometry_count(const somm_bake_result* result);
SOMM_API somm_format somm_bake_result_format(const somm_bake_result* result);
/* The scene-wide level cap the byte budget applied (12 = none). */
SOMM_API uint32_t somm_bake_result_level_cap(const somm_bake_result* result);
SOMM_API somm_result somm_bake_result_array_info(const somm_bake_result* result, uint32_t array,
                                                 somm_array_info* info, somm_error* error);
SOMM_API somm_result somm_bake_result_copy_array(const somm_bake_result* result, uint32_t array,
                                                 const somm_array_buffers* buffers, somm_error* error);
SOMM_API somm_result somm_bake_result_geometry_info(const somm_bake_result* result, uint32_t geometry,
                                                    somm_geometry_info* info, somm_error* error);
SOMM_API somm_result somm_bake_result_copy_geometry(const somm_bake_result* result, uint32_t geometry,
                                                    const somm_geometry_buffers* buffers, somm_error* error);

/* ---- compressed arrays (docs/encodings.md) ---- */

typedef enum somm_encoding {
  SOMM_ENCODING_FLAT = 0,
  SOMM_ENCODING_DFS = 1,
  SOMM_ENCODING_DFS_FAST = 2,
  SOMM_ENCODING_RANK = 3,
  SOMM_ENCODING_HYBRID = 4,
  SOMM_ENCODING_CSM = 5, /* common-subtree-merged DAG (Chernaik et al., HPG 2026) */
  SOMM_ENCODING_SDAG = 6 /* somm's succinct DAG shared across the array */
} somm_encoding;

/* The spec buffers of one OMM array, as the caller holds them (e.g. copied from a bake). */
typedef struct somm_flat_array {
  const void* data;
  uint64_t data_size;
  const void* triangles; /* 8-byte records */
  uint32_t triangle_count;
  const void* indices; /* index_count values of index_type (special indices −1..−4) */
  somm_index_type index_type;
  uint32_t index_count;
} somm_flat_array;

SOMM_API somm_flat_array somm_flat_array_default(void);

typedef struct somm_encoded_array somm_encoded_array;

/* Builds an encoded array from flat buffers (validated: offsets, levels, formats, indices). */
SOMM_API somm_result somm_encoded_array_build(const somm_flat_array* flat, somm_encoding encoding,
                                              somm_encoded_array** array, somm_error* error);
/* Parses serialized bytes (untrusted input: every lookup of a parsed array stays in bounds). */
SOMM_API somm_result somm_encoded_array_parse(const void* bytes, size_t size, somm_encoded_array** array,
                                              somm_error* error);
SOMM_API void somm_encoded_array_destroy(somm_encoded_array* array); /* NULL is ignored */

SOMM_API somm_encoding somm_encoded_array_encoding(const somm_encoded_array* array);
SOMM_API uint32_t somm_encoded_array_triangle_count(const somm_encoded_array* array);
SOMM_API uint32_t somm_encoded_array_map_count(const somm_encoded_array* array);
/* Bytes of the serialized form (= what a GPU needs for random access into this encoding). */
SOMM_API uint64_t somm_encoded_array_serialized_size(const somm_encoded_array* array);
SOMM_API somm_result somm_encoded_array_serialize(const somm_encoded_array* array, void* bytes,
                                                  uint64_t capacity, somm_error* error);
/* State of micro-triangle `index` (bird-curve order) of `triangle`, special indices resolved: 0..3 (somm_state),
 * or −1 when triangle or index is out of range. */
SOMM_API int somm_encoded_array_state(const somm_encoded_array* array, uint32_t triangle, uint32_t index);
/* The same at barycentrics (u, v) of vertices 1 and 2 (exactly the hardware's micro-triangle choice). */
SOMM_API int somm_encoded_array_state_uv(const somm_encoded_array* array, uint32_t triangle, float u,
                                         float v);
/* Subdivision level of the triangle's micromap (0 for a special index), or −1 when out of range. */
SOMM_API int somm_encoded_array_level(const somm_encoded_array* array, uint32_t triangle);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* SOMM_SOMM_H */
