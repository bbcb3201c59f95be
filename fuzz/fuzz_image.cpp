// SPDX-License-Identifier: MIT
// Fuzz target: image decoding (stb_image through the scene loader's decodeImage: PNG, JPEG, TGA, BMP, ...)
// and the conversions to alpha and colour textures; the PNG fast path (libdeflate) must equal stb wherever it
// decodes, and the alpha channel decoded alone (decodeAlphaFast) the whole decode's alpha texture. Decoded sizes must
// be consistent, alphas in [0, 1], and a small input must not allocate a huge image (run with -malloc_limit_mb, see
// fuzz_image.options).
#include <stb_image.h>

#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "scene/image_io.h"
#include "scene_fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace somm;
  // Speed: skip inputs declaring more than 4 Mi samples (legal, but slow to decode on every execution). The
  // size bounds themselves are exercised by the inputs below that and by tests/hardening.
  int w = 0, h = 0, comp = 0;
  // Never for JPEG: stbi_info itself would parse unvalidated Huffman tables (decodeImage checks them first).
  // (A TGA may start with 0xFF too, its id length, and one of 452 bytes can declare 1536 x 8192 RGBA: not a JPEG.)
  const bool jpeg = detail::jpegSoiOffset(data, size) != 0;
  if (!jpeg && size <= size_t(INT32_MAX) && stbi_info_from_memory(data, int(size), &w, &h, &comp) &&
      uint64_t(w) * uint64_t(h) * uint64_t(comp) > (uint64_t(1) << 22))
    return 0;
  // The PNG fast path against stb_image (decodeImage without it): whatever it decodes, stb decodes to the same bytes
  // (where it declines, decodeImage uses stb itself).
  if (detail::RawImage fast; detail::decodePngFast(data, size, fast)) {
    const Result<detail::RawImage> s = detail::decodeImage(data, size, defaultLimits(), nullptr, false);
    if (!s.ok()) fuzz::fail("fuzz_image", "PNG fast path decoded what stb rejects");
    if (s->width != fast.width || s->height != fast.height || s->channels != fast.channels || s->sixteenBit ||
        std::memcmp(s->px8(), fast.px8(), fast.sampleCount()) != 0)
      fuzz::fail("fuzz_image", "PNG fast path differs from stb");
  }
  const Result<detail::RawImage> r = detail::decodeImage(data, size);
  if (!r.ok()) {
    if (r.error().message.find('\n') != std::string::npos) fuzz::fail("fuzz_image", "multi-line error");
    return 0;
  }
  const detail::RawImage& img = *r;
  // The alpha channel alone (what the loaders take when only the alpha is needed) equals the whole decode's.
  if (const Result<detail::ImageHeader> hd = detail::checkImage(data, size); hd.ok()) {
    for (bool flip : {false, true}) {
      const auto a = detail::decodeAlphaFast(data, size, *hd, detail::AlphaChannel::AlphaOrOne, 0.75f, flip);
      if (!a) continue;
      const AlphaTexture t = detail::toAlphaTexture(img, detail::AlphaChannel::AlphaOrOne, 0.75f, flip);
      if (a->width != t.width || a->height != t.height || a->storage != t.storage || a->alpha8 != t.alpha8 ||
          a->scale != t.scale)
        fuzz::fail("fuzz_image", "the alpha channel alone differs from the whole decode's");
    }
  } else {
    fuzz::fail("fuzz_image", "checkImage rejects what decodeImage decodes");
  }
  if (img.width == 0 || img.height == 0 || img.channels < 1 || img.channels > 4 || !img.samples)
    fuzz::fail("fuzz_image", "inconsistent decoded image");
  for (detail::AlphaChannel c : {detail::AlphaChannel::AlphaOrOne, detail::AlphaChannel::AlphaOrLuminance,
                                 detail::AlphaChannel::Red, detail::AlphaChannel::Luminance}) {
    const AlphaTexture t = detail::toAlphaTexture(img, c, 0.75f, c == detail::AlphaChannel::Red);
    if (t.width != img.width || t.height != img.height || !t.consistent() ||
        t.texelCount() != img.sampleCount() / img.channels)
      fuzz::fail("fuzz_image", "alpha texture size");
    for (size_t i = 0; i < t.texelCount(); ++i)
      if (!(t.texel(i) >= 0.0f && t.texel(i) <= 1.0f)) fuzz::fail("fuzz_image", "alpha outside [0, 1]");
  }
  const ColorImage c = detail::toColorImage(img, true);
  if (c.rgba.size() != size_t(img.width) * img.height * 4) fuzz::fail("fuzz_image", "colour image size");
  return 0;
}
