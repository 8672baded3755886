// A small RGB image, colour maps and PNG output (libpng), shared by the query client's map pictures and the
// evaluation's ROC plots.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace densemap::util {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  ///< row-major, top row first
  Image(int w, int h, std::uint8_t grey = 255)
      : width(w), height(h), rgb(static_cast<std::size_t>(w * h * 3), grey) {}
  /// Sets a pixel; coordinates outside the image are ignored.
  void set(int x, int y, const std::uint8_t c[3]);
  /// A line from (x0, y0) to (x1, y1), `thickness` pixels wide.
  void line(int x0, int y0, int x1, int y1, const std::uint8_t c[3], int thickness = 1);
};

/// Colour for t in [0, 1] on a perceptual blue-green-yellow-red scale.
void colormap(float t, std::uint8_t out[3]);

/// Two pictures next to each other on a white background.
Image sideBySide(const Image& a, const Image& b, int gap = 8);

/// Throws std::runtime_error naming the file when it cannot be written.
void writePng(const std::string& path, const Image& image);

}  // namespace densemap::util
