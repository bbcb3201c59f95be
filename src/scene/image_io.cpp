// SPDX-License-Identifier: MIT
// somm — image decoding via stb_image (implementation in the Debian libstb).
#include "image_io.h"

#include <libdeflate.h>
#include <stb_image.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <type_traits>

#include "somm/io.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace somm::detail {

namespace {

// Limit on decoded texels × channels we accept (1 Gi values = 2 GiB of 16-bit samples).
constexpr uint64_t kMaxSamples = uint64_t(1) << 30;
// Memory bound against hostile headers (docs/hardening.md): beyond 16 Mi samples, an image may not declare more
// samples than 1032 per byte of encoded data — deflate (PNG) cannot expand more than 1032:1, so no valid PNG is
// rejected, and other formats of real content compress far less. A 100-byte file claiming 30000x30000 texels is
// refused before anything is allocated.
constexpr uint64_t kFreeSamples = uint64_t(1) << 24;
constexpr uint64_t kMaxExpansion = 1032;

// PNG: every chunk must fit in the bytes present. stb_image grows its IDAT buffer to a chunk's declared length
// before reading it, so a 100-byte file declaring a 2 GB IDAT chunk would make it allocate 2 GB.
std::string pngChunkProblem(const uint8_t* p, size_t n) {
  if (!hasPngSignature(p, n)) return {};
  size_t i = 8;
  while (n - i >= 8) {
    const uint64_t len = uint64_t(p[i]) << 24 | uint64_t(p[i + 1]) << 16 | uint64_t(p[i + 2]) << 8 | p[i + 3];
    if (len + 12 > n - i)
      return "truncated PNG: a chunk at offset " + std::to_string(i) + " declares " + std::to_string(len) +
             " bytes but only " + std::to_string(n - i) + " remain";
    if (std::memcmp(p + i + 4, "IEND", 4) == 0) break;
    i += size_t(len) + 12;
  }
  return {};
}

// JPEG: a Huffman table may hold at most 256 codes. The Debian stb_image does not check this and writes past its
// tables (a heap buffer overflow) when a DHT segment's 16 counts add up to more; refuse such files first. Walks the
// marker segments like stb does (entropy-coded data byte by byte), so every DHT stb would read is seen.
bool jpegHuffmanTablesValid(const uint8_t* p, size_t n) {
  size_t i = jpegSoiOffset(p, n);
  if (i == 0) return true;
  ++i;
  auto at = [&](size_t k) -> uint32_t { return k < n ? p[k] : 0u; };  // stb reads zeros past the end
  while (i + 1 < n) {
    if (p[i] != 0xFF || p[i + 1] == 0xFF) {  // entropy-coded data, or a fill byte before a marker
      ++i;
      continue;
    }
    const uint8_t m = p[i + 1];
    if (m == 0x00 || m == 0x01 || m == 0xD8 || (m >= 0xD0 && m <= 0xD7)) {  // stuffed byte, TEM, SOI, RSTn
      i += 2;
      continue;
    }
    if (m == 0xD9) break;  // EOI
    const size_t len = size_t(at(i + 2) << 8 | at(i + 3));
    if (m == 0xC4) {
      const size_t end = i + 2 + len;
      for (size_t t = i + 4; t < end && t < n;) {
        uint32_t codes = 0;
        for (size_t k = 1; k <= 16; ++k) codes += at(t + k);
        if (codes > 256) return false;
        t += 17 + codes;
      }
    }
    i += 2 + (len < 2 ? 2 : len);
  }
  return true;
}

// TGA (which has no signature: stb reads a file as TGA when no other format claims it and its header is
// plausible): stb reads zeros past the end of the data, so a truncated TGA decodes to an image padded with zeros —
// and a 110-byte file that happens to parse as a TGA header can declare millions of texels. A TGA whose header (the
// 18-byte TGA header, with the width and height stb reported) declares more texel data than the file can hold is
// refused: uncompressed (types 1-3) it needs width × height × ⌈bits / 8⌉ bytes after the header, the id field and
// the colour map; run-length encoded (types 9-11) at least ⌈width × height / 128⌉ packets of 1 + ⌈bits / 8⌉ bytes
// (a packet stands for at most 128 texels). Returns the problem, or "" (also for files that are not such a TGA).
std::string tgaDataProblem(const uint8_t* p, size_t n, int w, int h) {
  if (n < 18 || p[1] > 1) return {};
  const uint32_t type = p[2];
  if (!((type >= 1 && type <= 3) || (type >= 9 && type <= 11))) return {};
  const uint32_t tw = uint32_t(p[12]) | uint32_t(p[13]) << 8, th = uint32_t(p[14]) | uint32_t(p[15]) << 8;
  if (tw != uint32_t(w) || th != uint32_t(h)) return {};  // stb read some other format
  const uint64_t pixelBytes = (uint64_t(p[16]) + 7) / 8;
  const uint64_t mapBytes = p[1] ? (uint64_t(p[5]) | uint64_t(p[6]) << 8) * ((uint64_t(p[7]) + 7) / 8) : 0;
  const uint64_t texels = uint64_t(tw) * th, head = 18 + uint64_t(p[0]) + mapBytes;
  const uint64_t data = type <= 3 ? texels * pixelBytes : (texels + 127) / 128 * (1 + pixelBytes);
  if (head + data <= n) return {};
  return "truncated TGA: " + std::to_string(tw) + "x" + std::to_string(th) + " texels need at least " +
         std::to_string(head + data) + " bytes, the file has " + std::to_string(n);
}

// A palette PNG's indices may exceed its PLTE entries; stb_image then reads its uninitialised palette memory.
// Returns a copy with PLTE padded to 256 entries (black, opaque unless tRNS says otherwise — what libpng gives
// for such indices), or nothing when the input needs no change. Chunk CRCs are recomputed.
std::vector<uint8_t> padPalette(const uint8_t* p, size_t n) {
  // Called after pngChunkProblem: every chunk fits.
  if (n < 33 || std::memcmp(p + 12, "IHDR", 4) != 0 || p[25] != 3) return {};  // colour type 3: palette
  size_t i = 8;
  while (n - i >= 12) {
    const uint32_t len = loadBe32(p + i);
    if (std::memcmp(p + i + 4, "PLTE", 4) == 0) {
      if (len >= 768 || len % 3 != 0) return {};
      std::vector<uint8_t> out(p, p + i);
      const uint8_t hdr[8] = {0, 0, 3, 0, 'P', 'L', 'T', 'E'};
      out.insert(out.end(), hdr, hdr + 8);
      out.insert(out.end(), p + i + 8, p + i + 8 + len);
      out.resize(out.size() + (768 - len), 0);
      const uint32_t crc = libdeflate_crc32(0, out.data() + i + 4, 4 + 768);
      for (int s = 24; s >= 0; s -= 8) out.push_back(uint8_t(crc >> s));
      out.insert(out.end(), p + i + 12 + len, p + n);
      return out;
    }
    if (std::memcmp(p + i + 4, "IEND", 4) == 0) break;
    i += size_t(len) + 12;
  }
  return {};
}

// stb_image copies every IDAT chunk into a buffer it allocates on the first non-empty one: an empty IDAT before it
// becomes memcpy(NULL, ..., 0), undefined behaviour (found by fuzz_image). Empty IDAT chunks carry no data, so a copy
// without them decodes to the same image. Empty when there is nothing to drop (or not a PNG).
std::vector<uint8_t> dropEmptyIdat(const uint8_t* p, size_t n) {
  // Called after pngChunkProblem: every chunk fits.
  if (!hasPngSignature(p, n)) return {};
  std::vector<uint8_t> out;
  size_t i = 8, copied = 0;
  while (n - i >= 12) {
    const uint32_t len = loadBe32(p + i);
    if (len == 0 && std::memcmp(p + i + 4, "IDAT", 4) == 0) {
      out.insert(out.end(), p + copied, p + i);
      copied = i + 12;
    }
    if (std::memcmp(p + i + 4, "IEND", 4) == 0) break;
    i += size_t(len) + 12;
  }
  if (copied == 0) return {};
  out.insert(out.end(), p + copied, p + n);
  return out;
}

}  // namespace

