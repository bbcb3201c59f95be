// SPDX-License-Identifier: MIT
// somm compare SCENE --levels 4,6,8,10,12 --formats 2,4 [--json] [--plot out.png]: bakes the scene at every
// level and format and prints the memory table of every encoding (bytes and ratio to flat), optionally as a
// PNG plot of the ratio against the level.
#include <stb/stb_image_write.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "command.h"
#include "encodings.h"
#include "file_summary.h"
#include "limits_cli.h"
#include "somm/bake.h"
#include "somm/encode.h"
#include "somm/omm_array.h"
#include "somm/procedural.h"
#include "somm/scene.h"
#include "somm/somm_file.h"

namespace {

using somm::Encoding;

// Every record of format f reachable from the sdag maps' roots, once each (depth first): height (1 = leaf), byte
// offset in the data, bytes, and whether it is local (stored with its only parent).
struct SdagRecordInfo {
  uint32_t height;
  uint32_t offset;
  uint32_t bytes;
  bool local;
};
// The offset and localness of child i of the record at `at` (children of height h, references from bit pos).
std::pair<uint32_t, bool> sdagChildInfo(const uint8_t* data, const somm::encode::SdagDirectory& dir,
                                        somm::Format f, uint32_t h, uint32_t at, uint32_t pos, uint32_t n,
                                        uint32_t i) {
  using namespace somm::encode;
  const uint32_t k = sdagRegion(f, h), w = dir.width[k], t = dir.tier[k], u = dir.mid[k];
  const uint8_t* p = data + at;
  const bool local = h == 1 && dir.local[k]
                         ? sdagLeafRefClass(p, pos, n, i, w, t, u).isLong != 0
                         : (sdagRefClass(p, pos, n, i, w, t, u).isLong & dir.local[k]) != 0;
  const uint32_t c = sdagChildAt(dir, p, at, pos, n, i, k, h == 1 ? 2 * somm::bitsPerState(f) : 0);
  // A leaf: the stored leaf's offset (its handle without T).
  return {h == 1 ? uint32_t(sdagLeafOf(data, dir, f, c).p - data) : c, local};
}
void sdagVisit(const uint8_t* data, const somm::encode::SdagDirectory& dir, somm::Format f, uint32_t h,
               uint32_t off, bool local, std::set<std::pair<uint32_t, uint32_t>>& seen,
               std::vector<SdagRecordInfo>& out) {
  using namespace somm::encode;
  if (!seen.emplace(h, off).second) return;
  if (h == 1) {
    out.push_back({1, off, 2 * somm::bitsPerState(f), local});
    return;
  }
  const uint32_t k = sdagRegion(f, h - 1);
  const uint8_t* p = data + off;
  const uint32_t m = load16(p), n = popcount64(m), pos = sdagNodeFlags(p, n).pos;
  const bool hf = h == 2 && dir.local[k] != 0;
  out.push_back(
      {h, off, (pos + sdagRefBits(p, pos, n, dir.width[k], dir.tier[k], dir.mid[k], hf) + 7) / 8, local});
  for (uint32_t i = 0; i < n; ++i) {
    const auto [c, l] = sdagChildInfo(data, dir, f, h - 1, off, pos, n, i);
    sdagVisit(data, dir, f, h - 1, c, l, seen, out);
  }
}
std::vector<SdagRecordInfo> sdagRecords(const somm::EncodedArray& a, somm::Format f) {
  using namespace somm::encode;
  const auto& dir = a.directory();
  const uint8_t* data = a.data().data();
  std::set<std::pair<uint32_t, uint32_t>> seen;
  std::vector<SdagRecordInfo> out;
  for (const auto& d : a.maps()) {
    if (d.kind != somm::MapKind::Sdag || somm::Format(d.format) != f || d.level < 2) continue;
    if (d.level % 2 == 0) {
      sdagVisit(data, dir, f, d.level / 2, d.offset, false, seen, out);
      continue;
    }
    const uint32_t h = (d.level - 1) / 2, m = data[d.offset] & 15u, n = popcount64(m);
    for (uint32_t i = 0; i < n; ++i) {
      const auto [c, l] = sdagChildInfo(data, dir, f, h, d.offset, 8 - n, n, i);
      sdagVisit(data, dir, f, h, c, l, seen, out);
    }
  }
  return out;
}

// Statistics that bound the sdag size ideas (4-state regions): printed with --sdag-stats.
void printSdagAnalysis(const somm::EncodedArray& a) {
  using namespace somm::encode;
  const auto& dir = a.directory();
  const uint8_t* data = a.data().data();
  auto entropyBits = [](const std::vector<uint64_t>& c) {
    double tot = 0, e = 0;
    for (uint64_t v : c) tot += double(v);
    for (uint64_t v : c)
      if (v) e -= double(v) * std::log2(double(v) / tot);
    return e;
  };
  const uint32_t k1 = sdagRegion(somm::Format::FourState, 1), k2 = k1 + 1;
  const std::vector<SdagRecordInfo> all = sdagRecords(a, somm::Format::FourState);
  std::map<uint32_t, uint32_t> leafNo;  // leaf offset -> number
  for (const SdagRecordInfo& r : all)
    if (r.height == 1) leafNo.emplace(r.offset, uint32_t(leafNo.size()));
  const uint32_t nLeaves = uint32_t(leafNo.size());
  std::vector<uint64_t> leafUse(nLeaves, 0);
  std::vector<std::vector<uint64_t>> leafUseSlot(16, std::vector<uint64_t>(nLeaves, 0));
  uint64_t recs = 0, maskBits = 0, stateBits = 0, flagBits = 0, refBits = 0, padBits = 0, stHist[2] = {};
  std::map<std::pair<uint32_t, uint64_t>, uint32_t> shapes;
  for (const SdagRecordInfo& rec : all) {
    if (rec.height != 2) continue;
    const uint64_t off = rec.offset;
    const uint8_t* p = data + off;
    const uint32_t m = load16(p), n = popcount64(m);
    const uint32_t pos = sdagNodeFlags(p, n).pos, w = dir.width[k1], t = dir.tier[k1], u = dir.mid[k1];
    // The uniform children's states (0 transparent, 1 opaque; a uniformly unknown child is a node).
    uint64_t st = 0;
    for (uint32_t i = 0; i < 16 - n; ++i) {
      const uint32_t s = sdagUniformState(load64(p + 2), i);
      ++stHist[s];
      st |= uint64_t(s) << i;
    }
    ++shapes[{m, st}];
    uint32_t slot = 0, j = 0;
    for (uint32_t s = 0; s < 16; ++s)
      if (m >> s & 1u) {
        const uint32_t r =
            leafNo.at(sdagChildInfo(data, dir, somm::Format::FourState, 1, uint32_t(off), pos, n, j++).first);
        ++leafUse[r];
        ++leafUseSlot[s][r];
      }
    (void)slot;
    const bool hf = dir.local[k1] != 0;
    const uint32_t rb = sdagRefBits(p, pos, n, w, t, u, hf);
    const uint32_t bytes = (pos + rb + 7) / 8;
    maskBits += 16;
    stateBits += pos - 16;
    const uint32_t sh = t ? popcount64(getBits(p, pos, n)) : 0, gl = t && u ? n - sh : 0;
    const uint32_t mids = gl ? popcount64(getBits(p, pos + n, gl)) : 0;
    const uint32_t flags = (t ? n : 0) + gl + (hf ? n - sh - mids : 0);  // F, G and H
    flagBits += flags;
    refBits += rb - flags;
    padBits += bytes * 8 - pos - rb;
    ++recs;
  }
  double hs = 0;
  for (auto& v : leafUseSlot) hs += entropyBits(v);
  uint64_t leafOnce = 0;
  for (uint64_t u : leafUse) leafOnce += u == 1;
  // leaves equal to another's complement (state ^ 1)
  std::set<uint32_t> leafSet;
  for (const auto& [o, i] : leafNo) leafSet.insert(load32(data + o));
  uint64_t compl1 = 0;
  for (uint32_t v : leafSet)
    if (v != (v ^ 0x55555555u) && leafSet.count(v ^ 0x55555555u)) ++compl1;
  std::fprintf(
      stderr,
      "h2 analysis: %llu records, bits: mask %llu B, uniform states %llu B (transparent %llu, opaque "
      "%llu), flags %llu B, refs %llu B, pad %llu B; distinct (mask, states) shapes %zu\n",
      (unsigned long long)recs, (unsigned long long)maskBits / 8, (unsigned long long)stateBits / 8,
      (unsigned long long)stHist[0], (unsigned long long)stHist[1], (unsigned long long)flagBits / 8,
      (unsigned long long)refBits / 8, (unsigned long long)padBits / 8, shapes.size());
  std::fprintf(stderr,
               "leaf refs: H(leaf) %.0f B, H(leaf | slot) %.0f B, leaves referenced once %llu, leaves whose "
               "complement is a leaf %llu of %u\n",
               entropyBits(leafUse) / 8, hs / 8, (unsigned long long)leafOnce, (unsigned long long)compl1,
               nLeaves);
  // h3: references into h2, how many h2 records referenced once
  std::map<uint32_t, uint32_t> h2use;
  uint64_t h3recs = 0, h3refBits = 0, h3refs = 0;
  for (const SdagRecordInfo& rec : all) {
    if (rec.height != 3) continue;
    const uint8_t* p = data + rec.offset;
    const uint32_t m = load16(p), n = popcount64(m);
    const uint32_t pos = sdagNodeFlags(p, n).pos, w = dir.width[k2], t = dir.tier[k2], u = dir.mid[k2];
    for (uint32_t j = 0; j < n; ++j)
      ++h2use[sdagChildInfo(data, dir, somm::Format::FourState, 2, rec.offset, pos, n, j).first];
    const uint32_t rb = sdagRefBits(p, pos, n, w, t, u);
    h3refBits += rb;
    h3refs += n;
    ++h3recs;
  }
  uint64_t once = 0;
  for (auto& [o, u] : h2use) once += u == 1;
  std::vector<uint64_t> h2u;
  h2u.reserve(h2use.size());
  for (auto& [o, u] : h2use) h2u.push_back(u);
  std::fprintf(
      stderr,
      "h3: %llu records, %llu refs into h2 (%llu B of refs+flags, H %.0f B), h2 records referenced once "
      "from h3: %llu of %zu referenced\n",
      (unsigned long long)h3recs, (unsigned long long)h3refs, (unsigned long long)h3refBits / 8,
      entropyBits(h2u) / 8, (unsigned long long)once, h2use.size());
  {
    std::map<int32_t, uint64_t> hist;
    uint64_t runs = 0;
    int32_t prev = 1 << 30;
    for (int32_t v : a.indices()) {
      ++hist[v < 0 ? v : 0];
      runs += v != prev;
      prev = v;
    }
    std::vector<uint64_t> hv;
    std::map<int32_t, uint64_t> full;
    for (int32_t v : a.indices()) ++full[v];
    hv.reserve(full.size());
    for (auto& [v, c] : full) hv.push_back(c);
    std::fprintf(stderr,
                 "index: %zu triangles, maps %llu, -1 %llu, -2 %llu, -3 %llu, -4 %llu, runs %llu, H %.0f B\n",
                 a.indices().size(), (unsigned long long)hist[0], (unsigned long long)hist[-1],
                 (unsigned long long)hist[-2], (unsigned long long)hist[-3], (unsigned long long)hist[-4],
                 (unsigned long long)runs, entropyBits(hv) / 8);
  }
}

struct Options {
  std::vector<std::string> scenes;
  std::string scene;  // the scenes' names, joined by ' + '

