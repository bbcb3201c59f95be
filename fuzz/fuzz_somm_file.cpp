// SPDX-License-Identifier: MIT
// Fuzz target: the .somm reader (parseSomm). Each input is parsed twice: as is (exercising the magic,
// version, size and checksum checks) and with every checksum and the declared size recomputed, so that
// mutations reach the structural validation behind the checksums. A parsed file must be internally valid:
// every lookup a ray tracer or `somm query` can make stays inside the buffers, and serialising it gives a
// file that parses to the same bytes. Every stored encoding (ENCD section: dfs, rank, hybrid, csm, sdag) is loaded
// the way `somm info` / `query --encoding` load it (tools/somm/encodings.cpp: parse, match the array,
// verifyAgainstFlat); an accepted one must answer exactly like the flat buffers (dfs also through the dfs-fast
// lookup), a refused one with a one-line message.
#include <xxhash.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <span>
#include <vector>

#include "somm/encode.h"
#include "somm/somm_file.h"

namespace {

[[noreturn]] void fail(const char* what, const std::string& detail = "") {
  std::fprintf(stderr, "fuzz_somm_file: %s %s\n", what, detail.c_str());
  std::abort();
}

uint64_t load64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= uint64_t(p[i]) << (8 * i);
  return v;
}
void store64(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = uint8_t(v >> (8 * i));
}

// Recomputes the header's declared size and checksum and every chunk checksum it can reach
// (docs/somm-format.md: 32-byte header, then chunks of a 24-byte header {type, index, size u64, checksum
// u64} + payload padded to 8; the same in versions 1 and 2).
void fixChecksums(std::vector<uint8_t>& b) {
  if (b.size() < 32) return;
  store64(b.data() + 16, b.size());
  store64(b.data() + 24, XXH3_64bits(b.data(), 24));
  size_t off = 32;
  while (b.size() - off >= 24) {
    uint8_t* h = b.data() + off;
    const uint64_t size = load64(h + 8);
    if (size > b.size() - off - 24) break;
    store64(h + 16, XXH3_64bits_withSeed(h + 24, size_t(size), XXH3_64bits(h, 16)));
    off += 24 + ((size_t(size) + 7) & ~size_t(7));
    if (off > b.size()) break;
  }
}

void checkError(const somm::Error& e, const char* name);

// The flat state of micro-triangle m of array triangle t (special indices resolved).
somm::State flatState(const somm::OmmArray& a, uint32_t t, uint32_t m) {
  const int32_t i = a.indices[t];
  if (i < 0) return somm::stateOfSpecialIndex(i);
  const somm::TriangleDescriptor& d = a.descriptors[size_t(i)];
  return somm::readPackedState(a.data.data() + d.dataOffset, somm::Format(d.format), m);
}

void checkEncodings(const somm::SommFile& f) {
  for (size_t a = 0; a < f.encodings.size(); ++a) {
    const somm::OmmArray& flat = f.micromaps.arrays[a];
    for (const somm::EncodedSection& s : f.encodings[a]) {
      auto e =
          somm::EncodedArray::parse(somm::Span<const uint8_t>(s.bytes.data(), s.bytes.size()), "fuzz.enc");
      if (!e) {
        checkError(e.error(), "fuzz.enc");
        continue;
      }
      if (e->triangleCount() != flat.indices.size()) continue;  // loadEncoding refuses it
      if (somm::Status v = somm::verifyAgainstFlat(*e, flat, "fuzz.verify"); !v) {
        checkError(v.error(), "fuzz.verify");
        continue;
      }
      // Verified: every lookup must agree with flat (sampled: up to 256 triangles, 64 micro-triangles each).
      for (int pass = 0; pass < 2; ++pass) {
        if (pass == 1 && !e->setLookup(somm::Encoding::DfsFast)) break;
        for (uint32_t t = 0; t < e->triangleCount() && t < 256; ++t) {
          const int32_t i = flat.indices[t];
          const uint32_t level = i < 0 ? 0 : flat.descriptors[size_t(i)].subdivisionLevel;
          const uint32_t n = somm::microTriangleCount(level), step = n / 64 + 1;
          for (uint32_t m = 0; m < n; m += step)
            if (e->state(t, m) != flatState(flat, t, m)) fail("a verified encoding differs from flat");
          if (e->state(t, n - 1) != flatState(flat, t, n - 1)) fail("a verified encoding differs from flat");
          for (const float uv : {0.0f, 0.2f, 0.49f, 1.0f})
            if (e->stateUV(t, uv, 0.3f) != flatState(flat, t, somm::baryToIndex(uv, 0.3f, level)))
              fail("a verified encoding differs from flat (stateUV)");
        }
      }
    }
  }
}

void checkParsed(const somm::SommFile& f) {
  const somm::SceneMicromaps& m = f.micromaps;
  if (m.geometries.size() != f.geometries.size() || f.encodings.size() != m.arrays.size())
    fail("geometry or encoding lists do not match the micromaps");
  for (const somm::OmmArray& a : m.arrays)
    if (!somm::validateOmmArray(a, "fuzz").ok()) fail("a parsed array does not validate");
  for (uint32_t g = 0; g < f.geometries.size(); ++g) {
    const somm::GeometryMicromaps& r = m.geometries[g];
    if (r.array >= m.arrays.size()) fail("a geometry points past the arrays");
    if (r.triangleCount != f.geometries[g].triangleCount) fail("triangle count differs from the placement");
    if (uint64_t(r.firstTriangle) + r.triangleCount > m.arrays[r.array].indices.size())
      fail("a geometry's range leaves its array");
    // Every lookup `somm query` can make: each triangle, its first and last micro-triangle, and a few (u, v).
    const somm::OmmArray& a = m.arrays[r.array];
    for (uint32_t t = 0; t < r.triangleCount; ++t) {
      const int32_t i = m.indices(g)[t];
      uint32_t level = 0;
      if (i >= 0) level = a.descriptors[size_t(i)].subdivisionLevel;
      volatile uint32_t sink = 0;
      sink = sink + uint32_t(m.state(g, t, 0)) + uint32_t(m.state(g, t, somm::microTriangleCount(level) - 1));
      sink = sink + uint32_t(m.stateUV(g, t, 0.3f, 0.6f)) + uint32_t(m.stateUV(g, t, 1.0f, 1.0f));
    }
  }
  checkEncodings(f);
  const auto bytes = somm::serializeSomm(f);
  if (!bytes.ok()) fail("a parsed file does not serialise:", bytes.error().message);
  const auto again = somm::parseSomm(*bytes, "fuzz-roundtrip.somm");
  if (!again.ok()) fail("a serialised file does not parse:", again.error().message);
  const auto bytes2 = somm::serializeSomm(*again);
  if (!bytes2.ok() || *bytes2 != *bytes) fail("serialise(parse(serialise(f))) differs");
}

void checkError(const somm::Error& e, const char* name) {
  if (e.message.rfind(name, 0) != 0) fail("error message does not start with the file name:", e.message);
  if (e.message.find('\n') != std::string::npos) fail("error message is not one line:", e.message);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto raw = somm::parseSomm(std::span<const uint8_t>(data, size), "raw.somm");
  if (raw.ok())
    checkParsed(*raw);
  else
    checkError(raw.error(), "raw.somm");
  std::vector<uint8_t> fixed(data, data + size);
  fixChecksums(fixed);
  const auto r = somm::parseSomm(fixed, "fixed.somm");
  if (r.ok())
    checkParsed(*r);
  else
    checkError(r.error(), "fixed.somm");
  return 0;
}
