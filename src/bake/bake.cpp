// SPDX-License-Identifier: MIT
// somm — conservative OMM baking. Algorithm and conservativeness argument: docs/baking.md.
#include "somm/bake.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace somm {

namespace {

struct Interval {
  uint32_t lo, hi;  // inclusive
};

// The wrapped texel intervals of the unwrapped inclusive range [a, b] (a <= b); at most 4, possibly
// overlapping.
int wrapInterval(int64_t a, int64_t b, uint32_t size, Wrap w, Interval out[4]) noexcept {
  const int64_t n = int64_t(size);
  if (a >= 0 && b < n) {  // inside the texture: every wrap mode is the identity
    out[0] = {uint32_t(a), uint32_t(b)};
    return 1;
  }
  switch (w) {
    case Wrap::ClampToEdge:
      out[0] = {uint32_t(std::clamp<int64_t>(a, 0, n - 1)), uint32_t(std::clamp<int64_t>(b, 0, n - 1))};
      return 1;
    case Wrap::Repeat: {
      if (b - a + 1 >= n) {
        out[0] = {0, uint32_t(n - 1)};
        return 1;
      }
      int64_t ra = a % n;
      if (ra < 0) ra += n;
      const int64_t rb = ra + (b - a);
      if (rb < n) {
        out[0] = {uint32_t(ra), uint32_t(rb)};
        return 1;
      }
      out[0] = {uint32_t(ra), uint32_t(n - 1)};
      out[1] = {0, uint32_t(rb - n)};
      return 2;
    }
    case Wrap::MirroredRepeat: {
      if (b - a + 1 >= 2 * n) {
        out[0] = {0, uint32_t(n - 1)};
        return 1;
      }
      int64_t ra = a % (2 * n);
      if (ra < 0) ra += 2 * n;
      const int64_t rb = ra + (b - a);  // < 4n
      int k = 0;
      for (int64_t s = 0; s < 4 && k < 4; ++s) {
        const int64_t lo = std::max(ra, s * n), hi = std::min(rb, (s + 1) * n - 1);
        if (lo > hi) continue;
        if (s % 2 == 0)
          out[k++] = {uint32_t(lo - s * n), uint32_t(hi - s * n)};
        else
          out[k++] = {uint32_t((s + 1) * n - 1 - hi), uint32_t((s + 1) * n - 1 - lo)};
      }
      return k;
    }
  }
  out[0] = {0, uint32_t(n - 1)};
  return 1;
}

// texelFloor without the libm call (std::floor is not inlined without SSE4.1).
inline int64_t cellFloor(double x) noexcept {
  if (!(std::fabs(x) < 1e15)) return texelFloor(x);
  const int64_t i = int64_t(x);
  return i - (double(i) > x ? 1 : 0);
}

// wrapTexel with a fast path for indices inside the texture.
inline uint32_t wrapFast(int64_t i, uint32_t size, Wrap w) noexcept {
  return i >= 0 && i < int64_t(size) ? uint32_t(i) : wrapTexel(i, size, w);
}

constexpr unsigned kPass = 1, kFail = 2, kMixed = 3;

inline double min3(const double v[3]) {
  return std::min(v[0], std::min(v[1], v[2]));
}
inline double max3(const double v[3]) {
  return std::max(v[0], std::max(v[1], v[2]));
}

uint8_t fillByte(Format f, State s) {
  if (f == Format::TwoState) return (uint8_t(s) & 1u) ? 0xffu : 0x00u;
  const uint8_t v = uint8_t(s) & 3u;
  return uint8_t(v | (v << 2) | (v << 4) | (v << 6));
}

// Linear filter: regions touching at most this many cells get the exact bilinear bound (leaves / inner
// nodes).
constexpr int64_t kLeafCells = 1024, kNodeCells = 4;

// Texel coordinates at or beyond this magnitude make a triangle unknown (texelFloor clamps at 1e15).
constexpr double kMaxTexelCoord = 1e14;

// Rows of cells beyond which a region is declared mixed without enumerating (still conservative).
constexpr int64_t kMaxRows = int64_t(1) << 22;

// Classifies one triangle's micro-triangles. Coordinates are in "cell space": texel space for nearest, texel
// space shifted by −½ for linear (cell i of the shifted grid blends texels i and i + 1).
struct TriangleClassifier {
  const AlphaMask& mask;
  double margin = 0;
  double shift = 0;  // 0 nearest, 0.5 linear
  int64_t ext = 0;   // 0 nearest, 1 linear: cell range [i0, i1] reads texels [i0, i1 + ext]
  uint32_t level = 0;
  Format format = Format::FourState;
  UnknownAs unknownAs = UnknownAs::Majority;
  uint8_t* bytes = nullptr;
  uint64_t unknown = 0;

