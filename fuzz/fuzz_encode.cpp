// SPDX-License-Identifier: MIT
// Fuzz target: every encoding's validating parser and lookups on arbitrary bytes (docs/encodings.md).
// Mode by the first byte:
//   0: EncodedArray::parse on the rest. A parsed array: every lookup (state, stateUV, stateAs<E>) stays in
//   bounds
//      (ASan), lookups equal the decoded spec buffers, serialise → parse is the identity.
//   1: validateMap on one blob (kind, level, format from the next bytes), copied into a buffer of exactly the
//      validated size + kTailPadding so that any read past it is caught; every index looked up, equal to
//      decodeMap.
//   2: build: micromaps made from the bytes → OmmArray → every encoding (csm and sdag included: the maps share
//      subtrees, some are repeated with a few states changed; then up to 2040 triangles of mostly one special
//      index, as on real foliage, so that sdag's index buffer is rank-packed); lookups equal flat, decode() is
//      bit-exact, serialise → parse round-trips; the packed index buffer is the smaller of plain and rank-packed.
// In every mode an accepted array must pass verifyAgainstFlat against its own decoded spec buffers (the check a
// .somm load makes), and fail it (CorruptFile naming the difference) once one micro-triangle of the flat side is
// changed; LimitExceeded (its work bound) is the only other outcome allowed.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <span>
#include <vector>

#include "packed_index_oracle.h"
#include "somm/encode.h"
#include "somm/omm_array.h"

