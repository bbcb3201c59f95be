// SPDX-License-Identifier: MIT
// somm — glTF 2.0 (.gltf / .glb) loading via tinygltf. tinygltf parses the JSON and the buffers; everything
// else (accessor bounds, images, node hierarchy) is validated and converted here, so malformed files give
// errors, not crashes.
#include <sys/stat.h>
#include <tbb/parallel_for.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <utility>

#include "image_io.h"
#include "loaders.h"
#include "somm/io.h"

namespace somm::detail {

namespace {

using Mat4 = std::array<double, 16>;  // column-major

constexpr Mat4 kIdentity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

// double → float without undefined behaviour for values beyond the float range (they become ±inf).
float narrow(double v) {
  if (v > double(FLT_MAX)) return INFINITY;
  if (v < -double(FLT_MAX)) return -INFINITY;
  return float(v);
}

Mat4 mul(const Mat4& a, const Mat4& b) {
  Mat4 c{};
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + row] * b[col * 4 + k];
      c[col * 4 + row] = s;
    }
  return c;
}

Mat4 localTransform(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) {
    Mat4 m;
    std::copy(n.matrix.begin(), n.matrix.end(), m.begin());
    return m;
  }
  double t[3] = {0, 0, 0}, s[3] = {1, 1, 1}, q[4] = {0, 0, 0, 1};
  if (n.translation.size() == 3) std::copy(n.translation.begin(), n.translation.end(), t);
  if (n.scale.size() == 3) std::copy(n.scale.begin(), n.scale.end(), s);
  if (n.rotation.size() == 4) std::copy(n.rotation.begin(), n.rotation.end(), q);
  const double x = q[0], y = q[1], z = q[2], w = q[3];
  const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                          {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                          {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
  Mat4 m{};
  for (int col = 0; col < 3; ++col)
    for (int row = 0; row < 3; ++row) m[col * 4 + row] = r[row][col] * s[col];
  m[12] = t[0], m[13] = t[1], m[14] = t[2], m[15] = 1;
  return m;
}

// Keeps images encoded: bytes of URI images are stored as-is; bufferView images are decoded later by us
// (tinygltf does not bounds-check their buffer views).
bool keepEncoded(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                 const unsigned char* bytes, int size, void*) {
  if (image->bufferView < 0 && bytes && size > 0) image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

// tinygltf's external files (buffers; images are kept encoded and read again by us) go through these callbacks.
// tinygltf joins its base directory with the URI and then tries "./URI" in the current directory: an absolute
// URI ("/dev/zero") became "DIR//dev/zero", was not found there, and was then looked up relative to the current
// directory ("File not found : /dev/zero", or a file of the caller's directory read instead). So tinygltf gets an
// empty base directory, every candidate "exists", and the path is resolved here: absolute URIs as they are,
// relative ones against the glTF's directory only; the read itself reports what is wrong (missing, not a regular
// file, too large), and that message, naming the file, becomes the load error.
struct ExternalFiles {
  const Limits* limits = nullptr;
  std::filesystem::path dir;  // the glTF's directory
  std::string error;          // the first failed read: "<path>: <problem>"
  ErrorCode errorCode = ErrorCode::IoError;
  std::vector<std::string> read;  // the files read (Scene::inputFiles)
};

// No shell-style expansion of URIs (tinygltf's default uses wordexp): resolve against the glTF's directory.
std::string resolveUri(const std::string& p, void* user) {
  const auto& files = *static_cast<const ExternalFiles*>(user);
  std::filesystem::path uri(p);
  if (uri.is_absolute()) return p;
  if (p.rfind("./", 0) == 0) uri = p.substr(2);  // tinygltf's second candidate: the same file
  return (files.dir / uri).string();
}

// tinygltf's FileExists opens the file (a FIFO would block): the read decides instead.
bool existsAlways(const std::string&, void*) {
  return true;
}

bool isImagePath(const std::string& p) {
  std::string ext = std::filesystem::path(p).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tga" || ext == ".bmp" ||
         ext == ".gif" || ext == ".psd" || ext == ".hdr" || ext == ".pic" || ext == ".pnm" || ext == ".ppm" ||
         ext == ".pgm";
}

// External buffers and images: regular files only, at most the cap of their kind.
bool readExternal(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  auto& files = *static_cast<ExternalFiles*>(user);
  const bool image = isImagePath(path);
  auto bytes = image
                   ? readRegularFile(path, files.limits->imageFileBytes, "image", "file-bytes.image")
                   : readRegularFile(path, files.limits->bufferFileBytes, "glTF buffer", "file-bytes.buffer");
  if (!bytes) {
    if (!image && files.error.empty()) {  // images are read again, with their own errors
      files.error = "buffer " + bytes.error().message;
      files.errorCode = bytes.error().code;
    }
    if (err) *err += bytes.error().message + "\n";
    return false;
  }
  *out = std::move(bytes.value());
  files.read.push_back(path);
  return true;
}

// Nesting depth of the JSON arrays and objects in `text` (strings skipped), stopping once beyond `limit`.
uint32_t jsonDepth(const char* p, size_t n, uint32_t limit) {
  uint32_t depth = 0, deepest = 0;
  bool inString = false;
  for (size_t i = 0; i < n; ++i) {
    const char c = p[i];
    if (inString) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        inString = false;
      continue;
    }
    if (c == '"')
      inString = true;
    else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > limit) return deepest;
    } else if ((c == ']' || c == '}') && depth > 0)
      --depth;
  }
  return deepest;
}

