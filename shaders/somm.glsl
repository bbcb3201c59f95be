// SPDX-License-Identifier: MIT
// somm — software opacity micromap lookups for GLSL 4.60 (Vulkan), bit-identical to include/somm/bird.h and
// include/somm/encode.h. Layouts and binding example: docs/shaders.md.
//
// Include this file after defining how to read 32-bit word i (little endian, byte address 4·i) of the storage
// buffer that holds the serialized EncodedArray bytes, e.g.
//   layout(std430, set = 0, binding = 0) readonly buffer SommArrays { uint sommWords[]; };
//   #define SOMM_WORD(i) sommWords[i]
//   #include "somm.glsl"
// Only core GLSL 4.60: 32-bit integers, floatBitsToUint, bitCount. No extension, no 64-bit or 8/16-bit types.
// Every function is pure integer arithmetic: no float operation can be contracted, reassociated, flushed or
// rounded differently by a driver, so the results do not depend on the device's float modes.
//
// Addresses are byte addresses into that buffer. The buffer must hold at least 8 readable bytes after the
// last array (the array's own tail padding, or zeros the application appends): unaligned reads fetch the
// word after the addressed one.
#ifndef SOMM_GLSL
#define SOMM_GLSL

#ifndef SOMM_WORD
#error "define SOMM_WORD(i) (read 32-bit word i of the micromap buffer) before including somm.glsl"
#endif

// ---- layout constants (equal to the C++ ones; tests/gpu/shader_constants_test.cpp checks) ----
const uint SOMM_MAX_LEVEL = 12u;
const uint SOMM_STATE_TRANSPARENT = 0u;
const uint SOMM_STATE_OPAQUE = 1u;
const uint SOMM_STATE_UNKNOWN_TRANSPARENT = 2u;
const uint SOMM_STATE_UNKNOWN_OPAQUE = 3u;
const uint SOMM_ARRAY_MAGIC = 0x434e4553u;  // "SENC", bytes 0..3 of an array
const uint SOMM_ARRAY_HEADER_BYTES = 20u;
const uint SOMM_DESCRIPTOR_BYTES = 8u;
const uint SOMM_TAIL_PADDING = 8u;
const uint SOMM_RANK_BLOCK_BITS = 256u;
const uint SOMM_ENCODING_FLAT = 0u;
const uint SOMM_ENCODING_DFS = 1u;
const uint SOMM_ENCODING_DFS_FAST = 2u;
const uint SOMM_ENCODING_RANK = 3u;
const uint SOMM_ENCODING_HYBRID = 4u;
const uint SOMM_ENCODING_CSM = 5u;
const uint SOMM_ENCODING_SDAG = 6u;
const uint SOMM_KIND_FLAT = 0u;
const uint SOMM_KIND_DFS = 1u;
const uint SOMM_KIND_RANK = 2u;
const uint SOMM_KIND_CSM = 3u;
const uint SOMM_KIND_SDAG = 4u;
const uint SOMM_SDAG_DIRECTORY_BYTES = 80u;
const uint SOMM_FORMAT_2_STATE = 1u;
const uint SOMM_FORMAT_4_STATE = 2u;

// ---- byte and bit access ----
uint sommByte(uint addr) { return (SOMM_WORD(addr >> 2u) >> ((addr & 3u) * 8u)) & 0xffu; }

// 32 bits starting at any byte address (reads two words; the second shift pair is a no-op when aligned).
uint sommRead32(uint addr) {
  uint s = (addr & 3u) * 8u;
  uint w = addr >> 2u;
  return (SOMM_WORD(w) >> s) | ((SOMM_WORD(w + 1u) << 1u) << (31u - s));
}
uint sommRead16(uint addr) { return sommRead32(addr) & 0xffffu; }