  std::string levels = "4,6,8,10,12";
  std::string formats = "2,4";
  bool json = false;
  std::string plot;
  uint32_t threads = 0;
  std::vector<std::string> limits;
  uint32_t lookups = 20000;
  float texelsPerMicroTri = 0;  // > 0: each level is a cap of adaptive levels
  bool sdagStats = false;
  somm::cli::MaterialOverrides material;  // --filter, --cutoff, --blend-as-mask, as in somm bake
};

struct Row {
  uint32_t level = 0;
  uint32_t states = 2;
  uint64_t triangles = 0, maps = 0;
  std::array<uint64_t, somm::kEncodingCount> bytes{};  // by Encoding: the scene-wide array
  std::array<double, somm::kEncodingCount> ns{};       // ns per random (u, v) lookup, 0 = not measured
  uint64_t xz = 0;                                     // xz -9 of the flat array's bytes
  std::string error;  // non-empty: the row hit a limit (bake work, encoded size) and holds no sizes
  double ratio(Encoding e) const { return bytes[0] ? double(bytes[size_t(e)]) / double(bytes[0]) : 0.0; }
  double ratioTo(Encoding e, uint64_t base) const {
    return base ? double(bytes[size_t(e)]) / double(base) : 0.0;
  }
};

// Thread CPU time in ns (the machine may be shared: wall time would measure the neighbours).
double cpuNs() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e9 + double(t.tv_nsec);
}

