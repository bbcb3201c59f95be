// SPDX-License-Identifier: MIT
#include "somm/micromap.h"

#include <algorithm>

#include "somm/result.h"

namespace somm {

const char* errorCodeName(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::InvalidArgument:
      return "invalid argument";
    case ErrorCode::ParseError:
      return "parse error";
    case ErrorCode::IoError:
      return "I/O error";
    case ErrorCode::CorruptFile:
      return "corrupt file";
    case ErrorCode::UnsupportedFormat:
      return "unsupported format";
    case ErrorCode::LimitExceeded:
      return "limit exceeded";
    case ErrorCode::Cancelled:
      return "cancelled";
  }
  return "error";
}

namespace {
uint8_t fillByte(Format f, State s) {
  if (f == Format::TwoState) return (uint8_t(s) & 1u) ? 0xffu : 0x00u;
  const uint8_t v = uint8_t(s) & 3u;
  return uint8_t(v | (v << 2) | (v << 4) | (v << 6));
}
}  // namespace

Micromap::Micromap(uint32_t level, Format format, State fill)
    : level_(level), format_(format), bytes_(micromapDataBytes(level, format), 0) {
  std::fill(bytes_.begin(), bytes_.end(), fillByte(format, fill));
  // Keep unused bits of a partial byte zero, so that equal maps have equal bytes.
  const uint64_t bits = uint64_t(size()) * bitsPerState(format);
  if (bits % 8 != 0) bytes_.back() &= uint8_t((1u << (bits % 8)) - 1u);
}

std::optional<State> Micromap::uniformState() const noexcept {
  const State first = get(0);
  const uint64_t bits = uint64_t(size()) * bitsPerState(format_);
  if (bits < 8) {
    for (uint32_t i = 1; i < size(); ++i)
      if (get(i) != first) return std::nullopt;
    return first;
  }
  const uint8_t want = fillByte(format_, first);
  for (uint8_t b : bytes_)
    if (b != want) return std::nullopt;
  return first;
}

// ---- vertex orders ----
// The 6 orders, numbered; 0 is the identity. A triangle's children in bird-curve order, with their own vertex orders,
// from its vertices (a, b, c) (the rule of docs/bird.md that the baker follows too):
// (a, ab, ac), (ac, bc, ab), (ab, b, bc), (bc, ac, c). For T' = T listed in order p, child c' of T' is a child c of T
// (the same three points) listed in some order q: the tables below find (c, q) once, from that rule on symbolic
// points, for every p and c'.
namespace {
constexpr uint8_t kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

struct ChildStep {
  uint8_t child;  // the other triangle's child
  uint8_t order;  // that child's vertex order
};
struct OrderTables {
  ChildStep fwd[6][4];    // fwd[p][c']: child c' of T' (T in order p) is child .child of T, in order .order
  ChildStep inv[6][4];    // inv[p][c]: child c of T is child .child of T', in order .order
  uint8_t quad4[6][256];  // 4-state: the 4 states of a node's children (one byte), as T' lists them
  uint8_t quad2[6][16];   // 2-state: the same for a nibble
};

constexpr int orderId(const uint8_t o[3]) {
  for (int p = 0; p < 6; ++p)
    if (kOrders[p][0] == o[0] && kOrders[p][1] == o[1] && kOrders[p][2] == o[2]) return p;
  return -1;
}

constexpr OrderTables makeOrderTables() {
  OrderTables t{};
  // Points as barycentric weights × 2 (midpoints stay integral).
  struct P {
    int w[3];
  };
  auto same = [](P a, P b) { return a.w[0] == b.w[0] && a.w[1] == b.w[1] && a.w[2] == b.w[2]; };
  auto children = [](const P v[3], P out[4][3]) {
    auto mid = [](P a, P b) {
      return P{{(a.w[0] + b.w[0]) / 2, (a.w[1] + b.w[1]) / 2, (a.w[2] + b.w[2]) / 2}};
    };
    const P a = v[0], b = v[1], c = v[2], ab = mid(a, b), ac = mid(a, c), bc = mid(b, c);
    const P ch[4][3] = {{a, ab, ac}, {ac, bc, ab}, {ab, b, bc}, {bc, ac, c}};
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) out[i][k] = ch[i][k];
  };
  const P e[3] = {P{{2, 0, 0}}, P{{0, 2, 0}}, P{{0, 0, 2}}};
  P ech[4][3] = {};
  children(e, ech);
  for (int p = 0; p < 6; ++p) {
    const P tv[3] = {e[kOrders[p][0]], e[kOrders[p][1]], e[kOrders[p][2]]};
    P tch[4][3] = {};
    children(tv, tch);
    for (int cp = 0; cp < 4; ++cp)
      for (int c = 0; c < 4; ++c) {
        uint8_t o[3] = {3, 3, 3};
        for (int k = 0; k < 3; ++k)
          for (int j = 0; j < 3; ++j)
            if (same(tch[cp][k], ech[c][j])) o[k] = uint8_t(j);
        const int q = orderId(o);
        if (q < 0) continue;
        t.fwd[p][cp] = ChildStep{uint8_t(c), uint8_t(q)};
        t.inv[p][c] = ChildStep{uint8_t(cp), uint8_t(q)};
      }
    for (int v = 0; v < 256; ++v) {
      int r = 0;
      for (int cp = 0; cp < 4; ++cp) r |= ((v >> (2 * t.fwd[p][cp].child)) & 3) << (2 * cp);
      t.quad4[p][v] = uint8_t(r);
    }
    for (int v = 0; v < 16; ++v) {
      int r = 0;
      for (int cp = 0; cp < 4; ++cp) r |= ((v >> t.fwd[p][cp].child) & 1) << cp;
      t.quad2[p][v] = uint8_t(r);
    }
  }
  return t;
}
constexpr OrderTables kOrderTables = makeOrderTables();