// Properties tinygltf reads as unsigned integers but silently ignores (as 0 / absent) when negative or not an
// integer: refuse those, naming the property. `j` is the parsed document (nesting already bounded).
std::string badUnsigned(const nlohmann::json& j) {
  static const struct {
    const char* array;
    const char* keys[5];
  } kChecks[] = {{"bufferViews", {"buffer", "byteOffset", "byteLength", "byteStride", nullptr}},
                 {"accessors", {"bufferView", "byteOffset", "count", "componentType", nullptr}},
                 {"buffers", {"byteLength", nullptr}},
                 {"images", {"bufferView", nullptr}},
                 {"nodes", {"mesh", "camera", nullptr}}};
  if (!j.is_object()) return {};
  for (const auto& c : kChecks) {
    auto it = j.find(c.array);
    if (it == j.end() || !it->is_array()) continue;
    for (size_t i = 0; i < it->size(); ++i) {
      const nlohmann::json& e = (*it)[i];
      if (!e.is_object()) continue;
      for (const char* const* k = c.keys; *k; ++k) {
        auto v = e.find(*k);
        if (v != e.end() && !v->is_number_unsigned())
          return std::string(c.array) + "[" + std::to_string(i) + "]." + *k + " is " +
                 (v->is_number() ? "negative or not an integer" : "not a number");
      }
    }
  }
  return {};
}

// A validated accessor: element i starts at base + i * stride. base == nullptr: all zeros (no bufferView).
struct AccessorView {
  const uint8_t* base = nullptr;
  size_t stride = 0, count = 0;
  int componentType = 0, components = 0;
  bool normalized = false;

  double component(size_t i, int c) const noexcept {
    if (!base) return 0.0;
    const uint8_t* p = base + i * stride;
    switch (componentType) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float v;
        std::memcpy(&v, p + 4 * c, 4);
        return v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
        const uint8_t v = p[c];
        return normalized ? v / 255.0 : double(v);
      }
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        int8_t v;
        std::memcpy(&v, p + c, 1);
        return normalized ? std::max(v / 127.0, -1.0) : double(v);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p + 2 * c, 2);
        return normalized ? v / 65535.0 : double(v);
      }
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t v;
        std::memcpy(&v, p + 2 * c, 2);
        return normalized ? std::max(v / 32767.0, -1.0) : double(v);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t v;
        std::memcpy(&v, p + 4 * c, 4);
        return double(v);
      }
      default:
        return 0.0;
    }
  }
  uint32_t index(size_t i) const noexcept {
    if (!base) return 0;
    const uint8_t* p = base + i * stride;
    switch (componentType) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return p[0];
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return v;
      }
      default: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return v;
      }
    }
  }
};

class GltfLoader {
 public:
  GltfLoader(std::string path, const LoadOptions& opts) : path_(std::move(path)), opts_(opts) {}
  uint64_t droppedNonFinite() const { return droppedNonFinite_; }

  Result<Scene> run(bool binary);

 private:
  Error fail(ErrorCode code, const std::string& what) const { return makeError(code, path_ + ": " + what); }

  Result<AccessorView> view(int accessor, const std::string& what, int expectType) const;
  Status loadMaterials();
  Status loadMaterial(size_t index);
  Status finishImages();
  Status loadGeometries();
  Status loadInstances();
  Status requestImage(int imageIndex, const std::string& materialName, bool color, std::optional<float> alpha,
                      size_t material);

  // One image the materials take something from. The materials are read in order first (requestImage: the image's
  // bytes found and its header checked and charged against limits.decodedImageBytes in the order the materials reach
  // it, as a serial loader would), then the requested images are decoded and converted in parallel (largest first;
  // each decoded image is freed once converted, so at most one per thread is alive) and finishImages() hands the
  // conversions to the materials. A decode error is reported as at the first material that takes the image: before a
  // later material's error, as a serial loader would.
  struct ImagePlan {
    size_t firstMaterial = 0;
    std::string context;  // "material 'NAME': texture WHERE" for errors
    const uint8_t* data = nullptr;
    size_t size = 0;
    ImageHeader header;          // checkImage's (checked and charged by requestImage)
    std::vector<uint8_t> owned;  // an external file tinygltf did not read (read by us instead)
    bool color = false;
    std::vector<float> alphaFactors;  // one alpha texture per distinct factor
    // Results (written by the task).
    std::optional<Error> error;
    std::shared_ptr<const ColorImage> colorImage;
    std::vector<std::shared_ptr<const AlphaTexture>> alpha;  // per alphaFactors entry
  };
  struct MaterialImage {
    size_t material = 0, plan = 0;
    bool color = false;
    std::optional<float> alpha;
  };
  std::vector<ImagePlan> plans_;
  std::map<int, size_t> planOf_;  // image index -> plans_ entry
  std::vector<MaterialImage> materialImages_;
  // A material's error found while reading them in order (it is reported unless an image that an earlier material
  // takes fails to decode) and the material it was found at.
  std::optional<Error> materialError_;
  size_t materialErrorAt_ = 0;

  struct MatInfo {
    int texCoord = 0;
    bool transform = false;
    double m[6] = {1, 0, 0, 0, 1, 0};  // u' = m0 u + m1 v + m2, v' = m3 u + m4 v + m5
    bool alphaFromTexture = false;
  };

  std::string path_;
  LoadOptions opts_;
  // Non-finite position components read but not kept (LoadOptions::loadPositions false).
  uint64_t droppedNonFinite_ = 0;
  tinygltf::Model model_;
  Scene scene_;
  std::vector<MatInfo> matInfo_;
  int defaultMaterial_ = -1;
  std::vector<uint32_t> firstGeometry_;  // per mesh
  size_t bufferBytes_ = 0;
  uint64_t materialised_ = 0;
  uint64_t decoded_ = 0;  // decoded image bytes so far (limits.decodedImageBytes)
  Status charge(const std::string& what, size_t vertices, size_t indices);
};

