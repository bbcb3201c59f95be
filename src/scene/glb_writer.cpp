// SPDX-License-Identifier: MIT
// somm — writing a Scene as a self-contained .glb (procedural scenes on disk for CLI tests, demos and benchmarks;
// `somm bake` of an OBJ to glTF: docs/gltf.md).
#include <libdeflate.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <system_error>
#include <tuple>

#include "somm/io.h"
#include "somm/scene.h"

namespace somm {

namespace {

void put32be(std::vector<uint8_t>& v, uint32_t x) {
  for (int s = 24; s >= 0; s -= 8) v.push_back(uint8_t(x >> s));
}

// A PNG of RGBA rows of `depth` (8 or 16) bits per sample: `pixels` holds the rows one after the other, samples
// big-endian, without filter bytes. Each row gets the filter (None, Sub, Up or Paeth) whose bytes have the smallest
// sum of absolute values as signed bytes (libpng's heuristic); the zlib stream is libdeflate's (level 6).
Result<std::vector<uint8_t>> encodePng(uint32_t w, uint32_t h, uint32_t depth,
                                       const std::vector<uint8_t>& pixels) {
  const size_t bpp = depth / 2, rowBytes = size_t(w) * bpp;  // 4 samples of depth / 8 bytes
  if (pixels.size() != rowBytes * h)
    return makeError(ErrorCode::InvalidArgument, "inconsistent texture rows");
  if ((rowBytes + 1) * h > size_t(INT32_MAX))
    return makeError(ErrorCode::LimitExceeded, "texture too large to encode");
  std::vector<uint8_t> raw((rowBytes + 1) * h);
  std::vector<uint8_t> zero(rowBytes, 0), trial[4];
  for (auto& t : trial) t.resize(rowBytes);
  for (uint32_t y = 0; y < h; ++y) {
    const uint8_t* cur = pixels.data() + size_t(y) * rowBytes;
    const uint8_t* up = y ? cur - rowBytes : zero.data();
    uint64_t best = ~uint64_t(0);
    int pick = 0;
    for (int f = 0; f < 4; ++f) {
      uint8_t* out = trial[f].data();
      uint64_t sum = 0;
      for (size_t i = 0; i < rowBytes; ++i) {
        const int a = i >= bpp ? cur[i - bpp] : 0, b = up[i], c = i >= bpp ? up[i - bpp] : 0;
        int pred = 0;
        if (f == 1) {
          pred = a;
        } else if (f == 2) {
          pred = b;
        } else if (f == 3) {
          const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
          pred = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
        }
        out[i] = uint8_t(cur[i] - pred);
        sum += uint64_t(std::abs(int(int8_t(out[i]))));
      }
      if (sum < best) best = sum, pick = f;
    }
    static constexpr uint8_t kFilterType[4] = {0, 1, 2, 4};  // None, Sub, Up, Paeth
    uint8_t* row = raw.data() + size_t(y) * (rowBytes + 1);
    row[0] = kFilterType[pick];
    std::copy(trial[pick].begin(), trial[pick].end(), row + 1);
  }
  std::unique_ptr<libdeflate_compressor, decltype(&libdeflate_free_compressor)> zc(
      libdeflate_alloc_compressor(6), &libdeflate_free_compressor);
  if (!zc) return makeError(ErrorCode::LimitExceeded, "PNG compression: out of memory");
  std::vector<uint8_t> z(libdeflate_zlib_compress_bound(zc.get(), raw.size()));
  const size_t zlen = libdeflate_zlib_compress(zc.get(), raw.data(), raw.size(), z.data(), z.size());
  if (zlen == 0) return makeError(ErrorCode::IoError, "PNG compression failed");
  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  auto chunk = [&](const char* type, const uint8_t* data, size_t n) {
    put32be(png, uint32_t(n));
    const size_t start = png.size();
    png.insert(png.end(), type, type + 4);
    if (n) png.insert(png.end(), data, data + n);
    put32be(png, libdeflate_crc32(0, png.data() + start, n + 4));
  };
  std::vector<uint8_t> ihdr;
  put32be(ihdr, w);
  put32be(ihdr, h);
  ihdr.insert(ihdr.end(), {uint8_t(depth), 6, 0, 0, 0});
  chunk("IHDR", ihdr.data(), ihdr.size());
  chunk("IDAT", z.data(), zlen);
  chunk("IEND", nullptr, 0);
  return png;
}

// One axis of resampling a colour image of n texels to m: each target texel's source taps (indices, weights).
// Fewer target texels (n > m): the mean of the source texels whose centres lie in the target texel's footprint
// [x·n/m, (x + 1)·n/m) (at least one). More (n < m): bilinear at the target texel's centre, taps wrapped as the
// material's sampler wraps.
struct Taps {
  std::vector<uint32_t> first;  // m + 1 offsets into index / weight
  std::vector<uint32_t> index;
  std::vector<double> weight;
};

Taps axisTaps(uint32_t n, uint32_t m, Wrap w) {
  Taps t;
  t.first.reserve(size_t(m) + 1);
  for (uint32_t x = 0; x < m; ++x) {
    t.first.push_back(uint32_t(t.index.size()));
    if (n >= m) {
      // Source texel i's centre i + ½ in [x·n/m, (x + 1)·n/m): ⌈x·n/m − ½⌉ ≤ i < ⌈(x + 1)·n/m − ½⌉, where
      // ⌈(2xn − m) / 2m⌉ = ⌊(2xn + m − 1) / 2m⌋ in integers.
      const uint64_t lo = (2 * uint64_t(x) * n + m - 1) / (2 * uint64_t(m));
      uint64_t hi = (2 * (uint64_t(x) + 1) * n + m - 1) / (2 * uint64_t(m));
      if (hi <= lo) hi = lo + 1;
      hi = std::min<uint64_t>(hi, n);
      for (uint64_t i = lo; i < hi; ++i) {
        t.index.push_back(uint32_t(i));
        t.weight.push_back(1.0 / double(hi - lo));
      }
    } else {
      const double s = (double(x) + 0.5) * double(n) / double(m) - 0.5;
      const double f0 = std::floor(s), f = s - f0;
      t.index.push_back(wrapTexel(int64_t(f0), n, w));
      t.weight.push_back(1 - f);
      t.index.push_back(wrapTexel(int64_t(f0) + 1, n, w));
      t.weight.push_back(f);
    }
  }
  t.first.push_back(uint32_t(t.index.size()));
  return t;
}

// The colour image resampled to w × h (RGBA, alpha unused): itself when it has that size.
std::vector<uint8_t> colourAt(const ColorImage& c, uint32_t w, uint32_t h, const Sampler& s) {
  if (c.width == w && c.height == h) return c.rgba;
  const Taps tx = axisTaps(c.width, w, s.wrapS), ty = axisTaps(c.height, h, s.wrapT);
  std::vector<uint8_t> out(size_t(w) * h * 4, 255);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x)
      for (size_t k = 0; k < 3; ++k) {
        double v = 0;
        for (uint32_t b = ty.first[y]; b < ty.first[y + 1]; ++b)
          for (uint32_t a = tx.first[x]; a < tx.first[x + 1]; ++a)
            v += ty.weight[b] * tx.weight[a] *
                 double(c.rgba[(size_t(ty.index[b]) * c.width + tx.index[a]) * 4 + k]);
        out[(size_t(y) * w + x) * 4 + k] = uint8_t(std::clamp(std::lround(v), 0L, 255L));
      }
  return out;
}

// The base colour texture of a material: RGB from `c` (resampled to the alpha's size when it has another, see
// colourAt; else white), alpha from `a` (else from `c`, else opaque). 8 bits per sample when that is exact — the
// alpha's texels are 8-bit values with no factor (they read back as the same alphas), or there is no alpha texture
// — else 16 bits, alpha rounded to multiples of 1/65535.
Result<std::vector<uint8_t>> encodeBaseColor(const AlphaTexture* a, const ColorImage* c, const Sampler& s) {
  const uint32_t w = a ? a->width : c->width, h = a ? a->height : c->height;
  const std::vector<uint8_t> rgb = c ? colourAt(*c, w, h, s) : std::vector<uint8_t>();
  const bool useColor = c != nullptr;
  const bool exact8 = !a || (a->storage == AlphaStorage::UInt8 && a->scale == 1.0f);
  const size_t n = size_t(w) * h;
  if (exact8) {
    std::vector<uint8_t> px(n * 4);
    for (size_t i = 0; i < n; ++i) {
      for (size_t k = 0; k < 3; ++k) px[i * 4 + k] = useColor ? rgb[i * 4 + k] : 255;
      px[i * 4 + 3] = a ? a->alpha8[i] : useColor ? rgb[i * 4 + 3] : 255;
    }
    return encodePng(w, h, 8, px);
  }
  std::vector<uint8_t> px(n * 8);
  auto put16 = [&](size_t at, uint32_t v) {
    px[at] = uint8_t(v >> 8);
    px[at + 1] = uint8_t(v & 0xFF);
  };
  for (size_t i = 0; i < n; ++i) {
    for (size_t k = 0; k < 3; ++k) put16(i * 8 + 2 * k, useColor ? rgb[i * 4 + k] * 257u : 65535u);
    const float v = a->texel(i);
    put16(i * 8 + 6,
          std::isfinite(v) ? uint32_t(std::lround(std::clamp(double(v), 0.0, 1.0) * 65535.0)) : 0u);
  }
  return encodePng(w, h, 16, px);
}

int wrapCode(Wrap w) {
  return w == Wrap::ClampToEdge ? 33071 : w == Wrap::MirroredRepeat ? 33648 : 10497;
}

}  // namespace