Result<ImageHeader> checkImage(const uint8_t* data, size_t size, const Limits& limits,
                               uint64_t* decodedBytes) {
  if (size == 0) return makeError(ErrorCode::CorruptFile, "empty image data");
  if (size > size_t(INT_MAX)) return makeError(ErrorCode::LimitExceeded, "image data larger than 2 GiB");
  const int n = int(size);
  if (std::string why = pngChunkProblem(data, size); !why.empty())
    return makeError(ErrorCode::CorruptFile, why);
  if (!jpegHuffmanTablesValid(data, size))
    return makeError(ErrorCode::CorruptFile, "corrupt JPEG: a Huffman table declares more than 256 codes");
  int w = 0, h = 0, comp = 0;
  if (!stbi_info_from_memory(data, n, &w, &h, &comp)) {
    const char* why = stbi_failure_reason();
    return makeError(ErrorCode::CorruptFile,
                     "cannot decode image (" + oneLine(why ? why : "unknown format") + ")");
  }
  if (w < 1 || h < 1 || comp < 1 || comp > 4)
    return makeError(ErrorCode::CorruptFile, "image has invalid dimensions or channel count");
  if (std::string why = tgaDataProblem(data, size, w, h); !why.empty())
    return makeError(ErrorCode::CorruptFile, why);
  if (uint64_t(w) * uint64_t(h) > limits.imagePixels)
    return makeError(ErrorCode::LimitExceeded, "image of " + std::to_string(w) + "x" + std::to_string(h) +
                                                   " texels exceeds " +
                                                   limitHint("image-pixels", limits.imagePixels));
  // What decoding may cost, charged conservatively: the decoder's buffer (kept as the RawImage) and the alpha/colour
  // textures made from it.
  const uint64_t cost = uint64_t(w) * uint64_t(h) * (uint64_t(comp) * 3 + 8);
  if (decodedBytes) {
    if (*decodedBytes + cost > limits.decodedImageBytes)
      return makeError(ErrorCode::LimitExceeded,
                       "decoding this " + std::to_string(w) + "x" + std::to_string(h) +
                           " image would bring the scene's "
                           "decoded images to " +
                           std::to_string(*decodedBytes + cost) + " bytes, more than " +
                           limitHint("decoded-bytes", limits.decodedImageBytes));
    *decodedBytes += cost;
  }
  return ImageHeader{uint32_t(w), uint32_t(h), uint32_t(comp)};
}