Status GltfLoader::charge(const std::string& what, size_t vertices, size_t indices) {
  if (bufferBytes_ == 0)
    for (const tinygltf::Buffer& b : model_.buffers) bufferBytes_ += b.data.size();
  // 20 bytes per vertex (xyz + uv floats), 4 per index.
  materialised_ += uint64_t(vertices) * 20 + uint64_t(indices) * 4;
  const uint64_t limit = (uint64_t(64) << 20) + 16 * uint64_t(bufferBytes_);
  if (materialised_ > limit)
    return fail(ErrorCode::LimitExceeded, what + ": the scene's vertices and indices would take " +
                                              std::to_string(materialised_) + " bytes, more than 16x its " +
                                              std::to_string(bufferBytes_) + " buffer bytes + 64 MiB");
  return Ok{};
}

Result<AccessorView> GltfLoader::view(int index, const std::string& what, int expectType) const {
  if (index < 0 || size_t(index) >= model_.accessors.size())
    return fail(ErrorCode::CorruptFile, what + ": accessor " + std::to_string(index) + " does not exist");
  const tinygltf::Accessor& a = model_.accessors[size_t(index)];
  const std::string name = what + " (accessor " + std::to_string(index) + ")";
  if (a.type != expectType) return fail(ErrorCode::CorruptFile, name + ": wrong accessor type");
  const int compSize = tinygltf::GetComponentSizeInBytes(uint32_t(a.componentType));
  const int comps = tinygltf::GetNumComponentsInType(uint32_t(a.type));
  if (compSize <= 0 || compSize > 4 || comps <= 0)
    return fail(ErrorCode::CorruptFile, name + ": invalid component type " + std::to_string(a.componentType));
  if (a.sparse.isSparse)
    return fail(ErrorCode::UnsupportedFormat, name + ": sparse accessors are not supported");
  AccessorView v;
  v.count = a.count;
  v.componentType = a.componentType;
  v.components = comps;
  v.normalized = a.normalized;
  const size_t elem = size_t(compSize) * size_t(comps);
  if (a.bufferView < 0) {
    // All zeros, backed by no data: bounded by a constant, not by the file (docs/hardening.md, memory bounds).
    if (a.count > (size_t(1) << 20)) return fail(ErrorCode::LimitExceeded, name + ": too many elements");
    return v;  // all zeros
  }
  if (size_t(a.bufferView) >= model_.bufferViews.size())
    return fail(ErrorCode::CorruptFile,
                name + ": buffer view " + std::to_string(a.bufferView) + " does not exist");
  const tinygltf::BufferView& bv = model_.bufferViews[size_t(a.bufferView)];
  if (bv.buffer < 0 || size_t(bv.buffer) >= model_.buffers.size())
    return fail(ErrorCode::CorruptFile, name + ": buffer " + std::to_string(bv.buffer) + " does not exist");
  const tinygltf::Buffer& buf = model_.buffers[size_t(bv.buffer)];
  if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset)
    return fail(ErrorCode::CorruptFile, name + ": buffer view " + std::to_string(a.bufferView) +
                                            " extends past the end of its buffer");
  const size_t stride = bv.byteStride ? bv.byteStride : elem;
  if (stride < elem || stride > 1024)
    return fail(ErrorCode::CorruptFile, name + ": invalid byte stride " + std::to_string(bv.byteStride));
  if (a.count > 0) {
    // offset + stride * (count - 1) + elem <= byteLength, without overflow.
    if (a.byteOffset > bv.byteLength || a.count - 1 > bv.byteLength / stride ||
        stride * (a.count - 1) > bv.byteLength - a.byteOffset ||
        elem > bv.byteLength - a.byteOffset - stride * (a.count - 1))
      return fail(ErrorCode::CorruptFile, name + ": " + std::to_string(a.count) +
                                              " elements extend past the end of buffer view " +
                                              std::to_string(a.bufferView));
  }
  v.base = buf.data.data() + bv.byteOffset + a.byteOffset;
  v.stride = stride;
  return v;
}

