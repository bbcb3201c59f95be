// SPDX-License-Identifier: MIT
// PNG decoding: the fast path (decodePngFast: libdeflate + in-place unfilter) against stb_image, the baseline, in the
// same run, on the bundled textures and (when ../shared is present) every real foliage PNG. Each fast decode is
// checked against stb's bytes (decodeImage without the fast path) once before timing. And the alpha channel alone
// (decodeAlphaFast) against the whole decode + toAlphaTexture.
#include <benchmark/benchmark.h>
#include <stb_image.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "scene/image_io.h"

namespace {

using Bytes = std::vector<uint8_t>;

std::vector<Bytes> pngFiles(const std::string& dir) {
  std::vector<Bytes> files;
  if (dir.empty() || !std::filesystem::is_directory(dir)) return files;
  std::vector<std::string> paths;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.path().extension() == ".png") paths.push_back(e.path().string());
  std::sort(paths.begin(), paths.end());
  for (const std::string& p : paths) {
    std::ifstream f(p, std::ios::binary);
    files.emplace_back(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  return files;
}

// "bundled": data/; otherwise $SOMM_FOLIAGE_DIR or ../shared/assets/foliage.
std::string pngDir(const char* which) {
  if (std::string(which) == "bundled") return SOMM_DATA_DIR;
  const char* env = std::getenv("SOMM_FOLIAGE_DIR");
  return env && *env ? env : SOMM_FOLIAGE_DIR;
}

// Decodes every file with both decoders `rounds` times, alternating; counters: seconds of each (best round), the
// ratio, decoded MB, and how many files took the fast path (the others are stb's in both columns).
void BM_DecodePng(benchmark::State& state, const char* which) {
  const std::string dir = pngDir(which);
  const std::vector<Bytes> files = pngFiles(dir);
  if (files.empty()) {
    state.SkipWithError("no PNG files (../shared/assets/foliage absent?)");
    return;
  }
  size_t fastFiles = 0, samples = 0;
  for (const Bytes& f : files) {
    somm::detail::RawImage img;
    int w = 0, h = 0, c = 0;
    stbi_uc* p = stbi_load_from_memory(f.data(), int(f.size()), &w, &h, &c, 0);
    if (!p) continue;
    samples += size_t(w) * h * c;
    if (somm::detail::decodePngFast(f.data(), f.size(), img)) {
      ++fastFiles;
      // The oracle: decodeImage with stb alone (for palette images, stb after the palette is padded).
      const auto s = somm::detail::decodeImage(f.data(), f.size(), somm::defaultLimits(), nullptr, false);
      if (!s.ok() || s->sixteenBit || img.sampleCount() != s->sampleCount() ||
          std::memcmp(s->px8(), img.px8(), img.sampleCount()) != 0) {
        stbi_image_free(p);
        state.SkipWithError("fast path differs from stb");
        return;
      }
    }
    stbi_image_free(p);
  }
  double bestFast = 1e30, bestStb = 1e30;
  for (auto _ : state) {
    for (int round = 0; round < 3; ++round) {
      const auto t0 = std::chrono::steady_clock::now();
      for (const Bytes& f : files) {
        int w = 0, h = 0, c = 0;
        stbi_uc* p = stbi_load_from_memory(f.data(), int(f.size()), &w, &h, &c, 0);
        benchmark::DoNotOptimize(p);
        stbi_image_free(p);
      }
      const auto t1 = std::chrono::steady_clock::now();
      for (const Bytes& f : files) {
        somm::detail::RawImage img;
        if (!somm::detail::decodePngFast(f.data(), f.size(), img)) {
          int w = 0, h = 0, c = 0;  // outside the subset: stb, as decodeImage does
          stbi_image_free(stbi_load_from_memory(f.data(), int(f.size()), &w, &h, &c, 0));
        }
        benchmark::DoNotOptimize(img.samples);
      }
      const auto t2 = std::chrono::steady_clock::now();
      bestStb = std::min(bestStb, std::chrono::duration<double>(t1 - t0).count());
      bestFast = std::min(bestFast, std::chrono::duration<double>(t2 - t1).count());
    }
  }
  state.counters["files"] = double(files.size());
  state.counters["fast_path_files"] = double(fastFiles);
  state.counters["MB_decoded"] = double(samples) / 1e6;
  state.counters["stb_s"] = bestStb;
  state.counters["fast_s"] = bestFast;
  state.counters["speedup_vs_stb"] = bestStb / bestFast;
  state.SetLabel(std::string(which) + " PNGs");
}

// The alpha texture of every PNG that has an alpha channel, as `somm bake` makes it: decodeAlphaFast (only the alpha
// bytes unfiltered) against the whole decode (decodeImage, fast path included) + toAlphaTexture, the baseline, in the
// same run; each result checked equal to the baseline's texture once before timing.
void BM_DecodePngAlpha(benchmark::State& state, const char* which) {
  const std::string dir = pngDir(which);
  using somm::detail::AlphaChannel;
  std::vector<Bytes> files;
  std::vector<somm::detail::ImageHeader> headers;
  size_t texels = 0;
  for (Bytes& f : pngFiles(dir)) {
    const auto hd = somm::detail::checkImage(f.data(), f.size());
    if (!hd.ok()) continue;
    const auto alone =
        somm::detail::decodeAlphaFast(f.data(), f.size(), *hd, AlphaChannel::AlphaOrOne, 1.0f, true);
    if (!alone) continue;  // no alpha channel (or outside the subset)
    const auto whole = somm::detail::decodeImage(f.data(), f.size());
    if (!whole.ok()) {
      state.SkipWithError("decodeImage fails where decodeAlphaFast decodes");
      return;
    }
    const somm::AlphaTexture t = somm::detail::toAlphaTexture(*whole, AlphaChannel::AlphaOrOne, 1.0f, true);
    if (t.alpha8 != alone->alpha8 || t.storage != alone->storage) {
      state.SkipWithError("the alpha alone differs from the whole decode's");
      return;
    }
    texels += t.texelCount();
    headers.push_back(*hd);
    files.push_back(std::move(f));
  }
  if (files.empty()) {
    state.SkipWithError("no PNG files with alpha (../shared/assets/foliage absent?)");
    return;
  }
  double bestAlone = 1e30, bestWhole = 1e30;
  for (auto _ : state) {
    for (int round = 0; round < 3; ++round) {
      const auto t0 = std::chrono::steady_clock::now();
      for (const Bytes& f : files) {
        const auto img = somm::detail::decodeImage(f.data(), f.size());
        const somm::AlphaTexture t = somm::detail::toAlphaTexture(*img, AlphaChannel::AlphaOrOne, 1.0f, true);
        benchmark::DoNotOptimize(t.alpha8.data());
      }
      const auto t1 = std::chrono::steady_clock::now();
      for (size_t k = 0; k < files.size(); ++k) {
        const auto t = somm::detail::decodeAlphaFast(files[k].data(), files[k].size(), headers[k],
                                                     AlphaChannel::AlphaOrOne, 1.0f, true);
        benchmark::DoNotOptimize(t->alpha8.data());
      }
      const auto t2 = std::chrono::steady_clock::now();
      bestWhole = std::min(bestWhole, std::chrono::duration<double>(t1 - t0).count());
      bestAlone = std::min(bestAlone, std::chrono::duration<double>(t2 - t1).count());
    }
  }
  state.counters["files"] = double(files.size());
  state.counters["Mtexels"] = double(texels) / 1e6;
  state.counters["whole_s"] = bestWhole;
  state.counters["alpha_alone_s"] = bestAlone;
  state.counters["speedup_vs_whole"] = bestWhole / bestAlone;
  state.SetLabel(std::string(which) + " PNGs with alpha");
}

BENCHMARK_CAPTURE(BM_DecodePng, bundled, "bundled")->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK_CAPTURE(BM_DecodePng, foliage, "foliage")->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK_CAPTURE(BM_DecodePngAlpha, bundled, "bundled")->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK_CAPTURE(BM_DecodePngAlpha, foliage, "foliage")->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
