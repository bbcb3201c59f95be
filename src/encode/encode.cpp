// SPDX-License-Identifier: MIT
#include "somm/encode.h"

#include <algorithm>
#include <array>

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
      return makeError(
          ErrorCode::InvalidArgument,
          "unknown encoding '" + std::string(name) + "' (expected flat, dfs, dfs-fast, rank, hybrid or all)");
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
  }
  return "?";
}

namespace encode {
namespace {

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
std::vector<std::vector<uint8_t>> nodeValues(const Micromap& map) {
  const uint32_t level = map.level();
  std::vector<std::vector<uint8_t>> vals(level + 1);
  vals[level].resize(map.size());
  for (uint32_t i = 0; i < map.size(); ++i) vals[level][i] = uint8_t(map.get(i));
  for (uint32_t d = level; d-- > 0;) {
    const std::vector<uint8_t>& c = vals[d + 1];
    std::vector<uint8_t>& v = vals[d];
    v.resize(c.size() / 4);
    for (size_t i = 0; i < v.size(); ++i) {
      const uint8_t a = c[4 * i];
      v[i] = (a != kMixed && c[4 * i + 1] == a && c[4 * i + 2] == a && c[4 * i + 3] == a) ? a : kMixed;
    }
  }
  return vals;
}

void emitDfs(const std::vector<std::vector<uint8_t>>& vals, uint32_t d, uint32_t i, uint32_t bps,
             BitWriter& t, BitWriter& v) {
  const uint8_t s = vals[d][i];
  if (s != kMixed) {
    t.putBit(0);
    v.put(s, bps);
    return;
  }
  t.putBit(1);
  for (uint32_t c = 0; c < 4; ++c) emitDfs(vals, d + 1, 4 * i + c, bps, t, v);
}

std::vector<uint8_t> encodeDfs(const Micromap& map) {
  const auto vals = nodeValues(map);
  const uint32_t bps = bitsPerState(map.format());
  uint64_t internal = 0;
  for (const auto& level : vals)
    for (uint8_t s : level) internal += s == kMixed;
  BitWriter out, t, v;
  out.put(internal, countFieldBits(map.level()));
  out.padToByte();
  emitDfs(vals, 0, 0, bps, t, v);
  out.append(t);
  out.append(v);
  return out.bytes();
}

std::vector<uint8_t> encodeRank(const Micromap& map) {
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
  for (uint32_t i : nodes) values.put(vals[level][i], bps);
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

std::vector<uint8_t> encodeMap(const Micromap& map, MapKind kind) {
  switch (kind) {
    case MapKind::Flat: {
      const auto b = map.bytes();
      return std::vector<uint8_t>(b.begin(), b.end());
    }
    case MapKind::Dfs:
      return encodeDfs(map);
    case MapKind::Rank:
      return encodeRank(map);
  }
  return {};
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
  }
  return corrupt("unknown micromap kind");
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

constexpr uint32_t kMagic = 0x434e4553;  // "SENC"
constexpr uint8_t kVersion = 1;

}  // namespace

Result<EncodedArray> EncodedArray::build(const OmmArray& array, Encoding encoding) {
  EncodedArray out;
  out.encoding_ = encoding;
  out.indexType_ = array.indexType();
  const uint64_t mapCount = array.descriptors.size();
  if (mapCount > uint64_t(INT32_MAX))
    return makeError(ErrorCode::LimitExceeded, "too many micromaps in the array");
  for (int32_t i : array.indices)
    if (!(isSpecialIndex(i) || (i >= 0 && uint64_t(i) < mapCount)))
      return makeError(ErrorCode::InvalidArgument,
                       "OMM array index " + std::to_string(i) + " is out of range");
  out.indices_ = array.indices;
  std::vector<uint8_t>& data = out.data_;
  bool anyTree = encoding != Encoding::Flat && encoding != Encoding::Hybrid;
  for (const TriangleDescriptor& d : array.descriptors) {
    if (!validDescriptor(d))
      return makeError(ErrorCode::InvalidArgument, "OMM array descriptor has a bad level or format");
    const Format f = Format(d.format);
    if (uint64_t(d.dataOffset) + micromapDataBytes(d.subdivisionLevel, f) > array.data.size())
      return makeError(ErrorCode::InvalidArgument, "OMM array descriptor points past the data buffer");
    Micromap m(d.subdivisionLevel, f);
    std::memcpy(m.bytes().data(), array.data.data() + d.dataOffset, m.bytes().size());
    MapKind kind = MapKind::Flat;
    std::vector<uint8_t> blob;
    switch (encoding) {
      case Encoding::Flat:
        blob = encode::encodeMap(m, MapKind::Flat);
        break;
      case Encoding::Dfs:
      case Encoding::DfsFast:
        kind = MapKind::Dfs;
        blob = encode::encodeMap(m, kind);
        break;
      case Encoding::Rank:
        kind = MapKind::Rank;
        blob = encode::encodeMap(m, kind);
        break;
      case Encoding::Hybrid: {
        // Smallest wins; ties go to the faster lookup (flat, then rank, then dfs).
        blob = encode::encodeMap(m, MapKind::Flat);
        for (MapKind k : {MapKind::Rank, MapKind::Dfs}) {
          std::vector<uint8_t> b = encode::encodeMap(m, k);
          if (b.size() < blob.size()) {
            blob = std::move(b);
            kind = k;
          }
        }
        if (kind != MapKind::Flat) anyTree = true;
        break;
      }
    }
    if (data.size() + blob.size() > UINT32_MAX)
      return makeError(ErrorCode::LimitExceeded, "encoded micromap data exceeds 4 GiB");
    out.maps_.push_back(
        EncodedMapDesc{uint32_t(data.size()), uint8_t(d.subdivisionLevel), uint8_t(d.format), kind, 0});
    data.insert(data.end(), blob.begin(), blob.end());
  }
  out.dataBytes_ = data.size();
  data.resize(data.size() + (anyTree ? encode::kTailPadding : 0), 0);
  return out;
}

OmmArray EncodedArray::decode() const {
  OmmArray a;
  a.indices = indices_;
  for (const EncodedMapDesc& d : maps_) {
    const Micromap m = encode::decodeMap(data_.data() + d.offset, d.kind, d.level, Format(d.format));
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
  out.push_back(kVersion);
  out.push_back(uint8_t(encoding_));
  out.push_back(uint8_t(indexType_));
  out.push_back(0);
  putU32(out, uint32_t(indices_.size()));
  putU32(out, uint32_t(maps_.size()));
  putU32(out, uint32_t(dataBytes_));
  for (int32_t i : indices_) {
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
  if (p[4] != kVersion)
    return makeError(ErrorCode::UnsupportedFormat,
                     prefix + "encoded array version " + std::to_string(p[4]) + " is not supported");
  if (p[5] > uint8_t(Encoding::Hybrid)) return bad("unknown encoding id " + std::to_string(p[5]));
  if (p[6] != 2 && p[6] != 4) return bad("index size must be 2 or 4 bytes");
  if (p[7] != 0) return bad("reserved header byte is not zero");
  EncodedArray out;
  out.encoding_ = Encoding(p[5]);
  out.indexType_ = IndexType(p[6]);
  const uint64_t triangles = getU32(p + 8), mapCount = getU32(p + 12), dataBytes = getU32(p + 16);
  const uint64_t fixed =
      encode::kArrayHeaderBytes + triangles * p[6] + mapCount * encode::kDescriptorBytes + dataBytes;
  if (fixed > bytes.size()) return bad("encoded array is truncated (declares more bytes than present)");
  const uint64_t padding = bytes.size() - fixed;
  if (padding != 0 && padding != encode::kTailPadding) return bad("encoded array has trailing bytes");
  if (mapCount > uint64_t(INT32_MAX)) return bad("too many micromaps");
  const uint8_t* q = p + encode::kArrayHeaderBytes;
  out.indices_.resize(triangles);
  for (uint64_t t = 0; t < triangles; ++t) {
    int32_t v;
    if (out.indexType_ == IndexType::UInt32) {
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
  const uint8_t* data = q + mapCount * encode::kDescriptorBytes;
  bool anyTree = false;
  out.maps_.resize(mapCount);
  for (uint64_t m = 0; m < mapCount; ++m, q += encode::kDescriptorBytes) {
    EncodedMapDesc d{getU32(q), q[4], q[5], MapKind(q[6]), q[7]};
    const std::string which = "micromap " + std::to_string(m) + ": ";
    if (d.level > kMaxLevel)
      return bad(which + "subdivision level " + std::to_string(d.level) + " exceeds 12");
    if (!isValidFormat(d.format)) return bad(which + "format " + std::to_string(d.format) + " is not 1 or 2");
    if (d.reserved != 0 || q[6] > uint8_t(MapKind::Rank)) return bad(which + "bad kind or reserved byte");
    const MapKind want = out.encoding_ == Encoding::Flat   ? MapKind::Flat
                         : out.encoding_ == Encoding::Rank ? MapKind::Rank
                         : out.encoding_ == Encoding::Dfs || out.encoding_ == Encoding::DfsFast ? MapKind::Dfs
                                                                                                : d.kind;
    if (d.kind != want)
      return bad(which + "kind " + mapKindName(d.kind) + " does not match the array's encoding");
    if (d.offset > dataBytes) return bad(which + "offset past the data buffer");
    auto size = encode::validateMap(data + d.offset, dataBytes - d.offset, d.kind, d.level, Format(d.format));
    if (!size) return bad(which + size.error().message);
    anyTree |= d.kind != MapKind::Flat;
    out.maps_[m] = d;
  }
  const uint64_t wantPadding =
      anyTree || (out.encoding_ != Encoding::Flat && out.encoding_ != Encoding::Hybrid) ? encode::kTailPadding
                                                                                        : 0;
  if (padding != wantPadding) return bad("encoded array tail padding is wrong");
  out.data_.assign(data, data + dataBytes + padding);
  for (uint64_t i = dataBytes; i < out.data_.size(); ++i)
    if (out.data_[i] != 0) return bad("encoded array tail padding is not zero");
  out.dataBytes_ = dataBytes;
  return out;
}

}  // namespace somm