Status GltfLoader::requestImage(int index, const std::string& matName, bool color, std::optional<float> alpha,
                                size_t material) {
  auto known = planOf_.find(index);
  if (known == planOf_.end()) {
    const std::string ctx = "material '" + matName + "'";
    if (index < 0 || size_t(index) >= model_.images.size())
      return fail(ErrorCode::CorruptFile, ctx + ": image " + std::to_string(index) + " does not exist");
    const tinygltf::Image& im = model_.images[size_t(index)];
    ImagePlan plan;
    plan.firstMaterial = material;
    std::string where;
    if (im.bufferView >= 0) {
      where = "image " + std::to_string(index) + " (buffer view " + std::to_string(im.bufferView) + ")";
      if (size_t(im.bufferView) >= model_.bufferViews.size())
        return fail(ErrorCode::CorruptFile, ctx + ": " + where + " does not exist");
      const tinygltf::BufferView& bv = model_.bufferViews[size_t(im.bufferView)];
      if (bv.buffer < 0 || size_t(bv.buffer) >= model_.buffers.size())
        return fail(ErrorCode::CorruptFile, ctx + ": " + where + ": buffer does not exist");
      const tinygltf::Buffer& buf = model_.buffers[size_t(bv.buffer)];
      if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset)
        return fail(ErrorCode::CorruptFile, ctx + ": " + where + " extends past the end of its buffer");
      plan.data = buf.data.data() + bv.byteOffset;
      plan.size = bv.byteLength;
    } else if (tinygltf::IsDataURI(im.uri) || (im.uri.empty() && !im.image.empty())) {
      where = "image " + std::to_string(index) + " (data URI)";
      plan.data = im.image.data();
      plan.size = im.image.size();
    } else {
      const std::filesystem::path base = std::filesystem::path(path_).parent_path();
      where = "'" + (base / im.uri).string() + "'";
      if (!color && !alpha) return Ok{};  // (below: read only when needed)
      if (im.image.empty()) {
        // tinygltf only warns when an external image is missing: try ourselves, for the reason of the failure.
        scene_.inputFiles.push_back((base / im.uri).string());
        auto bytes = readImageBytes((base / im.uri).string(), opts_.limits);
        if (!bytes.ok())
          return fail(bytes.error().code, ctx + ": texture " + where + ": " + bytes.error().message);
        plan.owned = std::move(bytes.value());
        plan.data = plan.owned.data();
        plan.size = plan.owned.size();
      } else {
        plan.data = im.image.data();
        plan.size = im.image.size();
      }
    }
    // Nothing taken from it (an opaque material's texture when colours are not loaded): checked where it lies, not
    // decoded.
    if (!color && !alpha) return Ok{};
    plan.context = ctx + ": texture " + where;
    // The header's checks and the decoded-bytes charge, in the order the materials reach the images.
    auto h = checkImage(plan.data, plan.size, opts_.limits, &decoded_);
    if (!h.ok()) return fail(h.error().code, plan.context + ": " + h.error().message);
    plan.header = *h;
    known = planOf_.emplace(index, plans_.size()).first;
    plans_.push_back(std::move(plan));
  }
  ImagePlan& plan = plans_[known->second];
  plan.color |= color;
  if (alpha &&
      std::find(plan.alphaFactors.begin(), plan.alphaFactors.end(), *alpha) == plan.alphaFactors.end())
    plan.alphaFactors.push_back(*alpha);
  materialImages_.push_back(MaterialImage{material, known->second, color, alpha});
  return Ok{};
}

Status GltfLoader::loadMaterials() {
  for (size_t i = 0; i < model_.materials.size(); ++i) {
    if (Status st = loadMaterial(i); !st.ok()) {
      materialError_ = st.error();
      materialErrorAt_ = i;
      break;
    }
  }
  // Largest first (in order at one thread; at two, the second takes the next largest while the first decodes): the
  // largest decode transient comes while few conversions are held, the small images fill in at the end. Decoding
  // while the geometry is read as well gained nothing measurable (TORCS forza as glTF, level 6, two threads) and
  // held both at once (+1.5 MB peak).
  std::vector<size_t> order(plans_.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return plans_[a].size > plans_[b].size; });
  tbb::parallel_for(
      size_t(0), order.size(),
      [&](size_t k) {
        ImagePlan& p = plans_[order[k]];
        if (!p.color) {
          // The alpha alone (`somm bake`): when the image is a PNG with an alpha channel, only that is decoded (one
          // texture per factor from the same bytes, as toAlphaTexture makes them).
          if (auto a = decodeAlphaFast(p.data, p.size, p.header, AlphaChannel::AlphaOrOne, p.alphaFactors[0],
                                       false)) {
            for (size_t f = 1; f < p.alphaFactors.size(); ++f)
              p.alpha.push_back(std::make_shared<const AlphaTexture>(
                  AlphaTexture::fromUInt8(a->width, a->height, a->alpha8, p.alphaFactors[f])));
            p.alpha.insert(p.alpha.begin(), std::make_shared<const AlphaTexture>(std::move(*a)));
            return;
          }
        }
        Result<RawImage> raw = decodeImage(p.data, p.size, opts_.limits, nullptr);  // charged by requestImage
        if (!raw.ok()) {
          p.error = raw.error();
          return;
        }
        const RawImage& img = raw.value();
        if (p.color) p.colorImage = std::make_shared<const ColorImage>(toColorImage(img, false));
        for (float f : p.alphaFactors)
          p.alpha.push_back(
              std::make_shared<const AlphaTexture>(toAlphaTexture(img, AlphaChannel::AlphaOrOne, f, false)));
      },
      tbb::simple_partitioner());
  return finishImages();
}

Status GltfLoader::finishImages() {
  // The first failing image in the order the materials reach them.
  const ImagePlan* failed = nullptr;
  for (const ImagePlan& p : plans_)
    if (p.error && (!failed || p.firstMaterial < failed->firstMaterial)) failed = &p;
  if (failed && (!materialError_ || failed->firstMaterial < materialErrorAt_))
    return fail(failed->error->code, failed->context + ": " + failed->error->message);
  if (materialError_) return *materialError_;
  for (const MaterialImage& mi : materialImages_) {
    const ImagePlan& p = plans_[mi.plan];
    Material& m = scene_.materials[mi.material];
    if (mi.color) m.baseColor = p.colorImage;
    if (mi.alpha) {
      const size_t k =
          size_t(std::find(p.alphaFactors.begin(), p.alphaFactors.end(), *mi.alpha) - p.alphaFactors.begin());
      m.alpha = p.alpha[k];
    }
  }
  plans_.clear();  // the encoded bytes we read ourselves, the plans' references
  planOf_.clear();
  materialImages_.clear();
  return Ok{};
}

