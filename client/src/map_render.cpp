#include "densemap/client/map_render.h"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

namespace densemap::client {

void Image::set(int x, int y, const std::uint8_t c[3]) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  std::uint8_t* p = &rgb[static_cast<std::size_t>((y * width + x) * 3)];
  p[0] = c[0];
  p[1] = c[1];
  p[2] = c[2];
}

void colormap(float t, std::uint8_t out[3]) {
  // Piecewise-linear through blue, cyan, green, yellow, red.
  static constexpr float stops[5][3] = {{0.15f, 0.2f, 0.8f},
                                        {0.1f, 0.75f, 0.9f},
                                        {0.2f, 0.8f, 0.3f},
                                        {0.95f, 0.85f, 0.1f},
                                        {0.85f, 0.1f, 0.1f}};
  t = std::clamp(std::isfinite(t) ? t : 0.0f, 0.0f, 1.0f) * 4.0f;
  const int i = std::min(3, static_cast<int>(t));
  const float f = t - static_cast<float>(i);
  for (int c = 0; c < 3; ++c) {
    out[c] = static_cast<std::uint8_t>(255.0f * (stops[i][c] * (1 - f) + stops[i + 1][c] * f));
  }
}

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

Image sideBySide(const Image& a, const Image& b, int gap) {
  Image out(a.width + gap + b.width, std::max(a.height, b.height));
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) out.set(x, y, &a.rgb[static_cast<std::size_t>((y * a.width + x) * 3)]);
  for (int y = 0; y < b.height; ++y)
    for (int x = 0; x < b.width; ++x)
      out.set(a.width + gap + x, y, &b.rgb[static_cast<std::size_t>((y * b.width + x) * 3)]);
  return out;
}

void writePng(const std::string& path, const Image& image) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!file) throw std::runtime_error("cannot open '" + path + "' for writing");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  if (png == nullptr || info == nullptr) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("libpng could not start writing '" + path + "'");
  }
  // libpng reports errors by longjmp; nothing with a destructor is created between here and the end.
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("libpng failed while writing '" + path + "'");
  }
  png_init_io(png, file.get());
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width), static_cast<png_uint_32>(image.height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) {
    png_write_row(png, const_cast<png_bytep>(&image.rgb[static_cast<std::size_t>(y * image.width * 3)]));
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
}

}  // namespace densemap::client
