#include "densemap/client/map_render.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

namespace densemap::client {

Image renderTopDown(const std::vector<float>& xyz, const RenderArea& area, float z_min, float z_max) {
  Image img(area.width(), area.height());
  std::vector<float> top(static_cast<std::size_t>(img.width * img.height), -INFINITY);
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) {
    const int x = static_cast<int>((xyz[i] - area.x0) / area.pixel);
    const int y = img.height - 1 - static_cast<int>((xyz[i + 1] - area.y0) / area.pixel);
    if (x < 0 || y < 0 || x >= img.width || y >= img.height) continue;
    float& t = top[static_cast<std::size_t>(y * img.width + x)];
    t = std::max(t, xyz[i + 2]);
  }
  const float span = std::max(1e-3f, z_max - z_min);
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      const float z = top[static_cast<std::size_t>(y * img.width + x)];
      if (!std::isfinite(z)) continue;
      std::uint8_t c[3];
      colormap((z - z_min) / span, c);
      img.set(x, y, c);
    }
  }
  return img;
}

Image renderSlice(const std::vector<float>& probabilities, const std::vector<std::uint8_t>& states, int width,
                  int height) {
  Image img(width, height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y * width + x);
      std::uint8_t c[3] = {150, 150, 150};  // unknown
      if (i < states.size() && states[i] != 0) colormap(probabilities[i], c);
      img.set(x, y, c);
    }
  }
  return img;
}

}  // namespace densemap::client