  unsigned rect(int64_t i0, int64_t i1, int64_t j0, int64_t j1) const noexcept {
    const AlphaMask::Count c = mask.count(i0, i1 + ext, j0, j1 + ext);
    return (c.pass > 0 ? kPass : 0u) | (c.pass < c.total ? kFail : 0u);
  }

  // The x-extent [xl, xr] of the triangle within the horizontal slab [ya, yb]; false when they do not meet.
  static bool slabExtent(const double X[3], const double Y[3], double ya, double yb, double& xl,
                         double& xr) noexcept {
    xl = std::numeric_limits<double>::infinity();
    xr = -xl;
    for (int k = 0; k < 3; ++k) {
      if (Y[k] >= ya && Y[k] <= yb) {
        xl = std::min(xl, X[k]);
        xr = std::max(xr, X[k]);
      }
      const int k1 = k == 2 ? 0 : k + 1;
      const double dy = Y[k1] - Y[k];
      for (const double c : {ya, yb}) {
        if ((Y[k] < c && Y[k1] > c) || (Y[k] > c && Y[k1] < c)) {
          const double x = X[k] + (c - Y[k]) / dy * (X[k1] - X[k]);
          xl = std::min(xl, x);
          xr = std::max(xr, x);
        }
      }
    }
    return xl <= xr;
  }

  static unsigned decide(double lo, double hi, float cutoff, double tol) noexcept {
    if (lo >= double(cutoff) + tol) return kPass;
    if (hi < double(cutoff) - tol) return kFail;
    return kMixed;  // also NaN
  }

  // Range of f = A + Bx + Cy + Dxy over the convex polygon (px, py): its vertices and the stationary points
  // of its restriction to each edge.
  static void polygonRange(double A, double B, double C, double D, const double* px, const double* py, int n,
                           double& lo, double& hi) noexcept {
    auto f = [&](double x, double y) { return A + B * x + C * y + D * x * y; };
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    for (int q = 0; q < n; ++q) {
      const double v = f(px[q], py[q]);
      lo = std::min(lo, v);
      hi = std::max(hi, v);
      const int q1 = q + 1 == n ? 0 : q + 1;
      const double ex = px[q1] - px[q], ey = py[q1] - py[q];
      // f along the edge: v + c1·t + c2·t², stationary at t = −c1 / (2·c2) with value v − c1² / (4·c2).
      const double c2 = D * ex * ey, c1 = B * ex + C * ey + D * (px[q] * ey + py[q] * ex);
      if ((c1 < 0) != (c2 < 0) && std::fabs(c1) < 2 * std::fabs(c2)) {
        const double w = v - c1 * c1 / (4 * c2);
        lo = std::min(lo, w);
        hi = std::max(hi, w);
      }
    }
    if (std::isnan(lo) || std::isnan(hi)) lo = hi = std::numeric_limits<double>::quiet_NaN();
  }

  // The exact-per-cell bound: T (cell-local) clipped to [−m, 1 + m]² (Sutherland–Hodgman), then polygonRange.
  unsigned clippedCell(double A, double B, double C, double D, const double tx[3], const double ty[3],
                       double grow, float cutoff, double tol) const noexcept {
    const double m = margin;
    double buf[2][2][48];  // each clip at most doubles the count (3 · 2^4)
    double *px = buf[0][0], *py = buf[0][1], *qx = buf[1][0], *qy = buf[1][1];
    int n = 3;
    std::copy(tx, tx + 3, px);
    std::copy(ty, ty + 3, py);
    for (int side = 0; side < 4 && n > 0; ++side) {
      const bool isX = side < 2;
      const double c = (side & 1) ? 1 + m : -m;
      const double sign = (side & 1) ? -1.0 : 1.0;  // inside: sign · (coord − c) >= 0
      int o = 0;
      for (int q = 0; q < n; ++q) {
        const int q1 = q + 1 == n ? 0 : q + 1;
        const double d0 = sign * ((isX ? px[q] : py[q]) - c), d1 = sign * ((isX ? px[q1] : py[q1]) - c);
        if (d0 >= 0) {
          qx[o] = px[q];
          qy[o++] = py[q];
        }
        if ((d0 >= 0) != (d1 >= 0)) {
          const double u = d0 / (d0 - d1);
          qx[o] = isX ? c : px[q] + u * (px[q1] - px[q]);
          qy[o++] = isX ? py[q] + u * (py[q1] - py[q]) : c;
        }
      }
      n = o;
      std::swap(px, qx);
      std::swap(py, qy);
    }
    if (n == 0) return 0;  // T does not come within m of the cell
    double lo, hi;
    polygonRange(A, B, C, D, px, py, n, lo, hi);
    return decide(lo - grow, hi + grow, cutoff, tol);
  }

