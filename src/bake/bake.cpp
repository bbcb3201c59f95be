// SPDX-License-Identifier: MIT
// somm — conservative OMM baking. Algorithm and conservativeness argument: docs/baking.md.
#include "somm/bake.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <unordered_map>

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

// texelFloor without the libm call (std::floor is not inlined without SSE4.1) and without its range clamp: the
// classifier only sees usable triangles (texel coordinates below kMaxTexelCoord = 1e14 in magnitude, the margin and
// the linear shift far below 1), so every x here is finite and |x| < 1e15, where texelFloor does not clamp either.
inline int64_t cellFloor(double x) noexcept {
  assert(std::fabs(x) < 1e15);
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
// nodes). An inner node decided by it needs no descent: its leaves would all be decided alike (docs/baking.md
// "Exact bounds at inner nodes"), so the limit changes the work, not the output.
constexpr int64_t kLeafCells = 1024, kNodeCells = 64;

// rect() answers from the pass bits for at most this many rows of texels, through AlphaMask::passFail beyond.
constexpr int64_t kBitRows = 16;

// Texel coordinates at or beyond this magnitude make a triangle unknown (texelFloor clamps at 1e15).
constexpr double kMaxTexelCoord = 1e14;

// Safety margin (docs/baking.md): float UV interpolation error in units of 2^-24 · P, and how far (in barycentric
// units) a hit point may lie outside the micro-triangle it is looked up in.
constexpr double kInterpolationUlps = 6.0;
constexpr double kBarycentricSlack = 0x1p-20;

// Rows of cells beyond which a region is declared mixed without enumerating (still conservative).
constexpr int64_t kMaxRows = int64_t(1) << 22;

// Work bound per triangle (docs/hardening.md): a budget of work units (a node visited, a row of cells counted,
// a cell bounded) of kWorkBase + kWorkPerEdgeLevel · (W + H) · (level + 1) + 4^level / 4 — above what real
// content needs (the oak tree at most a sixth of it at levels 2-12, torcs-forza about half at level 10), far below what slivers and huge
// UVs (each micro-triangle spanning thousands of texels) would cost: seconds per triangle. Once the budget is
// spent, every node not yet decided becomes unknown as a whole (conservative: 4-state unknown, 2-state by the
// majority rule). A triangle whose UVs span more than kAbsurdRepeats texture widths or heights is not
// classified at all (whole-unknown, like non-finite UVs).
constexpr uint64_t kWorkBase = uint64_t(1) << 14, kWorkPerEdgeLevel = 64;
constexpr double kAbsurdRepeats = 4096;
inline uint64_t workBudget(uint32_t level, uint32_t w, uint32_t h) noexcept {
  return kWorkBase + kWorkPerEdgeLevel * (uint64_t(w) + h) * (level + 1) + microTriangleCount(level) / 4;
}

// A tie of the majority rule (2 of the 4 child centroids pass, broken at a point towards the node's vertex 0): the
// node [start, start + span) of the map that got the tie's state. Recorded for triangles whose vertices other
// triangles list in another order (their ties are broken at their own vertex 0, see twinOf).
struct Tie {
  uint32_t start, span;
};

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
  mutable uint64_t budget = ~uint64_t(0);  // work units left (see kWorkBase)
  mutable uint64_t work = 0;               // work units done: those spent plus one per leaf sampled
  std::vector<Tie>* ties = nullptr;        // where to record ties (null: not recorded)
  // Side of a square (cell units) holding a whole wrap period in both axes; infinity when a wrap clamps.
  double periodSide = std::numeric_limits<double>::infinity();
  int64_t tw = 0, th = 0;  // the mask's size
  // The wrap period of each axis in texels (W for repeat, 2W for mirrored repeat), 0 when the axis clamps: texel i and
  // texel i − k·period are the same texel (docs/baking.md "Samples whole periods away").
  int64_t periodX = 0, periodY = 0;
  void spend(uint64_t units) const noexcept {
    budget = units < budget ? budget - units : 0;
    work += units;
  }

  // True when the triangle (cell space) surely contains an axis-aligned square of side periodSide: its incircle
  // (radius 2·area / perimeter) holds a square of side r·√2 (with a relative slack of 1e-6 for rounding). Such a
  // square holds a whole period of cells and a point on every texel, so its region reads every texel.
  bool holdsPeriod(const double X[3], const double Y[3], double scale = 1.0) const noexcept {
    // Cheap first: the bounding box must span the period (this also rules out clamping wraps: infinity).
    if (!((max3(X) - min3(X)) * scale >= periodSide && (max3(Y) - min3(Y)) * scale >= periodSide))
      return false;
    const double ax = X[1] - X[0], ay = Y[1] - Y[0], bx = X[2] - X[0], by = Y[2] - Y[0];
    const double area2 = std::fabs(ax * by - ay * bx);
    const double cx = X[2] - X[1], cy = Y[2] - Y[1];
    const double per =
        std::sqrt(ax * ax + ay * ay) + std::sqrt(bx * bx + by * by) + std::sqrt(cx * cx + cy * cy);
    if (!(per > 0)) return false;
    return area2 / per * scale * 1.4142135 >= periodSide * (1 + 1e-6) + 1e-6;
  }

  // The whole periods k·period (k = ⌊a / period⌋) that move index a into [0, period) (0 when the axis clamps).
  static int64_t periodOffset(int64_t a, int64_t period) noexcept {
    if (period == 0) return 0;
    const int64_t q = a / period;
    return (q - (q * period > a ? 1 : 0)) * period;
  }

  // True when the texels [x0, x1] × [y0, y1] lie inside the texture (no wrapping) and span at most 63 columns.
  bool bitsHold(int64_t x0, int64_t x1, int64_t y0, int64_t y1) const noexcept {
    return x0 >= 0 && y0 >= 0 && x1 < tw && y1 < th && x1 - x0 < 63;
  }

  // The texels [i0, i1 + ext] × [j0, j1 + ext]: kPass / kFail / kMixed. `rows` (optional, kBitRows + 1 words): where
  // the rows' pass bits are kept (row j0 + r in rows[r], bit k = texel i0 + k, the bits beyond i1 + ext clear) when
  // they are read from the pass bits; `*kept` says whether they were.
  unsigned rect(int64_t i0, int64_t i1, int64_t j0, int64_t j1, uint64_t* rows = nullptr,
                bool* kept = nullptr) const noexcept {
    if (bitsHold(i0, i1 + ext, j0, j1 + ext) && j1 - j0 < kBitRows) {
      // The same texels as the passFail query, from their pass bits row by row.
      const uint64_t full = (uint64_t(2) << (i1 + ext - i0)) - 1;
      uint64_t any = 0, all = full;
      const uint64_t* word = mask.passWord(uint32_t(i0), uint32_t(j0));
      const size_t rowWords = mask.passRowWords();
      const uint32_t s = uint32_t(i0) & 63u;
      for (int64_t y = j0; y <= j1 + ext; ++y, word += rowWords) {
        const uint64_t b = AlphaMask::passBitsAt(word, s) & full;
        if (rows) rows[y - j0] = b;
        any |= b;
        all &= b;
      }
      if (kept) *kept = rows != nullptr;
      return (any ? kPass : 0u) | (all != full ? kFail : 0u);
    }
    if (kept) *kept = false;
    static_assert(kPass == 1 && kFail == 2, "passFail's bits are the classes");
    return mask.passFail(i0, i1 + ext, j0, j1 + ext);
  }

  // The x-extent [xl, xr] of the triangle within the horizontal slab [ya, yb]; false when they do not meet.
  // `low` / `high`: whether an edge may cross ya / yb. In the first row of a grown bounding box no vertex lies below
  // ya = j0 − m (j0 = ⌊min Y − m⌋, and 2m is far above the rounding of min Y − m), in its last row none above yb, so
  // no edge crosses there and the test is skipped (the same extent).
  // The triangle's edges, prepared once for the slabs of all its rows: edge k runs from vertex k to k1 = k + 1 mod 3.
  struct Edges {
    double X[3], Y[3], dx[3], dy[3], ylo[3], yhi[3];
    Edges(const double X_[3], const double Y_[3]) noexcept {
      for (int k = 0; k < 3; ++k) {
        const int k1 = k == 2 ? 0 : k + 1;
        X[k] = X_[k];
        Y[k] = Y_[k];
        dx[k] = X_[k1] - X_[k];
        dy[k] = Y_[k1] - Y_[k];
        ylo[k] = std::min(Y_[k], Y_[k1]);
        yhi[k] = std::max(Y_[k], Y_[k1]);
      }
    }
  };
  static bool slabExtent(const Edges& e, double ya, double yb, double& xl, double& xr, bool low = true,
                         bool high = true) noexcept {
    xl = std::numeric_limits<double>::infinity();
    xr = -xl;
    for (int k = 0; k < 3; ++k) {
      if (e.Y[k] >= ya && e.Y[k] <= yb) {
        xl = std::min(xl, e.X[k]);
        xr = std::max(xr, e.X[k]);
      }
      // The edge crosses y = ya strictly (one end below, the other above).
      if (low && e.ylo[k] < ya && e.yhi[k] > ya) {
        const double x = e.X[k] + (ya - e.Y[k]) / e.dy[k] * e.dx[k];
        xl = std::min(xl, x);
        xr = std::max(xr, x);
      }
      if (high && e.ylo[k] < yb && e.yhi[k] > yb) {
        const double x = e.X[k] + (yb - e.Y[k]) / e.dy[k] * e.dx[k];
        xl = std::min(xl, x);
        xr = std::max(xr, x);
      }
    }
    return xl <= xr;
  }

  static unsigned decide(double lo, double hi, float cutoff, double tol) noexcept {
    if (lo >= double(cutoff) + tol) return kPass;
    if (hi < double(cutoff) - tol) return kFail;
    return kMixed;  // also NaN
  }

  // The exact-per-cell bound: the range of f over P = T ∩ [−m, 1 + m]² (cell-local). A bilinear function takes its
  // extremes over a convex polygon at a vertex or where its restriction to an edge is stationary; P's vertices are T's
  // vertices in the square, the square's corners in T and where T's edges cross the square's sides, and along the
  // square's sides f is linear. So the range is that of: each edge of T clipped to the square (Liang–Barsky: its ends
  // and, when inside, the stationary point of the quadratic along it), and the corners of the square inside T.
  unsigned clippedCell(double A, double B, double C, double D, const double tx[3], const double ty[3],
                       double grow, float cutoff, double tol) const noexcept {
    const double s0 = -margin, s1 = 1 + margin;
    auto f = [&](double x, double y) { return A + B * x + C * y + D * x * y; };
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    bool any = false;
    for (int k = 0; k < 3; ++k) {
      const int k1 = k == 2 ? 0 : k + 1;
      const double x0 = tx[k], y0 = ty[k], ex = tx[k1] - x0, ey = ty[k1] - y0;
      // The edge's parameter interval [t0, t1] inside the square, and the ends' coordinates (exact on a side).
      double t0 = 0, t1 = 1;
      double ax = x0, ay = y0, bx = tx[k1], by = ty[k1];
      if (x0 < s0 || x0 > s1 || bx < s0 || bx > s1) {
        if (ex == 0) continue;  // a vertical edge outside the slab
        const double ta = (s0 - x0) / ex, tb = (s1 - x0) / ex;
        const double tl = std::min(ta, tb), th = std::max(ta, tb);
        if (tl > t0) t0 = tl, ax = ex > 0 ? s0 : s1, ay = y0 + tl * ey;
        if (th < t1) t1 = th, bx = ex > 0 ? s1 : s0, by = y0 + th * ey;
        if (!(t0 <= t1)) continue;
      }
      if (ay < s0 || ay > s1 || by < s0 || by > s1) {
        if (ey == 0) continue;
        const double ta = (s0 - y0) / ey, tb = (s1 - y0) / ey;
        const double tl = std::min(ta, tb), th = std::max(ta, tb);
        if (tl > t0) t0 = tl, ay = ey > 0 ? s0 : s1, ax = x0 + tl * ex;
        if (th < t1) t1 = th, by = ey > 0 ? s1 : s0, bx = x0 + th * ex;
        if (!(t0 <= t1)) continue;
      }
      any = true;
      const double va = f(ax, ay), vb = f(bx, by);
      lo = std::min(lo, std::min(va, vb));
      hi = std::max(hi, std::max(va, vb));
      // f along the edge: v0 + c1·t + c2·t², stationary at t = −c1 / (2·c2) with value v0 − c1² / (4·c2).
      const double c2 = D * ex * ey, c1 = B * ex + C * ey + D * (x0 * ey + y0 * ex);
      if (c2 != 0) {
        const double t = -c1 / (2 * c2);
        if (t > t0 && t < t1) {
          const double w = f(x0, y0) - c1 * c1 / (4 * c2);
          lo = std::min(lo, w);
          hi = std::max(hi, w);
        }
      }
    }
    // The square's corners inside T (T of non-zero area; on an edge they are points of that edge's clipped part).
    const double area2 = (tx[1] - tx[0]) * (ty[2] - ty[0]) - (ty[1] - ty[0]) * (tx[2] - tx[0]);
    if (area2 != 0) {
      for (int c = 0; c < 4; ++c) {
        const double cx = (c & 1) ? s1 : s0, cy = (c & 2) ? s1 : s0;
        bool inside = true;
        for (int k = 0; k < 3 && inside; ++k) {
          const int k1 = k == 2 ? 0 : k + 1;
          const double e = (tx[k1] - tx[k]) * (cy - ty[k]) - (ty[k1] - ty[k]) * (cx - tx[k]);
          inside = area2 > 0 ? e >= 0 : e <= 0;
        }
        if (inside) {
          any = true;
          const double v = f(cx, cy);
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
      }
    }
    if (!any) return 0;  // T does not come within m of the cell
    if (std::isnan(lo) || std::isnan(hi)) return kMixed;
    return decide(lo - grow, hi + grow, cutoff, tol);
  }

  // kPass / kFail / kMixed for the closed triangle (X, Y) grown by the margin (Minkowski sum with a square):
  // the cells it touches all pass / all fail / neither. For the linear filter, regions touching at most
  // kLeafCells (a leaf) / kNodeCells (`innerNode`) cells get the exact bilinear bound (bilinearCells) instead of
  // the four-corner bound; an inner node's is counted per row (see bilinearCells).
  unsigned region(const double X[3], const double Y[3], bool innerNode) const noexcept {
    const int64_t cellLimit = innerNode ? kNodeCells : kLeafCells;
    const double m = margin;
    const int64_t i0 = cellFloor(min3(X) - m), i1 = cellFloor(max3(X) + m);
    const int64_t j0 = cellFloor(min3(Y) - m), j1 = cellFloor(max3(Y) + m);
    uint64_t rows[kBitRows + 1];
    bool kept = false;
    const unsigned box = rect(i0, i1, j0, j1, rows, &kept);
    if (box != kMixed) return box;
    // A region holding a whole period reads every texel, which pass and fail (box is mixed): O(1) however large.
    if (holdsPeriod(X, Y)) return kMixed;
    if (ext && i1 - i0 < cellLimit && j1 - j0 < cellLimit && (i1 - i0 + 1) * (j1 - j0 + 1) <= cellLimit)
      return bilinearCells(X, Y, i0, i1, j0, j1, innerNode, kept ? rows : nullptr);
    if (j0 == j1) return box;
    if (j1 - j0 > kMaxRows) return kMixed;
    // Exact: per row of cells, the x-extent of the grown triangle within the row.
    const Edges edges(X, Y);
    unsigned acc = 0;
    for (int64_t j = j0; j <= j1; ++j) {
      if (budget == 0) return kMixed;
      spend(1);
      double xl, xr;
      if (!slabExtent(edges, double(j) - m, double(j + 1) + m, xl, xr, j > j0, j < j1)) continue;
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
  // Cell (i, j) of bilinearCells whose corner alphas c00, c10, c01, c11 disagree: its class, or kStop when the
  // region is surely mixed (the triangle's vertices in the cell, with `acc`, see both classes).
  static constexpr unsigned kStop = 4;
  unsigned mixedCell(const double X[3], const double Y[3], int64_t i, int64_t j, float c00, float c10,
                     float c01, float c11, unsigned acc, float cutoff, double tol) const noexcept {
    const double m = margin;
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
    const unsigned cls = decide(lo - grow, hi + grow, cutoff, tol);
    if (cls != kMixed) return cls;
    // Vertices of T inside this cell are points of the region where the blend is f itself: if they (with what
    // other cells showed) see both classes, the region is mixed — no need for the exact bound.
    unsigned seen = acc;
    for (int k = 0; k < 3; ++k)
      if (px[k] >= 0 && px[k] <= 1 && py[k] >= 0 && py[k] <= 1)
        seen |= fv[k] >= double(cutoff) ? kPass : kFail;
    if (seen == kMixed) return kStop;
    // Cheaper than clipping, before it: f over the rectangle bbox(T) ∩ [−m, 1 + m]², a superset of T's part in the
    // grown cell, where a bilinear function takes its extremes at the rectangle's corners. Conclusive only when the
    // exact bound over the subset would be too (with the same class).
    const double x0 = std::max(min3(px), -m), x1 = std::min(max3(px), 1 + m);
    const double y0 = std::max(min3(py), -m), y1 = std::min(max3(py), 1 + m);
    if (x0 <= x1 && y0 <= y1) {
      const double g00 = A + B * x0 + C * y0 + D * x0 * y0, g10 = A + B * x1 + C * y0 + D * x1 * y0;
      const double g01 = A + B * x0 + C * y1 + D * x0 * y1, g11 = A + B * x1 + C * y1 + D * x1 * y1;
      const unsigned rc = decide(std::min(std::min(g00, g10), std::min(g01, g11)) - grow,
                                 std::max(std::max(g00, g10), std::max(g01, g11)) + grow, cutoff, tol);
      if (rc != kMixed) {
        return rc;
      }
    }
    return clippedCell(A, B, C, D, px, py, grow, cutoff, tol);
  }

  // [i0, i1] × [j0, j1]: the cells of the grown bounding box.
  // Work: a unit per cell of each row run whose corners disagree, or (`perRow`: an inner node's test, in place of the
  // four-corner row walk's unit per row) a unit per such run.
  // `rows`: the box's pass bits as rect() kept them (null: read them here): every row run [a, b] of row j lies in
  // the box, so its corners' bits are rows[j − j0] and rows[j + 1 − j0] from bit a − i0 on.
  unsigned bilinearCells(const double X[3], const double Y[3], int64_t i0, int64_t i1, int64_t j0, int64_t j1,
                         bool perRow = false, const uint64_t* rows = nullptr) const noexcept {
    const double m = margin;
    const Sampler& smp = mask.sampler();
    const float cutoff = mask.cutoff();
    const double tol = 1e-6 * std::max(1.0, std::fabs(double(cutoff)));
    const Edges edges(X, Y);
    const float* const lut8 = mask.u8Lut();
    const size_t pitch = mask.u8Pitch(), step = mask.u8Step();
    unsigned acc = 0;
    for (int64_t j = j0; j <= j1; ++j) {
      // One row: the whole grown triangle lies in the slab, its extent there is its bounding box's (slabExtent
      // would return the vertices' min and max: the same run).
      int64_t a = i0, b = i1;
      if (j0 != j1) {
        double xl, xr;
        if (!slabExtent(edges, double(j) - m, double(j + 1) + m, xl, xr, j > j0, j < j1)) continue;
        a = cellFloor(xl - m);
        b = cellFloor(xr + m);
      }
      if (rows || bitsHold(a, b + 1, j, j + 1)) {
        // Inside the texture: the run's corners from the pass bits of its two rows (read once), as rect() would.
        uint64_t ra, rb;
        if (rows) {
          ra = rows[j - j0] >> (a - i0);
          rb = rows[j + 1 - j0] >> (a - i0);
        } else {
          const uint64_t* word = mask.passWord(uint32_t(a), uint32_t(j));
          const uint32_t s = uint32_t(a) & 63u;
          ra = AlphaMask::passBitsAt(word, s);
          rb = AlphaMask::passBitsAt(word + mask.passRowWords(), s);
        }
        if (b - a >= 2) {
          // A run whose corner texels all agree decides all its cells (each by its four corners) in O(1).
          const uint64_t full = (uint64_t(2) << (b + 1 - a)) - 1;
          if (((ra | rb) & full) == 0 || (ra & rb & full) == full) {
            acc |= (ra & full) ? kPass : kFail;
            if (acc == kMixed) return kMixed;
            continue;
          }
        }
        spend(perRow ? 1u : uint64_t(b - a + 1));
        // Cells whose four corners agree are decided by them, all at once; the others one by one. The region's
        // class does not depend on the order its cells are visited in (docs/baking.md "Cells in any order"):
        // the same answer as cell by cell.
        const uint64_t cells = (uint64_t(2) << (b - a)) - 1;  // b − a ≤ 61
        const uint64_t ra1 = ra >> 1, rb1 = rb >> 1;
        const uint64_t allPass = ra & ra1 & rb & rb1 & cells, allFail = ~(ra | ra1 | rb | rb1) & cells;
        acc |= (allPass ? kPass : 0u) | (allFail ? kFail : 0u);
        if (acc == kMixed) return kMixed;
        for (uint64_t mixed = cells & ~(allPass | allFail); mixed; mixed &= mixed - 1) {
          const int64_t i = a + int64_t(std::countr_zero(mixed));
          const uint32_t x = uint32_t(i), y = uint32_t(j);
          if (lut8) {
            const uint8_t* p = mask.u8Texel(x, y);
            acc |= mixedCell(X, Y, i, j, lut8[p[0]], lut8[p[step]], lut8[p[pitch]], lut8[p[pitch + step]],
                             acc, cutoff, tol);
          } else {
            acc |= mixedCell(X, Y, i, j, mask.texel(x, y), mask.texel(x + 1, y), mask.texel(x, y + 1),
                             mask.texel(x + 1, y + 1), acc, cutoff, tol);
          }
          if (acc >= kMixed) return kMixed;
        }
        continue;
      }
      if (b - a >= 2) {
        // A run whose corner texels all agree decides all its cells (each by its four corners) in O(1).
        const unsigned run = rect(a, b, j, j);
        if (run != kMixed) {
          acc |= run;
          if (acc == kMixed) return kMixed;
          continue;
        }
      }
      spend(perRow ? 1u : uint64_t(b - a + 1));
      // Cell i's right corners are cell i + 1's left corners: each texel column is read once per row run.
      const uint32_t ya = wrapFast(j, th, smp.wrapT), yb = wrapFast(j + 1, th, smp.wrapT);
      const uint32_t xa0 = wrapFast(a, tw, smp.wrapS);
      float left0 = mask.texel(xa0, ya), left1 = mask.texel(xa0, yb);
      for (int64_t i = a; i <= b; ++i) {
        const uint32_t xb = wrapFast(i + 1, tw, smp.wrapS);
        const float c00 = left0, c10 = mask.texel(xb, ya), c01 = left1, c11 = mask.texel(xb, yb);
        left0 = c10;
        left1 = c11;
        const int passes = alphaTestPasses(c00, cutoff) + alphaTestPasses(c10, cutoff) +
                           alphaTestPasses(c01, cutoff) + alphaTestPasses(c11, cutoff);
        const unsigned cls = passes == 4   ? kPass
                             : passes == 0 ? kFail
                                           : mixedCell(X, Y, i, j, c00, c10, c01, c11, acc, cutoff, tol);
        acc |= cls;
        if (acc >= kMixed) return kMixed;
      }
    }
    return acc ? acc : kMixed;
  }

  void fill(uint32_t start, uint32_t count, State s) noexcept {
    const uint32_t perByte = format == Format::TwoState ? 8u : 4u;
    if (count >= perByte) {
      // Nodes just above the leaves fill 1 or 4 bytes: stored directly, not through a memset call.
      const uint8_t v = fillByte(format, s);
      if (count == perByte) {
        bytes[start / perByte] = v;
      } else if (count == 4 * perByte) {
        std::memset(bytes + start / perByte, v, 4);
      } else {
        std::memset(bytes + start / perByte, v, count / perByte);
      }
    } else {
      for (uint32_t i = 0; i < count; ++i) writePackedState(bytes, format, start + i, s);
    }
  }

  // The alpha test at cell-space point (x, y), evaluated like sampleAlpha but directly in cell space (used
  // only for the majority of unknown micro-triangles, which needs no exactness).
  bool passesAt(double x, double y) const noexcept {
    const Sampler& smp = mask.sampler();
    const int64_t i = cellFloor(x), j = cellFloor(y);
    const uint32_t xa = wrapFast(i, tw, smp.wrapS), ya = wrapFast(j, th, smp.wrapT);
    if (shift == 0) return alphaTestPasses(mask.texel(xa, ya), mask.cutoff());
    const uint32_t xb = wrapFast(i + 1, tw, smp.wrapS), yb = wrapFast(j + 1, th, smp.wrapT);
    const double fx = x - double(i), fy = y - double(j);
    const double top = double(mask.texel(xa, ya)) * (1 - fx) + double(mask.texel(xb, ya)) * fx;
    const double bot = double(mask.texel(xa, yb)) * (1 - fx) + double(mask.texel(xb, yb)) * fx;
    return alphaTestPasses(float(top * (1 - fy) + bot * fy), mask.cutoff());
  }

  // True when every point within 1e-6 of the closed triangle (cell space) reads texels inside the texture: x, y ≥ 0
  // (so truncation is the floor) and ⌊x⌋ + ext < W, ⌊y⌋ + ext < H (no wrapping). Points computed from the
  // triangle's vertices in double (midpoints, centroids) are within far less than 1e-6 of it.
  // Also true when the triangle moved by whole periods (ox, oy) is inside so: a sample point (x, y) computed from
  // (X, Y) reads, at (x − ox, y − oy), the same texels with the same weights (docs/baking.md "Samples whole periods
  // away"). The move is toward 0 from non-negative coordinates (0 ≤ ox ≤ x), so x − ox is exact and so is its
  // fraction. (ox, oy) = (0, 0) when the triangle is inside as it is, or not inside.
  SOMM_BAKE_INLINE bool samplesInside(const double X[3], const double Y[3], double& ox,
                                      double& oy) const noexcept {
    ox = oy = 0;
    const double x0 = min3(X), y0 = min3(Y);
    if (!(x0 >= 1e-6 && y0 >= 1e-6)) return false;
    if (max3(X) + 1e-6 < double(tw - ext) && max3(Y) + 1e-6 < double(th - ext)) return true;
    if ((periodX | periodY) == 0) return false;
    const double sx = double(periodOffset(cellFloor(x0), periodX)),
                 sy = double(periodOffset(cellFloor(y0), periodY));
    if (!(x0 - sx >= 1e-6 && y0 - sy >= 1e-6 && max3(X) - sx + 1e-6 < double(tw - ext) &&
          max3(Y) - sy + 1e-6 < double(th - ext)))
      return false;
    ox = sx;
    oy = sy;
    return true;
  }

  // passesAt for a point whose texels lie inside the texture (see samplesInside): the same texels and the same
  // arithmetic, without the wrap and the floor's range check.
  SOMM_BAKE_INLINE bool passesInside(double x, double y) const noexcept {
    const uint32_t i = uint32_t(x), j = uint32_t(y);
    if (shift == 0) return alphaTestPasses(mask.texel(i, j), mask.cutoff());
    const double fx = x - double(i), fy = y - double(j);
    const double top = double(mask.texel(i, j)) * (1 - fx) + double(mask.texel(i + 1, j)) * fx;
    const double bot = double(mask.texel(i, j + 1)) * (1 - fx) + double(mask.texel(i + 1, j + 1)) * fx;
    return alphaTestPasses(float(top * (1 - fy) + bot * fy), mask.cutoff());
  }

  // (ox, oy): the whole periods samplesInside moved an inside triangle by (0 otherwise).
  template <bool kInside>
  SOMM_BAKE_INLINE bool sampleAt(double x, double y, double ox, double oy) const noexcept {
    if constexpr (kInside) {
      return passesInside(x - ox, y - oy);
    } else {
      return passesAt(x, y);
    }
  }

  SOMM_BAKE_INLINE bool sampleWhere(bool inside, double x, double y, double ox, double oy) const noexcept {
    return inside ? passesInside(x - ox, y - oy) : passesAt(x, y);
  }

  // The state an unknown micro-triangle gets: by majority of the alpha test at the centroids of its 4
  // children (ties: its own centroid), or as the 2-state option says.
  // The alpha test at the centroids of the 4 children: how many pass.
  // Child centroids in barycentric terms: (4,1,1)/6, (1,4,1)/6, (1,1,4)/6 and (1,1,1)/3 (the middle child).
  static constexpr double kCentroid[4][3] = {
      {4. / 6, 1. / 6, 1. / 6}, {1. / 6, 4. / 6, 1. / 6}, {1. / 6, 1. / 6, 4. / 6}, {1. / 3, 1. / 3, 1. / 3}};
  template <bool kInside = false>
  int centroidPasses(const double X[3], const double Y[3], double ox = 0, double oy = 0) const noexcept {
    int pass = 0;
    for (const auto& b : kCentroid)
      pass += sampleAt<kInside>(b[0] * X[0] + b[1] * X[1] + b[2] * X[2],
                                b[0] * Y[0] + b[1] * Y[1] + b[2] * Y[2], ox, oy);
    return pass;
  }

  // The state of an unknown micro-triangle whose centroidPasses are `pass`.
  // `inside`: the micro-triangle lies inside the texture as samplesInside() tests (the tie-break point then reads
  // texels inside the texture: passesInside, the same bit as passesAt).
  // [start, start + span): the node's micro-triangles (for the tie record).
  State unknownFrom(int pass, const double X[3], const double Y[3], uint32_t start, uint32_t span,
                    bool inside = false, double ox = 0, double oy = 0) const {
    if (format == Format::TwoState && unknownAs != UnknownAs::Majority)
      return unknownAs == UnknownAs::Opaque ? State::Opaque : State::Transparent;
    bool opaque;
    if (pass != 2) {
      opaque = pass > 2;
    } else {
      // The middle child's centroid is the parent's centroid; break the tie with a point between it and
      // vertex 0.
      opaque = sampleWhere(inside, (2 * X[0] + X[1] + X[2]) / 4, (2 * Y[0] + Y[1] + Y[2]) / 4, ox, oy);
      if (ties) ties->push_back(Tie{start, span});
    }
    if (format == Format::TwoState) return opaque ? State::Opaque : State::Transparent;
    return opaque ? State::UnknownOpaque : State::UnknownTransparent;
  }

  // The state an unknown micro-triangle gets: by majority of the alpha test at the centroids of its 4
  // children (ties: a fifth point), or as the 2-state option says.
  State unknownState(const double X[3], const double Y[3], uint32_t start, uint32_t span) const {
    if (format == Format::TwoState && unknownAs != UnknownAs::Majority)
      return unknownAs == UnknownAs::Opaque ? State::Opaque : State::Transparent;
    return unknownFrom(centroidPasses(X, Y), X, Y, start, span);
  }

  // The children of a node at depth level − 1 (leaves). Witnesses first: the 4 majority samples are points of the
  // leaf's region; when they disagree the region is mixed (the region test is conservative, so it would say so
  // too) and the leaf is unknown without a region test. Output identical to testing every leaf's region.
  // The leaves' vertices (the parent's 3 vertices and 3 edge midpoints) are witnesses too, sampled once each
  // when first needed: vertex k of child c is point kLeafVertex[c][k] (a, b, c, ab, ac, bc).
  static constexpr uint8_t kLeafVertex[4][3] = {{0, 3, 4}, {4, 5, 3}, {3, 1, 5}, {5, 4, 2}};
  static constexpr uint8_t kChildOf[6] = {0, 2, 3, 0, 0, 1}, kSlotOf[6] = {0, 1, 2, 1, 2, 1};
  // `vb`: bit k is the alpha test at the parent's vertex k (points 0..2), sampled by the parent's parent.
  template <bool kInside>
  void leafSamples(const double cX[4][3], const double cY[4][3], unsigned& vpass, int pass[4], double ox = 0,
                   double oy = 0) const noexcept {
    for (unsigned p = 3; p < 6; ++p)
      vpass |= unsigned(sampleAt<kInside>(cX[kChildOf[p]][kSlotOf[p]], cY[kChildOf[p]][kSlotOf[p]], ox, oy))
               << p;
    for (uint32_t c = 0; c < 4; ++c) pass[c] = centroidPasses<kInside>(cX[c], cY[c], ox, oy);
  }

#if defined(__SSE2__)
  // leafSamples<true> for the linear filter, two samples at a time: the 3 edge midpoints and the 16 child centroids
  // (computed as in centroidPasses) in one lattice, each blended exactly as passesInside does (the same IEEE double
  // operations, packed; the same rounding to float and comparison), texels read per lane.
  // (ox, oy): as in sampleAt, subtracted from each point once it is computed.
  void linearLeafSamplesInside(const double cX[4][3], const double cY[4][3], unsigned& vpass, int pass[4],
                               double ox, double oy) const noexcept {
    alignas(16) double xs[20], ys[20];
    for (unsigned p = 3; p < 6; ++p) {
      xs[p - 3] = cX[kChildOf[p]][kSlotOf[p]] - ox;
      ys[p - 3] = cY[kChildOf[p]][kSlotOf[p]] - oy;
    }
    for (uint32_t c = 0; c < 4; ++c)
      for (uint32_t q = 0; q < 4; ++q) {
        const double* b = kCentroid[q];
        xs[3 + 4 * c + q] = (b[0] * cX[c][0] + b[1] * cX[c][1] + b[2] * cX[c][2]) - ox;
        ys[3 + 4 * c + q] = (b[0] * cY[c][0] + b[1] * cY[c][1] + b[2] * cY[c][2]) - oy;
      }
    xs[19] = xs[18];
    ys[19] = ys[18];
    const __m128 cut = _mm_set1_ps(mask.cutoff());
    const __m128d one = _mm_set1_pd(1.0);
    const float* const lut8 = mask.u8Lut();
    const size_t pitch = mask.u8Pitch(), step = mask.u8Step();
    uint32_t bits = 0;
    for (int k = 0; k < 20; k += 2) {
      const __m128d x = _mm_load_pd(xs + k), y = _mm_load_pd(ys + k);
      const __m128i ix = _mm_cvttpd_epi32(x), iy = _mm_cvttpd_epi32(y);  // x, y ≥ 0: the floor
      const __m128d fx = _mm_sub_pd(x, _mm_cvtepi32_pd(ix)), fy = _mm_sub_pd(y, _mm_cvtepi32_pd(iy));
      const uint32_t i0 = uint32_t(_mm_cvtsi128_si32(ix)),
                     i1 = uint32_t(_mm_cvtsi128_si32(_mm_srli_si128(ix, 4)));
      const uint32_t j0 = uint32_t(_mm_cvtsi128_si32(iy)),
                     j1 = uint32_t(_mm_cvtsi128_si32(_mm_srli_si128(iy, 4)));
      __m128d c00, c10, c01, c11;
      if (lut8) {
        // 8-bit texels: the same values as texel(), each 2×2 block from one address.
        const uint8_t *p0 = mask.u8Texel(i0, j0), *p1 = mask.u8Texel(i1, j1);
        c00 = _mm_set_pd(lut8[p1[0]], lut8[p0[0]]);
        c10 = _mm_set_pd(lut8[p1[step]], lut8[p0[step]]);
        c01 = _mm_set_pd(lut8[p1[pitch]], lut8[p0[pitch]]);
        c11 = _mm_set_pd(lut8[p1[pitch + step]], lut8[p0[pitch + step]]);
      } else {
        c00 = _mm_set_pd(mask.texel(i1, j1), mask.texel(i0, j0));
        c10 = _mm_set_pd(mask.texel(i1 + 1, j1), mask.texel(i0 + 1, j0));
        c01 = _mm_set_pd(mask.texel(i1, j1 + 1), mask.texel(i0, j0 + 1));
        c11 = _mm_set_pd(mask.texel(i1 + 1, j1 + 1), mask.texel(i0 + 1, j0 + 1));
      }
      const __m128d gx = _mm_sub_pd(one, fx), gy = _mm_sub_pd(one, fy);
      const __m128d top = _mm_add_pd(_mm_mul_pd(c00, gx), _mm_mul_pd(c10, fx));
      const __m128d bot = _mm_add_pd(_mm_mul_pd(c01, gx), _mm_mul_pd(c11, fx));
      const __m128 v = _mm_cvtpd_ps(_mm_add_pd(_mm_mul_pd(top, gy), _mm_mul_pd(bot, fy)));
      bits |= uint32_t(_mm_movemask_ps(_mm_cmpge_ps(v, cut)) & 3) << k;
    }
    vpass |= (bits & 7u) << 3;
    // Set bits of a 4-bit value v: nibble v of 0x4332'3221'3221'2110 (no popcnt instruction in the x86-64 baseline).
    for (uint32_t c = 0; c < 4; ++c)
      pass[c] = int((0x4332322132212110ull >> (4 * ((bits >> (3 + 4 * c)) & 15u))) & 15u);
  }
#endif

  void leaves(const double cX[4][3], const double cY[4][3], uint32_t prefix, unsigned vb) {
    work += 4;
    // Every sample first, without branching on any (they are cheap; mispredicted branches are not): the 6 vertices
    // (bit p: point p passes) and each leaf's 4 child centroids. The parent's vertices are a (cX[0][0]), b
    // (cX[2][1]) and c (cX[3][2]); every sample lies in the parent.
    unsigned vpass = vb & 7u;
    int pass[4];
    const double pX[3] = {cX[0][0], cX[2][1], cX[3][2]}, pY[3] = {cY[0][0], cY[2][1], cY[3][2]};
    double ox, oy;
    const bool inside = samplesInside(pX, pY, ox, oy);
    if (!inside) {
      leafSamples<false>(cX, cY, vpass, pass);
    } else if (shift == 0) {
      leafSamples<true>(cX, cY, vpass, pass, ox, oy);
    } else {
#if defined(__SSE2__)
      linearLeafSamplesInside(cX, cY, vpass, pass, ox, oy);
#else
      leafSamples<true>(cX, cY, vpass, pass, ox, oy);
#endif
    }
    State st[4];
    for (uint32_t c = 0; c < 4; ++c) {
      const unsigned vbits = ((vpass >> kLeafVertex[c][0]) & 1u) |
                             (((vpass >> kLeafVertex[c][1]) & 1u) << 1) |
                             (((vpass >> kLeafVertex[c][2]) & 1u) << 2);
      // Witnesses agree: all 7 pass or all 7 fail.
      if ((pass[c] == 4 && vbits == 7u) || (pass[c] == 0 && vbits == 0)) {
        const unsigned r = region(cX[c], cY[c], false);
        if (r == kPass || r == kFail) {
          st[c] = r == kPass ? State::Opaque : State::Transparent;
          continue;
        }
      }
      ++unknown;
      st[c] = unknownFrom(pass[c], cX[c], cY[c], prefix * 4 + c, 1, inside, ox, oy);
    }
    // The 4 leaves (indices 4·prefix .. 4·prefix + 3) fill one byte (4-state) or one nibble (2-state): stored at once.
    if (format == Format::FourState) {
      bytes[prefix] = uint8_t((uint32_t(st[0]) & 3u) | (uint32_t(st[1]) & 3u) << 2 |
                              (uint32_t(st[2]) & 3u) << 4 | (uint32_t(st[3]) & 3u) << 6);
    } else {
      const uint32_t nibble = (uint32_t(st[0]) & 1u) | (uint32_t(st[1]) & 1u) << 1 |
                              (uint32_t(st[2]) & 1u) << 2 | (uint32_t(st[3]) & 1u) << 3;
      const uint32_t shift = 4u * (prefix & 1u);
      bytes[prefix >> 1] = uint8_t((bytes[prefix >> 1] & ~(0xfu << shift)) | (nibble << shift));
    }
  }

  // Node `prefix` at `depth` with cell-space vertices (X, Y) whose region class is `r`; bit k of `vb` is the alpha
  // test at vertex k (passesAt(X[k], Y[k]), taken once where the vertex was first a witness).
  void node(const double X[3], const double Y[3], uint32_t depth, uint32_t prefix, unsigned r, unsigned vb) {
    const uint32_t span = 1u << (2 * (level - depth));
    const uint32_t start = prefix * span;
    if (r == kPass) return fill(start, span, State::Opaque);
    if (r == kFail) return fill(start, span, State::Transparent);
    spend(1);
    if (budget == 0 && depth < level) {  // work bound reached: the whole node unknown
      unknown += span;
      return fill(start, span, unknownState(X, Y, start, span));
    }
    if (depth == level) {
      ++unknown;
      return fill(start, 1, unknownState(X, Y, start, 1));
    }
    const double ax = X[0], ay = Y[0], bx = X[1], by = Y[1], cx = X[2], cy = Y[2];
    const double abx = (ax + bx) * 0.5, aby = (ay + by) * 0.5;
    const double acx = (ax + cx) * 0.5, acy = (ay + cy) * 0.5;
    const double bcx = (bx + cx) * 0.5, bcy = (by + cy) * 0.5;
    // Child order of the bird curve (see indexToMicroTriangle).
    const double cX[4][3] = {{ax, abx, acx}, {acx, bcx, abx}, {abx, bx, bcx}, {bcx, acx, cx}};
    const double cY[4][3] = {{ay, aby, acy}, {acy, bcy, aby}, {aby, by, bcy}, {bcy, acy, cy}};
    if (depth + 1 == level) return leaves(cX, cY, prefix, vb);
    // Witnesses as in leaves(): a child whose vertices (the points a, b, c, ab, ac, bc of this node) and centroid
    // see both classes has a mixed region, which region() would report too; it is subdivided without the test.
    bool v[6];
    double ox, oy;
    const bool inside = samplesInside(X, Y, ox, oy);
    for (int p = 0; p < 3; ++p) v[p] = (vb >> p) & 1u;
    for (int p = 3; p < 6; ++p)
      v[p] = sampleWhere(inside, cX[kChildOf[p]][kSlotOf[p]], cY[kChildOf[p]][kSlotOf[p]], ox, oy);
    for (uint32_t c = 0; c < 4; ++c) {
      const bool v0 = v[kLeafVertex[c][0]];
      const bool mixed = v[kLeafVertex[c][1]] != v0 || v[kLeafVertex[c][2]] != v0 ||
                         sampleWhere(inside, (cX[c][0] + cX[c][1] + cX[c][2]) / 3,
                                     (cY[c][0] + cY[c][1] + cY[c][2]) / 3, ox, oy) != v0;
      const unsigned cvb = unsigned(v[kLeafVertex[c][0]]) | unsigned(v[kLeafVertex[c][1]]) << 1 |
                           unsigned(v[kLeafVertex[c][2]]) << 2;
      node(cX[c], cY[c], depth + 1, prefix * 4 + c, mixed ? kMixed : region(cX[c], cY[c], true), cvb);
    }
  }
};

bool finite2(const std::array<float, 2>& p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]);
}

// One triangle's outcome: a uniform state (no map needed) or a map.
struct Baked {
  std::optional<State> uniform;
  Micromap map;
  // The builder's key of `map` when not uniform (the scene bake computes it with the map, in parallel).
  OmmArrayBuilder::MapKey key;
  uint64_t unknown = 0;
  uint64_t work = 0;  // TriangleClassifier::work
  bool nonFinite = false;
  bool exhausted = false;  // the work bound was reached (what it left unknown depends on the vertex order)
};

State wholeUnknown(Format format, UnknownAs unknownAs) {
  if (format == Format::FourState) return State::UnknownOpaque;
  return unknownAs == UnknownAs::Transparent ? State::Transparent : State::Opaque;
}

// A triangle in texel space (not yet shifted for the linear filter) with its margin: the classifier's inputs.
struct Prepared {
  double X[3], Y[3];
  double margin = 0;
  bool usable = true;
};

void prepare(const AlphaMask& mask, std::array<float, 2> uv0, std::array<float, 2> uv1,
             std::array<float, 2> uv2, Prepared& p) noexcept {
  const double W = mask.width(), H = mask.height();
  p.X[0] = double(uv0[0]) * W, p.X[1] = double(uv1[0]) * W, p.X[2] = double(uv2[0]) * W;
  p.Y[0] = double(uv0[1]) * H, p.Y[1] = double(uv1[1]) * H, p.Y[2] = double(uv2[1]) * H;
  // NaN/inf UVs, or texel coordinates so large that sampleAlpha's clamped texel arithmetic no longer
  // interpolates (|x| ≥ 1e15): not classified.
  p.usable = true;
  for (int k = 0; k < 3; ++k)
    p.usable = p.usable && std::fabs(p.X[k]) < kMaxTexelCoord && std::fabs(p.Y[k]) < kMaxTexelCoord;
  p.usable =
      p.usable && max3(p.X) - min3(p.X) <= kAbsurdRepeats * W && max3(p.Y) - min3(p.Y) <= kAbsurdRepeats * H;
  p.margin = p.usable ? bakeMarginTexels(p.X, p.Y) : 0.0;
}

TriangleClassifier makeClassifier(const AlphaMask& mask, double margin, uint32_t level, Format format,
                                  UnknownAs unknownAs) noexcept {
  TriangleClassifier c{mask};
  c.margin = margin;
  c.shift = mask.sampler().filter == Filter::Linear ? 0.5 : 0.0;
  c.ext = mask.sampler().filter == Filter::Linear ? 1 : 0;
  c.level = level;
  c.format = format;
  c.unknownAs = unknownAs;
  c.budget = workBudget(level, mask.width(), mask.height());
  c.tw = mask.width();
  c.th = mask.height();
  const Sampler& smp = mask.sampler();
  auto period = [](uint32_t size, Wrap w) -> int64_t {
    return w == Wrap::ClampToEdge ? 0 : int64_t(size) * (w == Wrap::MirroredRepeat ? 2 : 1);
  };
  c.periodX = period(mask.width(), smp.wrapS);
  c.periodY = period(mask.height(), smp.wrapT);
  if (c.periodX != 0 && c.periodY != 0) c.periodSide = double(std::max(c.periodX, c.periodY));
  return c;
}

// Classifies a prepared, usable triangle. `ties` (optional, cleared first): where the majority rule's ties go.
void classify(const AlphaMask& mask, const Prepared& p, uint32_t level, Format format, UnknownAs unknownAs,
              Baked& out, std::vector<Tie>* ties = nullptr) {
  out.uniform.reset();
  out.unknown = 0;
  out.work = 0;
  out.nonFinite = false;
  TriangleClassifier c = makeClassifier(mask, p.margin, level, format, unknownAs);
  if (ties) ties->clear();
  c.ties = ties;
  double X[3], Y[3];
  for (int k = 0; k < 3; ++k) {
    X[k] = p.X[k] - c.shift;
    Y[k] = p.Y[k] - c.shift;
  }
  const unsigned r = c.region(X, Y, level > 0);
  out.work = c.work + 1;
  out.exhausted = c.budget == 0;
  // Every micro-triangle (similar to the triangle, scaled by 2^-level) holds a whole period of a mixed texture: all
  // are unknown, with the triangle's majority state (O(1) instead of 4^level samples).
  if (r == kMixed && level > 0 && c.holdsPeriod(X, Y, std::ldexp(1.0, -int(level)))) {
    out.uniform = c.unknownState(X, Y, 0, microTriangleCount(level));
    out.unknown = microTriangleCount(level);
    return;
  }
  if (r == kPass || r == kFail) {
    out.uniform = r == kPass ? State::Opaque : State::Transparent;
    return;
  }
  if (level == 0) {
    out.uniform = c.unknownState(X, Y, 0, 1);
    out.unknown = 1;
    return;
  }
  // Every micro-triangle is written by node(), so a map of the same shape from an earlier triangle is reused
  // as is.
  if (out.map.level() != level || out.map.format() != format) out.map = Micromap(level, format);
  c.bytes = out.map.bytes().data();
  unsigned vb = 0;
  for (int k = 0; k < 3; ++k) vb |= unsigned(c.passesAt(X[k], Y[k])) << k;
  c.node(X, Y, 0, 0, r, vb);
  out.unknown = c.unknown;
  out.work = c.work + 1;
  out.exhausted = c.budget == 0;
}

// The outcome of a triangle listed in another order (order[k] = the vertex of the classified triangle `p` that is its
// vertex k; docs/baking.md "Vertex orders"), from that triangle's outcome `base` and its ties: the same regions, so the
// same classes and majorities — only where the majority rule tied, the point that broke the tie (towards a node's
// vertex 0) is the twin's own, sampled again. Node vertices are recomputed with node()'s arithmetic (the same doubles).
void twinOf(const AlphaMask& mask, const Prepared& p, uint32_t level, Format format, UnknownAs unknownAs,
            const Baked& base, const std::vector<Tie>& ties, const VertexOrder& order, Baked& out) {
  out.unknown = base.unknown;
  out.work = 0;
  out.nonFinite = false;
  out.uniform = base.uniform;
  const TriangleClassifier c = makeClassifier(mask, p.margin, level, format, unknownAs);
  auto tieState = [&](const double X[3], const double Y[3], const VertexOrder& o) {
    // unknownFrom's tie point for the node listed in order o.
    const bool opaque =
        c.passesAt((2 * X[o[0]] + X[o[1]] + X[o[2]]) / 4, (2 * Y[o[0]] + Y[o[1]] + Y[o[2]]) / 4);
    if (format == Format::TwoState) return opaque ? State::Opaque : State::Transparent;
    return opaque ? State::UnknownOpaque : State::UnknownTransparent;
  };
  double X0[3], Y0[3];
  for (int k = 0; k < 3; ++k) {
    X0[k] = p.X[k] - c.shift;
    Y0[k] = p.Y[k] - c.shift;
  }
  if (base.uniform) {
    // A uniform outcome ties only as a whole (level 0, or every micro-triangle holding a period).
    if (!ties.empty()) out.uniform = tieState(X0, Y0, order);
    return;
  }
  reorderVertices(base.map, order, out.map);
  for (const Tie& t : ties) {
    const uint32_t depth = level - uint32_t(std::countr_zero(t.span)) / 2, q = t.start / t.span;
    double X[3], Y[3];
    std::copy(X0, X0 + 3, X);
    std::copy(Y0, Y0 + 3, Y);
    for (uint32_t d = depth; d-- > 0;) {  // node()'s children, down to node q
      const double ax = X[0], ay = Y[0], bx = X[1], by = Y[1], cx = X[2], cy = Y[2];
      const double abx = (ax + bx) * 0.5, aby = (ay + by) * 0.5;
      const double acx = (ax + cx) * 0.5, acy = (ay + cy) * 0.5;
      const double bcx = (bx + cx) * 0.5, bcy = (by + cy) * 0.5;
      const double cX[4][3] = {{ax, abx, acx}, {acx, bcx, abx}, {abx, bx, bcx}, {bcx, acx, cx}};
      const double cY[4][3] = {{ay, aby, acy}, {acy, bcy, aby}, {aby, by, bcy}, {bcy, acy, cy}};
      const uint32_t ch = (q >> (2 * d)) & 3u;
      std::copy(cX[ch], cX[ch] + 3, X);
      std::copy(cY[ch], cY[ch] + 3, Y);
    }
    VertexOrder nodeOrder{};
    const uint32_t q2 = reorderedNode(q, depth, order, &nodeOrder);
    const State s = tieState(X, Y, nodeOrder);
    for (uint32_t i = q2 * t.span, e = i + t.span; i < e; ++i) out.map.set(i, s);
  }
}

void bakeOne(const AlphaMask& mask, std::array<float, 2> uv0, std::array<float, 2> uv1,
             std::array<float, 2> uv2, uint32_t level, Format format, UnknownAs unknownAs, Baked& out) {
  Prepared p;
  prepare(mask, uv0, uv1, uv2, p);
  if (!p.usable) {
    out.uniform = wholeUnknown(format, unknownAs);
    out.unknown = microTriangleCount(level);
    out.nonFinite = true;
    return;
  }
  classify(mask, p, level, format, unknownAs, out);
}

std::string quoted(const char* name) {
  return name && *name ? " '" + std::string(name) + "'" : std::string();
}

std::string geometryName(uint32_t g, const GeometryInput& in) {
  return "geometry " + std::to_string(g) + quoted(in.name);
}

std::string materialName(uint32_t m, const MaterialInput& in) {
  return in.name && *in.name ? "material '" + std::string(in.name) + "'" : "material " + std::to_string(m);
}

// ---- reading the caller's geometry ----

struct GeometryReader {
  const GeometryInput& g;
  size_t stride() const noexcept { return g.uvStride ? g.uvStride : 2 * sizeof(float); }
  uint32_t vertex(uint32_t t, int k) const noexcept {
    const size_t i = 3 * size_t(t) + size_t(k);
    switch (g.indexFormat) {
      case IndexFormat::UInt16: {
        uint16_t v;
        std::memcpy(&v, static_cast<const uint8_t*>(g.indices) + 2 * i, 2);
        return v;
      }
      case IndexFormat::UInt32: {
        uint32_t v;
        std::memcpy(&v, static_cast<const uint8_t*>(g.indices) + 4 * i, 4);
        return v;
      }
      case IndexFormat::None:
        break;
    }
    return uint32_t(i);
  }
  std::array<float, 2> uv(uint32_t vertex) const noexcept {
    std::array<float, 2> r;
    std::memcpy(r.data(), reinterpret_cast<const uint8_t*>(g.uvs) + size_t(vertex) * stride(),
                2 * sizeof(float));
    return r;
  }
  std::array<float, 2> corner(uint32_t t, int k) const noexcept { return uv(vertex(t, k)); }
};

Status validateGeometryInput(uint32_t gi, const GeometryInput& g, uint32_t materialCount, bool needUvs) {
  const std::string name = geometryName(gi, g);
  if (g.material >= materialCount)
    return makeError(ErrorCode::InvalidArgument, name + ": material " + std::to_string(g.material) +
                                                     " is out of range (" + std::to_string(materialCount) +
                                                     " materials)");
  if (g.triangleCount == 0) return Ok{};
  if (g.indexFormat != IndexFormat::None && g.indexFormat != IndexFormat::UInt16 &&
      g.indexFormat != IndexFormat::UInt32)
    return makeError(ErrorCode::InvalidArgument, name + ": unknown index format");
  if (g.indexFormat != IndexFormat::None && !g.indices)
    return makeError(ErrorCode::InvalidArgument, name + ": no index data");
  if (!needUvs) return Ok{};
  if (!g.uvs) return makeError(ErrorCode::InvalidArgument, name + ": no UVs");
  if (g.uvStride != 0 && g.uvStride < 2 * sizeof(float))
    return makeError(ErrorCode::InvalidArgument,
                     name + ": UV stride " + std::to_string(g.uvStride) + " is less than 8 bytes");
  const GeometryReader r{g};
  if (g.indexFormat == IndexFormat::None) {
    if (uint64_t(g.triangleCount) * 3 > g.vertexCount)
      return makeError(ErrorCode::InvalidArgument,
                       name + ": " + std::to_string(g.triangleCount) + " triangles need " +
                           std::to_string(uint64_t(g.triangleCount) * 3) + " vertices, " +
                           std::to_string(g.vertexCount) + " given");
    return Ok{};
  }
  for (uint32_t t = 0; t < g.triangleCount; ++t)
    for (int k = 0; k < 3; ++k)
      if (const uint32_t v = r.vertex(t, k); v >= g.vertexCount)
        return makeError(ErrorCode::InvalidArgument, name + ": index " + std::to_string(v) +
                                                         " out of range (" + std::to_string(g.vertexCount) +
                                                         " vertices with UVs)");
  return Ok{};
}

// ---- classification jobs: distinct classification inputs ----

struct Job {
  uint32_t mask;
  uint32_t level;
  double X[3], Y[3];  // texel space, after removing whole periods
  double margin;
};

uint64_t mix(uint64_t h, uint64_t v) noexcept {
  h ^= v + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
  return h * 0xff51afd7ed558ccdull;
}

uint64_t bitsOf(double d) noexcept {
  uint64_t u;
  std::memcpy(&u, &d, 8);
  return u;
}

// A job's corners (bit patterns) in a canonical order: jobs listing the same three points in any order have equal
// keys. Two jobs with equal inputs but their vertices in another order are one classification (docs/baking.md
// "Vertex orders").
struct CornerKey {
  uint64_t c[3][2];
  explicit CornerKey(const Job& j) noexcept {
    for (int k = 0; k < 3; ++k) c[k][0] = bitsOf(j.X[k]), c[k][1] = bitsOf(j.Y[k]);
    auto less = [](const uint64_t* a, const uint64_t* b) { return a[0] != b[0] ? a[0] < b[0] : a[1] < b[1]; };
    auto swap = [&](int a, int b) {
      if (less(c[b], c[a])) std::swap(c[a], c[b]);
    };
    swap(0, 1);
    swap(1, 2);
    swap(0, 1);
  }
  bool operator==(const CornerKey& o) const noexcept { return std::memcmp(c, o.c, sizeof c) == 0; }
};

uint64_t hashJob(const Job& j) noexcept {
  uint64_t h = mix(j.mask, j.level);
  const CornerKey key(j);
  for (int k = 0; k < 3; ++k) h = mix(mix(h, key.c[k][0]), key.c[k][1]);
  h = mix(h, bitsOf(j.margin));
  return h ^ (h >> 29);
}

// The same inputs, the corners in any order.
bool sameJob(const Job& a, const Job& b) noexcept {
  if (a.mask != b.mask || a.level != b.level || bitsOf(a.margin) != bitsOf(b.margin)) return false;
  return CornerKey(a) == CornerKey(b);
}

// The order of `t` relative to the job `j` with the same corners: t's vertex k is j's vertex order[k]; the index of
// that order among kVertexOrders (0: the same order).
constexpr VertexOrder kVertexOrders[6] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
uint32_t orderOf(const Job& t, const Job& j) noexcept {
  for (uint32_t o = 0; o < 6; ++o) {
    bool same = true;
    for (int k = 0; k < 3; ++k) {
      const int m = kVertexOrders[o][k];
      same = same && bitsOf(t.X[k]) == bitsOf(j.X[m]) && bitsOf(t.Y[k]) == bitsOf(j.Y[m]);
    }
    if (same) return o;
  }
  return 0;  // unreachable for jobs with the same corners
}

// Removes whole periods of a repeating wrap mode: the cells (and the linear filter's blends) are periodic with the
// period, so the translated region touches the same texels. Exact in double for textures up to 2^24 texels wide.
void removePeriods(double v[3], uint32_t size, Wrap w) noexcept {
  if (w == Wrap::ClampToEdge || size > (1u << 24)) return;
  const double period = double(size) * (w == Wrap::MirroredRepeat ? 2.0 : 1.0);
  const double k = std::floor(std::min(v[0], std::min(v[1], v[2])) / period);
  if (k == 0 || !std::isfinite(k)) return;
  for (int i = 0; i < 3; ++i) v[i] -= k * period;
}

// Jobs by id, in chunks of 1024 (64 KiB each): no copies as they are appended and no reservation for every
// triangle — a block that large is mapped afresh, and its pages faulted in one by one by the serial stage that
// appends the jobs (TORCS forza level 6: 476 faults, 4-6 of that stage's 6-8 ms on a VM where a first touch costs
// ~10 µs), where chunks of the heap reuse memory the process has touched before.
class JobStore {
 public:
  size_t size() const noexcept { return size_; }
  const Job& operator[](size_t i) const noexcept { return chunks_[i >> kShift][i & kMask]; }
  void push_back(const Job& j) {
    if ((size_ & kMask) == 0) chunks_.emplace_back(new Job[kMask + 1]);
    chunks_[size_ >> kShift][size_ & kMask] = j;
    ++size_;
  }

 private:
  static constexpr size_t kShift = 10, kMask = (size_t(1) << kShift) - 1;
  std::vector<std::unique_ptr<Job[]>> chunks_;
  size_t size_ = 0;
};

// Open-addressing table of job ids keyed by their inputs. Each job's hash (hashJob) is kept beside it: probes
// compare hashes before inputs, and growing does not hash again.
class JobTable {
 public:
  // The id of an equal job, or the new job's id (appended to `jobs`); h = hashJob(j).
  uint32_t insert(const Job& j, uint64_t h, JobStore& jobs) {
    if ((jobs.size() + 1) * 2 > slots_.size()) grow();
    const size_t m = slots_.size() - 1;
    const uint64_t tag = h & kTagMask;
    for (size_t i = h & m;; i = (i + 1) & m) {
      const uint64_t e = slots_[i];
      if (e == 0) {
        jobs.push_back(j);
        hashes_.push_back(h);
        slots_[i] = tag | jobs.size();
        return uint32_t(jobs.size() - 1);
      }
      const uint32_t id = uint32_t(e) - 1;
      if ((e & kTagMask) == tag && sameJob(jobs[id], j)) return id;
    }
  }
  // Starts loading the slot a job of hash h is probed at first (the serial stage prefetches a few triangles ahead:
  // the table does not stay in the cache of the thread that runs that stage).
  void prefetch(uint64_t h) const noexcept { __builtin_prefetch(&slots_[h & (slots_.size() - 1)]); }
  // Room for n jobs' hashes (no copies as they grow; the slots grow with the jobs, so that a table of a scene with
  // many repeated triangles stays small enough to be cached).
  void reserve(size_t n) { hashes_.reserve(n); }

 private:
  // A slot: 0 (empty), else the job's id + 1 in the low 32 bits and the hash's high 32 bits (compared before the
  // job itself: a probe reads the job only when they match).
  static constexpr uint64_t kTagMask = ~uint64_t(0) << 32;
  std::vector<uint64_t> slots_ = std::vector<uint64_t>(1024, 0);
  std::vector<uint64_t> hashes_;  // by job id
  void grow() {
    std::vector<uint64_t> next(slots_.size() * 2, 0);
    const size_t m = next.size() - 1;
    for (uint32_t id = 0; id < hashes_.size(); ++id)
      for (size_t i = hashes_[id] & m;; i = (i + 1) & m)
        if (next[i] == 0) {
          next[i] = (hashes_[id] & kTagMask) | (uint64_t(id) + 1);
          break;
        }
    slots_ = std::move(next);
  }
};

// Per-triangle reference: a job id, or a special outcome.
constexpr uint32_t kSpecialBit = 0x80000000u, kNonFiniteBit = 0x40000000u, kAllUnknownBit = 0x20000000u;

// How a material is baked.
struct MaterialPlan {
  const AlphaMask* mask = nullptr;  // textured and alpha-tested
  uint32_t maskId = 0;
  State state = State::Opaque;  // when not textured
  bool allUnknown = false;      // BLEND as unknown: counts as unknown micro-triangles
};

struct CoreInputs {
  const BakeInputs& in;
  std::vector<MaterialPlan> plans;  // per material
};

// Per-geometry statistics, the layout, and the totals, from the scene-wide array of a pass.
void finishScene(const BakeInputs& in, const BakeOptions& o, OmmArray array, SceneBake& out) {
  std::vector<uint32_t> stamp(array.descriptors.size(), 0);
  uint32_t first = 0;
  for (uint32_t g = 0; g < in.geometryCount; ++g) {
    const uint32_t n = in.geometries[g].triangleCount;
    GeometryBake& gb = out.geometries[g];
    if (gb.levels.size() != n) gb.levels.assign(n, 0);
    BakeStats& st = gb.stats;
    st.triangles = n;
    for (uint32_t t = 0; t < n; ++t) {
      const int32_t i = array.indices[first + t];
      if (isSpecialIndex(i)) {
        ++st.specialCount[size_t(stateOfSpecialIndex(i))];
      } else if (stamp[size_t(i)] != g + 1) {
        stamp[size_t(i)] = g + 1;
        ++st.uniqueMaps;
        const TriangleDescriptor& d = array.descriptors[size_t(i)];
        st.dataBytes += micromapDataBytes(d.subdivisionLevel, Format(d.format));
      }
    }
    st.minLevel = st.maxLevel = 0;
    if (n) {
      st.minLevel = *std::min_element(gb.levels.begin(), gb.levels.end());
      st.maxLevel = *std::max_element(gb.levels.begin(), gb.levels.end());
    }
    first += n;
  }
  SceneMicromaps sm;
  sm.arrays.push_back(std::move(array));
  first = 0;
  for (uint32_t g = 0; g < in.geometryCount; ++g) {
    sm.geometries.push_back(GeometryMicromaps{0, first, in.geometries[g].triangleCount});
    first += in.geometries[g].triangleCount;
  }
  if (o.layout == ArrayLayout::PerGeometry) {
    std::vector<OmmArray> per;
    per.reserve(in.geometryCount);
    for (uint32_t g = 0; g < in.geometryCount; ++g) per.push_back(sm.standalone(g));
    sm = perGeometryMicromaps(std::move(per));
  }
  out.micromaps = std::move(sm);
  BakeStats& t = out.total;
  t = BakeStats{};
  bool any = false;
  for (const GeometryBake& gb : out.geometries) {
    const BakeStats& st = gb.stats;
    t.triangles += st.triangles;
    for (size_t k = 0; k < 4; ++k) t.specialCount[k] += st.specialCount[k];
    t.microTriangles += st.microTriangles;
    t.unknownMicroTriangles += st.unknownMicroTriangles;
    t.nonFiniteUvTriangles += st.nonFiniteUvTriangles;
    if (st.triangles) {
      t.minLevel = any ? std::min(t.minLevel, st.minLevel) : st.minLevel;
      t.maxLevel = any ? std::max(t.maxLevel, st.maxLevel) : st.maxLevel;
      any = true;
    }
  }
  for (const OmmArray& a : out.micromaps.arrays) {
    t.uniqueMaps += a.descriptors.size();
    t.dataBytes += a.data.size();
  }
}

// One bake pass of every geometry at min(level, cap). Progress: base + span · fraction.
Status bakePass(const CoreInputs& ci, const std::vector<std::vector<uint8_t>>& levels, uint32_t cap,
                const BakeOptions& o, tbb::task_arena& arena, SceneBake& out, double progressBase,
                double progressSpan) {
  const BakeInputs& in = ci.in;
  JobStore jobs;
  JobTable table;
  // Triangle references in scene order (geometry, triangle).
  uint64_t triangles = 0;
  for (uint32_t g = 0; g < in.geometryCount; ++g) triangles += in.geometries[g].triangleCount;
  std::vector<uint32_t> refs;
  refs.reserve(size_t(triangles));
  table.reserve(size_t(triangles));
  // A triangle listing a job's corners in another order refers to the job and that order (refOrder: an index into
  // kVertexOrders per triangle, allocated at the first such triangle); jobTwins: per job, bit o = some triangle
  // needs its map in order o.
  std::vector<uint8_t> refOrder, jobTwins;
  // (job a, job · 8 + order): the map of a job in another order first appears after job a's first triangle and before
  // job a + 1's; in that place it goes into the array (as a per-triangle builder would add it). In order of a.
  std::vector<std::pair<uint32_t, uint64_t>> twinsAfter;
  auto pushRef = [&](uint32_t ref, uint32_t order) {
    if (order != 0 && refOrder.empty()) refOrder.assign(refs.size(), 0);
    if (!refOrder.empty()) refOrder.push_back(uint8_t(order));
    refs.push_back(ref);
  };
  // Each triangle's job (its corners in texel space, whole periods removed, and its hash) is prepared in parallel,
  // in blocks of scene order; the blocks enter the table in order (the same job ids, refs and twins as one loop).
  // At most `prepTokens` blocks are alive.
  struct Candidate {
    Job job;
    uint64_t hash;
    uint32_t special;  // a special outcome's reference (kSpecialBit set), or 0: the job
  };
  // Blocks (and batches below) on cache lines of their own: two threads filling neighbouring ones would otherwise
  // keep taking the line of their vector headers from each other.
  struct alignas(128) PrepBlock {
    uint32_t g = 0, t = 0, count = 0;  // the block's first triangle (geometry, triangle) and its size
    std::vector<Candidate> c;
  };
  constexpr uint32_t kPrepBlock = 1024;
  std::vector<PrepBlock> prep(size_t(2 * arena.max_concurrency() + 2));
  size_t prepIssued = 0;
  uint32_t pg = 0, pt = 0;  // the next block's first triangle
  arena.execute([&] {
    tbb::parallel_pipeline(
        prep.size(),
        tbb::make_filter<
            void, PrepBlock*>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control& fc) -> PrepBlock* {
          while (pg < in.geometryCount && pt == in.geometries[pg].triangleCount) {
            ++pg;
            pt = 0;
          }
          if (pg >= in.geometryCount) {
            fc.stop();
            return nullptr;
          }
          PrepBlock* b = &prep[prepIssued++ % prep.size()];
          b->g = pg;
          b->t = pt;
          b->count = 0;
          // Whole geometries and parts of them, kPrepBlock triangles in all.
          while (pg < in.geometryCount && b->count < kPrepBlock) {
            const uint32_t n = std::min(in.geometries[pg].triangleCount - pt, kPrepBlock - b->count);
            b->count += n;
            pt += n;
            if (pt == in.geometries[pg].triangleCount) {
              ++pg;
              pt = 0;
            }
          }
          return b;
        }) & tbb::make_filter<PrepBlock*, PrepBlock*>(tbb::filter_mode::parallel, [&](PrepBlock* b) {
          if (b->c.size() < b->count) b->c.resize(b->count);
          uint32_t g = b->g, t = b->t;
          for (uint32_t k = 0; k < b->count; ++k, ++t) {
            while (t == in.geometries[g].triangleCount) ++g, t = 0;
            const GeometryInput& gi = in.geometries[g];
            const MaterialPlan& plan = ci.plans[gi.material];
            Candidate& c = b->c[k];
            if (!plan.mask) {
              c.special = kSpecialBit | (plan.allUnknown ? kAllUnknownBit : 0u) | uint32_t(plan.state);
              continue;
            }
            const GeometryReader r{gi};
            Prepared p;
            prepare(*plan.mask, r.corner(t, 0), r.corner(t, 1), r.corner(t, 2), p);
            if (!p.usable) {
              c.special = kSpecialBit | kNonFiniteBit | uint32_t(wholeUnknown(o.format, o.unknownAs));
              continue;
            }
            Job& j = c.job;
            j.mask = plan.maskId;
            j.level = std::min<uint32_t>(levels[g][t], cap);
            std::copy(p.X, p.X + 3, j.X);
            std::copy(p.Y, p.Y + 3, j.Y);
            j.margin = p.margin;
            removePeriods(j.X, plan.mask->width(), plan.mask->sampler().wrapS);
            removePeriods(j.Y, plan.mask->height(), plan.mask->sampler().wrapT);
            c.hash = hashJob(j);
            c.special = 0;
          }
          return b;
        }) & tbb::make_filter<PrepBlock*, void>(tbb::filter_mode::serial_in_order, [&](PrepBlock* b) {
          constexpr uint32_t kAhead = 8;
          for (uint32_t k = 0; k < std::min(kAhead, b->count); ++k)
            if (!b->c[k].special) table.prefetch(b->c[k].hash);
          for (uint32_t k = 0; k < b->count; ++k) {
            if (k + kAhead < b->count && !b->c[k + kAhead].special) table.prefetch(b->c[k + kAhead].hash);
            const Candidate& c = b->c[k];
            if (c.special) {
              pushRef(c.special, 0);
              continue;
            }
            const size_t known = jobs.size();
            const uint32_t id = table.insert(c.job, c.hash, jobs);
            uint32_t order = 0;
            if (jobs.size() == known) {
              order = orderOf(c.job, jobs[id]);
              if (order != 0 && !(jobTwins[id] & (1u << order))) {
                jobTwins[id] = uint8_t(jobTwins[id] | (1u << order));
                twinsAfter.push_back({uint32_t(jobs.size() - 1), uint64_t(id) * 8 + order});
              }
            } else {
              jobTwins.push_back(0);
            }
            pushRef(id, order);
          }
        }));
  });
  std::vector<PrepBlock>().swap(prep);
  table = JobTable{};
  std::vector<const AlphaMask*> masks;  // by mask id
  for (const MaterialPlan& p : ci.plans)
    if (p.mask) {
      if (masks.size() <= p.maskId) masks.resize(p.maskId + 1, nullptr);
      masks[p.maskId] = p.mask;
    }

  // Classify the jobs in chunks (bounded in count and map memory); after each chunk, stream the triangles whose
  // jobs are done into the array in scene order. Job ids are in order of first appearance, so the triangles up to
  // the first one of a later chunk's job are complete.
  OmmArrayBuilder builder;
  std::vector<int32_t> jobIndex(jobs.size(), 0);
  // job · 8 + order → the index of the job's map in that order and its unknown micro-triangles (the same as the
  // job's unless the work bound was reached)
  std::unordered_map<uint64_t, std::pair<int32_t, uint64_t>> twinIndex;
  // maps of twinIndex not yet in the array, with their keys
  std::unordered_map<uint64_t, std::pair<Micromap, OmmArrayBuilder::MapKey>> pending;
  size_t nextTwin = 0;  // twinsAfter[nextTwin] is the next to add
  std::vector<uint32_t> jobUnknown(jobs.size(), 0);
  out.geometries.assign(in.geometryCount, GeometryBake{});
  out.classifiedTriangles = jobs.size();
  size_t cursor = 0;
  uint32_t cg = 0, ct = 0;  // geometry / triangle of refs[cursor]
  while (cg < in.geometryCount && in.geometries[cg].triangleCount == 0) ++cg;
  auto emit = [&](uint32_t jobEnd) {
    while (cursor < refs.size()) {
      const uint32_t ref = refs[cursor];
      if (!(ref & kSpecialBit) && ref >= jobEnd) break;
      GeometryBake& gb = out.geometries[cg];
      BakeStats& st = gb.stats;
      if (gb.levels.empty()) gb.levels.assign(in.geometries[cg].triangleCount, 0);
      if (ref & kSpecialBit) {
        const State s = State(ref & 3u);
        builder.addSpecial(s);
        if (ref & kNonFiniteBit) {
          const uint32_t level = std::min<uint32_t>(levels[cg][ct], cap);
          gb.levels[ct] = uint8_t(level);
          st.microTriangles += microTriangleCount(level);
          st.unknownMicroTriangles += microTriangleCount(level);
          ++st.nonFiniteUvTriangles;
        } else {
          st.microTriangles += 1;
          if (ref & kAllUnknownBit) st.unknownMicroTriangles += 1;
        }
      } else {
        const uint32_t level = jobs[ref].level;
        gb.levels[ct] = uint8_t(level);
        st.microTriangles += microTriangleCount(level);
        const uint32_t order = refOrder.empty() ? 0u : refOrder[cursor];
        if (order == 0) {
          st.unknownMicroTriangles += jobUnknown[ref];
          builder.addIndex(jobIndex[ref]);
        } else {
          const auto& [index, unknown] = twinIndex.at(uint64_t(ref) * 8 + order);
          st.unknownMicroTriangles += unknown;
          builder.addIndex(index);
        }
      }
      ++cursor;
      if (++ct == in.geometries[cg].triangleCount) {
        ct = 0;
        ++cg;
        while (cg < in.geometryCount && in.geometries[cg].triangleCount == 0) ++cg;
      }
    }
  };
  // A pipeline over all jobs: batches are handed out in job order, classified in parallel, and interned in job order
  // (= order of first appearance, as a per-triangle builder would store them) — no barrier, so a slow job only
  // delays the interning of later batches while the other threads go on. At most `tokens` batches (each bounded in
  // count and map bytes) are alive; batch k reuses ring slot k mod tokens, free since batch k − tokens has left the
  // last stage.
  // The ring's maps stay allocated for reuse (no fresh pages per map): about kRingBytes in all — 32 batches per thread
  // while that fits, fewer (at least 2 per thread + 2) when single maps are large (level 12: 4 MiB each).
  const uint32_t nj = uint32_t(jobs.size());
  constexpr uint64_t kRingBytes = uint64_t(4) << 20;
  uint64_t largestMap = 1, dataBound = 0;
  for (uint32_t i = 0; i < nj; ++i) {
    const uint64_t bytes = micromapDataBytes(jobs[i].level, o.format);
    largestMap = std::max(largestMap, bytes);
    dataBound += bytes * (1u + uint32_t(std::popcount(jobTwins[i])));
  }
  // The array's data is at most every job's map in every order it is needed in: reserved up front (address space;
  // pages are touched as maps are stored), the builder hands it over without concatenating chunks at the end.
  constexpr uint64_t kReserveCap = uint64_t(1) << 30;
  builder.reserveData(size_t(std::min(dataBound, kReserveCap)));
  const size_t tokens = size_t(std::max<uint64_t>(
      2 * uint64_t(arena.max_concurrency()) + 2,
      std::min<uint64_t>(32 * uint64_t(arena.max_concurrency()), kRingBytes / largestMap)));
  const uint64_t batchBytes = std::max<uint64_t>(kRingBytes / tokens, 1);
  constexpr uint32_t kBatchJobs = 16;
  struct alignas(128) Batch {  // (aligned: see PrepBlock; flora-quarter level 6, two threads: 6 % less CPU)
    uint32_t j0 = 0, j1 = 0;
    std::vector<Baked> slots;                 // maps are kept for reuse by a later batch
    std::vector<std::array<Baked, 6>> twins;  // per slot, the job's outcome in the orders it is needed in
    std::vector<Tie> ties;
  };
  std::vector<Batch> ring(std::max<size_t>(1, std::min<size_t>(tokens, nj)));
  uint32_t next = 0;
  size_t issued = 0;
  std::atomic<bool> cancelled{false};
  const std::thread::id caller = std::this_thread::get_id();
  arena.execute([&] {
    tbb::parallel_pipeline(
        ring.size(),
        tbb::make_filter<void,
                         Batch*>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control& fc) -> Batch* {
          if (next >= nj || cancelled.load(std::memory_order_relaxed)) {
            fc.stop();
            return nullptr;
          }
          Batch* b = &ring[issued++ % ring.size()];
          b->j0 = next;
          uint64_t bytes = 0;
          while (next < nj && next - b->j0 < kBatchJobs && bytes < batchBytes) {
            bytes += micromapDataBytes(jobs[next].level, o.format) *
                     (1u + uint32_t(std::popcount(jobTwins[next])));
            ++next;
          }
          b->j1 = next;
          if (b->slots.size() < b->j1 - b->j0) b->slots.resize(b->j1 - b->j0);
          if (b->twins.size() < b->j1 - b->j0) b->twins.resize(b->j1 - b->j0);
          return b;
        }) & tbb::make_filter<Batch*, Batch*>(tbb::filter_mode::parallel, [&](Batch* b) {
          for (uint32_t i = b->j0; i != b->j1; ++i) {
            const Job& j = jobs[i];
            Prepared p;
            std::copy(j.X, j.X + 3, p.X);
            std::copy(j.Y, j.Y + 3, p.Y);
            p.margin = j.margin;
            Baked& base = b->slots[i - b->j0];
            classify(*masks[j.mask], p, j.level, o.format, o.unknownAs, base,
                     jobTwins[i] ? &b->ties : nullptr);
            if (!base.uniform) base.key = OmmArrayBuilder::keyOf(base.map);
            for (uint32_t t = jobTwins[i]; t; t &= t - 1) {
              const uint32_t order = uint32_t(std::countr_zero(t));
              const VertexOrder& vo = kVertexOrders[order];
              Baked& tw = b->twins[i - b->j0][order];
              if (!base.exhausted) {
                twinOf(*masks[j.mask], p, j.level, o.format, o.unknownAs, base, b->ties, vo, tw);
              } else {
                // Where the work bound cut the classification short depends on the order the nodes were visited
                // in: the triangle in its own order is classified on its own (as it would be without sharing).
                Prepared q = p;
                for (int k = 0; k < 3; ++k) q.X[k] = p.X[vo[k]], q.Y[k] = p.Y[vo[k]];
                classify(*masks[j.mask], q, j.level, o.format, o.unknownAs, tw);
              }
              if (!tw.uniform) tw.key = OmmArrayBuilder::keyOf(tw.map);
            }
          }
          return b;
        }) & tbb::make_filter<Batch*, void>(tbb::filter_mode::serial_in_order, [&](Batch* b) {
          for (uint32_t i = b->j0; i < b->j1; ++i) {
            const Baked& r = b->slots[i - b->j0];
            jobUnknown[i] = uint32_t(r.unknown);
            jobIndex[i] = r.uniform ? specialIndexFor(*r.uniform) : builder.intern(r.map, r.key);
            // The job's maps in other orders wait (pending) for their place in the array.
            for (uint32_t t = jobTwins[i]; t; t &= t - 1) {
              const uint32_t order = uint32_t(std::countr_zero(t));
              Baked& tw = b->twins[i - b->j0][order];
              const uint64_t key = uint64_t(i) * 8 + order;
              if (tw.uniform) {
                twinIndex[key] = {specialIndexFor(*tw.uniform), tw.unknown};
              } else {
                twinIndex[key] = {-1, tw.unknown};
                pending.emplace(key, std::make_pair(std::move(tw.map), tw.key));
                tw.map = Micromap();  // not left moved-from: the slot's next job sizes it again
              }
            }
            for (; nextTwin < twinsAfter.size() && twinsAfter[nextTwin].first == i; ++nextTwin) {
              const auto it = pending.find(twinsAfter[nextTwin].second);
              if (it == pending.end()) continue;  // a uniform map: a special index, no place in the array
              twinIndex[it->first].first = builder.intern(it->second.first, it->second.second);
              pending.erase(it);
            }
          }
          emit(b->j1);
          // The progress callback runs on the calling thread only (when it runs this stage).
          if (o.progress && std::this_thread::get_id() == caller &&
              !o.progress(progressBase + progressSpan * double(b->j1) / double(nj)))
            cancelled.store(true, std::memory_order_relaxed);
        }));
  });
  if (cancelled.load() || (o.progress && !o.progress(progressBase + progressSpan)))
    return makeError(ErrorCode::Cancelled, "bake cancelled");
  emit(UINT32_MAX & ~kSpecialBit);
  assert(cursor == refs.size());
  // The ring's maps (about kRingBytes) are not needed any more: free them before finish() makes the data contiguous.
  std::vector<Batch>().swap(ring);
  OmmArray array = builder.finish();
  finishScene(in, o, std::move(array), out);
  return Ok{};
}

}  // namespace

