// SPDX-License-Identifier: MIT
// somm — conservative opacity-micromap baking from alpha-tested textures (see docs/baking.md).
//
// For every triangle, each micro-triangle's UV triangle (in texel space, grown by a small safety margin) is
// classified against the material's alpha test (include/somm/texture.h): Opaque (Transparent) only when every
// point of it passes (fails) the test under the material's filter and wrap modes, otherwise unknown.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#include "somm/micromap.h"
#include "somm/omm_array.h"
#include "somm/result.h"
#include "somm/scene.h"
#include "somm/texture.h"

namespace somm {

// What an unknown micro-triangle becomes in a 2-state bake (4-state bakes keep it unknown and only pick
// unknown-opaque / unknown-transparent by majority).
enum class UnknownAs : uint8_t { Majority = 0, Opaque = 1, Transparent = 2 };

// How a material whose alpha mode is BLEND is baked (nothing is decided silently: the default is an error).
enum class BlendAs : uint8_t {
  Error = 0,    // bakeScene fails, naming the material
  Unknown = 1,  // every triangle FullyUnknownOpaque (the any-hit shader decides, as without micromaps)
  Mask = 2,     // baked like MASK with the material's cutoff
  Opaque = 3,   // every triangle FullyOpaque
};

// The scene's OMM arrays: one array shared by every geometry (identical maps stored once), or one per geometry.
enum class ArrayLayout : uint8_t { SceneWide = 0, PerGeometry = 1 };

// Progress callback: fraction done 0..1 (non-decreasing, ends at 1), called on the calling thread between chunks of
// work. Returning false cancels the bake (ErrorCode::Cancelled); a callable returning void never cancels.
class BakeProgress {
 public:
  BakeProgress() = default;
  template <class F, class = std::enable_if_t<!std::is_same<std::decay_t<F>, BakeProgress>::value>>
  BakeProgress(F f)  // NOLINT(google-explicit-constructor)
      : fn_([f = std::move(f)](double x) mutable -> bool {
          if constexpr (std::is_void<decltype(f(x))>::value) {
            f(x);
            return true;
          } else {
            return bool(f(x));
          }
        }) {}
  explicit operator bool() const noexcept { return bool(fn_); }
  // True: go on; false: cancel.
  bool operator()(double fraction) const { return fn_ ? fn_(fraction) : true; }

 private:
  std::function<bool(double)> fn_;
};

struct BakeOptions {
  uint32_t level = 6;           // fixed subdivision level 0..12 (used when texelsPerMicroTri == 0)
  uint32_t maxLevel = 0;        // adaptive: cap 0..12 (used when texelsPerMicroTri > 0)
  float texelsPerMicroTri = 0;  // adaptive: smallest level with UV area·W·H / 4^L <= S, capped at maxLevel
  Format format = Format::FourState;
  UnknownAs unknownAs = UnknownAs::Majority;  // 2-state only
  std::optional<Filter> filter;               // overrides the material's sampler filter
  std::optional<float> cutoff;                // overrides the material's alpha cutoff
  // 0 = no limit; else lower a level cap (the largest maps first) until the data fits. bakeScene: the data of all
  // of the scene's arrays together; bakeGeometry: that geometry's data.
  uint64_t maxBytes = 0;
  uint32_t threads = 0;                         // 0 = all hardware threads
  BlendAs blend = BlendAs::Error;               // bakeScene: materials with alpha mode BLEND
  ArrayLayout layout = ArrayLayout::SceneWide;  // bakeScene: one array for the scene or one per geometry
  // Fraction done, 0..1, non-decreasing, ends at 1; called on the calling thread (the library never prints).
  BakeProgress progress;
};

struct BakeStats {
  uint64_t triangles = 0;
  std::array<uint64_t, 4> specialCount{};  // triangles with a special index, by State (0..3)
  uint64_t uniqueMaps = 0;                 // descriptors in the array
  uint64_t dataBytes = 0;                  // size of the data buffer
  uint64_t microTriangles = 0;             // sum over triangles of 4^level (special-index triangles included)
  uint64_t unknownMicroTriangles = 0;      // micro-triangles the conservative test left unknown (before any
                                           // 2-state demotion)
  uint64_t nonFiniteUvTriangles = 0;       // triangles with NaN/inf UVs (or texel coordinates >= 1e14 in
                                           // magnitude): baked as whole-triangle unknown
  uint32_t minLevel = 0, maxLevel = 0;     // range of the levels chosen (over all triangles)
  uint32_t levelCap = kMaxLevel;           // the global cap --max-bytes applied (kMaxLevel = none)
  double seconds = 0;