// n ≤ 25 bits at bit `bit` of the region starting at byte `addr` (bits LSB-first within bytes).
uint sommBits(uint addr, uint bit, uint n) {
  return (sommRead32(addr + (bit >> 3u)) >> (bit & 7u)) & ((1u << n) - 1u);
}
// n ≤ 32 bits at bit `bit` (reads 8 bytes).
uint sommBits32(uint addr, uint bit, uint n) {
  uint a = addr + (bit >> 3u);
  uint sh = bit & 7u;
  uint v = (sommRead32(a) >> sh) | ((sommRead32(a + 4u) << 1u) << (31u - sh));
  return n >= 32u ? v : v & ((1u << n) - 1u);
}
uint sommBit(uint addr, uint bit) { return (sommByte(addr + (bit >> 3u)) >> (bit & 7u)) & 1u; }

// State i of b bits per state (format 1 or 2) in a value region starting at bit `base` of `addr`.
uint sommValue(uint addr, uint base, uint format, uint i) {
  return format == SOMM_FORMAT_2_STATE ? sommBit(addr, base + i) : sommBits(addr, base + 2u * i, 2u);
}
uint sommDigit(uint index, uint level, uint depth) { return (index >> (2u * (level - 1u - depth))) & 3u; }

// ---- the bird curve (docs/bird.md) ----
// Quantises one barycentric exactly as baryToIndex: clamp to [0, 1] (NaN → 0, ±inf → 0 / 1), then
// cell = floor(x·2^L) (not yet capped) and frac26 = floor(frac(x·2^L)·2^26), both from the float's bits.
void sommQuantise(float x, uint level, out uint cell, out uint frac26) {
  uint a = floatBitsToUint(x);
  if (a > 0x7f800000u) a = 0u;                    // NaN of either sign, and every negative value (incl. -0)
  else if (a >= 0x3f800000u) a = 0x3f800000u;     // [1, +inf] → 1
  uint e = a >> 23u;
  uint mant = (a & 0x7fffffu) | (e != 0u ? 0x800000u : 0u);  // x = mant · 2^(max(e,1) - 150)
  uint s = 150u - max(e, 1u) - level;  // x·2^L = mant · 2^-s with 11 ≤ s ≤ 149 (x = 1: mant = 2^23, s = 23 - L)
  cell = mant >> min(s, 31u);
  uint f = s <= 26u ? mant << (26u - s) : mant >> min(s - 26u, 31u);
  frac26 = f & 0x3ffffffu;
}

uint sommSpread(uint x) {  // bit k → bit 2k for the low 16 bits
  x = (x | (x << 8u)) & 0x00ff00ffu;
  x = (x | (x << 4u)) & 0x0f0f0f0fu;
  x = (x | (x << 2u)) & 0x33333333u;
  x = (x | (x << 1u)) & 0x55555555u;
  return x;
}

// Index of the micro-triangle in grid cell (iu, iv) of level L, upper = 1 for the cell's inverted triangle.
uint sommCellToIndex(uint iu, uint iv, uint upper, uint level) {
  uint iw = ~(iu + iv + upper);
  uint b0 = ~(iu ^ iw) & ((1u << level) - 1u);
  uint t = (iu ^ iv) & b0;
  uint f = t;
  f ^= f >> 1u;
  f ^= f >> 2u;
  f ^= f >> 4u;
  f ^= f >> 8u;
  uint b1 = ((f ^ iu) & ~b0) | t;
  return sommSpread(b0) | (sommSpread(b1) << 1u);
}

// Barycentrics (u, v) (weights of vertices 1 and 2) → bird-curve index at level L (0..12). Equal to the CPU's
// baryToIndex for every pair of floats. The reference's float test frac(u·2^L) + frac(v·2^L) >= 1 (a
// round-to-nearest-even float addition) is evaluated exactly on integers: the rounded sum reaches 1 iff the
// exact sum is ≥ 1 - 2^-25, iff floor(frac_u·2^26) + floor(frac_v·2^26) ≥ 2^26 - 2 (docs/shaders.md).
uint sommBaryToIndex(float u, float v, uint level) {
  uint n = 1u << level;
  uint iu, iv, fu, fv;
  sommQuantise(u, level, iu, fu);
  sommQuantise(v, level, iv, fv);
  iu = min(iu, n - 1u);
  iv = min(iv, n - 1u);
  uint iuv = iu + iv;
  iu = iuv >= n ? n - 1u - iv : iu;
  uint upper = (fu + fv >= 0x3fffffeu && iuv < n - 1u) ? 1u : 0u;
  return sommCellToIndex(iu, iv, upper, level);
}

