// SPDX-License-Identifier: MIT
// C API bake: the C views are checked (messages in the C API's terms), mapped 1:1 onto the library's views
// (somm/bake.h: TextureView, MaterialInput, GeometryInput) and baked by bakeScene — the same scene-level bake
// (BLEND policy, scene-wide budget, layout) that `somm bake` runs, so the output is byte-identical to the CLI's.
#include "bake_views.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "somm/bake.h"
#include "somm/scene.h"

namespace somm::capi {
namespace {

Error invalid(const std::string& m) {
  return makeError(ErrorCode::InvalidArgument, m);
}

uint32_t texelBytes(int32_t f) {
  switch (f) {
    case SOMM_TEXEL_R8:
      return 1;
    case SOMM_TEXEL_RG8:
      return 2;
    case SOMM_TEXEL_RGBA8:
      return 4;
    case SOMM_TEXEL_R16:
      return 2;
    case SOMM_TEXEL_RGBA16:
      return 8;
    case SOMM_TEXEL_R32F:
      return 4;
    default:
      return 0;
  }
}
uint32_t channels(int32_t f) {
  switch (f) {
    case SOMM_TEXEL_R8:
    case SOMM_TEXEL_R16:
    case SOMM_TEXEL_R32F:
      return 1;
    case SOMM_TEXEL_RG8:
      return 2;
    case SOMM_TEXEL_RGBA8:
    case SOMM_TEXEL_RGBA16:
      return 4;
    default:
      return 0;
  }
}

// Checks a texture view: its format, alpha channel, size against width, height and pitch, and (R32F) that no texel
// is NaN. The texels are not copied: bakeScene reads them in place through a TextureView.
Status checkTexture(const somm_texture& t, const std::string& what) {
  const int32_t format = rawEnum(t.format);
  const uint32_t tb = texelBytes(format);
  if (tb == 0) return invalid(what + ".format " + std::to_string(format) + " is not a somm_texel_format");
  if (t.alpha_channel >= channels(format))
    return invalid(what + ".alpha_channel " + std::to_string(t.alpha_channel) + " is out of range for a " +
                   std::to_string(channels(format)) + "-channel format");
  if (t.width == 0 || t.height == 0)
    return invalid(what + ": empty texture (" + std::to_string(t.width) + "x" + std::to_string(t.height) +
                   ")");
  if (uint64_t(t.width) * t.height >= (uint64_t(1) << 32))
    return makeError(ErrorCode::LimitExceeded, what + ": texture too large");
  if (!t.data) return invalid(what + ".data is NULL");
  const uint64_t rowBytes = uint64_t(t.width) * tb;
  const uint64_t pitch = t.row_pitch ? t.row_pitch : rowBytes;
  if (pitch < rowBytes)
    return invalid(what + ".row_pitch " + std::to_string(pitch) + " is less than a row (" +
                   std::to_string(rowBytes) + " bytes)");
  const uint64_t need = (uint64_t(t.height) - 1) * pitch + rowBytes;
  if (uint64_t(t.size) < need)
    return invalid(what + ".size " + std::to_string(t.size) + " is less than the " + std::to_string(need) +
                   " bytes the texture needs");
  const auto* base = static_cast<const unsigned char*>(t.data);
  if (t.format == SOMM_TEXEL_R32F)
    for (uint32_t y = 0; y < t.height; ++y)
      for (uint32_t x = 0; x < t.width; ++x) {
        float a;
        std::memcpy(&a, base + size_t(y) * pitch + size_t(x) * 4, 4);
        if (std::isnan(a))
          return invalid(what + ": texel (" + std::to_string(x) + ", " + std::to_string(y) + ") is NaN");
      }
  return Ok{};
}

Result<Sampler> convertSampler(const somm_sampler& s, const std::string& what) {
  const int32_t filter = rawEnum(s.filter);
  if (filter != SOMM_FILTER_NEAREST && filter != SOMM_FILTER_LINEAR)
    return invalid(what + ".filter " + std::to_string(filter) + " is not a somm_filter");
  for (int32_t w : {rawEnum(s.wrap_s), rawEnum(s.wrap_t)})
    if (w != SOMM_WRAP_REPEAT && w != SOMM_WRAP_CLAMP_TO_EDGE && w != SOMM_WRAP_MIRRORED_REPEAT)
      return invalid(what + ": wrap mode " + std::to_string(w) + " is not a somm_wrap");
  Sampler out;
  out.filter = Filter(s.filter);
  out.wrapS = Wrap(s.wrap_s);
  out.wrapT = Wrap(s.wrap_t);
  return out;
}

Result<Material> convertMaterial(const somm_material& m, uint32_t index, const somm_bake_options& o) {
  const std::string what = "materials[" + std::to_string(index) + "]";
  Material out;
  out.name = std::to_string(index);
  switch (rawEnum(m.alpha_mode)) {
    case SOMM_ALPHA_OPAQUE:
      out.alphaMode = AlphaMode::Opaque;
      break;
    case SOMM_ALPHA_MASK:
      out.alphaMode = AlphaMode::Mask;
      break;
    case SOMM_ALPHA_BLEND:
      out.alphaMode = o.blend == SOMM_BLEND_AS_MASK ? AlphaMode::Mask : AlphaMode::Blend;
      break;
    default:
      return invalid(what + ".alpha_mode " + std::to_string(rawEnum(m.alpha_mode)) +
                     " is not a somm_alpha_mode");
  }
  if (!(m.cutoff >= 0.0f && m.cutoff <= 1.0f)) return invalid(what + ".cutoff must be a number in [0, 1]");
  out.alphaCutoff = m.cutoff;
  auto smp = convertSampler(m.sampler, what + ".sampler");
  if (!smp) return smp.error();
  out.sampler = *smp;
  if (out.alphaMode == AlphaMode::Opaque) return out;
  if (m.texture) {
    if (Status st = checkTexture(*m.texture, what + ".texture"); !st) return st.error();
  } else {
    if (!(m.constant_alpha >= 0.0f && m.constant_alpha <= 1.0f))
      return invalid(what + ".constant_alpha must be a number in [0, 1]");
    out.baseColorFactor[3] = m.constant_alpha;
  }
  return out;
}

Result<Geometry> convertGeometry(const somm_geometry& g, uint32_t index, bool needUvs) {
  const std::string what = "geometries[" + std::to_string(index) + "]";
  Geometry out;
  out.name = std::to_string(index);
  out.material = g.material;
  const uint64_t n = g.triangle_count;
  switch (rawEnum(g.index_type)) {
    case SOMM_INDEX_NONE:
      // Checked before allocating: a huge triangle_count with few vertices is an error, not 48 GB of indices.
      if (uint64_t(g.vertex_count) < 3 * n)
        return invalid(what + ": " + std::to_string(n) + " non-indexed triangles need " +
                       std::to_string(3 * n) + " vertices, vertex_count is " +
                       std::to_string(g.vertex_count));
      out.indices.resize(size_t(3 * n));
      for (uint64_t i = 0; i < 3 * n; ++i) out.indices[size_t(i)] = uint32_t(i);
      break;
    case SOMM_INDEX_UINT16:
    case SOMM_INDEX_UINT32: {
      if (n && !g.indices) return invalid(what + ".indices is NULL");
      out.indices.resize(size_t(3 * n));  // the caller's buffer holds 3n indices of 2 or 4 bytes
      const auto* p = static_cast<const unsigned char*>(g.indices);
      for (uint64_t i = 0; i < 3 * n; ++i) {
        uint32_t v;
        if (g.index_type == SOMM_INDEX_UINT16) {
          uint16_t s;
          std::memcpy(&s, p + 2 * i, 2);
          v = s;
        } else {
          std::memcpy(&v, p + 4 * i, 4);
        }
        if (v >= g.vertex_count)
          return invalid(what + ": index " + std::to_string(v) + " of triangle " + std::to_string(i / 3) +
                         " is out of range (vertex_count " + std::to_string(g.vertex_count) + ")");
        out.indices[size_t(i)] = v;
      }
      break;
    }
    default:
      return invalid(what + ".index_type " + std::to_string(rawEnum(g.index_type)) +
                     " is not a somm_index_type");
  }
  if (!needUvs) return out;
  const size_t stride = g.uv_stride ? g.uv_stride : 2 * sizeof(float);
  if (stride < 2 * sizeof(float))
    return invalid(what + ".uv_stride " + std::to_string(stride) + " is less than two floats");
  if (g.vertex_count && !g.uvs) return invalid(what + ".uvs is NULL");
  out.uvs.resize(size_t(2) * g.vertex_count);
  const auto* uv = reinterpret_cast<const unsigned char*>(g.uvs);
  for (uint32_t v = 0; v < g.vertex_count; ++v)
    std::memcpy(&out.uvs[2 * size_t(v)], uv + size_t(v) * stride, 8);
  return out;
}

Status validateOptions(const somm_bake_options& o) {
  if (o.level > kMaxLevel)
    return invalid("options.level " + std::to_string(o.level) + " is out of range 0..12");
  if (o.max_level > kMaxLevel)
    return invalid("options.max_level " + std::to_string(o.max_level) + " is out of range 0..12");
  if (!(o.texels_per_micro_triangle >= 0.0f) || !std::isfinite(o.texels_per_micro_triangle))
    return invalid("options.texels_per_micro_triangle must be a finite number >= 0");
  const int32_t format = rawEnum(o.format), unknownAs = rawEnum(o.unknown_as), blend = rawEnum(o.blend),
                layout = rawEnum(o.layout);
  if (format != SOMM_FORMAT_2_STATE && format != SOMM_FORMAT_4_STATE)
    return invalid("options.format " + std::to_string(format) + " is not a somm_format");
  if (unknownAs != SOMM_UNKNOWN_AS_MAJORITY && unknownAs != SOMM_UNKNOWN_AS_OPAQUE &&
      unknownAs != SOMM_UNKNOWN_AS_TRANSPARENT)
    return invalid("options.unknown_as " + std::to_string(unknownAs) + " is not a somm_unknown_as");
  if (blend != SOMM_BLEND_UNKNOWN && blend != SOMM_BLEND_AS_MASK)
    return invalid("options.blend " + std::to_string(blend) + " is not a somm_blend_policy");
  if (layout != SOMM_ARRAY_PER_GEOMETRY && layout != SOMM_ARRAY_PER_SCENE)
    return invalid("options.layout " + std::to_string(layout) + " is not a somm_array_layout");
  return Ok{};
}

}  // namespace

Result<SceneBake> bakeFromViews(const somm_bake_input& in, const somm_bake_options& o) {
  if (Status s = validateOptions(o); !s) return s.error();
  if (in.geometry_count && !in.geometries) return invalid("input.geometries is NULL");
  if (in.material_count && !in.materials) return invalid("input.materials is NULL");

  // Check the views the library cannot check itself (texture sizes, enum values, index ranges), then map them.
  std::vector<std::string> names;
  names.reserve(size_t(in.material_count) + in.geometry_count);
  std::vector<TextureView> textures;
  std::vector<MaterialInput> materials(in.material_count);
  for (uint32_t m = 0; m < in.material_count; ++m) {
    const somm_material& cm = in.materials[m];
    const std::string what = "materials[" + std::to_string(m) + "]";
    // convertMaterial checks every field (and, for a texture, its size against width, height, pitch and format).
    auto checked = convertMaterial(cm, m, o);
    if (!checked) return checked.error();
    MaterialInput& mi = materials[m];
    names.push_back(what);
    mi.name = names.back().c_str();
    mi.alpha = cm.alpha_mode == SOMM_ALPHA_OPAQUE  ? MaterialAlpha::Opaque
               : cm.alpha_mode == SOMM_ALPHA_BLEND ? MaterialAlpha::Blend
                                                   : MaterialAlpha::Tested;
    mi.cutoff = cm.cutoff;
    mi.constantAlpha = cm.constant_alpha;
    mi.sampler = checked->sampler;
    if (cm.texture && cm.alpha_mode != SOMM_ALPHA_OPAQUE) {
      const somm_texture& t = *cm.texture;
      TextureView v;
      v.data = t.data;
      v.width = t.width;
      v.height = t.height;
      v.rowPitch = t.row_pitch;
      v.format = t.format == SOMM_TEXEL_R8       ? TexelFormat::R8
                 : t.format == SOMM_TEXEL_RG8    ? TexelFormat::RG8
                 : t.format == SOMM_TEXEL_RGBA8  ? TexelFormat::RGBA8
                 : t.format == SOMM_TEXEL_R16    ? TexelFormat::R16
                 : t.format == SOMM_TEXEL_RGBA16 ? TexelFormat::RGBA16
                                                 : TexelFormat::R32F;
      v.alphaChannel = t.alpha_channel;
      v.name = mi.name;
      mi.texture = int32_t(textures.size());
      textures.push_back(v);
    }
  }
  std::vector<GeometryInput> geometries(in.geometry_count);
  for (uint32_t g = 0; g < in.geometry_count; ++g) {
    const somm_geometry& v = in.geometries[g];
    const std::string what = "geometries[" + std::to_string(g) + "]";
    if (v.material >= in.material_count)
      return invalid(what + ".material " + std::to_string(v.material) + " is out of range (" +
                     std::to_string(in.material_count) + " materials)");
    const somm_material& m = in.materials[v.material];
    const bool needUvs = m.texture && m.alpha_mode != SOMM_ALPHA_OPAQUE &&
                         (m.alpha_mode != SOMM_ALPHA_BLEND || o.blend == SOMM_BLEND_AS_MASK);
    auto checked = convertGeometry(v, g, needUvs);  // index ranges, strides, NULL pointers
    if (!checked) return checked.error();
    GeometryInput& gi = geometries[g];
    names.push_back(what);
    gi.name = names.back().c_str();
    gi.uvs = v.uvs;
    gi.uvStride = v.uv_stride;
    gi.vertexCount = v.vertex_count;
    gi.indices = v.indices;
    gi.indexFormat = v.index_type == SOMM_INDEX_UINT16   ? IndexFormat::UInt16
                     : v.index_type == SOMM_INDEX_UINT32 ? IndexFormat::UInt32
                                                         : IndexFormat::None;
    gi.triangleCount = v.triangle_count;
    gi.material = v.material;
    if (!needUvs) gi.uvs = nullptr, gi.uvStride = 0;
  }
  const BakeInputs inputs = BakeInputs::of(textures, materials, geometries);

  BakeOptions bo;
  bo.level = o.level;
  if (o.texels_per_micro_triangle > 0) {
    bo.maxLevel = o.max_level;
    bo.texelsPerMicroTri = o.texels_per_micro_triangle;
  }
  bo.format = o.format == SOMM_FORMAT_2_STATE ? Format::TwoState : Format::FourState;
  bo.unknownAs = UnknownAs(o.unknown_as);
  bo.maxBytes = o.max_bytes;
  bo.threads = o.threads;
  bo.blend = o.blend == SOMM_BLEND_AS_MASK ? BlendAs::Mask : BlendAs::Unknown;
  bo.layout = o.layout == SOMM_ARRAY_PER_GEOMETRY ? ArrayLayout::PerGeometry : ArrayLayout::SceneWide;
  if (o.progress) bo.progress = [&o](double f) -> bool { return o.progress(f, o.progress_user) == 0; };
  auto baked = bakeScene(inputs, bo);
  if (!baked) return baked.error();

  SceneBake out;
  out.format = bo.format;
  out.levelCap = baked->total.levelCap;
  out.micromaps = std::move(baked->micromaps);
  out.geometries.reserve(baked->geometries.size());
  for (const GeometryBake& g : baked->geometries) {
    GeometryBakeInfo info;
    info.specialCount = g.stats.specialCount;
    info.microTriangles = g.stats.microTriangles;
    info.unknownMicroTriangles = g.stats.unknownMicroTriangles;
    info.nonFiniteUvTriangles = g.stats.nonFiniteUvTriangles;
    info.minLevel = g.stats.minLevel;
    info.maxLevel = g.stats.maxLevel;
    out.geometries.push_back(info);
  }
  return out;
}

}  // namespace somm::capi