// ---- the scene pool ----

namespace {

Status validateGeometryLegacy(const Geometry& g, bool needUvs) {
  const std::string name = "geometry '" + g.name + "'";
  if (g.indices.size() % 3 != 0)
    return makeError(ErrorCode::InvalidArgument,
                     name + ": index count " + std::to_string(g.indices.size()) + " is not a multiple of 3");
  if (needUvs && g.uvs.size() % 2 != 0)
    return makeError(ErrorCode::InvalidArgument, name + ": odd number of UV floats");
  return Ok{};
}

Status validateAlphaTexture(const Material& m) {
  const AlphaTexture& t = *m.alpha;
  const std::string name =
      "material '" + m.name + "' alpha texture" + (m.alphaSource.empty() ? "" : " " + m.alphaSource);
  if (t.width == 0 || t.height == 0) return makeError(ErrorCode::InvalidArgument, name + ": empty texture");
  if (uint64_t(t.width) * t.height >= (uint64_t(1) << 32))
    return makeError(ErrorCode::LimitExceeded, name + ": texture too large");
  if (!t.consistent()) {
    const size_t n = t.storage == AlphaStorage::UInt8    ? t.alpha8.size()
                     : t.storage == AlphaStorage::UInt16 ? t.alpha16.size()
                                                         : t.alpha.size();
    if (n == t.texelCount())
      return makeError(ErrorCode::InvalidArgument,
                       name + ": integer alpha without a value table of its size");
    return makeError(ErrorCode::InvalidArgument, name + ": alpha has " + std::to_string(n) + " values for " +
                                                     std::to_string(t.width) + "x" +
                                                     std::to_string(t.height));
  }
  return Ok{};
}

Sampler effectiveSampler(Sampler s, const BakeOptions& o) {
  if (o.filter) s.filter = *o.filter;
  return s;
}

GeometryInput viewOf(const Geometry& g, uint32_t material) {
  GeometryInput in;
  in.uvs = g.uvs.data();
  in.uvStride = 2 * sizeof(float);
  in.vertexCount = uint32_t(std::min<size_t>(g.uvs.size() / 2, UINT32_MAX));
  in.indices = g.indices.data();
  in.indexFormat = IndexFormat::UInt32;
  in.triangleCount = g.triangleCount();
  in.material = material;
  in.name = g.name.c_str();
  return in;
}

// Bakes prepared inputs: validation of options and geometries, levels, the passes of the maxBytes cap.
Result<SceneBake> bakeCore(const CoreInputs& ci, const BakeOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const BakeInputs& in = ci.in;
  for (uint32_t g = 0; g < in.geometryCount; ++g) {
    const GeometryInput& gi = in.geometries[g];
    const bool needUvs = gi.material < ci.plans.size() && ci.plans[gi.material].mask;
    if (Status s = validateGeometryInput(g, gi, uint32_t(ci.plans.size()), needUvs); !s) return s.error();
  }
  // Levels before any cap.
  std::vector<std::vector<uint8_t>> levels(in.geometryCount);
  uint32_t top = 0;
  for (uint32_t g = 0; g < in.geometryCount; ++g) {
    const GeometryInput& gi = in.geometries[g];
    const MaterialPlan& plan = ci.plans[gi.material];
    levels[g].assign(gi.triangleCount, plan.mask ? uint8_t(o.level) : uint8_t(0));
    if (plan.mask && o.texelsPerMicroTri > 0) {
      const GeometryReader r{gi};
      for (uint32_t t = 0; t < gi.triangleCount; ++t)
        levels[g][t] =
            uint8_t(adaptiveLevel(r.corner(t, 0), r.corner(t, 1), r.corner(t, 2), plan.mask->width(),
                                  plan.mask->height(), o.texelsPerMicroTri, o.maxLevel));
    }
    for (uint8_t l : levels[g]) top = std::max<uint32_t>(top, l);
  }
  tbb::task_arena arena(o.threads ? int(o.threads) : tbb::task_arena::automatic);
  SceneBake out;
  // With maxBytes, re-bakes may follow: pass k reports within [1 − 2^−k, 1 − 2^−(k+1)], so progress stays
  // monotone.
  double span = o.maxBytes > 0 ? 0.5 : 1.0, base = 0;
  uint32_t levelCap = kMaxLevel;
  if (Status s = bakePass(ci, levels, kMaxLevel, o, arena, out, base, span); !s) return s.error();
  if (o.maxBytes > 0) {
    // Lower the largest maps (the highest levels) one level at a time until the data fits. Level 0 always
    // fits: a one-state map is uniform and becomes a special index.
    for (uint32_t cap = top; out.total.dataBytes > o.maxBytes && cap-- > 0;) {
      base += span;
      span *= 0.5;
      if (Status s = bakePass(ci, levels, cap, o, arena, out, base, span); !s) return s.error();
      levelCap = cap;
    }
  }
  if (o.progress) o.progress(1.0);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.total.levelCap = levelCap;
  out.total.seconds = seconds;
  for (GeometryBake& g : out.geometries) {
    g.stats.levelCap = levelCap;
    g.stats.seconds = seconds;
  }
  return out;
}

}  // namespace

