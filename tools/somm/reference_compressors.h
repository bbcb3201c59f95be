// SPDX-License-Identifier: MIT
// Non-random-access size references (CLI and benchmarks only; never in somm_core): the size of `bytes` compressed
// with zstd -19 and with xz -9 (preset 9, CRC64, dictionary no larger than the input), 0 on a compressor error.
#pragma once

#include <cstdint>
#include <span>

namespace somm::cli {

uint64_t zstdBytes(std::span<const uint8_t> bytes);
uint64_t xzBytes(std::span<const uint8_t> bytes);

}  // namespace somm::cli
