// SPDX-License-Identifier: MIT
// somm — the common PNG subset decoded fast: one libdeflate call for the zlib stream, rows unfiltered in place
// (docs/scene.md "PNG fast path"). Anything else is left to stb_image.
#include <libdeflate.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "image_io.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace somm::detail {

namespace {

// The Paeth predictor (PNG spec 9.4): a left, b up, c up-left; ties prefer a, then b. In libpng's form (pa = |b − c|,
// pb = |a − c|, pc = |a + b − 2c|, then two selects), which compilers make branch-free.
inline uint8_t paeth(int a, int b, int c) {
  const int p = b - c, q = a - c;
  int pa = std::abs(p);
  const int pb = std::abs(q), pc = std::abs(p + q);
  if (pb < pa) pa = pb, a = b;
  return uint8_t(pc < pa ? c : a);
}

// One row unfiltered in place: `row` holds the filtered bytes (rb of them, pixels of kBpp bytes), `prior` the
// previous row unfiltered, or null for the first row (a row of zeros).
template <int kBpp>
void unfilterScalar(uint8_t* row, const uint8_t* prior, size_t rb, int filter) {
  switch (filter) {
    case 1:  // Sub
      for (size_t x = kBpp; x < rb; ++x) row[x] = uint8_t(row[x] + row[x - kBpp]);
      break;
    case 2:  // Up
      if (prior)
        for (size_t x = 0; x < rb; ++x) row[x] = uint8_t(row[x] + prior[x]);
      break;
    case 3:  // Average
      for (size_t x = 0; x < rb; ++x) {
        const int a = x >= size_t(kBpp) ? row[x - kBpp] : 0, b = prior ? prior[x] : 0;
        row[x] = uint8_t(row[x] + ((a + b) >> 1));
      }
      break;
    case 4:  // Paeth
      for (size_t x = 0; x < rb; ++x) {
        const bool left = x >= size_t(kBpp);
        const int a = left ? row[x - kBpp] : 0, b = prior ? prior[x] : 0,
                  c = prior && left ? prior[x - kBpp] : 0;
        row[x] = uint8_t(row[x] + paeth(a, b, c));
      }
      break;
    default:  // None
      break;
  }
}

#if defined(__SSE2__)
// 4-byte pixels (RGBA): Sub, Average and Paeth depend on the pixel to the left, so they run a pixel at a time (Sub
// and Average in byte lanes, Paeth with its 4 samples in 16-bit lanes); Up 16 bytes at a time. The same bytes as
// unfilterScalar<4>.
// One pixel's 4 bytes in the low byte lanes, and back.
inline __m128i loadPixel(const uint8_t* p) {
  int v;
  std::memcpy(&v, p, 4);
  return _mm_cvtsi32_si128(v);
}
inline void storePixel(uint8_t* p, __m128i v) {
  const int w = _mm_cvtsi128_si32(v);
  std::memcpy(p, &w, 4);
}
// The same in 16-bit lanes (for Paeth).
inline __m128i load4(const uint8_t* p) {
  return _mm_unpacklo_epi8(loadPixel(p), _mm_setzero_si128());
}
inline void store4(uint8_t* p, __m128i v16) {
  storePixel(p, _mm_packus_epi16(v16, v16));
}

// filter: 0..4 (unfilterRows rejects the others).
void unfilterRgbaSse2(uint8_t* row, const uint8_t* prior, size_t rb, int filter) {
  const __m128i zero = _mm_setzero_si128(), low = _mm_set1_epi16(0xff), one = _mm_set1_epi16(1);
  if (filter == 2 && prior) {
    size_t x = 0;
    for (; x + 16 <= rb; x += 16) {
      const __m128i r = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + x));
      const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(prior + x));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(row + x), _mm_add_epi8(r, b));
    }
    for (; x < rb; ++x) row[x] = uint8_t(row[x] + prior[x]);
    return;
  }
  if (filter == 0 || filter == 2) return;  // None, or Up on the first row (its prior row is zeros)
  if (filter == 1) {                       // Sub: byte lanes, wrapping adds
    __m128i a = zero;
    for (size_t x = 0; x < rb; x += 4) {
      a = _mm_add_epi8(loadPixel(row + x), a);
      storePixel(row + x, a);
    }
    return;
  }
  if (filter == 3) {  // Average: ⌊(a + b) / 2⌋ = avg_epu8(a, b) − ((a ^ b) & 1) in byte lanes
    const __m128i lsb = _mm_set1_epi8(1);
    __m128i a = zero;
    for (size_t x = 0; x < rb; x += 4) {
      const __m128i b = prior ? loadPixel(prior + x) : zero;
      const __m128i mean = _mm_sub_epi8(_mm_avg_epu8(a, b), _mm_and_si128(_mm_xor_si128(a, b), lsb));
      a = _mm_add_epi8(loadPixel(row + x), mean);
      storePixel(row + x, a);
    }
    return;
  }
  // Paeth: 16-bit lanes (the predictor's distances need 9 bits and a sign).
  __m128i a = zero, c = zero;
  for (size_t x = 0; x < rb; x += 4) {
    const __m128i r = load4(row + x);
    const __m128i b = prior ? load4(prior + x) : zero;
    const __m128i p = _mm_sub_epi16(b, c), q = _mm_sub_epi16(a, c), t = _mm_add_epi16(p, q);
    const __m128i pa = _mm_max_epi16(p, _mm_sub_epi16(zero, p)),
                  pb = _mm_max_epi16(q, _mm_sub_epi16(zero, q)),
                  pc = _mm_max_epi16(t, _mm_sub_epi16(zero, t));
    // pa <= pb && pa <= pc: a; else pb <= pc: b; else c.
    const __m128i useA = _mm_and_si128(_mm_cmplt_epi16(pa, _mm_add_epi16(pb, one)),
                                       _mm_cmplt_epi16(pa, _mm_add_epi16(pc, one)));
    const __m128i useB = _mm_cmplt_epi16(pb, _mm_add_epi16(pc, one));
    const __m128i bc = _mm_or_si128(_mm_and_si128(useB, b), _mm_andnot_si128(useB, c));
    const __m128i v = _mm_and_si128(
        _mm_add_epi16(r, _mm_or_si128(_mm_and_si128(useA, a), _mm_andnot_si128(useA, bc))), low);
    store4(row + x, v);
    a = v;
    c = b;
  }
}
#endif