  double unknownFraction() const noexcept {
    return microTriangles ? double(unknownMicroTriangles) / double(microTriangles) : 0.0;
  }
};

struct BakedGeometry {
  OmmArray array;
  BakeStats stats;
  std::vector<uint8_t> levels;  // chosen level per triangle (after the maxBytes cap)
};

// ---- inputs as views of the caller's memory (nothing is copied; it must outlive the bake) ----

// Texel formats of an alpha texture. 8- and 16-bit channels are unsigned normalised (v / 255, v / 65535, rounded
// to float exactly like the scene loaders), 16-bit and float values in host byte order.
enum class TexelFormat : uint8_t { R8 = 0, RG8 = 1, RGBA8 = 2, R16 = 3, RGBA16 = 4, R32F = 5 };
constexpr uint32_t texelChannels(TexelFormat f) noexcept {
  return f == TexelFormat::RG8 ? 2u : (f == TexelFormat::RGBA8 || f == TexelFormat::RGBA16) ? 4u : 1u;
}
constexpr uint32_t texelBytes(TexelFormat f) noexcept {
  return f == TexelFormat::R8                                ? 1u
         : f == TexelFormat::RG8 || f == TexelFormat::R16    ? 2u
         : f == TexelFormat::RGBA8 || f == TexelFormat::R32F ? 4u
                                                             : 8u;
}
constexpr const char* texelFormatName(TexelFormat f) noexcept {
  return f == TexelFormat::R8       ? "R8"
         : f == TexelFormat::RG8    ? "RG8"
         : f == TexelFormat::RGBA8  ? "RGBA8"
         : f == TexelFormat::R16    ? "R16"
         : f == TexelFormat::RGBA16 ? "RGBA16"
                                    : "R32F";
}

// An alpha texture in the caller's memory. Row y covers texture coordinates v in [y/H, (y+1)/H] (the AlphaTexture
// convention of texture.h; a caller with the other convention flips its v or its rows).
struct TextureView {
  const void* data = nullptr;
  uint32_t width = 0, height = 0;
  size_t rowPitch = 0;  // bytes from one row to the next; 0 = width · texelBytes(format)
  TexelFormat format = TexelFormat::R8;
  uint32_t alphaChannel = 0;   // the channel that holds alpha, 0..texelChannels(format) − 1
  const char* name = nullptr;  // for messages (e.g. the image's path); may be null
};

// How a material's triangles are treated. The zero value bakes (nothing is skipped unless stated).
enum class MaterialAlpha : uint8_t {
  Tested = 0,  // alpha-tested (glTF MASK): baked against the texture (or the constant alpha)
  Opaque = 1,  // stated opaque: every triangle FullyOpaque, nothing baked
  Blend = 2,   // glTF BLEND: as BakeOptions::blend says
};

struct MaterialInput {
  MaterialAlpha alpha = MaterialAlpha::Tested;
  int32_t texture = -1;        // index into BakeInputs::textures; −1: the constant alpha below everywhere
  float constantAlpha = 1.0f;  // used when texture == −1
  // Multiplies the texture's alpha (then clamped to [0, 1]), as glTF's baseColorFactor alpha; 1 = unchanged.
  float alphaScale = 1.0f;
  Sampler sampler;             // filter and wrap S/T (BakeOptions::filter overrides the filter)
  float cutoff = 0.5f;         // opaque iff alpha >= cutoff (BakeOptions::cutoff overrides it)
  const char* name = nullptr;  // for messages; may be null
};

enum class IndexFormat : uint8_t { None = 0, UInt16 = 2, UInt32 = 4 };

struct GeometryInput {
  const float* uvs = nullptr;  // (s, t) of vertex i at byte offset i · uvStride
  size_t uvStride = 0;         // bytes between vertices' UVs; 0 = 8 (tightly packed pairs)
  uint32_t vertexCount = 0;
  const void* indices = nullptr;  // 3 per triangle; IndexFormat::None: triangle t = vertices 3t..3t+2
  IndexFormat indexFormat = IndexFormat::None;
  uint32_t triangleCount = 0;
  uint32_t material = 0;       // index into BakeInputs::materials
  const char* name = nullptr;  // for messages; may be null
};

struct BakeInputs {
  const TextureView* textures = nullptr;
  uint32_t textureCount = 0;
  const MaterialInput* materials = nullptr;
  uint32_t materialCount = 0;
  const GeometryInput* geometries = nullptr;
  uint32_t geometryCount = 0;

