// SPDX-License-Identifier: MIT
// somm CLI — succinct encodings in .somm files: section ids, storing, loading, size reports
// (docs/encodings.md).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "somm/encode.h"
#include "somm/somm_file.h"

namespace somm::cli {

// Section ids of the encodings in a geometry's extra sections: "dfs ", "dfsf", "rank", "hybr" (flat is the
// geometry's spec buffers and is never stored twice).
uint32_t encodingSectionId(Encoding e) noexcept;
std::optional<Encoding> sectionEncoding(uint32_t id) noexcept;

// Builds the given encodings of the geometry's flat array and stores them as extra sections (replacing any
// with the same id). Flat is skipped.
Status addEncodingSections(SommGeometry& g, std::span<const Encoding> encodings);

// Encoding `e` of a geometry: flat from the spec buffers, the others parsed (validated) from their section.
// Errors name `what` (the file) and the geometry.
Result<EncodedArray> loadEncoding(const SommGeometry& g, uint32_t geometryIndex, Encoding e,
                                  std::string_view what);

// Non-random-access references: the size of `bytes` compressed with zstd -19 and xz -9.
uint64_t zstdBytes(std::span<const uint8_t> bytes);
uint64_t xzBytes(std::span<const uint8_t> bytes);

// Exact bytes of each encoding of one or more geometries (serialized EncodedArray size: header, index buffer,
// descriptors, data, padding) plus the compressed references of the flat array.
struct EncodingSizes {
  uint64_t flat = 0;                                  // the flat EncodedArray (same framing as the others)
  std::vector<std::pair<Encoding, uint64_t>> stored;  // valid stored encodings, in kAllEncodings order
  std::vector<std::pair<Encoding, std::string>> invalid;  // stored sections that do not parse: the error
  uint64_t zstd = 0, xz = 0;                              // the flat EncodedArray's bytes compressed
  void add(const EncodingSizes& o);
};
// Sizes of the encodings stored in g (flat always), with the compressed references when `compressed`. A
// stored section that does not parse is listed in `invalid` (info still describes the rest of the file).
Result<EncodingSizes> encodingSizes(const SommGeometry& g, uint32_t geometryIndex, std::string_view what,
                                    bool compressed);
// {"flat": {"bytes": N, "ratio_to_flat": 1}, "rank": {...}, ..., "zstd-19": {..., "random_access": false},
//  "xz-9": {...}}; an unreadable section: "rank": {"error": "..."}
nlohmann::json encodingSizesJson(const EncodingSizes& s);

}  // namespace somm::cli