template <int kBpp>
bool unfilterRows(uint8_t* buf, size_t rb, uint32_t h, bool simd) {
  const uint8_t* prior = nullptr;
  for (uint32_t y = 0; y < h; ++y) {
    uint8_t* row = buf + size_t(y) * (rb + 1);
    const int filter = row[0];
    if (filter > 4) return false;
#if defined(__SSE2__)
    if (kBpp == 4 && simd) {
      unfilterRgbaSse2(row + 1, prior, rb, filter);
      prior = row + 1;
      continue;
    }
#else
    (void)simd;
#endif
    unfilterScalar<kBpp>(row + 1, prior, rb, filter);
    prior = row + 1;
  }
  return true;
}

}  // namespace

bool pngUnfilter(uint8_t* buf, uint32_t width, uint32_t height, uint32_t channels, bool simd) {
  const size_t rb = size_t(width) * channels;
  bool ok = false;
  switch (channels) {
    case 1:
      ok = unfilterRows<1>(buf, rb, height, simd);
      break;
    case 2:
      ok = unfilterRows<2>(buf, rb, height, simd);
      break;
    case 3:
      ok = unfilterRows<3>(buf, rb, height, simd);
      break;
    case 4:
      ok = unfilterRows<4>(buf, rb, height, simd);
      break;
    default:
      return false;
  }
  if (!ok) return false;
  // Rows packed: the filter bytes dropped (row y moves y + 1 bytes toward the start).
  for (uint32_t y = 0; y < height; ++y)
    std::memmove(buf + size_t(y) * rb, buf + size_t(y) * (rb + 1) + 1, rb);
  return true;
}

