// SPDX-License-Identifier: MIT
// The .somm container (docs/somm-format.md).
#include "somm/somm_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "somm/io.h"

namespace somm {

namespace {

constexpr uint8_t kMagic[8] = {'S', 'O', 'M', 'M', 0x0d, 0x0a, 0x1a, 0x0a};
constexpr size_t kHeaderBytes = 32;
constexpr size_t kChunkHeaderBytes = 24;
constexpr uint32_t kNoGeometry = 0xffffffffu;
constexpr uint32_t kMaxStringBytes = 1u << 16;

constexpr uint32_t kMeta = sectionId("META");
constexpr uint32_t kGeom = sectionId("GEOM");
constexpr uint32_t kFlat = sectionId("FLAT");
constexpr uint32_t kEncd = sectionId("ENCD");
constexpr uint32_t kEnd = sectionId("END ");

constexpr size_t kFlatHeaderBytes = 32;

// ---- little-endian writing ----

class Writer {
 public:
  std::vector<uint8_t> out;
  void u8(uint8_t v) { out.push_back(v); }
  void u16(uint16_t v) {
    for (int i = 0; i < 2; ++i) out.push_back(uint8_t(v >> (8 * i)));
  }
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
  }
  void u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) out.push_back(uint8_t(v >> (8 * i)));
  }
  void f32(float f) {
    uint32_t v;
    std::memcpy(&v, &f, 4);
    u32(v);
  }
  void str(const std::string& s) {
    u32(uint32_t(s.size()));
    out.insert(out.end(), s.begin(), s.end());
  }
  void bytes(std::span<const uint8_t> b) { out.insert(out.end(), b.begin(), b.end()); }
  void patchU64(size_t at, uint64_t v) {
    for (int i = 0; i < 8; ++i) out[at + size_t(i)] = uint8_t(v >> (8 * i));
  }

  // With `refs`, large caller-owned byte ranges are referenced, not copied: the file is the sequence of
  // segments (own bytes of `out` or external ranges). Offsets into `out` (patchU64, Chunk::own) stay own
  // offsets; `pos()` is the logical file offset.
  struct Segment {
    size_t own = 0, size = 0;
    const uint8_t* external = nullptr;  // nullptr: out[own, own + size)
  };
  bool refs = false;
  std::vector<Segment> segments;
  size_t pos() const { return out.size() + externalBytes_; }
  void ref(std::span<const uint8_t> b) {
    if (!refs) return bytes(b);
    if (b.empty()) return;
    flush();
    segments.push_back(Segment{0, b.size(), b.data()});
    externalBytes_ += b.size();
  }
  void flush() {
    if (out.size() > mark_) segments.push_back(Segment{mark_, out.size() - mark_, nullptr});
    mark_ = out.size();
  }
  // XXH3 of the logical bytes [from, pos()) with `seed`.
  uint64_t hashFrom(size_t from, uint64_t seed) {
    if (!refs) return XXH3_64bits_withSeed(out.data() + from, out.size() - from, seed);
    flush();
    XXH3_state_t* st = XXH3_createState();
    XXH3_64bits_reset_withSeed(st, seed);
    size_t at = 0;
    for (const Segment& g : segments) {
      const size_t end = at + g.size;
      if (end > from) {
        const size_t skip = from > at ? from - at : 0;
        const uint8_t* p = g.external ? g.external : out.data() + g.own;
        XXH3_64bits_update(st, p + skip, g.size - skip);
      }
      at = end;
    }
    const uint64_t h = XXH3_64bits_digest(st);
    XXH3_freeState(st);
    return h;
  }

 private:
  size_t mark_ = 0, externalBytes_ = 0;
};

uint64_t loadU64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= uint64_t(p[i]) << (8 * i);
  return v;
}
uint32_t loadU32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
uint16_t loadU16(const uint8_t* p) {
  return uint16_t(p[0] | p[1] << 8);
}

uint64_t chunkChecksum(const uint8_t* header16, const uint8_t* payload, size_t size) {
  return XXH3_64bits_withSeed(payload, size, XXH3_64bits(header16, 16));
}

// Appends one chunk: header, payload, zero padding to a multiple of 8.
void putChunk(Writer& w, uint32_t type, uint32_t geometry, std::span<const uint8_t> payload) {
  const size_t at = w.out.size();
  w.u32(type);
  w.u32(geometry);
  w.u64(payload.size());
  w.u64(0);
  w.bytes(payload);
  w.patchU64(at + 16,
             chunkChecksum(w.out.data() + at, w.out.data() + at + kChunkHeaderBytes, payload.size()));
  while (w.pos() % 8) w.u8(0);
}

// The same chunk with its payload written into w in place (no payload copy): openChunk, the payload, closeChunk.
struct OpenChunk {
  size_t own, logical;  // the header's offset in w.out and in the file
};

OpenChunk openChunk(Writer& w, uint32_t type, uint32_t geometry) {
  const OpenChunk c{w.out.size(), w.pos()};
  w.u32(type);
  w.u32(geometry);
  w.u64(0);  // payload size, patched by closeChunk
  w.u64(0);  // checksum, patched by closeChunk
  return c;
}

