// SPDX-License-Identifier: MIT
// somm — the one colour table of every picture that shows micromap states (`somm view`, `somm render --method
// state-overlay`, their legends). C++17.
#pragma once

#include <cstdint>

#include "somm/micromap.h"

namespace somm {

// RGB by State value: Transparent 0, Opaque 1, UnknownTransparent 2, UnknownOpaque 3.
inline constexpr uint8_t kStateColours[4][3] = {
    {40, 90, 250},  // transparent: blue
    {40, 200, 60},  // opaque: green
    {230, 40, 40},  // unknown-transparent: red
    {255, 165, 0},  // unknown-opaque: orange
};
// Geometry that is not alpha-tested (state-overlay).
inline constexpr uint8_t kNotAlphaTestedColour[3] = {140, 140, 150};

inline const uint8_t* stateColour(State s) noexcept {
  return kStateColours[uint8_t(s) & 3u];
}

// Legend labels, in the order the legends list them.
inline constexpr State kLegendOrder[4] = {State::Opaque, State::UnknownOpaque, State::UnknownTransparent,
                                          State::Transparent};
inline const char* stateLabel(State s) noexcept {
  switch (s) {
    case State::Transparent:
      return "transparent";
    case State::Opaque:
      return "opaque";
    case State::UnknownTransparent:
      return "unknown-transparent";
    case State::UnknownOpaque:
      return "unknown-opaque";
  }
  return "?";
}

}  // namespace somm
