// SPDX-License-Identifier: MIT
// somm — succinct micromap encodings with random access (see docs/encodings.md for the exact bit layouts).
//
// Per micromap ("map kind"):
//   flat  — the spec layout (VK_EXT_opacity_micromap): 4^L states, LSB-first.
//   dfs   — Waldemarson & Doggett's tree: uniform equal sibling groups collapsed bottom-up, pre-order
//   bit-vector T
//           (1 = internal, 0 = leaf; nodes at the last level carry a 0 bit so that skipping is pure counting)
//           and the leaf values in the same order. Two lookups over the same bits: the paper's bit-by-bit
//           count (Encoding::Dfs) and a word-at-a-time popcount skip (Encoding::DfsFast).
//   rank  — the same tree in level order (k²-tree / LOUDS style): one flag per node above the last level, a
//   rank
//           directory next to the flags, the children of internal node x at 1 + 4·rank1(x); last-level nodes
//           are plain states without flags. One bit test and one rank per level.
// Per geometry, an EncodedArray holds the spec index buffer, one 8-byte descriptor per unique micromap and
// the encoded data; Encoding::Hybrid chooses per micromap the smallest of flat / dfs / rank (the kind sits in
// the descriptor).
//
// Lookups (state, stateUV) are inline, noexcept, allocation-free and touch only the triangle's index,
// descriptor and micromap bytes. Data words are read with unaligned little-endian 64-bit loads; the data
// buffer ends with kTailPadding zero bytes so that every such load stays inside it.
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <new>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "somm/micromap.h"
#include "somm/omm_array.h"
#include "somm/result.h"
#include "somm/span.h"

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "somm encodings assume a little-endian host"
#endif

