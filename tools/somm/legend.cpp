// SPDX-License-Identifier: MIT
// somm CLI — the state legend: a 5×7 bitmap font for the few letters the labels need.
#include "legend.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "somm/state_colours.h"

namespace somm::cli {
namespace {

struct Glyph {
  char c;
  const char* rows[7];
};

// Lower-case letters of the labels and '-'; '#' = ink.
constexpr Glyph kFont[] = {
    {'a', {".....", ".....", ".###.", "....#", ".####", "#...#", ".####"}},
    {'d', {"....#", "....#", ".####", "#...#", "#...#", "#...#", ".####"}},
    {'e', {".....", ".....", ".###.", "#...#", "#####", "#....", ".###."}},
    {'h', {"#....", "#....", "####.", "#...#", "#...#", "#...#", "#...#"}},
    {'i', {"..#..", ".....", ".##..", "..#..", "..#..", "..#..", ".###."}},
    {'k', {"#....", "#....", "#..#.", "#.#..", "##...", "#.#..", "#..#."}},
    {'l', {".##..", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."}},
    {'n', {".....", ".....", "####.", "#...#", "#...#", "#...#", "#...#"}},
    {'o', {".....", ".....", ".###.", "#...#", "#...#", "#...#", ".###."}},
    {'p', {".....", "####.", "#...#", "#...#", "####.", "#....", "#...."}},
    {'q', {".....", ".####", "#...#", "#...#", ".####", "....#", "....#"}},
    {'r', {".....", ".....", "#.##.", "##..#", "#....", "#....", "#...."}},
    {'s', {".....", ".....", ".####", "#....", ".###.", "....#", "####."}},
    {'t', {".#...", ".#...", "####.", ".#...", ".#...", ".#..#", "..##."}},
    {'u', {".....", ".....", "#...#", "#...#", "#...#", "#..##", ".##.#"}},
    {'w', {".....", ".....", "#...#", "#...#", "#.#.#", "#.#.#", ".#.#."}},
    {'-', {".....", ".....", ".....", "#####", ".....", ".....", "....."}},
};

const Glyph* glyph(char c) {
  for (const Glyph& g : kFont)
    if (g.c == c) return &g;
  return nullptr;  // space and anything else: blank
}

struct Canvas {
  uint8_t* px;
  uint32_t w, h, channels;
  void fill(int x0, int y0, int x1, int y1, const uint8_t* rgb) const {
    for (int y = std::max(0, y0); y < std::min(int(h), y1); ++y)
      for (int x = std::max(0, x0); x < std::min(int(w), x1); ++x) {
        uint8_t* p = px + (size_t(y) * w + size_t(x)) * channels;
        p[0] = rgb[0];
        p[1] = rgb[1];
        p[2] = rgb[2];
        if (channels == 4) p[3] = 255;
      }
  }
};

}  // namespace

void drawStateLegend(uint8_t* pixels, uint32_t width, uint32_t height, uint32_t channels,
                     bool notAlphaTested) {
  const Canvas c{pixels, width, height, channels};
  const int s = width >= 480 ? 2 : 1;    // pixel scale
  const int line = 10 * s, pad = 3 * s;  // line height, panel padding
  std::vector<std::pair<const uint8_t*, std::string>> rows;
  for (State st : kLegendOrder) rows.emplace_back(stateColour(st), stateLabel(st));
  if (notAlphaTested) rows.emplace_back(kNotAlphaTestedColour, "not alpha-tested");
  size_t longest = 0;
  for (const auto& r : rows) longest = std::max(longest, r.second.size());
  const uint8_t white[3] = {255, 255, 255}, black[3] = {20, 20, 20};
  const int panelW = pad * 2 + 9 * s + int(longest) * 6 * s,
            panelH = pad * 2 + int(rows.size()) * line - 3 * s;
  c.fill(0, 0, panelW, panelH, white);
  for (size_t i = 0; i < rows.size(); ++i) {
    const int y0 = pad + int(i) * line;
    c.fill(pad, y0, pad + 7 * s, y0 + 7 * s, rows[i].first);
    int x = pad + 9 * s;
    for (char ch : rows[i].second) {
      if (const Glyph* g = glyph(ch))
        for (int gy = 0; gy < 7; ++gy)
          for (int gx = 0; gx < 5; ++gx)
            if (g->rows[gy][gx] == '#')
              c.fill(x + gx * s, y0 + gy * s, x + (gx + 1) * s, y0 + (gy + 1) * s, black);
      x += 6 * s;
    }
  }
}

}  // namespace somm::cli
