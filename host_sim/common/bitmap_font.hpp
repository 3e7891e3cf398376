// A 5x7 pixel font for labels in raster pictures (legends, scale bars, titles) written without a
// text-rendering library: the simulator's top view must stay readable on machines that have no
// fonts or plotting stack. Upper case, digits and the punctuation labels need; lower-case letters
// are drawn as capitals, other characters as '?'.
#pragma once

#include <array>
#include <cstdint>

namespace v2xloc::sim {

inline constexpr int kGlyphWidth = 5;
inline constexpr int kGlyphHeight = 7;

// Row r (0 = top) of a glyph: bit (kGlyphWidth - 1 - c) set = pixel in column c is ink.
using GlyphRows = std::array<std::uint8_t, kGlyphHeight>;

const GlyphRows& glyph(char c);

}  // namespace v2xloc::sim
