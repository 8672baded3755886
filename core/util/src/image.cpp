#include "densemap/util/image.h"

#include <png.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>

namespace densemap::util {

void Image::set(int x, int y, const std::uint8_t c[3]) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  std::uint8_t* p = &rgb[static_cast<std::size_t>((y * width + x) * 3)];
  p[0] = c[0];
  p[1] = c[1];
  p[2] = c[2];
}

void Image::line(int x0, int y0, int x1, int y1, const std::uint8_t c[3], int thickness) {
  const int steps = std::max({std::abs(x1 - x0), std::abs(y1 - y0), 1});
  for (int s = 0; s <= steps; ++s) {
    const int x = x0 + (x1 - x0) * s / steps, y = y0 + (y1 - y0) * s / steps;
    for (int dx = -(thickness / 2); dx <= thickness / 2; ++dx)
      for (int dy = -(thickness / 2); dy <= thickness / 2; ++dy) set(x + dx, y + dy, c);
  }
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

}  // namespace densemap::util