namespace {

[[noreturn]] void fail(const char* what, const std::string& detail = "") {
  std::fprintf(stderr, "fuzz_encode: %s %s\n", what, detail.c_str());
  std::abort();
}

using somm::EncodedArray;
using somm::Encoding;
using somm::State;

uint32_t lookupsFor(uint32_t level) {
  return level <= 6 ? somm::microTriangleCount(level) : 4096u;
}

// Index k of the lookups made on a map of `level`: all of them up to level 5, else a spread including the
// last.
uint32_t lookupIndex(uint32_t k, uint32_t level) {
  const uint32_t n = somm::microTriangleCount(level);
  return level <= 5 ? k : k == 0 ? n - 1 : uint32_t((uint64_t(k) * 2654435761u) % n);
}

template <Encoding E>
void checkAs(const EncodedArray& a, const somm::OmmArray& flat) {
  for (uint32_t t = 0; t < a.triangleCount(); ++t) {
    const int32_t i = a.indices()[t];
    if (a.indexAs<E>(t) != i) fail("the index buffer the lookup reads (packed for sdag) differs");
    const uint32_t level = i >= 0 ? a.maps()[size_t(i)].level : 0;
    for (uint32_t k = 0; k < lookupsFor(level); ++k) {
      const uint32_t idx = lookupIndex(k, level);
      if (a.stateAs<E>(t, idx) != flat.state(t, idx)) fail("lookup differs from the decoded array");
    }
    if (a.stateUVAs<E>(t, 0.2f, 0.7f) != flat.stateUV(t, 0.2f, 0.7f)) fail("stateUV differs");
  }
}

void checkArray(const EncodedArray& a) {
  const somm::OmmArray flat = a.decode();
  if (flat.indices.size() != a.triangleCount()) fail("decoded triangle count");
  switch (a.encoding()) {
    case Encoding::Flat:
      checkAs<Encoding::Flat>(a, flat);
      break;
    case Encoding::Dfs:
      checkAs<Encoding::Dfs>(a, flat);
      break;
    case Encoding::DfsFast:
      checkAs<Encoding::DfsFast>(a, flat);
      break;
    case Encoding::Rank:
      checkAs<Encoding::Rank>(a, flat);
      break;
    case Encoding::Hybrid:
      checkAs<Encoding::Hybrid>(a, flat);
      break;
    case Encoding::Csm:
      checkAs<Encoding::Csm>(a, flat);
      break;
    case Encoding::Sdag:
      checkAs<Encoding::Sdag>(a, flat);
      break;
  }
  for (uint32_t t = 0; t < a.triangleCount(); ++t)
    if (a.state(t, 0) != flat.state(t, 0)) fail("state() differs from stateAs<E>()");
  const somm::Status v = somm::verifyAgainstFlat(a, flat, "fuzz.verify");
  if (!v.ok() && v.error().code != somm::ErrorCode::LimitExceeded)
    fail("verifyAgainstFlat refuses the array's own decode:", v.error().message);
  if (v.ok()) {
    // One micro-triangle of the first triangle with a map, changed on the flat side: must be found.
    for (uint32_t t = 0; t < flat.indices.size(); ++t) {
      const int32_t i = flat.indices[t];
      if (i < 0) continue;
      somm::OmmArray changed = flat;
      const somm::TriangleDescriptor& d = changed.descriptors[size_t(i)];
      const somm::Format f = somm::Format(d.format);
      const uint32_t m = somm::microTriangleCount(d.subdivisionLevel) - 1;
      uint8_t* map = changed.data.data() + d.dataOffset;
      const State s = somm::readPackedState(map, f, m);
      somm::writePackedState(map, f, m, State((uint32_t(s) + 1) & (f == somm::Format::TwoState ? 1u : 3u)));
      const somm::Status w = somm::verifyAgainstFlat(a, changed, "fuzz.verify");
      if (w.ok()) fail("verifyAgainstFlat misses a changed micro-triangle");
      if (w.error().code != somm::ErrorCode::CorruptFile && w.error().code != somm::ErrorCode::LimitExceeded)
        fail("verifyAgainstFlat: unexpected error code", w.error().message);
      if (w.error().message.rfind("fuzz.verify", 0) != 0 || w.error().message.find('\n') != std::string::npos)
        fail("verifyAgainstFlat: bad error message:", w.error().message);
      break;
    }
  }
  const std::vector<uint8_t> bytes = a.serialize();
  if (bytes.size() != a.byteSize()) fail("serialised size differs from byteSize()");
  const auto again = EncodedArray::parse(bytes, "roundtrip");
  if (!again.ok()) fail("a serialised array does not parse:", again.error().message);
  if (!(*again == a)) fail("serialise → parse is not the identity");
}

void modeParse(const uint8_t* data, size_t size) {
  const auto r = EncodedArray::parse(std::span<const uint8_t>(data, size), "fuzz.bin");
  if (!r.ok()) {
    if (r.error().message.rfind("fuzz.bin", 0) != 0 || r.error().message.find('\n') != std::string::npos)
      fail("bad error message:", r.error().message);
    return;
  }
  checkArray(*r);
}

void modeValidateMap(const uint8_t* data, size_t size) {
  if (size < 2) return;
  const somm::MapKind kind = somm::MapKind(data[0] % 3);
  const uint32_t level = (data[0] >> 2) % (somm::kMaxLevel + 1);
  const somm::Format f = (data[1] & 1) ? somm::Format::FourState : somm::Format::TwoState;
  data += 2;
  size -= 2;
  const auto r = somm::encode::validateMap(data, size, kind, level, f);
  if (!r.ok()) return;
  if (*r > size) fail("validated size larger than the bytes available");
  // Exactly the validated bytes plus the documented tail padding (zeros), on the heap so ASan sees any
  // overrun.
  std::vector<uint8_t> blob(data, data + *r);
  blob.resize(size_t(*r) + somm::encode::kTailPadding, 0);
  blob.shrink_to_fit();
  // Levels above 7: lookups only (out-of-bounds reads are what matters there; a full decode is slow).
  const bool decode = level <= 7;
  const somm::Micromap m =
      decode ? somm::encode::decodeMap(blob.data(), kind, level, f) : somm::Micromap(0, f);
  if (decode && (m.level() != level || m.format() != f)) fail("decodeMap header");
  for (uint32_t k = 0; k < lookupsFor(level); ++k) {
    const uint32_t idx = lookupIndex(k, level);
    State s;
    switch (kind) {
      case somm::MapKind::Flat:
        s = somm::encode::flatState(blob.data(), level, f, idx);
        break;
      case somm::MapKind::Dfs:
        s = somm::encode::dfsState(blob.data(), level, f, idx);
        if (somm::encode::dfsFastState(blob.data(), level, f, idx) != s) fail("dfs-fast differs from dfs");
        break;
      default:
        s = somm::encode::rankState(blob.data(), level, f, idx);
        break;
    }
    if (decode && s != m.get(idx)) fail("lookup differs from decodeMap");
  }
  if (!decode) return;
  // Canonical: re-encoding the decoded map gives a map of at most the validated size that decodes the same.
  const std::vector<uint8_t> re = somm::encode::encodeMap(m, kind);
  if (re.size() > *r) fail("re-encoding is larger than the validated blob");
}

void modeBuild(const uint8_t* data, size_t size) {
  somm::OmmArrayBuilder b;
  size_t p = 0;
  auto byte = [&]() -> uint8_t { return p < size ? data[p++] : 0; };
  std::vector<somm::Micromap> added;
  for (int t = 0; t < 6 && p < size; ++t) {
    const uint8_t head = byte();
    const uint32_t level = head % 7;
    const somm::Format f = (head & 0x80) ? somm::Format::FourState : somm::Format::TwoState;
    somm::Micromap m(level, f, State((head >> 3) & 3));
    // Runs of states: (length byte, state) pairs, so that trees collapse in interesting ways.
    uint32_t at = 0;
    const uint32_t runs = byte() % 16;
    for (uint32_t k = 0; k < runs && at < m.size(); ++k) {
      const uint32_t len = 1u + uint32_t(byte()) * (1u + m.size() / 256u);
      const State s = State(byte() & 3);
      for (uint32_t i = 0; i < len && at < m.size(); ++i) m.set(at++, s);
      at += byte() % 8;
    }
    b.add(m);
    added.push_back(m);
    // A near-copy (one run of states changed): identical subtrees for the array-wide DAGs to share.
    if (head & 0x40 && m.size() > 1) {
      const uint32_t from = uint32_t(byte()) * m.size() / 256u;
      for (uint32_t i = from; i < m.size() && i < from + 1u + byte() % 16u; ++i) m.set(i, State(byte() & 3));
      b.add(m);
      added.push_back(m);
    }
  }
  // Then (count byte c, state byte s) triangles like real foliage: 8·c triangles, mostly of the uniform state s
  // (special indices), every (s >> 2 | 1)-th one a map added above: long arrays whose index buffer is rank-packed.
  const uint32_t more = 8u * byte();
  const uint8_t s = byte();
  const uint32_t every = (s >> 2) | 1u;
  for (uint32_t i = 0; i < more; ++i) {
    if (i % every == every - 1 && !added.empty())
      b.add(added[i % added.size()]);
    else
      b.add(somm::Micromap(0, somm::Format::FourState, State(s & 3)));
  }
  const somm::OmmArray flat = b.finish();
  for (Encoding e : somm::kAllEncodings) {
    const auto enc = EncodedArray::build(flat, e);
    if (!enc.ok()) fail("build failed:", enc.error().message);
    const somm::OmmArray back = enc->decode();
    if (back.data != flat.data || back.descriptors != flat.descriptors || back.indices != flat.indices ||
        back.histogram != flat.histogram || back.triangleHistogram != flat.triangleHistogram)
      fail("decode() is not bit-exact", somm::encodingName(e));
    if (enc->hasDirectory() && (enc->indexBufferBytes() != somm::testing::packedIndexBufferBytes(
                                                               flat.indices, flat.descriptors.size()) ||
                                enc->indexRankPacked() != (enc->indexBufferBytes() <
                                                           (flat.indices.size() * enc->indexBits() + 7) / 8)))
      fail("the packed index buffer is not the smaller of plain and rank-packed", somm::encodingName(e));
    checkArray(*enc);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  switch (data[0] % 3) {
    case 0:
      modeParse(data + 1, size - 1);
      break;
    case 1:
      modeValidateMap(data + 1, size - 1);
      break;
    default:
      modeBuild(data + 1, size - 1);
      break;
  }
  return 0;
}
