// Fuzz target: EncodedArray::parse on arbitrary bytes. Whatever parses must serialize back to the same bytes, answer
// every lookup inside its buffers (ASan), agree between the paper's dfs lookup and the dfs-fast one on the same bits,
// and decode to spec buffers whose re-encoding answers every lookup identically.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>

#include "somm/encode.h"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz_encode: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace somm;
  auto parsed = EncodedArray::parse(std::span(data, size), "fuzz");
  if (!parsed) {
    if (parsed.error().message.find('\n') != std::string::npos) fail("multi-line error message");
    return 0;
  }
  const EncodedArray& a = *parsed;
  const std::vector<uint8_t> again = a.serialize();
  if (again.size() != size || !std::equal(again.begin(), again.end(), data)) fail("serialize(parse(x)) != x");
  if (a.byteSize() != size) fail("byteSize differs from the serialized size");
  const OmmArray flat = a.decode();
  auto re = EncodedArray::build(flat, a.encoding());
  if (!re) fail("decoded array does not re-encode");
  for (uint32_t t = 0; t < a.triangleCount() && t < 64; ++t) {
    const int32_t i = a.indices()[t];
    const uint32_t level = i < 0 ? 0 : a.maps()[size_t(i)].level;
    const uint32_t n = microTriangleCount(level);
    const uint32_t step = n > 4096 ? n / 4096 + 1 : 1;
    for (uint32_t k = 0; k < n; k += step) {
      const State s = a.state(t, k);
      if (s != flat.state(t, k) || s != re->state(t, k)) fail("lookup differs from the decoded array");
      if (i >= 0 && a.maps()[size_t(i)].kind == MapKind::Dfs) {
        const EncodedMapDesc& d = a.maps()[size_t(i)];
        const uint8_t* blob = a.data().data() + d.offset;
        if (encode::dfsState(blob, d.level, Format(d.format), k) !=
            encode::dfsFastState(blob, d.level, Format(d.format), k))
          fail("dfs and dfs-fast lookups disagree");
      }
    }
  }
  return 0;
}