Status GltfLoader::loadMaterial(size_t i) {
  {
    const tinygltf::Material& gm = model_.materials[i];
    Material m;
    m.name = gm.name.empty() ? "material" + std::to_string(i) : gm.name;
    m.doubleSided = gm.doubleSided;
    const auto& f = gm.pbrMetallicRoughness.baseColorFactor;
    auto finiteFloat = [](double v) { return std::isfinite(v) && std::abs(v) <= double(FLT_MAX); };
    if (f.size() == 4) {
      for (int c = 0; c < 4; ++c) {
        if (!finiteFloat(f[size_t(c)]))
          return fail(ErrorCode::CorruptFile, "material '" + m.name + "': invalid baseColorFactor");
        m.baseColorFactor[size_t(c)] = float(f[size_t(c)]);
      }
    }
    if (!finiteFloat(gm.alphaCutoff) || gm.alphaCutoff < 0)
      return fail(ErrorCode::CorruptFile, "material '" + m.name + "': invalid alphaCutoff");
    m.alphaCutoff = float(gm.alphaCutoff);
    if (gm.alphaMode == "MASK") {
      m.alphaMode = AlphaMode::Mask;
    } else if (gm.alphaMode == "BLEND") {
      if (opts_.blendAsMask) {
        m.alphaMode = AlphaMode::Mask;
      } else {
        m.alphaMode = AlphaMode::Blend;
        scene_.warnings.push_back(
            "material '" + m.name +
            "' uses alphaMode BLEND: not alpha-tested, no micromaps (--blend-as-mask bakes it as MASK)");
      }
    } else if (gm.alphaMode.empty() || gm.alphaMode == "OPAQUE") {
      m.alphaMode = AlphaMode::Opaque;
    } else {
      scene_.warnings.push_back("material '" + m.name + "': unknown alphaMode '" + gm.alphaMode +
                                "', treated as OPAQUE");
    }

    MatInfo info;
    const tinygltf::TextureInfo& ti = gm.pbrMetallicRoughness.baseColorTexture;
    info.texCoord = std::max(ti.texCoord, 0);
    if (ti.index >= 0) {
      if (size_t(ti.index) >= model_.textures.size())
        return fail(ErrorCode::CorruptFile,
                    "material '" + m.name + "': texture " + std::to_string(ti.index) + " does not exist");
      const tinygltf::Texture& tex = model_.textures[size_t(ti.index)];
      if (tex.source < 0)
        return fail(
            ErrorCode::UnsupportedFormat,
            "material '" + m.name + "': base colour texture has no image source (unsupported extension?)");
      if (tex.sampler >= 0) {
        if (size_t(tex.sampler) >= model_.samplers.size())
          return fail(ErrorCode::CorruptFile, "material '" + m.name + "': sampler " +
                                                  std::to_string(tex.sampler) + " does not exist");
        const tinygltf::Sampler& s = model_.samplers[size_t(tex.sampler)];
        auto wrap = [](int w) {
          return w == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE     ? Wrap::ClampToEdge
                 : w == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT ? Wrap::MirroredRepeat
                                                              : Wrap::Repeat;
        };
        m.sampler.wrapS = wrap(s.wrapS);
        m.sampler.wrapT = wrap(s.wrapT);
        m.sampler.filter = s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST ? Filter::Nearest : Filter::Linear;
      }
      // KHR_texture_transform: uv' = T · R · S · uv.
      auto ext = ti.extensions.find("KHR_texture_transform");
      if (ext != ti.extensions.end() && ext->second.IsObject()) {
        const tinygltf::Value& v = ext->second;
        double off[2] = {0, 0}, sc[2] = {1, 1}, rot = 0;
        auto num2 = [&](const char* key, double out[2]) {
          if (!v.Has(key)) return true;
          const tinygltf::Value& a = v.Get(key);
          if (!a.IsArray() || a.ArrayLen() != 2 || !a.Get(0).IsNumber() || !a.Get(1).IsNumber()) return false;
          out[0] = a.Get(0).GetNumberAsDouble(), out[1] = a.Get(1).GetNumberAsDouble();
          return true;
        };
        bool good = num2("offset", off) && num2("scale", sc);
        if (v.Has("rotation")) {
          if (v.Get("rotation").IsNumber())
            rot = v.Get("rotation").GetNumberAsDouble();
          else
            good = false;
        }
        if (v.Has("texCoord")) {
          if (v.Get("texCoord").IsInt() && v.Get("texCoord").GetNumberAsInt() >= 0)
            info.texCoord = v.Get("texCoord").GetNumberAsInt();
          else
            good = false;
        }
        if (!good)
          return fail(ErrorCode::CorruptFile, "material '" + m.name + "': malformed KHR_texture_transform");
        const double c = std::cos(rot), s = std::sin(rot);
        info.transform = true;
        info.m[0] = c * sc[0], info.m[1] = s * sc[1], info.m[2] = off[0];
        info.m[3] = -s * sc[0], info.m[4] = c * sc[1], info.m[5] = off[1];
      }
      // Decoded later (loadMaterials' tasks) only when something is taken from it: the colour when the caller loads
      // colours, the alpha for the alpha test.
      if (Status st =
              requestImage(tex.source, m.name, opts_.loadColor,
                           m.alphaTested() ? std::optional<float>(m.baseColorFactor[3]) : std::nullopt, i);
          !st.ok())
        return st;
      const tinygltf::Image& gi = model_.images[size_t(tex.source)];
      m.alphaSource = gi.uri.empty() || tinygltf::IsDataURI(gi.uri)
                          ? "image " + std::to_string(tex.source)
                          : (std::filesystem::path(path_).parent_path() / gi.uri).string();
      info.alphaFromTexture = m.alphaTested();
    }
    scene_.materials.push_back(std::move(m));
    matInfo_.push_back(info);
  }
  return Ok{};
}

