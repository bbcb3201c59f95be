// SPDX-License-Identifier: MIT
// somm gpu-check FILE.somm: the shader lookups (shaders/somm.glsl, somm.hlsl) on the Vulkan device against the
// CPU, bit for bit. somm gpu-bench FILE.somm: lookups per second per encoding, as ratios to flat.
#include <cinttypes>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "command.h"
#include "encodings.h"
#include "gpu_arrays.h"
#include "somm/bird.h"
#include "somm/gpu.h"

namespace {

using somm::gpu::Query;
using somm::gpu::ShaderLanguage;

float bitsToFloat(uint32_t b) {
  float f;
  std::memcpy(&f, &b, 4);
  return f;
}
uint32_t floatToBits(float f) {
  uint32_t b;
  std::memcpy(&b, &f, 4);
  return b;
}

// Points that stress the quantisation at `level`: uniform inside the triangle, dyadic ties (cell corners and
// edges of this and the next level), one ulp off them, the triangle's edges and the anti-diagonal u + v = 1,
// out of range, NaN / inf / denormals / signed zeros, and arbitrary bit patterns.
class PointSampler {
 public:
  explicit PointSampler(uint64_t seed) : rng_(seed) {}

  void sample(uint32_t level, float& u, float& v) {
    switch (rng_() % 11) {
      case 0:
      case 1:
      case 2: {  // uniform in the triangle
        u = unit();
        v = unit();
        if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
        break;
      }
      case 3:
      case 4: {  // dyadic: exact grid points of level 0 .. level+1
        dyadic(level, u, v);
        break;
      }
      case 5: {  // one ulp (or a few) off a dyadic point
        dyadic(level, u, v);
        u = nudge(u);
        v = nudge(v);
        break;
      }
      case 6: {  // edges and the anti-diagonal
        const float t = rng_() % 2 ? unit() : dyadicCoord(level);
        switch (rng_() % 4) {
          case 0:
            u = 0.0f, v = t;
            break;
          case 1:
            u = t, v = 0.0f;
            break;
          case 2:
            u = t, v = 1.0f - t;
            break;
          default:
            u = t, v = nudge(1.0f - t);
            break;
        }
        if (rng_() % 2) std::swap(u, v);
        break;
      }
      case 7: {  // out of range
        u = float(std::uniform_real_distribution<double>(-2.0, 3.0)(rng_));
        v = float(std::uniform_real_distribution<double>(-2.0, 3.0)(rng_));
        if (rng_() % 4 == 0) u = rng_() % 2 ? 1e30f : -1e30f;
        break;
      }
      case 8: {  // special values in one or both coordinates
        u = special();
        v = rng_() % 2 ? special() : unit();
        if (rng_() % 2) std::swap(u, v);
        break;
      }
      case 9: {  // frac(u·2^L) + frac(v·2^L) within a few 2^-26 of 1: where the reference's float sum rounds
        v = unit();
        const double n = std::ldexp(1.0, int(level));
        const double fv = double(v) * n;
        const double vf = fv - std::floor(fv);
        const double t = 1.0 - vf - 0x1p-25 + double(int(rng_() % 7) - 3) * 0x1p-26;
        u = t >= 0 && t < 1 ? float(t / n) : 0.0f;  // cell 0 of u: the only one with such fine fractions
        if (rng_() % 2) std::swap(u, v);
        break;
      }
      default: {  // any bit pattern
        u = bitsToFloat(uint32_t(rng_()));
        v = rng_() % 2 ? bitsToFloat(uint32_t(rng_())) : unit();
        break;
      }
    }
  }

  uint64_t next() { return rng_(); }

 private:
  std::mt19937_64 rng_;

