// SPDX-License-Identifier: MIT
// somm — writing a baked scene as glTF 2.0 with EXT_mesh_opacity_micromap (docs/gltf.md).
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "document.h"
#include "gltf_internal.h"
#include "somm/gltf.h"
#include "somm/io.h"

namespace somm {

using gltfdoc::Document;
using gltfdoc::getInt;
using gltfdoc::json;

namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool endsWith(const std::string& s, const char* tail) {
  const size_t n = std::strlen(tail);
  return s.size() >= n && s.compare(s.size() - n, n, tail) == 0;
}

// The shortest decimal that reads back as the same float (so 0.3f is written 0.3).
double floatJson(float f) {
  char buf[32];
  for (int p = 6; p <= 9; ++p) {
    std::snprintf(buf, sizeof buf, "%.*g", p, double(f));
    if (std::strtof(buf, nullptr) == f) break;
  }
  return std::strtod(buf, nullptr);
}

fs::path absoluteNormal(const fs::path& p) {
  std::error_code ec;
  fs::path a = fs::absolute(p, ec);
  if (ec) a = p;
  return a.lexically_normal();
}

// Writes several files atomically: every temporary file written and fsynced first, then renamed in order (so a
// failure before the renames leaves every existing output untouched).
Status writeFilesAtomically(const std::vector<std::pair<std::string, const std::vector<uint8_t>*>>& files) {
  std::vector<std::string> temps;
  auto cleanup = [&] {
    for (const std::string& t : temps) ::unlink(t.c_str());
  };
  const mode_t mask = ::umask(0);
  ::umask(mask);
  for (const auto& [path, bytes] : files) {
    // An existing output that is not a regular file (a directory, a FIFO, a device) is refused, never replaced.
    if (Status s = checkOutputPath(path, {}); !s) {
      cleanup();
      return makeError(ErrorCode::IoError, s.error().message);
    }
    std::string tmp = path + ".tmp.XXXXXX";
    const int fd = ::mkstemp(tmp.data());
    if (fd < 0) {
      const std::string msg = path + ": cannot create a temporary file: " + std::strerror(errno);
      cleanup();
      return makeError(ErrorCode::IoError, msg);
    }
    temps.push_back(tmp);
    bool good = ::fchmod(fd, 0666 & ~mask) == 0;
    size_t done = 0;
    while (good && done < bytes->size()) {
      const ssize_t w = ::write(fd, bytes->data() + done, bytes->size() - done);
      if (w < 0 && errno == EINTR) continue;
      if (w < 0)
        good = false;
      else
        done += size_t(w);
    }
    good = good && ::fsync(fd) == 0;
    const std::string why = std::strerror(errno);
    good = (::close(fd) == 0) && good;
    if (!good) {
      cleanup();
      return makeError(ErrorCode::IoError, path + ": write failed: " + why);
    }
  }
  for (size_t i = 0; i < files.size(); ++i) {
    if (::rename(temps[i].c_str(), files[i].first.c_str()) != 0) {
      const std::string msg =
          files[i].first + ": cannot rename the temporary file into place: " + std::strerror(errno);
      for (size_t k = i; k < temps.size(); ++k) ::unlink(temps[k].c_str());
      return makeError(ErrorCode::IoError, msg);
    }
  }
  const fs::path dir = fs::path(files.front().first).parent_path();
  const int dfd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dfd >= 0) {
    (void)::fsync(dfd);
    ::close(dfd);
  }
  return Ok{};
}

uint64_t regionBytes(uint32_t level, uint32_t format) {
  return ((uint64_t(1) << (2 * level)) * (format == 1 ? 1 : 2) + 7) / 8;
}