// Random hits on triangles that have a micromap: (triangle, u, v).
struct Queries {
  std::vector<uint32_t> tri;
  std::vector<float> u, v;
};
Queries makeQueries(const somm::OmmArray& a, uint32_t n) {
  Queries q;
  std::vector<uint32_t> withMap;
  for (uint32_t t = 0; t < a.indices.size(); ++t)
    if (a.indices[t] >= 0) withMap.push_back(t);
  if (withMap.empty()) return q;
  uint64_t x = 0x9e3779b97f4a7c15ull;
  auto next = [&] {
    x ^= x << 13, x ^= x >> 7, x ^= x << 17;
    return x;
  };
  for (uint32_t i = 0; i < n; ++i) {
    float u = float(next() >> 40) / float(1 << 24), v = float(next() >> 40) / float(1 << 24);
    if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
    q.tri.push_back(withMap[next() % withMap.size()]);
    q.u.push_back(u);
    q.v.push_back(v);
  }
  return q;
}

// Best of three passes; -1 when a lookup disagrees with the flat array.
template <Encoding E>
double lookupNs(const somm::EncodedArray& a, const somm::OmmArray& flat, const Queries& q) {
  for (size_t i = 0; i < q.tri.size(); ++i)
    if (a.stateUVAs<E>(q.tri[i], q.u[i], q.v[i]) != flat.stateUV(q.tri[i], q.u[i], q.v[i])) return -1;
  double best = 1e30;
  for (int rep = 0; rep < 3; ++rep) {
    const double t0 = cpuNs();
    uint32_t sum = 0;
    for (size_t i = 0; i < q.tri.size(); ++i) sum += uint32_t(a.stateUVAs<E>(q.tri[i], q.u[i], q.v[i]));
    const double t = cpuNs() - t0;
    volatile uint32_t sink = sum;
    (void)sink;
    best = std::min(best, t / double(q.tri.size()));
  }
  return best;
}
double lookupNsAny(const somm::EncodedArray& a, const somm::OmmArray& flat, const Queries& q) {
  if (q.tri.empty()) return 0;
  switch (a.encoding()) {
    case Encoding::Flat:
      return lookupNs<Encoding::Flat>(a, flat, q);
    case Encoding::Dfs:
      return lookupNs<Encoding::Dfs>(a, flat, q);
    case Encoding::DfsFast:
      return lookupNs<Encoding::DfsFast>(a, flat, q);
    case Encoding::Rank:
      return lookupNs<Encoding::Rank>(a, flat, q);
    case Encoding::Hybrid:
      return lookupNs<Encoding::Hybrid>(a, flat, q);
    case Encoding::Csm:
      return lookupNs<Encoding::Csm>(a, flat, q);
    case Encoding::Sdag:
      return lookupNs<Encoding::Sdag>(a, flat, q);
  }
  return 0;
}