Result<std::vector<uint8_t>> encodeGlb(const Scene& scene, const std::string& path) {
  using nlohmann::json;
  auto fail = [&](ErrorCode c, const std::string& what) -> Error { return makeError(c, path + ": " + what); };
  std::vector<uint8_t> bin;
  json j;
  j["asset"] = {{"version", "2.0"}, {"generator", "somm"}};
  json views = json::array(), accessors = json::array();
  auto addView = [&](const void* data, size_t n) {
    while (bin.size() % 4) bin.push_back(0);
    const size_t off = bin.size();
    bin.insert(bin.end(), static_cast<const uint8_t*>(data), static_cast<const uint8_t*>(data) + n);
    views.push_back({{"buffer", 0}, {"byteOffset", off}, {"byteLength", n}});
    return views.size() - 1;
  };

  json images = json::array(), textures = json::array(), samplers = json::array(), materials = json::array();
  // Key: the alpha and colour images, and the wraps a colour of another size than the alpha is resampled with.
  std::map<std::tuple<const void*, const void*, int, int>, size_t> imageOf;
  std::map<std::array<int, 3>, size_t> samplerOf;
  std::map<std::pair<size_t, size_t>, size_t> textureOf;
  for (const Material& m : scene.materials) {
    json jm = {{"name", m.name}, {"doubleSided", m.doubleSided}, {"alphaCutoff", m.alphaCutoff}};
    jm["alphaMode"] = m.alphaMode == AlphaMode::Mask    ? "MASK"
                      : m.alphaMode == AlphaMode::Blend ? "BLEND"
                                                        : "OPAQUE";
    json pbr = {{"metallicFactor", 0.0}};
    std::array<float, 4> factor = m.baseColorFactor;
    const AlphaTexture* a = m.alpha.get();
    const ColorImage* c = m.baseColor.get();
    if (a && (a->width == 0 || a->height == 0 || !a->consistent()))
      return fail(ErrorCode::InvalidArgument, "material '" + m.name + "' has an inconsistent alpha texture");
    if (c && (c->width == 0 || c->height == 0 || c->rgba.size() != size_t(c->width) * c->height * 4))
      c = nullptr;
    if (a || c) {
      // Materials that share their textures and sampler share one image and one texture.
      const bool resampled = a && c && (c->width != a->width || c->height != a->height);
      const auto imageKey =
          std::make_tuple(static_cast<const void*>(a), static_cast<const void*>(c),
                          resampled ? int(m.sampler.wrapS) + 1 : 0, resampled ? int(m.sampler.wrapT) + 1 : 0);
      auto img = imageOf.find(imageKey);
      if (img == imageOf.end()) {
        auto png = encodeBaseColor(a, c, m.sampler);
        if (!png.ok()) return fail(png.error().code, "material '" + m.name + "': " + png.error().message);
        images.push_back({{"bufferView", addView(png->data(), png->size())}, {"mimeType", "image/png"}});
        img = imageOf.emplace(imageKey, images.size() - 1).first;
      }
      const int mag = m.sampler.filter == Filter::Nearest ? 9728 : 9729;
      const std::array<int, 3> samplerKey{mag, wrapCode(m.sampler.wrapS), wrapCode(m.sampler.wrapT)};
      auto smp = samplerOf.find(samplerKey);
      if (smp == samplerOf.end()) {
        samplers.push_back(
            {{"magFilter", mag}, {"minFilter", mag}, {"wrapS", samplerKey[1]}, {"wrapT", samplerKey[2]}});
        smp = samplerOf.emplace(samplerKey, samplers.size() - 1).first;
      }
      const auto textureKey = std::make_pair(img->second, smp->second);
      auto tex = textureOf.find(textureKey);
      if (tex == textureOf.end()) {
        textures.push_back({{"source", img->second}, {"sampler", smp->second}});
        tex = textureOf.emplace(textureKey, textures.size() - 1).first;
      }
      pbr["baseColorTexture"] = {{"index", tex->second}};
      if (a) factor[3] = 1.0f;  // the alpha factor is already in the texture
    }
    pbr["baseColorFactor"] = {factor[0], factor[1], factor[2], factor[3]};
    jm["pbrMetallicRoughness"] = pbr;
    materials.push_back(std::move(jm));
  }

  json meshes = json::array();
  for (size_t gi = 0; gi < scene.geometries.size(); ++gi) {
    const Geometry& g = scene.geometries[gi];
    const size_t n = g.positions.size() / 3;
    if (g.positions.size() != n * 3 || g.uvs.size() != n * 2 || g.indices.size() % 3 != 0 ||
        g.material >= scene.materials.size())
      return fail(ErrorCode::InvalidArgument, "geometry " + std::to_string(gi) + " is inconsistent");
    for (uint32_t i : g.indices)
      if (i >= n)
        return fail(ErrorCode::InvalidArgument,
                    "geometry " + std::to_string(gi) + " has an index out of range");
    json attrs = json::object();
    if (n == 0) {
      // Empty geometry (e.g. a skipped primitive): one point keeps the mesh valid and the numbering intact.
      const float origin[3] = {0, 0, 0};
      accessors.push_back({{"bufferView", addView(origin, 12)},
                           {"componentType", 5126},
                           {"count", 1},
                           {"type", "VEC3"},
                           {"min", {0, 0, 0}},
                           {"max", {0, 0, 0}}});
      attrs["POSITION"] = accessors.size() - 1;
      meshes.push_back(
          {{"name", g.name},
           {"primitives", json::array({{{"attributes", attrs}, {"material", g.material}, {"mode", 0}}})}});
      continue;
    }
    std::array<float, 3> lo{0, 0, 0}, hi{0, 0, 0};
    for (size_t v = 0; v < n; ++v)
      for (int k = 0; k < 3; ++k) {
        const float x = g.positions[v * 3 + size_t(k)];
        if (!std::isfinite(x)) continue;
        lo[size_t(k)] = v == 0 ? x : std::min(lo[size_t(k)], x);
        hi[size_t(k)] = v == 0 ? x : std::max(hi[size_t(k)], x);
      }
    accessors.push_back({{"bufferView", addView(g.positions.data(), g.positions.size() * 4)},
                         {"componentType", 5126},
                         {"count", n},
                         {"type", "VEC3"},
                         {"min", lo},
                         {"max", hi}});
    attrs["POSITION"] = accessors.size() - 1;
    accessors.push_back({{"bufferView", addView(g.uvs.data(), g.uvs.size() * 4)},
                         {"componentType", 5126},
                         {"count", n},
                         {"type", "VEC2"}});
    attrs["TEXCOORD_0"] = accessors.size() - 1;
    json prim = {{"attributes", attrs}, {"material", g.material}, {"mode", 4}};
    if (!g.indices.empty()) {
      accessors.push_back({{"bufferView", addView(g.indices.data(), g.indices.size() * 4)},
                           {"componentType", 5125},
                           {"count", g.indices.size()},
                           {"type", "SCALAR"}});
      prim["indices"] = accessors.size() - 1;
    }
    const std::string slashTail = "/0";
    std::string name = g.name;
    if (name.size() >= 2 && name.compare(name.size() - 2, 2, slashTail) == 0) name.resize(name.size() - 2);
    meshes.push_back({{"name", name}, {"primitives", json::array({prim})}});
  }

  json nodes = json::array(), roots = json::array();
  for (const Instance& inst : scene.instances) {
    if (inst.geometry >= scene.geometries.size())
      return fail(ErrorCode::InvalidArgument, "an instance refers to a missing geometry");
    nodes.push_back({{"mesh", inst.geometry}, {"matrix", inst.transform}});
    roots.push_back(nodes.size() - 1);
  }
  if (scene.camera) {
    const Camera& c = *scene.camera;
    auto norm = [](std::array<double, 3> v) {
      const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      if (l > 0) v = {v[0] / l, v[1] / l, v[2] / l};
      return v;
    };
    auto cross = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
      return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                   a[0] * b[1] - a[1] * b[0]};
    };
    const auto z = norm(
        {double(c.eye[0]) - c.target[0], double(c.eye[1]) - c.target[1], double(c.eye[2]) - c.target[2]});
    const auto x = norm(cross({c.up[0], c.up[1], c.up[2]}, z));
    const auto y = cross(z, x);
    nodes.push_back(
        {{"camera", 0},
         {"matrix",
          {x[0], x[1], x[2], 0, y[0], y[1], y[2], 0, z[0], z[1], z[2], 0, c.eye[0], c.eye[1], c.eye[2], 1}}});
    roots.push_back(nodes.size() - 1);
    j["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", c.yfovRadians}, {"znear", 0.01}}}}};
  }
  if (!materials.empty()) j["materials"] = materials;
  if (!meshes.empty()) j["meshes"] = meshes;
  if (!nodes.empty()) j["nodes"] = nodes;
  j["scenes"] = {{{"nodes", roots}}};
  j["scene"] = 0;
  if (!images.empty()) j["images"] = images, j["textures"] = textures, j["samplers"] = samplers;
  if (!accessors.empty()) j["accessors"] = accessors;
  if (!views.empty()) j["bufferViews"] = views;
  while (bin.size() % 4) bin.push_back(0);
  j["buffers"] = {{{"byteLength", bin.size()}}};

  std::string text = j.dump();
  while (text.size() % 4) text += ' ';
  const uint64_t total = 12 + 8 + text.size() + 8 + bin.size();
  if (total > 0xFFFFFFFFu) return fail(ErrorCode::LimitExceeded, "scene too large for a .glb (4 GiB)");
  std::vector<uint8_t> glb;
  auto le32 = [&](uint32_t v) {
    for (int s = 0; s < 32; s += 8) glb.push_back(uint8_t(v >> s));
  };
  le32(0x46546C67), le32(2), le32(uint32_t(total));
  le32(uint32_t(text.size())), le32(0x4E4F534A);
  glb.insert(glb.end(), text.begin(), text.end());
  le32(uint32_t(bin.size())), le32(0x004E4942);
  glb.insert(glb.end(), bin.begin(), bin.end());
  return glb;
}

Status writeGlb(const Scene& scene, const std::string& path) {
  auto encoded = encodeGlb(scene, path);
  if (!encoded) return encoded.error();
  return writeFileAtomically(path, encoded->data(), encoded->size());
}

}  // namespace somm