  // kPass / kFail / kMixed for the closed triangle (X, Y) grown by the margin (Minkowski sum with a square):
  // the cells it touches all pass / all fail / neither. `cellLimit`: for the linear filter, regions touching
  // at most this many cells get the exact bilinear bound (bilinearCells) instead of the four-corner bound.
  unsigned region(const double X[3], const double Y[3], int64_t cellLimit) const noexcept {
    const double m = margin;
    const int64_t i0 = cellFloor(min3(X) - m), i1 = cellFloor(max3(X) + m);
    const int64_t j0 = cellFloor(min3(Y) - m), j1 = cellFloor(max3(Y) + m);
    const unsigned box = rect(i0, i1, j0, j1);
    if (box != kMixed) return box;
    if (ext && i1 - i0 < cellLimit && j1 - j0 < cellLimit && (i1 - i0 + 1) * (j1 - j0 + 1) <= cellLimit)
      return bilinearCells(X, Y, j0, j1);
    if (j0 == j1) return box;
    if (j1 - j0 > kMaxRows) return kMixed;
    // Exact: per row of cells, the x-extent of the grown triangle within the row.
    unsigned acc = 0;
    for (int64_t j = j0; j <= j1; ++j) {
      double xl, xr;
      if (!slabExtent(X, Y, double(j) - m, double(j + 1) + m, xl, xr)) continue;
      acc |= rect(cellFloor(xl - m), cellFloor(xr + m), j, j);
      if (acc == kMixed) return kMixed;
    }
    return acc;
  }

  // Linear filter, exact per cell: for every cell the grown triangle touches (row runs as in region()), a
  // cell whose four corners agree is decided by them; otherwise the bilinear surface f of the cell is bounded
  // over the part of the grown triangle inside the cell. That part is within distance m (per axis) of T ∩
  // (cell ⊕ square m): clip T to the cell grown by m, bound f (extended as the same polynomial) there — a
  // bilinear function takes its extremes over a convex polygon on the boundary, at a vertex or where its
  // restriction to an edge (a quadratic) is stationary — and widen by m times the gradient bound. Values
  // within 1e-6 of the cutoff stay unknown (sampleAlpha's rounding).
  unsigned bilinearCells(const double X[3], const double Y[3], int64_t j0, int64_t j1) const noexcept {
    const double m = margin;
    const AlphaTexture& t = *mask.texture();
    const Sampler& smp = mask.sampler();
    const float cutoff = mask.cutoff();
    const double tol = 1e-6 * std::max(1.0, std::fabs(double(cutoff)));
    unsigned acc = 0;
    for (int64_t j = j0; j <= j1; ++j) {
      double xl, xr;
      if (!slabExtent(X, Y, double(j) - m, double(j + 1) + m, xl, xr)) continue;
      const uint32_t ya = wrapFast(j, t.height, smp.wrapT), yb = wrapFast(j + 1, t.height, smp.wrapT);
      const int64_t a = cellFloor(xl - m), b = cellFloor(xr + m);
      for (int64_t i = a; i <= b; ++i) {
        const uint32_t xa = wrapFast(i, t.width, smp.wrapS), xb = wrapFast(i + 1, t.width, smp.wrapS);
        const float c00 = t.at(xa, ya), c10 = t.at(xb, ya), c01 = t.at(xa, yb), c11 = t.at(xb, yb);
        const int passes = alphaTestPasses(c00, cutoff) + alphaTestPasses(c10, cutoff) +
                           alphaTestPasses(c01, cutoff) + alphaTestPasses(c11, cutoff);
        if (passes == 4 || passes == 0) {
          acc |= passes ? kPass : kFail;
          if (acc == kMixed) return kMixed;
          continue;
        }
        const double A = c00, B = double(c10) - A, C = double(c01) - A, D = double(c11) - c10 - c01 + A;
        const double grow = m * (std::fabs(B) + std::fabs(C) + 2 * std::fabs(D) * (1 + 2 * m));
        double px[3], py[3];
        for (int k = 0; k < 3; ++k) {
          px[k] = X[k] - double(i);
          py[k] = Y[k] - double(j);
        }
        // Cheap first: the cell's polynomial over the whole of T (a superset of T's part near the cell),
        // bounded by its degree-2 Bernstein coefficients on T: the vertex values and, per edge, (f_i + f_j)/2
        // − D·Δx·Δy/2.
        double fv[3], lo, hi;
        for (int k = 0; k < 3; ++k) fv[k] = A + B * px[k] + C * py[k] + D * px[k] * py[k];
        lo = hi = fv[0];
        for (int k = 0; k < 3; ++k) {
          const int k1 = k == 2 ? 0 : k + 1;
          const double e = (fv[k] + fv[k1]) * 0.5 - D * (px[k1] - px[k]) * (py[k1] - py[k]) * 0.5;
          lo = std::min(lo, std::min(fv[k], e));
          hi = std::max(hi, std::max(fv[k], e));
        }
        unsigned cls = decide(lo - grow, hi + grow, cutoff, tol);
        if (cls == kMixed) {
          // Vertices of T inside this cell are points of the region where the blend is f itself: if they
          // (with what other cells showed) see both classes, the region is mixed — no need for the exact
          // bound.
          unsigned seen = acc;
          for (int k = 0; k < 3; ++k)
            if (px[k] >= 0 && px[k] <= 1 && py[k] >= 0 && py[k] <= 1)
              seen |= fv[k] >= double(cutoff) ? kPass : kFail;
          if (seen == kMixed) return kMixed;
        }
        if (cls == kMixed) cls = clippedCell(A, B, C, D, px, py, grow, cutoff, tol);
        acc |= cls;
        if (acc == kMixed) return kMixed;
      }
    }
    return acc ? acc : kMixed;
  }

