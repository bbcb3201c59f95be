// SPDX-License-Identifier: MIT
// Helpers for the scene tests: temporary directories, image writers (incl. a 16-bit PNG writer, which stb
// lacks), and a small glTF builder that writes .gltf (external or data-URI buffers) and .glb files.
#pragma once

#include <gtest/gtest.h>
#include <stb_image_write.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace scenetest {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("somm_scene_") + std::to_string(::getpid()) + "_" +
                       (info ? std::string(info->test_suite_name()) + "_" + info->name() : "x");
    for (char& c : name)
      if (c == '/') c = '_';
    path_ = fs::temp_directory_path() / name;
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

inline void writeFile(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
}
inline void writeBytes(const std::string& path, const std::vector<uint8_t>& b) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}
inline std::vector<uint8_t> readBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// 8-bit PNG via stb (comp 1..4, rows top to bottom).
inline void writePng8(const std::string& path, int w, int h, int comp, const std::vector<uint8_t>& px) {
  ASSERT_EQ(px.size(), size_t(w) * h * comp);
  ASSERT_TRUE(stbi_write_png(path.c_str(), w, h, comp, px.data(), w * comp));
}

inline uint32_t crc32(const uint8_t* p, size_t n, uint32_t crc = 0) {
  crc = ~crc;
  for (size_t i = 0; i < n; ++i) {
    crc ^= p[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

// A PNG of the given bit depth and colour type from raw scanlines (each row's filter byte included), with
// uncompressed deflate blocks; `chunks` (e.g. PLTE, tRNS) go between IHDR and IDAT.
inline std::vector<uint8_t> encodePngRaw(
    uint32_t w, uint32_t h, uint8_t bitDepth, uint8_t colorType, const std::vector<uint8_t>& raw,
    const std::vector<std::pair<std::string, std::vector<uint8_t>>>& chunks = {}) {
  std::vector<uint8_t> z = {0x78, 0x01};
  size_t pos = 0;
  do {
    const size_t n = std::min<size_t>(65535, raw.size() - pos);
    const bool last = pos + n == raw.size();
    z.push_back(last ? 1 : 0);
    z.push_back(uint8_t(n & 0xFF)), z.push_back(uint8_t(n >> 8));
    z.push_back(uint8_t(~n & 0xFF)), z.push_back(uint8_t((~n >> 8) & 0xFF));
    z.insert(z.end(), raw.begin() + long(pos), raw.begin() + long(pos + n));
    pos += n;
  } while (pos < raw.size());
  uint32_t a = 1, b = 0;
  for (uint8_t c : raw) a = (a + c) % 65521, b = (b + a) % 65521;
  const uint32_t adler = (b << 16) | a;
  for (int s = 24; s >= 0; s -= 8) z.push_back(uint8_t(adler >> s));

  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  auto chunk = [&](const std::string& type, const std::vector<uint8_t>& data) {
    const uint32_t n = uint32_t(data.size());
    for (int s = 24; s >= 0; s -= 8) png.push_back(uint8_t(n >> s));
    std::vector<uint8_t> td(type.begin(), type.end());
    td.insert(td.end(), data.begin(), data.end());
    png.insert(png.end(), td.begin(), td.end());
    const uint32_t crc = crc32(td.data(), td.size());
    for (int s = 24; s >= 0; s -= 8) png.push_back(uint8_t(crc >> s));
  };
  std::vector<uint8_t> ihdr;
  for (uint32_t v : {w, h})
    for (int s = 24; s >= 0; s -= 8) ihdr.push_back(uint8_t(v >> s));
  ihdr.insert(ihdr.end(), {bitDepth, colorType, 0, 0, 0});
  chunk("IHDR", ihdr);
  for (const auto& [type, data] : chunks) chunk(type, data);
  chunk("IDAT", z);
  chunk("IEND", {});
  return png;
}

// 16-bit PNG (comp 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA), uncompressed deflate blocks.
inline std::vector<uint8_t> encodePng16(uint32_t w, uint32_t h, int comp, const std::vector<uint16_t>& px) {
  static const uint8_t colorType[5] = {0, 0, 4, 2, 6};
  std::vector<uint8_t> raw;
  for (uint32_t y = 0; y < h; ++y) {
    raw.push_back(0);  // filter: none
    for (uint32_t i = 0; i < w * uint32_t(comp); ++i) {
      const uint16_t v = px[size_t(y) * w * comp + i];
      raw.push_back(uint8_t(v >> 8));
      raw.push_back(uint8_t(v & 0xFF));
    }
  }
  return encodePngRaw(w, h, 16, colorType[comp], raw);
}

inline std::vector<uint8_t> encodePng8(int w, int h, int comp, const std::vector<uint8_t>& px) {
  std::vector<uint8_t> out;
  stbi_write_png_to_func(
      [](void* ctx, void* data, int size) {
        auto* o = static_cast<std::vector<uint8_t>*>(ctx);
        o->insert(o->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
      },
      &out, w, h, comp, px.data(), w * comp);
  return out;
}

inline std::string base64(const std::vector<uint8_t>& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t v = (uint32_t(in[i]) << 16) | (uint32_t(in[i + 1]) << 8) | in[i + 2];
    out += t[v >> 18], out += t[(v >> 12) & 63], out += t[(v >> 6) & 63], out += t[v & 63];
  }
  if (i + 1 == in.size()) {
    const uint32_t v = uint32_t(in[i]) << 16;
    out += t[v >> 18], out += t[(v >> 12) & 63], out += "==";
  } else if (i + 2 == in.size()) {
    const uint32_t v = (uint32_t(in[i]) << 16) | (uint32_t(in[i + 1]) << 8);
    out += t[v >> 18], out += t[(v >> 12) & 63], out += t[(v >> 6) & 63], out += '=';
  }
  return out;
}

// Minimal glTF writer: one buffer, buffer views, accessors; the caller fills meshes/materials/... in `j`.
struct GltfBuilder {
  nlohmann::json j;
  std::vector<uint8_t> bin;

  GltfBuilder() {
    j["asset"] = {{"version", "2.0"}};
    j["buffers"] = nlohmann::json::array();
    j["bufferViews"] = nlohmann::json::array();
    j["accessors"] = nlohmann::json::array();
  }
  int view(const void* data, size_t n) {
    while (bin.size() % 4) bin.push_back(0);
    const size_t off = bin.size();
    bin.insert(bin.end(), static_cast<const uint8_t*>(data), static_cast<const uint8_t*>(data) + n);
    j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", off}, {"byteLength", n}});
    return int(j["bufferViews"].size()) - 1;
  }
  int accessor(int view, int componentType, size_t count, const std::string& type) {
    j["accessors"].push_back(
        {{"bufferView", view}, {"componentType", componentType}, {"count", count}, {"type", type}});
    return int(j["accessors"].size()) - 1;
  }
  int floats(const std::vector<float>& v, const std::string& type, int comps) {
    return accessor(view(v.data(), v.size() * 4), 5126, v.size() / size_t(comps), type);
  }
  int indices16(const std::vector<uint16_t>& v) {
    return accessor(view(v.data(), v.size() * 2), 5123, v.size(), "SCALAR");
  }
  int indices32(const std::vector<uint32_t>& v) {
    return accessor(view(v.data(), v.size() * 4), 5125, v.size(), "SCALAR");
  }
  // An image stored in the buffer (for .glb) or as a data URI.
  int imageInBuffer(const std::vector<uint8_t>& png) {
    const int v = view(png.data(), png.size());
    j["images"].push_back({{"bufferView", v}, {"mimeType", "image/png"}});
    return int(j["images"].size()) - 1;
  }
  int imageDataUri(const std::vector<uint8_t>& png) {
    j["images"].push_back({{"uri", "data:image/png;base64," + base64(png)}});
    return int(j["images"].size()) - 1;
  }
  int imageFile(const std::string& uri) {
    j["images"].push_back({{"uri", uri}});
    return int(j["images"].size()) - 1;
  }

  // .gltf with the buffer in `binName` next to it, or as a data URI when binName is empty.
  void writeGltf(const std::string& path, const std::string& binName = "") {
    nlohmann::json out = j;
    if (binName.empty()) {
      out["buffers"] = {
          {{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + base64(bin)}}};
    } else {
      out["buffers"] = {{{"byteLength", bin.size()}, {"uri", binName}}};
      writeBytes((fs::path(path).parent_path() / binName).string(), bin);
    }
    writeFile(path, out.dump(1));
  }
  void writeGlb(const std::string& path) {
    nlohmann::json out = j;
    out["buffers"] = {{{"byteLength", bin.size()}}};
    std::string js = out.dump();
    while (js.size() % 4) js += ' ';
    std::vector<uint8_t> b = bin;
    while (b.size() % 4) b.push_back(0);
    std::vector<uint8_t> glb;
    auto u32 = [&](uint32_t v) {
      for (int s = 0; s < 32; s += 8) glb.push_back(uint8_t(v >> s));
    };
    u32(0x46546C67), u32(2), u32(uint32_t(12 + 8 + js.size() + 8 + b.size()));
    u32(uint32_t(js.size())), u32(0x4E4F534A);
    glb.insert(glb.end(), js.begin(), js.end());
    u32(uint32_t(b.size())), u32(0x004E4942);
    glb.insert(glb.end(), b.begin(), b.end());
    writeBytes(path, glb);
  }
};

// A unit quad (positions, TEXCOORD_0 with uv = corner in [0,1]², indices) as mesh 0 primitive 0 with material
// 0 in node 0 of scene 0. Returns the builder; callers add the material.
inline GltfBuilder quadGltf() {
  GltfBuilder b;
  const int pos = b.floats({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, "VEC3", 3);
  const int uv = b.floats({0, 0, 1, 0, 1, 1, 0, 1}, "VEC2", 2);
  const int idx = b.indices16({0, 1, 2, 0, 2, 3});
  nlohmann::json prim = {
      {"attributes", {{"POSITION", pos}, {"TEXCOORD_0", uv}}}, {"indices", idx}, {"material", 0}};
  nlohmann::json mesh = {{"name", "quad"}, {"primitives", nlohmann::json::array({prim})}};
  b.j["meshes"] = nlohmann::json::array({mesh});
  b.j["nodes"] = {{{"mesh", 0}}};
  b.j["scenes"] = {{{"nodes", {0}}}};
  b.j["scene"] = 0;
  return b;
}

}  // namespace scenetest