// Node `src` of T at depth level − 1 − left, listed in order p, is node `dst` of T': its 4^(left + 1) states.
void reorderNode(const uint8_t* in, uint8_t* out, Format f, uint32_t left, int p, uint32_t src,
                 uint32_t dst) {
  if (left == 0) {
    if (f == Format::FourState) {
      out[dst] = kOrderTables.quad4[p][in[src]];
    } else {
      const uint32_t v = (in[src >> 1] >> (4 * (src & 1))) & 15u;
      out[dst >> 1] = uint8_t(out[dst >> 1] | (kOrderTables.quad2[p][v] << (4 * (dst & 1))));
    }
    return;
  }
  for (uint32_t cp = 0; cp < 4; ++cp) {
    const ChildStep s = kOrderTables.fwd[p][cp];
    reorderNode(in, out, f, left - 1, s.order, src * 4 + s.child, dst * 4 + cp);
  }
}
}  // namespace

bool isVertexOrder(const VertexOrder& order) noexcept {
  return orderId(order.data()) >= 0;
}

void reorderVertices(const Micromap& map, const VertexOrder& order, Micromap& out) {
  const int p = orderId(order.data());
  if (out.level() != map.level() || out.format() != map.format() || out.bytes().size() != map.bytes().size())
    out = Micromap(map.level(), map.format());
  if (p <= 0 || map.level() == 0) {
    std::copy(map.bytes().begin(), map.bytes().end(), out.bytes().begin());
    return;
  }
  std::fill(out.bytes().begin(), out.bytes().end(), uint8_t(0));
  reorderNode(map.bytes().data(), out.bytes().data(), map.format(), map.level() - 1, p, 0, 0);
}

uint32_t reorderedNode(uint32_t prefix, uint32_t depth, const VertexOrder& order,
                       VertexOrder* nodeOrder) noexcept {
  int p = std::max(orderId(order.data()), 0);
  uint32_t r = 0;
  for (uint32_t d = depth; d-- > 0;) {
    const ChildStep s = kOrderTables.inv[p][(prefix >> (2 * d)) & 3u];
    r = r * 4 + s.child;
    p = s.order;
  }
  if (nodeOrder) *nodeOrder = {kOrders[p][0], kOrders[p][1], kOrders[p][2]};
  return r;
}

Micromap Micromap::toTwoStateMap() const {
  if (format_ == Format::TwoState) return *this;
  Micromap r(level_, Format::TwoState);
  for (uint32_t i = 0; i < size(); ++i) r.set(i, toTwoState(get(i)));
  return r;
}

}  // namespace somm
