// SPDX-License-Identifier: MIT
// somm — image decoding for the scene loaders (stb_image): any of PNG/JPEG/TGA/BMP, 8 or 16 bit, 1–4
// channels.
#pragma once

#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "somm/limits.h"
#include "somm/result.h"
#include "somm/scene.h"
#include "somm/texture.h"

namespace somm::detail {

// A decoded image, rows top to bottom as stored in the file, at the file's precision: the decoder's own buffer of
// 8-bit samples (sixteenBit false) or 16-bit samples, not copied or widened. at() widens an 8-bit v to v·257, so
// at()/65535 is exactly v/255.
struct RawImage {
  uint32_t width = 0, height = 0, channels = 0;  // channels: 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA
  bool sixteenBit = false;
  std::shared_ptr<const void> samples;  // width * height * channels samples of 1 (8-bit) or 2 bytes
  size_t sampleCount() const noexcept { return size_t(width) * height * channels; }
  const uint8_t* px8() const noexcept { return static_cast<const uint8_t*>(samples.get()); }
  const uint16_t* px16() const noexcept { return static_cast<const uint16_t*>(samples.get()); }
  // Sample i (of sampleCount()) widened to 16 bits.
  uint16_t sample(size_t i) const noexcept { return sixteenBit ? px16()[i] : uint16_t(px8()[i] * 257u); }
  uint16_t at(uint32_t x, uint32_t y, uint32_t c) const noexcept {
    return sample((size_t(y) * width + x) * channels + c);
  }
  bool hasAlpha() const noexcept { return channels == 2 || channels == 4; }
};

// An encoded image's declared size, as checkImage reads it from the header.
struct ImageHeader {
  uint32_t width = 0, height = 0, channels = 0;
};

// What decodeImage checks before it decodes (the format's header, the corrupt-table checks, limits.imagePixels and,
// when decodedBytes is given, the charge against limits.decodedImageBytes, *decodedBytes updated), nothing decoded.
// A loader that decodes in parallel charges its images in order with this, then decodes them with decodedBytes null.
Result<ImageHeader> checkImage(const uint8_t* data, size_t size, const Limits& limits = defaultLimits(),
                               uint64_t* decodedBytes = nullptr);
// Decodes an encoded image held in memory. The error message is the reason only (the caller adds context).
// The declared size is checked against limits.imagePixels and, when decodedBytes is given, the decoded bytes of
// the scene so far (*decodedBytes, updated) against limits.decodedImageBytes, before anything is decoded.
// fastPng false: stb_image for every PNG too (the fast path's oracle in tests and fuzzing).
Result<RawImage> decodeImage(const uint8_t* data, size_t size, const Limits& limits = defaultLimits(),
                             uint64_t* decodedBytes = nullptr, bool fastPng = true);
// Reads an image file's bytes (a regular file, at most limits.imageFileBytes). The error message is the reason only.
Result<std::vector<uint8_t>> readImageBytes(const std::string& path, const Limits& limits = defaultLimits());
// Reads (as readImageBytes) and decodes an image file. The error message is the reason only.
Result<RawImage> readImageFile(const std::string& path, const Limits& limits = defaultLimits(),
                               uint64_t* decodedBytes = nullptr);

// PNG helpers shared by the stb path's checks and the fast path: a big-endian u32, and the 8-byte signature.
inline uint32_t loadBe32(const uint8_t* p) noexcept {
  return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3];
}
inline bool hasPngSignature(const uint8_t* p, size_t n) noexcept {
  static constexpr uint8_t kSig[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  return n >= 8 && std::memcmp(p, kSig, 8) == 0;
}
// Where a JPEG's SOI marker (0xFF 0xD8) starts after the 0xFF fill bytes stb accepts before it: the offset of its
// 0xD8 byte, or 0 when the bytes do not start so.
inline size_t jpegSoiOffset(const uint8_t* p, size_t n) noexcept {
  size_t i = 0;
  while (i < n && p[i] == 0xFF) ++i;
  return i >= 1 && i < n && p[i] == 0xD8 ? i : 0;
}

// The common PNG subset — 8-bit grey, grey+alpha, RGB, RGBA or palette (one PLTE, at most one tRNS), not interlaced,
// without CgBI or unknown critical chunks — decoded with libdeflate and an in-place unfilter (docs/scene.md "PNG fast
// path"). False, with `out` untouched, for anything else and on any failure: the caller then decodes with stb_image,
// whose verdict stands. When true, the samples are those decodeImage gets from stb_image (stbi_load_from_memory, 0
// requested channels, a palette padded to 256 entries) byte for byte.
// Does no limit checks of its own beyond stb's dimension bounds: decodeImage checks first.
bool decodePngFast(const uint8_t* data, size_t size, RawImage& out);
// The alpha channel of a PNG of the fast path's subset that has one — grey+alpha, RGBA, or a palette with tRNS —
// decoded on its own: the zlib stream inflated, only the alpha bytes unfiltered (a PNG filter predicts each byte from
// the same channel's neighbours), written as width · height bytes, rows bottom-up when flipRows; `channels` is what
// decodePngFast would give (2 or 4). The same bytes as decodePngFast's alpha channel. False for anything else (no
// alpha channel, outside the subset, any failure).
bool decodePngAlphaFast(const uint8_t* data, size_t size, bool flipRows, std::vector<uint8_t>& alpha,
                        uint32_t& width, uint32_t& height, uint32_t& channels);
// PNG unfiltering of `height` rows of `width` pixels of `channels` bytes, each row preceded by its filter-type byte
// (the inflated IDAT stream), in place; then the rows packed without their filter bytes. False on a filter type
// above 4. simd: SSE2 for 4-byte pixels where available (the same bytes as without).
bool pngUnfilter(uint8_t* buf, uint32_t width, uint32_t height, uint32_t channels, bool simd);

// Which value of an image is the alpha.
enum class AlphaChannel : uint8_t {
  AlphaOrOne,        // glTF: the alpha channel, 1 when the image has none
  AlphaOrLuminance,  // OBJ map_d default / -imfchan m: the alpha channel, else the luminance
  Red,
  Green,
  Blue,
  Luminance,  // Rec. 709 weights (grey images: the grey value)
};

// Alpha texture of an image: value × factor, clamped to [0, 1]. flipRows: texture row y = image row H-1-y
// (OBJ).
AlphaTexture toAlphaTexture(const RawImage& img, AlphaChannel channel, float factor, bool flipRows);
// What toAlphaTexture(decodeImage(data, size), channel, factor, flipRows) gives, made without decoding the other
// channels, when the channel is the image's alpha (AlphaOrOne / AlphaOrLuminance) and decodePngAlphaFast takes the
// image; nullopt otherwise (the caller then decodes it whole). `header`: checkImage's result for these bytes (its
// checks and the charge are the caller's).
std::optional<AlphaTexture> decodeAlphaFast(const uint8_t* data, size_t size, const ImageHeader& header,
                                            AlphaChannel channel, float factor, bool flipRows);
// RGBA8 colour image (grey expanded, missing alpha = 255, 16 bit rounded to 8).
ColorImage toColorImage(const RawImage& img, bool flipRows);

// Replaces line breaks by "; " and trims, so library messages stay one line.
std::string oneLine(const std::string& s);

}  // namespace somm::detail