  void fill(uint32_t start, uint32_t count, State s) noexcept {
    const uint32_t perByte = format == Format::TwoState ? 8u : 4u;
    if (count >= perByte) {
      std::memset(bytes + start / perByte, fillByte(format, s), count / perByte);
    } else {
      for (uint32_t i = 0; i < count; ++i) writePackedState(bytes, format, start + i, s);
    }
  }

  // The alpha test at cell-space point (x, y), evaluated like sampleAlpha but directly in cell space (used
  // only for the majority of unknown micro-triangles, which needs no exactness).
  bool passesAt(double x, double y) const noexcept {
    const AlphaTexture& t = *mask.texture();
    const Sampler& smp = mask.sampler();
    const int64_t i = cellFloor(x), j = cellFloor(y);
    const uint32_t xa = wrapFast(i, t.width, smp.wrapS), ya = wrapFast(j, t.height, smp.wrapT);
    if (shift == 0) return alphaTestPasses(t.at(xa, ya), mask.cutoff());
    const uint32_t xb = wrapFast(i + 1, t.width, smp.wrapS), yb = wrapFast(j + 1, t.height, smp.wrapT);
    const double fx = x - double(i), fy = y - double(j);
    const double top = double(t.at(xa, ya)) * (1 - fx) + double(t.at(xb, ya)) * fx;
    const double bot = double(t.at(xa, yb)) * (1 - fx) + double(t.at(xb, yb)) * fx;
    return alphaTestPasses(float(top * (1 - fy) + bot * fy), mask.cutoff());
  }

  // The state an unknown micro-triangle gets: by majority of the alpha test at the centroids of its 4
  // children (ties: its own centroid), or as the 2-state option says.
  State unknownState(const double X[3], const double Y[3]) const noexcept {
    if (format == Format::TwoState && unknownAs != UnknownAs::Majority)
      return unknownAs == UnknownAs::Opaque ? State::Opaque : State::Transparent;
    // Child centroids in barycentric terms: (4,1,1)/6, (1,4,1)/6, (1,1,4)/6 and (1,1,1)/3 (the middle child).
    static constexpr double w[4][3] = {{4. / 6, 1. / 6, 1. / 6},
                                       {1. / 6, 4. / 6, 1. / 6},
                                       {1. / 6, 1. / 6, 4. / 6},
                                       {1. / 3, 1. / 3, 1. / 3}};
    int pass = 0;
    for (const auto& b : w)
      pass += passesAt(b[0] * X[0] + b[1] * X[1] + b[2] * X[2], b[0] * Y[0] + b[1] * Y[1] + b[2] * Y[2]);
    bool opaque;
    if (pass != 2) {
      opaque = pass > 2;
    } else {
      // The middle child's centroid is the parent's centroid; break the tie with a point between it and
      // vertex 0.
      opaque = passesAt((2 * X[0] + X[1] + X[2]) / 4, (2 * Y[0] + Y[1] + Y[2]) / 4);
    }
    if (format == Format::TwoState) return opaque ? State::Opaque : State::Transparent;
    return opaque ? State::UnknownOpaque : State::UnknownTransparent;
  }

