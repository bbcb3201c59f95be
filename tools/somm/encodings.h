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

#include "reference_compressors.h"
#include "somm/encode.h"
#include "somm/somm_file.h"

namespace somm::cli {

// Section ids of the encodings in an array's extra sections: "dfs ", "dfsf", "rank", "hybr" (flat is the
// array's spec buffers and is never stored twice). Users only ever see encoding names (encodingName), never ids.
uint32_t encodingSectionId(Encoding e) noexcept;
std::optional<Encoding> sectionEncoding(uint32_t id) noexcept;
// The name to show for a stored section: the encoding's name ("dfs-fast"), or for an id this build does not
// know "unknown encoding 'xxxx'".
std::string sectionName(uint32_t id);

// Builds the given encodings of the array and stores them in `extra` (replacing any with the same id). Flat is
// skipped.
Status addEncodingSections(const OmmArray& array, std::vector<EncodedSection>& extra,
                           std::span<const Encoding> encodings);
// The same for every array of the file.
Status addEncodingSections(SommFile& file, std::span<const Encoding> encodings);

// Encoding `e` of array `array`: flat from the spec buffers, the others parsed (validated) from their section.
// It answers for the array's triangles (SceneMicromaps::globalTriangle). Errors name `what` (the file) and the
// array.
Result<EncodedArray> loadEncoding(const SommFile& file, uint32_t array, Encoding e, std::string_view what);

// Every encoding name in kAllEncodings order, comma-separated ("flat, dfs, …, sdag"): the one list every option
// help and error message shows.
std::string encodingNameList();

// Exact bytes of each encoding of one or more arrays (serialized EncodedArray size: header, index buffer,
// descriptors, data, padding) plus the compressed references of the flat array.
struct EncodingSizes {
  uint64_t flat = 0;                                  // the flat EncodedArray (same framing as the others)
  std::vector<std::pair<Encoding, uint64_t>> stored;  // valid stored encodings, in kAllEncodings order
  std::vector<std::pair<Encoding, std::string>> invalid;  // stored sections that do not parse: the error
  uint64_t zstd = 0, xz = 0;                              // the flat EncodedArray's bytes compressed
  void add(const EncodingSizes& o);
};
// Sizes of the encodings stored for array `array` (flat always), with the compressed references when
// `compressed`. A stored section that does not parse is listed in `invalid` (info still describes the rest).
Result<EncodingSizes> encodingSizes(const SommFile& file, uint32_t array, std::string_view what,
                                    bool compressed);
// {"flat": {"bytes": N, "ratio_to_flat": 1}, "rank": {...}, ..., "zstd-19": {..., "random_access": false},
//  "xz-9": {...}}; an unreadable section: "rank": {"error": "..."}
nlohmann::json encodingSizesJson(const EncodingSizes& s);

}  // namespace somm::cli