Status GltfLoader::loadGeometries() {
  size_t skipped = 0, dropped = 0;
  for (size_t mi = 0; mi < model_.meshes.size(); ++mi) {
    const tinygltf::Mesh& mesh = model_.meshes[mi];
    firstGeometry_.push_back(uint32_t(scene_.geometries.size()));
    const std::string meshName = mesh.name.empty() ? "mesh" + std::to_string(mi) : mesh.name;
    for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
      const tinygltf::Primitive& prim = mesh.primitives[pi];
      Geometry g;
      g.name = meshName + "/" + std::to_string(pi);
      const std::string what = "mesh '" + meshName + "' primitive " + std::to_string(pi);
      if (prim.material >= 0) {
        if (size_t(prim.material) >= scene_.materials.size())
          return fail(ErrorCode::CorruptFile,
                      what + ": material " + std::to_string(prim.material) + " does not exist");
        g.material = uint32_t(prim.material);
      } else {
        if (defaultMaterial_ < 0) {
          defaultMaterial_ = int(scene_.materials.size());
          Material d;
          d.name = "default";
          scene_.materials.push_back(d);
          matInfo_.push_back(MatInfo{});
        }
        g.material = uint32_t(defaultMaterial_);
      }
      const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
      if (mode != TINYGLTF_MODE_TRIANGLES) {
        ++skipped;
        scene_.warnings.push_back(what + ": primitive mode " + std::to_string(mode) +
                                  " is not TRIANGLES, skipped (empty geometry " +
                                  std::to_string(scene_.geometries.size()) + ")");
        scene_.geometries.push_back(std::move(g));
        continue;
      }
      auto posIt = prim.attributes.find("POSITION");
      if (posIt == prim.attributes.end())
        return fail(ErrorCode::CorruptFile, what + ": no POSITION attribute");
      auto pos = view(posIt->second, what + " POSITION", TINYGLTF_TYPE_VEC3);
      if (!pos.ok()) return pos.error();
      const size_t n = pos->count;
      if (n > 0xFFFFFFFFu) return fail(ErrorCode::LimitExceeded, what + ": too many vertices");
      // Memory bound: primitives may share accessors, so the vertices and indices materialised over the whole scene
      // are capped at a multiple of the buffer bytes (a small file must not expand to gigabytes).
      if (Status b = charge(what, n,
                            prim.indices >= 0 && size_t(prim.indices) < model_.accessors.size()
                                ? model_.accessors[size_t(prim.indices)].count
                                : n);
          !b.ok())
        return b;
      if (opts_.loadPositions) {
        g.positions.resize(n * 3);
        for (size_t i = 0; i < n; ++i)
          for (int c = 0; c < 3; ++c) g.positions[i * 3 + size_t(c)] = narrow(pos->component(i, c));
      } else {  // not kept: only counted for loadScene's warning
        for (size_t i = 0; i < n; ++i)
          for (int c = 0; c < 3; ++c) droppedNonFinite_ += !std::isfinite(narrow(pos->component(i, c)));
      }

      const MatInfo& info = matInfo_[g.material];
      g.uvs.assign(n * 2, 0.0f);
      const std::string uvName = "TEXCOORD_" + std::to_string(info.texCoord);
      auto uvIt = prim.attributes.find(uvName);
      if (uvIt != prim.attributes.end()) {
        auto uv = view(uvIt->second, what + " " + uvName, TINYGLTF_TYPE_VEC2);
        if (!uv.ok()) return uv.error();
        if (uv->count < n)
          return fail(ErrorCode::CorruptFile, what + ": " + uvName + " has " + std::to_string(uv->count) +
                                                  " elements for " + std::to_string(n) + " vertices");
        for (size_t i = 0; i < n; ++i) {
          double u = uv->component(i, 0), v = uv->component(i, 1);
          if (info.transform) {
            const double u2 = info.m[0] * u + info.m[1] * v + info.m[2];
            const double v2 = info.m[3] * u + info.m[4] * v + info.m[5];
            u = u2, v = v2;
          }
          g.uvs[i * 2] = narrow(u), g.uvs[i * 2 + 1] = narrow(v);
        }
      } else if (info.alphaFromTexture) {
        scene_.warnings.push_back(what + ": no " + uvName + " for its alpha texture; UVs set to 0");
      }

      if (prim.indices >= 0) {
        auto idx = view(prim.indices, what + " indices", TINYGLTF_TYPE_SCALAR);
        if (!idx.ok()) return idx.error();
        if (idx->componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
            idx->componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
            idx->componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
          return fail(ErrorCode::CorruptFile, what + ": indices have component type " +
                                                  std::to_string(idx->componentType) + " (must be unsigned)");
        if (!idx->base && idx->count > 0)
          return fail(ErrorCode::CorruptFile, what + ": index accessor has no buffer view");
        const size_t m = idx->count - idx->count % 3;
        if (m != idx->count) ++dropped;
        g.indices.resize(m);
        for (size_t i = 0; i < m; ++i) {
          const uint32_t k = idx->index(i);
          if (k >= n)
            return fail(ErrorCode::CorruptFile, what + ": index " + std::to_string(k) + " at position " +
                                                    std::to_string(i) + " is out of range (" +
                                                    std::to_string(n) + " vertices)");
          g.indices[i] = k;
        }
      } else {
        const size_t m = n - n % 3;
        if (m != n) ++dropped;
        g.indices.resize(m);
        for (size_t i = 0; i < m; ++i) g.indices[i] = uint32_t(i);
      }
      scene_.geometries.push_back(std::move(g));
    }
  }
  if (dropped)
    scene_.warnings.push_back(
        std::to_string(dropped) +
        " primitive(s) have a vertex/index count not divisible by 3; trailing indices dropped");
  (void)skipped;
  return Ok{};
}