  // Node `prefix` at `depth` with cell-space vertices (X, Y) whose region class is `r`.
  void node(const double X[3], const double Y[3], uint32_t depth, uint32_t prefix, unsigned r) noexcept {
    const uint32_t span = 1u << (2 * (level - depth));
    const uint32_t start = prefix * span;
    if (r == kPass) return fill(start, span, State::Opaque);
    if (r == kFail) return fill(start, span, State::Transparent);
    if (depth == level) {
      ++unknown;
      return fill(start, 1, unknownState(X, Y));
    }
    const double ax = X[0], ay = Y[0], bx = X[1], by = Y[1], cx = X[2], cy = Y[2];
    const double abx = (ax + bx) * 0.5, aby = (ay + by) * 0.5;
    const double acx = (ax + cx) * 0.5, acy = (ay + cy) * 0.5;
    const double bcx = (bx + cx) * 0.5, bcy = (by + cy) * 0.5;
    // Child order of the bird curve (see indexToMicroTriangle).
    const double cX[4][3] = {{ax, abx, acx}, {acx, bcx, abx}, {abx, bx, bcx}, {bcx, acx, cx}};
    const double cY[4][3] = {{ay, aby, acy}, {acy, bcy, aby}, {aby, by, bcy}, {bcy, acy, cy}};
    const int64_t limit = depth + 1 == level ? kLeafCells : kNodeCells;
    for (uint32_t c = 0; c < 4; ++c)
      node(cX[c], cY[c], depth + 1, prefix * 4 + c, region(cX[c], cY[c], limit));
  }
};

bool finite2(const std::array<float, 2>& p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]);
}

// One triangle's outcome: a uniform state (no map needed) or a map.
struct Baked {
  std::optional<State> uniform;
  Micromap map;
  uint64_t unknown = 0;
  bool nonFinite = false;
};

State wholeUnknown(Format format, UnknownAs unknownAs) {
  if (format == Format::FourState) return State::UnknownOpaque;
  return unknownAs == UnknownAs::Transparent ? State::Transparent : State::Opaque;
}

void bakeOne(const AlphaMask& mask, std::array<float, 2> uv0, std::array<float, 2> uv1,
             std::array<float, 2> uv2, uint32_t level, Format format, UnknownAs unknownAs, Baked& out) {
  out.uniform.reset();
  out.unknown = 0;
  out.nonFinite = false;
  const double W = mask.width(), H = mask.height();
  double X[3] = {double(uv0[0]) * W, double(uv1[0]) * W, double(uv2[0]) * W};
  double Y[3] = {double(uv0[1]) * H, double(uv1[1]) * H, double(uv2[1]) * H};
  // NaN/inf UVs, or texel coordinates so large that sampleAlpha's clamped texel arithmetic no longer
  // interpolates
  // (|x| ≥ 1e15): not classified.
  bool usable = true;
  for (int k = 0; k < 3; ++k)
    usable = usable && std::fabs(X[k]) < kMaxTexelCoord && std::fabs(Y[k]) < kMaxTexelCoord;
  if (!usable) {
    out.nonFinite = true;
    out.uniform = wholeUnknown(format, unknownAs);
    out.unknown = microTriangleCount(level);
    return;
  }
  TriangleClassifier c{mask};
  c.margin = bakeMarginTexels(X, Y);
  c.shift = mask.sampler().filter == Filter::Linear ? 0.5 : 0.0;
  c.ext = mask.sampler().filter == Filter::Linear ? 1 : 0;
  c.level = level;
  c.format = format;
  c.unknownAs = unknownAs;
  for (int k = 0; k < 3; ++k) {
    X[k] -= c.shift;
    Y[k] -= c.shift;
  }
  const unsigned r = c.region(X, Y, level == 0 ? kLeafCells : kNodeCells);
  if (r == kPass || r == kFail) {
    out.uniform = r == kPass ? State::Opaque : State::Transparent;
    return;
  }
  if (level == 0) {
    out.uniform = c.unknownState(X, Y);
    out.unknown = 1;
    return;
  }
  // Every micro-triangle is written by node(), so a map of the same shape from an earlier triangle is reused
  // as is.
  if (out.map.level() != level || out.map.format() != format) out.map = Micromap(level, format);
  c.bytes = out.map.bytes().data();
  c.node(X, Y, 0, 0, r);
  out.unknown = c.unknown;
}

std::array<float, 2> uvOf(const Geometry& g, uint32_t vertex) {
  return {g.uvs[2 * size_t(vertex)], g.uvs[2 * size_t(vertex) + 1]};
}

Status validateGeometry(const Geometry& g, bool needUvs) {
  const std::string name = "geometry '" + g.name + "'";
  if (g.indices.size() % 3 != 0)
    return makeError(ErrorCode::InvalidArgument,
                     name + ": index count " + std::to_string(g.indices.size()) + " is not a multiple of 3");
  if (!needUvs) return Ok{};
  if (g.uvs.size() % 2 != 0) return makeError(ErrorCode::InvalidArgument, name + ": odd number of UV floats");
  const size_t vertices = g.uvs.size() / 2;
  for (uint32_t i : g.indices)
    if (i >= vertices)
      return makeError(ErrorCode::InvalidArgument, name + ": index " + std::to_string(i) + " out of range (" +
                                                       std::to_string(vertices) + " vertices with UVs)");
  return Ok{};
}

