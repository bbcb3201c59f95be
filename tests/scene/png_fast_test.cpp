// SPDX-License-Identifier: MIT
// The PNG fast path (decodePngFast, pngUnfilter) against stb_image as the oracle (decodeImage without the fast path):
// generated PNGs of every colour type it takes, every filter type and odd sizes, split and empty IDAT chunks, palettes
// short and long with and without tRNS; the inputs it must leave to stb; the bundled textures and, when ../shared is
// present, every real PNG there.
#include <gtest/gtest.h>
#include <stb_image.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "scene/image_io.h"

extern "C" unsigned char* stbi_zlib_compress(unsigned char* data, int data_len, int* out_len, int quality);

namespace {

using Bytes = std::vector<uint8_t>;

void put32(Bytes& b, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) b.push_back(uint8_t(v >> s));
}

void chunk(Bytes& png, const char* type, const Bytes& data) {
  put32(png, uint32_t(data.size()));
  png.insert(png.end(), type, type + 4);
  png.insert(png.end(), data.begin(), data.end());
  put32(png, 0);  // CRC: neither decoder checks it
}

uint32_t adler32(const Bytes& d) {
  uint32_t a = 1, b = 0;
  for (uint8_t v : d) {
    a = (a + v) % 65521;
    b = (b + a) % 65521;
  }
  return b << 16 | a;
}

// A zlib stream of stored (uncompressed) blocks of at most `block` bytes each.
Bytes zlibStored(const Bytes& raw, size_t block = 65535) {
  Bytes z = {0x78, 0x01};
  size_t i = 0;
  do {
    const size_t n = std::min(block, raw.size() - i);
    z.push_back(i + n == raw.size() ? 1 : 0);
    z.push_back(uint8_t(n));
    z.push_back(uint8_t(n >> 8));
    z.push_back(uint8_t(~n));
    z.push_back(uint8_t(~n >> 8));
    z.insert(z.end(), raw.begin() + long(i), raw.begin() + long(i + n));
    i += n;
  } while (i < raw.size());
  put32(z, adler32(raw));
  return z;
}

Bytes zlibStb(Bytes raw) {
  int len = 0;
  unsigned char* p = stbi_zlib_compress(raw.data(), int(raw.size()), &len, 8);
  Bytes z(p, p + len);
  std::free(p);
  return z;
}