namespace somm {

enum class Encoding : uint8_t { Flat = 0, Dfs = 1, DfsFast = 2, Rank = 3, Hybrid = 4, Csm = 5, Sdag = 6 };
inline constexpr Encoding kAllEncodings[] = {Encoding::Flat, Encoding::Dfs,    Encoding::DfsFast,
                                             Encoding::Rank, Encoding::Hybrid, Encoding::Csm,
                                             Encoding::Sdag};
inline constexpr uint32_t kEncodingCount = 7;

// "flat", "dfs", "dfs-fast", "rank", "hybrid", "csm", "sdag".
const char* encodingName(Encoding e) noexcept;
std::optional<Encoding> parseEncodingName(std::string_view name) noexcept;
// A comma-separated list of names or "all" (every encoding, in kAllEncodings order; duplicates removed).
Result<std::vector<Encoding>> parseEncodingList(std::string_view list);

// How one micromap is stored.
// Csm and Sdag maps are roots into the array-wide DAG (docs/encodings.md); the others are self-contained blobs.
enum class MapKind : uint8_t { Flat = 0, Dfs = 1, Rank = 2, Csm = 3, Sdag = 4 };
const char* mapKindName(MapKind k) noexcept;

namespace encode {

inline constexpr uint32_t kTailPadding = 8;        // zero bytes after the data buffer of every non-flat array
inline constexpr uint32_t kRankBlockBits = 256;    // rank directory: one cumulative count per 256 flag bits
inline constexpr uint32_t kArrayHeaderBytes = 20;  // serialized EncodedArray header
inline constexpr uint32_t kDescriptorBytes = 8;

// Width of the count fields in dfs / rank headers: enough for (4^L - 1) / 3, the internal nodes of a full
// tree.
constexpr uint32_t countFieldBits(uint32_t level) noexcept {
  return level == 0 ? 0u : 2u * level - 1u;
}
constexpr uint32_t dfsHeaderBytes(uint32_t level) noexcept {
  return (countFieldBits(level) + 7u) / 8u;
}
// rank header: I and F in W(L) bits each, then 4 bits K = the number of leading levels that are fully
// internal.
constexpr uint32_t rankHeaderBytes(uint32_t level) noexcept {
  return level == 0 ? 0u : (2u * countFieldBits(level) + 4u + 7u) / 8u;
}
// Rank directory (only when the flags span more than one 256-bit block): the flags are stored in blocks of
// 256, each preceded by its header — a counter of c bits (the 1s before the block; c = 16 while the map has
// fewer than 65536 internal nodes, else 32) and three bytes (the 1s in the block before its words 1, 2, 3) —
// so that a rank reads one header and one word, all in the same few bytes.
constexpr uint32_t rankCounterBits(uint64_t internal) noexcept {
  return internal < 65536u ? 16u : 32u;
}
constexpr uint64_t rankBlocks(uint64_t flagBits) noexcept {
  return (flagBits + kRankBlockBits - 1) / kRankBlockBits;
}
constexpr uint32_t rankBlockHeaderBits(uint64_t internal) noexcept {
  return rankCounterBits(internal) + 24u;
}
// Bits of the flag region (flags plus block headers).
constexpr uint64_t rankFlagRegionBits(uint64_t flagBits, uint64_t internal) noexcept {
  return rankBlocks(flagBits) <= 1 ? flagBits
                                   : flagBits + rankBlocks(flagBits) * rankBlockHeaderBits(internal);
}
// Bit position of flag x in the flag region.
constexpr uint64_t rankFlagPosition(uint64_t x, uint64_t flagBits, uint64_t internal) noexcept {
  if (rankBlocks(flagBits) <= 1) return x;
  const uint64_t h = rankBlockHeaderBits(internal);
  return (x / kRankBlockBits) * (kRankBlockBits + h) + h + x % kRankBlockBits;
}

// The shape of a map's collapsed tree: internal nodes in total and at depth level-1 (whose children are
// last-level nodes). Leaves = 3·internal + 1; dfs bits T = 4·internal + 1; rank flags = 1 + 4·(internal -
// internalAtLastParent) (zero at level 0).
struct TreeShape {
  uint64_t internal = 0;
  uint64_t internalAboveLast = 0;  // internal nodes at depth level-1
};
TreeShape treeShape(const Micromap& map);

// Exact byte sizes of one encoded micromap (docs/encodings.md).
constexpr uint64_t flatMapBytes(uint32_t level, Format f) noexcept {
  return micromapDataBytes(level, f);
}
constexpr uint64_t dfsMapBytes(uint32_t level, Format f, const TreeShape& s) noexcept {
  const uint64_t bits = 4 * s.internal + 1 + uint64_t(bitsPerState(f)) * (3 * s.internal + 1);
  return dfsHeaderBytes(level) + (bits + 7) / 8;
}
constexpr uint64_t rankFlagBits(uint32_t level, const TreeShape& s) noexcept {
  return level == 0 ? 0 : 1 + 4 * (s.internal - s.internalAboveLast);
}
constexpr uint64_t rankMapBytes(uint32_t level, Format f, const TreeShape& s) noexcept {
  const uint64_t nf = rankFlagBits(level, s);
  const uint64_t bits = rankFlagRegionBits(nf, s.internal) + uint64_t(bitsPerState(f)) * (3 * s.internal + 1);
  return rankHeaderBytes(level) + (bits + 7) / 8;
}

// ---- bit access (little-endian, LSB-first) ----
// Population count without a library call: the popcnt instruction when the build targets it (-mpopcnt,
// -march=x86-64-v2 or later), otherwise SWAR (std::popcount / __builtin_popcountll would call libgcc's __popcountdi2 on baseline
// x86-64).
inline uint32_t popcount64(uint64_t x) noexcept {
#if (defined(__GNUC__) || defined(__clang__)) && \
    (defined(__POPCNT__) || !(defined(__x86_64__) || defined(__i386__)))
  return uint32_t(__builtin_popcountll(x));
#else
  x = x - ((x >> 1) & 0x5555555555555555ull);
  x = (x & 0x3333333333333333ull) + ((x >> 2) & 0x3333333333333333ull);
  x = (x + (x >> 4)) & 0x0f0f0f0f0f0f0f0full;
  return uint32_t((x * 0x0101010101010101ull) >> 56);
#endif
}
inline constexpr auto kBytePopcount = [] {
  std::array<uint8_t, 256> t{};
  for (int b = 0; b < 256; ++b)
    t[size_t(b)] = uint8_t((b & 1) + (b >> 1 & 1) + (b >> 2 & 1) + (b >> 3 & 1) + (b >> 4 & 1) +
                           (b >> 5 & 1) + (b >> 6 & 1) + (b >> 7 & 1));
  return t;
}();

// Forced inlining for the small steps of the DAG walks (the compiler otherwise keeps some out of line).
#if defined(__GNUC__) || defined(__clang__)
#define SOMM_ENCODE_INLINE __attribute__((always_inline)) inline
#define SOMM_ENCODE_COLD __attribute__((noinline, cold))
#elif defined(_MSC_VER)
#define SOMM_ENCODE_INLINE __forceinline
#define SOMM_ENCODE_COLD __declspec(noinline)
#else
#define SOMM_ENCODE_INLINE inline
#define SOMM_ENCODE_COLD
#endif

// Population count of a 16-bit value (DAG masks and flags): the instruction when the build targets it, else two
// table reads (shorter latency than the 64-bit SWAR on the DAG walks' dependent chains).
SOMM_ENCODE_INLINE uint32_t popcount16(uint32_t x) noexcept {
#if (defined(__GNUC__) || defined(__clang__)) && \
    (defined(__POPCNT__) || !(defined(__x86_64__) || defined(__i386__)))
  return uint32_t(__builtin_popcount(x));
#else
  return uint32_t(kBytePopcount[x & 0xffu]) + kBytePopcount[(x >> 8) & 0xffu];
#endif
}

inline uint64_t load64(const uint8_t* p) noexcept {
  uint64_t w;
  std::memcpy(&w, p, 8);
  return w;
}
SOMM_ENCODE_INLINE uint32_t getBit(const uint8_t* p, uint64_t bit) noexcept {
  return (p[bit >> 3] >> (bit & 7u)) & 1u;
}
// n <= 32 bits starting at bit offset `bit`; reads 8 bytes from byte bit/8.
SOMM_ENCODE_INLINE uint32_t getBits(const uint8_t* p, uint64_t bit, uint32_t n) noexcept {
  return uint32_t((load64(p + (bit >> 3)) >> (bit & 7u)) & ((uint64_t(1) << n) - 1u));
}
inline State getValue(const uint8_t* p, uint64_t base, Format f, uint64_t i) noexcept {
  if (f == Format::TwoState) return State(getBit(p, base + i));
  const uint64_t b = base + 2 * i;  // may straddle a byte when base is odd
  return State(((uint32_t(p[b >> 3]) | uint32_t(p[(b >> 3) + 1]) << 8) >> (b & 7u)) & 3u);
}
inline uint32_t digitAt(uint32_t index, uint32_t level, uint32_t depth) noexcept {
  return (index >> (2u * (level - 1u - depth))) & 3u;
}

// ---- per-map lookups (blob = first byte of the encoded micromap) ----
inline State flatState(const uint8_t* blob, uint32_t /*level*/, Format f, uint32_t index) noexcept {
  return readPackedState(blob, f, index);
}

// For the word-at-a-time skip: kSkipEnd[n-1][b] is the bit (1..8) of byte b (LSB first) at which a pending
// count of n (1..8) reaches zero — each 1 adds three, each 0 removes one — or 0 if it stays positive over all
// 8 bits. A count above 8 cannot reach zero within a byte.
inline constexpr auto kSkipEnd = [] {
  std::array<std::array<uint8_t, 256>, 8> t{};
  for (int n = 1; n <= 8; ++n)
    for (int b = 0; b < 256; ++b) {
      int need = n;
      for (int i = 0; i < 8; ++i) {
        need += ((b >> i) & 1) ? 3 : -1;
        if (need == 0) {
          t[size_t(n - 1)][size_t(b)] = uint8_t(i + 1);
          break;
        }
      }
    }
  return t;
}();

// The paper's lookup (dfsState): descend; at an internal node skip the earlier sibling subtrees bit by bit,
// counting: each bit consumes one pending node, a 1 adds four, a 0 is a leaf. dfsFastState walks the same bits, but
// after bit steps up to a byte boundary it takes a whole 64-bit word at once (popcount) at word boundaries when the
// pending count exceeds the word's zeros — each 0 lowers the count by one, so it cannot reach zero inside — and
// otherwise a byte at a time (kSkipEnd finds where the skip ends inside the last byte).
template <bool Fast>
inline State dfsWalk(const uint8_t* blob, uint32_t level, Format f, uint32_t index) noexcept {
  const uint32_t w = countFieldBits(level);
  const uint64_t internal = w ? getBits(blob, 0, w) : 0;
  const uint8_t* t = blob + dfsHeaderBytes(level);
  uint64_t pos = 0, leaf = 0;
  for (uint32_t d = 0; d < level; ++d) {
    if (!getBit(t, pos)) break;
    ++pos;
    uint64_t need = digitAt(index, level, d);
    while (need != 0 && (!Fast || (pos & 7u) != 0)) {
      const uint32_t b = getBit(t, pos++);
      need = need - 1 + 4 * b;
      leaf += 1 - b;
    }
    if constexpr (Fast) {
      while (need != 0) {
        if ((pos & 63u) == 0) {
          const uint32_t ones = popcount64(load64(t + (pos >> 3)));
          if (need > 64u - ones) {
            need = need + 4 * ones - 64;
            leaf += 64 - ones;
            pos += 64;
            continue;
          }
        }
        const uint32_t byte = t[pos >> 3];
        if (need <= 8) {
          const uint32_t end = kSkipEnd[need - 1][byte];
          if (end != 0) {
            leaf += end - kBytePopcount[byte & ((1u << end) - 1u)];
            pos += end;
            break;
          }
        }
        const uint32_t p = kBytePopcount[byte];
        need = need + 4 * p - 8;
        leaf += 8 - p;
        pos += 8;
      }
    }
  }
  return getValue(t, 4 * internal + 1, f, leaf);
}
inline State dfsState(const uint8_t* blob, uint32_t level, Format f, uint32_t index) noexcept {
  return dfsWalk<false>(blob, level, f, index);
}
inline State dfsFastState(const uint8_t* blob, uint32_t level, Format f, uint32_t index) noexcept {
  return dfsWalk<true>(blob, level, f, index);
}

// Level-order tree: flag bit x (1 = internal) for nodes above the last level, children of x at 1 +
// 4·rank1(x), value of leaf x at x - rank1(min(x, flags)).
inline State rankState(const uint8_t* blob, uint32_t level, Format f, uint32_t index) noexcept {
  if (level == 0) return getValue(blob, 0, f, 0);
  const uint32_t w = countFieldBits(level);
  const uint64_t internal = getBits(blob, 0, w);
  const uint64_t nf = getBits(blob, w, w);
  const uint32_t full = getBits(blob, 2 * w, 4);  // levels 0..full-1 are all internal: jump to depth `full`
  const uint8_t* fl = blob + rankHeaderBytes(level);
  const uint64_t valueBase = rankFlagRegionBits(nf, internal);
  uint64_t x = ((uint64_t(1) << (2 * full)) - 1) / 3 + (uint64_t(index) >> (2 * (level - full)));
  if (nf <= kRankBlockBits) {  // one block, no directory: popcount the (at most three) earlier words
    for (uint32_t d = full; d < level; ++d) {
      const uint64_t wordIndex = x >> 6;
      const uint64_t word = load64(fl + (wordIndex << 3));
      const uint32_t sh = uint32_t(x & 63u);
      uint64_t r = popcount64(word & ((uint64_t(1) << sh) - 1u));
      for (uint64_t k = 0; k < wordIndex; ++k) r += popcount64(load64(fl + (k << 3)));
      if (!((word >> sh) & 1u)) return getValue(fl, valueBase, f, x - r);
      x = 1 + 4 * r + digitAt(index, level, d);
    }
    return getValue(fl, valueBase, f, x - internal);
  }
  const bool wide = internal >= 65536u;
  const uint64_t blockBytes = (kRankBlockBits + rankBlockHeaderBits(internal)) / 8;  // 37 or 39
  const uint32_t headerBytes = rankBlockHeaderBits(internal) / 8;                    // 5 or 7
  for (uint32_t d = full; d < level; ++d) {
    const uint8_t* block = fl + (x / kRankBlockBits) * blockBytes;
    const uint32_t wi = uint32_t(x >> 6) & 3u;
    uint64_t r = wide ? (uint64_t(block[0]) | uint64_t(block[1]) << 8 | uint64_t(block[2]) << 16 |
                         uint64_t(block[3]) << 24)
                      : (uint64_t(block[0]) | uint64_t(block[1]) << 8);
    if (wi != 0) r += block[headerBytes - 4 + wi];
    const uint64_t word = load64(block + headerBytes + 8 * wi);
    const uint32_t sh = uint32_t(x & 63u);
    r += popcount64(word & ((uint64_t(1) << sh) - 1u));
    if (!((word >> sh) & 1u)) return getValue(fl, valueBase, f, x - r);
    x = 1 + 4 * r + digitAt(index, level, d);
  }
  return getValue(fl, valueBase, f, x - internal);
}

// ---- array-wide DAGs: csm (Chernaik, Modisett & Billeter, HPG 2026) and sdag (ours) ----
//
// Both cut a map's quadtree into 16-way nodes of two levels each, aligned at the bottom: a "leaf" holds the 16
// states of a level-2 subtree, a node of height h (>= 2) has 16 children of height h-1, each covering 16^(h-1)
// micro-triangles; child `slot` of the node met at bird-curve index bits [s, s+4) is (index >> s) & 15 (the
// unmodified index, 4 bits per DAG level). A map of odd level L >= 3 has a 4-way root (2 index bits, children of
// height (L-1)/2); levels 0 and 1 are one byte of states. Identical subtrees of every map of the array (one
// array = the scene) are stored once (hash-consing).
inline uint32_t load16(const uint8_t* p) noexcept {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8;
}
inline uint32_t load32(const uint8_t* p) noexcept {
  uint32_t w;
  std::memcpy(&w, p, 4);
  return w;
}
inline State packedState(const uint8_t* p, Format f, uint32_t i) noexcept {
  return getValue(p, 0, f, i);
}

// csm: node = u16 child mask (1 = child present; absent = fully transparent) + one u32 byte offset (into the
// array's data buffer) per present child in slot order; leaf = 16 states (2 or 4 bytes). Uniform non-transparent
// subtrees are ordinary (shared) nodes. `data` = the array's data buffer, `offset` = the map's root.
inline State csmState(const uint8_t* data, uint32_t offset, uint32_t level, Format f,
                      uint32_t index) noexcept {
  const uint8_t* p = data + offset;
  if (level <= 1) return getValue(p, 0, f, index);
  uint32_t shift = 2 * level;
  if (level & 1u) {
    shift -= 2;
    const uint32_t slot = index >> shift, m = load16(p);
    if (!((m >> slot) & 1u)) return State::Transparent;
    p = data + load32(p + 2 + 4 * popcount64(m & ((1u << slot) - 1u)));
  }
  while (shift > 4) {
    shift -= 4;
    const uint32_t slot = (index >> shift) & 15u, m = load16(p);
    if (!((m >> slot) & 1u)) return State::Transparent;
    p = data + load32(p + 2 + 4 * popcount64(m & ((1u << slot) - 1u)));
  }
  return getValue(p, 0, f, index & 15u);
}

// sdag: the data buffer starts with a 104-byte directory: u32 base[13] (byte offset of region k = (format-1)·6 +
// height-1, base[12] = end of the regions), u8 width[12] (bits of a long reference into region k), u8 tier[12] (0:
// every reference into region k is long; t > 0: each is short, t-1 bits, or not), u8 mid[12] (0: a reference that
// is not short is long; u > t: it is mid, u-1 bits, or long), u8 local[12] (1: a long reference into region k is
// local: the child's byte offset from the referring record's first byte) and 4 zero bytes. A node of height h:
// u16 mask M (1 = child is a node), the states of the uniform children (M bit 0; transparent / opaque, 1 bit each; a
// uniformly unknown child is a node child) — unless M is full, a bit E then one state for all of them (E = 0) or
// one per uniform child in slot order (E = 1; version 7) —, then the references of the node children in
// slot order — when region (f, h-1) is tiered first one flag bit per node child (F, 1 = short), with a mid class
// then one bit per node child that is not short (G, 1 = mid), then the references —: short and mid ones (and long
// ones without the local flag) a leaf number in region (f, 1) (leaves are 2b bytes) or a byte offset into region
// (f, h-1); byte-aligned records. A record referenced once (from a node record) may be local: stored right after
// its parent (pre-order, in slot order) instead of in its region. Records are sorted by use, so the most used
// ones have the small (short, mid) references. The mask and the flags are the node's rank directory: the child's
// state or reference sits at popcount(M below the slot), and a reference's bit position at popcounts of F and G
// below it — counts and the bits they count are in the same record.
inline constexpr uint32_t kSdagDirectoryBytes = 104;
inline constexpr uint32_t kSdagRegions = 12;
constexpr uint32_t sdagRegion(Format f, uint32_t height) noexcept {
  return (uint32_t(f) - 1u) * 6u + height - 1u;
}
struct SdagDirectory {
  uint32_t base[kSdagRegions + 1] = {};
  uint8_t width[kSdagRegions] = {};
  uint8_t tier[kSdagRegions] = {};
  uint8_t mid[kSdagRegions] = {};
  uint8_t local[kSdagRegions] = {};  // 1: the long class of references into region k is local (version 6)
  // xform[f - 1] = 1: every region reference into the leaf region of format f carries a leaf transform in its
  // low 4 bits (version 8; bytes 100, 101 of the directory); [2], [3] are zero.
  uint8_t xform[4] = {};
  friend bool operator==(const SdagDirectory& a, const SdagDirectory& b) noexcept {
    return std::memcmp(&a, &b, sizeof(SdagDirectory)) == 0;
  }
};
// A leaf handle (what the walk and its memo keep for a leaf): the leaf's byte offset in the data, with T in bits
// 28..31 when the leaf region has transforms (an array with transforms has less than 2^28 data bytes).
inline constexpr uint32_t kSdagLeafTShift = 28, kSdagLeafOffsetMask = (1u << kSdagLeafTShift) - 1u;
// The handle of the leaf that region reference `ref` into leaf region k (leaves of leafBytes) names: the leaf number,
// with transforms (xform) shifted past T in the low 4 bits.
SOMM_ENCODE_INLINE uint32_t sdagLeafRegionHandle(const SdagDirectory& dir, uint32_t k, uint32_t ref,
                                                 uint32_t leafBytes) noexcept {
  const uint32_t sh = dir.xform[k / 6u] != 0 ? 4u : 0u;
  return (dir.base[k] + (ref >> sh) * leafBytes) | ((ref & ((1u << sh) - 1u)) << kSdagLeafTShift);
}
// Reference number i of the n node children of a record whose references (with their flags) start at bit `pos`
// (w, tier, mid: of the region referred to), and whether it is of the long class (width w: neither short nor mid),
// which is a local reference (a byte offset from the record's first byte) when the region's local flag is set.
struct SdagRefClass {
  uint32_t ref;
  uint32_t isLong;  // 1 = long class
};
// bit ? a : b without a branch (bit is 0 or 1; the reference widths depend on the data, a branch mispredicts).
SOMM_ENCODE_INLINE uint32_t sdagPick(uint32_t bit, uint32_t a, uint32_t b) noexcept {
  return b ^ ((a ^ b) & (0u - bit));
}
// The uniform-states field of a 16-slot node record with n node children (version 7), from bit 16: none when every
// child is a node (n = 16); otherwise bit 16 is E: E = 0, one state bit (bit 17) for every uniform child; E = 1, one
// bit per uniform child in slot order from bit 17. Its length in bits: 0, 2 or 1 + (16 - n). e: bit 16.
SOMM_ENCODE_INLINE uint32_t sdagStatesBits(uint32_t n, uint32_t e) noexcept {
  return n == 16u ? 0u : sdagPick(e, 17u - n, 2u);
}
// The record's bits from bit pos on (at least 56 of them), in one unaligned load.
SOMM_ENCODE_INLINE uint64_t sdagBitsFrom(const uint8_t* p, uint32_t pos) noexcept {
  return load64(p + (pos >> 3)) >> (pos & 7u);
}
// x: the record's bits from bit pos on (at least 3n of them: the flag vectors).
SOMM_ENCODE_INLINE SdagRefClass sdagRefClass(const uint8_t* p, uint32_t pos, uint32_t n, uint32_t i,
                                             uint32_t w, uint32_t tier, uint32_t mid, uint64_t x) noexcept {
  if (tier == 0) return {getBits(p, pos + w * i, w), 1u};
  const uint32_t sw = tier - 1u, fl = uint32_t(x) & ((1u << n) - 1u), s = popcount16(fl & ((1u << i) - 1u)),
                 q = i - s;
  const uint32_t isShort = (fl >> i) & 1u;
  if (mid == 0) return {getBits(p, pos + n + sw * s + w * q, sdagPick(isShort, sw, w)), isShort ^ 1u};
  const uint32_t longOrMid = n - popcount16(fl), g = uint32_t(x >> n) & ((1u << longOrMid) - 1u),
                 gb = popcount16(g & ((1u << q) - 1u)), mw = mid - 1u, isMid = (g >> q) & 1u & (isShort ^ 1u);
  const uint32_t at = pos + n + longOrMid + sw * s + mw * gb + w * (q - gb);
  return {getBits(p, at, sdagPick(isShort, sw, sdagPick(isMid, mw, w))), (isShort | isMid) ^ 1u};
}
// A reference into a leaf region with the local flag: a third flag vector H follows F and G, one bit per reference
// that is neither short nor mid (1 = local); local references take no bits: the record's local leaves are stored
// right before it in slot order, so local leaf j of the record's Lt is (Lt - j)·2b bytes before it. Returns
// isLong = 1 and ref = Lt - j for a local leaf, else the leaf number.
SOMM_ENCODE_INLINE SdagRefClass sdagLeafRefClass(const uint8_t* p, uint32_t pos, uint32_t n, uint32_t i,
                                                 uint32_t w, uint32_t tier, uint32_t mid,
                                                 uint64_t x) noexcept {
  const uint32_t below = (1u << i) - 1u;
  if (tier == 0) {  // every reference is long (no F, no G): H alone
    const uint32_t hh = uint32_t(x) & ((1u << n) - 1u), hb = popcount16(hh & below);
    if ((hh >> i) & 1u) return {popcount16(hh) - hb, 1u};
    return {getBits(p, pos + n + w * (i - hb), w), 0u};
  }
  const uint32_t fl = uint32_t(x) & ((1u << n) - 1u), s = popcount16(fl & below), q = i - s;
  const uint32_t isShort = (fl >> i) & 1u, r = n - popcount16(fl);
  const uint32_t gn = mid != 0 ? r : 0u;  // G's length
  const uint32_t g = uint32_t(x >> n) & ((1u << gn) - 1u), gb = popcount16(g & ((1u << q) - 1u));
  const uint32_t isMid = (g >> q) & 1u & (isShort ^ 1u), r2 = r - popcount16(g), o = q - gb;
  const uint32_t hh = uint32_t(x >> (n + gn)) & ((1u << r2) - 1u), hb = popcount16(hh & ((1u << o) - 1u));
  const uint32_t isLocal = (hh >> o) & 1u & ((isShort | isMid) ^ 1u);
  const uint32_t sw = tier - 1u, mw = mid != 0 ? mid - 1u : 0u;
  const uint32_t refAt = pos + n + gn + r2 + sw * s + mw * gb + w * (o - hb);
  const uint32_t ref =
      getBits(p, refAt, sdagPick(isShort, sw, sdagPick(isMid, mw, sdagPick(isLocal, 0u, w))));
  return {sdagPick(isLocal, popcount16(hh) - hb, ref), isLocal};
}
// The same reading the flags from p at bit pos.
SOMM_ENCODE_INLINE SdagRefClass sdagRefClass(const uint8_t* p, uint32_t pos, uint32_t n, uint32_t i,
                                             uint32_t w, uint32_t tier, uint32_t mid) noexcept {
  return sdagRefClass(p, pos, n, i, w, tier, mid, sdagBitsFrom(p, pos));
}
SOMM_ENCODE_INLINE SdagRefClass sdagLeafRefClass(const uint8_t* p, uint32_t pos, uint32_t n, uint32_t i,
                                                 uint32_t w, uint32_t tier, uint32_t mid) noexcept {
  return sdagLeafRefClass(p, pos, n, i, w, tier, mid, sdagBitsFrom(p, pos));
}
// The byte offset (in the data) of the child that reference number i of the record at byte offset `at` (p) refers
// to, in region k (leafBytes: 2b for a leaf region, 0 for a node region): a local node is at a byte offset from
// the record, a local leaf before it, the others in the region.
// x: the record's bits from bit pos on (the flags: 3n <= 48 bits).
SOMM_ENCODE_INLINE uint32_t sdagChildAt(const SdagDirectory& dir, const uint8_t* p, uint32_t at, uint32_t pos,
                                        uint32_t n, uint32_t i, uint32_t k, uint32_t leafBytes,
                                        uint64_t x) noexcept {
  const uint32_t w = dir.width[k], t = dir.tier[k], u = dir.mid[k];
  if (leafBytes != 0) {  // a leaf handle
    if (dir.local[k] != 0) {
      const SdagRefClass r = sdagLeafRefClass(p, pos, n, i, w, t, u, x);
      return sdagPick(r.isLong, at - r.ref * leafBytes, sdagLeafRegionHandle(dir, k, r.ref, leafBytes));
    }
    return sdagLeafRegionHandle(dir, k, sdagRefClass(p, pos, n, i, w, t, u, x).ref, leafBytes);
  }
  const SdagRefClass r = sdagRefClass(p, pos, n, i, w, t, u, x);
  return sdagPick(r.isLong & dir.local[k], at + r.ref, dir.base[k] + r.ref);
}
SOMM_ENCODE_INLINE uint32_t sdagChildAt(const SdagDirectory& dir, const uint8_t* p, uint32_t at, uint32_t pos,
                                        uint32_t n, uint32_t i, uint32_t k, uint32_t leafBytes) noexcept {
  return sdagChildAt(dir, p, at, pos, n, i, k, leafBytes, sdagBitsFrom(p, pos));
}
// Where the flags (and references) of a 16-slot node record with n node children start (pos = 16 + the states
// field's length), and the record's bits from there: one load from byte 2, independent of the mask (the states field
// skipped, 0, 2 or 17 - n bits, leaves at least 47 + n >= 3n bits: the flag vectors).
struct SdagFlags {
  uint32_t pos;
  uint64_t x;
};
// y: the record's bits from bit 16 (load64(p + 2)).
SOMM_ENCODE_INLINE SdagFlags sdagFlagsFrom(uint64_t y, uint32_t n) noexcept {
  const uint32_t sl = sdagStatesBits(n, uint32_t(y) & 1u);
  return {16u + sl, y >> sl};
}
SOMM_ENCODE_INLINE SdagFlags sdagNodeFlags(const uint8_t* p, uint32_t n) noexcept {
  return sdagFlagsFrom(load64(p + 2), n);
}
// The state (0 or 1) of uniform child number u of such a record, from its bits y from bit 16 (bit 17 + u of the
// record when E = 1, else bit 17): no load of its own.
SOMM_ENCODE_INLINE uint32_t sdagUniformState(uint64_t y, uint32_t u) noexcept {
  return uint32_t(y >> (1u + sdagPick(uint32_t(y) & 1u, u, 0u))) & 1u;
}
// Bits of the references (with their flags) of such a record (h: with the H flags of a local leaf region).
inline uint32_t sdagRefBits(const uint8_t* p, uint32_t pos, uint32_t n, uint32_t w, uint32_t tier,
                            uint32_t mid, bool h = false) noexcept {
  if (h) {
    const uint32_t s = tier != 0 ? popcount64(getBits(p, pos, n)) : 0u, f = tier != 0 ? n : 0u;
    const uint32_t g = mid != 0 ? popcount64(getBits(p, pos + f, n - s)) : 0u, gl = mid != 0 ? n - s : 0u;
    const uint32_t r2 = n - s - g, loc = popcount64(getBits(p, pos + f + gl, r2));
    return f + gl + r2 + (tier != 0 ? tier - 1u : 0u) * s + (mid != 0 ? mid - 1u : 0u) * g + w * (r2 - loc);
  }
  if (tier == 0) return w * n;
  const uint32_t s = popcount64(getBits(p, pos, n));
  if (mid == 0) return n + (tier - 1u) * s + w * (n - s);
  const uint32_t g = popcount64(getBits(p, pos + n, n - s));
  return n + (n - s) + (tier - 1u) * s + (mid - 1u) * g + w * (n - s - g);
}
// Leaf transforms (version 8): T = p | c << 3 with p < 6 one of the six symmetries of the leaf's triangle (its
// vertices permuted) and c a complement (every state xor 1: transparent <-> opaque, unknown-transparent <->
// unknown-opaque). State i of a leaf reached with T is state j = nibble i of kSdagLeafPerm[p] of the stored 16
// states, xor c. Row p maps micro-triangle i of the bird curve at level 2 to the one holding the barycentric
// centroid of i with its weights permuted: (w0, w1, w2) -> (w0, w1, w2), (w0, w2, w1), (w1, w0, w2),
// (w1, w2, w0), (w2, w0, w1), (w2, w1, w0) (tests/encode: EncodeDag.LeafSymmetriesFollowTheBirdCurve). Rows 6
// and 7 are the identity (never stored: the array's validation refuses them).
inline constexpr uint64_t kSdagLeafPerm[8] = {0xfedcba9876543210u, 0xa89bcfde46572310u, 0xfcde30127456b89au,
                                              0xab9820134756cedfu, 0x0213efdc64578b9au, 0x03128a9b6754ecdfu,
                                              0xfedcba9876543210u, 0xfedcba9876543210u};
// State `slot` (< 16) of a leaf (16 states, 2 or 4 bytes) reached with transform t: one load and two shifts.
template <Format F>
SOMM_ENCODE_INLINE State sdagLeafState(const uint8_t* leaf, uint32_t slot, uint32_t t = 0) noexcept {
  const uint32_t j = uint32_t(kSdagLeafPerm[t & 7u] >> (4u * slot)) & 15u, c = t >> 3;
  if constexpr (F == Format::TwoState) return State(((load16(leaf) >> j) & 1u) ^ c);
  return State(((load32(leaf) >> (2u * j)) & 3u) ^ c);
}
// A leaf reached by a walk step: where it is and its transform.
struct SdagLeafAt {
  const uint8_t* p;
  uint32_t t;
};
// The leaf with handle a of format f's leaf region (see kSdagLeafTShift).
SOMM_ENCODE_INLINE SdagLeafAt sdagLeafOf(const uint8_t* data, const SdagDirectory& dir, Format f,
                                         uint32_t a) noexcept {
  const uint32_t xf = dir.xform[uint32_t(f) - 1u];
  return {data + sdagPick(xf, a & kSdagLeafOffsetMask, a), sdagPick(xf, a >> kSdagLeafTShift, 0u)};
}
// The state `slot` of the leaf with handle a.
template <Format F>
SOMM_ENCODE_INLINE State sdagHandleState(const uint8_t* data, const SdagDirectory& dir, uint32_t a,
                                         uint32_t slot) noexcept {
  const SdagLeafAt l = sdagLeafOf(data, dir, F, a);
  return sdagLeafState<F>(l.p, slot, l.t);
}
// The leaf that node child number i (of n) of the height-2 record at p refers to, when the leaf region has short
// references (F) and local leaves (H), with a mid class (G) or without (kMid): the leaf regions of the real arrays
// measured (single models: F and H; whole scenes: F, G and H). The same reading as sdagLeafRefClass + sdagChildAt,
// with the references' start fixed (after F, G and H: pos + n + the lengths of G and H) and
// fewer values alive; a local leaf returns early (a branch: fewer instructions, measured no slower than a select).
// pos, x: where the flags start (F, G, H) and the record's bits from there.
template <Format F, bool kMid>
SOMM_ENCODE_INLINE SdagLeafAt sdagLocalLeaf(const uint8_t* data, const SdagDirectory& dir, const uint8_t* p,
                                            uint32_t n, uint32_t i, uint32_t pos, uint64_t x) noexcept {
  constexpr uint32_t leafBytes = F == Format::TwoState ? 2u : 4u, k = sdagRegion(F, 1);
  const uint32_t fl = uint32_t(x) & ((1u << n) - 1u), s = popcount16(fl & ((1u << i) - 1u));
  const uint32_t isShort = (fl >> i) & 1u, r = n - popcount16(fl), q = i - s;
  // G's length, its set bits before reference q, bit q; r2: the references neither short nor mid (H's length)
  uint32_t gl = 0, gb = 0, isMid = 0, r2 = r;
  if constexpr (kMid) {
    const uint32_t g = uint32_t(x >> n) & ((1u << r) - 1u);
    gl = r;
    gb = popcount16(g & ((1u << q) - 1u));
    isMid = (g >> q) & 1u & (isShort ^ 1u);
    r2 = r - popcount16(g);
  }
  const uint32_t o = q - gb;
  const uint32_t hh = uint32_t(x >> (n + gl)) & ((1u << r2) - 1u), hb = popcount16(hh & ((1u << o) - 1u));
  if ((hh >> o) & 1u & ((isShort | isMid) ^ 1u))
    return {p - (popcount16(hh) - hb) * leafBytes, 0u};  // a local leaf
  const uint32_t sw = dir.tier[k] - 1u, mw = dir.mid[k] - 1u, w = dir.width[k];
  const uint32_t at = pos + n + gl + r2 + sw * s + (kMid ? mw * gb : 0u) + w * (o - hb);
  const uint32_t ref = getBits(p, at, isShort ? sw : (isMid ? mw : w));
  const uint32_t sh = dir.xform[uint32_t(F) - 1u] != 0 ? 4u : 0u;  // with transforms: T in the low 4 bits
  return {data + dir.base[k] + (ref >> sh) * leafBytes, ref & ((1u << sh) - 1u)};
}
// The child that node child number i (of n) of the node record at p (height >= 3) refers to, when the child region
// k has local references and no mid class, with short references (kTier: the flags F from bit pos, then the
// references from bit pos + n) or without (every reference local, from bit pos): the node regions of the real arrays
// measured (single models: local only; whole scenes: short and local). The same reading as sdagChildAt, with the
// references' start fixed and the directory read once. x: the record's bits from bit pos (F).
template <bool kTier>
SOMM_ENCODE_INLINE const uint8_t* sdagLocalNode(const uint8_t* data, const SdagDirectory& dir,
                                                const uint8_t* p, uint32_t n, uint32_t i, uint32_t k,
                                                uint32_t pos, uint64_t x) noexcept {
  const uint32_t w = dir.width[k];
  if constexpr (!kTier) {
    return p + getBits(p, pos + w * i, w);
  } else {
    const uint32_t fl = uint32_t(x) & ((1u << n) - 1u), s = popcount16(fl & ((1u << i) - 1u));
    const uint32_t sw = dir.tier[k] - 1u, at = pos + n + sw * s + w * (i - s);
    if ((fl >> i) & 1u) return data + dir.base[k] + getBits(p, at, sw);  // short: in the region
    return p + getBits(p, at, w);                                        // local
  }
}
// The child that node child number i (of n) of the node record of height H >= 2 at p refers to (a leaf for H = 2):
// the regions of the real arrays read with the references' start fixed (sdagLocalLeaf, sdagLocalNode), the others
// by sdagChildAt. fx: where the flags start and the record's bits from there (sdagNodeFlags).
// For H = 2 the leaf and its transform (SdagLeafAt).
template <Format F, uint32_t H>
SOMM_ENCODE_INLINE auto sdagNodeChildOf(const uint8_t* data, const SdagDirectory& dir, const uint8_t* p,
                                        uint32_t n, uint32_t i, SdagFlags fx) noexcept {
  constexpr uint32_t b = F == Format::TwoState ? 1u : 2u, k = sdagRegion(F, H - 1);
  if constexpr (H == 2) {
    if (dir.local[k] != 0 && dir.tier[k] != 0)
      return dir.mid[k] != 0 ? sdagLocalLeaf<F, true>(data, dir, p, n, i, fx.pos, fx.x)
                             : sdagLocalLeaf<F, false>(data, dir, p, n, i, fx.pos, fx.x);
    return sdagLeafOf(data, dir, F, sdagChildAt(dir, p, uint32_t(p - data), fx.pos, n, i, k, 2u * b, fx.x));
  } else {
    if (dir.local[k] != 0 && dir.mid[k] == 0)
      return dir.tier[k] != 0 ? sdagLocalNode<true>(data, dir, p, n, i, k, fx.pos, fx.x)
                              : sdagLocalNode<false>(data, dir, p, n, i, k, fx.pos, fx.x);
    return data + sdagChildAt(dir, p, uint32_t(p - data), fx.pos, n, i, k, 0u, fx.x);
  }
}
// The walk, specialised per format and record height (unrolled: shifts, regions and state widths are
// constants). Step of a node record of height H >= 2 at p: index bits [4(H-1), 4H) pick the child.
template <Format F, uint32_t H>
SOMM_ENCODE_INLINE State sdagNodeStep(const uint8_t* data, const SdagDirectory& dir, const uint8_t* p,
                                      uint32_t index) noexcept {
  const uint32_t slot = (index >> (4u * (H - 1u))) & 15u, m = load16(p),
                 below = popcount16(m & ((1u << slot) - 1u));
  const uint64_t y = load64(p + 2);
  if (!((m >> slot) & 1u)) return State(sdagUniformState(y, slot - below));
  const uint32_t n = popcount16(m);
  const auto c = sdagNodeChildOf<F, H>(data, dir, p, n, below, sdagFlagsFrom(y, n));
  if constexpr (H == 2) {
    return sdagLeafState<F>(c.p, index & 15u, c.t);
  } else {
    return sdagNodeStep<F, H - 1>(data, dir, c, index);
  }
}
// The child of the node record of height H >= 2 at p that covers `index`: its byte offset in the data (a leaf's for
// H = 2), or the state (< 2) of a uniform child. The same reading as sdagNodeStep's.
template <Format F, uint32_t H>
SOMM_ENCODE_INLINE uint32_t sdagNodeChild(const uint8_t* data, const SdagDirectory& dir, const uint8_t* p,
                                          uint32_t index) noexcept {
  const uint32_t slot = (index >> (4u * (H - 1u))) & 15u, m = load16(p),
                 below = popcount16(m & ((1u << slot) - 1u));
  const uint64_t y = load64(p + 2);
  if (!((m >> slot) & 1u)) return sdagUniformState(y, slot - below);
  const uint32_t n = popcount16(m);
  const auto c = sdagNodeChildOf<F, H>(data, dir, p, n, below, sdagFlagsFrom(y, n));
  if constexpr (H == 2) {
    return uint32_t(c.p - data) | (c.t << kSdagLeafTShift);  // a leaf handle
  } else {
    return uint32_t(c - data);
  }
}
// The walk from the record of height h at byte offset a (h = 1: a leaf handle).
template <Format F>
inline State sdagNodeWalk(const uint8_t* data, const SdagDirectory& dir, uint32_t a, uint32_t h,
                          uint32_t index) noexcept {
  const uint8_t* p = data + a;
  switch (h) {
    case 1:
      return sdagHandleState<F>(data, dir, a, index & 15u);
    case 2:
      return sdagNodeStep<F, 2>(data, dir, p, index);
    case 3:
      return sdagNodeStep<F, 3>(data, dir, p, index);
    case 4:
      return sdagNodeStep<F, 4>(data, dir, p, index);
    case 5:
      return sdagNodeStep<F, 5>(data, dir, p, index);
    default:
      return sdagNodeStep<F, 6>(data, dir, p, index);
  }
}
// The step of the 4-way root (odd level >= 3) at byte offset `offset`: its child of height (level - 1) / 2 that
// covers `index` (the child's byte offset; a leaf's at level 3) or the state (< 4) of a uniform child. M in bits
// 0..3, the uniform states from bit 4.
template <Format F>
SOMM_ENCODE_INLINE uint32_t sdagRootChild(const uint8_t* data, const SdagDirectory& dir, uint32_t offset,
                                          uint32_t level, uint32_t index) noexcept {
  const uint8_t* p = data + offset;
  const uint32_t h = level >> 1, slot = index >> (2 * level - 2), m = p[0] & 15u,
                 below = popcount16(m & ((1u << slot) - 1u));
  if (!((m >> slot) & 1u)) return getBit(p, 4u + slot - below);
  const uint32_t k = sdagRegion(F, h), n = popcount16(m);
  return sdagChildAt(dir, p, offset, 8u - n, n, below, k, h == 1 ? 2u * bitsPerState(F) : 0u);
}
// One step down from the node record of height h >= 2 at byte offset `at`: the child of height h - 1 covering
// `index` (its byte offset; a leaf's for h = 2) or the state (< 2) of a uniform child.
template <Format F>
SOMM_ENCODE_INLINE uint32_t sdagStepDown(const uint8_t* data, const SdagDirectory& dir, uint32_t at,
                                         uint32_t h, uint32_t index) noexcept {
  constexpr uint32_t b = F == Format::TwoState ? 1u : 2u;
  const uint8_t* p = data + at;
  const uint32_t k = sdagRegion(F, h - 1u);
  const uint32_t slot = (index >> (4u * (h - 1u))) & 15u, m = load16(p),
                 below = popcount16(m & ((1u << slot) - 1u));
  const uint64_t y = load64(p + 2);
  if (!((m >> slot) & 1u)) return sdagUniformState(y, slot - below);
  const uint32_t n = popcount16(m);
  const SdagFlags fx = sdagFlagsFrom(y, n);
  return sdagChildAt(dir, p, at, fx.pos, n, below, k, h == 2u ? 2u * b : 0u, fx.x);
}
template <Format F>
inline State sdagStateAs(const uint8_t* data, const SdagDirectory& dir, uint32_t offset, uint32_t level,
                         uint32_t index) noexcept {
  if (level <= 1) return getValue(data + offset, 0, F, index);
  if (level & 1u) {
    const uint32_t child = sdagRootChild<F>(data, dir, offset, level, index);
    if (child < 4) return State(child);
    offset = child;
  }
  return sdagNodeWalk<F>(data, dir, offset, level >> 1, index);
}
// A per-thread memo of the triangles' index-buffer values (256 entries, direct mapped by triangle): rays next to
// each other hit the same triangles, so the packed index buffer and the descriptor are read once per triangle, not
// per lookup. An entry keeps the triangle's value resolved: the map's root, level, format and kind, or a special
// index's state — and, filled as lookups need them, the root's children (each slot's child record or uniform
// state), so that a walk of a map of level >= 4 starts one height below its root; those children are also kept
// per map (MapTop), so that a triangle's entry starts from what other triangles of its map found. Remembering the
// last walk's path and leaf to restart lower still (a finger search) cost more than it saved in tracing, on coherent
// close-ups as on default views (measured, docs/encodings.md). Entries are keyed by the array's identity
// (EncodedArray::identity(), unique per content: a new one for every build and parse, shared only by copies, which
// hold the same bytes) and the triangle, and hold offsets and states (never pointers), so an entry can never answer
// for other bytes.
struct SdagMemo {
  struct Entry {
    uint64_t array = 0;  // 0: empty (identities start at 1)
    uint32_t triangle = 0;
    uint32_t root = 0;  // the map's descriptor offset, or (kind 2) the special index's state
    uint8_t level = 0, format = 0,
            kind = 0;                   // kind: 0 a DAG map, 1 a flat map, 2 a special index, 3 a DAG map
                                        // of level >= 8 with a deep table
    uint8_t grand = 0;                  // the map's table is SdagMemo::grand[grand] (deep[grand]: kind 3) ...
    uint16_t topValid = 0;              // bit s: top[s] holds the root's child in slot s
    uint8_t slotShift = 0, hShift = 0;  // level >= 4: index >> slotShift = the root's slot; the root's
                                        // children's height h = hShift / 4 + 1
    uint64_t grandGen = ~uint64_t(0);   // ... while its gen equals this (~0: no table)
    uint32_t top[16] = {};              // the root's children (byte offsets, or uniform states < 4)
  };
  // The root's children found so far per map (direct mapped by the root's offset), shared by the triangles of a
  // map: a triangle's entry, when (re)filled, starts from its map's children instead of finding each again (real
  // scenes give hundreds of triangles one map). Keyed like an entry by the array's identity, and by the map's root,
  // level and format; read and written only when an entry is filled or finds a root child, never on the walk's
  // common path.
  struct MapTop {
    uint64_t array = 0;  // 0: empty
    uint32_t root = 0;
    uint8_t level = 0, format = 0;
    uint16_t valid = 0;  // bit s: top[s] holds the root's child in slot s
    uint32_t top[16] = {};
  };
  // The root's grandchildren found so far per map (64 tables, direct mapped by the root's offset; maps of level
  // >= 5 in arrays of at most kGrandArrayMaps DAG roots): at[g] = the record's byte offset or the uniform state (< 4)
  // covering the index range whose top bits (8 for an even level, 6 for an odd one) are g, valid where bit g of
  // `valid` is set. A lookup whose entry's map holds the table reads at[g] and walks on from there: one dependent
  // record fewer than from the root's child (levels 7 and 8: the height-2 record, then the leaf). An entry
  // (re)filled for a map takes its map's table over unless another map's entries were filled within the last
  // kGrandIdle fills (then it walks from the root's child); a takeover gives the table a new `gen`, so the entries
  // of the map that held it (entry.grandGen) stop reading it. Arrays with more maps keep no tables: on 0 A.D.
  // flora-quarter (2,256 maps at level 8) the tables' misses cost more than their hits saved (docs/encodings.md).
  // The owner and generation of a per-map table (Grand, Deep).
  struct TableHead {
    uint64_t array = 0;  // 0: empty
    uint32_t root = 0;
    uint8_t level = 0, format = 0;
    uint32_t stamp = 0;  // SdagMemo::fills when an entry of the owner was last filled
    uint64_t gen = 0;    // a new SdagMemo::gens whenever a map takes the table over
  };
  struct Grand : TableHead {
    uint64_t valid[4] = {};  // bit g: at[g] holds the grandchild
    uint32_t at[256] = {};
  };
  // The records below the root's grandchildren found so far per map (kDeep tables, each given to a map of level
  // >= 8 in an array of at most kGrandArrayMaps DAG roots: the one its map holds, else the first empty or idle
  // one): at[g] = the record's byte offset or the uniform state (< 4) covering the index range whose top bits
  // (14 for an odd level, 12 for an even one) are g — a leaf at levels 8 and 9, a height-2 record at levels 10 and
  // 11. A lookup whose entry's map holds one reads at[g] and walks on from there (levels 8 and 9: the leaf); a map
  // holding a deep table takes no grandchild table (its entries are of kind 3). Taken over like a grandchild table
  // (kGrandIdle, gen).
  struct Deep : TableHead {
    uint64_t valid[256] = {};  // bit g: at[g] holds the great-grandchild
    uint32_t at[16384] = {};
  };
  static constexpr uint32_t kGrandBits = 6, kGrandIdle = 64, kDeep = 4;
  uint32_t fills = 0;  // entries (re)filled so far
  // Table generations handed out so far (unique across every table: an entry's gen matches only the table that
  // issued it).
  uint64_t gens = 0;
  Entry entry[256];
  MapTop map[256];
  Grand grand[1u << kGrandBits];
  Deep deep[kDeep];
};
// Arrays of at most this many distinct DAG map roots keep grandchild tables (SdagMemo::Grand).
inline constexpr uint64_t kGrandArrayMaps = 256;
// The calling thread's memo lives on the heap, allocated by its first memo lookup: a thread_local SdagMemo itself
// (385,168 bytes, with non-zero initial values) would be in the program's static TLS image, which every thread the
// process starts gets a copy of — written page by page into its stack mapping — whether it ever looks anything up
// or not (`somm bake` of a small model spent ~2 ms of ~20 in those page faults). The slot is a plain pointer (no
// guard on the lookup's path); its owner, touched only when allocating, frees the memo when the thread ends.
inline SdagMemo*& sdagMemoSlot() noexcept {
  thread_local SdagMemo* memo = nullptr;
  return memo;
}
// Set when the thread's owner was destroyed (thread exit): no memo is allocated after that.
inline bool& sdagMemoEnded() noexcept {
  thread_local bool ended = false;
  return ended;
}
// Constructed by a thread's first sdagMemoAllocate, which is when the memo is allocated (once: a failed allocation
// is not retried).
struct SdagMemoOwner {
  SdagMemo* memo = new (std::nothrow) SdagMemo();
  SdagMemoOwner() = default;
  SdagMemoOwner(const SdagMemoOwner&) = delete;
  SdagMemoOwner& operator=(const SdagMemoOwner&) = delete;
  ~SdagMemoOwner() {
    delete memo;
    sdagMemoSlot() = nullptr;
    sdagMemoEnded() = true;
  }
};
// The calling thread's memo, allocated on its first call; null when the allocation failed (once per thread: then
// every lookup walks from the root, as sdagStateAs does) or the thread is ending.
SOMM_ENCODE_COLD inline SdagMemo* sdagMemoAllocate() noexcept {
  if (sdagMemoEnded()) return nullptr;
  thread_local SdagMemoOwner owner;
  return sdagMemoSlot() = owner.memo;
}
inline SdagMemo* sdagMemoOfThread() noexcept {
  SdagMemo* memo = sdagMemoSlot();
  return memo ? memo : sdagMemoAllocate();
}
// The memo of a thread inside a memo lookup (sdagMemoOfThread returned it, so it exists).
inline SdagMemo& sdagMemo() noexcept {
  return *sdagMemoSlot();
}
inline SdagMemo::Entry& sdagMemoEntry(SdagMemo& memo, uint32_t triangle) noexcept {
  return memo.entry[(triangle * 0x9e3779b1u) >> 24];
}
// The map cache slot of the map whose root record is at byte offset `root`.
inline SdagMemo::MapTop& sdagMapTop(uint32_t root) noexcept {
  return sdagMemo().map[(root * 0x9e3779b1u) >> 24];
}
// Whether a per-map table t (MapTop or Grand: keyed by array, root, level and format) holds entry e's map.
template <class Table>
inline bool sdagTableHolds(const Table& t, const SdagMemo::Entry& e) noexcept {
  return t.array == e.array && t.root == e.root && t.level == e.level && t.format == e.format;
}
// The grandchild table slot of the map whose root record is at byte offset `root`.
inline uint32_t sdagGrandSlot(uint32_t root) noexcept {
  return (root * 0x9e3779b1u) >> (32u - SdagMemo::kGrandBits);
}
// Whether table t (Grand or Deep) may be taken over at fill count `now`: empty, or its owner idle for more than
// kGrandIdle fills.
inline bool sdagTableFree(const SdagMemo::TableHead& t, uint32_t now) noexcept {
  return t.array == 0 || now - t.stamp > SdagMemo::kGrandIdle;
}
// Whether table t (Grand or Deep) can be entry e's map's: held by it (stamped now), else taken over when empty or
// idle for more than kGrandIdle fills (a new generation, the valid bits cleared). e's gen for t, or ~0 (no table).
template <class Table>
inline uint64_t sdagTakeTable(Table& t, const SdagMemo::Entry& e, uint32_t now, uint64_t& gens) noexcept {
  if (sdagTableHolds(t, e)) {
    t.stamp = now;
    return t.gen;
  }
  if (!sdagTableFree(t, now)) return ~uint64_t(0);
  t.stamp = now;
  t.array = e.array;
  t.root = e.root;
  t.level = e.level;
  t.format = e.format;
  std::memset(t.valid, 0, sizeof t.valid);
  return t.gen = ++gens;
}
// The deep table for entry e's map: the one it holds, else the first free one (sdagTableFree), else kDeep.
inline uint32_t sdagDeepPick(const SdagMemo& memo, const SdagMemo::Entry& e, uint32_t now) noexcept {
  for (uint32_t k = 0; k < SdagMemo::kDeep; ++k)
    if (sdagTableHolds(memo.deep[k], e)) return k;
  for (uint32_t k = 0; k < SdagMemo::kDeep; ++k)
    if (sdagTableFree(memo.deep[k], now)) return k;
  return SdagMemo::kDeep;
}
// The root's child covering `index` (see sdagMemoWalk), found and kept in the entry: out of line, so that the walk's
// common path (the child already kept) needs few registers.
template <Format F>
SOMM_ENCODE_COLD uint32_t sdagMemoTop(const uint8_t* data, const SdagDirectory& dir, SdagMemo::Entry& e,
                                      uint32_t slot, uint32_t index) noexcept {
  const uint32_t level = e.level;
  const uint32_t at = (level & 1u) ? sdagRootChild<F>(data, dir, e.root, level, index)
                                   : sdagStepDown<F>(data, dir, e.root, level >> 1, index);
  e.top[slot] = at;
  e.topValid = uint16_t(e.topValid | (1u << slot));
  SdagMemo::MapTop& t = sdagMapTop(e.root);
  if (sdagTableHolds(t, e)) {
    t.top[slot] = at;
    t.valid = uint16_t(t.valid | (1u << slot));
  }
  return at;
}
// The index bits below a deep table's records of entry e's map: 4 (leaves) at levels 8 and 9.
inline uint32_t sdagDeepShift(const SdagMemo::Entry& e) noexcept {
  return (e.level & 1u) ? e.hShift - 8u : e.hShift - 4u;
}
// The deep table's record covering `index` of a memo entry's map of level >= 8 (its byte offset — a leaf's at levels
// 8 and 9 — or a uniform state < 4), found from the root's child and kept in the entry's deep table d while the
// entry's map holds it: out of line (each slot of a table is filled once). A uniform record on the way fills every
// slot it covers (16, 256 or 4096).
template <Format F>
SOMM_ENCODE_COLD uint32_t sdagDeepMiss(const uint8_t* data, const SdagDirectory& dir, SdagMemo::Entry& e,
                                       SdagMemo::Deep& d, uint32_t index) noexcept {
  const uint32_t slot = index >> e.slotShift, shift = sdagDeepShift(e), g = index >> shift;
  const uint32_t hc = shift >> 2;     // the table's records' height
  uint32_t h = (e.hShift >> 2) + 1u;  // the root's children's height
  uint32_t a = ((e.topValid >> slot) & 1u) ? e.top[slot] : sdagMemoTop<F>(data, dir, e, slot, index);
  while (a >= 4 && h > hc) a = sdagStepDown<F>(data, dir, a, h--, index);
  if (d.gen == e.grandGen) {
    const uint32_t span = 1u << (4u * (h - hc)), first = g & ~(span - 1u);
    for (uint32_t k = first; k < first + span; ++k) d.at[k] = a;
    if (span >= 64) {
      for (uint32_t w = first >> 6; w < (first + span) >> 6; ++w) d.valid[w] = ~uint64_t(0);
    } else {
      d.valid[g >> 6] |= ((uint64_t(1) << span) - 1u) << (first & 63u);
    }
  }
  return a;
}
// Maps of level < 4 (no kept children): from the root, out of line.
template <Format F>
SOMM_ENCODE_COLD State sdagSmallState(const uint8_t* data, const SdagDirectory& dir, uint32_t root,
                                      uint32_t level, uint32_t index) noexcept {
  return sdagStateAs<F>(data, dir, root, level, index);
}
// The state at `index` of a memo entry's DAG map (kind 0 or 3): the walk from the root's child covering `index`,
// taken from the entry (or found and kept there), for maps of level >= 4; from the root below that. kGrand (arrays
// of at most kGrandArrayMaps DAG roots, see SdagMemo::Grand): maps of level >= 5 start from the root's grandchild,
// kept in the map's table while the entry's map holds one; entries of kind 3 (level >= 8) from their deep table's
// record (SdagMemo::Deep).
template <Format F, bool kGrand>
SOMM_ENCODE_INLINE State sdagMemoWalk(const uint8_t* data, const SdagDirectory& dir, SdagMemo::Entry& e,
                                      uint32_t index) noexcept {
  const uint32_t level = e.level;
  if (level < 4) return sdagSmallState<F>(data, dir, e.root, level, index);
  const uint32_t slot = index >> e.slotShift, hs = e.hShift, h = (hs >> 2) + 1u;  // h: the child's height
  if constexpr (kGrand) {
    if (e.kind == 3) {  // level >= 8: from the deep table's record (a leaf at levels 8 and 9)
      SdagMemo::Deep& d = sdagMemo().deep[e.grand];
      const uint32_t shift = sdagDeepShift(e), g = index >> shift, hc = shift >> 2;
      const uint32_t a = d.gen == e.grandGen && ((d.valid[g >> 6] >> (g & 63u)) & 1u)
                             ? d.at[g]
                             : sdagDeepMiss<F>(data, dir, e, d, index);
      if (a < 4) return State(a);
      if (hc == 1) return sdagHandleState<F>(data, dir, a, index & 15u);
      if (hc == 2) return sdagNodeStep<F, 2>(data, dir, data + a, index);
      return sdagNodeWalk<F>(data, dir, a, hc, index);
    }
    if (h >= 2) {
      SdagMemo::Grand& t = sdagMemo().grand[e.grand];
      const uint32_t g = index >> hs;
      const bool holds = t.gen == e.grandGen;
      uint32_t a;
      if (holds && ((t.valid[g >> 6] >> (g & 63u)) & 1u)) {
        a = t.at[g];
      } else {
        const uint32_t at =
            ((e.topValid >> slot) & 1u) ? e.top[slot] : sdagMemoTop<F>(data, dir, e, slot, index);
        if (at < 4) {
          a = at;
        } else if (h == 3) {
          a = sdagNodeChild<F, 3>(data, dir, data + at, index);
        } else if (h == 4) {
          a = sdagNodeChild<F, 4>(data, dir, data + at, index);
        } else if (h == 2) {
          a = sdagNodeChild<F, 2>(data, dir, data + at, index);
        } else {
          a = sdagStepDown<F>(data, dir, at, h, index);
        }
        if (holds) {
          t.at[g] = a;
          t.valid[g >> 6] |= uint64_t(1) << (g & 63u);
        }
      }
      if (a < 4) return State(a);
      if (h == 3) return sdagNodeStep<F, 2>(data, dir, data + a, index);
      if (h == 4) return sdagNodeStep<F, 3>(data, dir, data + a, index);
      if (h == 2) return sdagHandleState<F>(data, dir, a, index & 15u);
      return sdagNodeWalk<F>(data, dir, a, h - 1u, index);
    }
  }
  const uint32_t at = ((e.topValid >> slot) & 1u) ? e.top[slot] : sdagMemoTop<F>(data, dir, e, slot, index);
  if (at < 4) return State(at);
  // Levels 8 to 10 (a child of height 3 or 4) walked in line: no call, no jump on the height. (Height 5 too cost
  // registers: levels 8 and 10 took 2 % more instructions.)
  if (h == 3) return sdagNodeStep<F, 3>(data, dir, data + at, index);
  if (h == 4) return sdagNodeStep<F, 4>(data, dir, data + at, index);
  return sdagNodeWalk<F>(data, dir, at, h, index);
}

inline State sdagState(const uint8_t* data, const SdagDirectory& dir, uint32_t offset, uint32_t level,
                       Format f, uint32_t index) noexcept {
  return f == Format::TwoState ? sdagStateAs<Format::TwoState>(data, dir, offset, level, index)
                               : sdagStateAs<Format::FourState>(data, dir, offset, level, index);
}

// Arrays with the sdag directory (sdag, hybrid with sdag maps) store their own packed index buffer: k bits per
// triangle, k = sdagIndexBits(maps) = bits to hold 0 .. maps+3; triangle t's value at bit t·k is the map number,
// or 2^k + i for a special index i (-1 .. -4), i.e. the k-bit two's complement. Random access: one unaligned
// 64-bit load (the descriptors, data and tail padding follow the index buffer).
constexpr uint32_t sdagIndexBits(uint64_t maps) noexcept {
  uint32_t k = 2;
  while (k < 32 && (uint64_t(1) << k) < maps + 4) ++k;
  return k;
}
constexpr uint64_t packedIndexBytes(uint64_t triangles, uint32_t bits) noexcept {
  return (triangles * bits + 7) / 8;
}
SOMM_ENCODE_INLINE int32_t packedIndex(const uint8_t* p, uint32_t bits, uint64_t t) noexcept {
  const uint64_t pos = t * bits, top = uint64_t(1) << bits;
  const uint64_t v = (sdagBitsFrom(p, pos)) & (top - 1u);
  return v >= top - 4u ? int32_t(int64_t(v) - int64_t(top)) : int32_t(v);
}
// The rank-packed index buffer (flags bit 1; chosen when smaller than the plain one): the triangles whose value
// differs from the array's most common one (the "default") are listed, the others only flagged. Per group of 32
// triangles one 64-bit word: bits 0..31 = the number of listed triangles in the groups before, bits 32..63 = the
// group's mask (bit j: triangle 32g + j is listed). Then the value list, k bits per entry as in the plain buffer:
// entry 0 = the default value, entry 1 + r = the value of the r-th listed triangle (triangle order).
// Random access: the group word, then one entry (a listed triangle's or entry 0).
inline constexpr uint32_t kRankIndexGroup = 32;
constexpr uint64_t rankIndexGroups(uint64_t triangles) noexcept {
  return (triangles + kRankIndexGroup - 1) / kRankIndexGroup;
}
constexpr uint64_t rankIndexBytes(uint64_t triangles, uint64_t listed, uint32_t bits) noexcept {
  return 8 * rankIndexGroups(triangles) + packedIndexBytes(listed + 1, bits);
}
SOMM_ENCODE_INLINE int32_t rankPackedIndex(const uint8_t* p, uint32_t bits, uint64_t groups,
                                           uint32_t t) noexcept {
  const uint64_t w = load64(p + 8 * uint64_t(t >> 5));
  const uint32_t j = t & 31u, m = uint32_t(w >> 32);
  const uint64_t below = popcount64(uint64_t(m) & ((uint64_t(1) << j) - 1u));
  const uint64_t entry = ((m >> j) & 1u) ? 1 + uint32_t(w) + below : 0;
  return packedIndex(p + 8 * groups, bits, entry);
}

// Encode / decode one map. Encoding a map is deterministic and canonical (maximal collapse).
std::vector<uint8_t> encodeMap(const Micromap& map, MapKind kind);
// Decodes a blob produced by encodeMap (trusted input).
Micromap decodeMap(const uint8_t* blob, MapKind kind, uint32_t level, Format f);
// Checks an untrusted blob of `available` bytes; on success returns its exact size in bytes. Guarantees that
// every lookup into it stays within those bytes (plus kTailPadding).
Result<uint64_t> validateMap(const uint8_t* blob, uint64_t available, MapKind kind, uint32_t level, Format f);

}  // namespace encode

// Descriptor of one encoded micromap: 8 bytes on disk (u32 offset, u8 level, u8 format, u8 kind, u8 zero).
struct EncodedMapDesc {
  uint32_t offset = 0;
  uint8_t level = 0;
  uint8_t format = 1;
  MapKind kind = MapKind::Flat;
  uint8_t reserved = 0;
  friend bool operator==(const EncodedMapDesc& a, const EncodedMapDesc& b) noexcept {
    return a.offset == b.offset && a.level == b.level && a.format == b.format && a.kind == b.kind &&
           a.reserved == b.reserved;
  }
  friend bool operator!=(const EncodedMapDesc& a, const EncodedMapDesc& b) noexcept { return !(a == b); }
};

// One geometry's micromaps in one encoding, with random access.
class EncodedArray {
 public:
  EncodedArray() = default;