Result<RawImage> decodeImage(const uint8_t* data, size_t size, const Limits& limits, uint64_t* decodedBytes,
                             bool fastPng) {
  Result<ImageHeader> header = checkImage(data, size, limits, decodedBytes);
  if (!header.ok()) return header.error();
  const int w = int(header->width), h = int(header->height), comp = int(header->channels);
  if (RawImage fast; fastPng && decodePngFast(data, size, fast)) {
    if (fast.width == uint32_t(w) && fast.height == uint32_t(h) && fast.channels == uint32_t(comp))
      return fast;
  }
  std::vector<uint8_t> padded = padPalette(data, size);
  if (!padded.empty()) {
    if (padded.size() > size_t(INT_MAX))
      return makeError(ErrorCode::LimitExceeded, "image data larger than 2 GiB");
    data = padded.data();
    size = padded.size();
  }
  std::vector<uint8_t> noEmptyIdat = dropEmptyIdat(data, size);
  if (!noEmptyIdat.empty()) {
    data = noEmptyIdat.data();
    size = noEmptyIdat.size();
  }
  const int n2 = int(size);
  if (uint64_t(w) * uint64_t(h) * uint64_t(comp) > kMaxSamples)
    return makeError(ErrorCode::LimitExceeded, "image of " + std::to_string(w) + "x" + std::to_string(h) +
                                                   " texels is larger than supported");
  if (uint64_t(w) * uint64_t(h) * uint64_t(comp) > kFreeSamples + kMaxExpansion * uint64_t(size))
    return makeError(ErrorCode::LimitExceeded,
                     "image declares " + std::to_string(w) + "x" + std::to_string(h) + " texels but its " +
                         std::to_string(size) + " bytes cannot hold that many (truncated or corrupt)");
  RawImage img;
  const bool is16 = stbi_is_16_bit_from_memory(data, n2) != 0;
  int w2 = 0, h2 = 0, c2 = 0;
  // The decoder's buffer is kept as it is (no widened copy) and freed with stbi_image_free.
  void* p = is16 ? static_cast<void*>(stbi_load_16_from_memory(data, n2, &w2, &h2, &c2, 0))
                 : static_cast<void*>(stbi_load_from_memory(data, n2, &w2, &h2, &c2, 0));
  if (!p) {
    const char* why = stbi_failure_reason();
    return makeError(ErrorCode::CorruptFile, "cannot decode image (" + oneLine(why ? why : "?") + ")");
  }
  img.samples = std::shared_ptr<const void>(p, [](const void* q) { stbi_image_free(const_cast<void*>(q)); });
  img.width = uint32_t(w2), img.height = uint32_t(h2), img.channels = uint32_t(c2), img.sixteenBit = is16;
  if (img.width != uint32_t(w) || img.height != uint32_t(h) || img.channels < 1 || img.channels > 4)
    return makeError(ErrorCode::CorruptFile, "image decoder returned inconsistent dimensions");
  return img;
}