void AlphaMask::build() {
  words_ = size_t(w_) / 64 + 1;
  // One word of padding: passBits(x, y) reads the word after x's, which for the last row is past the rows. Bits of
  // texels at or beyond W stay 0 (the word table counts whole words).
  bits_.assign(words_ * h_ + 1, 0);
  // Integer texels: the alpha test of every value once (the same float and compare as texel()), then a table look-up.
  std::vector<uint8_t> passOf;
  if (kind_ == Kind::U8 || (kind_ == Kind::U16 && uint64_t(w_) * h_ > 65536)) {
    passOf.resize(kind_ == Kind::U8 ? 256 : 65536);
    for (size_t v = 0; v < passOf.size(); ++v) passOf[v] = alphaTestPasses(lut_[v], cutoff_) ? 1 : 0;
  }
  auto rows = [&](auto passAt) {
    for (uint32_t y = 0; y < h_; ++y) {
      uint64_t* bits = bits_.data() + size_t(y) * words_;
      const uint8_t* p = base_ + size_t(y) * pitch_;
      uint64_t word = 0;
      for (uint32_t x = 0; x < w_; ++x) {
        word |= uint64_t(passAt(p, x, y)) << (x & 63u);
        if ((x & 63u) == 63u) {
          bits[x >> 6] = word;
          word = 0;
        }
      }
      if (w_ & 63u) bits[w_ >> 6] = word;
    }
  };
  // 8-bit texels one byte apart whose alpha test is a threshold on the value (passOf[v] = v >= t, as for every
  // non-decreasing value table): 16 texels per compare.
  uint32_t threshold = 256;
  bool isThreshold = kind_ == Kind::U8 && !passOf.empty() && bpp_ == 1;
  for (uint32_t v = 0; isThreshold && v < 256; ++v) {
    if (passOf[v] && threshold == 256) threshold = v;
    isThreshold = passOf[v] == (v >= threshold ? 1 : 0);
  }
#if defined(__SSE2__)
  if (isThreshold) {
    // v >= t  ⟺  max(v, t) == v (unsigned bytes); t = 256 (nothing passes): the bits stay 0.
    const __m128i t = _mm_set1_epi8(char(uint8_t(std::min<uint32_t>(threshold, 255))));
    for (uint32_t y = 0; threshold < 256 && y < h_; ++y) {
      uint64_t* bits = bits_.data() + size_t(y) * words_;
      const uint8_t* p = base_ + size_t(y) * pitch_;
      uint32_t x = 0;
      for (; x + 64 <= w_; x += 64) {
        uint64_t word = 0;
        for (uint32_t q = 0; q < 4; ++q) {
          const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + x + 16 * q));
          word |= uint64_t(uint32_t(_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_max_epu8(v, t), v)))) << (16 * q);
        }
        bits[x >> 6] = word;
      }
      uint64_t word = 0;
      for (; x < w_; ++x) word |= uint64_t(p[x] >= threshold ? 1u : 0u) << (x & 63u);
      if (w_ & 63u) bits[w_ >> 6] = word;
    }
  } else
