// SPDX-License-Identifier: MIT
// somm CLI — the state legend drawn into every picture (somm view, somm render --method state-overlay).
#pragma once

#include <cstdint>

namespace somm::cli {

// Draws the legend of somm/state_colours.h (a swatch and a label per state, plus "not alpha-tested" when
// `notAlphaTested`) into the top-left corner of an 8-bit RGB (channels 3) or RGBA (4) image, row 0 at the top, on a
// white panel.
// Scaled ×2 on images at least 480 pixels wide; clipped to the image.
void drawStateLegend(uint8_t* pixels, uint32_t width, uint32_t height, uint32_t channels,
                     bool notAlphaTested);

}  // namespace somm::cli