Status GltfLoader::loadInstances() {
  std::vector<int> roots;
  if (!model_.scenes.empty()) {
    const size_t s = model_.defaultScene >= 0 && size_t(model_.defaultScene) < model_.scenes.size()
                         ? size_t(model_.defaultScene)
                         : 0;
    roots = model_.scenes[s].nodes;
  } else {
    std::vector<char> isChild(model_.nodes.size(), 0);
    for (const auto& n : model_.nodes)
      for (int c : n.children)
        if (c >= 0 && size_t(c) < model_.nodes.size()) isChild[size_t(c)] = 1;
    for (size_t i = 0; i < model_.nodes.size(); ++i)
      if (!isChild[i]) roots.push_back(int(i));
  }
  std::vector<char> onPath(model_.nodes.size(), 0);
  size_t visits = 0;
  bool cameraSet = false;
  // Depth-first, pre-order, children in order.
  struct Frame {
    int node;
    Mat4 world;
    size_t next;  // next child to visit
  };
  for (int root : roots) {
    std::vector<Frame> stack;
    auto enter = [&](int node, const Mat4& parent) -> Status {
      if (node < 0 || size_t(node) >= model_.nodes.size())
        return fail(ErrorCode::CorruptFile, "node " + std::to_string(node) + " does not exist");
      if (onPath[size_t(node)])
        return fail(ErrorCode::CorruptFile, "node hierarchy has a cycle at node " + std::to_string(node));
      if (++visits > opts_.limits.nodes)
        return fail(ErrorCode::LimitExceeded, "the node hierarchy expands to more than " +
                                                  std::to_string(opts_.limits.nodes) + " node visits, " +
                                                  limitHint("nodes", opts_.limits.nodes));
      const tinygltf::Node& n = model_.nodes[size_t(node)];
      const Mat4 world = mul(parent, localTransform(n));
      if (n.mesh >= 0) {
        if (size_t(n.mesh) >= model_.meshes.size())
          return fail(ErrorCode::CorruptFile, "node " + std::to_string(node) + ": mesh " +
                                                  std::to_string(n.mesh) + " does not exist");
        const size_t prims = model_.meshes[size_t(n.mesh)].primitives.size();
        if (prims > opts_.limits.instances || scene_.instances.size() > opts_.limits.instances - prims)
          return fail(ErrorCode::LimitExceeded, "the scene has more than " +
                                                    std::to_string(opts_.limits.instances) + " instances, " +
                                                    limitHint("instances", opts_.limits.instances));
        std::array<float, 16> transform;
        for (int k = 0; k < 16; ++k) transform[size_t(k)] = narrow(world[size_t(k)]);
        if (prims > 0 && !isUsableTransform(transform))
          return fail(ErrorCode::CorruptFile,
                      "node " + std::to_string(node) + (n.name.empty() ? "" : " '" + n.name + "'") +
                          ": its world transform is singular or not finite (the mesh would collapse)");
        for (size_t p = 0; p < prims; ++p) {
          Instance inst;
          inst.geometry = firstGeometry_[size_t(n.mesh)] + uint32_t(p);
          inst.transform = transform;
          scene_.instances.push_back(inst);
        }
      }
      if (!cameraSet && n.camera >= 0 && size_t(n.camera) < model_.cameras.size()) {
        cameraSet = true;
        const tinygltf::Camera& gc = model_.cameras[size_t(n.camera)];
        Camera cam;
        const double ex = world[12], ey = world[13], ez = world[14];
        double fx = -world[8], fy = -world[9], fz = -world[10];  // -Z axis
        const double fl = std::sqrt(fx * fx + fy * fy + fz * fz);
        if (fl > 0) fx /= fl, fy /= fl, fz /= fl;
        double ux = world[4], uy = world[5], uz = world[6];
        const double ul = std::sqrt(ux * ux + uy * uy + uz * uz);
        if (ul > 0) ux /= ul, uy /= ul, uz /= ul;
        cam.eye = {narrow(ex), narrow(ey), narrow(ez)};
        cam.target = {narrow(ex + fx), narrow(ey + fy), narrow(ez + fz)};
        cam.up = {narrow(ux), narrow(uy), narrow(uz)};
        if (gc.type == "perspective" && gc.perspective.yfov > 0)
          cam.yfovRadians = narrow(gc.perspective.yfov);
        else
          scene_.warnings.push_back("camera " + std::to_string(n.camera) +
                                    " is not a perspective camera; default field of view used");
        scene_.camera = cam;
      }
      onPath[size_t(node)] = 1;
      stack.push_back(Frame{node, world, 0});
      return Ok{};
    };
    Status st = enter(root, kIdentity);
    if (!st.ok()) return st;
    while (!stack.empty()) {
      Frame& f = stack.back();
      const auto& children = model_.nodes[size_t(f.node)].children;
      if (f.next < children.size()) {
        const int child = children[f.next++];
        const Mat4 world = f.world;  // f may move when the stack grows
        st = enter(child, world);
        if (!st.ok()) return st;
      } else {
        onPath[size_t(f.node)] = 0;
        stack.pop_back();
      }
    }
  }
  return Ok{};
}

