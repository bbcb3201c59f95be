// SPDX-License-Identifier: MIT
// Oracle for the tests and fuzz_encode: bytes of the packed index buffer of an array with the sdag directory, from
// docs/encodings.md ("Encoded array"), independent of the encoder: k bits per triangle, or the rank-packed buffer
// (8 bytes per 32 triangles + (listed + 1) entries of k bits, listed = the triangles whose value is not the most
// common one) when that is strictly smaller.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <vector>

#include "somm/encode.h"

namespace somm::testing {

inline uint64_t packedIndexBufferBytes(const std::vector<int32_t>& indices, uint64_t maps) {
  const uint32_t k = encode::sdagIndexBits(maps);
  std::map<int32_t, uint64_t> count;
  uint64_t most = 0;
  for (int32_t i : indices) most = std::max(most, ++count[i]);
  const uint64_t plain = (indices.size() * k + 7) / 8;
  const uint64_t rank = 8 * ((indices.size() + 31) / 32) + ((indices.size() - most + 1) * k + 7) / 8;
  return !indices.empty() && rank < plain ? rank : plain;
}

}  // namespace somm::testing