// ---- per-map lookups (blob = byte address of the encoded micromap; docs/encodings.md) ----
uint sommCountFieldBits(uint level) { return level == 0u ? 0u : 2u * level - 1u; }

uint sommFlatState(uint blob, uint level, uint format, uint index) { return sommValue(blob, 0u, format, index); }

// The dfs skips. One step consumes bit k of `word` (the bits from `pos` on): a node; a 1 opens four more pending
// nodes, a 0 is a leaf. A step after the count reached zero does nothing, so a block of steps may overrun.
// The skips take 48 bits per loop iteration (two 24-bit reads, 48 straight-line steps) because Mesa's
// llvmpipe / lavapipe ends a shader invocation's loops after 65535 iterations in total: with 48 bits per
// iteration a skip over up to 3 million tree bits (4·I + 1; ~786 000 internal nodes) stays below that.
#define SOMM_SKIP_BIT(word, k)                 \
  if (need != 0u) {                           \
    uint b_ = ((word) >> (k)) & 1u;           \
    need = need - 1u + 4u * b_;               \
    leaf += 1u - b_;                          \
    ++pos;                                    \
  }
#define SOMM_SKIP_4(w, k) SOMM_SKIP_BIT(w, k) SOMM_SKIP_BIT(w, k + 1u) SOMM_SKIP_BIT(w, k + 2u) SOMM_SKIP_BIT(w, k + 3u)
#define SOMM_SKIP_24(w) \
  SOMM_SKIP_4(w, 0u) SOMM_SKIP_4(w, 4u) SOMM_SKIP_4(w, 8u) SOMM_SKIP_4(w, 12u) SOMM_SKIP_4(w, 16u) SOMM_SKIP_4(w, 20u)

// The paper's dfs lookup (Waldemarson & Doggett 2024): skip earlier sibling subtrees bit by bit, counting.
uint sommDfsState(uint blob, uint level, uint format, uint index) {
  uint w = sommCountFieldBits(level);
  uint internal = w != 0u ? sommBits(blob, 0u, w) : 0u;
  uint t = blob + (w + 7u) / 8u;
  uint pos = 0u, leaf = 0u;
  for (uint d = 0u; d < level; ++d) {
    if (sommBit(t, pos) == 0u) break;
    ++pos;
    uint need = sommDigit(index, level, d);
    while (need != 0u) {
      uint lo = sommBits(t, pos, 24u);
      uint hi = sommBits(t, pos + 24u, 24u);
      SOMM_SKIP_24(lo)
      SOMM_SKIP_24(hi)
    }
  }
  return sommValue(t, 4u * internal + 1u, format, leaf);
}

// The same bits; 48 bits are consumed at once (popcount) when the pending count exceeds their zeros — it
// drops by at most one per bit, so it cannot reach zero inside — and stepped through otherwise.
uint sommDfsFastState(uint blob, uint level, uint format, uint index) {
  uint w = sommCountFieldBits(level);
  uint internal = w != 0u ? sommBits(blob, 0u, w) : 0u;
  uint t = blob + (w + 7u) / 8u;
  uint pos = 0u, leaf = 0u;
  for (uint d = 0u; d < level; ++d) {
    if (sommBit(t, pos) == 0u) break;
    ++pos;
    uint need = sommDigit(index, level, d);
    while (need != 0u) {
      uint lo = sommBits(t, pos, 24u);
      uint hi = sommBits(t, pos + 24u, 24u);
      uint ones = uint(bitCount(lo)) + uint(bitCount(hi));
      if (need > 48u - ones) {
        need = need + 4u * ones - 48u;
        leaf += 48u - ones;
        pos += 48u;
      } else {
        SOMM_SKIP_24(lo)
        SOMM_SKIP_24(hi)
      }
    }
  }
  return sommValue(t, 4u * internal + 1u, format, leaf);
}