// Filters `pixels` (rows of w·ch bytes) with the given per-row filter types (PNG spec 9), forward.
Bytes filterRows(const Bytes& pixels, uint32_t w, uint32_t h, uint32_t ch, const std::vector<int>& filters) {
  const size_t rb = size_t(w) * ch;
  Bytes out;
  for (uint32_t y = 0; y < h; ++y) {
    const int f = filters[y];
    out.push_back(uint8_t(f));
    for (size_t x = 0; x < rb; ++x) {
      const int v = pixels[y * rb + x];
      const int a = x >= ch ? pixels[y * rb + x - ch] : 0;
      const int b = y > 0 ? pixels[(y - 1) * rb + x] : 0;
      const int c = y > 0 && x >= ch ? pixels[(y - 1) * rb + x - ch] : 0;
      int pred = 0;
      if (f == 1) pred = a;
      if (f == 2) pred = b;
      if (f == 3) pred = (a + b) >> 1;
      if (f == 4) {
        const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
        pred = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      out.push_back(uint8_t(v - pred));
    }
  }
  return out;
}

Bytes ihdr(uint32_t w, uint32_t h, uint8_t depth, uint8_t colour, uint8_t interlace = 0) {
  Bytes d;
  put32(d, w);
  put32(d, h);
  d.insert(d.end(), {depth, colour, 0, 0, interlace});
  return d;
}

// A PNG with the zlib stream z split into IDAT chunks of `split` bytes (an empty IDAT and a tEXt chunk among them).
Bytes makePng(const Bytes& header, const Bytes& z, size_t split,
              const std::vector<std::pair<std::string, Bytes>>& extra = {}) {
  Bytes png = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  chunk(png, "IHDR", header);
  for (const auto& [type, data] : extra) chunk(png, type.c_str(), data);
  chunk(png, "tEXt", Bytes{'k', 0, 'v'});
  for (size_t i = 0; i < z.size(); i += split) {
    chunk(png, "IDAT", Bytes(z.begin() + long(i), z.begin() + long(std::min(z.size(), i + split))));
    if (i == 0) chunk(png, "IDAT", {});
  }
  chunk(png, "IEND", {});
  return png;
}

struct StbImage {
  int w = 0, h = 0, c = 0;
  Bytes px;
  bool ok = false;
};

StbImage stbDecode(const Bytes& png) {
  StbImage s;
  unsigned char* p = stbi_load_from_memory(png.data(), int(png.size()), &s.w, &s.h, &s.c, 0);
  if (!p) return s;
  s.px.assign(p, p + size_t(s.w) * s.h * s.c);
  stbi_image_free(p);
  s.ok = true;
  return s;
}

Bytes samples(const somm::detail::RawImage& img) {
  return Bytes(img.px8(), img.px8() + img.sampleCount());
}

// decodePngFast decodes `png` and gives what decodeImage gets from stb_image (stb with the palette padded to 256
// entries; for the other colour types that is stb's own result, checked too).
void expectFastEqualsStb(const Bytes& png, const std::string& what) {
  somm::detail::RawImage img;
  ASSERT_TRUE(somm::detail::decodePngFast(png.data(), png.size(), img)) << what;
  const auto oracle =
      somm::detail::decodeImage(png.data(), png.size(), somm::defaultLimits(), nullptr, false);
  ASSERT_TRUE(oracle.ok()) << what;
  EXPECT_EQ(img.width, oracle->width) << what;
  EXPECT_EQ(img.height, oracle->height) << what;
  EXPECT_EQ(img.channels, oracle->channels) << what;
  EXPECT_FALSE(img.sixteenBit) << what;
  EXPECT_TRUE(samples(img) == samples(*oracle)) << what;
  if (png.size() > 25 && png[25] != 3) {
    const StbImage s = stbDecode(png);
    ASSERT_TRUE(s.ok) << what;
    EXPECT_EQ(img.channels, uint32_t(s.c)) << what;
    EXPECT_TRUE(samples(img) == s.px) << what;
  }
}

Bytes readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return Bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

TEST(PngFast, GeneratedImagesEqualStbAndTheSource) {
  std::mt19937 rng(29);
  int cases = 0;
  for (uint8_t colour : {0, 2, 4, 6})
    for (uint32_t w : {1u, 2u, 3u, 5u, 16u, 17u, 33u})
      for (uint32_t h : {1u, 2u, 7u}) {
        const uint32_t ch = (colour & 2 ? 3u : 1u) + (colour & 4 ? 1u : 0u);
        Bytes pixels(size_t(w) * h * ch);
        // Half random, half from 3 values (the Paeth predictor's ties occur).
        for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = uint8_t(cases % 2 ? rng() : (rng() % 3) * 127);
        std::vector<int> filters(h);
        for (uint32_t y = 0; y < h; ++y) filters[y] = int((y + w + colour) % 5);
        const Bytes raw = filterRows(pixels, w, h, ch, filters);
        for (int zk = 0; zk < 2; ++zk) {
          const Bytes z = zk ? zlibStb(raw) : zlibStored(raw, 1 + rng() % 40);
          const Bytes png = makePng(ihdr(w, h, 8, colour), z, 1 + rng() % 23);
          const std::string what = "colour " + std::to_string(colour) + " " + std::to_string(w) + "x" +
                                   std::to_string(h) + (zk ? " stb zlib" : " stored");
          expectFastEqualsStb(png, what);
          somm::detail::RawImage img;
          ASSERT_TRUE(somm::detail::decodePngFast(png.data(), png.size(), img));
          EXPECT_TRUE(samples(img) == pixels) << what;
          ++cases;
        }
      }
  EXPECT_EQ(cases, 4 * 7 * 3 * 2);
}

TEST(PngFast, PaletteImagesEqualStbWithThePaddedPalette) {
  // 8-bit palette images: PLTE of 1, 7 or 256 entries (indices past it read black), no tRNS or tRNS of 0, 3 or 200
  // alphas (longer than a 7-entry PLTE: decodeImage pads the palette first, so stb accepts it too).
  std::mt19937 rng(3);
  int cases = 0;
  for (uint32_t entries : {1u, 7u, 256u})
    for (int trns : {-1, 0, 3, 200}) {
      const uint32_t w = 13, h = 6;
      Bytes plte(entries * 3), alphas(trns > 0 ? size_t(trns) : 0);
      for (auto& v : plte) v = uint8_t(rng());
      for (auto& v : alphas) v = uint8_t(rng());
      Bytes idx(size_t(w) * h);
      for (auto& v : idx) v = uint8_t(rng() % (entries + 3));
      std::vector<int> filters(h);
      for (uint32_t y = 0; y < h; ++y) filters[y] = int(y % 5);
      std::vector<std::pair<std::string, Bytes>> extra = {{"PLTE", plte}};
      if (trns >= 0) extra.push_back({"tRNS", alphas});
      const Bytes png = makePng(ihdr(w, h, 8, 3), zlibStb(filterRows(idx, w, h, 1, filters)), 9, extra);
      const std::string what = std::to_string(entries) + " entries, tRNS " + std::to_string(trns);
      expectFastEqualsStb(png, what);
      somm::detail::RawImage img;
      ASSERT_TRUE(somm::detail::decodePngFast(png.data(), png.size(), img));
      const uint32_t ch = trns >= 0 ? 4u : 3u;
      ASSERT_EQ(img.channels, ch) << what;
      Bytes expected;
      for (uint8_t i : idx) {
        for (uint32_t c = 0; c < 3; ++c) expected.push_back(i < entries ? plte[3 * i + c] : 0);
        if (ch == 4) expected.push_back(i < alphas.size() ? alphas[i] : 255);
      }
      EXPECT_TRUE(samples(img) == expected) << what;
      ++cases;
    }
  EXPECT_EQ(cases, 12);
}

TEST(PngFast, EveryFilterOnRgbaRowsEqualsScalar) {
  // The SSE2 unfilter of 4-byte pixels and the scalar one against the source, every filter type on every row
  // position; pixels from small alphabets, so the Paeth predictor's ties (pa = pb, pa = pc, pb = pc) all occur.
  std::mt19937 rng(7);
  for (uint32_t w : {1u, 3u, 4u, 5u, 64u, 129u})
    for (int alphabet : {3, 5, 256}) {
      const uint32_t h = 15;
      Bytes pixels(size_t(w) * 4 * h);
      for (auto& v : pixels) v = uint8_t((rng() % unsigned(alphabet)) * (alphabet == 3 ? 127 : 1));
      std::vector<int> filters(h);
      for (uint32_t y = 0; y < h; ++y) filters[y] = int(y % 5);
      const Bytes raw = filterRows(pixels, w, h, 4, filters);
      Bytes a = raw, b = raw;
      ASSERT_TRUE(somm::detail::pngUnfilter(a.data(), w, h, 4, true));
      ASSERT_TRUE(somm::detail::pngUnfilter(b.data(), w, h, 4, false));
      a.resize(pixels.size());
      b.resize(pixels.size());
      EXPECT_TRUE(a == pixels) << w << " " << alphabet;
      EXPECT_TRUE(b == pixels) << w << " " << alphabet;
    }
  Bytes bad = {5, 1, 2, 3, 4};
  EXPECT_FALSE(somm::detail::pngUnfilter(bad.data(), 1, 1, 4, true));
}

TEST(PngFast, LeavesEverythingElseToStb) {
  const uint32_t w = 6, h = 3;
  Bytes pixels(w * h * 4);
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = uint8_t(i * 37);
  const Bytes raw = filterRows(pixels, w, h, 4, {0, 4, 1});
  const Bytes z = zlibStored(raw);
  expectFastEqualsStb(makePng(ihdr(w, h, 8, 6), z, 1000), "baseline");
  // Each input: the fast path declines, and decodeImage gives exactly what stb gives (or fails where stb fails).
  struct Case {
    std::string what;
    Bytes png;
  };
  Bytes zExtra = raw;
  zExtra.insert(zExtra.end(), {1, 2, 3});  // more data than the image (stb accepts and ignores it)
  Bytes zShort(raw.begin(), raw.end() - 1);
  Bytes zBadAdler = z;
  zBadAdler.back() ^= 1;  // stb does not check the Adler-32, libdeflate does
  Bytes rawBadFilter = raw;
  rawBadFilter[0] = 5;
  const std::vector<Case> cases = {
      {"16-bit", makePng(ihdr(w, h, 16, 6), zlibStored(Bytes(raw.size() * 2, 0)), 1000)},
      {"interlaced", makePng(ihdr(w, h, 8, 6, 1), z, 1000)},
      {"palette of 4 bits",
       makePng(ihdr(w, h, 4, 3), zlibStored(Bytes((w / 2 + 1) * h, 0)), 1000, {{"PLTE", Bytes(6, 9)}})},
      {"palette without PLTE", makePng(ihdr(w, h, 8, 3), zlibStored(Bytes((w + 1) * h, 0)), 1000)},
      {"two PLTE", makePng(ihdr(w, h, 8, 3), zlibStored(Bytes((w + 1) * h, 0)), 1000,
                           {{"PLTE", Bytes(6, 9)}, {"PLTE", Bytes(6, 8)}})},
      {"tRNS before PLTE", makePng(ihdr(w, h, 8, 3), zlibStored(Bytes((w + 1) * h, 0)), 1000,
                                   {{"tRNS", Bytes(1, 9)}, {"PLTE", Bytes(6, 8)}})},
      {"PLTE of 257 entries",
       makePng(ihdr(w, h, 8, 3), zlibStored(Bytes((w + 1) * h, 0)), 1000, {{"PLTE", Bytes(771, 9)}})},
      {"tRNS", makePng(ihdr(w, h, 8, 2), zlibStored(filterRows(Bytes(w * h * 3, 1), w, h, 3, {0, 0, 0})),
                       1000, {{"tRNS", Bytes{0, 1, 0, 1, 0, 1}}})},
      {"PLTE in RGB", makePng(ihdr(w, h, 8, 6), z, 1000, {{"PLTE", Bytes(6, 9)}})},
      {"CgBI", makePng(ihdr(w, h, 8, 6), z, 1000, {{"CgBI", Bytes(4, 0)}})},
      {"unknown critical chunk", makePng(ihdr(w, h, 8, 6), z, 1000, {{"ABCD", Bytes(2, 0)}})},
      {"extra inflated data", makePng(ihdr(w, h, 8, 6), zlibStored(zExtra), 1000)},
      {"short inflated data", makePng(ihdr(w, h, 8, 6), zlibStored(zShort), 1000)},
      {"bad Adler-32", makePng(ihdr(w, h, 8, 6), zBadAdler, 1000)},
      {"filter type 5", makePng(ihdr(w, h, 8, 6), zlibStored(rawBadFilter), 1000)},
      {"no IDAT", makePng(ihdr(w, h, 8, 6), Bytes{}, 1000)},
  };
  for (const Case& c : cases) {
    somm::detail::RawImage img;
    EXPECT_FALSE(somm::detail::decodePngFast(c.png.data(), c.png.size(), img)) << c.what;
    EXPECT_EQ(img.samples, nullptr) << c.what;
    const auto s =
        somm::detail::decodeImage(c.png.data(), c.png.size(), somm::defaultLimits(), nullptr, false);
    const auto r = somm::detail::decodeImage(c.png.data(), c.png.size());
    EXPECT_EQ(r.ok(), s.ok()) << c.what;
    if (r.ok() && s.ok()) {
      EXPECT_EQ(r->channels, s->channels) << c.what;
      EXPECT_EQ(r->sixteenBit, s->sixteenBit) << c.what;
      EXPECT_TRUE(
          r->sampleCount() == s->sampleCount() &&
          std::memcmp(r->samples.get(), s->samples.get(), r->sampleCount() * (r->sixteenBit ? 2 : 1)) == 0)
          << c.what;
    }
  }
  // Missing IEND, and a truncated chunk.
  Bytes noEnd = makePng(ihdr(w, h, 8, 6), z, 1000);
  noEnd.resize(noEnd.size() - 12);
  somm::detail::RawImage img;
  EXPECT_FALSE(somm::detail::decodePngFast(noEnd.data(), noEnd.size(), img));
  Bytes cut = makePng(ihdr(w, h, 8, 6), z, 1000);
  cut.resize(cut.size() - 20);
  EXPECT_FALSE(somm::detail::decodePngFast(cut.data(), cut.size(), img));
}

// decodeAlphaFast (the alpha channel alone) against the whole decode by stb_image and toAlphaTexture: every colour
// type, palettes with and without tRNS, every filter type on random rows, odd sizes, both row orders, factors 1 and
// 0.5, every channel request — present exactly for the alpha of an image that has one, then texel for texel equal.
void expectAlphaAloneEqualsWhole(const Bytes& png, bool expectTaken, const std::string& what) {
  using somm::detail::AlphaChannel;
  const auto header = somm::detail::checkImage(png.data(), png.size());
  ASSERT_TRUE(header.ok()) << what;
  const auto whole = somm::detail::decodeImage(png.data(), png.size(), somm::defaultLimits(), nullptr, false);
  ASSERT_TRUE(whole.ok()) << what;
  for (AlphaChannel ch : {AlphaChannel::AlphaOrOne, AlphaChannel::AlphaOrLuminance, AlphaChannel::Red,
                          AlphaChannel::Green, AlphaChannel::Blue, AlphaChannel::Luminance})
    for (bool flip : {false, true})
      for (float factor : {1.0f, 0.5f}) {
        const std::string w = what + " channel " + std::to_string(int(ch)) + " flip " + std::to_string(flip) +
                              " factor " + std::to_string(factor);
        const auto fast = somm::detail::decodeAlphaFast(png.data(), png.size(), *header, ch, factor, flip);
        const bool alphaRequest = ch == AlphaChannel::AlphaOrOne || ch == AlphaChannel::AlphaOrLuminance;
        ASSERT_EQ(fast.has_value(), expectTaken && alphaRequest) << w;
        if (!fast) continue;
        const somm::AlphaTexture oracle = somm::detail::toAlphaTexture(*whole, ch, factor, flip);
        ASSERT_EQ(fast->width, oracle.width) << w;
        ASSERT_EQ(fast->height, oracle.height) << w;
        EXPECT_EQ(fast->storage, oracle.storage) << w;
        EXPECT_TRUE(fast->alpha8 == oracle.alpha8) << w;
        EXPECT_EQ(fast->scale, oracle.scale) << w;
        for (size_t i = 0; i < oracle.texelCount(); ++i)
          ASSERT_EQ(fast->texel(i), oracle.texel(i)) << w << " " << i;
      }
}

TEST(PngFast, AlphaAloneEqualsTheWholeDecode) {
  std::mt19937 rng(41);
  int cases = 0;
  for (int colour : {0, 2, 3, 4, 6})
    for (bool trns : {false, true}) {
      if (trns && colour != 3) continue;
      for (uint32_t w : {1u, 2u, 5u, 16u, 33u})
        for (uint32_t h : {1u, 3u, 9u}) {
          const uint32_t ch = colour == 3 ? 1u : (colour & 2 ? 3u : 1u) + (colour & 4 ? 1u : 0u);
          Bytes pixels(size_t(w) * h * ch);
          // Small alphabets half the time (the Paeth predictor's ties), indices beyond a short palette too.
          for (auto& v : pixels)
            v = uint8_t(colour == 3 ? rng() % 12 : cases % 2 ? rng() : (rng() % 3) * 127);
          std::vector<int> filters(h);
          for (uint32_t y = 0; y < h; ++y) filters[y] = int(rng() % 5);
          std::vector<std::pair<std::string, Bytes>> extra;
          if (colour == 3) {
            Bytes plte(3 * 9), alphas(7);
            for (auto& v : plte) v = uint8_t(rng());
            for (auto& v : alphas) v = uint8_t(rng());
            extra.push_back({"PLTE", plte});
            if (trns) extra.push_back({"tRNS", alphas});
          }
          const Bytes raw = filterRows(pixels, w, h, ch, filters);
          const Bytes z = cases % 3 ? zlibStb(raw) : zlibStored(raw, 1 + rng() % 40);
          const Bytes png = makePng(ihdr(w, h, 8, uint8_t(colour)), z, 1 + rng() % 23, extra);
          const bool hasAlpha = colour == 4 || colour == 6 || (colour == 3 && trns);
          expectAlphaAloneEqualsWhole(png, hasAlpha,
                                      "colour " + std::to_string(colour) + (trns ? " tRNS " : " ") +
                                          std::to_string(w) + "x" + std::to_string(h));
          ++cases;
        }
    }
  EXPECT_EQ(cases, 6 * 5 * 3);
  // A filter type above 4 in the alpha's rows: not taken (stb's verdict stands).
  Bytes pixels(4 * 2 * 2, 9);
  Bytes raw = filterRows(pixels, 2, 2, 4, {0, 1});
  raw[9] = 5;
  const Bytes bad = makePng(ihdr(2, 2, 8, 6), zlibStored(raw), 100);
  const somm::detail::ImageHeader hd{2, 2, 4};
  EXPECT_FALSE(somm::detail::decodeAlphaFast(bad.data(), bad.size(), hd,
                                             somm::detail::AlphaChannel::AlphaOrOne, 1.0f, false));
  // Dimensions other than the header's (what decodeImage would not keep): not taken.
  const Bytes good = makePng(ihdr(2, 2, 8, 6), zlibStored(filterRows(pixels, 2, 2, 4, {0, 1})), 100);
  EXPECT_TRUE(somm::detail::decodeAlphaFast(good.data(), good.size(), hd,
                                            somm::detail::AlphaChannel::AlphaOrOne, 1.0f, false));
  EXPECT_FALSE(somm::detail::decodeAlphaFast(good.data(), good.size(), somm::detail::ImageHeader{2, 2, 2},
                                             somm::detail::AlphaChannel::AlphaOrOne, 1.0f, false));
}

TEST(PngFast, BundledTexturesEqualStb) {
  int n = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(SOMM_DATA_DIR))
    if (e.path().extension() == ".png") {
      const Bytes png = readFile(e.path().string());
      somm::detail::RawImage img;
      if (!somm::detail::decodePngFast(png.data(), png.size(), img)) continue;  // not in the subset
      expectFastEqualsStb(png, e.path().string());
      ++n;
    }
  EXPECT_GE(n, 3);
}

