// SPDX-License-Identifier: MIT
#include "encodings.h"

#include <algorithm>
#include <span>

namespace somm::cli {

uint32_t encodingSectionId(Encoding e) noexcept {
  switch (e) {
    case Encoding::Flat:
      return sectionId("flat");
    case Encoding::Dfs:
      return sectionId("dfs ");
    case Encoding::DfsFast:
      return sectionId("dfsf");
    case Encoding::Rank:
      return sectionId("rank");
    case Encoding::Hybrid:
      return sectionId("hybr");
    case Encoding::Csm:
      return sectionId("csm ");
    case Encoding::Sdag:
      return sectionId("sdag");
  }
  return 0;
}

std::optional<Encoding> sectionEncoding(uint32_t id) noexcept {
  for (Encoding e : kAllEncodings)
    if (e != Encoding::Flat && encodingSectionId(e) == id) return e;
  return std::nullopt;
}

std::string sectionName(uint32_t id) {
  if (const auto e = sectionEncoding(id)) return encodingName(*e);
  return "unknown encoding '" + sectionIdName(id) + "'";
}

Status addEncodingSections(const OmmArray& array, std::vector<EncodedSection>& extra,
                           std::span<const Encoding> encodings) {
  for (Encoding requested : encodings) {
    // dfs-fast is the dfs tree with another lookup: one "dfs " section serves both.
    const Encoding e = EncodedArray::storedEncoding(requested);
    if (e == Encoding::Flat) continue;
    auto a = EncodedArray::build(array, e);
    if (!a) return a.error();
    EncodedSection s{encodingSectionId(e), a->serialize()};
    auto it = std::find_if(extra.begin(), extra.end(), [&](const EncodedSection& x) { return x.id == s.id; });
    if (it != extra.end())
      *it = std::move(s);
    else
      extra.push_back(std::move(s));
  }
  return Ok{};
}

Status addEncodingSections(SommFile& file, std::span<const Encoding> encodings) {
  file.encodings.resize(file.micromaps.arrays.size());
  for (size_t a = 0; a < file.micromaps.arrays.size(); ++a)
    if (Status s = addEncodingSections(file.micromaps.arrays[a], file.encodings[a], encodings); !s)
      return makeError(s.error().code, "array " + std::to_string(a) + ": " + s.error().message);
  return Ok{};
}

Result<EncodedArray> loadEncoding(const SommFile& file, uint32_t array, Encoding e, std::string_view what) {
  const std::string where = std::string(what) + ": array " + std::to_string(array);
  const OmmArray& flat = file.micromaps.arrays[array];
  if (e == Encoding::Flat) {
    auto a = EncodedArray::build(flat, Encoding::Flat);
    if (!a) return makeError(a.error().code, where + ": " + a.error().message);
    return a;
  }
  // dfs-fast reads the dfs section (files from before the shared section may hold a "dfsf" copy).
  const uint32_t ids[2] = {encodingSectionId(EncodedArray::storedEncoding(e)), encodingSectionId(e)};
  for (uint32_t id : ids)
    for (const EncodedSection& s : file.encodings[array]) {
      if (s.id != id) continue;
      auto a = EncodedArray::parse(s.bytes, where + " encoding '" + encodingName(e) + "'");
      if (!a) return a;
      a->setLookup(e);
      if (a->encoding() != e || a->triangleCount() != flat.indices.size())
        return makeError(ErrorCode::CorruptFile,
                         where + ": encoding '" + encodingName(e) +
                             "' does not match the array (encoding id or triangle count)");
      if (Status v = verifyAgainstFlat(*a, flat, where + " encoding '" + encodingName(e) + "'"); !v)
        return v.error();
      return a;
    }
  return makeError(
      ErrorCode::InvalidArgument,
      where + " stores no '" + encodingName(e) + "' encoding (bake with --encoding " + encodingName(e) + ")");
}

std::string encodingNameList() {
  std::string s;
  for (Encoding e : kAllEncodings) (s += s.empty() ? "" : ", ") += encodingName(e);
  return s;
}

void EncodingSizes::add(const EncodingSizes& o) {
  flat += o.flat;
  zstd += o.zstd;
  xz += o.xz;
  for (const auto& entry : o.stored) {
    auto it =
        std::find_if(stored.begin(), stored.end(), [&](const auto& p) { return p.first == entry.first; });
    if (it == stored.end())
      stored.push_back(entry);
    else
      it->second += entry.second;
  }
  std::sort(stored.begin(), stored.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
}

Result<EncodingSizes> encodingSizes(const SommFile& file, uint32_t array, std::string_view what,
                                    bool compressed) {
  EncodingSizes s;
  auto flat = loadEncoding(file, array, Encoding::Flat, what);
  if (!flat) return flat.error();
  s.flat = flat->byteSize();
  for (const EncodedSection& x : file.encodings[array]) {
    const auto e = sectionEncoding(x.id);
    if (!e) continue;
    auto a = loadEncoding(file, array, *e, what);
    if (a)
      s.stored.emplace_back(*e, a->byteSize());
    else
      s.invalid.emplace_back(*e, a.error().message);
    // The dfs section also serves dfs-fast (same bytes, another lookup).
    if (a && *e == Encoding::Dfs &&
        std::none_of(file.encodings[array].begin(), file.encodings[array].end(),
                     [](const EncodedSection& x) { return x.id == encodingSectionId(Encoding::DfsFast); }))
      s.stored.emplace_back(Encoding::DfsFast, a->byteSize());
  }
  std::sort(s.stored.begin(), s.stored.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  if (compressed) {
    const std::vector<uint8_t> bytes = flat->serialize();
    s.zstd = zstdBytes(bytes);
    s.xz = xzBytes(bytes);
  }
  return s;
}

nlohmann::json encodingSizesJson(const EncodingSizes& s) {
  auto entry = [&](uint64_t bytes) {
    return nlohmann::json{{"bytes", bytes}, {"ratio_to_flat", s.flat ? double(bytes) / double(s.flat) : 0.0}};
  };
  nlohmann::json j = nlohmann::json::object();
  j["flat"] = entry(s.flat);
  for (const auto& [e, b] : s.stored) j[encodingName(e)] = entry(b);
  for (const auto& [e, msg] : s.invalid) j[encodingName(e)] = {{"error", msg}};
  if (s.zstd) {
    j["zstd-19"] = entry(s.zstd);
    j["zstd-19"]["random_access"] = false;
  }
  if (s.xz) {
    j["xz-9"] = entry(s.xz);
    j["xz-9"]["random_access"] = false;
  }
  return j;
}

}  // namespace somm::cli