Status validateTexture(const Material& m) {
  const AlphaTexture& t = *m.alpha;
  const std::string name =
      "material '" + m.name + "' alpha texture" + (m.alphaSource.empty() ? "" : " " + m.alphaSource);
  if (t.width == 0 || t.height == 0) return makeError(ErrorCode::InvalidArgument, name + ": empty texture");
  if (uint64_t(t.width) * t.height >= (uint64_t(1) << 32))
    return makeError(ErrorCode::LimitExceeded, name + ": texture too large");
  if (t.alpha.size() != size_t(t.width) * t.height)
    return makeError(ErrorCode::InvalidArgument, name + ": alpha has " + std::to_string(t.alpha.size()) +
                                                     " values for " + std::to_string(t.width) + "x" +
                                                     std::to_string(t.height));
  return Ok{};
}

Sampler effectiveSampler(const Material& m, const BakeOptions& o) {
  Sampler s = m.sampler;
  if (o.filter) s.filter = *o.filter;
  return s;
}

float effectiveCutoff(const Material& m, const BakeOptions& o) {
  return o.cutoff ? *o.cutoff : m.alphaCutoff;
}

// Level per triangle before any maxBytes cap.
std::vector<uint8_t> chooseLevels(const Geometry& g, const AlphaMask& mask, const BakeOptions& o) {
  const uint32_t n = g.triangleCount();
  std::vector<uint8_t> levels(n, uint8_t(o.level));
  if (o.texelsPerMicroTri > 0) {
    for (uint32_t t = 0; t < n; ++t)
      levels[t] = uint8_t(adaptiveLevel(uvOf(g, g.indices[3 * t]), uvOf(g, g.indices[3 * t + 1]),
                                        uvOf(g, g.indices[3 * t + 2]), mask.width(), mask.height(),
                                        o.texelsPerMicroTri, o.maxLevel));
  }
  return levels;
}

// Bakes every triangle at min(level, cap) into `out`.
// Progress of this pass is reported as progressBase + fraction · progressSpan.
void bakeAll(const Geometry& g, const AlphaMask& mask, const std::vector<uint8_t>& levels, uint32_t cap,
             const BakeOptions& o, tbb::task_arena& arena, BakedGeometry& out, double progressBase,
             double progressSpan) {
  const uint32_t n = g.triangleCount();
  OmmArrayBuilder builder;
  BakeStats& st = out.stats;
  st.microTriangles = st.unknownMicroTriangles = st.nonFiniteUvTriangles = 0;
  out.levels.assign(n, 0);
  std::vector<Baked> slots;
  uint32_t t = 0;
  while (t < n) {
    // Chunks bounded in count and map memory; chunking never changes the output (maps are added in triangle
    // order).
    uint32_t end = t;
    uint64_t bytes = 0;
    while (end < n && end - t < 4096 && bytes < (uint64_t(64) << 20)) {
      bytes += micromapDataBytes(std::min<uint32_t>(levels[end], cap), o.format);
      ++end;
    }
    if (slots.size() < end - t) slots.resize(end - t);  // maps are kept for reuse by the next chunk
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<uint32_t>(t, end, 8), [&](const tbb::blocked_range<uint32_t>& r) {
        for (uint32_t i = r.begin(); i != r.end(); ++i) {
          const uint32_t level = std::min<uint32_t>(levels[i], cap);
          bakeOne(mask, uvOf(g, g.indices[3 * i]), uvOf(g, g.indices[3 * i + 1]),
                  uvOf(g, g.indices[3 * i + 2]), level, o.format, o.unknownAs, slots[i - t]);
        }
      });
    });
    for (uint32_t i = t; i < end; ++i) {
      Baked& b = slots[i - t];
      const uint32_t level = std::min<uint32_t>(levels[i], cap);
      out.levels[i] = uint8_t(level);
      st.microTriangles += microTriangleCount(level);
      st.unknownMicroTriangles += b.unknown;
      st.nonFiniteUvTriangles += b.nonFinite;
      if (b.uniform)
        builder.addSpecial(*b.uniform);
      else
        builder.add(b.map);
    }
    t = end;
    if (o.progress) o.progress(progressBase + progressSpan * double(t) / double(n));
  }
  out.array = builder.finish();
}

void finishStats(BakedGeometry& out) {
  BakeStats& st = out.stats;
  st.triangles = out.array.indices.size();
  st.specialCount = {};
  for (int32_t i : out.array.indices)
    if (isSpecialIndex(i)) ++st.specialCount[size_t(stateOfSpecialIndex(i))];
  st.uniqueMaps = out.array.descriptors.size();
  st.dataBytes = out.array.data.size();
  st.minLevel = st.maxLevel = 0;
  if (!out.levels.empty()) {
    st.minLevel = *std::min_element(out.levels.begin(), out.levels.end());
    st.maxLevel = *std::max_element(out.levels.begin(), out.levels.end());
  }
}

}  // namespace