  // Views of three caller-owned vectors (which must outlive the bake).
  static BakeInputs of(const std::vector<TextureView>& textures, const std::vector<MaterialInput>& materials,
                       const std::vector<GeometryInput>& geometries) noexcept {
    BakeInputs in;
    in.textures = textures.data();
    in.textureCount = uint32_t(textures.size());
    in.materials = materials.data();
    in.materialCount = uint32_t(materials.size());
    in.geometries = geometries.data();
    in.geometryCount = uint32_t(geometries.size());
    return in;
  }
};

// The alpha test of one (texture, channel, scale, sampler, cutoff), prepared for fast conservative queries: the
// texels' pass bits (one bit each) and a summed-area table of their 64-texel words; texel values are read from the
// caller's texture at its own precision (through a table for 8/16-bit formats, never a float copy). Building it is
// O(W·H); bakeScene builds one per distinct (texture, scale, sampler, cutoff) and shares it by every geometry and
// material. The texture must outlive the mask.
// Forced inlining for AlphaMask's per-texel queries (the classifier's hot loops; GCC otherwise keeps texel() out of
// line).
#if defined(__GNUC__) || defined(__clang__)
#define SOMM_BAKE_INLINE __attribute__((always_inline)) inline
#elif defined(_MSC_VER)
#define SOMM_BAKE_INLINE __forceinline
#else
#define SOMM_BAKE_INLINE inline
#endif

class AlphaMask {
 public:
  AlphaMask() = default;
  // `texture` must be non-empty with alpha.size() == width·height (checked by bakeGeometry; asserted here). Viewed
  // as R32F: no copy.
  AlphaMask(const AlphaTexture& texture, const Sampler& sampler, float cutoff);
  // A validated view (see validateTexture); alphaScale as MaterialInput::alphaScale.
  AlphaMask(const TextureView& texture, const Sampler& sampler, float cutoff, float alphaScale = 1.0f);

  uint32_t width() const noexcept { return w_; }
  uint32_t height() const noexcept { return h_; }
  const Sampler& sampler() const noexcept { return sampler_; }
  float cutoff() const noexcept { return cutoff_; }

  // The alpha of texel (x, y) (0 <= x < W, 0 <= y < H) as the alpha test sees it.
  SOMM_BAKE_INLINE float texel(uint32_t x, uint32_t y) const noexcept {
    const uint8_t* p = base_ + size_t(y) * pitch_ + size_t(x) * bpp_;
    if (kind_ == Kind::U8) return lut_[*p];
    if (kind_ == Kind::U16) {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return lut_[v];
    }
    float f;
    std::memcpy(&f, p, 4);
    if (scale_ != 1.0f) f = scaled(f, scale_);
    return f;
  }
  // 8-bit texels (texel(x, y) is u8Lut()[*u8Texel(x, y)]): for loops that read many texels at known offsets, rows
  // u8Pitch() bytes apart, texels u8Step() bytes apart. Null / 0 for other formats.
  const float* u8Lut() const noexcept { return kind_ == Kind::U8 ? lut_ : nullptr; }
  const uint8_t* u8Texel(uint32_t x, uint32_t y) const noexcept {
    return base_ + size_t(y) * pitch_ + size_t(x) * bpp_;
  }
  size_t u8Pitch() const noexcept { return pitch_; }
  size_t u8Step() const noexcept { return bpp_; }
  static float scaled(float a, float scale) noexcept {
    a *= scale;
    return a < 0.0f ? 0.0f : (a > 1.0f ? 1.0f : a);  // NaN stays NaN
  }

  // Number of passing texels in the (unwrapped, inclusive) texel rectangle [x0, x1] × [y0, y1] after
  // wrapping, and the number of texels it covers (counted with multiplicity per wrapped interval).
  struct Count {
    uint64_t pass = 0, total = 0;
  };
  Count count(int64_t x0, int64_t x1, int64_t y0, int64_t y1) const noexcept;
  // Whether the same rectangle (after wrapping) holds a passing texel (bit 0) and a failing one (bit 1): what
  // count() decides uniformity by (pass > 0, pass < total), answered from the word table and the pass bits with
  // an early exit (docs/baking.md "Pass bits").
  unsigned passFail(int64_t x0, int64_t x1, int64_t y0, int64_t y1) const noexcept;