#endif
      if (kind_ == Kind::U8 && !passOf.empty()) {
    const uint8_t* t = passOf.data();
    const size_t bpp = bpp_;
    rows([t, bpp](const uint8_t* p, uint32_t x, uint32_t) -> uint32_t { return t[p[size_t(x) * bpp]]; });
  } else if (kind_ == Kind::U16 && !passOf.empty()) {
    const uint8_t* t = passOf.data();
    const size_t bpp = bpp_;
    rows([t, bpp](const uint8_t* p, uint32_t x, uint32_t) -> uint32_t {
      uint16_t v;
      std::memcpy(&v, p + size_t(x) * bpp, 2);
      return t[v];
    });
  } else {
    rows([this](const uint8_t*, uint32_t x, uint32_t y) -> uint32_t {
      return alphaTestPasses(texel(x, y), cutoff_) ? 1u : 0u;
    });
  }
  // The word table: a summed-area table over the rows' words (1/64 of a per-texel table).
  const size_t stride = words_ + 1;
  wordSatSize_ = stride * (size_t(h_) + 1);
  wordSat_.reset(new uint32_t[wordSatSize_]);
  uint32_t* ws = wordSat_.get();
  std::fill(ws, ws + stride, 0u);
  for (uint32_t y = 0; y < h_; ++y) {
    const uint64_t* bits = bits_.data() + size_t(y) * words_;
    const uint32_t* above = ws + size_t(y) * stride;
    uint32_t* cur = ws + (size_t(y) + 1) * stride;
    cur[0] = 0;
    uint32_t row = 0;
    for (size_t k = 0; k < words_; ++k) {
      row += uint32_t(std::popcount(bits[k]));
      cur[k + 1] = above[k + 1] + row;
    }
  }
}