// Rank of bit `sh` (0..63) of the 64-bit word at byte `addr`: the number of 1s below it; flag = the bit itself.
uint sommRankInWord(uint addr, uint sh, out uint flag) {
  uint lo = sommRead32(addr);
  uint hi = sommRead32(addr + 4u);
  if (sh < 32u) {
    flag = (lo >> sh) & 1u;
    return uint(bitCount(lo & ((1u << sh) - 1u)));
  }
  flag = (hi >> (sh - 32u)) & 1u;
  return uint(bitCount(lo)) + uint(bitCount(hi & ((1u << (sh - 32u)) - 1u)));
}

// Level-order tree with a rank directory: one bit test and one rank per level.
uint sommRankState(uint blob, uint level, uint format, uint index) {
  if (level == 0u) return sommValue(blob, 0u, format, 0u);
  uint w = sommCountFieldBits(level);
  uint internal = sommBits(blob, 0u, w);
  uint nf = sommBits(blob, w, w);
  uint full = sommBits(blob, 2u * w, 4u);
  uint fl = blob + (2u * w + 4u + 7u) / 8u;
  uint x = ((1u << (2u * full)) - 1u) / 3u + (index >> (2u * (level - full)));
  if (nf <= SOMM_RANK_BLOCK_BITS) {
    uint valueBase = nf;
    for (uint d = full; d < level; ++d) {
      uint wordIndex = x >> 6u;
      uint flag;
      uint r = sommRankInWord(fl + 8u * wordIndex, x & 63u, flag);
      for (uint k = 0u; k < wordIndex; ++k) r += uint(bitCount(sommRead32(fl + 8u * k))) + uint(bitCount(sommRead32(fl + 8u * k + 4u)));
      if (flag == 0u) return sommValue(fl, valueBase, format, x - r);
      x = 1u + 4u * r + sommDigit(index, level, d);
    }
    return sommValue(fl, valueBase, format, x - internal);
  }
  bool wide = internal >= 65536u;
  uint headerBits = (wide ? 32u : 16u) + 24u;
  uint blockBytes = (SOMM_RANK_BLOCK_BITS + headerBits) / 8u;  // 37 or 39
  uint headerBytes = headerBits / 8u;                          // 5 or 7
  uint valueBase = nf + ((nf + SOMM_RANK_BLOCK_BITS - 1u) / SOMM_RANK_BLOCK_BITS) * headerBits;
  for (uint d = full; d < level; ++d) {
    uint block = fl + (x / SOMM_RANK_BLOCK_BITS) * blockBytes;
    uint wi = (x >> 6u) & 3u;
    uint r = wide ? sommRead32(block) : sommRead16(block);
    if (wi != 0u) r += sommByte(block + headerBytes - 4u + wi);
    uint flag;
    r += sommRankInWord(block + headerBytes + 8u * wi, x & 63u, flag);
    if (flag == 0u) return sommValue(fl, valueBase, format, x - r);
    x = 1u + 4u * r + sommDigit(index, level, d);
  }
  return sommValue(fl, valueBase, format, x - internal);
}