  Encoding encoding() const noexcept { return encoding_; }
  uint32_t triangleCount() const noexcept { return uint32_t(indices_.size()); }
  uint32_t mapCount() const noexcept { return uint32_t(maps_.size()); }
  Span<const int32_t> indices() const noexcept { return indices_; }
  Span<const EncodedMapDesc> maps() const noexcept { return maps_; }
  // The data bytes, without the tail padding.
  Span<const uint8_t> data() const noexcept { return {data_.data(), dataBytes_}; }
  IndexType indexType() const noexcept { return indexType_; }
  // Bits per triangle of the serialized index buffer: 0 = the spec's 16/32-bit buffer (indexType()); k > 0 = the
  // packed buffer of arrays with the sdag directory (encode::sdagIndexBits), which the sdag lookup reads.
  uint32_t indexBits() const noexcept { return indexBits_; }
  // The packed buffer is rank-packed (encode::rankPackedIndex: only the triangles whose value is not the most
  // common one are listed), chosen per array when that is smaller than k bits per triangle.
  bool indexRankPacked() const noexcept { return indexGroups_ != 0; }
  uint64_t indexBufferBytes() const noexcept {
    return indexBits_ ? packed_.size() - encode::kTailPadding
                      : uint64_t(indices_.size()) * uint64_t(indexType_);
  }
  // The sdag directory (zero unless hasDirectory(): always for sdag, for hybrid when a map is of kind Sdag).
  bool hasDirectory() const noexcept { return hasDirectory_; }
  const encode::SdagDirectory& directory() const noexcept { return dir_; }
  // Unique per content: every build and parse gets a new value (from 1); copies keep it (same bytes).
  uint64_t identity() const noexcept { return identity_; }
  // Whether sdag lookups keep per-map grandchild tables (encode::SdagMemo::Grand): arrays of at most
  // encode::kGrandArrayMaps distinct DAG map roots.
  bool keepsGrandTables() const noexcept { return grand_; }
  // The encoding whose bytes serve this array: dfs-fast is the dfs tree with another lookup, so it is stored
  // as dfs (a .somm file keeps one dfs section for both).
  static Encoding storedEncoding(Encoding e) noexcept { return e == Encoding::DfsFast ? Encoding::Dfs : e; }
  // The same bytes with another lookup: dfs <-> dfs-fast (false, unchanged, for any other pair).
  bool setLookup(Encoding e) noexcept {
    if (storedEncoding(e) != storedEncoding(encoding_) || storedEncoding(e) != Encoding::Dfs)
      return e == encoding_;
    encoding_ = e;
    return true;
  }