AlphaMask::AlphaMask(const AlphaTexture& texture, const Sampler& sampler, float cutoff)
    : w_(texture.width), h_(texture.height), sampler_(sampler), cutoff_(cutoff) {
  assert(w_ > 0 && h_ > 0 && texture.consistent());
  // Viewed at its own precision, no copy: integer texels through the texture's table (the same floats as at()).
  switch (texture.storage) {
    case AlphaStorage::UInt8:
      base_ = texture.alpha8.data();
      bpp_ = 1;
      kind_ = Kind::U8;
      break;
    case AlphaStorage::UInt16:
      base_ = reinterpret_cast<const uint8_t*>(texture.alpha16.data());
      bpp_ = 2;
      kind_ = Kind::U16;
      break;
    case AlphaStorage::Float32:
      base_ = reinterpret_cast<const uint8_t*>(texture.alpha.data());
      bpp_ = sizeof(float);
      kind_ = Kind::F32;
      break;
  }
  if (kind_ != Kind::F32) {
    lutTable_ = texture.lut;
    lut_ = lutTable_->data();
  }
  pitch_ = size_t(w_) * bpp_;
  build();
}

AlphaMask::AlphaMask(const TextureView& t, const Sampler& sampler, float cutoff, float alphaScale)
    : bpp_(texelBytes(t.format)), w_(t.width), h_(t.height), sampler_(sampler), cutoff_(cutoff) {
  assert(validateTexture(t).ok());
  pitch_ = t.rowPitch ? t.rowPitch : size_t(t.width) * bpp_;
  const uint8_t* data = static_cast<const uint8_t*>(t.data);
  switch (t.format) {
    case TexelFormat::R8:
    case TexelFormat::RG8:
    case TexelFormat::RGBA8:
      kind_ = Kind::U8;
      base_ = data + t.alphaChannel;
      lutTable_ = AlphaTexture::table(AlphaStorage::UInt8, alphaScale);
      break;
    case TexelFormat::R16:
    case TexelFormat::RGBA16:
      kind_ = Kind::U16;
      base_ = data + 2 * size_t(t.alphaChannel);
      lutTable_ = AlphaTexture::table(AlphaStorage::UInt16, alphaScale);
      break;
    case TexelFormat::R32F:
      kind_ = Kind::F32;
      base_ = data;
      scale_ = alphaScale;
      break;
  }
  if (lutTable_) {
    lut_ = lutTable_->data();
    if (alphaScale != 1.0f) lutBytes_ = lutTable_->size() * sizeof(float);  // made for this view
  }
  build();
}