// ---- the array-wide DAGs (docs/encodings.md, "csm" and "sdag"); `data` = byte address of the array's data ----
// csm (Chernaik, Modisett & Billeter, HPG 2026): 16-way nodes = u16 child mask (absent child = transparent) + one
// u32 data offset per present child; leaves of 16 states; odd levels ≥ 3 start with a 4-way root.
uint sommCsmState(uint data, uint offset, uint level, uint format, uint index) {
  uint p = data + offset;
  if (level <= 1u) return sommValue(p, 0u, format, index);
  uint shift = 2u * level;
  if ((level & 1u) != 0u) {
    shift -= 2u;
    uint slot = index >> shift;
    uint m = sommRead16(p);
    if (((m >> slot) & 1u) == 0u) return SOMM_STATE_TRANSPARENT;
    p = data + sommRead32(p + 2u + 4u * uint(bitCount(m & ((1u << slot) - 1u))));
  }
  while (shift > 4u) {
    shift -= 4u;
    uint slot = (index >> shift) & 15u;
    uint m = sommRead16(p);
    if (((m >> slot) & 1u) == 0u) return SOMM_STATE_TRANSPARENT;
    p = data + sommRead32(p + 2u + 4u * uint(bitCount(m & ((1u << slot) - 1u))));
  }
  return sommValue(p, 0u, format, index & 15u);
}

// sdag: the data starts with an 80-byte directory (u32 base[13], u8 width[12], u8 tier[12], 4 zero bytes); node
// records hold a u16 mask (1 = child is a node), the uniform children's states, then the references to the node
// children: width bits each, or — when the child region's tier t > 0 — one flag bit per node child (1 = short)
// followed by the references, short ones t-1 bits, long ones width bits.
uint sommSdagRegion(uint format, uint height) { return (format - 1u) * 6u + height - 1u; }
uint sommSdagChild(uint data, uint format, uint height, uint ref) {
  uint base = sommRead32(data + 4u * sommSdagRegion(format, height));
  return data + base + (height == 1u ? ref * 2u * format : ref);  // leaves: 2b bytes (b = format)
}
uint sommSdagWidth(uint data, uint format, uint height) { return sommByte(data + 52u + sommSdagRegion(format, height)); }
uint sommSdagTier(uint data, uint format, uint height) { return sommByte(data + 64u + sommSdagRegion(format, height)); }
// Reference number i of the n node children whose references start at bit `pos` of the record at p.
uint sommSdagRef(uint data, uint p, uint pos, uint n, uint i, uint format, uint height) {
  uint w = sommSdagWidth(data, format, height);
  uint t = sommSdagTier(data, format, height);
  if (t == 0u) return sommBits32(p, pos + w * i, w);
  uint fl = sommBits(p, pos, n);
  uint s = uint(bitCount(fl & ((1u << i) - 1u)));
  return sommBits32(p, pos + n + (t - 1u) * s + w * (i - s), ((fl >> i) & 1u) != 0u ? t - 1u : w);
}

uint sommSdagState(uint data, uint offset, uint level, uint format, uint index) {
  uint p = data + offset;
  if (level <= 1u) return sommValue(p, 0u, format, index);
  uint b = format;  // bits per state
  uint shift = 2u * level;
  uint h = level >> 1u;
  if ((level & 1u) != 0u) {  // 4-way root: M in bits 0..3, states from bit 4
    shift -= 2u;
    uint slot = index >> shift;
    uint m = sommByte(p) & 15u;
    uint below = uint(bitCount(m & ((1u << slot) - 1u)));
    if (((m >> slot) & 1u) == 0u) return sommValue(p, 4u, format, slot - below);
    uint n = uint(bitCount(m));
    p = sommSdagChild(data, format, h, sommSdagRef(data, p, 4u + b * (4u - n), n, below, format, h));
  }
  while (h >= 2u) {
    shift -= 4u;
    uint slot = (index >> shift) & 15u;
    uint m = sommRead16(p);
    uint below = uint(bitCount(m & ((1u << slot) - 1u)));
    if (((m >> slot) & 1u) == 0u) return sommValue(p, 16u, format, slot - below);
    --h;
    uint n = uint(bitCount(m));
    p = sommSdagChild(data, format, h, sommSdagRef(data, p, 16u + b * (16u - n), n, below, format, h));
  }
  return sommValue(p, 0u, format, index & 15u);
}