TEST(PngFast, RealTexturesEqualStb) {
  const char* env = std::getenv("SOMM_FOLIAGE_DIR");
  const std::string dir = env && *env ? env : SOMM_FOLIAGE_DIR;
  if (dir.empty() || !std::filesystem::is_directory(dir)) GTEST_SKIP() << "no ../shared/assets/foliage";
  int n = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.path().extension() == ".png") {
      const Bytes png = readFile(e.path().string());
      expectFastEqualsStb(png, e.path().string());  // all real ones are in the subset
      // The alpha alone, when they have one (grey+alpha, RGBA, palette with tRNS: byte 25 of IHDR).
      const bool hasAlpha = png[25] == 4 || png[25] == 6 ||
                            (png[25] == 3 && std::search(png.begin(), png.end(), std::begin("tRNS"),
                                                         std::end("tRNS") - 1) != png.end());
      expectAlphaAloneEqualsWhole(png, hasAlpha, e.path().string());
      ++n;
    }
  EXPECT_GT(n, 150);
}

}  // namespace

namespace {

TEST(AlphaFromRgba, EveryTexelAndRowOrder) {
  // toAlphaTexture on 8-bit RGBA (the SSE2 path: 16 texels at a time, then the row's tail) against the alpha bytes.
  std::mt19937 rng(11);
  for (uint32_t w : {1u, 15u, 16u, 17u, 37u})
    for (bool flip : {false, true}) {
      const uint32_t h = 5;
      auto* px = static_cast<uint8_t*>(std::malloc(size_t(w) * h * 4));
      for (size_t i = 0; i < size_t(w) * h * 4; ++i) px[i] = uint8_t(rng());
      somm::detail::RawImage img;
      img.width = w;
      img.height = h;
      img.channels = 4;
      img.samples = std::shared_ptr<const void>(px, [](const void* p) { std::free(const_cast<void*>(p)); });
      for (auto channel :
           {somm::detail::AlphaChannel::AlphaOrOne, somm::detail::AlphaChannel::AlphaOrLuminance}) {
        const somm::AlphaTexture t = somm::detail::toAlphaTexture(img, channel, 1.0f, flip);
        ASSERT_EQ(t.texelCount(), size_t(w) * h);
        for (uint32_t y = 0; y < h; ++y)
          for (uint32_t x = 0; x < w; ++x) {
            const uint8_t a = px[(size_t(flip ? h - 1 - y : y) * w + x) * 4 + 3];
            ASSERT_EQ(t.texel(size_t(y) * w + x), float(a) / 255.0f)
                << w << " " << flip << " " << x << "," << y;
          }
      }
    }
}

}  // namespace
