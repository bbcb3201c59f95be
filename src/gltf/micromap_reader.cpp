// SPDX-License-Identifier: MIT
// somm — reading EXT_mesh_opacity_micromap (docs/gltf.md): every MUST of the draft is checked, each violation is a
// one-line error naming the object and the rule.
#include <algorithm>
#include <cstring>

#include "document.h"
#include "gltf_internal.h"
#include "somm/gltf.h"

namespace somm {

using gltfdoc::Document;
using gltfdoc::getInt;
using gltfdoc::json;

namespace gltfint {

const json* member(const json& o, const char* key) {
  if (!o.is_object()) return nullptr;
  auto it = o.find(key);
  return it == o.end() ? nullptr : &*it;
}

const json* array(const json& root, const char* key) {
  const json* a = member(root, key);
  return a && a->is_array() ? a : nullptr;
}

Result<ViewBytes> bufferView(Document& d, int64_t index, const std::string& what) {
  const json* views = array(d.root, "bufferViews");
  if (index < 0 || !views || uint64_t(index) >= views->size())
    return d.fail(ErrorCode::CorruptFile, what + ": bufferView " + std::to_string(index) +
                                              " does not exist (MUST be a valid bufferView index)");
  const json& v = (*views)[size_t(index)];
  const std::string name = "bufferViews[" + std::to_string(index) + "]";
  int64_t buffer = -1, offset = 0, length = 0;
  if (!v.is_object() || !getInt(v, "buffer", buffer) || buffer < 0)
    return d.fail(ErrorCode::CorruptFile, name + ": buffer MUST be a valid buffer index (glTF 2.0)");
  if (v.contains("byteOffset") && (!getInt(v, "byteOffset", offset) || offset < 0))
    return d.fail(ErrorCode::CorruptFile, name + ": byteOffset MUST be an integer >= 0 (glTF 2.0)");
  if (!getInt(v, "byteLength", length) || length < 1)
    return d.fail(ErrorCode::CorruptFile, name + ": byteLength MUST be an integer >= 1 (glTF 2.0)");
  auto buf = d.buffer(size_t(buffer));
  if (!buf) return buf.error();
  if (uint64_t(offset) > (*buf)->size() || uint64_t(length) > (*buf)->size() - uint64_t(offset))
    return d.fail(ErrorCode::CorruptFile,
                  name + ": byteOffset + byteLength MUST NOT exceed the byteLength of buffer " +
                      std::to_string(buffer) + " (glTF 2.0)");
  ViewBytes out;
  out.data = (*buf)->data() + offset;
  out.size = size_t(length);
  out.hasStride = v.contains("byteStride");
  out.byteOffset = uint64_t(offset);
  return out;
}

// loadScene's geometry numbering: every primitive of every mesh in order.
Result<std::vector<PrimitiveRef>> primitives(Document& d) {
  std::vector<PrimitiveRef> out;
  const json* meshes = array(d.root, "meshes");
  if (!meshes) return out;
  const json* accessors = array(d.root, "accessors");
  for (size_t mi = 0; mi < meshes->size(); ++mi) {
    const json& mesh = (*meshes)[mi];
    const json* prims = member(mesh, "primitives");
    if (!prims || !prims->is_array())
      return d.fail(ErrorCode::CorruptFile,
                    "meshes[" + std::to_string(mi) + "]: primitives MUST be an array");
    const json* nameJ = member(mesh, "name");
    const std::string meshName =
        nameJ && nameJ->is_string() ? nameJ->get<std::string>() : "mesh" + std::to_string(mi);
    for (size_t pi = 0; pi < prims->size(); ++pi) {
      PrimitiveRef r;
      r.mesh = mi, r.primitive = pi;
      r.name = meshName + "/" + std::to_string(pi);
      r.where = "meshes[" + std::to_string(mi) + "].primitives[" + std::to_string(pi) + "]";
      const json& p = (*prims)[pi];
      if (!p.is_object()) return d.fail(ErrorCode::CorruptFile, r.where + " is not an object");
      int64_t mode = 4;
      if (p.contains("mode") && !getInt(p, "mode", mode))
        return d.fail(ErrorCode::CorruptFile, r.where + ": mode is not an integer");
      r.mode = mode;
      int64_t material = -1;
      if (p.contains("material") && !getInt(p, "material", material))
        return d.fail(ErrorCode::CorruptFile, r.where + ": material is not an integer");
      r.material = material;
      if (mode == 4) {
        int64_t acc = -1;
        const bool indexed = p.contains("indices");
        if (indexed) {
          if (!getInt(p, "indices", acc))
            return d.fail(ErrorCode::CorruptFile, r.where + ": indices is not an integer");
        } else {
          const json* attrs = member(p, "attributes");
          if (!attrs || !getInt(*attrs, "POSITION", acc))
            return d.fail(ErrorCode::CorruptFile, r.where + ": no POSITION attribute");
        }
        int64_t count = 0;
        if (acc < 0 || !accessors || uint64_t(acc) >= accessors->size() ||
            !getInt((*accessors)[size_t(acc)], "count", count) || count < 0)
          return d.fail(ErrorCode::CorruptFile, r.where + ": accessor " + std::to_string(acc) +
                                                    " does not exist or has no valid count");
        // Memory bound: the count must be backed by its buffer view (≥ 1 byte per element), or be small when the
        // accessor has no buffer view (all zeros), as loadScene requires.
        const json& a = (*accessors)[size_t(acc)];
        int64_t view = -1, viewLength = 0;
        const json* views = array(d.root, "bufferViews");
        if (getInt(a, "bufferView", view)) {
          if (view < 0 || !views || uint64_t(view) >= views->size() ||
              !getInt((*views)[size_t(view)], "byteLength", viewLength) || count > viewLength)
            return d.fail(ErrorCode::CorruptFile, r.where + ": accessor " + std::to_string(acc) + ": " +
                                                      std::to_string(count) +
                                                      " elements do not fit its buffer view");
        } else if (count > (int64_t(1) << 20)) {
          return d.fail(ErrorCode::LimitExceeded,
                        r.where + ": accessor " + std::to_string(acc) + ": too many elements");
        }
        if (count / 3 > int64_t(UINT32_MAX))
          return d.fail(ErrorCode::LimitExceeded, r.where + ": too many triangles");
        r.triangles = uint32_t(count / 3);
      }
      out.push_back(std::move(r));
    }
  }
  return out;
}

MaterialRef materialRef(const Document& d, int64_t material) {
  MaterialRef m;
  const json* mats = array(d.root, "materials");
  if (material < 0 || !mats || uint64_t(material) >= mats->size()) return m;
  const json& jm = (*mats)[size_t(material)];
  const json* n = member(jm, "name");
  m.name = n && n->is_string() ? n->get<std::string>() : "material" + std::to_string(material);
  const json* mode = member(jm, "alphaMode");
  m.alphaMode = mode && mode->is_string() ? mode->get<std::string>() : "OPAQUE";
  const json* c = member(jm, "alphaCutoff");
  if (c && c->is_number()) m.cutoff = c->get<double>();
  const json* pbr = member(jm, "pbrMetallicRoughness");
  const json* tex = pbr ? member(*pbr, "baseColorTexture") : nullptr;
  int64_t ti = -1, si = -1;
  const json* textures = array(d.root, "textures");
  const json* samplers = array(d.root, "samplers");
  if (tex && getInt(*tex, "index", ti) && ti >= 0 && textures && uint64_t(ti) < textures->size() &&
      getInt((*textures)[size_t(ti)], "sampler", si) && si >= 0 && samplers &&
      uint64_t(si) < samplers->size()) {
    const json& s = (*samplers)[size_t(si)];
    int64_t v = 0;
    auto wrap = [](int64_t w) {
      return w == 33071 ? Wrap::ClampToEdge : w == 33648 ? Wrap::MirroredRepeat : Wrap::Repeat;
    };
    if (getInt(s, "wrapS", v)) m.sampler.wrapS = wrap(v);
    if (getInt(s, "wrapT", v)) m.sampler.wrapT = wrap(v);
    if (getInt(s, "magFilter", v)) m.sampler.filter = v == 9728 ? Filter::Nearest : Filter::Linear;
  }
  return m;
}

}  // namespace gltfint

namespace {

using namespace gltfint;

const std::string kExt = kGltfMicromapExtension;

// Reads a JSON integer array with every element an integer; false otherwise.
bool intArray(const json* a, std::vector<int64_t>& out) {
  if (!a || !a->is_array()) return false;
  out.clear();
  for (const json& e : *a) {
    json wrapper = {{"v", e}};
    int64_t v;
    if (!getInt(wrapper, "v", v)) return false;
    out.push_back(v);
  }
  return true;
}

uint64_t regionBytes(uint32_t level, uint32_t format) {
  return ((uint64_t(1) << (2 * level)) * (format == 1 ? 1 : 2) + 7) / 8;
}

struct ArrayRead {
  OmmArray array;
  std::vector<uint64_t> unknownPerRecord;  // unknown micro-triangles of each record
};

Result<ArrayRead> readArray(Document& d, const json& m, size_t i) {
  const std::string where = kExt + ": micromaps[" + std::to_string(i) + "]";
  auto fail = [&](const std::string& rule) -> Error {
    return d.fail(ErrorCode::CorruptFile, where + ": " + rule);
  };
  if (!m.is_object()) return fail("MUST be an object");
  int64_t dataView = -1, triView = -1;
  if (!getInt(m, "data", dataView))
    return fail("data is required and MUST be an integer (a bufferView index)");
  if (!getInt(m, "triangles", triView))
    return fail("triangles is required and MUST be an integer (a bufferView index)");
  std::vector<int64_t> counts, levels, formats;
  if (!intArray(member(m, "usageCounts"), counts))
    return fail("usageCounts is required and MUST be an integer array");
  if (!intArray(member(m, "usageLevels"), levels))
    return fail("usageLevels is required and MUST be an integer array");
  if (!intArray(member(m, "usageFormats"), formats))
    return fail("usageFormats is required and MUST be an integer array");
  if (counts.size() != levels.size() || counts.size() != formats.size())
    return fail("usageCounts, usageLevels and usageFormats MUST have the same length (" +
                std::to_string(counts.size()) + ", " + std::to_string(levels.size()) + ", " +
                std::to_string(formats.size()) + ")");
  if (counts.empty()) return fail("usageCounts MUST have at least one element");
  for (size_t k = 0; k < counts.size(); ++k) {
    const std::string e = "[" + std::to_string(k) + "]";
    if (counts[k] < 1) return fail("usageCounts" + e + " = " + std::to_string(counts[k]) + ": MUST be >= 1");
    if (levels[k] < 0 || levels[k] > 12)
      return fail("usageLevels" + e + " = " + std::to_string(levels[k]) + ": MUST be in [0, 12]");
    if (formats[k] != 1 && formats[k] != 2)
      return fail("usageFormats" + e + " = " + std::to_string(formats[k]) + ": MUST be 1 or 2");
  }
  if (m.contains("name") && !m["name"].is_string()) return fail("name MUST be a string");
  auto dv = bufferView(d, dataView, where + " data");
  if (!dv) return dv.error();
  auto tv = bufferView(d, triView, where + " triangles");
  if (!tv) return tv.error();
  if (dv->hasStride)
    return fail("the data bufferView " + std::to_string(dataView) + " MUST NOT define byteStride");
  if (tv->hasStride)
    return fail("the triangles bufferView " + std::to_string(triView) + " MUST NOT define byteStride");
  if (tv->size % 8 != 0)
    return fail("the triangles bufferView's byteLength " + std::to_string(tv->size) +
                " MUST be a multiple of 8");
  ArrayRead out;
  OmmArray& a = out.array;
  const size_t n = tv->size / 8;
  a.descriptors.resize(n);
  uint64_t pairCount[13][3] = {};
  struct Region {
    uint64_t begin, end;
    size_t record;
  };
  std::vector<Region> regions(n);
  for (size_t r = 0; r < n; ++r) {
    const uint8_t* p = tv->data + 8 * r;
    TriangleDescriptor& t = a.descriptors[r];
    std::memcpy(&t.dataOffset, p, 4);
    std::memcpy(&t.subdivisionLevel, p + 4, 2);
    std::memcpy(&t.format, p + 6, 2);  // little endian host (x86-64, aarch64)
    const std::string rec = "triangle record " + std::to_string(r);
    if (t.subdivisionLevel > 12)
      return fail(rec + ": subdivisionLevel " + std::to_string(t.subdivisionLevel) + " MUST be in [0, 12]");
    if (t.format != 1 && t.format != 2)
      return fail(rec + ": format " + std::to_string(t.format) + " MUST be 1 or 2");
    const uint64_t bytes = regionBytes(t.subdivisionLevel, t.format);
    if (uint64_t(t.dataOffset) + bytes > dv->size)
      return fail(rec + ": its region [" + std::to_string(t.dataOffset) + ", " +
                  std::to_string(uint64_t(t.dataOffset) + bytes) + ") MUST lie within the data bufferView (" +
                  std::to_string(dv->size) + " bytes)");
    ++pairCount[t.subdivisionLevel][t.format];
    regions[r] = Region{t.dataOffset, t.dataOffset + bytes, r};
  }
  // Per distinct (level, format): the sum of its usage counts equals the number of records with that pair.
  uint64_t usage[13][3] = {};
  for (size_t k = 0; k < counts.size(); ++k)
    usage[levels[k]][formats[k]] += std::min<uint64_t>(uint64_t(counts[k]), uint64_t(n) + 1);  // no overflow
  for (uint32_t l = 0; l <= 12; ++l)
    for (uint32_t f = 1; f <= 2; ++f)
      if (usage[l][f] != pairCount[l][f])
        return fail("usage entries count " + std::to_string(usage[l][f]) + " triangles of level " +
                    std::to_string(l) + " format " + std::to_string(f) + " but " +
                    std::to_string(pairCount[l][f]) + " records have that pair (the sums MUST be equal)");
  std::sort(regions.begin(), regions.end(), [](const Region& x, const Region& y) {
    return x.begin != y.begin ? x.begin < y.begin : x.record < y.record;
  });
  for (size_t k = 1; k < regions.size(); ++k)
    if (regions[k].begin < regions[k - 1].end)
      return fail("the regions of triangle records " + std::to_string(regions[k - 1].record) + " and " +
                  std::to_string(regions[k].record) + " overlap (MUST NOT overlap)");
  a.data.assign(dv->data, dv->data + dv->size);
  out.unknownPerRecord.resize(n);
  for (size_t r = 0; r < n; ++r) {
    const TriangleDescriptor& t = a.descriptors[r];
    if (t.format != 2) continue;
    uint64_t unknown = 0;
    const uint32_t micro = 1u << (2 * t.subdivisionLevel);
    for (uint32_t k = 0; k < micro; ++k)
      unknown += uint32_t(readPackedState(a.data.data() + t.dataOffset, Format::FourState, k)) >= 2;
    out.unknownPerRecord[r] = unknown;
  }
  return out;
}

}  // namespace

Result<GltfMicromapsRead> readDocumentMicromaps(Document& d) {
  GltfMicromapsRead result;
  const json* rootExtObj = member(d.root, "extensions");
  const json* rootExt = rootExtObj ? member(*rootExtObj, kExt.c_str()) : nullptr;
  auto prims = primitives(d);
  if (!prims) return prims.error();
  bool anyPrim = false;
  for (const PrimitiveRef& r : *prims) {
    const json& p = d.root["meshes"][r.mesh]["primitives"][r.primitive];
    const json* e = member(p, "extensions");
    if (e && member(*e, kExt.c_str())) anyPrim = true;
  }
  if (!rootExt && !anyPrim) return result;  // not used: the caller behaves as without micromaps
  result.present = true;
  auto fail = [&](const std::string& what) -> Error { return d.fail(ErrorCode::CorruptFile, what); };
  bool listed = false;
  if (const json* used = array(d.root, "extensionsUsed"))
    for (const json& u : *used) listed = listed || (u.is_string() && u.get<std::string>() == kExt);
  if (!listed) return fail(kExt + " is used but not listed in extensionsUsed (glTF 2.0: it MUST be listed)");

  // Memory bound over the whole file (primitives may share accessors): 4 bytes per triangle within 64 MiB + 16x the
  // buffer bytes the file declares (embedded buffers are bounded by the file, external ones by their files).
  uint64_t triangles = 0, declared = 0;
  for (const PrimitiveRef& r : *prims) triangles += r.triangles;
  if (const json* bufs = array(d.root, "buffers"))
    for (size_t b = 0; b < bufs->size(); ++b) declared += d.bufferBound(b);
  if (4 * triangles > (uint64_t(64) << 20) + 16 * declared)
    return d.fail(ErrorCode::LimitExceeded, "the primitives' " + std::to_string(triangles) +
                                                " triangles exceed 16x the file's buffer bytes + 64 MiB");
  GltfMicromaps& out = result.value;
  std::vector<ArrayRead> arrays;
  if (rootExt) {
    if (!rootExt->is_object()) return fail(kExt + ": the root extension MUST be an object");
    const json* mm = member(*rootExt, "micromaps");
    if (!mm || !mm->is_array()) return fail(kExt + ": micromaps is required and MUST be an array");
    for (size_t i = 0; i < mm->size(); ++i) {
      auto a = readArray(d, (*mm)[i], i);
      if (!a) return a.error();
      arrays.push_back(std::move(*a));
    }
    const json* extras = mm->empty() ? nullptr : member((*mm)[0], "extras");
    if (extras) {
      const json* s = member(*extras, "somm");
      if (s && s->is_object()) {
        const json* src = member(*s, "source");
        if (src && src->is_string()) out.sourcePath = src->get<std::string>();
        const json* tv = member(*s, "tool");
        if (tv && tv->is_string()) out.toolVersion = tv->get<std::string>();
        const json* bo = member(*s, "bakeOptions");
        if (bo && bo->is_array())
          for (const json& kv : *bo)
            if (kv.is_array() && kv.size() == 2 && kv[0].is_string() && kv[1].is_string())
              out.bakeOptions.emplace_back(kv[0].get<std::string>(), kv[1].get<std::string>());
      }
    }
  }

  // Per geometry: its array and its index buffer (global record numbers or special indices).
  struct GeoIdx {
    uint32_t array = 0;
    std::vector<int32_t> indices;
  };
  std::vector<GeoIdx> geo(prims->size());
  const json* accessors = array(d.root, "accessors");
  for (size_t g = 0; g < prims->size(); ++g) {
    const PrimitiveRef& r = (*prims)[g];
    const json& p = d.root["meshes"][r.mesh]["primitives"][r.primitive];
    const MaterialRef mat = materialRef(d, r.material);
    GeometryInfo info;
    info.name = r.name;
    info.material = r.material >= 0 ? mat.name : "default";
    info.triangleCount = r.triangles;
    info.cutoff = float(mat.cutoff);
    info.sampler = mat.sampler;
    const json* e = member(p, "extensions");
    const json* x = e ? member(*e, kExt.c_str()) : nullptr;
    const std::string where = r.where + ": " + kExt;
    GeoIdx& gi = geo[g];
    out.hasMicromap.push_back(x ? 1 : 0);
    if (!x) {
      gi.indices.assign(r.triangles, specialIndexFor(State::UnknownOpaque));
      out.geometries.push_back(info);
      continue;
    }
    if (!x->is_object()) return fail(where + " MUST be an object");
    if (r.mode != 4)
      return fail(where + ": the primitive's mode is " + std::to_string(r.mode) + " (MUST be 4, TRIANGLES)");
    int64_t micromap = -1, base = 0;
    if (!getInt(*x, "micromap", micromap))
      return fail(where + ": micromap is required and MUST be an integer");
    if (micromap < 0 || uint64_t(micromap) >= arrays.size())
      return fail(where + ": micromap " + std::to_string(micromap) +
                  " MUST be an index into the root micromaps (" + std::to_string(arrays.size()) +
                  " entries)");
    if (x->contains("micromapBaseTriangle") && (!getInt(*x, "micromapBaseTriangle", base) || base < 0))
      return fail(where + ": micromapBaseTriangle MUST be an integer >= 0");
    gi.array = uint32_t(micromap);
    const OmmArray& arr = arrays[size_t(micromap)].array;
    const uint64_t records = arr.descriptors.size();
    gi.indices.resize(r.triangles);
    auto lookup = [&](uint32_t t, int64_t m) -> Status {
      if (m < 0) {
        gi.indices[t] = int32_t(m);
        return Ok{};
      }
      const uint64_t rec = uint64_t(m) + uint64_t(base);
      if (rec >= records)
        return fail(where + ": triangle " + std::to_string(t) + " uses micromap triangle " +
                    std::to_string(m) + " + micromapBaseTriangle " + std::to_string(base) + " = " +
                    std::to_string(rec) + " (MUST be less than the " + std::to_string(records) +
                    " triangle records)");
      gi.indices[t] = int32_t(rec);
      return Ok{};
    };
    int64_t acc = -1;
    if (x->contains("micromapIndices")) {
      if (!getInt(*x, "micromapIndices", acc) || acc < 0 || !accessors || uint64_t(acc) >= accessors->size())
        return fail(where + ": micromapIndices MUST be a valid accessor index");
      const json& a = (*accessors)[size_t(acc)];
      const std::string an = where + ": micromapIndices accessor " + std::to_string(acc);
      const json* type = member(a, "type");
      if (!type || !type->is_string() || type->get<std::string>() != "SCALAR")
        return fail(an + ": type MUST be SCALAR");
      int64_t ct = 0, count = -1, offset = 0, view = -1;
      getInt(a, "componentType", ct);
      if (ct != 5121 && ct != 5123 && ct != 5125 && ct != 5122 && ct != 5124)
        return fail(an + ": componentType " + std::to_string(ct) + " MUST be 5121, 5123, 5125, 5122 or 5124");
      const json* norm = member(a, "normalized");
      if (norm && norm->is_boolean() && norm->get<bool>()) return fail(an + ": normalized MUST NOT be true");
      if (!getInt(a, "count", count) || count != int64_t(r.triangles))
        return fail(an + ": count " + std::to_string(count) + " MUST equal the primitive's triangle count " +
                    std::to_string(r.triangles));
      if (a.contains("sparse"))
        return d.fail(ErrorCode::UnsupportedFormat, an + ": sparse micromapIndices are not supported");
      if (a.contains("byteOffset") && (!getInt(a, "byteOffset", offset) || offset < 0))
        return fail(an + ": byteOffset MUST be an integer >= 0");
      const int size = ct == 5121 ? 1 : (ct == 5123 || ct == 5122) ? 2 : 4;
      const bool isSigned = ct == 5122 || ct == 5124;
      const uint8_t* base8 = nullptr;
      if (a.contains("bufferView")) {
        if (!getInt(a, "bufferView", view)) return fail(an + ": bufferView is not an integer");
        auto bv = bufferView(d, view, an);
        if (!bv) return bv.error();
        if (bv->hasStride)
          return fail(an + ": its bufferView " + std::to_string(view) + " MUST NOT define byteStride");
        if ((bv->byteOffset + uint64_t(offset)) % uint64_t(size) != 0)
          return fail(an + ": its data MUST be aligned to its component size (glTF 2.0)");
        if (uint64_t(offset) > bv->size || uint64_t(count) * uint64_t(size) > bv->size - uint64_t(offset))
          return fail(an + ": " + std::to_string(count) + " elements MUST fit in bufferView " +
                      std::to_string(view));
        base8 = bv->data + offset;
      }
      for (uint32_t t = 0; t < r.triangles; ++t) {
        int64_t m = 0;
        if (base8) {
          const uint8_t* q = base8 + size_t(t) * size_t(size);
          if (size == 1) {
            m = q[0] >= 0xFC ? int64_t(q[0]) - 256 : q[0];  // UNSIGNED_BYTE: 252..255 = -4..-1
          } else if (size == 2) {
            uint16_t v;
            std::memcpy(&v, q, 2);
            m = isSigned ? int64_t(int16_t(v)) : (v >= 0xFFFC ? int64_t(v) - 65536 : v);
          } else {
            uint32_t v;
            std::memcpy(&v, q, 4);
            m = isSigned ? int64_t(int32_t(v)) : (v >= 0xFFFFFFFCu ? int64_t(v) - 4294967296LL : v);
          }
        }
        if (m < -4)
          return fail(an + ": element " + std::to_string(t) + " = " + std::to_string(m) + " MUST be >= -4");
        if (Status s = lookup(t, m); !s) return s.error();
      }
    } else {
      for (uint32_t t = 0; t < r.triangles; ++t)
        if (Status s = lookup(t, t); !s) return s.error();
    }
    // Bake parameters somm stored (for the alpha test the micromaps were made for).
    if (const json* extras = member(*x, "extras")) {
      const json* s = member(*extras, "somm");
      const json* c = s ? member(*s, "cutoff") : nullptr;
      if (c && c->is_number() && c->get<double>() >= 0 && c->get<double>() <= 1)
        info.cutoff = c->get<float>();
      const json* f = s ? member(*s, "filter") : nullptr;
      if (f && f->is_string()) {
        if (f->get<std::string>() == "nearest") info.sampler.filter = Filter::Nearest;
        if (f->get<std::string>() == "linear") info.sampler.filter = Filter::Linear;
      }
    }
    // Format and levels from the records the geometry uses.
    bool any = false, fourState = false;
    uint32_t lo = 12, hi = 0;
    uint64_t micro = 0, unknown = 0;
    for (int32_t v : gi.indices) {
      if (v < 0) {
        ++micro;
        if (v <= -3) fourState = true, ++unknown;
        continue;
      }
      const TriangleDescriptor& t = arr.descriptors[size_t(v)];
      any = true;
      fourState = fourState || t.format == 2;
      lo = std::min<uint32_t>(lo, t.subdivisionLevel), hi = std::max<uint32_t>(hi, t.subdivisionLevel);
      micro += uint64_t(1) << (2 * t.subdivisionLevel);
      unknown += arrays[size_t(micromap)].unknownPerRecord[size_t(v)];
    }
    info.format = (any && !fourState) ? Format::TwoState : Format::FourState;
    // The format somm baked with (a 2-state bake may hold only special indices, even -4 for BLEND).
    if (const json* extras = member(*x, "extras")) {
      const json* s = member(*extras, "somm");
      int64_t f = 0;
      if (s && getInt(*s, "format", f) && (f == 1 || f == 2) && !(f == 1 && any && fourState))
        info.format = Format(uint16_t(f));
    }
    info.minLevel = any ? lo : 0;
    info.maxLevel = any ? hi : 0;
    info.stats.microTriangles = micro;
    info.stats.unknownMicroTriangles = unknown;
    out.geometries.push_back(info);
  }

  // Assemble SceneMicromaps: per array, its geometries' index buffers concatenated in geometry order.
  if (arrays.empty()) arrays.emplace_back();
  out.micromaps.arrays.resize(arrays.size());
  for (size_t a = 0; a < arrays.size(); ++a) out.micromaps.arrays[a] = std::move(arrays[a].array);
  out.micromaps.geometries.resize(geo.size());
  for (size_t g = 0; g < geo.size(); ++g) {
    OmmArray& arr = out.micromaps.arrays[geo[g].array];
    GeometryMicromaps& gm = out.micromaps.geometries[g];
    gm.array = geo[g].array;
    gm.firstTriangle = uint32_t(arr.indices.size());
    gm.triangleCount = uint32_t(geo[g].indices.size());
    if (arr.indices.size() + geo[g].indices.size() > uint64_t(INT32_MAX))
      return d.fail(ErrorCode::LimitExceeded, "too many triangles share one micromap");
    arr.indices.insert(arr.indices.end(), geo[g].indices.begin(), geo[g].indices.end());
  }
  for (OmmArray& a : out.micromaps.arrays) computeUsageHistograms(a);
  return result;
}

Result<GltfMicromapsRead> parseGltfMicromaps(const std::vector<uint8_t>& bytes, bool binary,
                                             const std::string& path) {
  auto d = gltfdoc::parseDocument(bytes, binary, path);
  if (!d) return d.error();
  return readDocumentMicromaps(*d);
}

Result<GltfMicromapsRead> readGltfMicromaps(const std::string& path) {
  auto d = gltfdoc::readDocument(path);
  if (!d) return d.error();
  return readDocumentMicromaps(*d);
}

}  // namespace somm