bool parseList(const std::string& text, std::vector<uint32_t>& out, uint32_t lo, uint32_t hi) {
  out.clear();
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    uint64_t v;
    if (!somm::cli::parseUInt(std::string_view(text).substr(start, comma - start), v) || v < lo || v > hi)
      return false;
    if (std::find(out.begin(), out.end(), uint32_t(v)) == out.end()) out.push_back(uint32_t(v));
    start = comma + 1;
  }
  std::sort(out.begin(), out.end());
  return !out.empty();
}

// ---- a tiny PNG line plot ----

// 5×7 glyphs for the characters the plot writes.
const char* glyph(char c) {
  switch (c) {
    case '0':
      return " ### #   ##  ### # ###  ##   # ### ";
    case '1':
      return "  #   ##    #    #    #    #   ### ";
    case '2':
      return " ### #   #    #   #   #   #   #####";
    case '3':
      return "#####   #   #     #     ##   # ### ";
    case '4':
      return "   #   ##  # # #  # #####   #    # ";
    case '5':
      return "######    ####     #    ##   # ### ";
    case '6':
      return "  ##  #   #    #### #   ##   # ### ";
    case '7':
      return "#####    #   #   #   #    #    #   ";
    case '8':
      return " ### #   ##   # ### #   ##   # ### ";
    case '9':
      return " ### #   ##   # ####    #   #  ##  ";
    case '.':
      return "                          ##   ##  ";
    case '-':
      return "               #####               ";
    case 'a':
      return "           ###     # #####   # ####";
    case 'b':
      return "#    #    # ## ##  ##   ##   ##### ";
    case 'd':
      return "    #    # ## ##  ###   ##   # ####";
    case 'e':
      return "           ### #   #######     ### ";
    case 'f':
      return "  ##  #  # #   ###   #    #    #   ";
    case 'h':
      return "#    #    # ## ##  ##   ##   ##   #";
    case 'i':
      return "  #        ##    #    #    #   ### ";
    case 'k':
      return "#    #    #  # # #  ##   # #  #  # ";
    case 'l':
      return " ##    #    #    #    #    #   ### ";
    case 'n':
      return "          # ## ##  ##   ##   ##   #";
    case 'o':
      return "           ### #   ##   ##   # ### ";
    case 'r':
      return "          # ## ##  ##    #    #    ";
    case 's':
      return "           #### #     ###     #### ";
    case 't':
      return " #    #   ###  #    #    #  #  ##  ";
    case 'v':
      return "          #   ##   ##   # # #   #  ";
    case 'y':
      return "          #   ##   # ####    # ### ";
    case 'x':
      return "          #   # # #   #   # # #   #";
    case ',':
      return "                         ##   #  # ";
    case ':':
      return "      ##   ##        ##   ##       ";
    default:
      return nullptr;
  }
}

struct Canvas {
  int w, h;
  std::vector<uint8_t> px;
  Canvas(int width, int height) : w(width), h(height), px(size_t(width) * size_t(height) * 4, 255) {}
  void set(int x, int y, std::array<uint8_t, 3> c) {
    if (x < 0 || y < 0 || x >= w || y >= h) return;
    uint8_t* p = &px[(size_t(y) * size_t(w) + size_t(x)) * 4];
    p[0] = c[0], p[1] = c[1], p[2] = c[2], p[3] = 255;
  }
  void line(int x0, int y0, int x1, int y1, std::array<uint8_t, 3> c, int width = 1, int dash = 0) {
    const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0), sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
    int err = dx + dy, step = 0;
    while (true) {
      if (dash == 0 || (step / dash) % 2 == 0)
        for (int i = -(width / 2); i <= width / 2; ++i)
          for (int j = -(width / 2); j <= width / 2; ++j) set(x0 + i, y0 + j, c);
      ++step;
      if (x0 == x1 && y0 == y1) break;
      const int e2 = 2 * err;
      if (e2 >= dy) err += dy, x0 += sx;
      if (e2 <= dx) err += dx, y0 += sy;
    }
  }
  void text(int x, int y, const std::string& s, std::array<uint8_t, 3> c) {
    for (char ch : s) {
      if (const char* g = glyph(ch))
        for (int r = 0; r < 7; ++r)
          for (int k = 0; k < 5; ++k)
            if (size_t(r) * 5 + size_t(k) < std::char_traits<char>::length(g) && g[r * 5 + k] == '#')
              set(x + k, y + r, c);
      x += 6;
    }
  }
};

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