  // Exact sizes: the serialized form, which is also what a GPU needs for random access (docs/encodings.md):
  //   byteSize = 20 + triangles·indexBytes + 8·maps + dataBytes + padding.
  uint64_t dataBytes() const noexcept { return dataBytes_; }
  uint64_t paddingBytes() const noexcept { return data_.size() - dataBytes_; }
  uint64_t byteSize() const noexcept {
    return encode::kArrayHeaderBytes + indexBufferBytes() +
           uint64_t(maps_.size()) * encode::kDescriptorBytes + data_.size();
  }

  // State of micro-triangle `index` (< 4^level of that triangle's map) of `triangle`.
  State state(uint32_t triangle, uint32_t index) const noexcept {
    switch (encoding_) {
      case Encoding::Flat:
        return stateAs<Encoding::Flat>(triangle, index);
      case Encoding::Dfs:
        return stateAs<Encoding::Dfs>(triangle, index);
      case Encoding::DfsFast:
        return stateAs<Encoding::DfsFast>(triangle, index);
      case Encoding::Rank:
        return stateAs<Encoding::Rank>(triangle, index);
      case Encoding::Hybrid:
        return stateAs<Encoding::Hybrid>(triangle, index);
      case Encoding::Csm:
        return stateAs<Encoding::Csm>(triangle, index);
      case Encoding::Sdag:
        return stateAs<Encoding::Sdag>(triangle, index);
    }
    return State::Transparent;
  }
  State stateUV(uint32_t triangle, float u, float v) const noexcept {
    switch (encoding_) {
      case Encoding::Flat:
        return stateUVAs<Encoding::Flat>(triangle, u, v);
      case Encoding::Dfs:
        return stateUVAs<Encoding::Dfs>(triangle, u, v);
      case Encoding::DfsFast:
        return stateUVAs<Encoding::DfsFast>(triangle, u, v);
      case Encoding::Rank:
        return stateUVAs<Encoding::Rank>(triangle, u, v);
      case Encoding::Hybrid:
        return stateUVAs<Encoding::Hybrid>(triangle, u, v);
      case Encoding::Csm:
        return stateUVAs<Encoding::Csm>(triangle, u, v);
      case Encoding::Sdag:
        return stateUVAs<Encoding::Sdag>(triangle, u, v);
    }
    return State::Transparent;
  }