namespace {

// A PNG of the fast path's subset, its zlib stream inflated: `buf` holds h rows of 1 + rb bytes (the filter type,
// then the row's filtered bytes), rb = w · streamChannels; a palette image's palette (padded to 256 entries as
// decodeImage pads it for stb) and whether it has tRNS.
struct PngStream {
  uint32_t w = 0, h = 0, streamChannels = 0;
  bool indexed = false;
  int trnsCount = 0;
  uint8_t palette[256][4] = {};
  size_t rb = 0;
  std::unique_ptr<uint8_t, decltype(&std::free)> buf{nullptr, &std::free};
};

bool inflatePng(const uint8_t* data, size_t size, PngStream& out, bool alphaOnly = false) {
  if (size < 8 + 25 || !hasPngSignature(data, size)) return false;
  // IHDR first, 13 bytes: 8-bit, grey (0) / RGB (2) / palette (3) / grey+alpha (4) / RGBA (6), methods 0, not
  // interlaced.
  if (loadBe32(data + 8) != 13 || std::memcmp(data + 12, "IHDR", 4) != 0) return false;
  const uint32_t w = loadBe32(data + 16), h = loadBe32(data + 20);
  const uint8_t depth = data[24], colour = data[25];
  if (depth != 8 || colour > 6 || colour == 1 || colour == 5 || data[26] != 0 || data[27] != 0 ||
      data[28] != 0)
    return false;
  const bool indexed = colour == 3;
  // Samples per pixel in the stream (an index for a palette image).
  const uint32_t streamChannels = indexed ? 1u : (colour & 2 ? 3u : 1u) + (colour & 4 ? 1u : 0u);
  // stb_image's own bounds (2^24 a side, 2^30 samples; 4 per pixel for a palette image).
  if (w == 0 || h == 0 || w > (1u << 24) || h > (1u << 24) ||
      uint64_t(w) * h * (indexed ? 4u : streamChannels) > (uint64_t(1) << 30))
    return false;
  // The chunks up to IEND: IDAT data gathered. A palette image takes one PLTE (at most 256 entries) and at most one
  // tRNS after it, both before the first IDAT; entries past PLTE are black and alphas past tRNS 255 (what decodeImage
  // gives stb: the palette padded to 256 entries). Anything else — PLTE or tRNS in other images, CgBI (Apple's
  // variant), a second IHDR, unknown critical chunks — is left to stb.
  const uint8_t* single = nullptr;
  size_t singleLen = 0, idatCount = 0;
  std::vector<uint8_t> joined;
  uint8_t palette[256][4] = {};
  int plteCount = 0, trnsCount = 0;
  bool ended = false;
  for (size_t i = 8 + 25; size - i >= 12;) {
    const uint64_t len = loadBe32(data + i);
    if (len + 12 > size - i) return false;
    const uint8_t* type = data + i + 4;
    const uint8_t* body = data + i + 8;
    if (std::memcmp(type, "IEND", 4) == 0) {
      ended = true;
      break;
    }
    if (std::memcmp(type, "IDAT", 4) == 0) {
      if (indexed && plteCount == 0) return false;
      if (len > 0) {
        if (idatCount == 0) {
          single = body;
          singleLen = size_t(len);
        } else {
          if (idatCount == 1) {
            // The IDAT data is less than the file: one allocation, no copies as it grows (untouched pages of the
            // reservation cost nothing).
            joined.reserve(size);
            joined.assign(single, single + singleLen);
          }
          joined.insert(joined.end(), body, body + len);
        }
        ++idatCount;
      }
    } else if (indexed && std::memcmp(type, "PLTE", 4) == 0) {
      if (plteCount++ != 0 || idatCount != 0 || len > 768 || len % 3 != 0) return false;
      for (uint32_t k = 0; k < 256; ++k) palette[k][3] = 255;
      for (uint32_t k = 0; k < len / 3; ++k) std::memcpy(palette[k], body + 3 * k, 3);
    } else if (indexed && std::memcmp(type, "tRNS", 4) == 0) {
      if (trnsCount++ != 0 || plteCount == 0 || idatCount != 0 || len > 256) return false;
      for (uint32_t k = 0; k < len; ++k) palette[k][3] = body[k];
    } else if ((type[0] & 0x20) == 0 ||  // critical: IHDR again, PLTE, or unknown
               std::memcmp(type, "tRNS", 4) == 0 || std::memcmp(type, "CgBI", 4) == 0) {
      return false;
    }
    i += size_t(len) + 12;
  }
  if (!ended || idatCount == 0) return false;
  if (alphaOnly && indexed && trnsCount == 0) return false;  // no alpha: nothing inflated for nothing
  const uint8_t* z = idatCount == 1 ? single : joined.data();
  const size_t zLen = idatCount == 1 ? singleLen : joined.size();
  const size_t rb = size_t(w) * streamChannels, rawLen = (rb + 1) * h;
  std::unique_ptr<uint8_t, decltype(&std::free)> buf(static_cast<uint8_t*>(std::malloc(rawLen)), &std::free);
  if (!buf) return false;
  std::unique_ptr<libdeflate_decompressor, decltype(&libdeflate_free_decompressor)> d(
      libdeflate_alloc_decompressor(), &libdeflate_free_decompressor);
  if (!d) return false;
  size_t inUsed = 0, produced = 0;
  // Data after the zlib stream is ignored (as stb does); a stream that yields more than the image (stb accepts it)
  // or less fails here and goes to stb.
  if (libdeflate_zlib_decompress_ex(d.get(), z, zLen, buf.get(), rawLen, &inUsed, &produced) !=
          LIBDEFLATE_SUCCESS ||
      produced != rawLen)
    return false;
  joined = std::vector<uint8_t>();  // the compressed copy is not needed any more
  out.w = w;
  out.h = h;
  out.streamChannels = streamChannels;
  out.indexed = indexed;
  out.trnsCount = trnsCount;
  std::memcpy(out.palette, palette, sizeof palette);
  out.rb = rb;
  out.buf = std::move(buf);
  return true;
}

// The alpha bytes (offset kBpp - 1 of each kBpp-byte pixel) of the inflated rows unfiltered on their own — a PNG
// filter predicts each byte from the same channel's bytes to the left, above and above-left, so one channel needs no
// other — into `out` (w bytes a row; rows bottom-up when flipRows). False on a filter type above 4.
template <int kBpp>
bool unfilterAlpha(const uint8_t* buf, size_t rb, uint32_t w, uint32_t h, bool flipRows, uint8_t* out) {
  const uint8_t* prior = nullptr;  // the previous row's alphas (null: zeros)
  for (uint32_t y = 0; y < h; ++y) {
    const uint8_t* in = buf + size_t(y) * (rb + 1);
    const int filter = in[0];
    const uint8_t* src = in + 1 + (kBpp - 1);
    uint8_t* row = out + size_t(flipRows ? h - 1 - y : y) * w;
    switch (filter) {
      case 0:
        for (uint32_t x = 0; x < w; ++x) row[x] = src[size_t(x) * kBpp];
        break;
      case 1: {
        uint8_t a = 0;
        for (uint32_t x = 0; x < w; ++x) row[x] = a = uint8_t(src[size_t(x) * kBpp] + a);
        break;
      }
      case 2:
        if (prior) {
          for (uint32_t x = 0; x < w; ++x) row[x] = uint8_t(src[size_t(x) * kBpp] + prior[x]);
        } else {
          for (uint32_t x = 0; x < w; ++x) row[x] = src[size_t(x) * kBpp];
        }
        break;
      case 3: {
        int a = 0;
        for (uint32_t x = 0; x < w; ++x) {
          const int b = prior ? prior[x] : 0;
          row[x] = uint8_t(a = uint8_t(src[size_t(x) * kBpp] + ((a + b) >> 1)));
        }
        break;
      }
      case 4: {
        int a = 0, c = 0;
        for (uint32_t x = 0; x < w; ++x) {
          const int b = prior ? prior[x] : 0;
          row[x] = uint8_t(a = uint8_t(src[size_t(x) * kBpp] + paeth(a, b, c)));
          c = b;
        }
        break;
      }
      default:
        return false;
    }
    prior = row;
  }
  return true;
}

}  // namespace