// As chunkChecksum, over the payload written since openChunk (own or referenced bytes).
void closeChunk(Writer& w, OpenChunk c) {
  const size_t size = w.pos() - c.logical - kChunkHeaderBytes;
  w.patchU64(c.own + 8, size);
  w.patchU64(c.own + 16, w.hashFrom(c.logical + kChunkHeaderBytes, XXH3_64bits(w.out.data() + c.own, 16)));
  while (w.pos() % 8) w.u8(0);
}

std::string hex(uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// ---- checks shared by the writer and the reader ----

Status checkInfo(const GeometryInfo& in, const std::string& what) {
  auto fail = [&](ErrorCode code, const std::string& m) -> Status {
    return makeError(code, what + ": " + m);
  };
  if (!isValidFormat(uint32_t(in.format)))
    return fail(ErrorCode::CorruptFile, "format " + std::to_string(uint32_t(in.format)) + " is not 1 or 2");
  if (in.maxLevel > kMaxLevel)
    return fail(ErrorCode::CorruptFile, "max level " + std::to_string(in.maxLevel) + " exceeds 12");
  if (in.minLevel > in.maxLevel)
    return fail(ErrorCode::CorruptFile, "level range " + std::to_string(in.minLevel) + ".." +
                                            std::to_string(in.maxLevel) + " is empty");
  if (!std::isfinite(in.cutoff)) return fail(ErrorCode::CorruptFile, "cutoff is not finite");
  if (uint32_t(in.sampler.filter) > 1)
    return fail(ErrorCode::CorruptFile,
                "filter " + std::to_string(uint32_t(in.sampler.filter)) + " is not 0 or 1");
  if (uint32_t(in.sampler.wrapS) > 2 || uint32_t(in.sampler.wrapT) > 2)
    return fail(ErrorCode::CorruptFile, "wrap mode is not 0, 1 or 2");
  if (in.stats.unknownMicroTriangles > in.stats.microTriangles)
    return fail(ErrorCode::CorruptFile,
                "unknown micro-triangle count " + std::to_string(in.stats.unknownMicroTriangles) +
                    " exceeds the micro-triangle count " + std::to_string(in.stats.microTriangles));
  if (in.stats.invalidUvTriangles > in.triangleCount)
    return fail(ErrorCode::CorruptFile, "invalid-UV triangle count exceeds the triangle count");
  if (in.name.size() > kMaxStringBytes || in.material.size() > kMaxStringBytes)
    return fail(ErrorCode::LimitExceeded, "name longer than 65536 bytes");
  return Ok{};
}

// Every descriptor geometry g uses (through its range of the array's index buffer) has the geometry's format and a
// level in its range. Call after validateOmmArray(a) and with the range inside a.indices.
Status checkGeometryMaps(const GeometryInfo& in, const OmmArray& a, const GeometryMicromaps& r,
                         const std::string& what) {
  for (uint32_t t = 0; t < r.triangleCount; ++t) {
    const int32_t i = a.indices[size_t(r.firstTriangle) + t];
    if (isSpecialIndex(i)) continue;
    const TriangleDescriptor& d = a.descriptors[size_t(i)];
    if (d.format != uint16_t(in.format))
      return makeError(ErrorCode::CorruptFile, what + ": triangle " + std::to_string(t) +
                                                   " uses descriptor " + std::to_string(i) + " of format " +
                                                   std::to_string(d.format) + " but the geometry is format " +
                                                   std::to_string(uint32_t(in.format)));
    if (d.subdivisionLevel < in.minLevel || d.subdivisionLevel > in.maxLevel)
      return makeError(ErrorCode::CorruptFile,
                       what + ": triangle " + std::to_string(t) + " uses descriptor " + std::to_string(i) +
                           " of level " + std::to_string(d.subdivisionLevel) + " outside the level range " +
                           std::to_string(in.minLevel) + ".." + std::to_string(in.maxLevel));
  }
  return Ok{};
}

Status checkEncodings(const std::vector<EncodedSection>& extra, const std::string& what) {
  for (size_t i = 0; i < extra.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (extra[i].id == extra[j].id)
        return makeError(ErrorCode::CorruptFile,
                         what + ": encoding '" + sectionIdName(extra[i].id) + "' stored twice");
  return Ok{};
}

// The whole file as the writer sees it (the reader checks the same rules chunk by chunk).
Status checkFile(const SommFile& f) {
  const SceneMicromaps& m = f.micromaps;
  if (m.geometries.size() != f.geometries.size())
    return makeError(ErrorCode::InvalidArgument, std::to_string(f.geometries.size()) +
                                                     " geometries but micromaps for " +
                                                     std::to_string(m.geometries.size()));
  if (f.encodings.size() != m.arrays.size())
    return makeError(
        ErrorCode::InvalidArgument,
        std::to_string(m.arrays.size()) + " arrays but encodings for " + std::to_string(f.encodings.size()));
  if (f.geometries.size() > 0xffffffffull || m.arrays.size() > 0xfffffffeull)
    return makeError(ErrorCode::LimitExceeded, "too many geometries or arrays");
  std::vector<uint64_t> next(m.arrays.size(), 0);
  for (size_t g = 0; g < f.geometries.size(); ++g) {
    const std::string what = "geometry " + std::to_string(g);
    const GeometryInfo& in = f.geometries[g];
    const GeometryMicromaps& r = m.geometries[g];
    if (Status s = checkInfo(in, what); !s) return s;
    if (r.triangleCount != in.triangleCount)
      return makeError(ErrorCode::CorruptFile, what + ": triangle count " + std::to_string(in.triangleCount) +
                                                   " but its micromaps cover " +
                                                   std::to_string(r.triangleCount));
    if (r.array >= m.arrays.size())
      return makeError(ErrorCode::CorruptFile, what + ": array " + std::to_string(r.array) +
                                                   " does not exist (" + std::to_string(m.arrays.size()) +
                                                   " arrays)");
    if (r.firstTriangle != next[r.array])
      return makeError(ErrorCode::CorruptFile,
                       what + ": starts at triangle " + std::to_string(r.firstTriangle) + " of array " +
                           std::to_string(r.array) + ", expected " + std::to_string(next[r.array]) +
                           " (the geometries of an array tile its index buffer in geometry order)");
    next[r.array] += r.triangleCount;
  }
  for (size_t a = 0; a < m.arrays.size(); ++a) {
    const std::string what = "array " + std::to_string(a);
    if (Status s = validateOmmArray(m.arrays[a], what); !s) return s;
    if (next[a] != m.arrays[a].indices.size())
      return makeError(ErrorCode::CorruptFile, what + ": its geometries cover " + std::to_string(next[a]) +
                                                   " triangles but its index buffer has " +
                                                   std::to_string(m.arrays[a].indices.size()));
    if (Status s = checkEncodings(f.encodings[a], what); !s) return s;
  }
  for (size_t g = 0; g < f.geometries.size(); ++g)
    if (Status s = checkGeometryMaps(f.geometries[g], m.arrays[m.geometries[g].array], m.geometries[g],
                                     "geometry " + std::to_string(g));
        !s)
      return s;
  return Ok{};
}

// ---- reading ----

class Reader {
 public:
  Reader(const uint8_t* p, size_t n) : p_(p), n_(n) {}
  size_t remaining() const { return n_ - pos_; }
  size_t pos() const { return pos_; }
  bool u8(uint8_t& v) { return take(1) && (v = p_[pos_ - 1], true); }
  bool u16(uint16_t& v) { return take(2) && (v = loadU16(p_ + pos_ - 2), true); }
  bool u32(uint32_t& v) { return take(4) && (v = loadU32(p_ + pos_ - 4), true); }
  bool u64(uint64_t& v) { return take(8) && (v = loadU64(p_ + pos_ - 8), true); }
  bool f32(float& f) {
    uint32_t v;
    if (!u32(v)) return false;
    std::memcpy(&f, &v, 4);
    return true;
  }
  // A length-prefixed string; the length is checked against the bytes left before anything is allocated.
  bool str(std::string& s) {
    uint32_t len;
    if (!u32(len) || len > remaining() || len > kMaxStringBytes) return false;
    s.assign(reinterpret_cast<const char*>(p_ + pos_), len);
    pos_ += len;
    return true;
  }
  const uint8_t* here() const { return p_ + pos_; }
  bool skip(size_t k) { return take(k); }

 private:
  bool take(size_t k) {
    if (k > n_ - pos_) return false;
    pos_ += k;
    return true;
  }
  const uint8_t* p_;
  size_t n_;
  size_t pos_ = 0;
};

// "chunk 3 'FLAT' of array 0 at offset 184": FLAT and ENCD chunks belong to an array (version 1: a geometry).
std::string describeChunk(size_t ordinal, uint32_t type, uint32_t index, size_t offset, bool v1) {
  std::string s = "chunk " + std::to_string(ordinal) + " '" + sectionIdName(type) + "'";
  const bool ofArray = !v1 && (type == kFlat || type == kEncd);
  if (index != kNoGeometry) s += (ofArray ? " of array " : " of geometry ") + std::to_string(index);
  return s + " at offset " + std::to_string(offset);
}

Status parseFlat(const uint8_t* p, size_t n, OmmArray& a, const std::string& what) {
  auto corrupt = [&](const std::string& m) -> Status {
    return makeError(ErrorCode::CorruptFile, what + ": " + m);
  };
  Reader r(p, n);
  uint32_t triangles, descriptors, indexType, hist, triHist, reserved;
  uint64_t dataBytes;
  if (!r.u32(triangles) || !r.u32(descriptors) || !r.u32(indexType) || !r.u32(hist) || !r.u32(triHist) ||
      !r.u32(reserved) || !r.u64(dataBytes))
    return corrupt("payload of " + std::to_string(n) + " bytes is shorter than its 32-byte header");
  if (indexType != 2 && indexType != 4)
    return corrupt("index type " + std::to_string(indexType) + " is not 2 (16-bit) or 4 (32-bit)");
  if (reserved != 0) return corrupt("reserved field is " + std::to_string(reserved) + ", not 0");
  // Every count is bounded by the payload size before anything is allocated (all terms < 2^40: no overflow).
  if (dataBytes > n) return corrupt("data size " + std::to_string(dataBytes) + " exceeds the payload size");
  const uint64_t need = kFlatHeaderBytes + 8ull * descriptors + 12ull * (uint64_t(hist) + triHist) +
                        uint64_t(indexType) * triangles + dataBytes;
  if (need != n)
    return corrupt("counts (" + std::to_string(triangles) + " triangles, " + std::to_string(descriptors) +
                   " descriptors, " + std::to_string(hist) + "+" + std::to_string(triHist) +
                   " histogram entries, " + std::to_string(dataBytes) + " data bytes) need " +
                   std::to_string(need) + " bytes but the payload has " + std::to_string(n));
  a.descriptors.resize(descriptors);
  for (TriangleDescriptor& d : a.descriptors) {
    (void)r.u32(d.dataOffset);
    (void)r.u16(d.subdivisionLevel);
    (void)r.u16(d.format);
  }
  auto readHist = [&](std::vector<UsageCount>& h, uint32_t count) {
    h.resize(count);
    for (UsageCount& c : h) {
      (void)r.u32(c.count);
      (void)r.u32(c.subdivisionLevel);
      (void)r.u32(c.format);
    }
  };
  readHist(a.histogram, hist);
  readHist(a.triangleHistogram, triHist);
  a.indices.resize(triangles);
  for (uint32_t t = 0; t < triangles; ++t) {
    int64_t v;
    if (indexType == 2) {
      uint16_t x = 0;
      (void)r.u16(x);
      v = x >= 0xfffc ? int64_t(x) - 0x10000 : int64_t(x);
    } else {
      uint32_t x = 0;
      (void)r.u32(x);
      v = x >= 0xfffffffcu ? int64_t(x) - 0x100000000ll : int64_t(x);
    }
    if (v >= int64_t(descriptors))
      return corrupt("index of triangle " + std::to_string(t) + " is " + std::to_string(v) +
                     " but there are only " + std::to_string(descriptors) + " descriptors");
    a.indices[t] = int32_t(v);
  }
  a.data.assign(r.here(), r.here() + dataBytes);
  if (uint32_t(a.indexType()) != indexType)
    return corrupt("index type " + std::to_string(indexType) + " is not the narrowest one that fits (" +
                   std::to_string(uint32_t(a.indexType())) + ")");
  return Ok{};
}

// A GEOM payload; `placement` (version 2) also reads the geometry's array and first triangle.
Status parseGeom(const uint8_t* p, size_t n, GeometryInfo& g, GeometryMicromaps* placement,
                 const std::string& what) {
  Reader r(p, n);
  uint8_t format, minLevel, maxLevel, filter, wrapS, wrapT, reserved8[2];
  uint32_t reserved32;
  if (!r.str(g.name) || !r.str(g.material) || !r.u32(g.triangleCount) ||
      (placement && (!r.u32(placement->array) || !r.u32(placement->firstTriangle))) || !r.u8(format) ||
      !r.u8(minLevel) || !r.u8(maxLevel) || !r.u8(filter) || !r.u8(wrapS) || !r.u8(wrapT) ||
      !r.u8(reserved8[0]) || !r.u8(reserved8[1]) || !r.f32(g.cutoff) || !r.u32(reserved32) ||
      !r.u64(g.stats.microTriangles) || !r.u64(g.stats.unknownMicroTriangles) ||
      !r.u64(g.stats.invalidUvTriangles))
    return makeError(ErrorCode::CorruptFile, what + ": payload too short or a string length out of range");
  if (r.remaining() != 0)
    return makeError(ErrorCode::CorruptFile,
                     what + ": " + std::to_string(r.remaining()) + " unexpected trailing bytes");
  if (reserved8[0] || reserved8[1] || reserved32)
    return makeError(ErrorCode::CorruptFile, what + ": reserved fields are not 0");
  g.format = Format(format);
  g.minLevel = minLevel;
  g.maxLevel = maxLevel;
  g.sampler.filter = Filter(filter);
  g.sampler.wrapS = Wrap(wrapS);
  g.sampler.wrapT = Wrap(wrapT);
  if (placement) placement->triangleCount = g.triangleCount;
  return Ok{};
}

}  // namespace

std::string sectionIdName(uint32_t id) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const uint8_t c = uint8_t(id >> (8 * i));
    if (c >= 0x21 && c < 0x7f && c != '\'' && c != '\\') {
      s.push_back(char(c));
    } else if (c == ' ') {
      s.push_back(' ');
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      s += buf;
    }
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

Status validateOmmArray(const OmmArray& a, std::string_view whatView) {
  const std::string what(whatView);
  auto corrupt = [&](const std::string& m) -> Status {
    return makeError(ErrorCode::CorruptFile, what + ": " + m);
  };
  for (size_t i = 0; i < a.descriptors.size(); ++i) {
    const TriangleDescriptor& d = a.descriptors[i];
    if (!isValidFormat(d.format))
      return corrupt("descriptor " + std::to_string(i) + " has format " + std::to_string(d.format) +
                     " (must be 1 or 2)");
    if (d.subdivisionLevel > kMaxLevel)
      return corrupt("descriptor " + std::to_string(i) + " has level " + std::to_string(d.subdivisionLevel) +
                     " (must be at most 12)");
    const uint64_t end = uint64_t(d.dataOffset) + micromapDataBytes(d.subdivisionLevel, Format(d.format));
    if (end > a.data.size())
      return corrupt("micromap of descriptor " + std::to_string(i) + " (offset " +
                     std::to_string(d.dataOffset) + ", " + std::to_string(end - d.dataOffset) +
                     " bytes) extends past the " + std::to_string(a.data.size()) + "-byte data buffer");
  }
  if (a.indices.size() > 0xffffffffull) return corrupt("more than 2^32 - 1 triangles");
  if (a.descriptors.size() > 0x7fffffffull) return corrupt("more than 2^31 - 1 descriptors");
  if (a.data.size() > 0xffffffffull) return corrupt("data buffer larger than 4 GiB");
  for (size_t t = 0; t < a.indices.size(); ++t) {
    const int32_t i = a.indices[t];
    if (!isSpecialIndex(i) && (i < 0 || size_t(i) >= a.descriptors.size()))
      return corrupt("index of triangle " + std::to_string(t) + " is " + std::to_string(i) +
                     " (neither a descriptor index below " + std::to_string(a.descriptors.size()) +
                     " nor a special index -1..-4)");
  }
  const UsageHistograms usage = countUsage(a.descriptors, a.indices);
  if (a.histogram != usage.micromaps)
    return corrupt("micromap usage histogram does not match the descriptors");
  if (a.triangleHistogram != usage.triangles)
    return corrupt("triangle usage histogram does not match the index buffer");
  return Ok{};
}

namespace {

// The file into w (w.refs: the arrays' and encodings' bytes referenced, not copied).
Status serializeInto(const SommFile& f, Writer& w) {
  auto longString = [](const std::string& s) { return s.size() > kMaxStringBytes; };
  if (longString(f.sourcePath) || longString(f.toolVersion))
    return makeError(ErrorCode::LimitExceeded, "source path or tool version longer than 65536 bytes");
  for (const auto& [k, v] : f.bakeOptions)
    if (longString(k) || longString(v))
      return makeError(ErrorCode::LimitExceeded,
                       "bake option '" + k.substr(0, 40) + "' longer than 65536 bytes");
  if (Status s = checkFile(f); !s) return s.error();

  w.bytes(kMagic);
  w.u32(kSommFileVersion);
  w.u32(0);  // flags
  w.u64(0);  // file size, patched below
  w.u64(0);  // header checksum, patched below

  Writer meta;
  meta.u32(uint32_t(f.geometries.size()));
  meta.u32(uint32_t(f.micromaps.arrays.size()));
  meta.str(f.sourcePath);
  meta.str(f.toolVersion);
  meta.u32(uint32_t(f.bakeOptions.size()));
  for (const auto& [k, v] : f.bakeOptions) {
    meta.str(k);
    meta.str(v);
  }
  putChunk(w, kMeta, kNoGeometry, meta.out);

  for (size_t gi = 0; gi < f.geometries.size(); ++gi) {
    const GeometryInfo& in = f.geometries[gi];
    const GeometryMicromaps& r = f.micromaps.geometries[gi];
    Writer geom;
    geom.str(in.name);
    geom.str(in.material);
    geom.u32(in.triangleCount);
    geom.u32(r.array);
    geom.u32(r.firstTriangle);
    geom.u8(uint8_t(in.format));
    geom.u8(uint8_t(in.minLevel));
    geom.u8(uint8_t(in.maxLevel));
    geom.u8(uint8_t(in.sampler.filter));
    geom.u8(uint8_t(in.sampler.wrapS));
    geom.u8(uint8_t(in.sampler.wrapT));
    geom.u8(0);
    geom.u8(0);
    geom.f32(in.cutoff);
    geom.u32(0);
    geom.u64(in.stats.microTriangles);
    geom.u64(in.stats.unknownMicroTriangles);
    geom.u64(in.stats.invalidUvTriangles);
    putChunk(w, kGeom, uint32_t(gi), geom.out);
  }

  // The arrays' chunks are written in place, into a buffer reserved once: the file's bytes are the only copy of the
  // micromap data made (a bake's peak memory holds the data twice at most while writing).
  auto padded = [](size_t n) { return (n + 7) & ~size_t(7); };
  size_t total = w.out.size() + kChunkHeaderBytes;  // + the end chunk
  for (size_t ai = 0; ai < f.micromaps.arrays.size(); ++ai) {
    const OmmArray& a = f.micromaps.arrays[ai];
    total += kChunkHeaderBytes + padded(kFlatHeaderBytes + a.descriptorBytes().size() +
                                        12 * (a.histogram.size() + a.triangleHistogram.size()) +
                                        a.indexBufferBytes().size() + a.data.size());
    for (const EncodedSection& e : f.encodings[ai]) total += kChunkHeaderBytes + padded(8 + e.bytes.size());
  }
  if (!w.refs) w.out.reserve(total);
  for (size_t ai = 0; ai < f.micromaps.arrays.size(); ++ai) {
    const OmmArray& a = f.micromaps.arrays[ai];
    const OpenChunk flat = openChunk(w, kFlat, uint32_t(ai));
    w.u32(uint32_t(a.indices.size()));
    w.u32(uint32_t(a.descriptors.size()));
    w.u32(uint32_t(a.indexType()));
    w.u32(uint32_t(a.histogram.size()));
    w.u32(uint32_t(a.triangleHistogram.size()));
    w.u32(0);
    w.u64(a.data.size());
    w.bytes(a.descriptorBytes());
    for (const auto* h : {&a.histogram, &a.triangleHistogram})
      for (const UsageCount& c : *h) {
        w.u32(c.count);
        w.u32(c.subdivisionLevel);
        w.u32(c.format);
      }
    w.bytes(a.indexBufferBytes());  // temporaries: copied (data and encodings are referenced)
    w.ref(a.data);
    closeChunk(w, flat);

    for (const EncodedSection& e : f.encodings[ai]) {
      const OpenChunk enc = openChunk(w, kEncd, uint32_t(ai));
      w.u32(e.id);
      w.u32(0);
      w.ref(e.bytes);
      closeChunk(w, enc);
    }
  }
  putChunk(w, kEnd, kNoGeometry, {});
  w.patchU64(16, w.pos());
  w.patchU64(24, XXH3_64bits(w.out.data(), 24));
  w.flush();
  return Ok{};
}

}  // namespace

Result<std::vector<uint8_t>> serializeSomm(const SommFile& f) {
  Writer w;
  if (Status s = serializeInto(f, w); !s) return s.error();
  return std::move(w.out);
}

Status writeSommFile(const std::string& path, const SommFile& file) {
  Writer w;
  w.refs = true;
  if (Status s = serializeInto(file, w); !s)
    return makeError(s.error().code, path + ": not written: " + s.error().message);
  std::vector<std::pair<const uint8_t*, size_t>> pieces;
  pieces.reserve(w.segments.size());
  for (const Writer::Segment& g : w.segments)
    pieces.emplace_back(g.external ? g.external : w.out.data() + g.own, g.size);
  return writeFileAtomically(path, pieces.data(), pieces.size());
}

Result<SommFile> parseSomm(Span<const uint8_t> bytes, std::string_view nameView) {
  const std::string name(nameView);
  auto err = [&](ErrorCode code, const std::string& m) -> Error { return makeError(code, name + ": " + m); };
  const uint8_t* p = bytes.data();
  const size_t n = bytes.size();
  if (n < sizeof kMagic || std::memcmp(p, kMagic, sizeof kMagic) != 0) {
    if (n < sizeof kMagic && n > 0 && std::memcmp(p, kMagic, n) == 0)
      return err(ErrorCode::CorruptFile, "truncated .somm file (" + std::to_string(n) + " bytes)");
    return err(ErrorCode::UnsupportedFormat, "not a .somm file (bad magic)");
  }
  if (n < kHeaderBytes)
    return err(ErrorCode::CorruptFile,
               "truncated .somm file: " + std::to_string(n) + " bytes, header needs 32");
  const uint32_t version = loadU32(p + 8);
  if (version != 1 && version != kSommFileVersion)
    return err(ErrorCode::UnsupportedFormat, ".somm version " + std::to_string(version) +
                                                 " is not supported (this build reads versions 1 and " +
                                                 std::to_string(kSommFileVersion) + ")");
  const bool v1 = version == 1;
  if (XXH3_64bits(p, 24) != loadU64(p + 24)) return err(ErrorCode::CorruptFile, "header checksum mismatch");
  if (const uint32_t flags = loadU32(p + 12); flags != 0)
    return err(ErrorCode::UnsupportedFormat, "unknown header flags 0x" + hex(flags).substr(8));
  const uint64_t declared = loadU64(p + 16);
  if (declared > n)
    return err(ErrorCode::CorruptFile, "truncated: the header declares " + std::to_string(declared) +
                                           " bytes but the file has " + std::to_string(n));
  if (declared < n)
    return err(ErrorCode::CorruptFile, std::to_string(n - declared) +
                                           " unexpected bytes after the declared end at " +
                                           std::to_string(declared));

  SommFile out;
  uint32_t geometryCount = 0, arrayCount = 0;
  size_t off = kHeaderBytes;
  size_t ordinal = 0;
  bool ended = false;
  bool flatSeen = false;  // the FLAT chunk of the current geometry (v1) or array (v2) has been read
  // Version 1: one array per geometry, its encodings with it.
  std::vector<OmmArray> v1Arrays;
  // Version 2: triangles placed so far per array, and each array's geometries.
  std::vector<uint64_t> next;
  std::vector<std::vector<uint32_t>> byArray;
  // Expected sequence — v1: META, (GEOM FLAT ENCD*)^geometryCount, END;
  //                     v2: META, GEOM^geometryCount, (FLAT ENCD*)^arrayCount, END.
  while (!ended) {
    if (n - off < kChunkHeaderBytes)
      return err(ErrorCode::CorruptFile, "truncated: chunk " + std::to_string(ordinal) + " at offset " +
                                             std::to_string(off) + " has no room for its 24-byte header");
    const uint8_t* h = p + off;
    const uint32_t type = loadU32(h), index = loadU32(h + 4);
    const uint64_t size = loadU64(h + 8), sum = loadU64(h + 16);
    const std::string what = name + ": " + describeChunk(ordinal, type, index, off, v1);
    auto cerr = [&](ErrorCode code, const std::string& m) -> Error {
      return makeError(code, what + ": " + m);
    };
    const size_t room = n - off - kChunkHeaderBytes;
    if (size > room)
      return cerr(ErrorCode::CorruptFile, "payload of " + std::to_string(size) +
                                              " bytes extends past the end of the file (" +
                                              std::to_string(room) + " bytes left)");
    const uint8_t* payload = h + kChunkHeaderBytes;
    const size_t padded = (size_t(size) + 7) & ~size_t(7);
    if (padded > room) return cerr(ErrorCode::CorruptFile, "padding extends past the end of the file");
    if (chunkChecksum(h, payload, size_t(size)) != sum)
      return cerr(ErrorCode::CorruptFile, "checksum mismatch (stored " + hex(sum) + ")");
    for (size_t i = size_t(size); i < padded; ++i)
      if (payload[i] != 0) return cerr(ErrorCode::CorruptFile, "non-zero padding");

    const size_t geomDone = out.geometries.size();
    const size_t arraysDone = v1 ? 0 : out.micromaps.arrays.size();
    if (ordinal == 0) {
      if (type != kMeta || index != kNoGeometry)
        return cerr(ErrorCode::CorruptFile, "the first chunk must be 'META' without a geometry");
      Reader r(payload, size_t(size));
      uint32_t options;
      if (!r.u32(geometryCount) || (!v1 && !r.u32(arrayCount)) || !r.str(out.sourcePath) ||
          !r.str(out.toolVersion) || !r.u32(options))
        return cerr(ErrorCode::CorruptFile, "payload too short or a string length out of range");
      // Each option needs at least 8 bytes, each geometry (v1: two) and each array a 24-byte chunk header.
      if (options > r.remaining() / 8)
        return cerr(ErrorCode::CorruptFile,
                    std::to_string(options) + " bake options cannot fit in the payload");
      if (geometryCount > (n - off) / ((v1 ? 2 : 1) * kChunkHeaderBytes))
        return cerr(ErrorCode::CorruptFile, std::to_string(geometryCount) + " geometries cannot fit in a " +
                                                std::to_string(n) + "-byte file");
      if (arrayCount > (n - off) / kChunkHeaderBytes)
        return cerr(ErrorCode::CorruptFile, std::to_string(arrayCount) + " arrays cannot fit in a " +
                                                std::to_string(n) + "-byte file");
      out.bakeOptions.resize(options);
      for (auto& [k, v] : out.bakeOptions)
        if (!r.str(k) || !r.str(v))
          return cerr(ErrorCode::CorruptFile, "bake options truncated or a string length out of range");
      if (r.remaining() != 0)
        return cerr(ErrorCode::CorruptFile, std::to_string(r.remaining()) + " unexpected trailing bytes");
      out.geometries.reserve(geometryCount);
      out.micromaps.geometries.reserve(geometryCount);
      if (v1) {
        v1Arrays.reserve(geometryCount);
        out.encodings.reserve(geometryCount);
      } else {
        out.micromaps.arrays.reserve(arrayCount);
        out.encodings.reserve(arrayCount);
        next.assign(arrayCount, 0);
        byArray.resize(arrayCount);
      }
    } else if (type == kGeom) {
      if (geomDone == geometryCount)
        return cerr(ErrorCode::CorruptFile,
                    "more geometries than the " + std::to_string(geometryCount) + " declared");
      if (v1 && geomDone > 0 && !flatSeen)
        return cerr(ErrorCode::CorruptFile,
                    "geometry " + std::to_string(geomDone - 1) + " has no 'FLAT' chunk");
      if (!v1 && arraysDone > 0) return cerr(ErrorCode::CorruptFile, "geometries must precede the arrays");
      if (index != geomDone)
        return cerr(ErrorCode::CorruptFile, "expected geometry " + std::to_string(geomDone));
      GeometryInfo info;
      GeometryMicromaps place;
      if (Status s = parseGeom(payload, size_t(size), info, v1 ? nullptr : &place, what); !s)
        return s.error();
      if (Status s = checkInfo(info, what); !s) return s.error();
      if (!v1) {
        if (place.array >= arrayCount)
          return cerr(ErrorCode::CorruptFile, "array " + std::to_string(place.array) + " does not exist (" +
                                                  std::to_string(arrayCount) + " arrays)");
        if (place.firstTriangle != next[place.array])
          return cerr(ErrorCode::CorruptFile,
                      "starts at triangle " + std::to_string(place.firstTriangle) + " of array " +
                          std::to_string(place.array) + ", expected " + std::to_string(next[place.array]) +
                          " (the geometries of an array tile its index buffer in geometry order)");
        next[place.array] += place.triangleCount;
        if (next[place.array] > 0xffffffffull)
          return cerr(ErrorCode::CorruptFile,
                      "array " + std::to_string(place.array) + " would exceed 2^32 - 1 triangles");
        byArray[place.array].push_back(uint32_t(geomDone));
      } else {
        place = GeometryMicromaps{uint32_t(geomDone), 0, info.triangleCount};
      }
      out.geometries.push_back(std::move(info));
      out.micromaps.geometries.push_back(place);
      flatSeen = false;
    } else if (type == kFlat) {
      OmmArray a;
      if (v1) {
        if (geomDone == 0 || index != geomDone - 1)
          return cerr(ErrorCode::CorruptFile, "does not follow the 'GEOM' chunk of its geometry");
        if (flatSeen) return cerr(ErrorCode::CorruptFile, "a second 'FLAT' chunk for the geometry");
      } else {
        if (geomDone != geometryCount)
          return cerr(ErrorCode::CorruptFile, "only " + std::to_string(geomDone) + " of " +
                                                  std::to_string(geometryCount) +
                                                  " declared geometries precede the arrays");
        if (arraysDone == arrayCount)
          return cerr(ErrorCode::CorruptFile,
                      "more arrays than the " + std::to_string(arrayCount) + " declared");
        if (index != arraysDone)
          return cerr(ErrorCode::CorruptFile, "expected array " + std::to_string(arraysDone));
      }
      if (Status s = parseFlat(payload, size_t(size), a, what); !s) return s.error();
      if (Status s = validateOmmArray(a, what); !s) return s.error();
      if (v1) {
        const GeometryInfo& in = out.geometries.back();
        if (a.indices.size() != in.triangleCount)
          return cerr(ErrorCode::CorruptFile, "triangle count " + std::to_string(in.triangleCount) +
                                                  " but the index buffer has " +
                                                  std::to_string(a.indices.size()) + " entries");
        if (Status s = checkGeometryMaps(in, a, out.micromaps.geometries.back(), what); !s) return s.error();
        v1Arrays.push_back(std::move(a));
      } else {
        if (a.indices.size() != next[arraysDone])
          return cerr(ErrorCode::CorruptFile, "its geometries cover " + std::to_string(next[arraysDone]) +
                                                  " triangles but its index buffer has " +
                                                  std::to_string(a.indices.size()));
        for (uint32_t g : byArray[arraysDone])
          if (Status s = checkGeometryMaps(out.geometries[g], a, out.micromaps.geometries[g],
                                           what + ": geometry " + std::to_string(g));
              !s)
            return s.error();
        out.micromaps.arrays.push_back(std::move(a));
      }
      out.encodings.emplace_back();
      flatSeen = true;
    } else if (type == kEncd) {
      const bool follows =
          v1 ? geomDone > 0 && index == geomDone - 1 && flatSeen : arraysDone > 0 && index == arraysDone - 1;
      if (!follows)
        return cerr(ErrorCode::CorruptFile,
                    std::string("does not follow the 'FLAT' chunk of its ") + (v1 ? "geometry" : "array"));
      std::vector<EncodedSection>& extra = out.encodings.back();
      Reader r(payload, size_t(size));
      EncodedSection e;
      uint32_t reserved;
      if (!r.u32(e.id) || !r.u32(reserved))
        return cerr(ErrorCode::CorruptFile, "payload shorter than 8 bytes");
      if (reserved != 0) return cerr(ErrorCode::CorruptFile, "reserved field is not 0");
      for (const EncodedSection& x : extra)
        if (x.id == e.id)
          return cerr(ErrorCode::CorruptFile, "encoding '" + sectionIdName(e.id) + "' stored twice");
      e.bytes.assign(r.here(), r.here() + r.remaining());
      extra.push_back(std::move(e));
    } else if (type == kEnd) {
      if (index != kNoGeometry || size != 0)
        return cerr(ErrorCode::CorruptFile, "'END' must be empty and without a geometry");
      if (v1 && geomDone > 0 && !flatSeen)
        return cerr(ErrorCode::CorruptFile,
                    "geometry " + std::to_string(geomDone - 1) + " has no 'FLAT' chunk");
      if (geomDone != geometryCount)
        return cerr(ErrorCode::CorruptFile, "only " + std::to_string(geomDone) + " of " +
                                                std::to_string(geometryCount) +
                                                " declared geometries present");
      if (!v1 && arraysDone != arrayCount)
        return cerr(ErrorCode::CorruptFile, "only " + std::to_string(arraysDone) + " of " +
                                                std::to_string(arrayCount) + " declared arrays present");
      ended = true;
    } else if (type == kMeta) {
      return cerr(ErrorCode::CorruptFile, "a second 'META' chunk");
    } else {
      return cerr(ErrorCode::UnsupportedFormat, "unknown chunk type");
    }
    off += kChunkHeaderBytes + padded;
    ++ordinal;
  }
  if (off != n)
    return err(ErrorCode::CorruptFile, std::to_string(n - off) + " unexpected bytes after the 'END' chunk");
  if (v1) {
    // One array per geometry (GeometryMicromaps{g, 0, triangleCount}, as placed above).
    out.micromaps.arrays = std::move(v1Arrays);
  }
  return out;
}

}  // namespace somm