  // The same with the encoding fixed at compile time (E must equal encoding()).
  template <Encoding E>
  State stateAs(uint32_t triangle, uint32_t index) const noexcept {
    const auto indexOf = [index](uint32_t) { return index; };
    if constexpr (E == Encoding::Sdag) return sdagMemoState(triangle, indexOf);
    return plainState<E>(triangle, indexOf);
  }
  template <Encoding E>
  State stateUVAs(uint32_t triangle, float u, float v) const noexcept {
    const auto indexOf = [u, v](uint32_t level) { return baryToIndex(u, v, level); };
    if constexpr (E == Encoding::Sdag) return sdagMemoState(triangle, indexOf);
    return plainState<E>(triangle, indexOf);
  }
  // The lookup from the index buffer and the map's descriptor (every encoding but sdag, which has its memo);
  // indexOf(level) gives the micro-triangle index once the triangle's level is known.
  template <Encoding E, class IndexOf>
  State plainState(uint32_t triangle, IndexOf indexOf) const noexcept {
    const int32_t i = indexAs<E>(triangle);
    if (i < 0) return stateOfSpecialIndex(i);
    const EncodedMapDesc& d = maps_[size_t(i)];
    return mapState<E>(d, indexOf(d.level));
  }

  // The triangle's index-buffer value (a descriptor index or a special index -1..-4): sdag reads its packed
  // buffer, the others the spec one.
  template <Encoding E>
  int32_t indexAs(uint32_t triangle) const noexcept {
    if constexpr (E == Encoding::Sdag) {
      if (indexGroups_ != 0)
        return encode::rankPackedIndex(packed_.data(), indexBits_, indexGroups_, triangle);
      return encode::packedIndex(packed_.data(), indexBits_, triangle);
    }
    return indices_[triangle];
  }

