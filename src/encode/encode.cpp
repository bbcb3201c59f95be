// SPDX-License-Identifier: MIT
#include "somm/encode.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstring>
#include <map>
#include <stdexcept>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

namespace somm {

const char* encodingName(Encoding e) noexcept {
  switch (e) {
    case Encoding::Flat:
      return "flat";
    case Encoding::Dfs:
      return "dfs";
    case Encoding::DfsFast:
      return "dfs-fast";
    case Encoding::Rank:
      return "rank";
    case Encoding::Hybrid:
      return "hybrid";
    case Encoding::Csm:
      return "csm";
    case Encoding::Sdag:
      return "sdag";
  }
  return "?";
}

std::optional<Encoding> parseEncodingName(std::string_view name) noexcept {
  for (Encoding e : kAllEncodings)
    if (name == encodingName(e)) return e;
  return std::nullopt;
}

Result<std::vector<Encoding>> parseEncodingList(std::string_view list) {
  std::vector<Encoding> out;
  auto add = [&](Encoding e) {
    if (std::find(out.begin(), out.end(), e) == out.end()) out.push_back(e);
  };
  size_t start = 0;
  while (true) {
    const size_t comma = list.find(',', start);
    const std::string_view name =
        list.substr(start, comma == std::string_view::npos ? list.npos : comma - start);
    if (name == "all") {
      for (Encoding e : kAllEncodings) add(e);
    } else if (auto e = parseEncodingName(name)) {
      add(*e);
    } else {
      return makeError(ErrorCode::InvalidArgument,
                       "unknown encoding '" + std::string(name) +
                           "' (expected flat, dfs, dfs-fast, rank, hybrid, csm, sdag or all)");
    }
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

const char* mapKindName(MapKind k) noexcept {
  switch (k) {
    case MapKind::Flat:
      return "flat";
    case MapKind::Dfs:
      return "dfs";
    case MapKind::Rank:
      return "rank";
    case MapKind::Csm:
      return "csm";
    case MapKind::Sdag:
      return "sdag";
  }
  return "?";
}

namespace encode {
namespace {

// A map as the encoders read it: level, format and packed bytes, owned elsewhere (a Micromap, or the data of the
// array EncodedArray::build encodes: no copy of each distinct map).
class MapRef {
 public:
  MapRef(const Micromap& m) noexcept  // NOLINT(google-explicit-constructor)
      : bytes_(m.bytes()), level_(m.level()), format_(m.format()) {}
  MapRef(const uint8_t* bytes, uint32_t level, Format format) noexcept
      : bytes_(bytes, micromapDataBytes(level, format)), level_(level), format_(format) {}
  uint32_t level() const noexcept { return level_; }
  Format format() const noexcept { return format_; }
  uint32_t size() const noexcept { return microTriangleCount(level_); }
  State get(uint32_t index) const noexcept { return readPackedState(bytes_.data(), format_, index); }
  Span<const uint8_t> bytes() const noexcept { return bytes_; }

 private:
  Span<const uint8_t> bytes_;
  uint32_t level_;
  Format format_;
};

constexpr uint8_t kMixed = 0xff;

class BitWriter {
 public:
  // Appends the low n (<= 64) bits of value, LSB first.
  void put(uint64_t value, uint32_t n) {
    if (n == 0) return;
    if (n < 64) value &= (uint64_t(1) << n) - 1u;
    const uint32_t used = uint32_t(bits_ & 63u);
    if (used == 0) words_.push_back(0);
    words_.back() |= value << used;
    if (used + n > 64) words_.push_back(value >> (64 - used));
    bits_ += n;
  }
  void putBit(uint32_t b) { put(b, 1); }
  void padToByte() {
    const uint64_t pad = (8 - (bits_ & 7u)) & 7u;
    put(0, uint32_t(pad));
  }
  void append(const BitWriter& o) {
    for (uint64_t i = 0; i < o.bits_; i += 64)
      put(o.words_[i >> 6], uint32_t(std::min<uint64_t>(64, o.bits_ - i)));
  }
  uint64_t bits() const { return bits_; }
  uint32_t bit(uint64_t i) const { return uint32_t(words_[i >> 6] >> (i & 63u)) & 1u; }
  std::vector<uint8_t> bytes() const {
    std::vector<uint8_t> out((bits_ + 7) / 8);
    for (size_t i = 0; i < out.size(); ++i) out[i] = uint8_t(words_[i >> 3] >> (8 * (i & 7u)));
    return out;
  }

 private:
  std::vector<uint64_t> words_;
  uint64_t bits_ = 0;
};

// vals[d][i]: state of node i at depth d when its subtree is uniform, kMixed otherwise. Node i at depth d
// covers the micro-triangles [i·4^(L-d), (i+1)·4^(L-d)); its children are 4i..4i+3 at depth d+1.
// From level 2 on, vals[L] (a byte per micro-triangle: most of the work and memory at high levels) is left empty
// and vals[L − 1] is read straight from the packed bytes — a node of depth L − 1 is one byte of a 4-state map
// (uniform: 0x00, 0x55, 0xAA, 0xFF) or one nibble of a 2-state map (0x0, 0xF); the encoders read the leaves from
// the map (emitDfs, encodeRank, internRecord). Levels 0 and 1 keep vals[L].
std::vector<std::vector<uint8_t>> nodeValues(MapRef map) {
  const uint32_t level = map.level();
  std::vector<std::vector<uint8_t>> vals(level + 1);
  const size_t n = map.size();
  const uint8_t* bytes = map.bytes().data();
  const uint32_t bits = bitsPerState(map.format()), perByte = 8 / bits, mask = (1u << bits) - 1;
  uint32_t below = level;  // the deepest depth made
  if (level >= 2) {
    below = level - 1;
    vals[below].resize(n / 4);
    uint8_t* const v =
        vals[below].data();  // (locals: stores through v cannot move the vector's own pointers)
    const size_t nodes = n / 4;
    if (map.format() == Format::FourState) {
      // 0x00, 0x55, 0xAA, 0xFF: all 0, 1, 2, 3; any other byte mixed.
      static constexpr auto kByteNode = [] {
        std::array<uint8_t, 256> t{};
        for (uint32_t b = 0; b < 256; ++b) t[b] = b % 0x55u == 0 ? uint8_t(b / 0x55u) : kMixed;
        return t;
      }();
      for (size_t i = 0; i < nodes; ++i) v[i] = kByteNode[bytes[i]];
    } else {
      for (size_t i = 0; i < nodes; i += 2) {  // (nodes is a multiple of 4 from level 2 on)
        const uint32_t b = bytes[i / 2], lo = b & 15u, hi = b >> 4;
        v[i] = lo == 0 ? 0 : lo == 15 ? 1 : kMixed;
        v[i + 1] = hi == 0 ? 0 : hi == 15 ? 1 : kMixed;
      }
    }
  } else {
    // The leaves from the packed bytes (LSB first: 4 states a byte, or 8 in 2-state), the rest one by one.
    vals[level].resize(n);
    uint8_t* leaf = vals[level].data();
    size_t i = 0;
    for (; i + perByte <= n; i += perByte) {
      const uint32_t x = bytes[i / perByte];
      for (uint32_t k = 0; k < perByte; ++k) leaf[i + k] = uint8_t((x >> (bits * k)) & mask);
    }
    for (; i < n; ++i) leaf[i] = uint8_t(map.get(uint32_t(i)));
  }
  for (uint32_t d = below; d-- > 0;) {
    const size_t count = vals[d + 1].size() / 4;
    vals[d].resize(count);
    const uint8_t* const c = vals[d + 1].data();
    uint8_t* const v = vals[d].data();
    for (size_t i = 0; i < count; ++i) {
      uint32_t w;  // the 4 children's values, one word
      std::memcpy(&w, c + 4 * i, 4);
      const uint8_t a = uint8_t(w);
      v[i] = (a != kMixed && w == a * 0x01010101u) ? a : kMixed;
    }
  }
  return vals;
}

// (a leaf's state is read from the map: nodeValues leaves vals[L] empty)
void emitDfs(const std::vector<std::vector<uint8_t>>& vals, const MapRef& map, uint32_t d, uint32_t i,
             uint32_t bps, BitWriter& t, BitWriter& v) {
  const uint8_t s = d == map.level() ? uint8_t(map.get(i)) : vals[d][i];
  if (s != kMixed) {
    t.putBit(0);
    v.put(s, bps);
    return;
  }
  t.putBit(1);
  for (uint32_t c = 0; c < 4; ++c) emitDfs(vals, map, d + 1, 4 * i + c, bps, t, v);
}

std::vector<uint8_t> encodeDfs(MapRef map) {
  const auto vals = nodeValues(map);
  const uint32_t bps = bitsPerState(map.format());
  uint64_t internal = 0;
  for (const auto& level : vals)
    for (uint8_t s : level) internal += s == kMixed;
  BitWriter out, t, v;
  out.put(internal, countFieldBits(map.level()));
  out.padToByte();
  emitDfs(vals, map, 0, 0, bps, t, v);
  out.append(t);
  out.append(v);
  return out.bytes();
}

std::vector<uint8_t> encodeRank(MapRef map) {
  const auto vals = nodeValues(map);
  const uint32_t level = map.level();
  const uint32_t bps = bitsPerState(map.format());
  BitWriter flags, values;
  std::vector<uint32_t> nodes{0}, next;
  uint64_t internal = 0;
  for (uint32_t d = 0; d < level; ++d) {
    next.clear();
    for (uint32_t i : nodes) {
      const uint8_t s = vals[d][i];
      if (s == kMixed) {
        flags.putBit(1);
        ++internal;
        for (uint32_t c = 0; c < 4; ++c) next.push_back(4 * i + c);
      } else {
        flags.putBit(0);
        values.put(s, bps);
      }
    }
    nodes.swap(next);
  }
  for (uint32_t i : nodes) values.put(uint32_t(map.get(i)), bps);
  const uint64_t nf = flags.bits();
  uint32_t full = 0;  // leading levels whose nodes are all internal
  while (full < level &&
         std::all_of(vals[full].begin(), vals[full].end(), [](uint8_t v) { return v == kMixed; }))
    ++full;
  BitWriter out;
  out.put(internal, countFieldBits(level));
  out.put(nf, countFieldBits(level));
  if (level > 0) out.put(full, 4);
  out.padToByte();
  if (rankBlocks(nf) <= 1) {
    out.append(flags);
  } else {
    const uint32_t cw = rankCounterBits(internal);
    uint64_t before = 0;
    for (uint64_t b = 0; b < rankBlocks(nf); ++b) {
      const uint64_t start = b * kRankBlockBits, end = std::min<uint64_t>(nf, start + kRankBlockBits);
      uint64_t inBlock[4] = {0, 0, 0, 0};  // ones in words 0..3 of the block
      for (uint64_t k = start; k < end; ++k) inBlock[(k - start) / 64] += flags.bit(k);
      out.put(before, cw);
      out.put(inBlock[0], 8);
      out.put(inBlock[0] + inBlock[1], 8);
      out.put(inBlock[0] + inBlock[1] + inBlock[2], 8);
      for (uint64_t k = start; k < end; ++k) out.putBit(flags.bit(k));
      before += inBlock[0] + inBlock[1] + inBlock[2] + inBlock[3];
    }
  }
  out.append(values);
  return out.bytes();
}

void fillRange(Micromap& m, uint64_t start, uint64_t count, State s) {
  for (uint64_t i = 0; i < count; ++i) m.set(uint32_t(start + i), s);
}

// Pre-order walk of a dfs blob (trusted).
void decodeDfsNode(const uint8_t* t, uint64_t valueBase, Format f, uint32_t level, uint32_t d, uint64_t start,
                   uint64_t& pos, uint64_t& leaf, Micromap& out) {
  const uint64_t span = uint64_t(1) << (2 * (level - d));
  if (!getBit(t, pos++)) {
    fillRange(out, start, span, getValue(t, valueBase, f, leaf++));
    return;
  }
  for (uint32_t c = 0; c < 4; ++c)
    decodeDfsNode(t, valueBase, f, level, d + 1, start + c * span / 4, pos, leaf, out);
}

// Reads an untrusted bit with a bound.
struct Bounded {
  const uint8_t* p;
  uint64_t bits;
  bool get(uint64_t i, uint32_t& b) const {
    if (i >= bits) return false;
    b = getBit(p, i);
    return true;
  }
};

Error corrupt(std::string_view msg) {
  return makeError(ErrorCode::CorruptFile, std::string(msg));
}

}  // namespace

TreeShape treeShape(const Micromap& map) {
  const auto vals = nodeValues(map);
  TreeShape s;
  for (uint32_t d = 0; d < map.level(); ++d)
    for (uint8_t v : vals[d])
      if (v == kMixed) {
        ++s.internal;
        if (d + 1 == map.level()) ++s.internalAboveLast;
      }
  return s;
}

namespace {

// encodeMap of a map owned elsewhere.
std::vector<uint8_t> encodeBlob(MapRef map, MapKind kind) {
  switch (kind) {
    case MapKind::Flat: {
      const auto b = map.bytes();
      return std::vector<uint8_t>(b.begin(), b.end());
    }
    case MapKind::Dfs:
      return encodeDfs(map);
    case MapKind::Rank:
      return encodeRank(map);
    case MapKind::Csm:
    case MapKind::Sdag:
      break;  // array-wide DAGs: EncodedArray::build
  }
  return {};
}

}  // namespace

std::vector<uint8_t> encodeMap(const Micromap& map, MapKind kind) {
  return encodeBlob(map, kind);
}

Micromap decodeMap(const uint8_t* blob, MapKind kind, uint32_t level, Format f) {
  Micromap out(level, f);
  switch (kind) {
    case MapKind::Flat:
      std::memcpy(out.bytes().data(), blob, out.bytes().size());
      break;
    case MapKind::Dfs: {
      const uint32_t w = countFieldBits(level);
      const uint64_t internal = w ? getBits(blob, 0, w) : 0;
      const uint8_t* t = blob + dfsHeaderBytes(level);
      uint64_t pos = 0, leaf = 0;
      decodeDfsNode(t, 4 * internal + 1, f, level, 0, 0, pos, leaf, out);
      break;
    }
    case MapKind::Rank: {
      if (level == 0) {
        out.set(0, getValue(blob, 0, f, 0));
        break;
      }
      const uint32_t w = countFieldBits(level);
      const uint64_t internal = getBits(blob, 0, w);
      const uint64_t nf = getBits(blob, w, w);
      const uint8_t* fl = blob + rankHeaderBytes(level);
      const uint64_t valueBase = rankFlagRegionBits(nf, internal);
      // Level by level: (node position x, first micro-triangle).
      std::vector<uint64_t> starts{0}, next;
      uint64_t x = 0, leaf = 0;
      for (uint32_t d = 0; d < level; ++d) {
        const uint64_t span = uint64_t(1) << (2 * (level - d));
        next.clear();
        for (uint64_t start : starts) {
          if (getBit(fl, rankFlagPosition(x++, nf, internal))) {
            for (uint32_t c = 0; c < 4; ++c) next.push_back(start + c * span / 4);
          } else {
            fillRange(out, start, span, getValue(fl, valueBase, f, leaf++));
          }
        }
        starts.swap(next);
      }
      for (uint64_t start : starts) out.set(uint32_t(start), getValue(fl, valueBase, f, leaf++));
      break;
    }
    case MapKind::Csm:
    case MapKind::Sdag:
      break;  // array-wide DAGs: EncodedArray::decode
  }
  return out;
}

Result<uint64_t> validateMap(const uint8_t* blob, uint64_t available, MapKind kind, uint32_t level,
                             Format f) {
  const uint32_t bps = bitsPerState(f);
  const uint64_t maxInternal = ((uint64_t(1) << (2 * level)) - 1) / 3;
  switch (kind) {
    case MapKind::Flat: {
      const uint64_t size = flatMapBytes(level, f);
      if (size > available) return corrupt("flat micromap extends past the data buffer");
      return size;
    }
    case MapKind::Dfs: {
      const uint32_t w = countFieldBits(level);
      const uint64_t hdr = dfsHeaderBytes(level);
      if (hdr > available) return corrupt("dfs micromap header extends past the data buffer");
      uint64_t internal = 0;
      for (uint32_t i = 0; i < w; ++i) internal |= uint64_t((blob[i >> 3] >> (i & 7)) & 1u) << i;
      if (internal > maxInternal)
        return corrupt("dfs micromap declares more internal nodes than its level allows");
      const uint64_t tBits = 4 * internal + 1;
      const uint64_t size = hdr + (tBits + bps * (3 * internal + 1) + 7) / 8;
      if (size > available) return corrupt("dfs micromap extends past the data buffer");
      // Pre-order parse with a stack of pending children per depth.
      const Bounded t{blob + hdr, tBits};
      std::array<uint32_t, kMaxLevel + 2> pending{};
      uint32_t depth = 0;
      pending[0] = 1;
      uint64_t pos = 0, ones = 0;
      while (true) {
        uint32_t b;
        if (!t.get(pos++, b)) return corrupt("dfs micromap tree bits end early");
        --pending[depth];
        if (b) {
          if (depth == level) return corrupt("dfs micromap has an internal node below the last level");
          ++ones;
          pending[++depth] = 4;
        }
        while (pending[depth] == 0) {
          if (depth == 0) break;
          --depth;
        }
        if (depth == 0 && pending[0] == 0) break;
      }
      if (ones != internal || pos != tBits) return corrupt("dfs micromap tree bits disagree with its header");
      return size;
    }
    case MapKind::Rank: {
      if (level == 0) {
        if (available < 1) return corrupt("rank micromap extends past the data buffer");
        return uint64_t(1);
      }
      const uint32_t w = countFieldBits(level);
      const uint64_t hdr = rankHeaderBytes(level);
      if (hdr > available) return corrupt("rank micromap header extends past the data buffer");
      uint64_t internal = 0, nf = 0;
      for (uint32_t i = 0; i < w; ++i) {
        internal |= uint64_t((blob[i >> 3] >> (i & 7)) & 1u) << i;
        nf |= uint64_t((blob[(w + i) >> 3] >> ((w + i) & 7)) & 1u) << i;
      }
      uint32_t full = 0;
      for (uint32_t i = 0; i < 4; ++i)
        full |= uint32_t((blob[(2 * w + i) >> 3] >> ((2 * w + i) & 7)) & 1u) << i;
      if (internal > maxInternal || nf > maxInternal || internal > nf || full > level)
        return corrupt("rank micromap header counts exceed what its level allows");
      const uint64_t size = hdr + (rankFlagRegionBits(nf, internal) + bps * (3 * internal + 1) + 7) / 8;
      if (size > available) return corrupt("rank micromap extends past the data buffer");
      const uint8_t* fl = blob + hdr;
      auto flag = [&](uint64_t x) { return getBit(fl, rankFlagPosition(x, nf, internal)); };
      // Level sizes: 1, then 4 × the internal nodes of the level above; they must add up to nf.
      uint64_t x = 0, levelSize = 1, ones = 0;
      for (uint32_t d = 0; d < level; ++d) {
        if (levelSize > nf - x) return corrupt("rank micromap flags end early");
        uint64_t levelOnes = 0;
        for (uint64_t k = 0; k < levelSize; ++k) levelOnes += flag(x + k);
        if (d < full && levelOnes != levelSize) return corrupt("rank micromap full-level count is wrong");
        if (d == full && levelOnes == levelSize)
          return corrupt("rank micromap full-level count is too small");
        x += levelSize;
        ones += levelOnes;
        levelSize = 4 * levelOnes;
      }
      if (x != nf || ones != internal) return corrupt("rank micromap flags disagree with its header");
      if (rankBlocks(nf) > 1) {
        const uint32_t cw = rankCounterBits(internal);
        const uint64_t blockBits = kRankBlockBits + rankBlockHeaderBits(internal);
        auto field = [&](uint64_t bit, uint32_t n) {
          uint64_t v = 0;
          for (uint32_t i = 0; i < n; ++i) v |= uint64_t(getBit(fl, bit + i)) << i;
          return v;
        };
        uint64_t before = 0;
        for (uint64_t b = 0; b < rankBlocks(nf); ++b) {
          const uint64_t start = b * kRankBlockBits, end = std::min<uint64_t>(nf, start + kRankBlockBits);
          uint64_t inBlock[4] = {0, 0, 0, 0};
          for (uint64_t k = start; k < end; ++k) inBlock[(k - start) / 64] += flag(k);
          const uint64_t h = b * blockBits;
          if (field(h, cw) != before || field(h + cw, 8) != inBlock[0] ||
              field(h + cw + 8, 8) != inBlock[0] + inBlock[1] ||
              field(h + cw + 16, 8) != inBlock[0] + inBlock[1] + inBlock[2])
            return corrupt("rank micromap rank directory is inconsistent");
          before += inBlock[0] + inBlock[1] + inBlock[2] + inBlock[3];
        }
      }
      return size;
    }
    case MapKind::Csm:
    case MapKind::Sdag:
      break;
  }
  return corrupt("micromap kind is not a self-contained blob");
}

// ---------------------------------------------------------------- array-wide DAGs (csm, sdag)

namespace {

using Key = std::array<uint32_t, 16>;
struct KeyHash {
  size_t operator()(const Key& k) const noexcept {
    uint64_t h = 0x9e3779b97f4a7c15ull;
    for (uint32_t v : k) {
      h = (h ^ v) * 0xff51afd7ed558ccdull;
      h ^= h >> 29;
    }
    return size_t(h);
  }
};

constexpr uint32_t kNodeCode = 4;  // child codes: a state s < 4 (uniform child), or kNodeCode + record id

// Unique records per (format, height) = sdag region index: leaves keyed by their 16 states (2 bits each in
// key[0]), nodes by their 16 child codes. Ids in order of first appearance (children before parents).
struct DagTables {
  // A region's records in the order they were first interned (a record's id is its position) and an open-addressing
  // table over them: slot = (the key's hash's high half << 32) | (id + 1), 0 = empty; at most half full. (A
  // std::unordered_map held a node, a bucket pointer and a second copy of each 64-byte key: ~3× the memory, and most
  // of sdag's build time went to allocating and freeing its nodes.)
  struct Table {
    std::vector<Key> records;
    std::vector<uint64_t> slots;

    static constexpr uint64_t kTag = ~uint64_t(0xffffffffu);
    static uint64_t slotOf(uint64_t h, size_t id) noexcept { return (h & kTag) | (uint64_t(id) + 1); }
    // The slot holding k's id (hash h), or the empty slot where it goes.
    size_t probe(const Key& k, uint64_t h) const noexcept {
      const size_t mask = slots.size() - 1;
      for (size_t i = size_t(h) & mask;; i = (i + 1) & mask) {
        const uint64_t e = slots[i];
        if (e == 0 || ((e & kTag) == (h & kTag) && records[uint32_t(e) - 1] == k)) return i;
      }
    }
    void grow() {
      slots.assign(std::max<size_t>(64, slots.size() * 2), 0);
      for (size_t id = 0; id < records.size(); ++id) {
        const uint64_t h = KeyHash{}(records[id]);
        slots[probe(records[id], h)] = slotOf(h, id);
      }
    }
  };
  std::array<Table, kSdagRegions> t;
  std::vector<std::pair<uint32_t, uint32_t>>* created = nullptr;  // (region, id) of every new record
  // sdag: uniform children hold 1 bit (transparent / opaque), so a uniformly unknown subtree is a node child:
  // the uniform record of its height (a leaf of 16 equal states, or a node of 16 references to the one below).
  bool sdag = false;

  uint32_t intern(uint32_t region, const Key& k) {
    Table& tb = t[region];
    if (2 * (tb.records.size() + 1) > tb.slots.size()) tb.grow();
    const uint64_t h = KeyHash{}(k);
    const size_t i = tb.probe(k, h);
    if (tb.slots[i] != 0) return uint32_t(tb.slots[i]) - 1;
    const uint32_t id = uint32_t(tb.records.size());
    tb.slots[i] = Table::slotOf(h, id);
    tb.records.push_back(k);
    if (created) created->emplace_back(region, id);
    return id;
  }
  // The id of a record known to be in the region.
  uint32_t find(uint32_t region, const Key& k) const {
    const Table& tb = t[region];
    const uint64_t e = tb.slots.empty() ? 0 : tb.slots[tb.probe(k, KeyHash{}(k))];
    if (e == 0) throw std::out_of_range("sdag: record not interned");
    return uint32_t(e) - 1;
  }
};

// A map's node values (nodeValues: without the leaves) and its packed bytes, where internRecord reads the leaves.
struct NodeVals {
  std::vector<std::vector<uint8_t>> v;
  const uint8_t* bytes = nullptr;
  const std::vector<uint8_t>& operator[](size_t d) const { return v[d]; }
};

uint32_t internRecord(const NodeVals& vals, uint32_t level, Format f, uint32_t d, uint64_t i,
                      DagTables& tables);

Key uniformKey(uint32_t h, uint32_t s);

// The uniform record of height h and state s in region (f, h), for sdag's uniformly unknown children.
uint32_t internUniform(Format f, uint32_t h, uint32_t s, DagTables& tables) {
  Key k = uniformKey(h, s);
  if (h > 1) k.fill(kNodeCode + internUniform(f, h - 1, s, tables));
  return tables.intern(sdagRegion(f, h), k);
}

uint32_t internSubtree(const NodeVals& vals, uint32_t level, Format f, uint32_t d, uint64_t i,
                       DagTables& tables) {
  if (vals[d][i] != kMixed) {
    if (tables.sdag && vals[d][i] >= 2)
      return kNodeCode + internUniform(f, (level - d) / 2, vals[d][i], tables);
    return vals[d][i];
  }
  return kNodeCode + internRecord(vals, level, f, d, i, tables);
}

// The 16-way record of quadtree node (d, i) (level - d even, >= 2), uniform or not.
uint32_t internRecord(const NodeVals& vals, uint32_t level, Format f, uint32_t d, uint64_t i,
                      DagTables& tables) {
  const uint32_t h = (level - d) / 2;
  Key k{};
  if (h == 1) {
    // The 16 leaves 16i .. 16i + 15, 2 bits each (state s at bits 2s): a 4-state map's 4 bytes as they are, a
    // 2-state map's 2 bytes with each bit spread to 2.
    if (f == Format::FourState) {
      const uint8_t* p = vals.bytes + 4 * i;
      k[0] = uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
    } else {
      uint32_t x = uint32_t(vals.bytes[2 * i]) | uint32_t(vals.bytes[2 * i + 1]) << 8;
      x = (x | x << 8) & 0x00FF00FFu;  // bit s → bit 2s
      x = (x | x << 4) & 0x0F0F0F0Fu;
      x = (x | x << 2) & 0x33333333u;
      k[0] = (x | x << 1) & 0x55555555u;
    }
  } else {
    for (uint32_t s = 0; s < 16; ++s) k[s] = internSubtree(vals, level, f, d + 2, 16 * i + s, tables);
  }
  return tables.intern(sdagRegion(f, h), k);
}

Key uniformKey(uint32_t h, uint32_t s) {
  Key k{};
  if (h == 1) {
    for (uint32_t i = 0; i < 16; ++i) k[0] |= s << (2 * i);
  } else {
    k.fill(s);
  }
  return k;
}

// A map's root: levels 0/1 one byte of states; even levels a record of height L/2; odd levels a 4-way root.
struct DagRoot {
  uint32_t level = 0;
  Format format = Format::TwoState;
  uint8_t byte = 0;                    // levels 0, 1
  uint32_t id = 0;                     // even levels >= 2: record id in region (format, L/2)
  std::array<uint32_t, 4> children{};  // odd levels >= 3: child codes (height (L-1)/2)
  bool interned = false;               // in the DAG (internMap), not a map kept flat / dfs / rank
};

DagRoot internMap(MapRef m, DagTables& tables) {
  DagRoot r;
  r.interned = true;
  r.level = m.level();
  r.format = m.format();
  const uint32_t b = bitsPerState(m.format());
  if (r.level <= 1) {
    for (uint32_t i = 0; i < m.size(); ++i) r.byte = uint8_t(r.byte | uint32_t(m.get(i)) << (b * i));
    return r;
  }
  const NodeVals vals{nodeValues(m), m.bytes().data()};
  if (r.level % 2 == 0) {
    r.id = internRecord(vals, r.level, r.format, 0, 0, tables);
  } else {
    for (uint32_t c = 0; c < 4; ++c) r.children[c] = internSubtree(vals, r.level, r.format, 1, c, tables);
  }
  return r;
}

uint32_t bitsFor(uint64_t n) {  // bits to hold 0 .. n-1
  uint32_t w = 0;
  while (w < 32 && (uint64_t(1) << w) < n) ++w;
  return w;
}

// Whether the uniform children (codes < kNodeCode) of a 16-slot record all hold one state (true when there is at
// most one): its states field is then E = 0 and that state.
bool sdagUniformStatesAgree(const Key& k) {
  uint32_t first = kNodeCode;
  for (uint32_t s = 0; s < 16; ++s)
    if (k[s] < kNodeCode) {
      if (first == kNodeCode) first = k[s];
      if (k[s] != first) return false;
    }
  return true;
}

// Per region: the records stored in the region in emission order (most used first; the local ones are not
// listed: each is stored right after its only parent, include/somm/encode.h), each record's reference (leaf number
// or byte offset in the region; for a local record its byte offset from its parent's first byte), the record's
// own bytes and its subtree's (itself and its local descendants), and the directory fields.
struct SdagLayout {
  std::array<std::vector<uint32_t>, kSdagRegions> order;
  std::array<std::vector<uint32_t>, kSdagRegions> ref;
  std::array<std::vector<uint8_t>, kSdagRegions> isLocal;
  std::array<std::vector<uint64_t>, kSdagRegions> own;
  std::array<std::vector<uint64_t>, kSdagRegions> sub;
  std::array<std::vector<uint64_t>, kSdagRegions>
      pre;  // height 2: bytes of the local leaves stored before it
  std::array<uint64_t, kSdagRegions> bytes{};
  std::array<uint8_t, kSdagRegions> width{};
  std::array<uint8_t, kSdagRegions> tier{};
  std::array<uint8_t, kSdagRegions> mid{};
  std::array<uint8_t, kSdagRegions> local{};
  std::array<uint8_t, 2> xform{};  // per format: the leaf region's references carry a transform (version 8)

  bool localRec(uint32_t k, uint32_t id) const { return local[k] != 0 && isLocal[k][id] != 0; }
  bool isShort(uint32_t k, uint32_t id) const {
    return tier[k] != 0 && !localRec(k, id) && ref[k][id] < (uint64_t(1) << (tier[k] - 1u));
  }
  bool isMid(uint32_t k, uint32_t id) const {
    return mid[k] != 0 && !isShort(k, id) && !localRec(k, id) && ref[k][id] < (uint64_t(1) << (mid[k] - 1u));
  }
  bool hFlags(uint32_t k) const { return local[k] != 0 && k % 6 == 0; }  // a leaf region with local leaves
  uint32_t refBits(uint32_t k, uint32_t id) const {
    return isShort(k, id)                 ? tier[k] - 1u
           : isMid(k, id)                 ? mid[k] - 1u
           : hFlags(k) && localRec(k, id) ? 0u
                                          : width[k];
  }
  // The bits a reference to record id of region k costs in its parent besides the parent's per-child tier bit: the
  // reference, the G flag (not short, with mid tiers) and the H flag (neither short nor mid, leaf region with local
  // leaves). A local record's cost does not depend on its reference.
  uint32_t childBits(uint32_t k, uint32_t id) const {
    return refBits(k, id) + (mid[k] != 0 && !isShort(k, id)) +
           (hFlags(k) && !isShort(k, id) && !isMid(k, id));
  }
};

// Bits of the uniform children's states of a record of `slots` children, n of them nodes: 1 bit each in a 4-way
// root; in a 16-slot record none (n = 16), or the flag E and one state for all (2 bits) when they agree, else E and
// 1 bit each (version 7).
uint32_t sdagKeyStatesBits(const Key& k, uint32_t slots, uint32_t n) {
  if (slots != 16) return slots - n;
  if (n == 16) return 0;
  return sdagUniformStatesAgree(k) ? 2 : 17 - n;
}

// Bytes of a record of `slots` children whose node children are in region `below`; `cost(id)`: childBits of
// record id of that region.
template <class Cost>
uint64_t sdagNodeBytesWith(const Key& k, uint32_t slots, const SdagLayout& l, uint32_t below, Cost cost) {
  uint32_t n = 0;
  uint64_t bits = 0;
  for (uint32_t s = 0; s < slots; ++s)
    if (k[s] >= kNodeCode) {
      ++n;
      bits += cost(k[s] - kNodeCode);
    }
  return (bits + slots + sdagKeyStatesBits(k, slots, n) + (l.tier[below] != 0 ? n : 0) + 7) / 8;
}
uint64_t sdagNodeBytes(const Key& k, uint32_t slots, const SdagLayout& l, uint32_t below) {
  return sdagNodeBytesWith(k, slots, l, below, [&](uint32_t id) { return l.childBits(below, id); });
}

// below[b] = uses of the records (in `order`, references increasing) whose reference is < 2^b, b = 0..w.
std::vector<uint64_t> usesBelow(const std::vector<uint32_t>& order, const std::vector<uint32_t>& ref,
                                const std::vector<uint64_t>& uses, uint32_t w) {
  std::vector<uint64_t> below(w + 1, 0);
  size_t i = 0;
  uint64_t acc = 0;
  for (uint32_t b = 0; b <= w; ++b) {
    while (i < order.size() && ref[order[i]] < (uint64_t(1) << b)) acc += uses[order[i++]];
    below[b] = acc;
  }
  return below;
}

// The cheapest (tier, mid) pair, starting from `best` / `tiers`: for each short width sw < w the pair
// (sw + 1, twoMid) costing two(sw), then for each mid width sw < mw < w the pair (sw + 1, mw + 1) costing
// three(sw, mw) (ties: the earlier candidate).
template <class Two, class Three>
std::pair<uint8_t, uint8_t> cheapestTiers(uint32_t w, uint64_t best, std::pair<uint8_t, uint8_t> tiers,
                                          uint8_t twoMid, Two two, Three three) {
  for (uint32_t sw = 0; sw < w; ++sw) {
    if (const uint64_t c = two(sw); c < best) {
      best = c;
      tiers = {uint8_t(sw + 1), twoMid};
    }
    for (uint32_t mw = sw + 1; mw < w; ++mw)
      if (const uint64_t c = three(sw, mw); c < best) {
        best = c;
        tiers = {uint8_t(sw + 1), uint8_t(mw + 1)};
      }
  }
  return tiers;
}
constexpr uint64_t kNoCandidate = ~uint64_t(0);

// The tier and mid (0, or short / mid width + 1) that minimise the bits of `uses` references into records whose
// references `ref` increase along `order`: plain w bits; F + short / long; F + G + short / mid / long.
std::pair<uint8_t, uint8_t> bestTiers(const std::vector<uint32_t>& order, const std::vector<uint32_t>& ref,
                                      const std::vector<uint64_t>& uses, uint32_t w) {
  uint64_t total = 0;
  for (uint64_t u : uses) total += u;
  const std::vector<uint64_t> below = usesBelow(order, ref, uses, w);
  return cheapestTiers(
      w, total * w, {0, 0}, 0, [&](uint32_t sw) { return total + below[sw] * sw + (total - below[sw]) * w; },
      [&](uint32_t sw, uint32_t mw) {
        return total + (total - below[sw]) + below[sw] * sw + (below[mw] - below[sw]) * mw +
               (total - below[mw]) * w;
      });
}

// With local references (the long class): the region references (of the `order` records, wr bits reach all of
// them) are short, or short / mid with the mid class reaching all; `localUses` references are local (their width
// is the same in every choice). Tier 0 (every reference local) when no reference goes into the region.
std::pair<uint8_t, uint8_t> bestTiersLocal(const std::vector<uint32_t>& order,
                                           const std::vector<uint32_t>& ref,
                                           const std::vector<uint64_t>& uses, uint32_t wr,
                                           uint64_t localUses) {
  uint64_t regional = 0;
  for (uint32_t id : order) regional += uses[id];
  if (regional == 0) return {0, 0};
  const uint64_t total = regional + localUses;
  const std::vector<uint64_t> below = usesBelow(order, ref, uses, wr);
  return cheapestTiers(
      wr, total + regional * wr, {uint8_t(wr + 1), 0}, uint8_t(wr + 1),
      [&](uint32_t sw) { return total + (total - below[sw]) + below[sw] * sw + (regional - below[sw]) * wr; },
      [](uint32_t, uint32_t) { return kNoCandidate; });
}

// A leaf region with local leaves: short, mid and long region references as without, plus the H flags (one per
// reference neither short nor mid); local references take no bits.
std::pair<uint8_t, uint8_t> bestTiersLeafLocal(const std::vector<uint32_t>& order,
                                               const std::vector<uint32_t>& ref,
                                               const std::vector<uint64_t>& uses, uint32_t w,
                                               uint64_t localUses) {
  uint64_t regional = 0;
  for (uint32_t id : order) regional += uses[id];
  const uint64_t total = regional + localUses;
  const std::vector<uint64_t> below = usesBelow(order, ref, uses, w);
  return cheapestTiers(
      w, total + regional * w, {0, 0}, 0,
      [&](uint32_t sw) { return 2 * total - below[sw] + below[sw] * sw + (regional - below[sw]) * w; },
      [&](uint32_t sw, uint32_t mw) {
        return total + (total - below[sw]) + (total - below[mw]) + below[sw] * sw +
               (below[mw] - below[sw]) * mw + (regional - below[mw]) * w;
      });
}

// Places region k: with `withLocal`, the candidates (referenced once, from a node record) become local records;
// the others are stored in the region by use (ties: first appearance), each followed by its local subtree. Sets
// the region's references, bytes and classes; the local width (width[k]) is set by the caller.
void placeRegion(SdagLayout& l, uint32_t k, const std::vector<uint64_t>& uses,
                 const std::vector<uint8_t>& candidate, bool withLocal) {
  const uint32_t h = k % 6 + 1;
  const size_t count = uses.size();
  l.isLocal[k].assign(count, 0);
  uint64_t localUses = 0;
  if (withLocal)
    for (size_t i = 0; i < count; ++i)
      if (candidate[i]) {
        l.isLocal[k][i] = 1;
        localUses += uses[i];
      }
  auto& order = l.order[k];
  order.clear();
  for (uint32_t i = 0; i < count; ++i)
    if (!l.isLocal[k][i]) order.push_back(i);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) { return uses[x] > uses[y]; });
  l.ref[k].assign(count, 0);
  uint64_t off = 0;
  for (uint32_t i = 0; i < order.size(); ++i) {
    l.ref[k][order[i]] = h == 1 ? i : uint32_t(off + l.pre[k][order[i]]);
    off += l.sub[k][order[i]];
  }
  l.bytes[k] = off;
  const uint32_t wr = order.empty() ? 0 : bitsFor(uint64_t(l.ref[k][order.back()]) + 1);
  l.local[k] = withLocal ? 1 : 0;
  if (h == 1) l.xform[k / 6] = 0;
  l.width[k] = uint8_t(wr);
  std::tie(l.tier[k], l.mid[k]) = !withLocal ? bestTiers(order, l.ref[k], uses, wr)
                                  : h == 1   ? bestTiersLeafLocal(order, l.ref[k], uses, wr, localUses)
                                             : bestTiersLocal(order, l.ref[k], uses, wr, localUses);
}

// Leaf transforms (version 8, include/somm/encode.h kSdagLeafPerm): the leaf (2-bit states, packed) reached from
// stored leaf v with transform t.
uint32_t applyLeafTransform(uint32_t v, uint32_t t) {
  const uint64_t perm = kSdagLeafPerm[t & 7u];
  uint32_t o = 0;
  for (uint32_t i = 0; i < 16; ++i) o |= ((v >> (2u * ((perm >> (4u * i)) & 15u))) & 3u) << (2u * i);
  return o ^ ((t >> 3) * 0x55555555u);
}
constexpr uint32_t kLeafTransforms[12] = {0, 1, 2, 3, 4, 5, 8, 9, 10, 11, 12, 13};
// The smallest leaf reachable from v by a transform: equal for the leaves one transform apart (the transforms
// are a group: the six symmetries of the triangle and the complement).
uint32_t canonicalLeaf(uint32_t v) {
  uint32_t best = v;
  for (uint32_t t : kLeafTransforms) best = std::min(best, applyLeafTransform(v, t));
  return best;
}

// Places leaf region k with transforms (version 8): the leaves one transform apart form a class, stored once (the
// member with the most uses, ties: the first); a reference to a member is (the class's number << 4) | T, T the
// transform from the stored leaf to the member. With `withLocal`, a class used once (from a node record) is a
// local leaf. Classes by use (ties: first appearance); the leaves that are level-2 maps' roots (the descriptor
// holds their byte offset: no transform) are classes of their own. canon: canonicalLeaf of each leaf.
void placeLeafClasses(SdagLayout& l, uint32_t k, const std::vector<Key>& recs,
                      const std::vector<uint32_t>& canon, const std::vector<uint64_t>& uses,
                      const std::vector<uint64_t>& rootUses, const std::vector<uint8_t>& mapRoot,
                      bool withLocal) {
  const size_t count = recs.size();
  std::vector<uint32_t> cls(count), rep;
  std::vector<uint64_t> cUses, cRoot;
  std::unordered_map<uint32_t, uint32_t> byCanon;
  for (uint32_t id = 0; id < count; ++id) {
    uint32_t c = uint32_t(rep.size());
    if (!mapRoot[id]) c = byCanon.try_emplace(canon[id], c).first->second;
    if (c == rep.size()) {
      rep.push_back(id);
      cUses.push_back(0);
      cRoot.push_back(0);
    }
    cls[id] = c;
    cUses[c] += uses[id];
    cRoot[c] += rootUses[id] + mapRoot[id];
    if (uses[id] > uses[rep[c]]) rep[c] = id;
  }
  l.isLocal[k].assign(count, 0);
  l.ref[k].assign(count, 0);
  uint64_t localUses = 0;
  std::vector<uint32_t> region;
  for (uint32_t c = 0; c < rep.size(); ++c) {
    if (withLocal && cUses[c] == 1 && cRoot[c] == 0) continue;
    region.push_back(c);
  }
  std::stable_sort(region.begin(), region.end(), [&](uint32_t x, uint32_t y) { return cUses[x] > cUses[y]; });
  std::vector<uint32_t> number(rep.size(), ~0u);
  auto& order = l.order[k];
  order.clear();
  for (uint32_t i = 0; i < region.size(); ++i) {
    number[region[i]] = i;
    order.push_back(rep[region[i]]);
  }
  uint64_t maxRef = 0;
  std::vector<uint32_t> members;  // the region's members, by reference
  for (uint32_t id = 0; id < count; ++id) {
    const uint32_t c = cls[id];
    if (number[c] == ~0u) {
      l.isLocal[k][id] = 1;
      localUses += uses[id];
      continue;
    }
    const uint32_t stored = recs[rep[c]][0];
    uint32_t t = 0;
    for (uint32_t x : kLeafTransforms)
      if (applyLeafTransform(stored, x) == recs[id][0]) {
        t = x;
        break;
      }
    l.ref[k][id] = number[c] << 4 | t;
    maxRef = std::max<uint64_t>(maxRef, l.ref[k][id]);
    members.push_back(id);
  }
  std::sort(members.begin(), members.end(),
            [&](uint32_t x, uint32_t y) { return l.ref[k][x] < l.ref[k][y]; });
  l.bytes[k] = uint64_t(order.size()) * (k < 6 ? 2u : 4u);
  const uint32_t wr = members.empty() ? 0 : bitsFor(maxRef + 1);
  l.local[k] = withLocal ? 1 : 0;
  l.width[k] = uint8_t(wr);
  l.xform[k / 6] = 1;
  std::tie(l.tier[k], l.mid[k]) = withLocal ? bestTiersLeafLocal(members, l.ref[k], uses, wr, localUses)
                                            : bestTiers(members, l.ref[k], uses, wr);
}

// The records of region k+1 (parents of region k's): their own bytes, and the local references of their local
// children (byte offsets from the parent: its own bytes, then the subtrees of the local children before, in slot
// order). Returns the largest local reference + 1 and the total bytes of the parents.
std::pair<uint64_t, uint64_t> placeParents(SdagLayout& l, uint32_t k, const DagTables& tables) {
  const auto& recs = tables.t[k + 1].records;
  uint64_t reach = 0, total = 0;
  l.own[k + 1].resize(recs.size());
  // Each record of region k's childBits once, not once per reference (see childBits: a local record's cost does
  // not depend on the reference set below).
  std::vector<uint32_t> cost(tables.t[k].records.size());
  for (uint32_t id = 0; id < cost.size(); ++id) cost[id] = l.childBits(k, id);
  for (size_t id = 0; id < recs.size(); ++id) {
    const uint64_t own = sdagNodeBytesWith(recs[id], 16, l, k, [&](uint32_t c) { return cost[c]; });
    l.own[k + 1][id] = own;
    total += own;
    uint64_t off = own;
    if (k % 6 != 0)  // local leaves (before the parent) need no reference
      for (uint32_t c : recs[id])
        if (c >= kNodeCode && l.localRec(k, c - kNodeCode)) {
          l.ref[k][c - kNodeCode] = uint32_t(off + l.pre[k][c - kNodeCode]);
          reach = std::max(reach, off + l.pre[k][c - kNodeCode] + 1);
          off += l.sub[k][c - kNodeCode];
        }
  }
  return {reach, total};
}

SdagLayout sdagLayout(const DagTables& tables, const std::vector<DagRoot>& roots, bool allowXform) {
  // References to each record: from the records one height up and from the 4-way roots.
  std::array<std::vector<uint64_t>, kSdagRegions> uses, rootUses;
  for (uint32_t k = 0; k < kSdagRegions; ++k) {
    uses[k].assign(tables.t[k].records.size(), 0);
    rootUses[k].assign(tables.t[k].records.size(), 0);
  }
  for (uint32_t k = 0; k < kSdagRegions; ++k)
    if (k % 6 != 0)
      for (const Key& r : tables.t[k].records)
        for (uint32_t c : r)
          if (c >= kNodeCode) ++uses[k - 1][c - kNodeCode];
  for (const DagRoot& r : roots)
    if (r.level >= 3 && r.level % 2 == 1)
      for (uint32_t c : r.children)
        if (c >= kNodeCode) {
          ++uses[sdagRegion(r.format, (r.level - 1) / 2)][c - kNodeCode];
          ++rootUses[sdagRegion(r.format, (r.level - 1) / 2)][c - kNodeCode];
        }
  // The 4-way roots' bytes per region of their children (part of what a region's classes cost).
  auto rootBytes = [&](const SdagLayout& l, uint32_t k) {
    uint64_t total = 0;
    for (const DagRoot& r : roots)
      if (r.level >= 3 && r.level % 2 == 1 && sdagRegion(r.format, (r.level - 1) / 2) == k) {
        Key key{};
        for (uint32_t c = 0; c < 4; ++c) key[c] = r.children[c];
        total += sdagNodeBytes(key, 4, l, k);
      }
    return total;
  };
  SdagLayout l;
  for (Format f : {Format::TwoState, Format::FourState}) {
    const uint32_t b = bitsPerState(f);
    for (uint32_t h = 1; h <= 6; ++h) {
      const uint32_t k = sdagRegion(f, h);
      const auto& recs = tables.t[k].records;
      // Own and subtree bytes (region k-1 is placed and its local references are set).
      l.own[k].resize(recs.size());
      l.sub[k].resize(recs.size());
      l.pre[k].assign(recs.size(), 0);
      for (size_t id = 0; id < recs.size(); ++id) {
        l.own[k][id] = h == 1 ? 2 * b : l.own[k][id];
        if (h > 1)
          for (uint32_t c : recs[id])
            if (c >= kNodeCode && l.localRec(k - 1, c - kNodeCode)) {
              if (h == 2)
                l.pre[k][id] += 2 * b;
              else
                l.sub[k][id] += l.sub[k - 1][c - kNodeCode];
            }
        l.sub[k][id] += l.pre[k][id] + l.own[k][id];
      }
      std::vector<uint8_t> candidate(recs.size(), 0);
      bool any = false;
      for (size_t id = 0; id < recs.size(); ++id) {
        candidate[id] = h < 6 && uses[k][id] == 1 && rootUses[k][id] == 0;
        any = any || candidate[id];
      }
      if (h == 6) {
        placeRegion(l, k, uses[k], candidate, false);
        continue;
      }
      if (h == 1) {
        // Leaves: in the region, local, and (version 8) with transforms with or without local leaves; the
        // smallest parents (records of height 2 and 4-way roots) plus leaves wins, ties the earlier.
        std::vector<uint32_t> canon(recs.size());
        std::vector<uint8_t> mapRoot(recs.size(), 0);
        for (const DagRoot& r : roots)
          if (r.interned && r.level == 2 && r.format == f) mapRoot[r.id] = 1;
        std::unordered_set<uint32_t> classes;
        for (size_t id = 0; id < recs.size(); ++id) {
          canon[id] = canonicalLeaf(recs[id][0]);
          classes.insert(mapRoot[id] ? ~uint32_t(id) : canon[id]);
        }
        const bool xform = allowXform && classes.size() < recs.size();
        auto place = [&](int variant) {
          if (variant < 2)
            placeRegion(l, k, uses[k], candidate, variant == 1);
          else
            placeLeafClasses(l, k, recs, canon, uses[k], rootUses[k], mapRoot, variant == 3);
          uint64_t locals = 0;
          for (uint8_t x : l.isLocal[k]) locals += x;
          return placeParents(l, k, tables).second + rootBytes(l, k) + l.bytes[k] + locals * 2 * b;
        };
        int best = 0;
        uint64_t bestBytes = place(0);
        for (int v = 1; v < 4; ++v) {
          if ((v == 1 && !any) || (v >= 2 && !xform)) continue;
          if (const uint64_t bytes = place(v); bytes < bestBytes) {
            best = v;
            bestBytes = bytes;
          }
        }
        place(best);
        continue;
      }
      // Without local records, then with (the local width grown until it reaches every local reference);
      // the smaller parents (records one height up and 4-way roots) win, ties without.
      placeRegion(l, k, uses[k], candidate, false);
      const uint64_t plain = placeParents(l, k, tables).second + rootBytes(l, k);
      if (!any) continue;
      placeRegion(l, k, uses[k], candidate, true);
      uint8_t lw = h == 1 ? l.width[k] : 0;  // leaves: the width of long references (local ones take none)
      uint64_t withLocal = 0;
      for (;;) {
        l.width[k] = lw;
        const auto [reach, total] = placeParents(l, k, tables);
        const uint32_t need = h == 1 ? lw : bitsFor(reach);
        if (need <= lw) {
          withLocal = total + rootBytes(l, k);
          break;
        }
        lw = uint8_t(need);
      }
      if (withLocal >= plain) {
        placeRegion(l, k, uses[k], candidate, false);
        placeParents(l, k, tables);
      }
    }
  }
  return l;
}

uint64_t sdagRootBytes(const DagRoot& r, const SdagLayout& l) {
  if (r.level <= 1 || r.level % 2 == 0) return r.level <= 1 ? 1 : 0;  // even roots live in their region
  Key k{};
  for (uint32_t c = 0; c < 4; ++c) k[c] = r.children[c];
  return sdagNodeBytes(k, 4, l, sdagRegion(r.format, (r.level - 1) / 2));
}

uint64_t sdagRecordBytes(uint32_t region, uint32_t id, const DagTables&, const SdagLayout& l) {
  return l.own[region][id];
}

void putLeaf(BitWriter& out, uint32_t packed, uint32_t b) {
  for (uint32_t s = 0; s < 16; ++s) out.put((packed >> (2 * s)) & 3u, b);
}

// Mask, uniform states, the short flags (tiered region below), references, byte-padded.
void putSdagNode(BitWriter& out, const Key& k, uint32_t slots, const SdagLayout& l, uint32_t below) {
  uint32_t m = 0;
  for (uint32_t s = 0; s < slots; ++s)
    if (k[s] >= kNodeCode) m |= 1u << s;
  out.put(m, slots);
  if (slots == 16 && m != 0xffffu) {
    const bool agree = sdagUniformStatesAgree(k);
    out.put(agree ? 0 : 1, 1);  // E
    for (uint32_t s = 0; s < slots; ++s)
      if (k[s] < kNodeCode) {
        out.put(k[s], 1);
        if (agree) break;
      }
  } else {
    for (uint32_t s = 0; s < slots; ++s)
      if (k[s] < kNodeCode) out.put(k[s], 1);
  }
  if (l.tier[below] != 0)
    for (uint32_t s = 0; s < slots; ++s)
      if (k[s] >= kNodeCode) out.put(l.isShort(below, k[s] - kNodeCode) ? 1 : 0, 1);
  if (l.mid[below] != 0)
    for (uint32_t s = 0; s < slots; ++s)
      if (k[s] >= kNodeCode && !l.isShort(below, k[s] - kNodeCode))
        out.put(l.isMid(below, k[s] - kNodeCode) ? 1 : 0, 1);
  if (l.hFlags(below))
    for (uint32_t s = 0; s < slots; ++s)
      if (k[s] >= kNodeCode && !l.isShort(below, k[s] - kNodeCode) && !l.isMid(below, k[s] - kNodeCode))
        out.put(l.localRec(below, k[s] - kNodeCode) ? 1 : 0, 1);
  for (uint32_t s = 0; s < slots; ++s)
    if (k[s] >= kNodeCode) out.put(l.ref[below][k[s] - kNodeCode], l.refBits(below, k[s] - kNodeCode));
  out.padToByte();
}

struct DagMapOut {
  MapKind kind = MapKind::Flat;
  // Non-DAG kinds; in buildSdagWith's input, Flat with no blob stands for the map's own bytes.
  std::vector<uint8_t> blob;
};

// A record of region k, then its local children's subtrees in slot order (pre-order); at[k][id] = its offset.
void putSdagSubtree(BitWriter& out, const DagTables& tables, const SdagLayout& l, uint32_t k, uint32_t id,
                    std::array<std::vector<uint32_t>, kSdagRegions>& at) {
  const uint32_t h = k % 6 + 1, b = k < 6 ? 1 : 2;
  const Key& r = tables.t[k].records[id];
  if (h == 1) {
    at[k][id] = uint32_t(out.bits() / 8);
    putLeaf(out, r[0], b);
    return;
  }
  if (h == 2)  // local leaves before their parent
    for (uint32_t c : r)
      if (c >= kNodeCode && l.localRec(k - 1, c - kNodeCode))
        putSdagSubtree(out, tables, l, k - 1, c - kNodeCode, at);
  at[k][id] = uint32_t(out.bits() / 8);
  putSdagNode(out, r, 16, l, k - 1);
  if (h > 2)
    for (uint32_t c : r)
      if (c >= kNodeCode && l.localRec(k - 1, c - kNodeCode))
        putSdagSubtree(out, tables, l, k - 1, c - kNodeCode, at);
}

// Emits an sdag data buffer: directory, regions, then the other area (odd and level-0/1 roots, blobs of the
// non-DAG maps) in map order. offsets[m] = the map's descriptor offset.
std::vector<uint8_t> emitSdagWith(const DagTables& tables, const std::vector<DagRoot>& roots,
                                  const std::vector<DagMapOut>& kinds, std::vector<uint32_t>& offsets,
                                  SdagDirectory& dir, bool allowXform) {
  const SdagLayout l = sdagLayout(tables, roots, allowXform);
  BitWriter out;
  uint64_t base = kSdagDirectoryBytes;
  for (uint32_t k = 0; k < kSdagRegions; ++k) {
    dir.base[k] = uint32_t(base);
    dir.width[k] = l.width[k];
    dir.tier[k] = l.tier[k];
    dir.mid[k] = l.mid[k];
    dir.local[k] = l.local[k];
    base += l.bytes[k];
  }
  dir.base[kSdagRegions] = uint32_t(base);
  dir.xform[0] = l.xform[0];
  dir.xform[1] = l.xform[1];
  for (uint32_t k = 0; k <= kSdagRegions; ++k) out.put(dir.base[k], 32);
  for (uint32_t k = 0; k < kSdagRegions; ++k) out.put(dir.width[k], 8);
  for (uint32_t k = 0; k < kSdagRegions; ++k) out.put(dir.tier[k], 8);
  for (uint32_t k = 0; k < kSdagRegions; ++k) out.put(dir.mid[k], 8);
  for (uint32_t k = 0; k < kSdagRegions; ++k) out.put(dir.local[k], 8);
  for (uint32_t f = 0; f < 4; ++f) out.put(dir.xform[f], 8);
  std::array<std::vector<uint32_t>, kSdagRegions> at;
  for (uint32_t k = 0; k < kSdagRegions; ++k) at[k].assign(tables.t[k].records.size(), 0);
  for (uint32_t k = 0; k < kSdagRegions; ++k)
    for (uint32_t id : l.order[k]) putSdagSubtree(out, tables, l, k, id, at);
  offsets.assign(roots.size(), 0);
  for (size_t m = 0; m < roots.size(); ++m) {
    const DagRoot& r = roots[m];
    if (kinds[m].kind != MapKind::Sdag) {
      offsets[m] = uint32_t(out.bits() / 8);
      for (uint8_t byte : kinds[m].blob) out.put(byte, 8);
      continue;
    }
    if (r.level <= 1) {
      offsets[m] = uint32_t(out.bits() / 8);
      out.put(r.byte, 8);
    } else if (r.level % 2 == 0) {
      offsets[m] = at[sdagRegion(r.format, r.level / 2)][r.id];
    } else {
      offsets[m] = uint32_t(out.bits() / 8);
      Key k{};
      for (uint32_t c = 0; c < 4; ++c) k[c] = r.children[c];
      putSdagNode(out, k, 4, l, sdagRegion(r.format, (r.level - 1) / 2));
    }
  }
  return out.bytes();
}
// Leaf transforms need leaf handles of 28-bit offsets (include/somm/encode.h kSdagLeafTShift): a data buffer of
// 2^28 bytes or more is emitted again without them.
std::vector<uint8_t> emitSdag(const DagTables& tables, const std::vector<DagRoot>& roots,
                              const std::vector<DagMapOut>& kinds, std::vector<uint32_t>& offsets,
                              SdagDirectory& dir, bool allowXform = true) {
  dir = SdagDirectory{};
  std::vector<uint8_t> data = emitSdagWith(tables, roots, kinds, offsets, dir, allowXform);
  if ((dir.xform[0] | dir.xform[1]) != 0 && data.size() >= (uint64_t(1) << kSdagLeafTShift)) {
    dir = SdagDirectory{};
    data = emitSdagWith(tables, roots, kinds, offsets, dir, false);
  }
  return data;
}

// csm: the uniform non-transparent records every record (and root) refers to, then absolute offsets bottom-up.
std::vector<uint8_t> emitCsm(DagTables& tables, const std::vector<DagRoot>& roots,
                             std::vector<uint32_t>& offsets) {
  for (const DagRoot& r : roots)
    if (r.level >= 3 && r.level % 2 == 1)
      for (uint32_t c : r.children)
        if (c != 0 && c < kNodeCode)
          tables.intern(sdagRegion(r.format, (r.level - 1) / 2), uniformKey((r.level - 1) / 2, c));
  for (Format f : {Format::TwoState, Format::FourState})
    for (uint32_t h = 6; h >= 2; --h) {
      const uint32_t k = sdagRegion(f, h);
      for (size_t i = 0; i < tables.t[k].records.size(); ++i)
        for (uint32_t s = 0; s < 16; ++s) {
          const uint32_t c = tables.t[k].records[i][s];
          if (c != 0 && c < kNodeCode) tables.intern(k - 1, uniformKey(h - 1, c));
        }
    }
  std::array<std::vector<uint32_t>, kSdagRegions> off;
  uint64_t pos = 0;
  for (uint32_t k = 0; k < kSdagRegions; ++k) {
    const uint32_t h = k % 6 + 1, b = k < 6 ? 1 : 2;
    for (const Key& r : tables.t[k].records) {
      off[k].push_back(uint32_t(pos));
      pos += h == 1 ? 2 * b : 2 + 4 * uint64_t(16 - std::count(r.begin(), r.end(), 0u));
    }
  }
  BitWriter out;
  auto putNode = [&](const Key& r, uint32_t slots, uint32_t below, uint32_t childHeight) {
    uint32_t m = 0;
    for (uint32_t s = 0; s < slots; ++s)
      if (r[s] != 0) m |= 1u << s;
    out.put(m, 16);
    for (uint32_t s = 0; s < slots; ++s) {
      if (r[s] == 0) continue;
      const uint32_t id =
          r[s] >= kNodeCode ? r[s] - kNodeCode : tables.find(below, uniformKey(childHeight, r[s]));
      out.put(off[below][id], 32);
    }
  };
  for (uint32_t k = 0; k < kSdagRegions; ++k) {
    const uint32_t h = k % 6 + 1, b = k < 6 ? 1 : 2;
    for (const Key& r : tables.t[k].records) {
      if (h == 1)
        putLeaf(out, r[0], b);
      else
        putNode(r, 16, k - 1, h - 1);
    }
  }
  offsets.assign(roots.size(), 0);
  for (size_t m = 0; m < roots.size(); ++m) {
    const DagRoot& r = roots[m];
    if (r.level % 2 == 0 && r.level >= 2) {
      offsets[m] = off[sdagRegion(r.format, r.level / 2)][r.id];
      continue;
    }
    offsets[m] = uint32_t(out.bits() / 8);
    if (r.level <= 1) {
      out.put(r.byte, 8);
    } else {
      Key k{};
      for (uint32_t c = 0; c < 4; ++c) k[c] = r.children[c];
      const uint32_t h = (r.level - 1) / 2;
      putNode(k, 4, sdagRegion(r.format, h), h);
    }
  }
  return out.bytes();
}

// ---- decoding (trusted) ----

// Where the flags start in a record of `slots` children (16: a node record, 4: a 4-way root), n of them nodes: after
// the mask and the uniform children's states (a 4-way root: 1 bit each; a node record: include/somm/encode.h
// sdagStatesBits). The byte holding bit 16 must be readable when slots = 16 and n < 16.
uint32_t sdagFlagsPos(const uint8_t* p, uint32_t slots, uint32_t n) {
  return slots == 16 ? 16u + sdagStatesBits(n, p[2] & 1u) : slots + (slots - n);
}
// The state of uniform child number u of such a record.
State sdagUniformChild(const uint8_t* p, uint32_t slots, uint32_t u) {
  return State(slots == 16 ? sdagUniformState(load64(p + 2), u) : getBit(p, slots + u));
}

void sdagFill(const uint8_t* data, const SdagDirectory& dir, const uint8_t* p, Format f, uint32_t h,
              uint32_t slots, uint64_t start, Micromap& out, uint32_t t = 0) {
  if (h == 0) {  // a leaf's states (slots = 16, reached with transform t) or a level-0/1 root byte
    for (uint32_t s = 0; s < slots; ++s)
      out.set(uint32_t(start + s), slots == 16
                                       ? (f == Format::TwoState ? sdagLeafState<Format::TwoState>(p, s, t)
                                                                : sdagLeafState<Format::FourState>(p, s, t))
                                       : getValue(p, 0, f, s));
    return;
  }
  const uint32_t m = slots == 16 ? load16(p) : p[0] & 15u;
  const uint32_t k = sdagRegion(f, h), n = popcount64(m);
  const uint64_t span = uint64_t(1) << (4 * h);
  uint32_t ui = 0, ni = 0;
  for (uint32_t s = 0; s < slots; ++s) {
    if ((m >> s) & 1u) {
      const uint32_t a = sdagChildAt(dir, p, uint32_t(p - data), sdagFlagsPos(p, slots, n), n, ni++, k,
                                     h == 1 ? 2 * bitsPerState(f) : 0u);
      if (h == 1) {  // a leaf handle
        const SdagLeafAt l = sdagLeafOf(data, dir, f, a);
        sdagFill(data, dir, l.p, f, 0, 16, start + s * span, out, l.t);
      } else {
        sdagFill(data, dir, data + a, f, h - 1, 16, start + s * span, out);
      }
    } else {
      fillRange(out, start + s * span, span, sdagUniformChild(p, slots, ui++));
    }
  }
}

// h = height of the children of the record at p (0: p is a leaf / root byte).
void csmFill(const uint8_t* data, const uint8_t* p, Format f, uint32_t h, uint32_t slots, uint64_t start,
             Micromap& out) {
  if (h == 0) {
    for (uint32_t s = 0; s < slots; ++s) out.set(uint32_t(start + s), getValue(p, 0, f, s));
    return;
  }
  const uint32_t m = load16(p);
  const uint64_t span = uint64_t(1) << (4 * h);
  uint32_t ni = 0;
  for (uint32_t s = 0; s < slots; ++s) {
    if ((m >> s) & 1u)
      csmFill(data, data + load32(p + 2 + 4 * ni++), f, h - 1, 16, start + s * span, out);
    else
      fillRange(out, start + s * span, span, State::Transparent);
  }
}

// ---- validation (untrusted; every record checked once per (format, height), work and memory O(bytes)) ----

struct SdagChecker {
  const uint8_t* data;
  uint64_t dataBytes;
  const SdagDirectory& dir;
  std::array<std::vector<bool>, kSdagRegions> seen{};

  uint64_t regionBytes(uint32_t k) const { return uint64_t(dir.base[k + 1]) - dir.base[k]; }
  uint64_t end() const { return dir.base[kSdagRegions]; }
  // The child of height h that reference r of the record at `at` (of `bytes` bytes) refers to: a region
  // reference inside its region, a local one after the record and inside the regions.
  bool child(Format f, uint32_t h, uint64_t at, uint64_t bytes, SdagRefClass r) {
    const uint32_t k = sdagRegion(f, h), leaf = 2 * bitsPerState(f);
    if (h == 1 && dir.local[k] != 0 && r.isLong != 0)  // a local leaf, before the record
      return at >= dir.base[0] + uint64_t(r.ref) * leaf;
    if (h > 1 && (r.isLong & dir.local[k]) != 0) {
      if (r.ref < bytes || at + r.ref >= end()) return false;
      return h == 1 ? end() - (at + r.ref) >= leaf : node(f, h, at + r.ref);
    }
    if (h == 1 && dir.xform[uint32_t(f) - 1u] != 0)  // a leaf number and a transform (p < 6)
      return (r.ref >> 4) < regionBytes(k) / leaf && (r.ref & 7u) < 6;
    if (h == 1) return r.ref < regionBytes(k) / leaf;
    return r.ref < regionBytes(k) && node(f, h, dir.base[k] + uint64_t(r.ref));
  }
  // A record of `slots` children of height h at byte `at` with `avail` bytes.
  bool record(uint64_t at, uint64_t avail, Format f, uint32_t h, uint32_t slots) {
    const uint8_t* p = data + at;
    if (avail < (slots == 16 ? 2u : 1u)) return false;
    const uint32_t m = slots == 16 ? load16(p) : p[0] & 15u, n = popcount64(m);
    if (h == 0 && m != 0) return false;
    const uint32_t k = h == 0 ? 0 : sdagRegion(f, h);
    const uint32_t w = h == 0 ? 0 : dir.width[k], t = h == 0 ? 0 : dir.tier[k], u = h == 0 ? 0 : dir.mid[k];
    if (slots == 16 && n < 16 && avail < 3) return false;  // the states field's flag E
    const uint32_t pos = sdagFlagsPos(p, slots, n);
    if ((pos + (t != 0 ? n : 0) + 7) / 8 > avail) return false;                                    // F
    if (u != 0 && (pos + n + (n - popcount64(getBits(p, pos, n))) + 7) / 8 > avail) return false;  // G
    const bool hf = h == 1 && dir.local[k] != 0;  // H flags (a leaf region with local leaves)
    if (hf) {
      const uint32_t s = t != 0 ? popcount64(getBits(p, pos, n)) : 0;
      const uint32_t g = u != 0 ? popcount64(getBits(p, pos + n, n - s)) : 0;
      if ((pos + (t != 0 ? n : 0) + (u != 0 ? n - s : 0) + (n - s - g) + 7) / 8 > avail) return false;  // H
    }
    const uint64_t bytes = (pos + uint64_t(sdagRefBits(p, pos, n, w, t, u, hf)) + 7) / 8;
    if (bytes > avail) return false;
    for (uint32_t i = 0; i < n; ++i)
      if (!child(f, h, at, bytes,
                 hf ? sdagLeafRefClass(p, pos, n, i, w, t, u) : sdagRefClass(p, pos, n, i, w, t, u)))
        return false;
    return true;
  }
  // A node record of height h at byte `at` (in the regions).
  bool node(Format f, uint32_t h, uint64_t at) {
    const uint32_t k = sdagRegion(f, h);
    if (at < dir.base[0] || at >= end()) return false;
    if (seen[k].empty()) seen[k].resize(end(), false);
    if (seen[k][at]) return true;
    if (!record(at, end() - at, f, h - 1, 16)) return false;
    seen[k][at] = true;
    return true;
  }
  Status root(uint32_t offset, uint32_t level, Format f) {
    if (offset >= dataBytes) return corrupt("sdag root past the data buffer");
    if (level <= 1) return Ok{};
    if (level % 2 == 0) {
      const uint32_t h = level / 2;
      if (offset < dir.base[0] || offset >= end()) return corrupt("sdag root outside the regions");
      if (h == 1 ? end() - offset < 2 * bitsPerState(f) : !node(f, h, offset))
        return corrupt("sdag tree is malformed (record or reference out of range)");
      return Ok{};
    }
    if (!record(offset, dataBytes - offset, f, (level - 1) / 2, 4))
      return corrupt("sdag 4-way root is malformed");
    return Ok{};
  }
};

struct CsmChecker {
  const uint8_t* data;
  uint64_t dataBytes;
  std::array<std::vector<bool>, kSdagRegions> seen{};

  // A record of height h (1 = leaf) at absolute offset off.
  bool node(Format f, uint32_t h, uint64_t off) {
    if (off >= dataBytes) return false;
    if (h == 1) return dataBytes - off >= 2 * bitsPerState(f);
    const uint32_t k = sdagRegion(f, h);
    if (seen[k].empty()) seen[k].resize(dataBytes, false);
    if (seen[k][off]) return true;
    if (!children(f, h - 1, off, 16)) return false;
    seen[k][off] = true;
    return true;
  }
  bool children(Format f, uint32_t h, uint64_t off, uint32_t slots) {
    if (dataBytes - off < 2) return false;
    const uint32_t m = load16(data + off);
    if (m >> slots) return false;
    const uint32_t n = popcount64(m);
    if (2 + 4 * uint64_t(n) > dataBytes - off) return false;
    for (uint32_t i = 0; i < n; ++i)
      if (!node(f, h, load32(data + off + 2 + 4 * i))) return false;
    return true;
  }
  Status root(uint32_t offset, uint32_t level, Format f) {
    if (offset >= dataBytes) return corrupt("csm root past the data buffer");
    if (level <= 1) return Ok{};
    const bool ok = level % 2 == 0 ? node(f, level / 2, offset) : children(f, (level - 1) / 2, offset, 4);
    if (!ok) return corrupt("csm tree is malformed (record or pointer out of range)");
    return Ok{};
  }
};

}  // namespace

Micromap decodeDagMap(const uint8_t* data, const SdagDirectory* dir, uint32_t offset, MapKind kind,
                      uint32_t level, Format f) {
  Micromap out(level, f);
  const uint8_t* p = data + offset;
  if (level <= 1) {
    for (uint32_t i = 0; i < out.size(); ++i) out.set(i, getValue(p, 0, f, i));
    return out;
  }
  const uint32_t h = level / 2;  // even: the root's height; odd: its children's height
  if (kind == MapKind::Sdag) {
    if (level % 2 == 0)
      sdagFill(data, *dir, p, f, h - 1, 16, 0, out);
    else
      sdagFill(data, *dir, p, f, h, 4, 0, out);
  } else {
    if (level % 2 == 0)
      csmFill(data, p, f, h - 1, 16, 0, out);
    else
      csmFill(data, p, f, h, 4, 0, out);
  }
  return out;
}

}  // namespace encode

// ---------------------------------------------------------------- EncodedArray

namespace {

bool validDescriptor(const TriangleDescriptor& d) {
  return d.subdivisionLevel <= kMaxLevel && isValidFormat(d.format);
}

void putU32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
}
uint32_t getU32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// Whether the sdag walk keeps grandchild tables for an array with these maps: at most kGrandArrayMaps distinct
// roots (descriptors sharing bytes share a root).
bool fewRootsForGrandTables(const std::vector<EncodedMapDesc>& maps) {
  std::vector<uint32_t> roots;
  for (const EncodedMapDesc& d : maps)
    if (d.kind != MapKind::Flat) roots.push_back(d.offset);
  std::sort(roots.begin(), roots.end());
  return uint64_t(std::unique(roots.begin(), roots.end()) - roots.begin()) <= encode::kGrandArrayMaps;
}

uint64_t newIdentity() {
  static std::atomic<uint64_t> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

constexpr uint32_t kMagic = 0x434e4553;  // "SENC"
constexpr uint8_t kVersion = 1;          // arrays without the sdag directory
// Arrays with the sdag directory (104 bytes, local references, the node records' uniform-states field).
constexpr uint8_t kVersionDirectory = 7;
// The same with leaf transforms (the directory's bytes 100, 101; written only when a leaf region has them, so an
// array without them is byte-identical to version 7).
constexpr uint8_t kVersionTransforms = 8;
// Retired layouts of arrays with the sdag directory: refused with what they were.
struct RetiredVersion {
  uint8_t version;
  const char* what;
};
constexpr RetiredVersion kRetiredVersions[] = {
    {2, "the sdag layout with a 16/32-bit index buffer"},
    {3, "the sdag layout with 2-bit uniform states"},
    {4, "the sdag layout with the 80-byte directory and no rank-packed index buffer"},
    {5, "the sdag layout with the 96-byte directory, without local references"},
    {6, "the sdag layout with one bit per uniform child in every node record"},
};

}  // namespace

namespace {

// Maps kept flat / dfs / rank, one blob each, in descriptor order (the per-map encodings and plain hybrid).
std::vector<encode::DagMapOut> blobKinds(const std::vector<encode::MapRef>& maps, Encoding encoding) {
  std::vector<encode::DagMapOut> out(maps.size());
  for (size_t i = 0; i < maps.size(); ++i) {
    const encode::MapRef m = maps[i];
    encode::DagMapOut& o = out[i];
    switch (encoding) {
      case Encoding::Dfs:
      case Encoding::DfsFast:
        o.kind = MapKind::Dfs;
        o.blob = encode::encodeBlob(m, o.kind);
        break;
      case Encoding::Rank:
        o.kind = MapKind::Rank;
        o.blob = encode::encodeBlob(m, o.kind);
        break;
      case Encoding::Hybrid:
        // Smallest wins; ties go to the faster lookup (flat, then rank, then dfs).
        o.blob = encode::encodeBlob(m, MapKind::Flat);
        for (MapKind k : {MapKind::Rank, MapKind::Dfs}) {
          std::vector<uint8_t> b = encode::encodeBlob(m, k);
          if (b.size() < o.blob.size()) {
            o.blob = std::move(b);
            o.kind = k;
          }
        }
        break;
      default:
        o.blob = encode::encodeBlob(m, MapKind::Flat);
        break;
    }
  }
  return out;
}

struct SdagBuild {
  std::vector<uint8_t> data;
  std::vector<uint32_t> offsets;
  std::vector<encode::DagMapOut> kinds;
  encode::SdagDirectory dir;
  bool directory = true;
  bool xformCharged = false;  // pass 1's layout had leaf transforms
};

// sdag with per-map alternatives: pass 1 puts every map in the DAG and charges each the bytes of the records
// it adds first (with pass 1's widths); a map keeps its alternative blob when that is smaller (ties: a flat
// alternative wins, a dfs / rank one loses), and pass 2 builds the DAG of the others.
SdagBuild buildSdagWith(const std::vector<encode::MapRef>& maps, const std::vector<encode::DagMapOut>& choice,
                        bool allowXform) {
  // Which maps go into the DAG (the others keep their blob). Only those blobs are copied into the result: a copy of
  // every alternative (flat: the whole array again) was most of the encoder's peak memory.
  std::vector<uint8_t> inDag(maps.size(), 0);
  // A flat alternative with an empty blob stands for the map's own bytes (copied only if the map keeps it).
  auto blobBytes = [&](size_t i) -> uint64_t {
    return choice[i].kind == MapKind::Flat && choice[i].blob.empty() ? maps[i].bytes().size()
                                                                     : choice[i].blob.size();
  };
  bool charged = false;
  encode::DagTables tables;
  tables.sdag = true;
  std::vector<encode::DagRoot> roots;
  bool all = true;
  {
    std::vector<std::vector<std::pair<uint32_t, uint32_t>>> created(maps.size());
    for (size_t i = 0; i < maps.size(); ++i) {
      tables.created = &created[i];
      roots.push_back(encode::internMap(maps[i], tables));
    }
    tables.created = nullptr;
    const encode::SdagLayout l = encode::sdagLayout(tables, roots, allowXform);
    charged = (l.xform[0] | l.xform[1]) != 0;
    for (size_t i = 0; i < maps.size(); ++i) {
      uint64_t own = encode::sdagRootBytes(roots[i], l);
      for (const auto& [k, id] : created[i]) own += encode::sdagRecordBytes(k, id, tables, l);
      const uint64_t alt = blobBytes(i);
      inDag[i] = own < alt || (own == alt && choice[i].kind != MapKind::Flat);
      all = all && inDag[i];
    }
  }
  std::vector<encode::DagMapOut> kinds(maps.size());
  if (all) {
    // Every map stays in the DAG: pass 2 would intern the same maps in the same order into the same tables.
    for (auto& k : kinds) k.kind = MapKind::Sdag;
    SdagBuild b;
    b.data = encode::emitSdag(tables, roots, kinds, b.offsets, b.dir, allowXform);
    b.kinds = std::move(kinds);
    b.xformCharged = charged;
    return b;
  }
  tables = encode::DagTables{};
  tables.sdag = true;
  roots.clear();
  for (size_t i = 0; i < maps.size(); ++i) {
    if (inDag[i]) {
      kinds[i].kind = MapKind::Sdag;
      roots.push_back(encode::internMap(maps[i], tables));
    } else {
      kinds[i] = choice[i];
      if (kinds[i].kind == MapKind::Flat && kinds[i].blob.empty())
        kinds[i].blob.assign(maps[i].bytes().begin(), maps[i].bytes().end());
      roots.push_back(encode::DagRoot{maps[i].level(), maps[i].format()});
    }
  }
  SdagBuild b;
  b.data = encode::emitSdag(tables, roots, kinds, b.offsets, b.dir, allowXform);
  b.kinds = std::move(kinds);
  b.xformCharged = charged;
  return b;
}
// The same with leaf transforms where the layout takes them (chosen per leaf region, height by height; in pass
// 1 they change what each map is charged), unless the whole array without any is no larger (ties: without).
SdagBuild buildSdag(const std::vector<encode::MapRef>& maps, const std::vector<encode::DagMapOut>& choice) {
  SdagBuild b = buildSdagWith(maps, choice, true);
  if (!b.xformCharged && (b.dir.xform[0] | b.dir.xform[1]) == 0) return b;
  SdagBuild plain = buildSdagWith(maps, choice, false);
  return plain.data.size() <= b.data.size() ? plain : b;
}

}  // namespace

namespace {

// Writes `v`'s k low bits at bit `pos` of `out` (zeroed).
void putPackedBits(std::vector<uint8_t>& out, uint64_t pos, uint64_t v, uint32_t k) {
  for (uint32_t b = 0; b < k; ++b)
    if ((v >> b) & 1u) out[(pos + b) >> 3] |= uint8_t(1u << ((pos + b) & 7u));
}

// The packed index buffer of an array with the directory: k bits per triangle, or rank-packed around the most
// common value (ties: the smallest k-bit value) when that is smaller (ties: plain, one read).
struct IndexPlan {
  uint32_t bits = 0;
  uint64_t def = 0, listed = 0, bytes = 0;
  bool rank = false;
};
IndexPlan planIndex(const std::vector<int32_t>& indices, uint64_t maps) {
  IndexPlan p;
  p.bits = encode::sdagIndexBits(maps);
  const uint64_t mask = (uint64_t(1) << p.bits) - 1u;
  std::map<uint64_t, uint64_t> count;
  for (int32_t i : indices) ++count[uint64_t(int64_t(i)) & mask];
  uint64_t defCount = 0;
  for (const auto& [v, c] : count) {
    if (c <= defCount) continue;
    p.def = v;
    defCount = c;
  }
  p.listed = indices.size() - defCount;
  p.bytes = encode::packedIndexBytes(indices.size(), p.bits);
  const uint64_t rankBytes = encode::rankIndexBytes(indices.size(), p.listed, p.bits);
  if (!indices.empty() && rankBytes < p.bytes) {
    p.rank = true;
    p.bytes = rankBytes;
  }
  return p;
}

}  // namespace

Result<EncodedArray> EncodedArray::build(const OmmArray& array, Encoding encoding) {
  EncodedArray out;
  out.encoding_ = encoding;
  out.indexType_ = array.indexType();
  const uint64_t mapCount = array.descriptors.size();
  if (mapCount > uint64_t(INT32_MAX))
    return makeError(ErrorCode::LimitExceeded, "too many micromaps in the array");
  if (uint8_t(encoding) >= kEncodingCount) return makeError(ErrorCode::InvalidArgument, "unknown encoding");
  for (int32_t i : array.indices)
    if (!(isSpecialIndex(i) || (i >= 0 && uint64_t(i) < mapCount)))
      return makeError(ErrorCode::InvalidArgument,
                       "OMM array index " + std::to_string(i) + " is out of range");
  out.indices_ = array.indices;
  // Descriptors sharing one map (same offset, level and format) share its encoded map: memory and work stay
  // bounded by the distinct maps, not descriptors × map size (docs/hardening.md). Arrays made by OmmArrayBuilder
  // have no such sharing, so their encoding is unchanged.
  std::vector<encode::MapRef> maps;
  std::vector<uint32_t> mapOfDescriptor;
  mapOfDescriptor.reserve(mapCount);
  std::map<std::tuple<uint32_t, uint16_t, uint16_t>, uint32_t> seen;
  uint64_t flatTotal = 0;
  for (const TriangleDescriptor& d : array.descriptors) {
    if (!validDescriptor(d))
      return makeError(ErrorCode::InvalidArgument, "OMM array descriptor has a bad level or format");
    const Format f = Format(d.format);
    if (uint64_t(d.dataOffset) + micromapDataBytes(d.subdivisionLevel, f) > array.data.size())
      return makeError(ErrorCode::InvalidArgument, "OMM array descriptor points past the data buffer");
    const auto [it, fresh] =
        seen.emplace(std::make_tuple(d.dataOffset, d.subdivisionLevel, d.format), uint32_t(maps.size()));
    mapOfDescriptor.push_back(it->second);
    if (!fresh) continue;
    maps.emplace_back(array.data.data() + d.dataOffset, d.subdivisionLevel, f);  // the array's bytes, no copy
    flatTotal += maps.back().bytes().size();
  }
  if (flatTotal > UINT32_MAX / 2)
    return makeError(ErrorCode::LimitExceeded, "encoded micromap data exceeds 2 GiB");

  std::vector<encode::DagMapOut> kinds;
  std::vector<uint32_t> offsets;
  std::vector<uint8_t> data;
  if (encoding == Encoding::Csm) {
    encode::DagTables tables;
    std::vector<encode::DagRoot> roots;
    roots.reserve(maps.size());
    for (const encode::MapRef& m : maps) roots.push_back(encode::internMap(m, tables));
    data = encode::emitCsm(tables, roots, offsets);
    kinds.assign(maps.size(), encode::DagMapOut{MapKind::Csm, {}});
  } else if (encoding == Encoding::Sdag || encoding == Encoding::Hybrid) {
    // Every map's alternative is flat: empty blobs stand for the maps' own bytes (no copy of the array).
    SdagBuild best = buildSdag(maps, std::vector<encode::DagMapOut>(maps.size()));
    if (encoding == Encoding::Sdag && best.data.size() > encode::kSdagDirectoryBytes + flatTotal) {
      // Cannot happen with the per-map choice unless sharing shifted; the bound holds regardless.
      std::vector<encode::DagRoot> roots;
      roots.reserve(maps.size());
      for (const encode::MapRef& m : maps) roots.push_back(encode::DagRoot{m.level(), m.format()});
      best.kinds = blobKinds(maps, Encoding::Flat);
      best.dir = {};
      best.data = encode::emitSdag(encode::DagTables{}, roots, best.kinds, best.offsets, best.dir);
    }
    if (encoding == Encoding::Hybrid) {
      // The smallest of: sdag (maps in the DAG or flat), the DAG with dfs / rank blobs as further candidates,
      // and the DAG-free hybrid (no directory; ties go to it, then to plain sdag).
      std::vector<encode::DagMapOut> plain = blobKinds(maps, Encoding::Hybrid);
      SdagBuild mixed = buildSdag(maps, plain);
      if (mixed.data.size() < best.data.size()) best = std::move(mixed);
      uint64_t plainBytes = 0;
      for (const auto& o : plain) plainBytes += o.blob.size();
      // (with the directory the index buffer is packed: compare whole arrays)
      const uint64_t specIndex = uint64_t(array.indices.size()) * uint64_t(out.indexType_);
      const uint64_t packedIndex = planIndex(array.indices, mapCount).bytes;
      if (plainBytes + specIndex <= best.data.size() + packedIndex)
        best = SdagBuild{{}, {}, std::move(plain), {}, false};
    }
    data = std::move(best.data);
    offsets = std::move(best.offsets);
    kinds = std::move(best.kinds);
    out.hasDirectory_ = best.directory;
    out.dir_ = best.dir;
  } else {
    kinds = blobKinds(maps, encoding);
  }
  if (!out.hasDirectory_ && encoding != Encoding::Csm) {
    offsets.clear();
    for (const auto& o : kinds) {
      offsets.push_back(uint32_t(data.size()));
      data.insert(data.end(), o.blob.begin(), o.blob.end());
    }
  }
  if (data.size() > UINT32_MAX - encode::kTailPadding)
    return makeError(ErrorCode::LimitExceeded, "encoded micromap data exceeds 4 GiB");
  bool anyTree = (encoding != Encoding::Flat && encoding != Encoding::Hybrid) || out.hasDirectory_;
  for (uint32_t i : mapOfDescriptor) {
    out.maps_.push_back(
        EncodedMapDesc{offsets[i], uint8_t(maps[i].level()), uint8_t(maps[i].format()), kinds[i].kind, 0});
    anyTree |= kinds[i].kind != MapKind::Flat;
  }
  out.dataBytes_ = data.size();
  out.data_ = std::move(data);
  out.data_.resize(out.data_.size() + (anyTree ? encode::kTailPadding : 0), 0);
  if (out.hasDirectory_) out.packIndices();
  out.identity_ = newIdentity();
  out.grand_ = fewRootsForGrandTables(out.maps_);
  return out;
}

void EncodedArray::packIndices() {
  const IndexPlan plan = planIndex(indices_, maps_.size());
  indexBits_ = plan.bits;
  const uint32_t k = indexBits_;
  const uint64_t mask = (uint64_t(1) << k) - 1u, def = plan.def, triangles = indices_.size();
  if (plan.rank) {
    const uint64_t rankBytes = plan.bytes;
    indexGroups_ = encode::rankIndexGroups(triangles);
    packed_.assign(rankBytes + encode::kTailPadding, 0);
    const uint64_t values = 8 * indexGroups_;
    putPackedBits(packed_, values * 8, def, k);
    uint64_t n = 0;
    for (uint64_t g = 0; g < indexGroups_; ++g) {
      uint64_t word = n;
      for (uint64_t j = 0; j < encode::kRankIndexGroup && 32 * g + j < triangles; ++j) {
        const uint64_t v = uint64_t(int64_t(indices_[32 * g + j])) & mask;
        if (v == def) continue;
        word |= uint64_t(1) << (32 + j);
        putPackedBits(packed_, values * 8 + (1 + n) * k, v, k);
        ++n;
      }
      for (uint32_t b = 0; b < 8; ++b) packed_[8 * g + b] = uint8_t(word >> (8 * b));
    }
    return;
  }
  indexGroups_ = 0;
  packed_.assign(plan.bytes + encode::kTailPadding, 0);
  for (size_t t = 0; t < indices_.size(); ++t)
    putPackedBits(packed_, uint64_t(t) * k, uint64_t(int64_t(indices_[t])) & mask, k);
}

Micromap EncodedArray::decodeMap(uint32_t map) const {
  const EncodedMapDesc& d = maps_[map];
  return d.kind == MapKind::Csm || d.kind == MapKind::Sdag
             ? encode::decodeDagMap(data_.data(), &dir_, d.offset, d.kind, d.level, Format(d.format))
             : encode::decodeMap(data_.data() + d.offset, d.kind, d.level, Format(d.format));
}

OmmArray EncodedArray::decode() const {
  OmmArray a;
  a.indices = indices_;
  for (uint32_t i = 0; i < maps_.size(); ++i) {
    const EncodedMapDesc& d = maps_[i];
    const Micromap m = decodeMap(i);
    a.descriptors.push_back(TriangleDescriptor{uint32_t(a.data.size()), d.level, d.format});
    a.data.insert(a.data.end(), m.bytes().begin(), m.bytes().end());
  }
  computeUsageHistograms(a);
  return a;
}

std::vector<uint8_t> EncodedArray::serialize() const {
  std::vector<uint8_t> out;
  out.reserve(byteSize());
  putU32(out, kMagic);
  out.push_back(!hasDirectory_                         ? kVersion
                : (dir_.xform[0] | dir_.xform[1]) != 0 ? kVersionTransforms
                                                       : kVersionDirectory);
  out.push_back(uint8_t(encoding_));
  out.push_back(hasDirectory_ ? uint8_t(indexBits_) : uint8_t(indexType_));
  out.push_back(hasDirectory_ ? (indexGroups_ != 0 ? 3 : 1) : 0);
  putU32(out, uint32_t(indices_.size()));
  putU32(out, uint32_t(maps_.size()));
  putU32(out, uint32_t(dataBytes_));
  if (hasDirectory_) out.insert(out.end(), packed_.begin(), packed_.end() - encode::kTailPadding);
  for (int32_t i : indices_) {
    if (hasDirectory_) break;
    if (indexType_ == IndexType::UInt32) {
      putU32(out, uint32_t(i));
    } else {
      out.push_back(uint8_t(uint32_t(i)));
      out.push_back(uint8_t(uint32_t(i) >> 8));
    }
  }
  for (const EncodedMapDesc& d : maps_) {
    putU32(out, d.offset);
    out.push_back(d.level);
    out.push_back(d.format);
    out.push_back(uint8_t(d.kind));
    out.push_back(0);
  }
  out.insert(out.end(), data_.begin(), data_.end());
  return out;
}

Result<EncodedArray> EncodedArray::parse(Span<const uint8_t> bytes, std::string_view what) {
  const std::string prefix = std::string(what) + ": ";
  auto bad = [&](const std::string& msg) { return makeError(ErrorCode::CorruptFile, prefix + msg); };
  if (bytes.size() < encode::kArrayHeaderBytes) return bad("encoded array header is truncated");
  const uint8_t* p = bytes.data();
  if (getU32(p) != kMagic) return bad("not an encoded micromap array (bad magic)");
  for (const RetiredVersion& r : kRetiredVersions)
    if (p[4] == r.version)
      return makeError(ErrorCode::UnsupportedFormat,
                       prefix + "encoded array version " + std::to_string(r.version) + " (" + r.what +
                           ") is no longer supported (encode the micromaps again)");
  if (p[4] != kVersion && p[4] != kVersionDirectory && p[4] != kVersionTransforms)
    return makeError(ErrorCode::UnsupportedFormat,
                     prefix + "encoded array version " + std::to_string(p[4]) + " is not supported");
  if (p[4] == kVersion && p[7] == 1)
    return makeError(ErrorCode::UnsupportedFormat,
                     prefix +
                         "encoded array version 1 with the old sdag layout is no longer supported "
                         "(encode the micromaps again)");
  if ((p[4] == kVersionDirectory || p[4] == kVersionTransforms) && (p[7] & 1) != 1)
    return bad("encoded array version " + std::to_string(p[4]) + " without the sdag directory");
  if (p[5] >= kEncodingCount) return bad("unknown encoding id " + std::to_string(p[5]));
  const bool packed = p[4] == kVersionDirectory || p[4] == kVersionTransforms;
  if (!packed && p[6] != 2 && p[6] != 4) return bad("index size must be 2 or 4 bytes");
  const Encoding enc = Encoding(p[5]);
  if (p[7] > 3 || (p[7] & 1) != (enc == Encoding::Sdag || (enc == Encoding::Hybrid && (p[7] & 1))))
    return bad("bad flags byte (the directory flag is set for sdag, optional for hybrid)");
  if (p[7] == 2) return bad("bad flags byte (a rank-packed index buffer without the sdag directory)");
  EncodedArray out;
  out.encoding_ = enc;
  out.indexType_ = packed ? IndexType::UInt16 : IndexType(p[6]);
  out.hasDirectory_ = (p[7] & 1) != 0;
  const bool rankPacked = p[7] == 3;
  const uint64_t triangles = getU32(p + 8), mapCount = getU32(p + 12), dataBytes = getU32(p + 16);
  if (packed && p[6] != encode::sdagIndexBits(mapCount))
    return bad("packed index width " + std::to_string(p[6]) + " bits, expected " +
               std::to_string(encode::sdagIndexBits(mapCount)) + " for " + std::to_string(mapCount) +
               " micromaps");
  // Rank-packed: the group words first (their counts must be the true ranks), which give the listed count.
  uint64_t groups = 0, listed = 0;
  if (rankPacked) {
    if (triangles == 0) return bad("rank-packed index buffer of zero triangles");
    groups = encode::rankIndexGroups(triangles);
    if (encode::kArrayHeaderBytes + 8 * groups > bytes.size())
      return bad("encoded array is truncated (declares more bytes than present)");
    for (uint64_t g = 0; g < groups; ++g) {
      const uint8_t* w = p + encode::kArrayHeaderBytes + 8 * g;
      const uint32_t mask = getU32(w + 4), inGroup = uint32_t(std::min<uint64_t>(32, triangles - 32 * g));
      if (getU32(w) != listed)
        return bad("rank-packed index buffer: group " + std::to_string(g) + " count is wrong");
      if (inGroup < 32 && (mask >> inGroup) != 0)
        return bad("rank-packed index buffer lists triangles past the last one");
      listed += encode::popcount64(mask);
    }
  }
  const uint64_t indexBytes = rankPacked ? encode::rankIndexBytes(triangles, listed, p[6])
                              : packed   ? encode::packedIndexBytes(triangles, p[6])
                                         : triangles * p[6];
  const uint64_t fixed =
      encode::kArrayHeaderBytes + indexBytes + mapCount * encode::kDescriptorBytes + dataBytes;
  if (fixed > bytes.size()) return bad("encoded array is truncated (declares more bytes than present)");
  const uint64_t padding = bytes.size() - fixed;
  if (padding != 0 && padding != encode::kTailPadding) return bad("encoded array has trailing bytes");
  if (mapCount > uint64_t(INT32_MAX)) return bad("too many micromaps");
  const bool dagArray = enc == Encoding::Csm || out.hasDirectory_;
  if (dagArray && padding != encode::kTailPadding) return bad("encoded array tail padding is wrong");
  const uint8_t* q = p + encode::kArrayHeaderBytes;
  out.indices_.resize(triangles);
  if (packed) {
    out.indexBits_ = p[6];
    out.packed_.assign(q, q + indexBytes);
    out.packed_.resize(indexBytes + encode::kTailPadding, 0);
    out.indexGroups_ = groups;
    const uint64_t usedBits = rankPacked ? 64 * groups + (listed + 1) * p[6] : triangles * p[6];
    if (usedBits % 8 != 0 && (q[indexBytes - 1] >> (usedBits % 8)) != 0)
      return bad("packed index buffer has nonzero bits after the last triangle");
  }
  const int32_t defaultIndex = rankPacked ? encode::packedIndex(out.packed_.data() + 8 * groups, p[6], 0) : 0;
  if (rankPacked &&
      !(isSpecialIndex(defaultIndex) || (defaultIndex >= 0 && uint64_t(defaultIndex) < mapCount)))
    return bad("rank-packed index buffer: the default index " + std::to_string(defaultIndex) +
               " is out of range");
  for (uint64_t t = 0; t < triangles; ++t) {
    int32_t v;
    if (rankPacked) {
      v = encode::rankPackedIndex(out.packed_.data(), out.indexBits_, groups, uint32_t(t));
      const bool isListed = (getU32(q + 8 * (t >> 5) + 4) >> (t & 31u)) & 1u;
      if (isListed && v == defaultIndex)
        return bad("rank-packed index buffer lists triangle " + std::to_string(t) +
                   " with the default index");
      if (v >= 0 && v > 0xfffb) out.indexType_ = IndexType::UInt32;
    } else if (packed) {
      v = encode::packedIndex(out.packed_.data(), out.indexBits_, uint32_t(t));
      if (v >= 0 && v > 0xfffb) out.indexType_ = IndexType::UInt32;
    } else if (out.indexType_ == IndexType::UInt32) {
      v = int32_t(getU32(q));
      q += 4;
    } else {
      const uint32_t u = uint32_t(q[0]) | uint32_t(q[1]) << 8;
      v = u >= 0xfffcu ? int32_t(u | 0xffff0000u) : int32_t(u);
      q += 2;
    }
    if (!(isSpecialIndex(v) || (v >= 0 && uint64_t(v) < mapCount)))
      return bad("triangle " + std::to_string(t) + " has index " + std::to_string(v) + " out of range");
    out.indices_[t] = v;
  }
  if (packed) q += indexBytes;
  const uint8_t* data = q + mapCount * encode::kDescriptorBytes;
  if (out.hasDirectory_) {
    if (dataBytes < encode::kSdagDirectoryBytes) return bad("sdag directory is truncated");
    for (uint32_t k = 0; k <= encode::kSdagRegions; ++k) out.dir_.base[k] = getU32(data + 4 * k);
    for (uint32_t k = 0; k < encode::kSdagRegions; ++k) out.dir_.width[k] = data[52 + k];
    for (uint32_t k = 0; k < encode::kSdagRegions; ++k) out.dir_.tier[k] = data[64 + k];
    for (uint32_t k = 0; k < encode::kSdagRegions; ++k) out.dir_.mid[k] = data[76 + k];
    for (uint32_t k = 0; k < encode::kSdagRegions; ++k) out.dir_.local[k] = data[88 + k];
    for (uint32_t f = 0; f < 4; ++f) out.dir_.xform[f] = data[100 + f];
    if (p[4] == kVersionDirectory && getU32(data + 100) != 0)
      return bad("sdag directory's reserved bytes are not zero");
    if (p[4] == kVersionTransforms &&
        (data[100] > 1 || data[101] > 1 || (data[100] | data[101]) == 0 || data[102] != 0 || data[103] != 0))
      return bad("sdag directory's leaf transform flags are not 0 or 1 (one of them 1, bytes 102, 103 zero)");
    if ((data[100] | data[101]) != 0 && dataBytes >= (uint64_t(1) << encode::kSdagLeafTShift))
      return bad("sdag leaf transforms in a data buffer of 2^28 bytes or more");
    if (out.dir_.base[0] != encode::kSdagDirectoryBytes || out.dir_.base[encode::kSdagRegions] > dataBytes)
      return bad("sdag directory regions exceed the data buffer");
    for (uint32_t k = 0; k < encode::kSdagRegions; ++k) {
      // Without local references the short and mid classes are narrower than the long one; with them, the long
      // class is local and the short / mid classes may be up to 32 bits.
      const encode::SdagDirectory& d = out.dir_;
      const uint32_t top = d.local[k] != 0 ? 33 : d.width[k];
      if (d.base[k + 1] < d.base[k] || d.width[k] > 32 || d.local[k] > 1 || d.tier[k] > top ||
          (d.mid[k] != 0 && (d.tier[k] == 0 || d.mid[k] <= d.tier[k] || d.mid[k] > top)))
        return bad(
            "sdag directory is inconsistent (regions out of order, reference width above 32, local flag "
            "above 1, "
            "tier above the width, or mid not between the tier and the width)");
    }
  }
  encode::SdagChecker sdag{data, dataBytes, out.dir_};
  encode::CsmChecker csm{data, dataBytes};
  bool anyTree = false;
  out.maps_.resize(mapCount);
  // A map shared by several descriptors is validated once (work bounded by the distinct maps).
  std::map<std::tuple<uint32_t, uint8_t, uint8_t, uint8_t>, bool> validated;
  for (uint64_t m = 0; m < mapCount; ++m, q += encode::kDescriptorBytes) {
    EncodedMapDesc d{getU32(q), q[4], q[5], MapKind(q[6]), q[7]};
    const std::string which = "micromap " + std::to_string(m) + ": ";
    if (d.level > kMaxLevel)
      return bad(which + "subdivision level " + std::to_string(d.level) + " exceeds 12");
    if (!isValidFormat(d.format)) return bad(which + "format " + std::to_string(d.format) + " is not 1 or 2");
    if (d.reserved != 0 || q[6] > uint8_t(MapKind::Sdag)) return bad(which + "bad kind or reserved byte");
    bool kindOk;
    switch (enc) {
      case Encoding::Flat:
        kindOk = d.kind == MapKind::Flat;
        break;
      case Encoding::Dfs:
      case Encoding::DfsFast:
        kindOk = d.kind == MapKind::Dfs;
        break;
      case Encoding::Rank:
        kindOk = d.kind == MapKind::Rank;
        break;
      case Encoding::Csm:
        kindOk = d.kind == MapKind::Csm;
        break;
      case Encoding::Sdag:
        kindOk = d.kind == MapKind::Sdag || d.kind == MapKind::Flat;
        break;
      default:
        kindOk = d.kind != MapKind::Csm && (d.kind != MapKind::Sdag || out.hasDirectory_);
        break;
    }
    if (!kindOk) return bad(which + "kind " + mapKindName(d.kind) + " does not match the array's encoding");
    if (d.offset > dataBytes) return bad(which + "offset past the data buffer");
    const Format f = Format(d.format);
    if (d.kind == MapKind::Sdag) {
      if (Status st = sdag.root(d.offset, d.level, f); !st) return bad(which + st.error().message);
    } else if (d.kind == MapKind::Csm) {
      if (Status st = csm.root(d.offset, d.level, f); !st) return bad(which + st.error().message);
    } else if (validated.emplace(std::make_tuple(d.offset, d.level, d.format, uint8_t(d.kind)), true)
                   .second) {
      auto size = encode::validateMap(data + d.offset, dataBytes - d.offset, d.kind, d.level, f);
      if (!size) return bad(which + size.error().message);
    }
    anyTree |= d.kind != MapKind::Flat;
    out.maps_[m] = d;
  }
  const uint64_t wantPadding =
      anyTree || dagArray || (enc != Encoding::Flat && enc != Encoding::Hybrid) ? encode::kTailPadding : 0;
  if (padding != wantPadding) return bad("encoded array tail padding is wrong");
  out.data_.assign(data, data + dataBytes + padding);
  for (uint64_t i = dataBytes; i < out.data_.size(); ++i)
    if (out.data_[i] != 0) return bad("encoded array tail padding is not zero");
  out.dataBytes_ = dataBytes;
  out.identity_ = newIdentity();
  out.grand_ = fewRootsForGrandTables(out.maps_);
  return out;
}

Status verifyAgainstFlat(const EncodedArray& e, const OmmArray& flat, std::string_view what) {
  const std::string w(what);
  if (e.triangleCount() != flat.indices.size() || e.mapCount() != flat.descriptors.size())
    return makeError(ErrorCode::CorruptFile, w + ": " + std::to_string(e.triangleCount()) +
                                                 " triangles and " + std::to_string(e.mapCount()) +
                                                 " maps, flat has " + std::to_string(flat.indices.size()) +
                                                 " and " + std::to_string(flat.descriptors.size()));
  for (size_t t = 0; t < flat.indices.size(); ++t)
    if (e.indices()[t] != flat.indices[t])
      return makeError(ErrorCode::CorruptFile, w + ": triangle " + std::to_string(t) + " has index " +
                                                   std::to_string(e.indices()[t]) + ", flat has " +
                                                   std::to_string(flat.indices[t]));
  // Each distinct encoded map is decoded once and compared with the flat map of every descriptor using it
  // (a distinct flat map once per encoded map). Work is bounded: Σ 4^level over the distinct (encoded, flat)
  // pairs must stay within 8 states per byte of the two data buffers plus 2^20 (a well-formed array needs at
  // most 1 state per pair and byte); otherwise the file is refused rather than checked for minutes.
  const uint64_t budget = 8 * (uint64_t(e.dataBytes()) + flat.data.size()) * 4 + (uint64_t(1) << 20);
  uint64_t work = 0;
  std::map<std::tuple<uint32_t, uint8_t, uint8_t, uint8_t>, size_t> decoded;  // encoded desc → slot
  std::vector<Micromap> maps;
  std::map<std::pair<size_t, uint32_t>, bool> compared;  // (slot, flat offset)
  const auto descs = e.maps();
  for (size_t i = 0; i < flat.descriptors.size(); ++i) {
    const TriangleDescriptor& d = flat.descriptors[i];
    const EncodedMapDesc& m = descs[i];
    if (m.level != d.subdivisionLevel || m.format != d.format)
      return makeError(ErrorCode::CorruptFile,
                       w + ": map " + std::to_string(i) + " has level " + std::to_string(m.level) +
                           " format " + std::to_string(m.format) + ", flat has level " +
                           std::to_string(d.subdivisionLevel) + " format " + std::to_string(d.format));
    const auto key = std::make_tuple(m.offset, m.level, m.format, uint8_t(m.kind));
    auto it = decoded.find(key);
    if (it == decoded.end()) {
      work += microTriangleCount(m.level);
      if (work > budget)
        return makeError(ErrorCode::LimitExceeded,
                         w + ": checking this encoding against flat would decode more than " +
                             std::to_string(budget) +
                             " micro-triangle states (its maps are shared beyond what the data can hold)");
      maps.push_back(e.decodeMap(uint32_t(i)));
      it = decoded.emplace(key, maps.size() - 1).first;
    }
    if (!compared.emplace(std::make_pair(it->second, d.dataOffset), true).second) continue;
    const Micromap& a = maps[it->second];
    const Format f = Format(d.format);
    const uint8_t* fb = flat.data.data() + d.dataOffset;
    bool same = true;
    if (d.subdivisionLevel >= 2) {
      same = std::memcmp(a.bytes().data(), fb, a.bytes().size()) == 0;
    } else {
      for (uint32_t k = 0; k < microTriangleCount(d.subdivisionLevel) && same; ++k)
        same = readPackedState(a.bytes().data(), f, k) == readPackedState(fb, f, k);
    }
    if (!same) {
      uint32_t k = 0;
      while (k + 1 < microTriangleCount(d.subdivisionLevel) &&
             readPackedState(a.bytes().data(), f, k) == readPackedState(fb, f, k))
        ++k;
      return makeError(ErrorCode::CorruptFile, w + ": map " + std::to_string(i) + " micro-triangle " +
                                                   std::to_string(k) +
                                                   " differs from flat (the stored encoding "
                                                   "contradicts the spec buffers)");
    }
  }
  return Ok{};
}

}  // namespace somm