// The array's records and data with every region inside the data and no two overlapping (repacked in record order
// when the input shares or overlaps regions); an array without records gets one unused level-0 record, because the
// draft's usage arrays and glTF buffer views cannot be empty.
void layoutArray(const OmmArray& a, std::vector<TriangleDescriptor>& records, std::vector<uint8_t>& data) {
  records = a.descriptors;
  data = a.data;
  if (records.empty()) {
    records.push_back(TriangleDescriptor{0, 0, 1});
    data.assign(1, 0);
    return;
  }
  struct R {
    uint64_t b, e;
  };
  std::vector<R> rs;
  bool good = true;
  for (const TriangleDescriptor& d : records) {
    const uint64_t n = regionBytes(d.subdivisionLevel, d.format);
    if (d.subdivisionLevel > 12 || (d.format != 1 && d.format != 2) || d.dataOffset + n > data.size())
      good = false;
    rs.push_back(R{d.dataOffset, d.dataOffset + n});
  }
  std::sort(rs.begin(), rs.end(), [](const R& x, const R& y) { return x.b < y.b; });
  for (size_t i = 1; good && i < rs.size(); ++i) good = rs[i].b >= rs[i - 1].e;
  if (good) return;
  std::vector<uint8_t> packed;
  for (TriangleDescriptor& d : records) {
    const uint64_t n = regionBytes(d.subdivisionLevel, d.format);
    const size_t at = packed.size();
    packed.resize(at + n, 0);
    if (d.dataOffset + n <= a.data.size()) std::memcpy(packed.data() + at, a.data.data() + d.dataOffset, n);
    d.dataOffset = uint32_t(at);
  }
  data = std::move(packed);
}

void putLE(std::vector<uint8_t>& v, uint64_t x, int bytes) {
  for (int i = 0; i < bytes; ++i) v.push_back(uint8_t(x >> (8 * i)));
}

}  // namespace

bool isGltfPath(const std::string& path) {
  const std::string l = lower(path);
  return endsWith(l, ".gltf") || endsWith(l, ".glb");
}