Status validateTexture(const TextureView& t) {
  const std::string name = "texture" + quoted(t.name);
  if (!t.data) return makeError(ErrorCode::InvalidArgument, name + ": no texel data");
  if (t.width == 0 || t.height == 0) return makeError(ErrorCode::InvalidArgument, name + ": empty texture");
  if (uint64_t(t.width) * t.height >= (uint64_t(1) << 32))
    return makeError(ErrorCode::LimitExceeded, name + ": texture too large");
  if (uint8_t(t.format) > uint8_t(TexelFormat::R32F))
    return makeError(ErrorCode::InvalidArgument, name + ": unknown texel format");
  if (t.alphaChannel >= texelChannels(t.format))
    return makeError(ErrorCode::InvalidArgument, name + ": alpha channel " + std::to_string(t.alphaChannel) +
                                                     " is out of range for " + texelFormatName(t.format));
  const uint64_t row = uint64_t(t.width) * texelBytes(t.format);
  if (t.rowPitch != 0 && t.rowPitch < row)
    return makeError(ErrorCode::InvalidArgument,
                     name + ": row pitch " + std::to_string(t.rowPitch) + " is less than width * " +
                         std::to_string(texelBytes(t.format)) + " = " + std::to_string(row));
  return Ok{};
}

// Passing texels of rows [y0, y1] in the whole words [ka, kb) (ka < kb), from the word table in O(1).
uint64_t AlphaMask::wordsPass(uint32_t ka, uint32_t kb, uint32_t y0, uint32_t y1) const noexcept {
  const size_t stride = words_ + 1;
  const uint32_t* a = wordSat_.get() + size_t(y0) * stride;
  const uint32_t* b = wordSat_.get() + (size_t(y1) + 1) * stride;
  return uint32_t(b[kb] - b[ka] - a[kb] + a[ka]);  // modular arithmetic; the true count fits
}

