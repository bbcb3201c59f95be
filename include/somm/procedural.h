// SPDX-License-Identifier: MIT
// somm — deterministic procedural alpha textures and scenes for tests and benchmarks (target somm_scene).
// Every function is a pure function of its arguments: the same seed gives the same bytes on every platform
// (own PRNG, no <random> distributions). Textures follow the AlphaTexture convention (row 0 is v = 0).
#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "somm/scene.h"
#include "somm/texture.h"

namespace somm {

// A disc of radius 3/8·size centred in the texture, alpha 1 inside and 0 outside with a one-texel linear ramp
// at the edge (so alpha takes intermediate values there).
AlphaTexture makeDiscTexture(uint32_t size);

// Smooth, tileable value noise in [0, 1]: random lattice values every `cell` texels (cell ≥ 1 and a divisor
// of size for seamless tiling), smoothstep-interpolated.
AlphaTexture makeNoiseTexture(uint32_t size, uint32_t seed, uint32_t cell = 16);

// Checkerboard of cell×cell texel squares: alpha 1 where (x / cell + y / cell) is even, else 0.
AlphaTexture makeCheckerTexture(uint32_t size, uint32_t cell);

// Transparent (alpha 0) with `count` distinct single opaque texels (alpha 1) at random positions.
AlphaTexture makeSpeckTexture(uint32_t size, uint32_t count, uint32_t seed);

// Hard vertical stripes: alpha 1 where (x mod period) < period / 2, else 0 (period ≥ 2).
AlphaTexture makeStripeTexture(uint32_t size, uint32_t period);

// A leaf silhouette (binary alpha: 1 on the leaf, 0 elsewhere): pointed, wavy-edged blade along the v axis
// with a stem, tip at the top of the image (small v), about 40% coverage.
AlphaTexture makeLeafTexture(uint32_t size);

// A 2×2 atlas of four different leaf silhouettes (binary alpha), each in one size/2 quadrant.
AlphaTexture makeLeafAtlasTexture(uint32_t size);

// One quad (2 triangles, 4 vertices) spanning [-1, 1]² in the z = 0 plane facing +z, with texture coordinates
// uvRect = {u0, v0, u1, v1}: the top-left corner (-1, 1) gets (u0, v0), the bottom-right (1, -1) gets (u1,
// v1). Triangles: (top-left, bottom-left, bottom-right) and (top-left, bottom-right, top-right). One material
// "quad" (MASK, the cutoff, the texture, the sampler), one geometry "quad", one identity instance, a camera
// at (0, 0, 2.5) looking at the origin.
Scene makeQuadScene(std::shared_ptr<const AlphaTexture> texture, Sampler sampler, float cutoff,
                    std::array<float, 4> uvRect = {0, 0, 1, 1});

// A layered leaf-card scene: `cards` overlapping alpha-tested quads (2 triangles each) with random position in
// [-1, 1]³, orientation and size (0.25–0.6), all in one geometry "cards" (triangles 2c and 2c+1 are card c) with one
// MASK material "leaf" (cutoff 0.5, linear, repeat) using an atlasSize² leaf atlas (makeLeafAtlasTexture); each card
// maps a randomly jittered quadrant of the atlas (so cards have distinct UVs). One identity instance and a camera at
// (0, 0, 3.5) looking at the origin. Deterministic from the seed and the atlas size.
Scene makeLeafCardScene(uint32_t cards, uint32_t seed, uint32_t atlasSize = 512);

}  // namespace somm