AlphaMask::AlphaMask(const AlphaTexture& texture, const Sampler& sampler, float cutoff)
    : tex_(&texture), w_(texture.width), h_(texture.height), sampler_(sampler), cutoff_(cutoff) {
  assert(w_ > 0 && h_ > 0 && texture.alpha.size() == size_t(w_) * h_);
  const size_t stride = size_t(w_) + 1;
  sat_.assign(stride * (size_t(h_) + 1), 0);
  for (uint32_t y = 0; y < h_; ++y) {
    uint32_t row = 0;
    for (uint32_t x = 0; x < w_; ++x) {
      row += alphaTestPasses(texture.at(x, y), cutoff) ? 1u : 0u;
      sat_[(size_t(y) + 1) * stride + x + 1] = sat_[size_t(y) * stride + x + 1] + row;
    }
  }
}

uint64_t AlphaMask::rect(uint32_t x0, uint32_t x1, uint32_t y0, uint32_t y1) const noexcept {
  const size_t stride = size_t(w_) + 1;
  const uint32_t* a = sat_.data() + size_t(y0) * stride;
  const uint32_t* b = sat_.data() + (size_t(y1) + 1) * stride;
  return uint32_t(b[x1 + 1] - b[x0] - a[x1 + 1] + a[x0]);  // modular arithmetic; the true count fits
}

AlphaMask::Count AlphaMask::count(int64_t x0, int64_t x1, int64_t y0, int64_t y1) const noexcept {
  Interval xs[4], ys[4];
  const int nx = wrapInterval(x0, x1, w_, sampler_.wrapS, xs);
  const int ny = wrapInterval(y0, y1, h_, sampler_.wrapT, ys);
  Count c;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      c.pass += rect(xs[i].lo, xs[i].hi, ys[j].lo, ys[j].hi);
      c.total += uint64_t(xs[i].hi - xs[i].lo + 1) * (ys[j].hi - ys[j].lo + 1);
    }
  return c;
}

double bakeMarginTexels(const double x[3], const double y[3]) noexcept {
  double mag = 0;
  for (int k = 0; k < 3; ++k) mag = std::max(mag, std::max(std::fabs(x[k]), std::fabs(y[k])));
  return 1e-3 + 1e-5 * mag;
}

uint32_t adaptiveLevel(std::array<float, 2> uv0, std::array<float, 2> uv1, std::array<float, 2> uv2,
                       uint32_t width, uint32_t height, float texelsPerMicroTri, uint32_t maxLevel) noexcept {
  const double e1x = double(uv1[0]) - uv0[0], e1y = double(uv1[1]) - uv0[1];
  const double e2x = double(uv2[0]) - uv0[0], e2y = double(uv2[1]) - uv0[1];
  const double area = std::fabs(e1x * e2y - e1y * e2x) * 0.5 * double(width) * double(height);
  if (!std::isfinite(area) || !(texelsPerMicroTri > 0)) return 0;
  uint32_t level = 0;
  double cap = texelsPerMicroTri;
  while (level < maxLevel && area > cap) {
    ++level;
    cap *= 4;
  }
  return level;
}

TriangleBake bakeTriangle(const AlphaMask& mask, std::array<float, 2> uv0, std::array<float, 2> uv1,
                          std::array<float, 2> uv2, uint32_t level, Format format, UnknownAs unknownAs) {
  assert(level <= kMaxLevel);
  Baked b;
  bakeOne(mask, uv0, uv1, uv2, level, format, unknownAs, b);
  TriangleBake r;
  r.map = b.uniform ? Micromap(level, format, *b.uniform) : std::move(b.map);
  r.unknownCount = b.unknown;
  r.nonFiniteUv = b.nonFinite;
  return r;
}

Status validateBakeOptions(const BakeOptions& o) {
  if (o.level > kMaxLevel)
    return makeError(ErrorCode::InvalidArgument,
                     "--level " + std::to_string(o.level) + " is out of range 0..12");
  if (o.maxLevel > kMaxLevel)
    return makeError(ErrorCode::InvalidArgument,
                     "--max-level " + std::to_string(o.maxLevel) + " is out of range 0..12");
  if (!(o.texelsPerMicroTri >= 0) || !std::isfinite(o.texelsPerMicroTri))
    return makeError(ErrorCode::InvalidArgument, "--texels-per-microtri must be a finite number >= 0");
  if (!isValidFormat(uint32_t(o.format)))
    return makeError(ErrorCode::InvalidArgument, "--format must be 2 or 4");
  if (o.cutoff && !std::isfinite(*o.cutoff))
    return makeError(ErrorCode::InvalidArgument, "--cutoff must be finite");
  if (uint8_t(o.unknownAs) > 2) return makeError(ErrorCode::InvalidArgument, "--unknown-as is invalid");
  return Ok{};
}