  // The alpha test of the 64 texels (x, y) .. (x + 63, y) of row y (x < W, y < H) as bits 0..63; bits for texels at
  // or beyond W are unspecified. (docs/baking.md "Pass bits".)
  SOMM_BAKE_INLINE uint64_t passBits(uint32_t x, uint32_t y) const noexcept {
    return passBitsAt(passWord(x, y), x & 63u);
  }
  // passBits in steps: the word holding texel (x, y); the next row's is passRowWords() words further on; passBitsAt(word,
  // x & 63) is passBits(x, y).
  SOMM_BAKE_INLINE const uint64_t* passWord(uint32_t x, uint32_t y) const noexcept {
    return bits_.data() + size_t(y) * words_ + (x >> 6);
  }
  size_t passRowWords() const noexcept { return words_; }
  static SOMM_BAKE_INLINE uint64_t passBitsAt(const uint64_t* word, uint32_t s) noexcept {
    return s ? (word[0] >> s) | (word[1] << (64 - s)) : word[0];
  }

  // Bytes held by the mask (its tables), for memory accounting.
  size_t memoryBytes() const noexcept {
    return wordSatSize_ * sizeof(uint32_t) + bits_.size() * sizeof(uint64_t) + lutBytes_;
  }

 private:
  enum class Kind : uint8_t { U8, U16, F32 };
  const uint8_t* base_ = nullptr;  // texel (0, 0)'s alpha channel; not owned
  size_t pitch_ = 0;
  uint32_t bpp_ = 4;
  Kind kind_ = Kind::F32;
  float scale_ = 1.0f;
  size_t lutBytes_ =
      0;  // bytes of a table made for this mask alone (a scaled view); shared tables are not counted
  const float* lut_ = nullptr;  // 8/16-bit: value → alpha (256 / 65536 entries of lutTable_)
  std::shared_ptr<const std::vector<float>>
      lutTable_;  // shared with the texture (or AlphaTexture::table), not copied
  uint32_t w_ = 0, h_ = 0;
  Sampler sampler_;
  float cutoff_ = 0.5f;
  // The word table: (h + 1)·(words_ + 1) counts, entry (y, k) = the passing texels of rows < y in words < k (the
  // summed-area table of the rows' 64-texel words; immutable once built: shared by copies).
  std::shared_ptr<uint32_t[]> wordSat_;
  size_t wordSatSize_ = 0;
  std::vector<uint64_t> bits_;  // h rows of words_ words: bit x % 64 of word x / 64 is texel x's alpha test
  size_t words_ = 0;  // w / 64 + 1 (a spare word, so passBits may read one word past the row's last texel)
  void build();
  uint64_t wordsPass(uint32_t ka, uint32_t kb, uint32_t y0, uint32_t y1) const noexcept;
  uint64_t rectPass(uint32_t x0, uint32_t x1, uint32_t y0, uint32_t y1) const noexcept;
  unsigned rectPassFail(uint32_t x0, uint32_t x1, uint32_t y0, uint32_t y1) const noexcept;
};

// A texture view's problem in one line ("texture 'leaf.png': row pitch 10 is less than width·4 = 16"), or Ok.
Status validateTexture(const TextureView& texture);

// Per-triangle result of the classifier.
struct TriangleBake {
  Micromap map;  // level/format as requested; uniform maps are left to OmmArrayBuilder to specialise
  uint64_t unknownCount = 0;  // micro-triangles left unknown by the conservative test
  // Work done (units of docs/baking.md "Work bound": nodes, rows and cells visited, leaves sampled); 0 when nothing
  // was classified. For tests of the work bound.
  uint64_t workUnits = 0;
  bool nonFiniteUv = false;
};

// Bakes one triangle with UVs uv0..uv2 at `level` (0..12). The building block of bakeGeometry, exposed for
// tests.
TriangleBake bakeTriangle(const AlphaMask& mask, std::array<float, 2> uv0, std::array<float, 2> uv1,
                          std::array<float, 2> uv2, uint32_t level, Format format,
                          UnknownAs unknownAs = UnknownAs::Majority);

// The safety margin (in texels) used for a triangle whose texel-space vertices are given: 6·2^-24·P + 2^-19·E +
// 1e-9, P = the power of two above the largest coordinate magnitude, E = the larger of the x and y extents (the
// float error bound of a ray tracer's UV interpolation and barycentrics up to 2^-20 outside a micro-triangle, see
// docs/baking.md).
double bakeMarginTexels(const double x[3], const double y[3]) noexcept;

// Adaptive level of a triangle: the smallest L in [0, maxLevel] with uvArea·W·H / 4^L <= texelsPerMicroTri
// (maxLevel when none). Zero-area and non-finite triangles get level 0.
uint32_t adaptiveLevel(std::array<float, 2> uv0, std::array<float, 2> uv1, std::array<float, 2> uv2,
                       uint32_t width, uint32_t height, float texelsPerMicroTri, uint32_t maxLevel) noexcept;

// Bakes one geometry. Materials that are not alpha-tested (OPAQUE) get FullyOpaque for every triangle; MASK
// and BLEND (a caller that bakes BLEND treats it as a mask) are baked; a material without an alpha texture
// has the constant alpha baseColorFactor[3] everywhere. Output bytes are identical for every thread count.
Result<BakedGeometry> bakeGeometry(const Geometry& geometry, const Material& material,
                                   const BakeOptions& options);

// Same, with a prepared mask for the material (nullptr when the material has no alpha texture). The mask's
// sampler and cutoff are used as they are: build it with the effective filter / cutoff (options.filter /
// cutoff are not applied).
Result<BakedGeometry> bakeGeometry(const Geometry& geometry, const Material& material, const AlphaMask* mask,
                                   const BakeOptions& options);

// ---- a whole scene: all geometries' triangles in one parallel pool ----
//
// Triangles with equal classification inputs (same mask, level and format, the same texel-space corners — exactly,
// or after removing a whole period where the wrap mode repeats — and the same margin) are classified once; masks are
// built once per distinct (texture, alphaScale, sampler, cutoff). Maps are streamed into the array as chunks of work
// finish. Output bytes are identical for every thread count.
struct GeometryBake {
  BakeStats stats;              // this geometry's triangles; uniqueMaps / dataBytes: the maps it refers to
  std::vector<uint8_t> levels;  // level per triangle (after the maxBytes cap); 0 where nothing was classified
};

struct SceneBake {
  SceneMicromaps micromaps;              // ArrayLayout::SceneWide: one array; PerGeometry: one per geometry
  std::vector<GeometryBake> geometries;  // one per input geometry
  BakeStats total;                       // uniqueMaps / dataBytes: of the arrays as stored
  uint64_t classifiedTriangles = 0;      // distinct classification inputs actually classified (last pass)
  uint64_t masks = 0, maskBytes = 0;     // alpha masks built and the memory they hold
};

Result<SceneBake> bakeScene(const BakeInputs& inputs, const BakeOptions& options);
// The same for a loaded scene (its geometries, materials and textures viewed, not copied; textures shared by
// materials are one texture). Scene alpha modes: OPAQUE → MaterialAlpha::Opaque, MASK → Tested, BLEND → Blend.
Result<SceneBake> bakeScene(const Scene& scene, const BakeOptions& options);

// Class of a region of one triangle under a prepared mask (the baker's own test, for the tracer's bitmask): the
// sub-triangle with barycentric corners b[k] = (u, v) of the triangle (uv0, uv1, uv2), grown by the bake margin of
// the whole triangle. Opaque / Transparent when every point of it passes / fails the alpha test, else
// UnknownOpaque (mixed, or a triangle with non-finite / huge UVs).
State classifyRegion(const AlphaMask& mask, std::array<float, 2> uv0, std::array<float, 2> uv1,
                     std::array<float, 2> uv2, const std::array<double, 2> b[3]) noexcept;

// What `somm bake --estimate` reports, computed from the levels alone (no classification): the data size if
// every alpha-tested triangle with finite UVs and a texture stored its own micromap (no special indices, no
// deduplication). This is an exact upper bound of the baked data size (without maxBytes).
struct BakeEstimate {
  uint64_t triangles = 0;
  uint64_t mapTriangles = 0;  // triangles that would need a micromap if not uniform
  uint64_t dataBytes = 0;     // sum of micromapDataBytes(level) over mapTriangles
  uint64_t microTriangles = 0;
  std::array<uint64_t, kMaxLevel + 1> levelHistogram{};  // over mapTriangles
};
Result<BakeEstimate> estimateBake(const Geometry& geometry, const Material& material,
                                  const BakeOptions& options);

// Checks BakeOptions ranges; the message names the option by its field ("level 13 is out of range (0..12)").
Status validateBakeOptions(const BakeOptions& options);

}  // namespace somm
