// SPDX-License-Identifier: MIT
// The .somm container (docs/somm-format.md).
#include "somm/somm_file.h"

#include <span>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

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

constexpr size_t kGeomFixedBytes = 4 + 8 + 4 + 4 + 3 * 8;  // after the two strings
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
  while (w.out.size() % 8) w.u8(0);
}

std::string hex(uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// ---- checks shared by the writer and the reader ----

Status checkGeometry(const SommGeometry& g, const std::string& what) {
  auto fail = [&](ErrorCode code, const std::string& m) -> Status {
    return makeError(code, what + ": " + m);
  };
  const GeometryInfo& in = g.info;
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
  if (g.flat.indices.size() != in.triangleCount)
    return fail(ErrorCode::CorruptFile, "triangle count " + std::to_string(in.triangleCount) +
                                            " but the index buffer has " +
                                            std::to_string(g.flat.indices.size()) + " entries");
  if (Status s = validateOmmArray(g.flat, what); !s) return s;
  for (size_t i = 0; i < g.flat.descriptors.size(); ++i) {
    const TriangleDescriptor& d = g.flat.descriptors[i];
    if (d.format != uint16_t(in.format))
      return fail(ErrorCode::CorruptFile, "descriptor " + std::to_string(i) + " has format " +
                                              std::to_string(d.format) + " but the geometry is format " +
                                              std::to_string(uint32_t(in.format)));
    if (d.subdivisionLevel < in.minLevel || d.subdivisionLevel > in.maxLevel)
      return fail(ErrorCode::CorruptFile, "descriptor " + std::to_string(i) + " has level " +
                                              std::to_string(d.subdivisionLevel) +
                                              " outside the level range " + std::to_string(in.minLevel) +
                                              ".." + std::to_string(in.maxLevel));
  }
  for (size_t i = 0; i < g.extra.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (g.extra[i].id == g.extra[j].id)
        return fail(ErrorCode::CorruptFile, "encoding '" + sectionIdName(g.extra[i].id) + "' stored twice");
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

std::string describeChunk(size_t ordinal, uint32_t type, uint32_t geometry, size_t offset) {
  std::string s = "chunk " + std::to_string(ordinal) + " '" + sectionIdName(type) + "'";
  if (geometry != kNoGeometry) s += " of geometry " + std::to_string(geometry);
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

Status parseGeom(const uint8_t* p, size_t n, GeometryInfo& g, const std::string& what) {
  Reader r(p, n);
  uint8_t format, minLevel, maxLevel, filter, wrapS, wrapT, reserved8[2];
  uint32_t reserved32;
  if (!r.str(g.name) || !r.str(g.material) || !r.u32(g.triangleCount) || !r.u8(format) || !r.u8(minLevel) ||
      !r.u8(maxLevel) || !r.u8(filter) || !r.u8(wrapS) || !r.u8(wrapT) || !r.u8(reserved8[0]) ||
      !r.u8(reserved8[1]) || !r.f32(g.cutoff) || !r.u32(reserved32) || !r.u64(g.stats.microTriangles) ||
      !r.u64(g.stats.unknownMicroTriangles) || !r.u64(g.stats.invalidUvTriangles))
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

Result<std::vector<uint8_t>> serializeSomm(const SommFile& f) {
  if (f.geometries.size() > 0xffffffffull) return makeError(ErrorCode::LimitExceeded, "too many geometries");
  auto longString = [](const std::string& s) { return s.size() > kMaxStringBytes; };
  if (longString(f.sourcePath) || longString(f.toolVersion))
    return makeError(ErrorCode::LimitExceeded, "source path or tool version longer than 65536 bytes");
  for (const auto& [k, v] : f.bakeOptions)
    if (longString(k) || longString(v))
      return makeError(ErrorCode::LimitExceeded,
                       "bake option '" + k.substr(0, 40) + "' longer than 65536 bytes");
  for (size_t g = 0; g < f.geometries.size(); ++g)
    if (Status s = checkGeometry(f.geometries[g], "geometry " + std::to_string(g)); !s) return s.error();

  Writer w;
  w.bytes(kMagic);
  w.u32(kSommFileVersion);
  w.u32(0);  // flags
  w.u64(0);  // file size, patched below
  w.u64(0);  // header checksum, patched below

  Writer meta;
  meta.u32(uint32_t(f.geometries.size()));
  meta.str(f.sourcePath);
  meta.str(f.toolVersion);
  meta.u32(uint32_t(f.bakeOptions.size()));
  for (const auto& [k, v] : f.bakeOptions) {
    meta.str(k);
    meta.str(v);
  }
  putChunk(w, kMeta, kNoGeometry, meta.out);

  for (size_t gi = 0; gi < f.geometries.size(); ++gi) {
    const SommGeometry& g = f.geometries[gi];
    const GeometryInfo& in = g.info;
    Writer geom;
    geom.str(in.name);
    geom.str(in.material);
    geom.u32(in.triangleCount);
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

    const OmmArray& a = g.flat;
    Writer flat;
    flat.out.reserve(kFlatHeaderBytes + a.descriptors.size() * 8 + a.indices.size() * 4 + a.data.size() +
                     256);
    flat.u32(uint32_t(a.indices.size()));
    flat.u32(uint32_t(a.descriptors.size()));
    flat.u32(uint32_t(a.indexType()));
    flat.u32(uint32_t(a.histogram.size()));
    flat.u32(uint32_t(a.triangleHistogram.size()));
    flat.u32(0);
    flat.u64(a.data.size());
    flat.bytes(a.descriptorBytes());
    for (const auto* h : {&a.histogram, &a.triangleHistogram})
      for (const UsageCount& c : *h) {
        flat.u32(c.count);
        flat.u32(c.subdivisionLevel);
        flat.u32(c.format);
      }
    flat.bytes(a.indexBufferBytes());
    flat.bytes(a.data);
    putChunk(w, kFlat, uint32_t(gi), flat.out);

    for (const EncodedSection& e : g.extra) {
      Writer enc;
      enc.out.reserve(8 + e.bytes.size());
      enc.u32(e.id);
      enc.u32(0);
      enc.bytes(e.bytes);
      putChunk(w, kEncd, uint32_t(gi), enc.out);
    }
  }
  putChunk(w, kEnd, kNoGeometry, {});
  w.patchU64(16, w.out.size());
  w.patchU64(24, XXH3_64bits(w.out.data(), 24));
  return std::move(w.out);
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
  if (version != kSommFileVersion)
    return err(ErrorCode::UnsupportedFormat, ".somm version " + std::to_string(version) +
                                                 " is not supported (this build reads version " +
                                                 std::to_string(kSommFileVersion) + ")");
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
  uint32_t geometryCount = 0;
  size_t off = kHeaderBytes;
  size_t ordinal = 0;
  bool ended = false;
  bool flatSeen = false;
  // Expected sequence: META, (GEOM FLAT ENCD*)^geometryCount, END.
  while (!ended) {
    if (n - off < kChunkHeaderBytes)
      return err(ErrorCode::CorruptFile, "truncated: chunk " + std::to_string(ordinal) + " at offset " +
                                             std::to_string(off) + " has no room for its 24-byte header");
    const uint8_t* h = p + off;
    const uint32_t type = loadU32(h), geometry = loadU32(h + 4);
    const uint64_t size = loadU64(h + 8), sum = loadU64(h + 16);
    const std::string what = name + ": " + describeChunk(ordinal, type, geometry, off);
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
    if (ordinal == 0) {
      if (type != kMeta || geometry != kNoGeometry)
        return cerr(ErrorCode::CorruptFile, "the first chunk must be 'META' without a geometry");
      Reader r(payload, size_t(size));
      uint32_t options;
      if (!r.u32(geometryCount) || !r.str(out.sourcePath) || !r.str(out.toolVersion) || !r.u32(options))
        return cerr(ErrorCode::CorruptFile, "payload too short or a string length out of range");
      // Each option needs at least 8 bytes, each geometry at least two 24-byte chunk headers.
      if (options > r.remaining() / 8)
        return cerr(ErrorCode::CorruptFile,
                    std::to_string(options) + " bake options cannot fit in the payload");
      if (geometryCount > (n - off) / (2 * kChunkHeaderBytes))
        return cerr(ErrorCode::CorruptFile, std::to_string(geometryCount) + " geometries cannot fit in a " +
                                                std::to_string(n) + "-byte file");
      out.bakeOptions.resize(options);
      for (auto& [k, v] : out.bakeOptions)
        if (!r.str(k) || !r.str(v))
          return cerr(ErrorCode::CorruptFile, "bake options truncated or a string length out of range");
      if (r.remaining() != 0)
        return cerr(ErrorCode::CorruptFile, std::to_string(r.remaining()) + " unexpected trailing bytes");
      out.geometries.reserve(geometryCount);
    } else if (type == kGeom) {
      if (geomDone == geometryCount)
        return cerr(ErrorCode::CorruptFile,
                    "more geometries than the " + std::to_string(geometryCount) + " declared");
      if (geomDone > 0 && !flatSeen)
        return cerr(ErrorCode::CorruptFile,
                    "geometry " + std::to_string(geomDone - 1) + " has no 'FLAT' chunk");
      if (geometry != geomDone)
        return cerr(ErrorCode::CorruptFile, "expected geometry " + std::to_string(geomDone));
      SommGeometry g;
      if (Status s = parseGeom(payload, size_t(size), g.info, what); !s) return s.error();
      out.geometries.push_back(std::move(g));
      flatSeen = false;
    } else if (type == kFlat) {
      if (geomDone == 0 || geometry != geomDone - 1)
        return cerr(ErrorCode::CorruptFile, "does not follow the 'GEOM' chunk of its geometry");
      if (flatSeen) return cerr(ErrorCode::CorruptFile, "a second 'FLAT' chunk for the geometry");
      SommGeometry& g = out.geometries.back();
      if (Status s = parseFlat(payload, size_t(size), g.flat, what); !s) return s.error();
      if (Status s = checkGeometry(g, what); !s) return s.error();
      flatSeen = true;
    } else if (type == kEncd) {
      if (geomDone == 0 || geometry != geomDone - 1 || !flatSeen)
        return cerr(ErrorCode::CorruptFile, "does not follow the 'FLAT' chunk of its geometry");
      SommGeometry& g = out.geometries.back();
      Reader r(payload, size_t(size));
      EncodedSection e;
      uint32_t reserved;
      if (!r.u32(e.id) || !r.u32(reserved))
        return cerr(ErrorCode::CorruptFile, "payload shorter than 8 bytes");
      if (reserved != 0) return cerr(ErrorCode::CorruptFile, "reserved field is not 0");
      for (const EncodedSection& x : g.extra)
        if (x.id == e.id)
          return cerr(ErrorCode::CorruptFile, "encoding '" + sectionIdName(e.id) + "' stored twice");
      e.bytes.assign(r.here(), r.here() + r.remaining());
      g.extra.push_back(std::move(e));
    } else if (type == kEnd) {
      if (geometry != kNoGeometry || size != 0)
        return cerr(ErrorCode::CorruptFile, "'END' must be empty and without a geometry");
      if (geomDone > 0 && !flatSeen)
        return cerr(ErrorCode::CorruptFile,
                    "geometry " + std::to_string(geomDone - 1) + " has no 'FLAT' chunk");
      if (geomDone != geometryCount)
        return cerr(ErrorCode::CorruptFile, "only " + std::to_string(geomDone) + " of " +
                                                std::to_string(geometryCount) +
                                                " declared geometries present");
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
  return out;
}

}  // namespace somm