  // A memo entry (re)filled for `triangle`: out of line, so that the lookup's hit path keeps its registers.
  SOMM_ENCODE_COLD void sdagMemoFill(encode::SdagMemo::Entry& e, uint32_t triangle) const noexcept {
    const int32_t i = indexAs<Encoding::Sdag>(triangle);
    e.array = identity_;
    e.triangle = triangle;
    e.topValid = 0;
    e.grandGen = ~uint64_t(0);
    if (i < 0) {
      e.kind = 2;
      e.root = uint32_t(stateOfSpecialIndex(i));
    } else {
      const EncodedMapDesc& d = maps_[size_t(i)];
      e.kind = d.kind == MapKind::Flat ? 1 : 0;
      e.root = d.offset;
      e.level = d.level;
      e.format = d.format;
      if (e.level >= 4) {
        const uint32_t odd = e.level & 1u;
        e.slotShift = uint8_t(2u * e.level - 4u + 2u * odd);  // 4-way root (odd level): 2 bits
        e.hShift = uint8_t(4u * ((e.level >> 1) - 2u + odd));
      }
      if (e.kind == 0 && e.level >= 4) {
        // The root's children other triangles of the map found (or, another map in the slot: the slot now this
        // map's, empty).
        encode::SdagMemo::MapTop& t = encode::sdagMapTop(e.root);
        if (encode::sdagTableHolds(t, e)) {
          e.topValid = t.valid;
          std::memcpy(e.top, t.top, sizeof e.top);
        } else {
          t.array = e.array;
          t.root = e.root;
          t.level = e.level;
          t.format = e.format;
          t.valid = 0;
        }
        if (grand_ && e.level >= 5) {
          // The map's deep table (level >= 8), else its grandchild table: its own, or taken over from a map idle
          // for kGrandIdle fills, or none.
          encode::SdagMemo& memo = encode::sdagMemo();
          const uint32_t now = ++memo.fills;
          if (e.level >= 8) {
            const uint32_t slot = encode::sdagDeepPick(memo, e, now);
            e.grandGen = slot < encode::SdagMemo::kDeep
                             ? encode::sdagTakeTable(memo.deep[slot], e, now, memo.gens)
                             : ~uint64_t(0);
            if (e.grandGen != ~uint64_t(0)) {
              e.kind = 3;
              e.grand = uint8_t(slot);
            }
          }
          if (e.kind == 0) {
            const uint32_t slot = encode::sdagGrandSlot(e.root);
            e.grand = uint8_t(slot);
            e.grandGen = encode::sdagTakeTable(memo.grand[slot], e, now, memo.gens);
          }
        }
      }
    }
  }

