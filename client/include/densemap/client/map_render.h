// PNG pictures of a map, as in the dissertation's figures: a top-down view of the occupied cells coloured
// by height, and a probability slice at one height (unknown cells grey).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "densemap/util/image.h"

namespace densemap::client {

using util::colormap;
using util::Image;
using util::sideBySide;
using util::writePng;

/// The area a picture covers: x to the right, y up, `pixel` metres per pixel.
struct RenderArea {
  float x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  float pixel = 0.2f;
  int width() const { return std::max(1, static_cast<int>((x1 - x0) / pixel + 0.5f)); }
  int height() const { return std::max(1, static_cast<int>((y1 - y0) / pixel + 0.5f)); }
};

/// Top-down view: per pixel the highest occupied cell, coloured from z_min (blue) to z_max (red).
Image renderTopDown(const std::vector<float>& cells_xyz, const RenderArea& area, float z_min, float z_max);
/// Probability slice: one value per pixel (row-major, top row first), 0..1, states 0 = unknown (grey).
Image renderSlice(const std::vector<float>& probabilities, const std::vector<std::uint8_t>& states, int width,
                  int height);

}  // namespace densemap::client
