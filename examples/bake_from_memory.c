// SPDX-License-Identifier: MIT
/* bake_from_memory [DIR]: the somm C API on an engine's own arrays and an RGBA8 image.
 *
 * Bakes 4-state opacity micromaps (level 6) for leaf cards whose vertices interleave position and UV, indexed with
 * 16 bits, and prints the sizes of the buffers a Vulkan / DXR OMM array build takes. With DIR it also writes them as
 * DIR/array-0/{data,triangles}.bin and DIR/geometry-0/index.bin (what `somm export` writes) and the same input as
 * DIR/scene.obj, so that
 *   somm bake DIR/scene.obj -o x.somm && somm export x.somm --dir D
 * can be compared byte for byte (make test does). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "example_scene.h"
#include "somm/somm.h"

static int check(somm_result r, const somm_error* e) {
  if (r == SOMM_OK) return 0;
  fprintf(stderr, "bake_from_memory: %s: %s\n", somm_result_name(r), e->message);
  return 1;
}

int main(int argc, char** argv) {
  static ex_scene scene; /* static: ~17 KB */
  somm_texture texture;
  somm_material material;
  somm_geometry geometry;
  somm_bake_input input;
  somm_bake_options options;
  somm_bake_result* result = NULL;
  somm_error error;
  somm_array_info info;
  somm_array_buffers buffers;
  somm_geometry_info ginfo;
  somm_geometry_buffers gbuffers;
  void *data, *triangles, *indices;
  somm_usage_count* usage;
  uint32_t i;
  const char* dir = argc > 1 ? argv[1] : NULL;

  printf("somm %s\n", somm_version());
  ex_make_scene(&scene);

  texture = somm_texture_default(); /* RGBA8, alpha in channel 3 */
  texture.data = scene.rgba;
  texture.size = sizeof scene.rgba;
  texture.width = EX_TEX;
  texture.height = EX_TEX;
  texture.row_pitch = 4 * EX_TEX;

  material = somm_material_default(); /* MASK, cutoff 0.5, linear, repeat */
  material.texture = &texture;

  geometry = somm_geometry_default();
  geometry.uvs = &scene.vertices[0].u;
  geometry.uv_stride = sizeof(ex_vertex);
  geometry.vertex_count = EX_VERTICES;
  geometry.indices = scene.indices;
  geometry.index_type = SOMM_INDEX_UINT16;
  geometry.triangle_count = EX_TRIANGLES;
  geometry.material = 0;

  input.geometries = &geometry;
  input.geometry_count = 1;
  input.materials = &material;
  input.material_count = 1;

  options = somm_bake_options_default(); /* level 6, 4-state */
  if (check(somm_bake(&input, &options, &result, &error), &error)) return 1;

  /* Query the sizes, allocate (an engine would map its staging buffers), copy: the array (micromap data, triangle
   * records, usage counts), then the geometry's index buffer into it. */
  if (check(somm_bake_result_array_info(result, 0, &info, &error), &error)) return 1;
  if (check(somm_bake_result_geometry_info(result, 0, &ginfo, &error), &error)) return 1;
  data = malloc(info.data_size ? (size_t)info.data_size : 1);
  triangles = malloc(info.triangle_count ? (size_t)info.triangle_count * 8 : 1);
  indices = malloc(ginfo.index_size ? (size_t)ginfo.index_size : 1);
  usage = (somm_usage_count*)malloc(sizeof(somm_usage_count) *
                                    (info.usage_count_count ? info.usage_count_count : 1));
  if (!data || !triangles || !indices || !usage) return 1;
  memset(&buffers, 0, sizeof buffers);
  buffers.data = data;
  buffers.data_capacity = info.data_size;
  buffers.triangles = triangles;
  buffers.triangles_capacity = (uint64_t)info.triangle_count * 8;
  buffers.usage_counts = usage;
  buffers.usage_counts_capacity = info.usage_count_count;
  if (check(somm_bake_result_copy_array(result, 0, &buffers, &error), &error)) return 1;
  memset(&gbuffers, 0, sizeof gbuffers);
  gbuffers.indices = indices;
  gbuffers.indices_capacity = ginfo.index_size;
  if (check(somm_bake_result_copy_geometry(result, 0, &gbuffers, &error), &error)) return 1;

  printf("%u triangles: %u micromaps, %llu special (transparent %llu, opaque %llu, unknown %llu)\n",
         (unsigned)ginfo.triangle_count, (unsigned)info.triangle_count,
         (unsigned long long)(ginfo.special_count[0] + ginfo.special_count[1] + ginfo.special_count[2] +
                              ginfo.special_count[3]),
         (unsigned long long)ginfo.special_count[0], (unsigned long long)ginfo.special_count[1],
         (unsigned long long)(ginfo.special_count[2] + ginfo.special_count[3]));
  printf("data buffer       %llu bytes\n", (unsigned long long)info.data_size);
  printf("triangle array    %llu bytes (%u x 8-byte VkMicromapTriangleEXT)\n",
         (unsigned long long)buffers.triangles_capacity, (unsigned)info.triangle_count);
  printf("index buffer      %llu bytes (%s)\n", (unsigned long long)ginfo.index_size,
         ginfo.index_type == SOMM_INDEX_UINT16 ? "VK_INDEX_TYPE_UINT16" : "VK_INDEX_TYPE_UINT32");
  for (i = 0; i < info.usage_count_count; ++i)
    printf("usage count       %u micromaps at level %u, format %u\n", (unsigned)usage[i].count,
           (unsigned)usage[i].subdivision_level, (unsigned)usage[i].format);

  if (dir) {
    char sub[4096];
    int failed;
    mkdir(dir, 0777);
    snprintf(sub, sizeof sub, "%s/array-0", dir);
    mkdir(sub, 0777);
    failed = ex_write_file(sub, "data.bin", data, (size_t)info.data_size) ||
             ex_write_file(sub, "triangles.bin", triangles, (size_t)buffers.triangles_capacity);
    snprintf(sub, sizeof sub, "%s/geometry-0", dir);
    mkdir(sub, 0777);
    failed = failed || ex_write_file(sub, "index.bin", indices, (size_t)ginfo.index_size) ||
             ex_write_obj_scene(&scene, dir);
    if (failed) {
      fprintf(stderr, "bake_from_memory: %s: cannot write the output files\n", dir);
      return 1;
    }
  }
  free(data);
  free(triangles);
  free(indices);
  free(usage);
  somm_bake_result_destroy(result);
  return 0;
}