somm::Status writePlot(const std::string& path, const std::vector<Row>& rows,
                       const std::vector<uint32_t>& levels, const std::vector<uint32_t>& formats) {
  Canvas cv(900, 520);
  const int left = 70, right = 700, top = 20, bottom = 470;
  double lo = 1, hi = 1;
  for (const Row& r : rows)
    for (Encoding e : somm::kAllEncodings)
      if (r.ratio(e) > 0) lo = std::min(lo, r.ratio(e)), hi = std::max(hi, r.ratio(e));
  const double l0 = std::floor(std::log10(lo)), l1 = std::max(std::ceil(std::log10(hi)), l0 + 1);
  const double x0 = levels.front(), x1 = std::max<double>(levels.back(), x0 + 1);
  auto X = [&](double level) { return int(left + (level - x0) / (x1 - x0) * (right - left)); };
  auto Y = [&](double ratio) { return int(bottom - (std::log10(ratio) - l0) / (l1 - l0) * (bottom - top)); };
  const std::array<uint8_t, 3> grid{220, 220, 220}, ink{0, 0, 0};
  for (double d = l0; d <= l1 + 1e-9; d += 1) {
    cv.line(left, Y(std::pow(10, d)), right, Y(std::pow(10, d)), grid);
    cv.text(4, Y(std::pow(10, d)) - 3, fmt("%g", std::pow(10, d)), ink);
  }
  for (uint32_t l : levels) {
    cv.line(X(l), top, X(l), bottom, grid);
    cv.text(X(l) - 5, bottom + 8, std::to_string(l), ink);
  }
  cv.line(left, bottom, right, bottom, ink);
  cv.line(left, top, left, bottom, ink);
  cv.text((left + right) / 2 - 15, bottom + 24, "level", ink);
  cv.text(4, 4, "ratio to flat", ink);
  const std::array<std::array<uint8_t, 3>, somm::kEncodingCount> colors{{{0, 0, 0},
                                                                         {214, 39, 40},
                                                                         {255, 127, 14},
                                                                         {31, 119, 180},
                                                                         {44, 160, 44},
                                                                         {148, 103, 189},
                                                                         {140, 86, 75}}};
  int legendY = top + 10;
  for (Encoding e : somm::kAllEncodings)
    for (uint32_t f : formats) {
      const int dash = f == 4 ? 6 : 0;
      int px = -1, py = -1;
      for (const Row& r : rows) {
        if (r.states != f || r.ratio(e) <= 0) continue;
        const int x = X(r.level), y = Y(r.ratio(e));
        // dfs and dfs-fast (rank and often hybrid) coincide: the wider line of the first shows around the
        // second.
        const int width = e == Encoding::Dfs || e == Encoding::Rank ? 5 : 2;
        if (px >= 0) cv.line(px, py, x, y, colors[size_t(e)], width, dash);
        for (int i = -2; i <= 2; ++i) cv.line(x - 2, y + i, x + 2, y + i, colors[size_t(e)]);
        px = x, py = y;
      }
      cv.line(right + 15, legendY + 3, right + 45, legendY + 3, colors[size_t(e)], 2, dash);
      cv.text(right + 52, legendY, std::string(somm::encodingName(e)) + ", " + std::to_string(f) + "-state",
              ink);
      legendY += 14;
    }
  std::vector<uint8_t> png;
  auto sink = [](void* ctx, void* data, int size) {
    auto* v = static_cast<std::vector<uint8_t>*>(ctx);
    v->insert(v->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
  };
  if (!stbi_write_png_to_func(sink, &png, cv.w, cv.h, 4, cv.px.data(), cv.w * 4))
    return somm::makeError(somm::ErrorCode::IoError, path + ": PNG encoding failed");
  return somm::writeFileAtomically(path, png);
}

int run(const Options& o) {
  using namespace somm::cli;
  std::vector<uint32_t> levels, formats;
  if (!parseList(o.levels, levels, 0, somm::kMaxLevel)) {
    printError("compare", "--levels '" + o.levels + "' must be a comma list of levels 0..12");
    return kExitUsage;
  }
  if (!parseList(o.formats, formats, 2, 4) ||
      std::find(formats.begin(), formats.end(), 3u) != formats.end()) {
    printError("compare", "--formats '" + o.formats + "' must be a comma list of 2 and 4");
    return kExitUsage;
  }
  somm::BakeOptions overrides;
  if (!applyMaterialOverrides("compare", o.material, overrides)) return kExitUsage;
  somm::LoadOptions lo;
  lo.blendAsMask = o.material.blendAsMask;
  lo.loadColor = false;      // compare bakes: the alpha
  lo.loadPositions = false;  // and the UVs are all it reads
  if (!applyLimits("compare", o.limits, lo.limits)) return kExitUsage;
  somm::Scene scene;
  if (o.scene.rfind("procedural:leaf-cards", 0) == 0 && o.scenes.size() == 1) {
    uint64_t cards = 64;
    const std::string rest = o.scene.substr(std::string("procedural:leaf-cards").size());
    if (!rest.empty() &&
        (rest[0] != ':' || !parseUInt(rest.substr(1), cards) || cards == 0 || cards > 100000)) {
      printError("compare",
                 "scene '" + o.scene + "': expected procedural:leaf-cards[:N] with N in 1..100000");
      return kExitUsage;
    }
    scene = somm::makeLeafCardScene(uint32_t(cards), 1);
  } else {
    // Several files are one scene (e.g. every model of a game's foliage): geometries in file order.
    for (const std::string& path : o.scenes) {
      auto s = somm::loadScene(path, lo);
      if (!s) {
        printError("compare", s.error().message);
        return kExitFailure;
      }
      const uint32_t materialBase = uint32_t(scene.materials.size());
      scene.materials.insert(scene.materials.end(), s->materials.begin(), s->materials.end());
      for (somm::Geometry& g : s->geometries) {
        g.material += materialBase;
        scene.geometries.push_back(std::move(g));
      }
    }
  }
  scene.sourcePath = o.scene;
  std::vector<Row> rows;
  bool rowFailed = false;
  // A row that hits a limit (the bake's micro-triangle budget, as somm bake checks it; an encoded array over
  // 2 GiB) is reported and the other rows still run: a table of levels 8..12 keeps its feasible rows.
  auto limitRow = [&](Row& row, const std::string& message) {
    row.error = message;
    rowFailed = true;
    printError("compare", "level " + std::to_string(row.level) + ", " + std::to_string(row.states) +
                              "-state: " + message);
  };
  for (uint32_t states : formats)
    for (uint32_t level : levels) {
      Row row;
      row.level = level;
      row.states = states;
      somm::BakeOptions bo = overrides;
      bo.level = level;
      if (o.texelsPerMicroTri > 0) {
        bo.maxLevel = level;
        bo.texelsPerMicroTri = o.texelsPerMicroTri;
      }
      bo.format = states == 2 ? somm::Format::TwoState : somm::Format::FourState;
      bo.threads = o.threads;
      if (somm::Status st = checkBakeWork(scene, bo, lo.limits); !st) {
        limitRow(row, st.error().message);
        rows.push_back(row);
        continue;
      }
      // Per geometry with the library baker, then one scene-wide array (identical maps stored once) as the
      // default bake stores it: every encoding is built from that array.
      std::vector<somm::OmmArray> perGeometry;
      for (const somm::Geometry& g : scene.geometries) {
        if (g.material >= scene.materials.size()) continue;
        auto baked = somm::bakeGeometry(g, scene.materials[g.material], bo);
        if (!baked) {
          printError("compare", o.scene + ": geometry '" + g.name + "': " + baked.error().message);
          return kExitFailure;
        }
        perGeometry.push_back(std::move(baked->array));
      }
      const somm::SceneMicromaps sm =
          somm::mergeToSceneArray(somm::perGeometryMicromaps(std::move(perGeometry)));
      const somm::OmmArray flat = sm.arrays.empty() ? somm::OmmArray{} : sm.arrays[0];
      row.triangles = flat.indices.size();
      row.maps = flat.descriptors.size();
      const Queries q = makeQueries(flat, o.lookups);
      for (Encoding e : somm::kAllEncodings) {
        auto a = somm::EncodedArray::build(flat, e);
        if (!a && a.error().code == somm::ErrorCode::LimitExceeded) {
          limitRow(row, o.scene + ": " + a.error().message);
          break;
        }
        if (!a) {
          printError("compare", o.scene + ": " + a.error().message);
          return kExitFailure;
        }
        row.bytes[size_t(e)] = a->byteSize();
        if (e == Encoding::Sdag && o.sdagStats) {
          // Bytes per DAG height (both formats) and the maps stored flat.
          const auto& dir = a->directory();
          std::string line = "sdag L" + std::to_string(level) + ":";
          for (uint32_t h = 1; h <= 6; ++h) {
            uint64_t b = 0, w = 0, t = 0, u = 0, loc = 0;
            for (uint32_t f = 1; f <= 2; ++f) {
              const uint32_t k = somm::encode::sdagRegion(somm::Format(f), h);
              b += dir.base[k + 1] - dir.base[k];
              w = std::max<uint64_t>(w, dir.width[k]);
              t = std::max<uint64_t>(t, dir.tier[k]);
              u = std::max<uint64_t>(u, dir.mid[k]);
              loc = std::max<uint64_t>(loc, dir.local[k]);
            }
            line += " h" + std::to_string(h) + " " + std::to_string(b) + " B (ref " + (loc ? "local " : "") +
                    std::to_string(w) + (t != 0 ? " or " + std::to_string(t - 1) : std::string()) +
                    (u != 0 ? " or " + std::to_string(u - 1) : std::string()) + " bits" +
                    (h == 1 && (dir.xform[0] | dir.xform[1]) != 0 ? ", with leaf transforms)" : ")");
          }
          // Records and references per height (4-state regions), and how the leaf references spread.
          {
            const uint8_t* data = a->data().data();
            std::vector<uint32_t> leafRefs;
            std::map<uint32_t, uint32_t> leafNo;
            const auto all = sdagRecords(*a, somm::Format::FourState);
            for (const auto& r : all)
              if (r.height == 1) leafNo.emplace(r.offset, uint32_t(leafNo.size()));
            leafRefs.assign(leafNo.size(), 0);
            uint64_t localRecs[7] = {};
            for (uint32_t h = 2; h <= 6; ++h) {
              uint64_t recs = 0, refs = 0;
              for (const auto& rec : all) {
                if (rec.height != h) continue;
                const uint8_t* p = data + rec.offset;
                const uint32_t m = somm::encode::load16(p), n = somm::encode::popcount64(m);
                const uint32_t pos = somm::encode::sdagNodeFlags(p, n).pos;
                if (h == 2)
                  for (uint32_t i = 0; i < n; ++i)
                    ++leafRefs[leafNo.at(
                        sdagChildInfo(data, dir, somm::Format::FourState, 1, rec.offset, pos, n, i).first)];
                ++recs;
                refs += n;
              }
              for (const auto& rec : all) localRecs[rec.height] += rec.local && rec.height == h - 1;
              line += " [h" + std::to_string(h) + ": " + std::to_string(recs) + " records, " +
                      std::to_string(refs) + " refs, " + std::to_string(localRecs[h - 1]) + " local h" +
                      std::to_string(h - 1) + "]";
            }
            std::sort(leafRefs.rbegin(), leafRefs.rend());
            uint64_t total = 0, top = 0, once = 0;
            for (size_t i = 0; i < leafRefs.size(); ++i) {
              total += leafRefs[i];
              if (i < 256) top += leafRefs[i];
              once += leafRefs[i] == 1;
            }
            line += " leaves " + std::to_string(leafRefs.size()) + ", refs " + std::to_string(total) +
                    ", to top-256 " + std::to_string(top) + ", leaves referenced once " +
                    std::to_string(once);
          }
          uint64_t flatMaps = 0;
          for (const auto& d : a->maps()) flatMaps += d.kind == somm::MapKind::Flat;
          line += ", other " + std::to_string(a->dataBytes() - dir.base[somm::encode::kSdagRegions]) +
                  " B, " + std::to_string(flatMaps) + " maps flat, indices+descriptors " +
                  std::to_string(a->byteSize() - a->dataBytes() - a->paddingBytes()) + " B\n";
          std::fputs(line.c_str(), stderr);
          printSdagAnalysis(*a);
        }
        if (e == Encoding::Flat) row.xz = xzBytes(a->serialize());
        row.ns[size_t(e)] = lookupNsAny(*a, flat, q);
        if (row.ns[size_t(e)] < 0) {
          printError("compare", o.scene + ": encoding " + somm::encodingName(e) + " disagrees with flat");
          return kExitFailure;
        }
      }
      rows.push_back(row);
    }

  Output out;
  if (o.json) {
    nlohmann::json j;
    j["scene"] = o.scene;
    nlohmann::json rs = nlohmann::json::array();
    for (const Row& r : rows) {
      nlohmann::json x{
          {"level", r.level}, {"format", r.states}, {"triangles", r.triangles}, {"micromaps", r.maps}};
      if (!r.error.empty()) {
        x["error"] = r.error;
        rs.push_back(std::move(x));
        continue;
      }
      for (Encoding e : somm::kAllEncodings) {
        nlohmann::json c{{"bytes", r.bytes[size_t(e)]},
                         {"ratio_to_flat", r.ratio(e)},
                         {"ratio_to_dfs", r.ratioTo(e, r.bytes[size_t(Encoding::Dfs)])},
                         {"ratio_to_csm", r.ratioTo(e, r.bytes[size_t(Encoding::Csm)])},
                         {"ratio_to_xz", r.ratioTo(e, r.xz)}};
        if (o.lookups) {
          c["lookup_ns"] = r.ns[size_t(e)];
          c["lookup_x_flat"] = r.ns[0] > 0 ? r.ns[size_t(e)] / r.ns[0] : 0.0;
        }
        x[somm::encodingName(e)] = std::move(c);
      }
      x["xz-9"] = {{"bytes", r.xz},
                   {"ratio_to_flat", r.bytes[0] ? double(r.xz) / double(r.bytes[0]) : 0.0},
                   {"random_access", false}};
      rs.push_back(std::move(x));
    }
    j["rows"] = rs;
    out.put(dumpJson(j));
    out.put("\n");
  } else {
    out.put("scene " + o.scene +
            ": bytes of each encoding (serialized array: header, indices, descriptors, data,\n"
            "padding) and ratio to flat\n");
    char buf[256];
    std::snprintf(buf, sizeof buf, "%5s %6s %8s %12s", "level", "format", "maps", "flat");
    out.put(buf);
    for (Encoding e : somm::kAllEncodings)
      if (e != Encoding::Flat) {
        std::snprintf(buf, sizeof buf, " %21s", somm::encodingName(e));
        out.put(buf);
      }
    out.put("\n");
    for (const Row& r : rows) {
      if (!r.error.empty()) {
        std::snprintf(buf, sizeof buf, "%5u %6u ", r.level, r.states);
        out.put(buf + ("error: " + r.error) + "\n");
        continue;
      }
      std::snprintf(buf, sizeof buf, "%5u %6u %8llu %12llu", r.level, r.states, (unsigned long long)r.maps,
                    (unsigned long long)r.bytes[0]);
      out.put(buf);
      for (Encoding e : somm::kAllEncodings)
        if (e != Encoding::Flat) {
          std::snprintf(buf, sizeof buf, " %12llu (%6.4f)", (unsigned long long)r.bytes[size_t(e)],
                        r.ratio(e));
          out.put(buf);
        }
      out.put("\n");
    }
    out.put("\nratios to dfs / csm / xz -9 of the flat array, and ns per random lookup (x flat, same run)\n");
    std::snprintf(buf, sizeof buf, "%5s %6s %10s", "level", "format", "xz-9");
    out.put(buf);
    for (Encoding e : somm::kAllEncodings) {
      std::snprintf(buf, sizeof buf, " %27s", somm::encodingName(e));
      out.put(buf);
    }
    out.put("\n");
    for (const Row& r : rows) {
      if (!r.error.empty()) continue;
      std::snprintf(buf, sizeof buf, "%5u %6u %10llu", r.level, r.states, (unsigned long long)r.xz);
      out.put(buf);
      for (Encoding e : somm::kAllEncodings) {
        std::snprintf(buf, sizeof buf, " %5.3f/%5.3f/%5.2f %5.0f(%4.2fx)",
                      r.ratioTo(e, r.bytes[size_t(Encoding::Dfs)]),
                      r.ratioTo(e, r.bytes[size_t(Encoding::Csm)]), r.ratioTo(e, r.xz), r.ns[size_t(e)],
                      r.ns[0] > 0 ? r.ns[size_t(e)] / r.ns[0] : 0.0);
        out.put(buf);
      }
      out.put("\n");
    }
  }
  out.flush();
  if (!o.plot.empty()) {
    std::vector<Row> plotted;
    for (const Row& r : rows)
      if (r.error.empty()) plotted.push_back(r);
    auto st = writePlot(o.plot, plotted, levels, formats);
    if (!st) {
      printError("compare", st.error().message);
      return kExitFailure;
    }
  }
  return rowFailed ? kExitFailure : kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd =
      root.add_subcommand("compare",
                          "Bake a scene at several levels and formats and print the memory of "
                          "every encoding (flat, dfs, dfs-fast, "
                          "rank, hybrid, csm, sdag) of the scene-wide array: exact bytes, ratios to "
                          "flat, dfs, csm and xz -9, ns per lookup. SCENE is a "
                          ".gltf/.glb/.obj file or procedural:leaf-cards[:N].");
  cmd->add_option("scene", opts->scenes,
                  "scene file(s) (several files are one scene) or procedural:leaf-cards[:N]")
      ->required();
  cmd->add_option("--levels", opts->levels, "comma list of subdivision levels 0..12 (default 4,6,8,10,12)");
  cmd->add_option("--formats", opts->formats, "comma list of formats: 2 and/or 4 states (default 2,4)");
  cmd->add_flag("--json", opts->json,
                "print JSON: rows of {level, format, triangles, micromaps, <encoding>: {bytes, "
                "ratio_to_flat}}");
  cmd->add_option("--plot", opts->plot, "write a PNG plot of the ratio to flat against the level");
  cmd->add_option("--threads", opts->threads, "bake threads (0 = all)")->check(CLI::Range(0u, 1024u));
  somm::cli::addLimitOption(cmd, opts->limits);
  cmd->add_option(
      "--texels-per-microtri", opts->texelsPerMicroTri,
      "adaptive levels (as bake --texels-per-microtri): each --levels value is the cap --max-level");
  cmd->add_flag("--sdag-stats", opts->sdagStats, "print the bytes of the sdag DAG per height to stderr");
  somm::cli::addMaterialOverrideOptions(cmd, opts->material);
  cmd->add_option(
      "--lookups", opts->lookups,
      "random (u, v) lookups timed per encoding, checked against flat (0 = do not time; default 20000)");
  cmd->callback([opts] {
    opts->scene.clear();
    for (const std::string& p : opts->scenes) opts->scene += (opts->scene.empty() ? "" : " + ") + p;
    somm::cli::setExitCode(run(*opts));
  });
}

const somm::cli::Registration reg("compare", &setup);

}  // namespace
