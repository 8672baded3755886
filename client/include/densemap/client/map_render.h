// PNG pictures of a map, as in the dissertation's figures: a top-down view of the occupied cells coloured
// by height, and a probability slice at one height (unknown cells grey). Written with libpng.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace densemap::client {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  ///< row-major, top row first
  Image(int w, int h, std::uint8_t grey = 255)
      : width(w), height(h), rgb(static_cast<std::size_t>(w * h * 3), grey) {}
  void set(int x, int y, const std::uint8_t c[3]);
};

/// The area a picture covers: x to the right, y up, `pixel` metres per pixel.
struct RenderArea {
  float x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  float pixel = 0.2f;
  int width() const { return std::max(1, static_cast<int>((x1 - x0) / pixel + 0.5f)); }
  int height() const { return std::max(1, static_cast<int>((y1 - y0) / pixel + 0.5f)); }
};

/// Colour for t in [0, 1] on a perceptual blue-green-yellow-red scale.
void colormap(float t, std::uint8_t out[3]);

/// Top-down view: per pixel the highest occupied cell, coloured from z_min (blue) to z_max (red).
Image renderTopDown(const std::vector<float>& cells_xyz, const RenderArea& area, float z_min, float z_max);
/// Probability slice: one value per pixel (row-major, top row first), 0..1, states 0 = unknown (grey).
Image renderSlice(const std::vector<float>& probabilities, const std::vector<std::uint8_t>& states, int width,
                  int height);
/// Two pictures next to each other on a white background.
Image sideBySide(const Image& a, const Image& b, int gap = 8);

/// Throws std::runtime_error naming the file when it cannot be written.
void writePng(const std::string& path, const Image& image);

}  // namespace densemap::client