std::optional<AlphaTexture> decodeAlphaFast(const uint8_t* data, size_t size, const ImageHeader& header,
                                            AlphaChannel channel, float factor, bool flipRows) {
  if (channel != AlphaChannel::AlphaOrOne && channel != AlphaChannel::AlphaOrLuminance) return std::nullopt;
  std::vector<uint8_t> alpha;
  uint32_t w = 0, h = 0, c = 0;
  if (!decodePngAlphaFast(data, size, flipRows, alpha, w, h, c)) return std::nullopt;
  // decodeImage keeps the fast path's result only when it agrees with the header stb reads: the same here.
  if (w != header.width || h != header.height || c != header.channels) return std::nullopt;
  return AlphaTexture::fromUInt8(w, h, std::move(alpha), factor);
}

Result<std::vector<uint8_t>> readImageBytes(const std::string& path, const Limits& limits) {
  // Only regular files, at most the image cap: a directory made the read throw (std::terminate, found by fuzz_obj
  // with `map_Kd /`), /dev/zero would never end and a FIFO would block.
  auto bytes = readRegularFile(path, limits.imageFileBytes, "image", "file-bytes.image");
  if (!bytes) {
    // The reason only: the caller names the file.
    std::string msg = bytes.error().message;
    const std::string prefix = escapeName(path) + ": ";
    if (msg.rfind(prefix, 0) == 0) msg = msg.substr(prefix.size());
    return makeError(bytes.error().code, msg);
  }
  return bytes;
}

Result<RawImage> readImageFile(const std::string& path, const Limits& limits, uint64_t* decodedBytes) {
  auto bytes = readImageBytes(path, limits);
  if (!bytes) return bytes.error();
  return decodeImage(bytes->data(), bytes->size(), limits, decodedBytes);
}