Result<Scene> GltfLoader::run(bool binary) {
  // The file is read here (a regular file, at most the scene cap), its JSON nesting bounded before any parser
  // recurses into it (tinygltf's JSON parser recurses per level: ~20,000 levels overflow the stack).
  auto file = readRegularFile(path_, opts_.limits.sceneFileBytes, binary ? "GLB file" : "glTF file",
                              "file-bytes.scene");
  if (!file) return file.error();
  const std::vector<uint8_t>& bytes = *file;
  const char* json = reinterpret_cast<const char*>(bytes.data());
  size_t jsonSize = bytes.size();
  if (binary) {
    auto le32 = [&](size_t o) {
      return uint32_t(bytes[o]) | uint32_t(bytes[o + 1]) << 8 | uint32_t(bytes[o + 2]) << 16 |
             uint32_t(bytes[o + 3]) << 24;
    };
    if (bytes.size() < 20 || std::memcmp(bytes.data(), "glTF", 4) != 0)
      return fail(ErrorCode::CorruptFile, "not a GLB file (no 'glTF' magic)");
    if (le32(4) != 2)
      return fail(ErrorCode::UnsupportedFormat,
                  "GLB container version " + std::to_string(le32(4)) + " (only version 2 is supported)");
    if (le32(16) != 0x4E4F534Au) return fail(ErrorCode::CorruptFile, "the first GLB chunk is not JSON");
    jsonSize = std::min<size_t>(le32(12), bytes.size() - 20);
    json += 20;
  }
  if (bytes.size() > 0xFFFFFFFFu)
    return fail(ErrorCode::LimitExceeded, "larger than 4 GiB, more than glTF can address");
  if (const uint32_t d = jsonDepth(json, jsonSize, opts_.limits.jsonDepth); d > opts_.limits.jsonDepth)
    return fail(ErrorCode::LimitExceeded,
                "JSON nested deeper than " + limitHint("json-depth", opts_.limits.jsonDepth));
  {
    const nlohmann::json doc = nlohmann::json::parse(json, json + jsonSize, nullptr, false);
    if (!doc.is_discarded()) {
      if (std::string why = badUnsigned(doc); !why.empty()) return fail(ErrorCode::CorruptFile, why);
      auto asset = doc.find("asset");
      if (asset != doc.end() && asset->is_object()) {
        auto v = asset->find("version");
        if (v != asset->end() && v->is_string()) {
          const std::string ver = v->get<std::string>();
          if (ver.rfind("2.", 0) != 0)
            return fail(ErrorCode::UnsupportedFormat,
                        "asset.version '" + escapeName(ver.substr(0, 40)) + "' (only glTF 2.x is supported)");
        }
        auto mv = asset->find("minVersion");
        if (mv != asset->end() && mv->is_string() && mv->get<std::string>() != "2.0")
          return fail(ErrorCode::UnsupportedFormat, "asset.minVersion '" +
                                                        escapeName(mv->get<std::string>().substr(0, 40)) +
                                                        "' (only 2.0 is supported)");
      }
    }
  }
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(&keepEncoded, nullptr);
  ExternalFiles files;
  files.limits = &opts_.limits;
  files.dir = std::filesystem::path(path_).parent_path();
  tinygltf::FsCallbacks fs{&existsAlways, &resolveUri, &readExternal, &tinygltf::WriteWholeFile, &files};
  loader.SetFsCallbacks(fs);
  std::string err, warn;
  bool ok = false;
  const std::string baseDir;  // resolveUri resolves relative URIs (see ExternalFiles)
  try {
    ok = binary ? loader.LoadBinaryFromMemory(&model_, &err, &warn, bytes.data(), unsigned(bytes.size()),
                                              baseDir)
                : loader.LoadASCIIFromString(&model_, &err, &warn, json, unsigned(jsonSize), baseDir);
  } catch (const std::bad_alloc&) {
    err = "out of memory while parsing";
    ok = false;
  } catch (const std::exception& e) {
    err = std::string("parser exception: ") + e.what();
    ok = false;
  }
  if (!ok) {
    if (!files.error.empty()) return fail(files.errorCode, oneLine(files.error));
    std::string msg = oneLine(err);
    if (msg.empty()) msg = oneLine(warn);
    if (msg.empty()) msg = "cannot parse glTF";
    return fail(ErrorCode::CorruptFile, msg);
  }
  splitLines(warn, scene_.warnings);
  // Extensions that change how geometry or images must be read cannot be ignored.
  for (const std::string& ext : model_.extensionsRequired) {
    const bool supported = ext == "KHR_texture_transform" || ext == "KHR_mesh_quantization" ||
                           ext == "EXT_mesh_opacity_micromap" ||  // geometry is complete without it
                           ext.rfind("KHR_materials_", 0) == 0;
    if (!supported) return fail(ErrorCode::UnsupportedFormat, "requires the unsupported extension " + ext);
  }
  scene_.sourcePath = path_;
  scene_.inputFiles.push_back(path_);
  scene_.inputFiles.insert(scene_.inputFiles.end(), files.read.begin(), files.read.end());
  Status st = loadMaterials();
  if (!st.ok()) return st.error();
  st = loadGeometries();
  if (!st.ok()) return st.error();
  st = loadInstances();
  if (!st.ok()) return st.error();
  return std::move(scene_);
}

}  // namespace

Result<Scene> loadGltf(const std::string& path, bool binary, const LoadOptions& options,
                       uint64_t& nonFinitePositions) {
  GltfLoader loader(path, options);
  Result<Scene> r = loader.run(binary);
  nonFinitePositions = loader.droppedNonFinite();
  return r;
}

}  // namespace somm::detail