bool decodePngFast(const uint8_t* data, size_t size, RawImage& out) {
  PngStream s;
  if (!inflatePng(data, size, s)) return false;
  const uint32_t w = s.w, h = s.h, streamChannels = s.streamChannels;
  const bool indexed = s.indexed;
  const int trnsCount = s.trnsCount;
  const auto& palette = s.palette;
  std::unique_ptr<uint8_t, decltype(&std::free)> buf = std::move(s.buf);
  if (!pngUnfilter(buf.get(), w, h, streamChannels, true)) return false;
  uint32_t channels = streamChannels;
  if (indexed) {
    // Indices to RGB (RGBA with tRNS), as stb expands them.
    channels = trnsCount != 0 ? 4u : 3u;
    const size_t n = size_t(w) * h;
    std::unique_ptr<uint8_t, decltype(&std::free)> rgb(static_cast<uint8_t*>(std::malloc(n * channels)),
                                                       &std::free);
    if (!rgb) return false;
    const uint8_t* idx = buf.get();
    uint8_t* o = rgb.get();
    if (channels == 4) {
      for (size_t k = 0; k < n; ++k) std::memcpy(o + 4 * k, palette[idx[k]], 4);
    } else {
      for (size_t k = 0; k < n; ++k) std::memcpy(o + 3 * k, palette[idx[k]], 3);
    }
    buf = std::move(rgb);
  }
  out = RawImage{};
  out.width = w;
  out.height = h;
  out.channels = channels;
  out.sixteenBit = false;
  out.samples =
      std::shared_ptr<const void>(buf.release(), [](const void* p) { std::free(const_cast<void*>(p)); });
  return true;
}

