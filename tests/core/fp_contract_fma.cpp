// SPDX-License-Identifier: MIT
// baryToIndex as a consumer may compile it: -ffp-contract=fast -mfma (tests/CMakeLists.txt sets them for this file
// alone). flatten: the inline function is inlined here, so no FMA-compiled out-of-line copy reaches other files.
#include <cstdint>

#include "somm/bird.h"

__attribute__((flatten)) uint32_t baryToIndexContracted(float u, float v, uint32_t level) noexcept {
  return somm::baryToIndex(u, v, level);
}