// ---- a serialized EncodedArray at byte address `base` (docs/encodings.md, "Encoded array") ----
struct SommArray {
  uint encoding;   // SOMM_ENCODING_*
  uint indexSize;  // 2 or 4
  uint triangles;
  uint maps;
  uint indices;      // byte address of the index buffer
  uint descriptors;  // byte address of the descriptors
  uint data;         // byte address of the micromap data
};

SommArray sommArray(uint base) {
  SommArray a;
  a.encoding = sommByte(base + 5u);
  a.indexSize = sommByte(base + 6u);
  a.triangles = sommRead32(base + 8u);
  a.maps = sommRead32(base + 12u);
  a.indices = base + SOMM_ARRAY_HEADER_BYTES;
  a.descriptors = a.indices + a.triangles * a.indexSize;
  a.data = a.descriptors + a.maps * SOMM_DESCRIPTOR_BYTES;
  return a;
}

// The triangle's index-buffer value: a descriptor index, or 0xfffffffc..0xffffffff for the special indices
// -4..-1 (16-bit values 0xfffc..0xffff are widened).
uint sommTriangleIndex(SommArray a, uint tri) {
  if (a.indexSize == 2u) {
    uint i = sommRead16(a.indices + 2u * tri);
    return i >= 0xfffcu ? i | 0xffff0000u : i;
  }
  return sommRead32(a.indices + 4u * tri);
}
bool sommIsSpecial(uint i) { return i >= 0xfffffffcu; }
uint sommSpecialState(uint i) { return 0xffffffffu - i; }  // -1 → 0 transparent, ..., -4 → 3 unknown-opaque

// State of micro-triangle `index` of descriptor `map` (the encoding and kind decide the lookup, as on the CPU:
// hybrid dfs maps use the fast skip).
uint sommMapState(SommArray a, uint map, uint index) {
  uint d = a.descriptors + SOMM_DESCRIPTOR_BYTES * map;
  uint blob = a.data + sommRead32(d);
  uint meta = sommRead32(d + 4u);
  uint level = meta & 0xffu;
  uint format = (meta >> 8u) & 0xffu;
  uint kind = (meta >> 16u) & 0xffu;
  if (kind == SOMM_KIND_RANK) return sommRankState(blob, level, format, index);
  if (kind == SOMM_KIND_CSM) return sommCsmState(a.data, sommRead32(d), level, format, index);
  if (kind == SOMM_KIND_SDAG) return sommSdagState(a.data, sommRead32(d), level, format, index);
  if (kind == SOMM_KIND_DFS)
    return a.encoding == SOMM_ENCODING_DFS ? sommDfsState(blob, level, format, index)
                                           : sommDfsFastState(blob, level, format, index);
  return sommFlatState(blob, level, format, index);
}
uint sommMapLevel(SommArray a, uint map) { return sommByte(a.descriptors + SOMM_DESCRIPTOR_BYTES * map + 4u); }

// EncodedArray::state / stateUV: the state (SOMM_STATE_*) a ray tracer reads, special indices resolved.
uint sommState(SommArray a, uint tri, uint index) {
  uint i = sommTriangleIndex(a, tri);
  if (sommIsSpecial(i)) return sommSpecialState(i);
  return sommMapState(a, i, index);
}
uint sommStateUV(SommArray a, uint tri, float u, float v) {
  uint i = sommTriangleIndex(a, tri);
  if (sommIsSpecial(i)) return sommSpecialState(i);
  return sommMapState(a, i, sommBaryToIndex(u, v, sommMapLevel(a, i)));
}
// Opaque for an any-hit shader: states 1 (opaque) and 3 (unknown-opaque) — the spec's 2-state demotion.
bool sommIsOpaque(uint state) { return (state & 1u) != 0u; }

#endif  // SOMM_GLSL