  // The sdag lookup without the memo (a thread whose memo could not be allocated), out of line.
  template <class IndexOf>
  SOMM_ENCODE_COLD State sdagPlainState(uint32_t triangle, IndexOf indexOf) const noexcept {
    return plainState<Encoding::Sdag>(triangle, indexOf);
  }

  // The sdag lookup of a triangle through the per-thread memo (encode::SdagMemo); indexOf(level) gives the
  // micro-triangle index once the triangle's level is known.
  template <class IndexOf>
  SOMM_ENCODE_INLINE State sdagMemoState(uint32_t triangle, IndexOf indexOf) const noexcept {
    encode::SdagMemo* memo = encode::sdagMemoOfThread();
    if (!memo) return sdagPlainState(triangle, indexOf);
    encode::SdagMemo::Entry& e = encode::sdagMemoEntry(*memo, triangle);
    if (e.array != identity_ || e.triangle != triangle) sdagMemoFill(e, triangle);
    if (e.kind == 2) return State(e.root);
    const uint32_t index = indexOf(e.level);
    const Format f = Format(e.format);
    if (e.kind == 1) return encode::flatState(data_.data() + e.root, e.level, f, index);
    if (grand_)
      return f == Format::FourState
                 ? encode::sdagMemoWalk<Format::FourState, true>(data_.data(), dir_, e, index)
                 : encode::sdagMemoWalk<Format::TwoState, true>(data_.data(), dir_, e, index);
    return f == Format::FourState
               ? encode::sdagMemoWalk<Format::FourState, false>(data_.data(), dir_, e, index)
               : encode::sdagMemoWalk<Format::TwoState, false>(data_.data(), dir_, e, index);
  }