  float unit() { return std::uniform_real_distribution<float>(0.0f, 1.0f)(rng_); }
  float dyadicCoord(uint32_t level) {
    const uint32_t l = uint32_t(rng_() % (level + 2));
    const uint32_t n = 1u << l;
    return float(rng_() % (n + 1)) / float(n);
  }
  void dyadic(uint32_t level, float& u, float& v) {
    const uint32_t l = uint32_t(rng_() % (level + 2));
    const uint32_t n = 1u << l;
    const uint32_t iu = uint32_t(rng_() % (n + 1));
    const uint32_t iv = uint32_t(rng_() % (n + 1 - iu));
    u = float(iu) / float(n);
    v = float(iv) / float(n);
  }
  float nudge(float x) {
    const int steps = int(rng_() % 3) + 1;
    for (int i = 0; i < steps; ++i)
      x = std::nextafter(
          x, rng_() % 2 ? std::numeric_limits<float>::infinity() : -std::numeric_limits<float>::infinity());
    return x;
  }
  float special() {
    static const uint32_t kBits[] = {
        0x7fc00000u, 0xffc00000u, 0x7f800001u, 0x7fbfffffu,
        0xff800001u,                                         // quiet / signalling NaNs, both signs
        0x7f800000u, 0xff800000u,                            // ±inf
        0x00000000u, 0x80000000u,                            // ±0
        0x00000001u, 0x007fffffu, 0x80000001u, 0x00400000u,  // denormals
        0x7f7fffffu, 0xff7fffffu,                            // ±FLT_MAX
        0x3f800000u, 0x3f7fffffu, 0x3f800001u, 0xbf800000u,  // 1, 1 - ulp, 1 + ulp, -1
        0x3f000000u, 0x3effffffu, 0x3f000001u, 0x33800000u, 0x33000000u};  // 0.5 ± ulp, 2^-24, 2^-25
    return bitsToFloat(kBits[rng_() % (sizeof kBits / sizeof kBits[0])]);
  }
};

std::vector<ShaderLanguage> languages(const std::string& s) {
  if (s == "glsl") return {ShaderLanguage::Glsl};
  if (s == "hlsl") return {ShaderLanguage::Hlsl};
  return {ShaderLanguage::Glsl, ShaderLanguage::Hlsl};
}

// Queries over all arrays of one encoding: array chosen in proportion to its triangles, then a uniform
// triangle and a point at that triangle's level. Deterministic for a seed (the same for every encoding).
std::vector<Query> makeQueries(const somm::cli::GpuEncoding& ge, uint64_t samples, uint64_t seed,
                               bool stress) {
  PointSampler ps(seed);
  uint64_t total = 0;
  for (const somm::EncodedArray& a : ge.arrays) total += a.triangleCount();
  std::vector<Query> q;
  if (total == 0) return q;
  q.reserve(samples);
  for (uint64_t i = 0; i < samples; ++i) {
    uint64_t t = ps.next() % total;
    size_t k = 0;
    while (t >= ge.arrays[k].triangleCount()) t -= ge.arrays[k++].triangleCount();
    const somm::EncodedArray& a = ge.arrays[k];
    const int32_t idx = a.indices()[size_t(t)];
    const uint32_t level = idx >= 0 ? a.maps()[size_t(idx)].level : uint32_t(ps.next() % 13);
    Query x;
    x.triangle = uint32_t(t);
    x.w = ge.bases[k];
    if (stress) {
      ps.sample(level, x.u, x.v);
    } else {  // benchmark: uniform inside the triangle
      x.u = float(ps.next() >> 40) * 0x1p-24f;
      x.v = float(ps.next() >> 40) * 0x1p-24f;
      if (x.u + x.v > 1.0f) x.u = 1.0f - x.u, x.v = 1.0f - x.v;
    }
    q.push_back(x);
  }
  return q;
}

size_t arrayOf(const somm::cli::GpuEncoding& ge, uint32_t base) {
  size_t k = 0;
  while (k + 1 < ge.bases.size() && ge.bases[k + 1] <= base) ++k;
  return k;
}

struct CheckOptions {
  std::string path;
  std::string encoding = "all";
  std::string shader = "both";
  uint64_t samples = 100000;
  uint64_t seed = 1;
};

void reportMismatch(const char* what, const char* lang, const Query& q, uint32_t cpu, uint32_t gpu) {
  std::fprintf(stderr,
               "somm gpu-check: %s %s: triangle %" PRIu32 " u=%a (0x%08" PRIx32 ") v=%a (0x%08" PRIx32
               ") w=%" PRIu32 ": cpu %" PRIu32 ", gpu %" PRIu32 "\n",
               what, lang, q.triangle, double(q.u), floatToBits(q.u), double(q.v), floatToBits(q.v), q.w, cpu,
               gpu);
}

bool validEncodingOption(const char* command, const std::string& e) {
  if (e == "all" || somm::parseEncodingName(e)) return true;
  somm::cli::printError(command,
                        "--encoding '" + e + "' is not one of " + somm::cli::encodingNameList() + ", all");
  return false;
}

int runCheck(const CheckOptions& o) {
  using namespace somm::cli;
  if (!validEncodingOption("gpu-check", o.encoding)) return kExitUsage;
  auto file = somm::readSommFile(o.path);
  if (!file) {
    printError("gpu-check", file.error().message);
    return kExitFailure;
  }
  auto encodings = loadGpuEncodings(*file, o.path, o.encoding);
  if (!encodings) {
    printError("gpu-check", encodings.error().message);
    return kExitFailure;
  }
  auto device = somm::gpu::Device::open();
  if (!device) {
    printError("gpu-check", device.error().message);
    return kExitFailure;
  }
  Output out;
  out.put("device: " + device->name() + " (" + device->typeName() + ")\n");
  out.flush();
  bool ok = true;
  const std::vector<ShaderLanguage> langs = languages(o.shader);

  // The bird index alone, at every level.
  {
    PointSampler ps(o.seed ^ 0xb1d);
    std::vector<Query> q(size_t(o.samples));
    for (Query& x : q) {
      x.w = uint32_t(ps.next() % (somm::kMaxLevel + 1));
      ps.sample(x.w, x.u, x.v);
    }
    for (ShaderLanguage l : langs) {
      auto r = device->run(l, somm::gpu::LookupMode::BirdIndex, {}, 0, q);
      if (!r) {
        printError("gpu-check", r.error().message);
        return kExitFailure;
      }
      uint64_t bad = 0;
      for (size_t i = 0; i < q.size(); ++i) {
        const uint32_t cpu = somm::baryToIndex(q[i].u, q[i].v, q[i].w);
        if ((*r)[i] != cpu && bad++ < 5)
          reportMismatch("bird", somm::gpu::shaderLanguageName(l), q[i], cpu, (*r)[i]);
      }
      ok = ok && bad == 0;
      out.put(std::string("bird ") + somm::gpu::shaderLanguageName(l) + ": ");
      out.putUInt(bad);
      out.put(" mismatches in ");
      out.putUInt(q.size());
      out.put(" lookups\n");
      out.flush();
    }
  }

  for (const GpuEncoding& ge : *encodings) {
    const std::vector<Query> q = makeQueries(ge, o.samples, o.seed, true);
    for (ShaderLanguage l : langs) {
      auto r = device->run(l, somm::gpu::LookupMode::StateUV, ge.buffer, 0, q);
      if (!r) {
        printError("gpu-check", r.error().message);
        return kExitFailure;
      }
      uint64_t bad = 0;
      for (size_t i = 0; i < q.size(); ++i) {
        const somm::EncodedArray& a = ge.arrays[arrayOf(ge, q[i].w)];
        const uint32_t cpu = uint32_t(a.stateUV(q[i].triangle, q[i].u, q[i].v));
        if ((*r)[i] != cpu && bad++ < 5)
          reportMismatch(somm::encodingName(ge.encoding), somm::gpu::shaderLanguageName(l), q[i], cpu,
                         (*r)[i]);
      }
      ok = ok && bad == 0;
      out.put(std::string(somm::encodingName(ge.encoding)) + " " + somm::gpu::shaderLanguageName(l) + ": ");
      out.putUInt(bad);
      out.put(" mismatches in ");
      out.putUInt(q.size());
      out.put(" lookups\n");
      out.flush();
    }
  }
  return ok ? kExitOk : kExitFailure;
}

struct BenchOptions {
  std::string path;
  std::string encoding = "all";
  std::string shader = "glsl";
  uint64_t samples = 1u << 20;
  uint32_t repeats = 5;
};

int runBench(const BenchOptions& o) {
  using namespace somm::cli;
  if (!validEncodingOption("gpu-bench", o.encoding)) return kExitUsage;
  auto file = somm::readSommFile(o.path);
  if (!file) {
    printError("gpu-bench", file.error().message);
    return kExitFailure;
  }
  auto encodings = loadGpuEncodings(*file, o.path, o.encoding);
  if (!encodings) {
    printError("gpu-bench", encodings.error().message);
    return kExitFailure;
  }
  if (encodings->empty() || encodings->front().encoding != somm::Encoding::Flat) {
    // the baseline: flat first
    auto flat = loadGpuEncodings(*file, o.path, "flat");
    if (!flat) {
      printError("gpu-bench", flat.error().message);
      return kExitFailure;
    }
    encodings->insert(encodings->begin(), std::move(flat->front()));
  }
  auto device = somm::gpu::Device::open();
  if (!device) {
    printError("gpu-bench", device.error().message);
    return kExitFailure;
  }
  Output out;
  out.put("device: " + device->name() + " (" + device->typeName() + ")\n");
  out.put("uniform random (triangle, u, v) lookups; fastest of " + std::to_string(o.repeats) +
          " dispatches of " + std::to_string(o.samples) + "\n");
  for (ShaderLanguage l : languages(o.shader)) {
    double flatRate = 0;
    for (const GpuEncoding& ge : *encodings) {
      const std::vector<Query> q = makeQueries(ge, o.samples, 7, false);
      double seconds = 0;
      auto r = device->run(l, somm::gpu::LookupMode::StateUV, ge.buffer, 0, q, o.repeats, &seconds);
      if (!r) {
        printError("gpu-bench", r.error().message);
        return kExitFailure;
      }
      const double rate = seconds > 0 ? double(q.size()) / seconds : 0;
      if (ge.encoding == somm::Encoding::Flat) flatRate = rate;
      char line[160];
      std::snprintf(line, sizeof line, "%-9s %s: %10.4g lookups/s  %.3f x flat\n",
                    somm::encodingName(ge.encoding), somm::gpu::shaderLanguageName(l), rate,
                    flatRate > 0 ? rate / flatRate : 0.0);
      out.put(line);
      out.flush();
    }
  }
  return kExitOk;
}

void setupCheck(CLI::App& root) {
  auto o = std::make_shared<CheckOptions>();
  CLI::App* cmd = root.add_subcommand(
      "gpu-check",
      "Run the shader lookups (shaders/somm.glsl and somm.hlsl, compiled to SPIR-V at build time) on the "
      "Vulkan "
      "device and compare every result with the CPU: the bird index at every level, and stateUV of each "
      "stored "
      "encoding on random, dyadic-tie, edge, out-of-range and NaN/inf points. Prints '<what> <shader>: N "
      "mismatches'; exit 1 on any mismatch or when there is no Vulkan device.");
  cmd->add_option("file", o->path, ".somm file")->required();
  cmd->add_option("--encoding,-e", o->encoding,
                  somm::cli::encodingNameList() + " or all (default: all stored)");
  cmd->add_option("--samples,-n", o->samples, "lookups per encoding and shader (default 100000)")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 26));
  cmd->add_option("--shader", o->shader, "glsl, hlsl or both (default)")
      ->check(CLI::IsMember({"glsl", "hlsl", "both"}));
  cmd->add_option("--seed", o->seed, "random seed (default 1)");
  cmd->callback([o] { somm::cli::setExitCode(runCheck(*o)); });
}

void setupBench(CLI::App& root) {
  auto o = std::make_shared<BenchOptions>();
  CLI::App* cmd = root.add_subcommand("gpu-bench",
                                      "Lookups per second of each stored encoding in the compute shader on "
                                      "the Vulkan device, as ratios to flat "
                                      "in the same run (on lavapipe these are CPU figures).");
  cmd->add_option("file", o->path, ".somm file")->required();
  cmd->add_option("--encoding,-e", o->encoding,
                  somm::cli::encodingNameList() + " or all (default: all stored)");
  cmd->add_option("--samples,-n", o->samples, "lookups per dispatch (default 1048576)")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 26));
  cmd->add_option("--repeat,-r", o->repeats, "dispatches per encoding; the fastest counts (default 5)")
      ->check(CLI::Range(1u, 1000u));
  cmd->add_option("--shader", o->shader, "glsl (default), hlsl or both")
      ->check(CLI::IsMember({"glsl", "hlsl", "both"}));
  cmd->callback([o] { somm::cli::setExitCode(runBench(*o)); });
}

const somm::cli::Registration regCheck("gpu-check", &setupCheck);
const somm::cli::Registration regBench("gpu-bench", &setupBench);

}  // namespace
