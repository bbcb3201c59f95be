// SPDX-License-Identifier: MIT
/* The input of the examples, as an engine would hold it: an RGBA8 leaf texture and leaf cards whose vertices
 * interleave position and UV (20 bytes per vertex), with a 16-bit index buffer. Deterministic (integer math), C99
 * and C++17. UVs are multiples of 1/64, so that they print exactly as decimal text (see write_obj_scene). */
#ifndef SOMM_EXAMPLE_SCENE_H
#define SOMM_EXAMPLE_SCENE_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

enum { EX_TEX = 64, EX_CARDS = 24, EX_VERTICES = 4 * EX_CARDS, EX_TRIANGLES = 2 * EX_CARDS };

typedef struct ex_vertex {
  float x, y, z, u, v;
} ex_vertex;

typedef struct ex_scene {
  uint8_t rgba[EX_TEX * EX_TEX * 4]; /* row 0 is v = 0 */
  ex_vertex vertices[EX_VERTICES];
  uint16_t indices[3 * EX_TRIANGLES];
} ex_scene;

static inline void ex_make_scene(ex_scene* s) {
  int x, y, c;
  uint32_t seed = 12345u;
  for (y = 0; y < EX_TEX; ++y)
    for (x = 0; x < EX_TEX; ++x) {
      /* a leaf: inside the ellipse ((x-32)/28)^2 + ((y-32)/13)^2 < 1, with a one-texel half-alpha rim and a vein */
      const int dx = 2 * x + 1 - EX_TEX, dy = 2 * y + 1 - EX_TEX; /* in half texels */
      const long e = (long)dx * dx * 169 + (long)dy * dy * 784;   /* < 56² · 13² · 4 · 4 inside */
      const long r = 4L * 56 * 56 * 169;
      uint8_t* p = &s->rgba[4 * (y * EX_TEX + x)];
      p[0] = (uint8_t)(40 + x);
      p[1] = (uint8_t)(120 + y);
      p[2] = 30;
      p[3] = e < r * 8 / 10 ? 255 : e < r ? 128 : 0;
      if (y == EX_TEX / 2 && x > 4 && x < EX_TEX - 4 && (x & 7) == 0) p[3] = 0; /* holes along the vein */
    }
  for (c = 0; c < EX_CARDS; ++c) {
    ex_vertex* v = &s->vertices[4 * c];
    uint16_t* t = &s->indices[6 * c];
    int k;
    /* card position from a small LCG; UV rectangle [u0, u0 + du] × [v0, v0 + dv] in 64ths, sometimes beyond [0, 1] */
    float px, py;
    int u0, v0, du, dv;
    seed = seed * 1103515245u + 12345u;
    px = (float)((seed >> 16) % 100) / 25.0f - 2.0f;
    seed = seed * 1103515245u + 12345u;
    py = (float)((seed >> 16) % 100) / 25.0f - 2.0f;
    seed = seed * 1103515245u + 12345u;
    u0 = (int)((seed >> 16) % 96) - 16;
    v0 = (int)((seed >> 8) % 96) - 16;
    du = 32 + (int)((seed >> 4) % 48);
    dv = 32 + (int)((seed >> 12) % 48);
    for (k = 0; k < 4; ++k) {
      const int right = k == 1 || k == 2, top = k >= 2;
      v[k].x = px + (right ? 0.5f : 0.0f);
      v[k].y = py + (top ? 0.5f : 0.0f);
      v[k].z = (float)c * 0.01f;
      v[k].u = (float)(u0 + (right ? du : 0)) / 64.0f;
      v[k].v = (float)(v0 + (top ? dv : 0)) / 64.0f;
    }
    t[0] = (uint16_t)(4 * c), t[1] = (uint16_t)(4 * c + 1), t[2] = (uint16_t)(4 * c + 2);
    t[3] = (uint16_t)(4 * c), t[4] = (uint16_t)(4 * c + 2), t[5] = (uint16_t)(4 * c + 3);
  }
}

/* The same scene as files `somm bake` reads: DIR/scene.obj + scene.mtl + alpha.pgm (map_d, the texture's alpha;
 * OBJ's v = 0 is the bottom image row, so rows are written last to first). OBJ defaults = the examples' material:
 * MASK, cutoff 0.5, linear filter, repeat. Returns 0 on success. */
static inline int ex_write_obj_scene(const ex_scene* s, const char* dir) {
  char path[4096];
  FILE* f;
  int i, y, x;
  snprintf(path, sizeof path, "%s/alpha.pgm", dir);
  if (!(f = fopen(path, "wb"))) return 1;
  fprintf(f, "P5\n%d %d\n255\n", EX_TEX, EX_TEX);
  for (y = EX_TEX - 1; y >= 0; --y)
    for (x = 0; x < EX_TEX; ++x) fputc(s->rgba[4 * (y * EX_TEX + x) + 3], f);
  if (fclose(f)) return 1;
  snprintf(path, sizeof path, "%s/scene.mtl", dir);
  if (!(f = fopen(path, "w"))) return 1;
  fprintf(f, "newmtl leaf\nmap_d alpha.pgm\n");
  if (fclose(f)) return 1;
  snprintf(path, sizeof path, "%s/scene.obj", dir);
  if (!(f = fopen(path, "w"))) return 1;
  fprintf(f, "mtllib scene.mtl\no cards\nusemtl leaf\n");
  for (i = 0; i < EX_VERTICES; ++i)
    fprintf(f, "v %.9g %.9g %.9g\n", s->vertices[i].x, s->vertices[i].y, s->vertices[i].z);
  for (i = 0; i < EX_VERTICES; ++i) fprintf(f, "vt %.9g %.9g\n", s->vertices[i].u, s->vertices[i].v);
  for (i = 0; i < EX_TRIANGLES; ++i) {
    const int a = s->indices[3 * i] + 1, b = s->indices[3 * i + 1] + 1, c = s->indices[3 * i + 2] + 1;
    fprintf(f, "f %d/%d %d/%d %d/%d\n", a, a, b, b, c, c);
  }
  return fclose(f) ? 1 : 0;
}

/* Writes `size` bytes to DIR/NAME (creating nothing else). Returns 0 on success. */
static inline int ex_write_file(const char* dir, const char* name, const void* data, size_t size) {
  char path[4096];
  FILE* f;
  snprintf(path, sizeof path, "%s/%s", dir, name);
  if (!(f = fopen(path, "wb"))) return 1;
  if (size && fwrite(data, 1, size, f) != size) {
    fclose(f);
    return 1;
  }
  return fclose(f) ? 1 : 0;
}

#endif /* SOMM_EXAMPLE_SCENE_H */