  template <Encoding E>
  State mapState(const EncodedMapDesc& d, uint32_t index) const noexcept {
    const uint8_t* blob = data_.data() + d.offset;
    const Format f = Format(d.format);
    if constexpr (E == Encoding::Flat) return encode::flatState(blob, d.level, f, index);
    if constexpr (E == Encoding::Dfs) return encode::dfsState(blob, d.level, f, index);
    if constexpr (E == Encoding::DfsFast) return encode::dfsFastState(blob, d.level, f, index);
    if constexpr (E == Encoding::Rank) return encode::rankState(blob, d.level, f, index);
    if constexpr (E == Encoding::Csm) return encode::csmState(data_.data(), d.offset, d.level, f, index);
    if constexpr (E == Encoding::Sdag) {
      if (d.kind == MapKind::Flat) return encode::flatState(blob, d.level, f, index);
      return encode::sdagState(data_.data(), dir_, d.offset, d.level, f, index);
    }
    if constexpr (E == Encoding::Hybrid) {
      switch (d.kind) {
        case MapKind::Flat:
          return encode::flatState(blob, d.level, f, index);
        case MapKind::Dfs:
          return encode::dfsFastState(blob, d.level, f, index);
        case MapKind::Rank:
          return encode::rankState(blob, d.level, f, index);
        case MapKind::Sdag:
          return encode::sdagState(data_.data(), dir_, d.offset, d.level, f, index);
        case MapKind::Csm:
          return encode::csmState(data_.data(), d.offset, d.level, f, index);
      }
    }
    return State::Transparent;
  }

  // Builds the encoded form of `array` (checks the array: offsets in range, valid levels/formats/indices).
  static Result<EncodedArray> build(const OmmArray& array, Encoding encoding);
  // Back to the spec buffers: micromaps in descriptor order at contiguous offsets, usage histograms as
  // OmmArrayBuilder computes them. Bit-exact against an array made by OmmArrayBuilder.
  OmmArray decode() const;
  // Map `map` (< mapCount()) decoded to the spec layout.
  Micromap decodeMap(uint32_t map) const;

  std::vector<uint8_t> serialize() const;
  // Validating parser: any byte string either parses into an array whose every lookup stays in bounds or
  // yields a CorruptFile / UnsupportedFormat error with a one-line message prefixed by `what` (e.g. a file
  // name).
  static Result<EncodedArray> parse(Span<const uint8_t> bytes, std::string_view what = "encoded array");

  friend bool operator==(const EncodedArray& a, const EncodedArray& b) {
    return a.encoding_ == b.encoding_ && a.indexType_ == b.indexType_ && a.indices_ == b.indices_ &&
           a.maps_ == b.maps_ && a.data_ == b.data_ && a.dataBytes_ == b.dataBytes_ &&
           a.hasDirectory_ == b.hasDirectory_ && a.dir_ == b.dir_ && a.indexBits_ == b.indexBits_ &&
           a.packed_ == b.packed_ && a.indexGroups_ == b.indexGroups_;
  }
  friend bool operator!=(const EncodedArray& a, const EncodedArray& b) noexcept { return !(a == b); }

 private:
  Encoding encoding_ = Encoding::Flat;
  IndexType indexType_ = IndexType::UInt16;
  std::vector<int32_t> indices_;
  std::vector<EncodedMapDesc> maps_;
  std::vector<uint8_t> data_;  // dataBytes_ + padding
  uint64_t dataBytes_ = 0;
  bool hasDirectory_ = false;
  encode::SdagDirectory dir_{};
  uint64_t identity_ = 0;        // unique per content (build / parse), a key of encode::sdagMemo
  bool grand_ = false;           // the sdag walk keeps grandchild tables (encode::SdagMemo::Grand)
  uint32_t indexBits_ = 0;       // > 0 iff hasDirectory_
  std::vector<uint8_t> packed_;  // the packed index buffer (indexBits_ > 0) + kTailPadding zero bytes
  uint64_t indexGroups_ = 0;     // > 0 iff the packed buffer is rank-packed: its number of 32-triangle groups
  void packIndices();
};

// Checks that a (parsed, validated) encoded array answers exactly like the flat spec buffers it was stored
// with: same indices, same level and format per map, the same state for every micro-triangle. Run when a .somm
// is read, so that a file cannot answer differently per encoding. Each distinct map is decoded once (work
// bounded, LimitExceeded beyond); CorruptFile names the first difference, prefixed by `what`.
Status verifyAgainstFlat(const EncodedArray& encoded, const OmmArray& flat, std::string_view what);

}  // namespace somm
