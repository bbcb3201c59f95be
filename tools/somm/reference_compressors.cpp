// SPDX-License-Identifier: MIT
// zstd -19 and xz -9 sizes: the non-random-access references the CLI (info, compare) and the benchmarks report.
#include "reference_compressors.h"

#include <lzma.h>
#include <zstd.h>

#include <algorithm>
#include <vector>

namespace somm::cli {

uint64_t zstdBytes(std::span<const uint8_t> bytes) {
  std::vector<uint8_t> out(ZSTD_compressBound(bytes.size()));
  const size_t n = ZSTD_compress(out.data(), out.size(), bytes.data(), bytes.size(), 19);
  return ZSTD_isError(n) ? 0 : n;
}

uint64_t xzBytes(std::span<const uint8_t> bytes) {
  // xz -9 (preset 9, CRC64), with the dictionary no larger than the input: identical matches, far less
  // memory.
  lzma_options_lzma opt;
  if (lzma_lzma_preset(&opt, 9)) return 0;
  opt.dict_size = uint32_t(std::clamp<uint64_t>(bytes.size(), LZMA_DICT_SIZE_MIN, opt.dict_size));
  lzma_filter filters[2] = {{LZMA_FILTER_LZMA2, &opt}, {LZMA_VLI_UNKNOWN, nullptr}};
  std::vector<uint8_t> out(lzma_stream_buffer_bound(bytes.size()));
  size_t pos = 0;
  if (lzma_stream_buffer_encode(filters, LZMA_CHECK_CRC64, nullptr, bytes.data(), bytes.size(), out.data(),
                                &pos, out.size()) != LZMA_OK)
    return 0;
  return pos;
}

}  // namespace somm::cli