Status writeGltfMicromaps(const std::string& outPath, const std::string& scenePath, const Scene& scene,
                          const SceneMicromaps& micromaps, const std::vector<GeometryInfo>& info,
                          const GltfWriteOptions& options) {
  auto fail = [&](ErrorCode c, const std::string& what) -> Error {
    return makeError(c, outPath + ": " + what);
  };
  const std::string ext = kGltfMicromapExtension;
  const bool outBinary = endsWith(lower(outPath), ".glb");
  if (!outBinary && !endsWith(lower(outPath), ".gltf"))
    return fail(ErrorCode::InvalidArgument, "the output must end in .glb or .gltf");
  const size_t G = scene.geometries.size();
  if (micromaps.geometries.size() != G || info.size() != G)
    return fail(ErrorCode::InvalidArgument, "micromaps for " + std::to_string(micromaps.geometries.size()) +
                                                " geometries, the scene has " + std::to_string(G));
  for (size_t g = 0; g < G; ++g)
    if (micromaps.geometries[g].triangleCount != scene.geometries[g].triangleCount() ||
        micromaps.geometries[g].array >= micromaps.arrays.size() ||
        uint64_t(micromaps.geometries[g].firstTriangle) + micromaps.geometries[g].triangleCount >
            micromaps.arrays[micromaps.geometries[g].array].indices.size())
      return fail(ErrorCode::InvalidArgument,
                  "the micromaps of geometry " + std::to_string(g) + " do not match its triangles");

  // ---- the document to extend ----
  const bool gltfInput = isGltfPath(scenePath);
  Result<Document> doc = makeError(ErrorCode::InvalidArgument, "");
  if (gltfInput) {
    doc = gltfdoc::readDocument(scenePath);
  } else {
    // OBJ (or another non-glTF scene): writeGlb's scene with the cutoff and filter the bake used.
    Scene copy = scene;
    for (size_t g = 0; g < G; ++g) {
      Material& m = copy.materials[scene.geometries[g].material];
      if (m.alphaTested()) {
        m.alphaCutoff = info[g].cutoff;
        m.sampler.filter = info[g].sampler.filter;
      }
    }
    auto bytes = encodeGlb(copy, outPath);
    if (!bytes) return bytes.error();
    doc = gltfdoc::parseDocument(*bytes, true, outPath);
  }
  if (!doc) return doc.error();
  Document& d = *doc;
  json& root = d.root;
  auto prims = gltfint::primitives(d);
  if (!prims) return prims.error();
  if (prims->size() != G)
    return fail(ErrorCode::InvalidArgument, scenePath + " has " + std::to_string(prims->size()) +
                                                " primitives, the scene " + std::to_string(G) +
                                                " geometries");
  for (size_t g = 0; g < G; ++g)
    if ((*prims)[g].triangles != scene.geometries[g].triangleCount() && (*prims)[g].mode == 4)
      return fail(ErrorCode::InvalidArgument, scenePath + ": primitive of geometry " + std::to_string(g) +
                                                  " has a different triangle count than the scene");

  // ---- drop an existing EXT_mesh_opacity_micromap (a re-bake replaces it) ----
  if (root.contains("extensions") && root["extensions"].is_object()) {
    root["extensions"].erase(ext);
    if (root["extensions"].empty()) root.erase("extensions");
  }
  for (const auto& r : *prims) {
    json& p = root["meshes"][r.mesh]["primitives"][r.primitive];
    if (p.contains("extensions") && p["extensions"].is_object()) {
      p["extensions"].erase(ext);
      if (p["extensions"].empty()) p.erase("extensions");
    }
  }
  if (root.contains("extensionsRequired") && root["extensionsRequired"].is_array()) {
    json& req = root["extensionsRequired"];
    for (size_t i = req.size(); i-- > 0;)
      if (req[i].is_string() && req[i].get<std::string>() == ext) req.erase(i);
    if (req.empty()) root.erase("extensionsRequired");
  }

  // ---- the buffer that receives the new data, and URIs relative to the output ----
  if (!root.contains("buffers") || !root["buffers"].is_array()) root["buffers"] = json::array();
  if (!root.contains("bufferViews") || !root["bufferViews"].is_array()) root["bufferViews"] = json::array();
  if (!root.contains("accessors") || !root["accessors"].is_array()) root["accessors"] = json::array();
  json& buffers = root["buffers"];
  const fs::path inDir = absoluteNormal(fs::path(d.path)).parent_path();
  const fs::path outAbs = absoluteNormal(fs::path(outPath));
  const fs::path outDir = outAbs.parent_path();
  fs::path binPath = outAbs;
  binPath.replace_extension(".bin");
  const std::string binUri = gltfdoc::percentEncodePath(binPath.filename().string());
  auto resolved = [&](const std::string& uri) {
    return (inDir / fs::path(gltfdoc::percentDecode(uri))).lexically_normal();
  };
  // The .bin written next to a .gltf must not be one of the input's files (its buffers, images, or the scene file
  // itself): `bake a.gltf -o out.gltf`, with a.gltf's geometry in out.bin, rewrote out.bin and left a.gltf
  // broken. Writing back into the input itself (outPath = the scene) keeps that buffer as the carrier.
  if (!outBinary && gltfInput) {
    struct stat so, si;
    const bool inPlace = ::stat(outPath.c_str(), &so) == 0 && ::stat(scenePath.c_str(), &si) == 0 &&
                         so.st_dev == si.st_dev && so.st_ino == si.st_ino;
    if (!inPlace) {
      std::vector<std::string> inputs{scenePath};
      for (const char* kind : {"buffers", "images"}) {
        if (!root.contains(kind) || !root[kind].is_array()) continue;
        for (const json& o : root[kind]) {
          const json* u = gltfint::member(o, "uri");
          if (u && u->is_string() && !gltfdoc::isDataUri(u->get<std::string>()) &&
              gltfdoc::isRelativeUri(u->get<std::string>()))
            inputs.push_back((inDir / fs::path(gltfdoc::percentDecode(u->get<std::string>()))).string());
        }
      }
      for (const std::string& in : inputs)
        if (absoluteNormal(fs::path(in)) == binPath)
          return fail(ErrorCode::InvalidArgument,
                      "its buffer " + escapeName(binPath.string()) +
                          " is a file of the input scene; refusing to overwrite it");
      if (Status s = checkOutputPath(binPath.string(), inputs); !s)
        return fail(ErrorCode::InvalidArgument, "its buffer " + s.error().message);
    }
  }
  long carrier = -1;
  if (outBinary) {
    if (!buffers.empty()) carrier = 0;
  } else {
    if (!buffers.empty() && buffers[0].is_object() && !buffers[0].contains("uri")) carrier = 0;
    for (size_t i = 0; carrier < 0 && i < buffers.size(); ++i) {
      const json* u = gltfint::member(buffers[i], "uri");
      if (u && u->is_string() && gltfdoc::isRelativeUri(u->get<std::string>()) &&
          resolved(u->get<std::string>()) == binPath)
        carrier = long(i);
    }
  }
  std::vector<uint8_t> bin;
  if (carrier >= 0) {
    auto b = d.buffer(size_t(carrier));
    if (!b) return b.error();
    bin = **b;
  }
  auto rewrite = [&](json& o) {
    const json* u = gltfint::member(o, "uri");
    if (!u || !u->is_string()) return;
    const std::string uri = u->get<std::string>();
    if (gltfdoc::isDataUri(uri) || !gltfdoc::isRelativeUri(uri)) return;
    const fs::path rel = resolved(uri).lexically_relative(outDir);
    if (!rel.empty()) o["uri"] = gltfdoc::percentEncodePath(rel.generic_string());
  };
  for (size_t i = 0; i < buffers.size(); ++i)
    if (long(i) != carrier) rewrite(buffers[i]);
  if (root.contains("images") && root["images"].is_array())
    for (json& im : root["images"]) rewrite(im);
  if (carrier < 0) {
    carrier = long(buffers.size());
    buffers.push_back(json::object());
  }
  if (outBinary)
    buffers[size_t(carrier)].erase("uri");
  else
    buffers[size_t(carrier)]["uri"] = binUri;

  json& views = root["bufferViews"];
  json& accessors = root["accessors"];
  auto addView = [&](const std::vector<uint8_t>& bytes, size_t align) -> size_t {
    while (bin.size() % align) bin.push_back(0);
    json v = {{"buffer", carrier}, {"byteOffset", bin.size()}, {"byteLength", bytes.size()}};
    bin.insert(bin.end(), bytes.begin(), bytes.end());
    views.push_back(std::move(v));
    return views.size() - 1;
  };

  // ---- root micromaps: one per array ----
  json list = json::array();
  for (size_t a = 0; a < micromaps.arrays.size(); ++a) {
    std::vector<TriangleDescriptor> records;
    std::vector<uint8_t> data;
    layoutArray(micromaps.arrays[a], records, data);
    std::vector<uint8_t> recBytes;
    for (const TriangleDescriptor& t : records) {
      putLE(recBytes, t.dataOffset, 4);
      putLE(recBytes, t.subdivisionLevel, 2);
      putLE(recBytes, t.format, 2);
    }
    const UsageHistograms h = countUsage(records, {});
    json counts = json::array(), levels = json::array(), formats = json::array();
    for (const UsageCount& u : h.micromaps) {
      counts.push_back(u.count);
      levels.push_back(u.subdivisionLevel);
      formats.push_back(u.format);
    }
    const size_t dv = addView(data, 8);
    const size_t tv = addView(recBytes, 8);
    json m = {{"data", dv},
              {"triangles", tv},
              {"usageCounts", counts},
              {"usageLevels", levels},
              {"usageFormats", formats}};
    if (a == 0 && (!options.toolVersion.empty() || !options.bakeOptions.empty())) {
      json bo = json::array();  // [key, value] pairs, in order
      for (const auto& [k, v] : options.bakeOptions) bo.push_back({k, v});
      m["extras"] = {
          {"somm", {{"tool", options.toolVersion}, {"source", options.sourcePath}, {"bakeOptions", bo}}}};
    }
    list.push_back(std::move(m));
  }
  if (!root.contains("extensions") || !root["extensions"].is_object()) root["extensions"] = json::object();
  root["extensions"][ext] = {{"micromaps", list}};

  // ---- per primitive ----
  json* materials = root.contains("materials") && root["materials"].is_array() ? &root["materials"] : nullptr;
  for (size_t g = 0; g < G; ++g) {
    const gltfint::PrimitiveRef& r = (*prims)[g];
    const uint32_t n = micromaps.geometries[g].triangleCount;
    if (r.mode != 4 || n == 0) continue;
    const int32_t* idx = micromaps.indices(uint32_t(g));
    int64_t lo = INT64_MAX, hi = -1;
    bool identity = true;
    for (uint32_t t = 0; t < n; ++t)
      if (idx[t] >= 0) lo = std::min<int64_t>(lo, idx[t]), hi = std::max<int64_t>(hi, idx[t]);
    const int64_t base = hi >= 0 ? lo : 0;
    for (uint32_t t = 0; t < n && identity; ++t) identity = idx[t] >= 0 && int64_t(idx[t]) == base + t;
    // An array without records was given one unused record: its triangles are all special indices anyway.
    json x = {{"micromap", micromaps.geometries[g].array}};
    if (base > 0) x["micromapBaseTriangle"] = base;
    if (!identity) {
      const int64_t range = hi - base;  // largest non-special value after rebasing
      const int size = range <= 0xFB ? 1 : range <= 0xFFFB ? 2 : 4;
      std::vector<uint8_t> bytes;
      bytes.reserve(size_t(n) * size_t(size));
      for (uint32_t t = 0; t < n; ++t) {
        const int64_t v = idx[t] < 0 ? int64_t(idx[t]) : int64_t(idx[t]) - base;
        putLE(bytes, uint64_t(v), size);  // two's complement for the special indices
      }
      const size_t view = addView(bytes, 4);
      accessors.push_back({{"bufferView", view},
                           {"componentType", size == 1   ? 5121
                                             : size == 2 ? 5123
                                                         : 5125},
                           {"count", n},
                           {"type", "SCALAR"}});
      x["micromapIndices"] = accessors.size() - 1;
    }
    x["extras"] = {{"somm",
                    {{"cutoff", floatJson(info[g].cutoff)},
                     {"format", int(info[g].format)},
                     {"filter", info[g].sampler.filter == Filter::Nearest ? "nearest" : "linear"}}}};
    json& p = root["meshes"][r.mesh]["primitives"][r.primitive];
    if (!p.contains("extensions") || !p["extensions"].is_object()) p["extensions"] = json::object();
    p["extensions"][ext] = std::move(x);
    // A MASK material carries the cutoff the micromaps were baked with.
    if (materials && r.material >= 0 && size_t(r.material) < materials->size()) {
      json& jm = (*materials)[size_t(r.material)];
      const json* mode = gltfint::member(jm, "alphaMode");
      const json* c = gltfint::member(jm, "alphaCutoff");
      const float current = c && c->is_number() ? c->get<float>() : 0.5f;
      if (mode && mode->is_string() && mode->get<std::string>() == "MASK" && current != info[g].cutoff)
        jm["alphaCutoff"] = floatJson(info[g].cutoff);
    }
  }
  if (views.empty()) root.erase("bufferViews");
  if (accessors.empty()) root.erase("accessors");
  while (bin.size() % 4) bin.push_back(0);
  buffers[size_t(carrier)]["byteLength"] = bin.size();

  // extensionsUsed lists it; extensionsRequired never does.
  if (!root.contains("extensionsUsed") || !root["extensionsUsed"].is_array())
    root["extensionsUsed"] = json::array();
  bool listed = false;
  for (const json& u : root["extensionsUsed"])
    listed = listed || (u.is_string() && u.get<std::string>() == ext);
  if (!listed) root["extensionsUsed"].push_back(ext);

  // ---- serialise ----
  std::string text = root.dump(outBinary ? -1 : 1, ' ', false, json::error_handler_t::replace);
  if (outBinary) {
    while (text.size() % 4) text += ' ';
    const uint64_t total = 12 + 8 + text.size() + 8 + bin.size();
    if (total > 0xFFFFFFFFu) return fail(ErrorCode::LimitExceeded, "too large for a .glb (4 GiB)");
    std::vector<uint8_t> glb;
    glb.reserve(size_t(total));
    putLE(glb, 0x46546C67u, 4), putLE(glb, 2, 4), putLE(glb, total, 4);
    putLE(glb, text.size(), 4), putLE(glb, 0x4E4F534Au, 4);
    glb.insert(glb.end(), text.begin(), text.end());
    putLE(glb, bin.size(), 4), putLE(glb, 0x004E4942u, 4);
    glb.insert(glb.end(), bin.begin(), bin.end());
    return writeFilesAtomically({{outPath, &glb}});
  }
  text += '\n';
  const std::vector<uint8_t> textBytes(text.begin(), text.end());
  return writeFilesAtomically({{binPath.string(), &bin}, {outPath, &textBytes}});
}

}  // namespace somm