// Passing texels in [x0, x1] × [y0, y1] (inside the texture): whole words from the word table, the partial words
// at either end row by row.
uint64_t AlphaMask::rectPass(uint32_t x0, uint32_t x1, uint32_t y0, uint32_t y1) const noexcept {
  const uint32_t k0 = x0 >> 6, k1 = x1 >> 6, s0 = x0 & 63u, s1 = x1 & 63u;
  const uint64_t lo = ~uint64_t(0) << s0, hi = ~uint64_t(0) >> (63u - s1);
  const uint64_t* row = bits_.data() + size_t(y0) * words_;
  uint64_t n = 0;
  if (k0 == k1) {
    for (uint32_t y = y0; y <= y1; ++y, row += words_) n += uint64_t(std::popcount(row[k0] & lo & hi));
    return n;
  }
  // Whole words (k0, k1) exclusive (none when k1 = k0 + 1); the end words' bits in the rectangle row by row.
  if (k1 > k0 + 1) n = wordsPass(k0 + 1, k1, y0, y1);
  for (uint32_t y = y0; y <= y1; ++y, row += words_)
    n += uint64_t(std::popcount(row[k0] & lo)) + uint64_t(std::popcount(row[k1] & hi));
  return n;
}

// Bit 0: [x0, x1] × [y0, y1] (inside the texture) holds a passing texel; bit 1: a failing one. The whole words from
// the word table first (O(1)); the partial end words row by row only while a class is still unseen.
unsigned AlphaMask::rectPassFail(uint32_t x0, uint32_t x1, uint32_t y0, uint32_t y1) const noexcept {
  constexpr uint32_t kCountRows = 8;
  const uint32_t k0 = x0 >> 6, k1 = x1 >> 6, s0 = x0 & 63u, s1 = x1 & 63u;
  uint64_t lo = ~uint64_t(0) << s0, hi = ~uint64_t(0) >> (63u - s1);
  unsigned seen = 0;
  uint32_t kl = k0, kr = k1;  // the end words scanned row by row (one when k0 == k1)
  if (k0 == k1) {
    lo &= hi;
    hi = 0;
  } else if (k1 > k0 + 1) {
    const uint64_t pass = wordsPass(k0 + 1, k1, y0, y1);
    const uint64_t total = uint64_t(k1 - k0 - 1) * 64u * (uint64_t(y1) - y0 + 1);
    seen = (pass > 0 ? 1u : 0u) | (pass < total ? 2u : 0u);
    if (seen == 3u) return 3u;
  }
  // An end word whose whole column [64k, 64k + 63] × [y0, y1] is of one class (the word table's count, O(1)) gives
  // its part of the rectangle that class without reading its rows: tall rectangles over uniform texels (a node's
  // grown box) read no row at all. Short ones read their rows (fewer instructions than the two counts).
  if (y1 - y0 >= kCountRows) {
    const uint64_t whole = 64u * (uint64_t(y1) - y0 + 1);
    const uint64_t pl = wordsPass(kl, kl + 1, y0, y1);
    if (pl == 0 || pl == whole) {
      seen |= pl ? 1u : 2u;
      if (!hi) return seen;
      lo = 0;  // the left word is done; only the right one is left to read
    }
    if (hi) {
      const uint64_t pr = wordsPass(kr, kr + 1, y0, y1);
      if (pr == 0 || pr == whole) {
        seen |= pr ? 1u : 2u;
        hi = 0;
      }
    }
    if (seen == 3u || (lo | hi) == 0) return seen;
  }
  const uint64_t* row = bits_.data() + size_t(y0) * words_;
  for (uint32_t y = y0; y <= y1; ++y, row += words_) {
    const uint64_t l = row[kl], r = hi ? row[kr] : 0;
    seen |= ((l & lo) | (r & hi)) != 0 ? 1u : 0u;
    seen |= ((~l & lo) | (~r & hi)) != 0 ? 2u : 0u;
    if (seen == 3u) return 3u;
  }
  return seen;
}

AlphaMask::Count AlphaMask::count(int64_t x0, int64_t x1, int64_t y0, int64_t y1) const noexcept {
  Interval xs[4], ys[4];
  const int nx = wrapInterval(x0, x1, w_, sampler_.wrapS, xs);
  const int ny = wrapInterval(y0, y1, h_, sampler_.wrapT, ys);
  Count c;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      c.pass += rectPass(xs[i].lo, xs[i].hi, ys[j].lo, ys[j].hi);
      c.total += uint64_t(xs[i].hi - xs[i].lo + 1) * (ys[j].hi - ys[j].lo + 1);
    }
  return c;
}

unsigned AlphaMask::passFail(int64_t x0, int64_t x1, int64_t y0, int64_t y1) const noexcept {
  Interval xs[4], ys[4];
  const int nx = wrapInterval(x0, x1, w_, sampler_.wrapS, xs);
  const int ny = wrapInterval(y0, y1, h_, sampler_.wrapT, ys);
  unsigned seen = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      seen |= rectPassFail(xs[i].lo, xs[i].hi, ys[j].lo, ys[j].hi);
      if (seen == 3u) return 3u;
    }
  return seen;
}