AlphaTexture toAlphaTexture(const RawImage& img, AlphaChannel channel, float factor, bool flipRows) {
  const uint32_t nc = img.channels;
  const bool hasAlpha = img.hasAlpha();
  const bool colour = nc >= 3;
  // The channel the alpha is, when it is one stored value (not a luminance mix): -1 none, nc: the constant 1.
  int source = -1;
  switch (channel) {
    case AlphaChannel::AlphaOrOne:
      source = hasAlpha ? int(nc) - 1 : int(nc);
      break;
    case AlphaChannel::AlphaOrLuminance:
      source = hasAlpha ? int(nc) - 1 : (colour ? -1 : 0);
      break;
    case AlphaChannel::Red:
      source = 0;
      break;
    case AlphaChannel::Green:
      source = colour ? 1 : 0;
      break;
    case AlphaChannel::Blue:
      source = colour ? 2 : 0;
      break;
    case AlphaChannel::Luminance:
      source = colour ? -1 : 0;
      break;
  }
  if (source >= 0) {
    // At the image's precision (8-bit samples stay 8-bit): the table gives exactly the float the conversion below
    // would. source == nc: the constant 1 (the largest value).
    const size_t n = size_t(img.width) * img.height;
    auto fill = [&](auto* out, auto one, const auto* in) {
      for (uint32_t y = 0; y < img.height; ++y) {
        const uint32_t sy = flipRows ? img.height - 1 - y : y;
        auto* row = out + size_t(y) * img.width;
        if (source == int(nc)) {
          std::fill(row, row + img.width, one);
          continue;
        }
        const auto* src = in + size_t(sy) * img.width * nc + size_t(source);
        uint32_t x = 0;
#if defined(__SSE2__)
        if constexpr (std::is_same_v<std::remove_cv_t<std::remove_pointer_t<decltype(in)>>, uint8_t>) {
          if (nc == 4 && source == 3) {
            // RGBA's alpha bytes, 16 texels at a time: each 32-bit texel shifted right by 24, packed to bytes.
            const uint8_t* px = src - 3;
            for (; x + 16 <= img.width; x += 16) {
              __m128i q[4];
              for (int k = 0; k < 4; ++k)
                q[k] = _mm_srli_epi32(
                    _mm_loadu_si128(reinterpret_cast<const __m128i*>(px + 4 * (size_t(x) + 4 * k))), 24);
              const __m128i lo = _mm_packs_epi32(q[0], q[1]), hi = _mm_packs_epi32(q[2], q[3]);
              _mm_storeu_si128(reinterpret_cast<__m128i*>(row + x), _mm_packus_epi16(lo, hi));
            }
          }
        }
#endif
        for (; x < img.width; ++x) row[x] = src[size_t(x) * nc];
      }
    };
    if (!img.sixteenBit) {
      std::vector<uint8_t> v8(n);
      fill(v8.data(), uint8_t(255), img.px8());
      return AlphaTexture::fromUInt8(img.width, img.height, std::move(v8), factor);
    }
    std::vector<uint16_t> v16(n);
    fill(v16.data(), uint16_t(65535), img.px16());
    return AlphaTexture::fromUInt16(img.width, img.height, std::move(v16), factor);
  }
  AlphaTexture t;
  t.width = img.width;
  t.height = img.height;
  t.alpha.resize(size_t(img.width) * img.height);
  for (uint32_t y = 0; y < img.height; ++y) {
    const uint32_t sy = flipRows ? img.height - 1 - y : y;
    for (uint32_t x = 0; x < img.width; ++x) {
      uint16_t p[4] = {0, 0, 0, 0};  // the texel's samples widened to 16 bits
      for (uint32_t c = 0; c < nc; ++c) p[c] = img.at(x, sy, c);
      double v = 1.0;  // in [0, 65535] units below, except for this default
      auto lum = [&]() -> double {
        if (!colour) return p[0];
        return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
      };
      switch (channel) {
        case AlphaChannel::AlphaOrOne:
          v = hasAlpha ? p[nc - 1] : 65535.0;
          break;
        case AlphaChannel::AlphaOrLuminance:
          v = hasAlpha ? double(p[nc - 1]) : lum();
          break;
        case AlphaChannel::Red:
          v = p[0];
          break;
        case AlphaChannel::Green:
          v = colour ? p[1] : p[0];
          break;
        case AlphaChannel::Blue:
          v = colour ? p[2] : p[0];
          break;
        case AlphaChannel::Luminance:
          v = lum();
          break;
      }
      float a = float(v / 65535.0);
      if (factor != 1.0f) a *= factor;
      a = std::clamp(a, 0.0f, 1.0f);
      t.alpha[size_t(y) * img.width + x] = a;
    }
  }
  return t;
}

ColorImage toColorImage(const RawImage& img, bool flipRows) {
  ColorImage c;
  c.width = img.width;
  c.height = img.height;
  c.rgba.resize(size_t(img.width) * img.height * 4);
  const uint32_t nc = img.channels;
  auto to8 = [](uint16_t v) { return uint8_t((uint32_t(v) * 255u + 32767u) / 65535u); };
  for (uint32_t y = 0; y < img.height; ++y) {
    const uint32_t sy = flipRows ? img.height - 1 - y : y;
    for (uint32_t x = 0; x < img.width; ++x) {
      uint16_t p[4] = {0, 0, 0, 0};  // the texel's samples widened to 16 bits
      for (uint32_t c = 0; c < nc; ++c) p[c] = img.at(x, sy, c);
      uint8_t* o = &c.rgba[(size_t(y) * img.width + x) * 4];
      if (nc >= 3) {
        o[0] = to8(p[0]), o[1] = to8(p[1]), o[2] = to8(p[2]);
        o[3] = nc == 4 ? to8(p[3]) : 255;
      } else {
        o[0] = o[1] = o[2] = to8(p[0]);
        o[3] = nc == 2 ? to8(p[1]) : 255;
      }
    }
  }
  return c;
}

std::string oneLine(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  bool pendingSep = false;
  for (char ch : s) {
    if (ch == '\n' || ch == '\r') {
      pendingSep = !out.empty();
      continue;
    }
    if (pendingSep) {
      out += "; ";
      pendingSep = false;
    }
    out += ch;
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == ';')) out.pop_back();
  return out;
}

}  // namespace somm::detail
