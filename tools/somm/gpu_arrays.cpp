// SPDX-License-Identifier: MIT
#include "gpu_arrays.h"

#include "encodings.h"

namespace somm::cli {

Result<std::vector<GpuEncoding>> loadGpuEncodings(const SommFile& file, const std::string& path,
                                                  const std::string& encoding) {
  std::vector<Encoding> wanted;
  if (encoding == "all") {
    // flat, then every encoding that each array stores (dfs-fast reads the dfs section)
    for (Encoding e : kAllEncodings) {
      bool everywhere = !file.micromaps.arrays.empty();
      if (e != Encoding::Flat)
        for (size_t a = 0; a < file.micromaps.arrays.size(); ++a) {
          bool has = false;
          if (a < file.encodings.size())
            for (const EncodedSection& s : file.encodings[a])
              has = has || s.id == encodingSectionId(EncodedArray::storedEncoding(e));
          everywhere = everywhere && has;
        }
      if (everywhere || e == Encoding::Flat) wanted.push_back(e);
    }
  } else {
    const auto e = parseEncodingName(encoding);
    if (!e)
      return makeError(ErrorCode::InvalidArgument, "--encoding '" + encoding + "' is not one of " +
                                                       somm::cli::encodingNameList() + ", all");
    wanted.push_back(*e);
  }
  std::vector<GpuEncoding> out;
  for (Encoding e : wanted) {
    GpuEncoding ge;
    ge.encoding = e;
    for (uint32_t k = 0; k < file.micromaps.arrays.size(); ++k) {
      auto a = loadEncoding(file, k, e, path);
      if (!a) return a.error();
      std::vector<uint8_t> bytes = a->serialize();
      if (ge.buffer.size() + bytes.size() + 16 > 0xfffffff0u)
        return makeError(
            ErrorCode::LimitExceeded,
            path + ": the '" + encodingName(e) + "' arrays exceed the 4 GiB a 32-bit shader address reaches");
      ge.bases.push_back(uint32_t(ge.buffer.size()));
      ge.buffer.insert(ge.buffer.end(), bytes.begin(), bytes.end());
      ge.buffer.resize((ge.buffer.size() + 15) & ~size_t(15), 0);
      ge.arrays.push_back(std::move(*a));
    }
    out.push_back(std::move(ge));
  }
  return out;
}

}  // namespace somm::cli