Result<BakedGeometry> bakeGeometry(const Geometry& geometry, const Material& material,
                                   const BakeOptions& options) {
  const bool textured = material.alphaMode != AlphaMode::Opaque && material.alpha;
  if (!textured) return bakeGeometry(geometry, material, nullptr, options);
  if (Status s = validateTexture(material); !s) return s.error();
  const AlphaMask mask(*material.alpha, effectiveSampler(material, options),
                       effectiveCutoff(material, options));
  return bakeGeometry(geometry, material, &mask, options);
}

Result<BakedGeometry> bakeGeometry(const Geometry& geometry, const Material& material, const AlphaMask* mask,
                                   const BakeOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  if (Status s = validateBakeOptions(options); !s) return s.error();
  const bool textured = material.alphaMode != AlphaMode::Opaque && material.alpha;
  if (textured && !mask)
    return makeError(ErrorCode::InvalidArgument, "material '" + material.name + "': no prepared alpha mask");
  if (Status s = validateGeometry(geometry, textured); !s) return s.error();

  BakedGeometry out;
  const uint32_t n = geometry.triangleCount();
  if (!textured) {
    // Not alpha-tested, or a constant alpha: one state for every point of every triangle.
    State s = State::Opaque;
    if (material.alphaMode != AlphaMode::Opaque)
      s = alphaTestPasses(material.baseColorFactor[3], effectiveCutoff(material, options))
              ? State::Opaque
              : State::Transparent;
    OmmArrayBuilder builder;
    for (uint32_t t = 0; t < n; ++t) builder.addSpecial(s);
    out.array = builder.finish();
    out.levels.assign(n, 0);
    out.stats.microTriangles = n;
    finishStats(out);
    if (options.progress) options.progress(1.0);
    out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  tbb::task_arena arena(options.threads ? int(options.threads) : tbb::task_arena::automatic);
  const std::vector<uint8_t> levels = chooseLevels(geometry, *mask, options);
  const uint32_t top = levels.empty() ? 0 : *std::max_element(levels.begin(), levels.end());
  // With maxBytes, re-bakes may follow: pass k reports within [1 − 2^−k, 1 − 2^−(k+1)], so progress stays
  // monotone.
  double span = options.maxBytes > 0 ? 0.5 : 1.0, base = 0;
  bakeAll(geometry, *mask, levels, kMaxLevel, options, arena, out, base, span);
  out.stats.levelCap = kMaxLevel;
  if (options.maxBytes > 0) {
    // Lower the largest maps (the highest levels) one level at a time until the data fits. Level 0 always
    // fits: a one-state map is uniform and becomes a special index.
    for (uint32_t cap = top; out.array.data.size() > options.maxBytes && cap-- > 0;) {
      base += span;
      span *= 0.5;
      bakeAll(geometry, *mask, levels, cap, options, arena, out, base, span);
      out.stats.levelCap = cap;
    }
  }
  if (options.progress && span != 1.0) options.progress(1.0);
  finishStats(out);
  out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

Result<BakeEstimate> estimateBake(const Geometry& geometry, const Material& material,
                                  const BakeOptions& options) {
  if (Status s = validateBakeOptions(options); !s) return s.error();
  const bool textured = material.alphaMode != AlphaMode::Opaque && material.alpha;
  if (textured) {
    if (Status s = validateTexture(material); !s) return s.error();
  }
  if (Status s = validateGeometry(geometry, textured); !s) return s.error();
  BakeEstimate e;
  const uint32_t n = geometry.triangleCount();
  e.triangles = n;
  if (!textured) {
    e.microTriangles = n;
    return e;
  }
  const AlphaTexture& tex = *material.alpha;
  for (uint32_t t = 0; t < n; ++t) {
    const auto a = uvOf(geometry, geometry.indices[3 * t]), b = uvOf(geometry, geometry.indices[3 * t + 1]),
               c = uvOf(geometry, geometry.indices[3 * t + 2]);
    const uint32_t level =
        options.texelsPerMicroTri > 0
            ? adaptiveLevel(a, b, c, tex.width, tex.height, options.texelsPerMicroTri, options.maxLevel)
            : options.level;
    e.microTriangles += microTriangleCount(level);
    if (!finite2(a) || !finite2(b) || !finite2(c) || level == 0) continue;
    ++e.mapTriangles;
    ++e.levelHistogram[level];
    e.dataBytes += micromapDataBytes(level, options.format);
  }
  return e;
}

}  // namespace somm