double bakeMarginTexels(const double x[3], const double y[3]) noexcept {
  // docs/baking.md "Safety margin": 6·2^-24·P (float UV interpolation, P = the power of two above the largest
  // coordinate magnitude) + 2·2^-20·E (barycentrics up to 2^-20 outside the micro-triangle, E = the larger extent)
  // + 1e-9 (the baker's own double arithmetic).
  double mag = 0;
  for (int k = 0; k < 3; ++k) mag = std::max(mag, std::max(std::fabs(x[k]), std::fabs(y[k])));
  const double ex = std::max(x[0], std::max(x[1], x[2])) - std::min(x[0], std::min(x[1], x[2]));
  const double ey = std::max(y[0], std::max(y[1], y[2])) - std::min(y[0], std::min(y[1], y[2]));
  int e = 0;
  std::frexp(mag, &e);  // mag = f · 2^e, f in [0.5, 1): 2^e > mag (mag = 0: e = 0, P = 1)
  const double P = std::ldexp(1.0, e);
  return kInterpolationUlps * 0x1p-24 * P + 2 * kBarycentricSlack * std::max(ex, ey) + 1e-9;
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
  r.workUnits = b.work;
  return r;
}

State classifyRegion(const AlphaMask& mask, std::array<float, 2> uv0, std::array<float, 2> uv1,
                     std::array<float, 2> uv2, const std::array<double, 2> b[3]) noexcept {
  Prepared p;
  prepare(mask, uv0, uv1, uv2, p);
  if (!p.usable) return State::UnknownOpaque;
  TriangleClassifier c = makeClassifier(mask, p.margin, 0, Format::FourState, UnknownAs::Majority);
  double X[3], Y[3];
  for (int k = 0; k < 3; ++k) {
    const double u = b[k][0], v = b[k][1], w = 1.0 - u - v;
    X[k] = w * p.X[0] + u * p.X[1] + v * p.X[2] - c.shift;
    Y[k] = w * p.Y[0] + u * p.Y[1] + v * p.Y[2] - c.shift;
  }
  const unsigned r = c.region(X, Y, false);
  return r == kPass ? State::Opaque : r == kFail ? State::Transparent : State::UnknownOpaque;
}

Status validateBakeOptions(const BakeOptions& o) {
  if (o.level > kMaxLevel)
    return makeError(ErrorCode::InvalidArgument,
                     "level " + std::to_string(o.level) + " is out of range (0..12)");
  if (o.maxLevel > kMaxLevel)
    return makeError(ErrorCode::InvalidArgument,
                     "maxLevel " + std::to_string(o.maxLevel) + " is out of range (0..12)");
  if (!(o.texelsPerMicroTri >= 0) || !std::isfinite(o.texelsPerMicroTri))
    return makeError(ErrorCode::InvalidArgument, "texelsPerMicroTri must be a finite number >= 0");
  if (!isValidFormat(uint32_t(o.format)))
    return makeError(ErrorCode::InvalidArgument, "format must be 2-state (1) or 4-state (2)");
  if (o.cutoff && !std::isfinite(*o.cutoff))
    return makeError(ErrorCode::InvalidArgument, "cutoff must be finite");
  if (uint8_t(o.unknownAs) > 2) return makeError(ErrorCode::InvalidArgument, "unknownAs is invalid");
  if (uint8_t(o.blend) > 3) return makeError(ErrorCode::InvalidArgument, "blend is invalid");
  if (uint8_t(o.layout) > 1) return makeError(ErrorCode::InvalidArgument, "layout is invalid");
  return Ok{};
}

Result<SceneBake> bakeScene(const BakeInputs& in, const BakeOptions& o) {
  if (Status s = validateBakeOptions(o); !s) return s.error();
  if ((in.textureCount && !in.textures) || (in.materialCount && !in.materials) ||
      (in.geometryCount && !in.geometries))
    return makeError(ErrorCode::InvalidArgument, "bake inputs: a count without its array");
  std::vector<bool> used(in.materialCount, false);
  for (uint32_t g = 0; g < in.geometryCount; ++g) {
    const GeometryInput& gi = in.geometries[g];
    if (gi.material >= in.materialCount)
      return makeError(ErrorCode::InvalidArgument, geometryName(g, gi) + ": material " +
                                                       std::to_string(gi.material) + " is out of range (" +
                                                       std::to_string(in.materialCount) + " materials)");
    if (gi.triangleCount) used[gi.material] = true;
  }
  struct MaskKey {
    int32_t texture;
    float scale, cutoff;
    Sampler sampler;
  };
  std::vector<MaskKey> keys;
  std::vector<bool> textureChecked(in.textureCount, false);
  CoreInputs ci{in, std::vector<MaterialPlan>(in.materialCount)};
  std::vector<int32_t> keyOf(in.materialCount, -1);
  for (uint32_t m = 0; m < in.materialCount; ++m) {
    const MaterialInput& mi = in.materials[m];
    MaterialPlan& plan = ci.plans[m];
    MaterialAlpha mode = mi.alpha;
    if (uint8_t(mode) > 2)
      return makeError(ErrorCode::InvalidArgument, materialName(m, mi) + ": unknown alpha mode");
    if (mode == MaterialAlpha::Blend && used[m]) {
      switch (o.blend) {
        case BlendAs::Error:
          return makeError(
              ErrorCode::InvalidArgument,
              materialName(m, mi) +
                  " has alpha mode BLEND: say how to bake it (blend as unknown, mask or opaque)");
        case BlendAs::Unknown:
          plan.state = State::UnknownOpaque;
          plan.allUnknown = true;
          continue;
        case BlendAs::Opaque:
          mode = MaterialAlpha::Opaque;
          break;
        case BlendAs::Mask:
          mode = MaterialAlpha::Tested;
          break;
      }
    }
    if (mode != MaterialAlpha::Tested || !used[m]) {
      plan.state = State::Opaque;
      continue;
    }
    const float cutoff = o.cutoff ? *o.cutoff : mi.cutoff;
    if (!std::isfinite(cutoff))
      return makeError(ErrorCode::InvalidArgument, materialName(m, mi) + ": cutoff must be finite");
    if (mi.texture < 0) {
      plan.state = alphaTestPasses(mi.constantAlpha, cutoff) ? State::Opaque : State::Transparent;
      continue;
    }
    if (uint32_t(mi.texture) >= in.textureCount)
      return makeError(ErrorCode::InvalidArgument, materialName(m, mi) + ": texture " +
                                                       std::to_string(mi.texture) + " is out of range (" +
                                                       std::to_string(in.textureCount) + " textures)");
    if (!textureChecked[size_t(mi.texture)]) {
      if (Status s = validateTexture(in.textures[mi.texture]); !s)
        return makeError(s.error().code, materialName(m, mi) + ": " + s.error().message);
      textureChecked[size_t(mi.texture)] = true;
    }
    const MaskKey k{mi.texture, mi.alphaScale, cutoff, effectiveSampler(mi.sampler, o)};
    int32_t id = -1;
    for (size_t i = 0; i < keys.size() && id < 0; ++i)
      if (keys[i].texture == k.texture && bitsOf(keys[i].scale) == bitsOf(k.scale) &&
          bitsOf(keys[i].cutoff) == bitsOf(k.cutoff) && keys[i].sampler == k.sampler)
        id = int32_t(i);
    if (id < 0) {
      id = int32_t(keys.size());
      keys.push_back(k);
    }
    keyOf[m] = id;
  }
  // The masks, built in parallel (each on one thread: deterministic).
  std::vector<AlphaMask> masks(keys.size());
  {
    tbb::task_arena arena(o.threads ? int(o.threads) : tbb::task_arena::automatic);
    arena.execute([&] {
      tbb::parallel_for(size_t(0), keys.size(), [&](size_t i) {
        const MaskKey& k = keys[i];
        masks[i] = AlphaMask(in.textures[k.texture], k.sampler, k.cutoff, k.scale);
      });
    });
  }
  for (uint32_t m = 0; m < in.materialCount; ++m)
    if (keyOf[m] >= 0) {
      ci.plans[m].mask = &masks[size_t(keyOf[m])];
      ci.plans[m].maskId = uint32_t(keyOf[m]);
    }
  auto r = bakeCore(ci, o);
  if (!r) return r;
  r->masks = masks.size();
  for (const AlphaMask& m : masks) r->maskBytes += m.memoryBytes();
  return r;
}

Result<SceneBake> bakeScene(const Scene& scene, const BakeOptions& o) {
  std::vector<TextureView> textures;
  std::vector<const AlphaTexture*> seen;
  std::vector<float> scales;  // by texture: the factor an integer texture's table includes
  std::vector<MaterialInput> materials(scene.materials.size());
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    const Material& sm = scene.materials[m];
    MaterialInput& mi = materials[m];
    mi.name = sm.name.c_str();
    mi.alpha = sm.alphaMode == AlphaMode::Opaque  ? MaterialAlpha::Opaque
               : sm.alphaMode == AlphaMode::Blend ? MaterialAlpha::Blend
                                                  : MaterialAlpha::Tested;
    mi.cutoff = sm.alphaCutoff;
    mi.sampler = sm.sampler;
    mi.constantAlpha = sm.baseColorFactor[3];
    if (sm.alpha && sm.alphaMode != AlphaMode::Opaque) {
      if (Status s = validateAlphaTexture(sm); !s) return s.error();
      const auto it = std::find(seen.begin(), seen.end(), sm.alpha.get());
      if (it != seen.end()) {
        mi.texture = int32_t(it - seen.begin());
      } else {
        mi.texture = int32_t(seen.size());
        seen.push_back(sm.alpha.get());
        // At the texture's own precision (the mask reads 8/16-bit texels through a table: no float copy).
        const AlphaTexture& a = *sm.alpha;
        TextureView v;
        v.data = a.storage == AlphaStorage::UInt8    ? static_cast<const void*>(a.alpha8.data())
                 : a.storage == AlphaStorage::UInt16 ? static_cast<const void*>(a.alpha16.data())
                                                     : static_cast<const void*>(a.alpha.data());
        v.width = a.width;
        v.height = a.height;
        v.format = a.storage == AlphaStorage::UInt8    ? TexelFormat::R8
                   : a.storage == AlphaStorage::UInt16 ? TexelFormat::R16
                                                       : TexelFormat::R32F;
        v.name = sm.alphaSource.c_str();
        textures.push_back(v);
        scales.push_back(a.storage == AlphaStorage::Float32 ? 1.0f : a.scale);
      }
      mi.alphaScale = scales[size_t(mi.texture)];
    }
  }
  std::vector<GeometryInput> geometries;
  for (size_t g = 0; g < scene.geometries.size(); ++g) {
    const Geometry& sg = scene.geometries[g];
    const bool textured = sg.material < scene.materials.size() &&
                          scene.materials[sg.material].alphaMode != AlphaMode::Opaque &&
                          scene.materials[sg.material].alpha;
    if (Status s = validateGeometryLegacy(sg, textured); !s)
      return makeError(s.error().code, "geometry " + std::to_string(g) + " " + s.error().message.substr(9));
    geometries.push_back(viewOf(sg, sg.material));
  }
  return bakeScene(BakeInputs::of(textures, materials, geometries), o);
}

Result<BakedGeometry> bakeGeometry(const Geometry& geometry, const Material& material,
                                   const BakeOptions& options) {
  const bool textured = material.alphaMode != AlphaMode::Opaque && material.alpha;
  if (!textured) return bakeGeometry(geometry, material, nullptr, options);
  if (Status s = validateAlphaTexture(material); !s) return s.error();
  const AlphaMask mask(*material.alpha, effectiveSampler(material.sampler, options),
                       options.cutoff ? *options.cutoff : material.alphaCutoff);
  return bakeGeometry(geometry, material, &mask, options);
}

Result<BakedGeometry> bakeGeometry(const Geometry& geometry, const Material& material, const AlphaMask* mask,
                                   const BakeOptions& options) {
  if (Status s = validateBakeOptions(options); !s) return s.error();
  const bool textured = material.alphaMode != AlphaMode::Opaque && material.alpha;
  if (textured && !mask)
    return makeError(ErrorCode::InvalidArgument, "material '" + material.name + "': no prepared alpha mask");
  if (Status s = validateGeometryLegacy(geometry, textured); !s) return s.error();
  BakeInputs in;
  const GeometryInput gi = viewOf(geometry, 0);
  in.geometries = &gi;
  in.geometryCount = 1;
  CoreInputs ci{in, std::vector<MaterialPlan>(1)};
  MaterialPlan& plan = ci.plans[0];
  if (textured) {
    plan.mask = mask;
  } else if (material.alphaMode != AlphaMode::Opaque) {
    // A constant alpha: one state for every point of every triangle.
    plan.state =
        alphaTestPasses(material.baseColorFactor[3], options.cutoff ? *options.cutoff : material.alphaCutoff)
            ? State::Opaque
            : State::Transparent;
  }
  BakeOptions o = options;
  o.layout = ArrayLayout::SceneWide;
  auto r = bakeCore(ci, o);
  if (!r) {
    std::string msg = r.error().message;
    if (msg.rfind("geometry 0", 0) == 0) msg = "geometry '" + geometry.name + "'" + msg.substr(msg.find(':'));
    return makeError(r.error().code, msg);
  }
  BakedGeometry out;
  out.array = std::move(r->micromaps.arrays[0]);
  out.stats = r->geometries[0].stats;
  out.levels = std::move(r->geometries[0].levels);
  return out;
}

Result<BakeEstimate> estimateBake(const Geometry& geometry, const Material& material,
                                  const BakeOptions& options) {
  if (Status s = validateBakeOptions(options); !s) return s.error();
  const bool textured = material.alphaMode != AlphaMode::Opaque && material.alpha;
  if (textured) {
    if (Status s = validateAlphaTexture(material); !s) return s.error();
  }
  if (Status s = validateGeometryLegacy(geometry, textured); !s) return s.error();
  BakeEstimate e;
  const uint32_t n = geometry.triangleCount();
  e.triangles = n;
  if (!textured) {
    e.microTriangles = n;
    return e;
  }
  const size_t vertices = geometry.uvs.size() / 2;
  for (uint32_t i : geometry.indices)
    if (i >= vertices)
      return makeError(ErrorCode::InvalidArgument, "geometry '" + geometry.name + "': index " +
                                                       std::to_string(i) + " out of range (" +
                                                       std::to_string(vertices) + " vertices with UVs)");
  const AlphaTexture& tex = *material.alpha;
  auto uvOf = [&](uint32_t v) {
    return std::array<float, 2>{geometry.uvs[2 * size_t(v)], geometry.uvs[2 * size_t(v) + 1]};
  };
  for (uint32_t t = 0; t < n; ++t) {
    const auto a = uvOf(geometry.indices[3 * t]), b = uvOf(geometry.indices[3 * t + 1]),
               c = uvOf(geometry.indices[3 * t + 2]);
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