bool decodePngAlphaFast(const uint8_t* data, size_t size, bool flipRows, std::vector<uint8_t>& alpha,
                        uint32_t& width, uint32_t& height, uint32_t& channels) {
  // Only the colour types with an alpha channel (before inflating anything): grey+alpha, RGBA, palette (with tRNS).
  if (size < 8 + 25 || !hasPngSignature(data, size)) return false;
  const uint8_t colour = data[25];
  if (colour != 3 && colour != 4 && colour != 6) return false;
  PngStream s;
  if (!inflatePng(data, size, s, true)) return false;
  const size_t n = size_t(s.w) * s.h;
  std::vector<uint8_t> a(n);
  if (s.indexed) {
    if (!pngUnfilter(s.buf.get(), s.w, s.h, 1, false)) return false;
    const uint8_t* idx = s.buf.get();
    for (uint32_t y = 0; y < s.h; ++y) {
      const uint8_t* in = idx + size_t(y) * s.w;
      uint8_t* row = a.data() + size_t(flipRows ? s.h - 1 - y : y) * s.w;
      for (uint32_t x = 0; x < s.w; ++x) row[x] = s.palette[in[x]][3];
    }
    channels = 4;
  } else if (s.streamChannels == 4) {
    if (!unfilterAlpha<4>(s.buf.get(), s.rb, s.w, s.h, flipRows, a.data())) return false;
    channels = 4;
  } else {
    if (!unfilterAlpha<2>(s.buf.get(), s.rb, s.w, s.h, flipRows, a.data())) return false;
    channels = 2;
  }
  alpha = std::move(a);
  width = s.w;
  height = s.h;
  return true;
}

}  // namespace somm::detail
